"""A fitted map carries each pixel's best-fit spectrum (what ``viscoforce view`` draws)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from viscoforce.exceptions import ParameterError
from viscoforce.fitting.maps import fit_map
from viscoforce.fitting.models import make_model
from viscoforce.schema import make_spectrum

OMEGA = np.geomspace(10.0, 1e4, 8)
TAU = np.array([[1e-3, 2e-3], [3e-3, 4e-3]])


@pytest.fixture(scope="module")
def spectra():
    k = 1.0 + 2.0 * 1j * OMEGA * TAU[..., None] / (1 + 1j * OMEGA * TAU[..., None])
    rng = np.random.default_rng(3)
    noisy = k * (1 + 0.01 * rng.standard_normal(k.shape))
    quality = np.zeros(k.shape, dtype=np.int8)
    quality[0, 1, -1] = 1  # a flagged point: the curve still covers it
    return make_spectrum(OMEGA, noisy, 1e-9, 1e-10, dims=("y", "x", "omega"), quality=quality,
                         coords={"x": ("x", [0.0, 2e-6]), "y": ("y", [0.0, 2e-6])},
                         stderr={"stiffness": 0.01 * np.abs(k), "phase": np.full(k.shape, 0.5)})


def test_each_pixel_has_its_model_at_the_data_frequencies(spectra):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fits = fit_map(spectra, "prony", scheduler="synchronous", progress=False)
    assert fits["fit_stiffness"].dims == ("y", "x", "omega")
    np.testing.assert_array_equal(fits["omega"].values, OMEGA)
    model = make_model("prony", 1)
    for iy in range(2):
        for ix in range(2):
            values = {n: float(fits[n][iy, ix]) for n in model.names}
            k = model.raw(OMEGA, values)
            np.testing.assert_allclose(fits["fit_stiffness"][iy, ix], np.abs(k), rtol=1e-12)
            np.testing.assert_allclose(fits["fit_phase"][iy, ix], np.degrees(np.angle(k)),
                                       rtol=1e-12)
    assert np.isfinite(fits["fit_stiffness"][0, 1, -1])  # at the flagged point too


def test_a_pixel_without_data_has_no_curve():
    from viscoforce.fitting.pixels import fit_block

    assert fit_block(["no data"], "prony", 1, "bic", {}, omega=OMEGA) == [
        {"success": False, "message": "no data"}]


def test_reports_on_request_keep_each_pixels_lmfit_report(spectra, tmp_path):
    import xarray as xr

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = fit_map(spectra, "prony", scheduler="synchronous", progress=False)
        fits = fit_map(spectra, "prony", scheduler="synchronous", progress=False, reports=True)
    assert "fit_report" not in plain
    text = str(fits["fit_report"][1, 0].values)
    assert "[[Variables]]" in text and "tau_1:" in text
    tau = float(fits["tau_1"][1, 0])
    import re

    shown = float(re.search(r"\n\s+tau_1:\s+(\S+)", text).group(1))
    assert shown == pytest.approx(tau, rel=1e-5)  # the pixel's own value
    fits.to_netcdf(tmp_path / "fits.nc")
    with xr.open_dataset(tmp_path / "fits.nc") as back:
        assert str(back["fit_report"][1, 0].values) == text  # files keep it
    with pytest.raises(ParameterError, match="reports must be True or False"):
        fit_map(spectra, "prony", scheduler="synchronous", progress=False, reports="yes")


def test_the_cli_keeps_the_reports_in_its_output(spectra, tmp_path):
    import xarray as xr

    from viscoforce.cli import main

    spectra.to_netcdf(tmp_path / "map.nc")
    out = tmp_path / "fits.nc"
    assert main(["fit", str(tmp_path / "map.nc"), "--model", "prony", "--scheduler",
                 "synchronous", "--reports", "--out", str(out)]) == 0
    with xr.open_dataset(out) as back:
        assert "[[Variables]]" in str(back["fit_report"][0, 0].values)
