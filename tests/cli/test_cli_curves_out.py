"""``fit --curves-out FILE.csv``: the data, best fit and residual of every fitted point (issue 38
item 7), checked against the fit result it came from; refused up front where there are none."""

from __future__ import annotations

import io
import json

import numpy as np
import pandas as pd
import pytest

from viscoforce.cli import main


def _table(path) -> pd.DataFrame:
    text = "".join(line for line in path.read_text().splitlines(keepends=True)
                   if not line.startswith("#"))
    return pd.read_csv(io.StringIO(text))


def test_a_spectrums_curves_are_its_data_fit_and_residual(tmp_path, capsys):
    out, nc = tmp_path / "curves.csv", tmp_path / "fit.nc"
    assert main(["fit", "example:sls_spectrum.csv", "--model", "exact", "--h0=-5nm",
                 "--budget", "calibration", "--curves-out", str(out), "--out", str(nc),
                 "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["curves_out"]["rows"] == 25 and info["curves_out"]["path"] == str(out)
    table = _table(out)
    import xarray as xr

    with xr.open_dataset(nc) as fit:  # the result's best fit on its fine grid, at the data
        dim = fit["fit_stiffness"].dims[0]
        fine = np.interp(np.log(table["omega (rad/s)"]), np.log(fit[dim].values),
                         fit["fit_stiffness"].values)
    np.testing.assert_allclose(table["fit_stiffness (N/m)"], fine, rtol=2e-3)
    np.testing.assert_allclose(table["residual_stiffness (N/m)"],
                               table["stiffness (N/m)"] - table["fit_stiffness (N/m)"],
                               rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize(("data", "out", "match"), [
    (["example:sls_spectrum.csv"], "x.txt", "must end in .csv"),
    (["example:sls_spectrum.csv", "example:sls_spectrum.csv"], "c.csv", "give one file"),
])
def test_curves_out_is_refused_before_any_fit(tmp_path, capsys, monkeypatch, data, out, match):
    monkeypatch.chdir(tmp_path)
    assert main(["fit", *data, "--model", "exact", "--h0=-5nm", "--curves-out", out]) == 2
    assert match in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
