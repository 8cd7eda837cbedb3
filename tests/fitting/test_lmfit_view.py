"""``ds.lmfit``: lmfit's result, report, confidence intervals and uvars of a single fit."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import xarray as xr

from tests.fitting.test_identifiability_auto import _structural
from viscoforce.exceptions import ParameterError
from viscoforce.fitting.data import FitData
from viscoforce.fitting.fit import fit_data, fit_spectrum
from viscoforce.fitting.models import make_model


@pytest.fixture(scope="module")
def fitted():
    ds_in, fixed = _structural()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fit_spectrum(ds_in, "contact", **fixed)


def test_the_lmfit_result_is_the_fit_with_its_spec_names(fitted):
    assert fitted.lmfit.available
    params = fitted.lmfit.result.params
    for name in ("E_ref", "alpha", "mu"):
        # the same optimum; known stderr: lmfit's covariance is the dataset's
        assert params[name].value == pytest.approx(float(fitted[name]), rel=1e-6)
        assert params[name].stderr == pytest.approx(float(fitted[f"{name}_stderr"]), rel=1e-3)
    report = fitted.lmfit.fit_report()
    assert "[[Variables]]" in report and "E_ref:" in report and "log_E_ref:" in report


def test_uvars_carry_the_correlations(fitted):
    u = fitted.lmfit.uvars
    assert u["E_ref"].n == pytest.approx(float(fitted["E_ref"]), rel=1e-6)
    corr = float(fitted["correlation"].sel(param_i="E_ref", param_j="alpha"))
    cov = u["E_ref"].s * u["alpha"].s * corr
    from uncertainties import covariance_matrix

    assert covariance_matrix([u["E_ref"], u["alpha"]])[0][1] == pytest.approx(cov, rel=1e-2)


def test_conf_interval_brackets_each_internal_parameter(fitted):
    ci = fitted.lmfit.conf_interval(sigmas=[1])
    assert set(ci) == {"log_E_ref", "alpha", "log_mu"}
    for name, rows in ci.items():
        (lo_p, lo), (_, best), (hi_p, hi) = rows
        assert lo < best < hi, name
        assert best == pytest.approx(fitted.lmfit.result.params[name].value, rel=1e-6)


def test_a_curve_fit_carries_its_result_too():
    t = np.linspace(0.0, 0.05, 40)
    f = make_model("relaxation", 1).raw(t, {"F_inf": 2e-9, "dF_1": 3e-9, "tau_1": 0.01})
    f = f + 1e-11 * np.random.default_rng(2).standard_normal(t.size)
    ds = fit_data(FitData(t, f, None, {"data_kind": "curve"}), "relaxation")
    assert ds.lmfit.result.params["tau_1"].value == pytest.approx(float(ds["tau_1"]), rel=1e-6)


def test_a_dataset_from_a_file_or_a_selection_says_it_has_none(fitted, tmp_path):
    path = tmp_path / "fit.nc"
    fitted.to_netcdf(path)
    with xr.open_dataset(path) as back:
        assert not back.lmfit.available
        with pytest.raises(ParameterError, match="carries no lmfit result"):
            back.lmfit.fit_report()
    assert not fitted.isel(omega=slice(0, 3)).lmfit.available
    assert math.isfinite(float(fitted["E_ref"]))


def test_a_fitted_dataset_pickles_without_its_fit(fitted):
    """A result sent to another process (pickle: dask, multiprocessing) keeps every variable
    and attribute; its fit (closures) stays behind, as with a file."""
    import pickle

    fitted.lmfit.fit_report()  # the accessor fully built (minimizer and result cached)
    back = pickle.loads(pickle.dumps(fitted))
    xr.testing.assert_identical(back, fitted)
    assert fitted.lmfit.available and not back.lmfit.available
    with pytest.raises(ParameterError, match="carries no lmfit result"):
        back.lmfit.fit_report()
