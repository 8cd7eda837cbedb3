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
from viscoforce.fitting.data import FitData, spectrum_data
from viscoforce.fitting.models import make_model
from viscoforce.fitting.outcome import _residual, _vector_residual
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
    theirs = lmfit.minimize(_residual(model, data), start.to_lmfit(), method="leastsq",
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


def test_engine_refuses_expressions_naming_the_parameter():
    params = lmfit.Parameters()
    params.add("a", value=1.0)
    params.add("b", expr="2*a")
    with pytest.raises(TypeError, match=r"params\['b'\] has the expression '2\*a'"):
        _engine.leastsq(lambda x: x, params)


def _line_params(a=1.0, b=0.0, **bounds):
    params = lmfit.Parameters()
    params.add("a", value=a, **bounds)
    params.add("b", value=b)
    return params


def test_a_perfect_fit_has_lmfits_finite_criteria():
    """χ² = 0: lmfit clamps χ² to 1e-250 n before the logarithm; so does the engine."""
    x = np.linspace(0.0, 1.0, 12)
    y = 3.0 * x + 1.0

    def by_params(p):
        return y - (p["a"].value * x + p["b"].value)

    theirs = lmfit.minimize(by_params, _line_params(), method="leastsq")
    ours = _engine.leastsq(lambda v: y - (v[0] * x + v[1]), _line_params())
    assert np.isfinite(ours.aic) and np.isfinite(ours.bic)
    for key in ("chisqr", "aic", "bic", "redchi"):
        assert getattr(ours, key) == pytest.approx(getattr(theirs, key), rel=1e-9, abs=1e-300)


def test_starts_on_a_bound_are_lmfits():
    """A start exactly on either bound: lmfit's internal value, inverse and gradient."""
    for low, high, value in ((-2.0, 3.0, -2.0), (-2.0, 3.0, 3.0), (-2.0, np.inf, -2.0),
                             (-np.inf, 3.0, 3.0)):
        p = lmfit.Parameter("p", value=value, min=low, max=high)
        bounds = _engine._Bounds(np.array([low]), np.array([high]))
        u = bounds.internal(np.array([value]))
        assert u[0] == pytest.approx(p.setup_bounds(), abs=1e-12)
        assert bounds.external(u)[0] == pytest.approx(value, abs=1e-12)


def test_minpack_stops_at_lmfits_evaluation_limit(monkeypatch):
    """lmfit aborts a fit after 2000 (n + 1) evaluations; MINPACK is given that limit (ier = 5,
    a failure) and lmfit's other settings."""
    seen = {}
    real = _engine.minpack_leastsq

    def spy(func, x0, **kwargs):
        seen.update(kwargs)
        return real(func, x0, **kwargs)

    monkeypatch.setattr(_engine, "minpack_leastsq", spy)
    x = np.linspace(0.0, 1.0, 12)
    _engine.leastsq(lambda v: 3.0 * x + 1.0 - (v[0] * x + v[1]), _line_params())
    assert seen["maxfev"] == 2000 * (2 + 1)
    assert {k: seen[k] for k in ("ftol", "xtol", "gtol", "epsfcn", "factor")} == {
        "ftol": 1.5e-8, "xtol": 1.5e-8, "gtol": 0.0, "epsfcn": 1e-10, "factor": 100}


def test_a_residual_that_raises_propagates():
    def broken(v):
        raise ArithmeticError("the model gave NaN")

    with pytest.raises(ArithmeticError, match="NaN"):
        _engine.leastsq(broken, _line_params())


def test_engine_keeps_parameters_that_do_not_vary():
    """A parameter with vary=False keeps its value; the others fit as lmfit fits them."""
    model = make_model("contact", 1, radius=5e-6, indentation=5e-7)
    data = _spectrum_data(model, SLS, 5)
    start = model.internal_guess(data.y, data.x)
    start["log_tau"].set(value=-3.0, vary=False)
    theirs = lmfit.minimize(_residual(model, data), start.to_lmfit(), method="leastsq",
                            scale_covar=not data.sigma_known)
    ours = _engine.leastsq(_vector_residual(model, data, start), start,
                           scale_covar=not data.sigma_known)
    assert start["log_tau"].value == -3.0 and "log_tau" not in ours.var_names
    _assert_same(theirs, ours)


# ── the other starts of a several-mode fit (outcome._settled) ──────────────────────────────────────

PRONY = {"k_inf": 1.0, "dk_1": 2.0, "dk_2": 1.0, "tau_1": 1e-4, "tau_2": 1e-2}


def _count_fits(monkeypatch):
    calls = []
    real = _engine.leastsq

    def counting(residual, params, **kwargs):
        calls.append(1)
        return real(residual, params, **kwargs)

    monkeypatch.setattr(_engine, "leastsq", counting)
    return calls


@pytest.mark.parametrize("weighted, settle, fits", [
    (True, True, 1),    # settled: interior, covariance, p >= 0.05 -> the first start only
    (True, False, 2),   # a selection by criterion tries every start
    (False, True, 2),   # unknown stderr: no chi-square test, so never settled
])
def test_other_starts_run_only_for_a_fit_not_settled(monkeypatch, weighted, settle, fits):
    from viscoforce.fitting.outcome import _settled, fit_once

    model = make_model("prony", 2)
    data = _spectrum_data(model, PRONY, 11, weighted=weighted)
    calls = _count_fits(monkeypatch)
    outcome = fit_once(model, data, settle=settle)
    assert len(calls) == fits
    assert _settled(outcome) == (weighted and outcome.pvalue >= 0.05)


def test_a_fit_on_a_bound_is_not_settled():
    from viscoforce.fitting.outcome import _settled, fit_once

    model = make_model("prony", 2)
    data = _spectrum_data(model, PRONY, 11)
    outcome = fit_once(model, data)
    assert _settled(outcome)
    name = "log_tau_2"
    outcome.result.params[name].value = outcome.result.params[name].max  # now on its bound
    assert not _settled(outcome)


def test_selection_by_criterion_keeps_every_start(monkeypatch):
    """modes='auto' compares criteria: every candidate tries all its starts."""
    from viscoforce.fitting.fit import select

    model = make_model("prony", 2)
    data = _spectrum_data(model, PRONY, 11)
    calls = _count_fits(monkeypatch)
    _, rows = select(data, "prony", modes="auto")
    several = sum(1 for r in rows if r["modes"] > 1)
    assert len(calls) == (len(rows) - several) + 2 * several


def test_the_result_carries_its_fit_through_xarrays_accessor_cache():
    """report._accessor fills xarray's accessor cache: ds.lmfit is that object."""
    from viscoforce.fitting.fit import fit_data
    from viscoforce.fitting.report import _accessor

    model = make_model("contact", 1, radius=5e-6, indentation=5e-7)
    ds = fit_data(_spectrum_data(model, SLS, 3), "contact", radius=5e-6, indentation=5e-7)
    assert ds.lmfit is _accessor(ds) and ds.lmfit.available
    assert "log_E_inf" in ds.lmfit.fit_report()


# ── the engine's light parameters and decoder (issue 22: no lmfit container per fit) ──────────

@pytest.mark.parametrize("model_name, modes, fixed, truth", CASES)
def test_internal_parameters_are_lmfits_own(model_name, modes, fixed, truth):
    """internal_guess's light container holds what lmfit's Parameters of the layout hold."""
    from viscoforce.fitting import _params

    model = make_model(model_name, modes, **fixed)
    data = _spectrum_data(model, truth, 11)
    ours = model.internal_guess(data.y, data.x)
    guess = model._guesser(data.y, data.x)
    reference = lmfit.Parameters()
    for name, p in model.parameters_from(guess, data.x, y=data.y).items():
        if not p.expr:  # the internal ones: what lmfit would vary
            reference.add(name, value=p.value, min=p.min, max=p.max, vary=p.vary)
    assert isinstance(ours, _params.InternalParameters)
    assert list(ours) == list(reference)
    for name, p in reference.items():
        assert (ours[name].value, ours[name].min, ours[name].max, ours[name].vary) == (
            p.value, p.min, p.max, p.vary)
    as_lmfit = ours.to_lmfit()
    assert as_lmfit.valuesdict() == ours.valuesdict() == reference.valuesdict()


def test_internal_parameters_clip_copy_and_refuse_empty_windows():
    from viscoforce.fitting._params import Internal, InternalParameters

    params = InternalParameters()
    params.add("a", value=5.0, min=0.0, max=2.0)  # lmfit clips a start beyond a bound
    assert params["a"].value == 2.0 == lmfit.Parameter("a", value=5.0, min=0.0, max=2.0).value
    twin = params.copy()
    twin["a"].set(value=-1.0)
    assert twin["a"].value == 0.0 and params["a"].value == 2.0  # independent, clipped
    twin["a"].set(vary=False)
    assert not twin["a"].vary and params["a"].vary
    for low, high in ((2.0, 2.0), (2.0, 1.0), (1.0, 1.0 + 1e-14), (np.nan, 1.0)):
        with pytest.raises(ValueError, match="min < max"):  # lmfit refuses or swaps these
            Internal("b", 1.0, low, high)


@pytest.mark.parametrize("model_name, modes, fixed, truth", CASES)
def test_the_decoder_gives_reported_values_exactly(model_name, modes, fixed, truth):
    """The fit loop's decoder is reported_values to the bit, varied and fixed alike."""
    from viscoforce.fitting import _params

    model = make_model(model_name, modes, **fixed)
    data = _spectrum_data(model, truth, 12)
    params = model.internal_guess(data.y, data.x)
    names = list(params)
    held = names[-1]
    varied = names[:-1]
    rng = np.random.default_rng(3)
    decode = _params.decoder(model.layout, varied, {held: params[held].value})
    for _ in range(20):
        x = [params[n].value + rng.normal(scale=0.3) for n in varied]
        internal = {**dict(zip(varied, x, strict=True)), held: params[held].value}
        assert decode(x) == _params.reported_values(model.layout, internal)
    with pytest.raises(KeyError, match="neither varied nor fixed"):
        _params.decoder(model.layout, varied, {})


@pytest.mark.parametrize("low, high", [
    ([-2.0, 0.0, 1.0], [3.0, 12.0, 1.5]),                    # every parameter bounded twice
    ([-2.0, -np.inf, 0.5, -np.inf], [3.0, 1.0, np.inf, np.inf]),  # mixed, one free
    ([-np.inf, -np.inf], [np.inf, np.inf]),                 # none bounded
    ([-1.0, -np.inf, -np.inf], [np.inf, 2.0, np.inf]),       # one-sided only (no both-bounded)
])
def test_bound_transforms_match_lmfits_per_parameter(low, high):
    """The vectorised transforms (and the all-bounded shortcut) are lmfit's, parameter by
    parameter: external value and gradient."""
    bounds = _engine._Bounds(np.array(low), np.array(high))
    u = np.random.default_rng(0).normal(scale=2.0, size=len(low))
    x, g = bounds.external(u), bounds.gradient(u)
    for i, (lo, hi) in enumerate(zip(low, high, strict=True)):
        p = lmfit.Parameter("p", value=0.5 * (max(lo, -5.0) + min(hi, 5.0)), min=lo, max=hi)
        p.setup_bounds()
        value, grad = p.from_internal(u[i]), p.scale_gradient(u[i])
        assert x[i] == pytest.approx(value, rel=1e-15, abs=1e-15)
        assert g[i] == pytest.approx(grad, rel=1e-12, abs=1e-15)


@pytest.mark.parametrize("seed", range(40))
def test_spectrum_features_are_the_polyfit_vertex_and_numpys_medians(seed):
    """The guess's phase peak (a closed-form vertex) is np.polyfit's parabola through the top
    three points in log ω, clipped to them; the level medians are np.median's."""
    from viscoforce.fitting.guesses import SpectrumFeatures

    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 40))
    w = np.sort(np.exp(rng.uniform(0.0, 12.0, n)))
    k = np.exp(rng.normal(size=n)) * np.exp(1j * rng.uniform(0.0, 1.5, n))
    feats = SpectrumFeatures.of(k[::-1], w[::-1])  # any order
    mag, phase, n_end = np.abs(k), np.angle(k), max(1, n // 10)
    assert feats.k_low == float(np.median(mag[:n_end]))
    assert feats.k_high == float(np.median(mag[-n_end:]))
    i = int(np.argmax(phase))
    peak = w[i]
    if 0 < i < n - 1:
        a = np.polyfit(np.log(w[i - 1:i + 2]), phase[i - 1:i + 2], 2)
        if a[0] < 0:
            peak = min(max(math.exp(-a[1] / (2 * a[0])), w[i - 1]), w[i + 1])
    assert feats.omega_peak == pytest.approx(peak, rel=1e-9)


def test_spectrum_features_survive_a_repeated_frequency_and_keep_numpys_nan():
    """A frequency measured twice beside the phase peak defines no parabola: the peak point is
    the peak (no division by zero); a NaN level stays NaN as np.median gives it, so the guess
    refuses it by name instead of starting from a wrong value."""
    from viscoforce.fitting.guesses import SpectrumFeatures

    w = np.array([10.0, 100.0, 100.0, 1000.0, 1e4])
    k = np.exp(1j * np.array([0.1, 0.3, 0.5, 0.2, 0.1]))
    feats = SpectrumFeatures.of(k, w)
    assert 100.0 <= feats.omega_peak <= 1000.0
    k_nan = np.array([np.nan, 1.0, 1.0, 1.0, 1.0]) * np.exp(1j * np.array([0.1, 0.3, 0.5, 0.2, 0.1]))
    assert math.isnan(SpectrumFeatures.of(k_nan, w).k_low)
    with pytest.raises(ValueError, match="must be > 0 and finite"):
        make_model("prony").guess(k_nan, w)
