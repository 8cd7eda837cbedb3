"""Identifiability beyond the local test: the profile likelihood of each fitted parameter.

The stderr of a least-squares fit come from the curvature of χ² at the minimum. They are
honest when χ² is close to quadratic over ±2σ; they are not when the likelihood is one-sided
(e.g. E0 of a contact spectrum whose glassy plateau lies above the measured frequencies: χ²
barely rises as E0 → ∞, while the curvature at the minimum can still give a small stderr).

:func:`profile_parameters` walks each parameter q away from its best value on both sides and
re-minimises the others at every step (the profile Δχ²(q)). Positive parameters are walked in
log10 q, the others in q. A side is bounded when the profile reaches Δχ² = 4 (the 2σ level of
one parameter; χ² divided by the reduced χ² when the data carry no stderr, the scale of the
covariance lmfit reports then): the first step is the local 2σ; if Δχ² < 1 there (the quadratic
says 4) the step grows ×4 up to :data:`MAX_WALK_DECADES` (or the parameter's window; a
positive parameter's first step is at most :data:`FIRST_STEP_DECADES`). The 2σ limit is found
in √Δχ² (false position to within :data:`ROOT_TOLERANCE` when the walk bracketed it). The
constraint is a stiff quadratic penalty on the parameter, so any parameter (a chain member
E0 = E_inf·10^log_E0 too) is profiled the same way.

A step the parameters' window cannot reach (the target outside it, or the constrained fit
pushed another parameter onto a bound it was not on at the best fit) ends the walk on that side
unbounded: the window bounds it, not the data (the walk bisects back, since the profile may rise
before the window). So does a step whose constrained fit did not converge within
:data:`PROFILE_NFEV` evaluations per parameter or where the model gives NaN: unknown is
reported as not bounded, never as a bound. A step the fit cannot reach with every parameter free
(the data hold it off) bounds it.

Codes (:data:`IDENTIFIABILITY`): 0 determined (bounded on both sides, and for a positive
parameter within a factor :data:`WIDEST_DETERMINED`), 1 lower bound only (q > lower: the
likelihood is flat towards larger q), 2 upper bound only (q < upper), 3 not determined (flat on
both sides, or a positive parameter bounded on both sides by limits further apart than
:data:`WIDEST_DETERMINED`: the limits are kept).

The factor is the local test's rule (stderr > |value|: not determined) carried over to the
coordinates the limits of a positive parameter are found in, log q: a quadratic profile with
σ(ln q) = stderr/q = 1 has 2σ limits q·e^{±2}, a factor e⁴ ≈ 54.6 (1.74 decades) apart. So a
profile does not call a parameter determined that the local test would not, merely because the
likelihood rises to Δχ² = 4 somewhere within the window (a noise-only force curve bounded its
E between 1.4 Pa and 30 kPa, issue 40).

Nuisance parameters (:data:`~viscoforce.fitting.verdict.NUISANCE`: the contact point, the
baseline and its slope, which place a force curve rather than describe the material) are judged
by :data:`~viscoforce.fitting.verdict.NUISANCE_RULE`
(:func:`~viscoforce.fitting.verdict.settle_nuisance`): the local test's stderr > |value|
measures a value against its own size, which for a term counted from an arbitrary zero (the
piezo's, the deflection's) or whose natural value is 0 (an untilted baseline) says nothing: an
untilted baseline's slope, 0 ± its noise, was "not determined" in 28 of 40 Ting fits, and each
warned (issue 37). Their uncertainty reaches the moduli through the covariance (each modulus'
stderr is marginal over them), so the moduli's own codes say whether it matters. The profile
and the curvature's limits here judge every parameter that is not positive this way already
(bounded on both sides: determined).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import lmfit
import numpy as np

from viscoforce.exceptions import ViscoforceError
from viscoforce.fitting import _engine, _params

#: Identifiability codes of a fitted parameter.
IDENTIFIABILITY: dict[int, str] = {0: "determined", 1: "lower_bound_only",
                                   2: "upper_bound_only", 3: "not_determined"}
#: Profile Δχ² of the reported limits (2σ of one parameter).
DELTA_CHI2 = 4.0
#: Widest ratio upper/lower of the 2σ limits of a positive parameter that is determined: e⁴,
#: the limits q·e^{±2σ/q} of the local test's edge σ = q (module docstring).
WIDEST_DETERMINED = math.exp(2.0 * math.sqrt(DELTA_CHI2))
#: Below this Δχ² at the local 2σ step a side is flatter than the curvature says: walk on.
FLAT = 1.0
#: Factor of each further step of the walk.
GROWTH = 4.0
#: Farthest step [decades] of a positive parameter's walk (a linear one: 1000 local σ).
MAX_WALK_DECADES = 12.0
#: Largest first step [decades] of a positive parameter (when its local 2σ is wider).
FIRST_STEP_DECADES = 0.5
#: Most steps narrowing a 2σ limit bracketed between two steps of the walk.
BISECTIONS = 6
#: A step whose √(Δχ²/scale) is this close to 2 is the limit (Δχ² = 4 ± 0.04: the limit to
#: ≈ 0.5 % of its distance from the best value where the profile is quadratic).
ROOT_TOLERANCE = 0.01
#: Model evaluations per free parameter of one constrained fit (lmfit's default is 2000: a
#: profile step that has not converged by then overestimates Δχ², towards "bounded").
PROFILE_NFEV = 100
#: Penalty scale of the constraint: a miss of 1e-6 (decades, or relative) costs Δχ²/scale = 1.
PENALTY = 1e-6
#: ``"auto"`` profiles a positive parameter whose local 2σ spans more than this [decades]: over
#: a narrower range a smooth model is close to linear in log q, so the curvature's ±2σ and the
#: profile agree (to ≈ 1 % of the width on the test cases; tests/fitting/test_fit_statistics.py).
QUADRATIC_DECADES = 0.1
#: ``"auto"`` profiles both members of a pair correlated beyond this (a long, possibly curved
#: valley, along which the curvature at the minimum says little).
QUADRATIC_CORRELATION = 0.98


@dataclass(frozen=True)
class Profile:
    """Profile of one parameter: its code and 2σ limits (NaN on an unbounded side) [SI]."""

    code: int
    lower: float
    upper: float


Residual = Callable[[lmfit.Parameters], np.ndarray]


def positive_names(layout: Sequence[_params.Item]) -> set[str]:
    """The SPEC parameters walked in log10 (the members of a positive chain)."""
    return {n for item in layout if isinstance(item, _params.Chain) for n in item.names}


def needs_profile(layout: Sequence[_params.Item], values: Mapping[str, float],
                  stderr: Mapping[str, float | None], correlation: np.ndarray,
                  at_bound: Sequence[str]) -> list[str]:
    """The parameters whose curvature can mislead: the ones ``"auto"`` profiles.

    A parameter is profiled when the local test does not call it determined (no stderr,
    stderr > |value|, or at a bound), when it is positive and its local 2σ spans more than
    :data:`QUADRATIC_DECADES`, or when it is correlated with another beyond
    :data:`QUADRATIC_CORRELATION`. The others get :func:`quadratic_limits`.
    """
    positive = positive_names(layout)
    names = list(values)
    corr = np.abs(np.asarray(correlation, dtype=float))  # a new array
    corr[np.isnan(corr)] = 1.0  # unknown: as if correlated
    np.fill_diagonal(corr, 0.0)
    out = []
    for i, name in enumerate(names):
        err, value = stderr.get(name), values[name]
        local = (err is None or not math.isfinite(err) or err <= 0 or err > abs(value)
                 or name in at_bound)
        wide = (name in positive and not local and value > 0
                and 2.0 * err / (value * math.log(10.0)) > QUADRATIC_DECADES)
        if local or wide or corr[i].max(initial=0.0) > QUADRATIC_CORRELATION:
            out.append(name)
    return out


def quadratic_limits(layout: Sequence[_params.Item], values: Mapping[str, float],
                     stderr: Mapping[str, float | None], names: Sequence[str]
                     ) -> dict[str, Profile]:
    """The curvature's 2σ limits: ±2 stderr, in log10 for positive parameters.

    Code 0, or 3 where a positive parameter's limits are further apart than
    :data:`WIDEST_DETERMINED` (i.e. stderr > value: the local test's rule).
    """
    positive = positive_names(layout)
    out = {}
    for name in names:
        value, err = values[name], float(stderr[name])  # type: ignore[arg-type]
        if name in positive:
            width = 2.0 * err / (value * math.log(10.0))
            lower, upper = value * 10.0 ** -width, value * 10.0 ** width
            out[name] = Profile(limits_code(True, True, lower, upper, True), lower, upper)
        else:
            out[name] = Profile(0, value - 2.0 * err, value + 2.0 * err)
    return out


def limits_code(lower_ok: bool, upper_ok: bool, lower: float, upper: float, log: bool) -> int:
    """The :data:`IDENTIFIABILITY` code of 2σ limits, bounded (``*_ok``) or not on each side.

    Bounded on both sides is determined (0), except a positive parameter (``log``) whose limits
    are further apart than :data:`WIDEST_DETERMINED`: not determined (3).
    """
    if lower_ok and upper_ok:
        too_wide = log and not (lower > 0 and upper <= WIDEST_DETERMINED * lower)
        return 3 if too_wide else 0
    return 1 if lower_ok else 2 if upper_ok else 3


def profile_parameters(layout: Sequence[_params.Item], residual: Residual,
                       best: _params.ParameterSet, stderr: Mapping[str, float | None],
                       chisqr: float, scale: float, names: Sequence[str] | None = None
                       ) -> dict[str, Profile]:
    """Profile the SPEC parameters of a fit (see the module docstring).

    Parameters
    ----------
    layout : sequence
        The model's parameter layout (:mod:`viscoforce.fitting._params`).
    residual : callable
        The fit's weighted residual of the internal parameters.
    best : lmfit.Parameters or viscoforce.fitting._params.InternalParameters
        The best-fit internal parameters.
    stderr : mapping
        Local stderr of each SPEC parameter (None or NaN when there is none).
    chisqr : float
        χ² at the best fit.
    scale : float
        Divisor of Δχ² (1 with known stderr; the reduced χ² without).
    names : sequence of str, optional
        The parameters to profile (default: all).

    Returns
    -------
    dict
        SPEC name → :class:`Profile`.
    """
    positive = positive_names(layout)
    values, _ = _params.to_reported(layout, best.valuesdict())
    out = {}
    for name in _params.reported_names(layout) if names is None else names:
        log = name in positive
        value = values[name]
        err = stderr.get(name)
        local = (err / (value * math.log(10.0)) if log else err) if (
            err is not None and math.isfinite(err) and err > 0) else math.nan
        out[name] = _profile_one(layout, residual, best, name, log, value, local, chisqr,
                                 max(scale, 1e-300))
    return out


def _profile_one(layout: Sequence[_params.Item], residual: Residual, best: _params.ParameterSet,
                 name: str, log: bool, value: float, local: float, chisqr: float,
                 scale: float) -> Profile:
    g0 = math.log10(value) if log else value
    if not math.isfinite(local):
        local = 0.05 if log else 0.05 * max(abs(value), 1e-300)
    cap = MAX_WALK_DECADES if log else 1000 * local
    limits = []
    bounded = []

    solved: dict[float, list[tuple[float, _params.ParameterSet]]] = {-1.0: [], 1.0: []}

    def root_at(step: float, side: float) -> float:
        """√(Δχ²/scale) at ``step`` from the best value (NaN: the window holds it there).

        Each constrained fit starts from the solved step nearest to it on its side (a warm
        start along the profile valley), else from the best fit.
        """
        near = min(solved[side], key=lambda item: abs(item[0] - step), default=(0.0, best))
        delta, params = _delta_chi2(layout, residual, best, name, log, g0 + side * step, chisqr,
                                    scale, start=near[1])
        if params is not None:
            solved[side].append((step, params))
        return math.sqrt(max(delta, 0.0) / scale) if delta == delta else math.nan

    for side in (-1.0, 1.0):
        first = min(2.0 * local, FIRST_STEP_DECADES) if log else 2.0 * local
        limit = _walk(lambda x, side=side: root_at(x, side), min(first, cap), cap)
        bounded.append(math.isfinite(limit))
        g = g0 + side * limit if math.isfinite(limit) else math.nan
        limits.append(10.0 ** g if log and math.isfinite(g) else g)
    lower_ok, upper_ok = bounded
    return Profile(limits_code(lower_ok, upper_ok, limits[0], limits[1], log), limits[0],
                   limits[1])


def _walk(root_at: Callable[[float], float], first: float, cap: float) -> float:
    """The step where √(Δχ²/scale) reaches 2 on one side (NaN: it never does before ``cap``).

    The first step is the local 2σ. Where the profile already rises to Δχ² ≥ :data:`FLAT` there,
    the quadratic through the minimum predicts the 2σ point; it is evaluated, not assumed (a
    profile that flattens beyond the first step walks on from it). Otherwise the step grows by
    :data:`GROWTH` until Δχ² ≥ 4 (then bisected), the cap, or a step the window holds (NaN:
    bisected too, since the profile may rise before the window is reached). A step the model
    cannot reach with every parameter free (inf) is bracketed like Δχ² ≥ 4.
    """
    target = math.sqrt(DELTA_CHI2)
    root = root_at(first)
    if root != root:
        return _bisect(root_at, 0.0, 0.0, first)
    if root >= target:
        return _bisect(root_at, 0.0, 0.0, first, root)
    prev, prev_root, step = first, root, first
    if root * root >= FLAT:  # near-quadratic: try its 2σ point next, then walk on from there
        predicted = min(first * target / root, cap)
        r_pred = root_at(predicted)
        if r_pred != r_pred:
            return _bisect(root_at, prev, prev_root, predicted)
        if r_pred >= target:
            return _interpolate(prev, prev_root, predicted, r_pred)
        prev, prev_root, step = predicted, r_pred, predicted
    while step < cap:
        step = min(step * GROWTH, cap)
        root = root_at(step)
        if root != root:
            return _bisect(root_at, prev, prev_root, step)
        if root >= target:
            return _bisect(root_at, prev, prev_root, step, root)
        prev, prev_root = step, root
    return math.nan


def _interpolate(lo: float, r_lo: float, hi: float, r_hi: float) -> float:
    """The step where √(Δχ²/scale) = 2, linear in √Δχ² between two bracketing steps."""
    target = math.sqrt(DELTA_CHI2)
    frac = (target - r_lo) / max(r_hi - r_lo, 1e-300) if math.isfinite(r_hi) else 1.0
    return lo + min(max(frac, 0.0), 1.0) * (hi - lo)


def _bisect(root_at: Callable[[float], float], lo: float, r_lo: float, hi: float,
            r_hi: float = math.nan) -> float:
    """Narrow [lo, hi] to √(Δχ²/scale) = 2; ``r_hi`` NaN: hi is held by the window.

    Where both ends are measured the next step is the false-position point (Illinois variant:
    an end kept twice has its miss halved), since √Δχ² is close to linear in the step; where
    hi is held by the window or by the data (inf) it is the midpoint. Stops at a step within
    :data:`ROOT_TOLERANCE` of 2, else after :data:`BISECTIONS` steps (then interpolated).

    NaN when the profile never rose to 2 before the window (unbounded by the data) or when the
    bracket shrank to the best value itself (nothing measured on that side).
    """
    target = math.sqrt(DELTA_CHI2)
    f_lo, f_hi, kept = r_lo - target, r_hi - target, 0
    for _ in range(BISECTIONS):
        if math.isfinite(f_hi):
            mid = lo + (hi - lo) * min(max(-f_lo / max(f_hi - f_lo, 1e-300), 0.05), 0.95)
        else:
            mid = 0.5 * (lo + hi)
        r_mid = root_at(mid)
        if r_mid != r_mid:  # still held by the window: look nearer
            hi, r_hi, f_hi, kept = mid, math.nan, math.nan, 0
        elif abs(r_mid - target) <= ROOT_TOLERANCE:
            return mid
        elif r_mid >= target:
            hi, r_hi, f_hi = mid, r_mid, r_mid - target
            f_lo, kept = (0.5 * f_lo if kept == -1 else f_lo), -1
        else:
            lo, r_lo, f_lo = mid, r_mid, r_mid - target
            f_hi, kept = (0.5 * f_hi if kept == 1 else f_hi), 1
    if r_hi != r_hi or lo == 0.0 and not math.isfinite(r_hi):
        return math.nan
    return _interpolate(lo, r_lo, hi, r_hi)


def _delta_chi2(layout: Sequence[_params.Item], residual: Residual, best: _params.ParameterSet,
                name: str, log: bool, target: float, chisqr: float, scale: float, *,
                start: _params.ParameterSet | None = None
                ) -> tuple[float, _params.ParameterSet | None]:
    """Profile Δχ² with ``name`` held at ``target`` (log10 for positive parameters).

    Returns (Δχ², the constrained fit's parameters where it met the target, else None); Δχ² is
    NaN where the window holds the fit or nothing converged, inf where the data hold it off.
    """
    # the penalty in the units of Δχ²/scale, so that the constraint neither drowns the data's
    # χ² (unweighted forces in N give χ² ~ 1e-17) nor lets the parameter drift off its target
    width = PENALTY * max(abs(target) if not log else 1.0, 1e-300) / math.sqrt(scale)

    def constrained(params: lmfit.Parameters) -> np.ndarray:
        values, _ = _params.to_reported(layout, params.valuesdict())
        q = values[name]
        g = math.log10(q) if log and q > 0 else q if not log else -math.inf
        return np.append(residual(params), (g - target) / width)

    lo, hi = _window(layout, best, name, log)
    if not lo <= target <= hi:
        return math.nan, None  # beyond the parameters' window: it bounds it, not the data
    first = _shifted(layout, best if start is None else start, name, log, target)
    try:
        res = _constrained_fit(constrained, first)
    except (ArithmeticError, ViscoforceError, _Unconverged):
        # the model gave NaN/inf or cannot be solved here (a state outside its grid), or the
        # fit did not converge within PROFILE_NFEV: nothing measured, say unknown
        return math.nan, None
    if _window_bounds(layout, res.params) - _window_bounds(layout, best):
        return math.nan, None  # a bound of the parameters' window held the fit, not the data
    values, _ = _params.to_reported(layout, res.params.valuesdict())
    q = values[name]
    reached = (math.log10(q) if q > 0 else math.nan) if log else q
    miss = abs(reached - target) if math.isfinite(reached) else math.inf
    if miss > 1e-2 * (1.0 if log else max(abs(target), 1e-300)):
        return math.inf, None  # nothing at a bound: the data held the fit off its target
    r = np.asarray(res.residual, dtype=float)[:-1]  # the data part (the penalty is last)
    return max(float(r @ r) - chisqr, 0.0), res.params


class _Unconverged(Exception):
    """A constrained fit of the profile reached :data:`PROFILE_NFEV` evaluations per parameter."""


def _constrained_fit(constrained: Residual, first: _params.InternalParameters
                     ) -> _engine.LeastSquares:
    """Minimise ``constrained`` from ``first`` (in place) on the package's engine.

    :func:`viscoforce.fitting._engine.leastsq` is lmfit's ``leastsq`` without lmfit's per-fit
    and per-evaluation machinery (the same MINPACK call, the same numbers); the residual is
    handed ``first`` itself with the trial values set (it reads ``valuesdict()`` or
    ``params[name].value``). More than :data:`PROFILE_NFEV` evaluations per varied parameter
    raise :class:`_Unconverged`: a fit stopped there would overestimate Δχ².
    """
    varied = [n for n, p in first.items() if p.vary]
    work = first.copy()
    cap = PROFILE_NFEV * (len(varied) + 1)
    calls = 0

    def vector(x: np.ndarray) -> np.ndarray:
        nonlocal calls
        calls += 1
        if calls > cap:
            raise _Unconverged
        for key, value in zip(varied, x, strict=True):
            work[key].value = float(value)
        return constrained(work)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return _engine.leastsq(vector, first, scale_covar=False)


def _window_bounds(layout: Sequence[_params.Item], params: _params.ParameterSet) -> set[str]:
    """Internal parameters on a bound of their window.

    An ordering bound (E0 = E_inf) is not one: the fit there is as legitimate as anywhere, and
    the data's Δχ² counts.
    """
    ordering = {f"log_{n}" for item in layout if isinstance(item, _params.Chain)
                for n in item.names[1:]}
    out = set()
    for name in _params.at_bound(params):
        key = f"log_{name}" if f"log_{name}" in params else name
        p = params[key]
        if key in ordering and p.value - p.min <= 1e-6 * max(p.max - p.min, 1.0):
            continue
        out.add(key)
    return out


def _window(layout: Sequence[_params.Item], best: _params.ParameterSet, name: str,
            log: bool) -> tuple[float, float]:
    """The range (log10 for positive parameters) the internal parameters' bounds allow ``name``."""
    for item in layout:
        if isinstance(item, _params.Chain) and name in item.names:
            lo = hi = 0.0
            for member in item.names[:item.names.index(name) + 1]:
                p = best[f"log_{member}"]
                lo += p.min if p.vary else p.value
                hi += p.max if p.vary else p.value
            return lo, hi
    p = best[name]
    return (p.min, p.max) if p.vary else (p.value, p.value)


def _shifted(layout: Sequence[_params.Item], base: _params.ParameterSet, name: str, log: bool,
             target: float) -> _params.InternalParameters:
    """A copy of ``base`` with ``name``'s own internal parameter moved to meet ``target``."""
    start = _as_internal(base)
    values, _ = _params.to_reported(layout, base.valuesdict())
    key = f"log_{name}" if log else name
    if key not in start or not start[key].vary:
        return start
    p = start[key]
    shift = target - math.log10(values[name]) if log else target - values[name]
    p.set(value=min(max(p.value + shift, p.min), p.max))
    return start


def _as_internal(params: _params.ParameterSet) -> _params.InternalParameters:
    """A copy of ``params`` in the engine's container (values, bounds, vary)."""
    if isinstance(params, _params.InternalParameters):
        return params.copy()
    out = _params.InternalParameters()
    for name, p in params.items():
        if p.expr:  # an lmfit expression: the SPEC names of a chain, not varied
            continue
        out[name] = _params.Internal(name, p.value, p.min, p.max, p.vary)
    return out
