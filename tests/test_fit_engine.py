"""Issue 22: the package's leastsq (fitting._engine) gives lmfit's numbers without lmfit's cost.

The oracle is ``lmfit.minimize(method="leastsq")`` itself, on the same residual from the same
start. Both call MINPACK's lmdif with the same settings and transforms, so the tolerances are
those of floating-point reordering (the transforms are vectorised here, scalar in lmfit):
values to 1e-7 relative, χ² to 1e-9, the covariance to 1e-4 relative.
"""

from __future__ import annotations

import math

import lmfit
import numpy as np
import pytest

from viscoforce import PAPER
from viscoforce.fitting import _engine
from viscoforce.fitting.fit import FitData, _residual, _vector_residual, spectrum_data
from viscoforce.fitting.models import make_model
from viscoforce.schema import make_spectrum

OMEGA = np.geomspace(10.0, 1e6, 20)
SVDA = {"position": 2e-9, "radius": PAPER.R, "P": PAPER.P, "debye_length": PAPER.debye_length}
SLS = {"E0": 1e9, "E_inf": 2e8, "tau": 1e-3}
CASES = [
    ("svda", 1, SVDA, SLS),
    ("contact", 1, {"radius": 5e-6, "indentation": 5e-7}, SLS),
    ("contact", 1, {"radius": 5e-6, "indentation": 5e-7, "material": "structural"},
     {"E_ref": 1e3, "alpha": 0.15, "mu": 0.5}),
    ("prony", 2, {}, {"k_inf": 1.0, "dk_1": 2.0, "dk_2": 1.0, "tau_1": 1e-4, "tau_2": 1e-2}),
]


def _spectrum_data(model, truth, seed, weighted=True):
    rng = np.random.default_rng(seed)
    k = model.raw(OMEGA, truth)
    noisy = k * (1 + 0.01 * rng.standard_normal(k.shape)) * np.exp(
        1j * 0.01 * rng.standard_normal(k.shape))
    stderr = ({"stiffness": 0.01 * np.abs(k), "phase": np.full(k.shape, math.degrees(0.01))}
              if weighted else None)
    return spectrum_data(make_spectrum(OMEGA, noisy, 1e-7, 1e-10, stderr=stderr,
                                       source="simulation"),
                         weights=None if weighted else "relative")


def _both(model, data):
    start = model.internal_guess(data.y, data.x)
    theirs = lmfit.minimize(_residual(model, data), start.copy(), method="leastsq",
                            scale_covar=not data.sigma_known)
    ours = _engine.leastsq(_vector_residual(model, data, start), start,
                           scale_covar=not data.sigma_known)
    return theirs, ours


def _assert_same(theirs, ours):
    assert ours.var_names == theirs.var_names
    for name in ours.var_names:
        assert ours.params[name].value == pytest.approx(theirs.params[name].value, rel=1e-7,
                                                        abs=1e-10)
    assert ours.chisqr == pytest.approx(theirs.chisqr, rel=1e-9)
    for key in ("redchi", "aic", "bic"):
        assert getattr(ours, key) == pytest.approx(getattr(theirs, key), rel=1e-9, abs=1e-9)
    assert (ours.ndata, ours.nvarys, ours.nfree) == (theirs.ndata, theirs.nvarys, theirs.nfree)
    assert ours.success == theirs.success
    assert ours.errorbars == theirs.errorbars
    if theirs.errorbars:
        scale = np.sqrt(np.outer(np.diag(theirs.covar), np.diag(theirs.covar)))
        np.testing.assert_allclose(ours.covar / scale, theirs.covar / scale, atol=1e-4)
        for name in ours.var_names:
            assert ours.params[name].stderr == pytest.approx(theirs.params[name].stderr,
                                                             rel=1e-4)


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("name, modes, fixed, truth", CASES,
                         ids=["svda", "contact-sls", "contact-structural", "prony-2"])
def test_engine_matches_lmfit_on_the_closed_forms(name, modes, fixed, truth, seed):
    model = make_model(name, modes, **fixed)
    _assert_same(*_both(model, _spectrum_data(model, truth, seed)))


def test_engine_matches_lmfit_with_relative_weights_and_a_scaled_covariance():
    model = make_model("contact", 1, radius=5e-6, indentation=5e-7)
    data = _spectrum_data(model, SLS, 7, weighted=False)
    assert not data.sigma_known
    _assert_same(*_both(model, data))


def test_engine_matches_lmfit_on_a_force_relaxation_with_a_signed_parameter():
    model = make_model("relaxation", 1)
    t = np.linspace(0.0, 0.05, 40)
    rng = np.random.default_rng(4)
    f = model.raw(t, {"F_inf": 2e-9, "dF_1": 3e-9, "tau_1": 0.01})
    data = FitData(t, f + 1e-11 * rng.standard_normal(t.shape), None, {"data_kind": "curve"})
    _assert_same(*_both(model, data))


@pytest.mark.parametrize("low, high", [(-math.inf, math.inf), (-2.0, math.inf),
                                       (-math.inf, 3.0), (-2.0, 3.0)])
def test_bound_transforms_are_lmfits(low, high):
    """Internal value, its inverse and the covariance gradient, against lmfit's Parameter."""
    bounds = _engine._Bounds(np.array([low]), np.array([high]))
    for value in (-1.5, 0.0, 0.5, 2.5):
        p = lmfit.Parameter("p", value=value, min=low, max=high)
        u_lmfit = p.setup_bounds()
        u = bounds.internal(np.array([p.value]))
        assert u[0] == pytest.approx(u_lmfit, abs=1e-12)
        assert bounds.external(u)[0] == pytest.approx(p.from_internal(u_lmfit), abs=1e-12)
        assert bounds.gradient(u)[0] == pytest.approx(p.scale_gradient(u_lmfit), abs=1e-12)


def test_engine_refuses_expressions():
    params = lmfit.Parameters()
    params.add("a", value=1.0)
    params.add("b", expr="2*a")
    with pytest.raises(ValueError, match="expressions"):
        _engine.leastsq(lambda x: x, params)


def test_engine_keeps_parameters_that_do_not_vary():
    """A parameter with vary=False keeps its value; the others fit as lmfit fits them."""
    model = make_model("contact", 1, radius=5e-6, indentation=5e-7)
    data = _spectrum_data(model, SLS, 5)
    start = model.internal_guess(data.y, data.x)
    start["log_tau"].set(value=-3.0, vary=False)
    theirs = lmfit.minimize(_residual(model, data), start.copy(), method="leastsq",
                            scale_covar=not data.sigma_known)
    ours = _engine.leastsq(_vector_residual(model, data, start), start,
                           scale_covar=not data.sigma_known)
    assert start["log_tau"].value == -3.0 and "log_tau" not in ours.var_names
    _assert_same(theirs, ours)
