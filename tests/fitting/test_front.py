"""One front door, ``viscoforce.fit`` (issue 36 item 2, first step): a spectrum, a map, a curve.

Each route's result equals the result of the function it ends in (the same fit, bit for bit).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import viscoforce as vf
from viscoforce.exceptions import ParameterError
from viscoforce.fitting.curves import fit_curve
from viscoforce.fitting.fit import fit_spectrum
from viscoforce.fitting.maps import fit_map
from viscoforce.schema import make_curves


@pytest.fixture(scope="module")
def spectrum_map():
    with xr.open_dataset(vf.example_path("sls_spectrum_map.nc")) as ds:
        return ds.load()


def test_a_spectrum(spectrum_map):
    one = spectrum_map.isel(y=1, x=2)
    xr.testing.assert_identical(vf.fit(one, "prony"), fit_spectrum(one, "prony"))


def test_a_map(spectrum_map):
    small = spectrum_map.isel(y=slice(0, 2), x=slice(0, 2))
    got = vf.fit(small, "prony", scheduler="synchronous", progress=False)
    want = fit_map(small, "prony", scheduler="synchronous", progress=False)
    assert got["k_inf"].dims == ("y", "x")
    np.testing.assert_array_equal(got["k_inf"].values, want["k_inf"].values)


def test_a_force_curve():
    z = np.linspace(-1.0e-6, 2.6e-6, 1200)
    e_star = 1.5e3
    f = 4 / 3 * e_star * np.sqrt(5e-6) * np.maximum(z - 1.8e-6, 0.0) ** 1.5
    f = f + np.random.default_rng(3).normal(0.0, 30e-12, z.size)
    curves = make_curves(np.linspace(0, 1, z.size), f, -z, np.zeros_like(z), tip_position=z,
                         segment=0, segment_names=("approach",), source="synthetic")
    got = vf.fit(curves, "hertz", tip="paraboloid:5um")
    xr.testing.assert_identical(got, fit_curve(curves, "hertz", tip="paraboloid:5um"))
    assert float(got["E"]) == pytest.approx(2 * e_star, rel=0.05)


@pytest.mark.parametrize(("model", "match"), [
    ("hertz", "does not fit spectrum data; for spectrum: svda, exact, contact, prony, auto"),
    ("nonsense", "model must be one of svda, exact"),
])
def test_a_model_that_does_not_fit_the_data_is_refused(spectrum_map, model, match):
    with pytest.raises(ParameterError, match=match):
        vf.fit(spectrum_map.isel(y=0, x=0), model)


def test_data_of_no_known_kind_is_refused():
    with pytest.raises(ParameterError, match="data must be an xarray.Dataset"):
        vf.fit("file.nc", "prony")
    with pytest.raises(ParameterError, match="neither a spectrum"):
        vf.fit(xr.Dataset({"a": ("t", np.zeros(3))}), "prony")
