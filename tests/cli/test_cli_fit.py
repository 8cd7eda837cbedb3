"""``viscoforce fit`` and ``bode`` (issue 13 items 4, 6, 7): contract keys, real data, bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from viscoforce import PAPER
from viscoforce.cli import main
from viscoforce.schema import make_spectrum
from viscoforce.svda import svda_complex_stiffness

#: The paper's Fig. 3 scene (2 nm) is deliberately evaluated with the SVDA, which warns there
#: (estimated error > 1 %, issue 15); the warning itself is tested in tests/theory/test_failure_regions.py.
pytestmark = pytest.mark.filterwarnings(
    "ignore:the SVDA is about:viscoforce.exceptions.ModelValidityWarning")


REAL = Path(__file__).resolve().parents[3] / "shared" / "data" / "real"
SR_CURVE = REAL / "afmformats" / "fmt-jpk-sr_cell1-0008.jpk-force"
SR_ZIP = REAL / "afmformats" / "10.1002_btm2.10294_fig5d-cell1.zip"
MOD_MAP = REAL / "PyFMReader" / "map-data-2021.11.05-17.37.44.432.jpk-force-map"
OMEGA = np.geomspace(10.0, 1e6, 30)


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def spectrum_file(tmp_path):
    k = svda_complex_stiffness(OMEGA, 2e-9, PAPER.E0, PAPER.E_inf, PAPER.tau, PAPER.R, PAPER.P,
                               PAPER.debye_length)
    path = tmp_path / "spectrum.nc"
    make_spectrum(OMEGA, k, np.full(30, 6e-8), 1e-10,
                  stderr={"stiffness": 0.01 * np.abs(k), "phase": np.full(30, 0.5)}).to_netcdf(
        path)
    return path


def test_fit_json_has_the_contract_keys(capsys, spectrum_file, tmp_path):
    out_nc, plot = tmp_path / "fits.nc", tmp_path / "fit.png"
    code, out, err = _run(capsys, "fit", spectrum_file, "--model", "svda", "--h0=2nm", "--json",
                          "--out", out_nc, "--plot", plot)
    assert code == 0, err
    info = json.loads(out)
    assert {"model", "modes", "params", "correlations", "redchi", "aic", "bic",
            "success"} <= set(info)
    assert set(info["params"]) == {"tau", "E0", "E_inf"}
    assert info["params"]["tau"]["value"] == pytest.approx(PAPER.tau, rel=1e-6)
    assert out_nc.is_file() and plot.stat().st_size > 0


def test_fit_modes_auto_reports_the_selection(capsys, spectrum_file):
    code, out, err = _run(capsys, "fit", spectrum_file, "--model", "prony", "--modes", "auto",
                          "--json")
    assert code == 0, err
    info = json.loads(out)
    assert [row["modes"] for row in info["selection"]][:2] == [1, 2]
    assert {"modes", "aic", "bic"} == set(info["selection"][0])


def test_bode_with_a_fit_writes_the_figure(capsys, spectrum_file, tmp_path):
    png = tmp_path / "bode.png"
    code, _, err = _run(capsys, "bode", spectrum_file, "--model", "svda", "--h0", "2nm",
                        "--out", png)
    assert code == 0, err
    assert png.stat().st_size > 0


@pytest.mark.parametrize("argv, match", [
    (["--model", "svda"], "--h0"),
    (["--model", "svda", "--h0", "2nm", "--modes", "0"], "modes"),
    (["--model", "svda", "--h0", "2nm", "--modes", "-1"], "modes"),
    (["--model", "svda", "--h0", "2nm", "--modes", "two"], "modes"),
    (["--model", "svda", "--h0", "2nm", "--modes", "auto"], "several modes"),
    (["--model", "relaxation"], "does not fit spectrum"),
    (["--model", "svda", "--h0", "2nm", "--out", "/no/such/dir/f.nc"], "does not exist"),
    (["--model", "svda", "--h0=-5nm"], "pre-contact"),
])
def test_bad_fit_input_exits_2_with_one_message(capsys, spectrum_file, argv, match):
    code, out, err = _run(capsys, "fit", spectrum_file, *argv)
    assert code == 2
    assert match in err and "Traceback" not in err


def test_unreachable_scheduler_exits_2(capsys, tmp_path, monkeypatch):
    # nothing listens on port 9: the connection is refused at once and retried until
    # fitting.maps.CONNECT_TIMEOUT (10 s) runs out; a short wait gives the same error
    monkeypatch.setattr("viscoforce.fitting.maps.CONNECT_TIMEOUT", 0.5)
    k = svda_complex_stiffness(OMEGA, 2e-9, PAPER.E0, PAPER.E_inf, PAPER.tau, PAPER.R, PAPER.P,
                               PAPER.debye_length)
    path = tmp_path / "map.nc"
    make_spectrum(OMEGA, np.stack([k, k]), np.full((2, 30), 6e-8), 1e-10,
                  dims=("curve", "omega")).to_netcdf(path)
    code, _, err = _run(capsys, "fit", path, "--model", "svda", "--h0", "2nm", "--scheduler",
                        "tcp://127.0.0.1:9", "--out", tmp_path / "fits.nc")
    assert code == 2 and "cannot reach the dask scheduler" in err
    assert not (tmp_path / "fits.nc").exists()


# ── real data (skip cleanly without ../shared/data/real) ────────────────────────────────────────

@pytest.mark.skipif(not SR_CURVE.is_file(), reason="real data not present")
def test_real_stress_relaxation_with_modes_auto(capsys):
    code, out, err = _run(capsys, "fit", SR_CURVE, "--model", "relaxation", "--modes", "auto",
                          "--json")
    assert code == 0, err
    info = json.loads(out)
    # BIC alone ran this hold to the 4-mode cap (issue 37); the modes beyond the first move by
    # 10-18 stderr between the block halves of the hold: not robust, said, never kept
    assert info["success"] and 1 <= info["modes"] < 4
    assert "not robust" in info["explanation"]
    names = ["tau"] if "tau" in info["params"] else [f"tau_{i}"
                                                     for i in range(1, info["modes"] + 1)]
    taus = [info["params"][n]["value"] for n in names]
    assert taus == sorted(taus) and 0.01 < taus[0] and taus[-1] < 300  # 30 s hold
    assert len(info["selection"]) > info["modes"]  # the candidate not kept is listed


@pytest.mark.skipif(not SR_ZIP.is_file(), reason="real data not present")
def test_real_zip_of_curves_is_fitted_per_curve(capsys, tmp_path):
    out_nc = tmp_path / "fits.nc"
    code, out, err = _run(capsys, "fit", SR_ZIP, "--model", "relaxation", "--json",
                          "--out", out_nc, "--scheduler", "synchronous")
    assert code == 0, err
    info = json.loads(out)
    assert info["n_fits"] == 15 and info["n_fits"] - info["n_failed"] >= 12
    assert {"median", "q25", "q75"} == set(info["params"]["tau_1"])
    import xarray as xr

    with xr.open_dataset(out_nc) as ds:
        assert ds["tau_1"].dims == ("curve",) and {"success", "redchi", "bic"} <= set(ds)


@pytest.mark.skipif(not MOD_MAP.is_file(), reason="real data not present")
def test_real_modulation_map_contact_fit(capsys, tmp_path):
    # the sensor's phase (the default, the fitted sensor delay, determines E0 here: 10.6 +- 1.8 kPa)
    code, out, err = _run(capsys, "fit", MOD_MAP, "--model", "contact", "--R", "10um", "--curve", "3",
                          "--phase-reference", "sensor", "--json", "--plot", tmp_path / "fit.png")
    assert code == 0, err
    info = json.loads(out)
    e_inf = info["params"]["E_inf"]
    assert 50 < e_inf["value"] < 5e3 and e_inf["stderr"] < e_inf["value"]  # R = 10 µm assumed
    e0 = info["params"]["E0"]  # not identified: the glassy plateau lies beyond 100 Hz
    assert not (e0["stderr"] < e0["value"]) or "E0" in info["at_bound"]


def test_fit_and_bode_read_a_spectrum_csv(capsys, tmp_path):
    k = 10.0 + 20.0 * 1j * OMEGA * 1e-3 / (1 + 1j * OMEGA * 1e-3)
    path = tmp_path / "spectrum.csv"
    rows = ["frequency (Hz),stiffness (N/m),phase (deg)"]
    rows += [f"{w / (2 * np.pi):.10g},{abs(x):.10g},{np.degrees(np.angle(x)):.10g}"
             for w, x in zip(OMEGA, k, strict=True)]
    path.write_text("\n".join(rows) + "\n")
    code, out, err = _run(capsys, "fit", path, "--model", "prony", "--json")
    assert code == 0, err
    info = json.loads(out)
    assert info["params"]["tau_1"]["value"] == pytest.approx(1e-3, rel=1e-6)
    code, _, err = _run(capsys, "bode", path, "--model", "prony", "--out", tmp_path / "b.png")
    assert code == 0, err
