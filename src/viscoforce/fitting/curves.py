"""Force-curve data for the ``relaxation``, ``hertz``, ``creep`` and ``step`` models.

``relaxation`` fits the force on a hold (its τ_i are force-relaxation times at fixed position,
not creep times; F relative to the file's free-cantilever baseline where it has one): by
default the pause segment that follows the first approach of a curve (``segment=N`` picks the
curve's N-th segment, counted from 0 in the file's order), with t from the start of that
segment. ``hertz`` fits the approach (force over the tip position), ``creep`` the tip position
on a constant-force pause (:func:`fit_curve`). ``step`` fits a trajectory (time, position, force:
what ``simulate`` writes): the position history is the drive of the exact model.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.fitting.data import FitData
from viscoforce.fitting.fit import fit_data, result_dataset
from viscoforce.fitting.hertz_checks import hertz_checks
from viscoforce.fitting.model_error import validity_note
from viscoforce.fitting.models import MODELS, make_model
from viscoforce.fitting.moduli import add_derived_moduli
from viscoforce.fitting.outcome import Outcome
from viscoforce.fitting.registry import entries
from viscoforce.fitting.segments import (  # noqa: F401 - public here too
    approach_data,
    creep_data,
    hold_data,
    segment_runs,
)
from viscoforce.fitting.verdict import warn_fit
from viscoforce.problem import ContactProblem
from viscoforce.schema import validate_trajectory


def curve_data(curves: xr.Dataset, model: str, *, curve: int = 0,
               segment: int | None = None) -> FitData:
    """What curve model ``model`` (relaxation, hertz, creep, ting) fits on curve ``curve``.

    Raises
    ------
    ParameterError
        As the model's data function; for hertz and ting also a tip position or force whose
        span is below what the fit can bound (:func:`check_spans`).
    """
    cut = MODELS[model].cut if model in MODELS else None
    if cut is None:
        raise ParameterError(f"model must be one of {', '.join(entries(data='curve'))} for force "
                             "curves, "
                             f"got {model!r}")
    data = cut(curves, curve=curve, segment=segment)
    if model == "hertz":
        check_spans("the approach", data.x, data.y)
    elif model == "ting":
        check_spans("the approach-retract", getattr(data, "position", None), data.y)
    return data


def check_spans(what: str, position: np.ndarray | None, force: np.ndarray) -> None:
    """Refuse a curve whose tip position or force spans too little for a fit to bound.

    The hertz and ting models bound the contact point within the tip positions and the force
    baseline within a few force spans (the largest magnitude where the force is constant);
    lmfit refuses bounds closer than 1e-13 (absolute or relative), so a span below
    :data:`~viscoforce._limits.MIN_POSITION_SPAN`, :data:`~viscoforce._limits.MIN_FORCE_SPAN`
    or :data:`~viscoforce._limits.MIN_RELATIVE_SPAN` of its magnitude is refused here, naming
    it (a force or height in the wrong unit, values scaled by a tiny factor). A force of zeros
    is left to the fit (no contact).

    Parameters
    ----------
    what : str
        The segment named in the message (``"the approach"``).
    position : array_like or None
        Tip positions [m] (None: not checked).
    force : array_like
        Forces [N].

    Raises
    ------
    ParameterError
        Naming the span, its ends and the floor.
    """
    from viscoforce._limits import MIN_FORCE_SPAN, MIN_POSITION_SPAN, MIN_RELATIVE_SPAN

    for name, unit, values, floor in (("tip position", "m", position, MIN_POSITION_SPAN),
                                      ("force", "N", force, MIN_FORCE_SPAN)):
        if values is None:
            continue
        v = np.asarray(values, dtype=float)
        if v.size == 0:
            continue
        low, high = float(v.min()), float(v.max())  # NaN or inf among them: not finite
        if not (math.isfinite(low) and math.isfinite(high)):  # the finite values' span
            v = v[np.isfinite(v)]
            if v.size == 0:
                continue
            low, high = float(np.min(v)), float(np.max(v))
        largest = max(abs(low), abs(high))
        span = high - low
        if name == "force" and span == 0.0:  # the baseline window spans the magnitude
            if largest == 0.0:
                continue
            span = largest
        ends = f"(from {low:g} {unit} to {high:g} {unit})"
        if span < floor:
            raise ParameterError(
                f"{what} spans {span:g} {unit} of {name} {ends}, below the smallest span a fit "
                f"can bound, {floor:g} {unit}; check the unit of the {name} and its values")
        if span < MIN_RELATIVE_SPAN * largest:
            raise ParameterError(
                f"{what} spans {span:g} {unit} of {name} {ends}, below {MIN_RELATIVE_SPAN:g} of "
                f"its magnitude: a fit cannot bound it; check the {name}'s values")


def fit_hold(curves: xr.Dataset, *, curve: int = 0, segment: int | None = None,
             modes: int | str = 1, criterion: str = "bic") -> xr.Dataset:
    """Fit F(t) = F_inf + Σ dF_i e^{−t/τ_i} to the hold of one curve (``relaxation`` model).

    The τ_i are force-relaxation times at fixed position (not the creep times of Eq. 3: for a
    standard linear solid the force decays with τ·E_inf/E0). F is taken relative to the file's
    free-cantilever baseline where it records one (``attrs["force_baseline"]``,
    ``attrs["force_reference"]``). The stderr are corrected for autocorrelated residuals
    (:mod:`viscoforce.fitting.fit`).

    Parameters
    ----------
    curves : xarray.Dataset
        A curves dataset (:mod:`viscoforce.schema.curves`).
    curve : int
        The curve (pixel) to fit, from 0.
    segment : int, optional
        The curve's segment to fit (from 0, file order); default the pause after the approach.
    modes : int or "auto"
        Relaxation modes.
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.

    Returns
    -------
    xarray.Dataset
        The fit result (``F_inf``, ``dF_i``, ``tau_i`` [s]; ``attrs`` ``residual_lag1``,
        ``stderr_correction``, ``effective_samples``).
    """
    ds = fit_data(hold_data(curves, curve=curve, segment=segment), "relaxation", modes=modes,
                  criterion=criterion)
    ds.attrs["validity"] = validity_note("relaxation", ds)
    warn_fit(ds)
    return ds


def file_tip(curves: xr.Dataset):
    """The tip the file records (attrs of :meth:`~viscoforce.physics.tips.Tip.as_attrs`), or None."""
    from viscoforce.physics.tips import Tip

    if "tip_shape" not in curves.attrs:
        return None
    return Tip.from_attrs(curves.attrs)


def required_tip(curves: xr.Dataset, tip: Any, model: str):
    """``tip`` or the file's own; a ParameterError naming the model when there is neither."""
    tip = tip if tip is not None else file_tip(curves)
    if tip is None:
        raise ParameterError(
            f"the {model} model needs the tip, which this file does not record: give tip= "
            "(--tip sphere:R | paraboloid:R | cone:HALF_ANGLE | pyramid:HALF_ANGLE | "
            "flat:RADIUS)")
    return tip


def fit_curve(curves: xr.Dataset, model: str, *, curve: int = 0, segment: int | None = None,
              modes: int | str = 1, criterion: str = "bic", tip: Any = None,
              poisson: float | None = None, sample_height: float | None = None,
              sample_base: str | None = None,
              contact_window: tuple[float, float] | None = None) -> xr.Dataset:
    """Fit one segment of one measured force curve: ``relaxation``, ``hertz`` or ``creep``.

    * ``relaxation`` — F(t) = F_inf + Σ dF_i e^{−t/τ_i} on a constant-height hold (τ_i are
      force-relaxation times; see :func:`fit_hold`).
    * ``hertz`` — the approach: F(z) = baseline + baseline_slope·(z − contact_point) +
      E·shape(z − contact_point) in contact, with the tip's indentation law
      (:mod:`viscoforce.physics.tips`); ``E`` is the paper's modulus (E = 2Y/(1 − ν²)), also
      reported as ``E_young`` and ``E_shear``.
    * ``creep`` — the tip position on a constant-force pause, z(t) = z_inf + Σ dz_i e^{−t/τ_i}
      (τ_i creep times, ascending; ``attrs["creep_force"]`` the force held).

    The stderr of all three are corrected for autocorrelated residuals (lag-1 AR model; attrs
    ``residual_lag1``, ``stderr_correction``).

    Parameters
    ----------
    curves : xarray.Dataset
        A curves dataset (:mod:`viscoforce.schema.curves`).
    model : {"relaxation", "hertz", "creep"}
        The curve model.
    curve : int
        The curve (pixel) to fit, from 0.
    segment : int, optional
        The curve's segment to fit (from 0, file order); default the model's own (the approach,
        the constant-height or the constant-force pause after it).
    modes : int or "auto"
        Exponential modes (relaxation, creep; hertz has none).
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.
    tip : Tip or str, optional
        The tip (hertz; ``"sphere:5um"`` etc.); default the file's own when it records one.
    poisson : float, optional
        Poisson's ratio in [0, 0.5] of ``E_young``, ``E_shear`` (hertz; default 0.5).
    sample_height : float, optional
        Hertz: the sample's thickness [m] on its rigid support (the bottom-effect correction,
        :mod:`viscoforce.physics.bottom_effect`); ``attrs["bottom_effect_factor"]`` is then the
        force factor at the deepest fitted indentation.
    sample_base : {"bonded", "sliding"}, optional
        Hertz, with ``sample_height``: the layer bonded to (default) or sliding on its support.
    contact_window : (float, float), optional
        Hertz: the window [m] the contact point is fitted in (default the tip's own,
        :func:`~viscoforce.fitting.curve_models.contact_window`); a window a picometre wide holds
        it where another method put it (the error budget's ``contact_point`` source).

    Returns
    -------
    xarray.Dataset
        The fit result; hertz also holds the best-fit approach (``fit_approach_force`` over
        ``tip_position``), creep the best-fit ``fit_tip_position`` over ``time``.

    Raises
    ------
    ParameterError
        No segment for the model, too few samples, bad options, or hertz without a tip.
    """
    if model == "relaxation":
        if tip is not None or poisson is not None:
            raise ParameterError("the relaxation model takes no tip or poisson (it fits forces)")
        return fit_hold(curves, curve=curve, segment=segment, modes=modes, criterion=criterion)
    if model == "creep":  # Lee-Radok with a tip (given or the file's), else phenomenological
        from viscoforce.fitting.creep import fit_creep

        return fit_creep(curves, curve=curve, segment=segment, tip=tip, modes=modes,
                         criterion=criterion, poisson=poisson)
    data = curve_data(curves, model, curve=curve, segment=segment)
    fixed: dict[str, Any] = {}
    if model == "hertz":
        if modes not in (1, None):
            raise ParameterError(f"the hertz model has no modes (modes=1), got {modes!r}")
        modes = 1
        from viscoforce.physics.tips import tip_from

        fixed["tip"] = tip_from(required_tip(curves, tip, "hertz"))
        fixed.update({k: v for k, v in (("sample_height", sample_height),
                                        ("sample_base", sample_base),
                                        ("contact_window", contact_window)) if v is not None})
    elif contact_window is not None:
        raise ParameterError(f"contact_window applies to the hertz model, not {model!r}")
    elif sample_height is not None or sample_base is not None:
        raise ParameterError(f"sample_height and sample_base correct a contact law (hertz); "
                             f"model {model!r} has none")
    ds = fit_data(data, model, modes=modes, criterion=criterion, **fixed)
    ds.attrs["validity"] = validity_note(model, ds)
    if model == "hertz":  # first: its verdict on E is part of what warn_fit reports
        from viscoforce.fitting._layer import layered

        law = layered(fixed["tip"], fixed)  # the layer's law: the checks refit with it
        if law is not fixed["tip"]:
            deepest = max(float(np.max(data.x)) - float(ds["contact_point"]), 0.0)
            ds.attrs["bottom_effect_factor"] = float(
                law.force_shape(deepest) / fixed["tip"].force_shape(deepest)) if deepest > 0 \
                else 1.0
        ds = hertz_checks(ds, data, law, copy=False)  # ds is this call's own
    warn_fit(ds)
    if model == "hertz":
        ds = add_derived_moduli(ds, poisson)
    return ds


def trajectory_data(trajectory: xr.Dataset) -> tuple[FitData, tuple[np.ndarray, np.ndarray]]:
    """(t, F) and the position history (t, h0) of a trajectory (the ``step`` model's data)."""
    validate_trajectory(trajectory)
    t = np.asarray(trajectory["time"].values, dtype=float)
    f = np.asarray(trajectory["force"].values, dtype=float)
    h = np.asarray(trajectory["position"].values, dtype=float)
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(h))):
        raise ParameterError("the trajectory's force and position must be finite")
    return (FitData(t, f, None, {"data_kind": "trajectory", "data_points": int(t.size)}),
            (t, h))


#: Tolerance of the step fit's search stage, in units of simulate's default (the fit from its
#: optimum runs at the default): measured in benchmarks/bench_step.py.
STEP_SEARCH_TOL = 100.0
#: Most samples the search stage fits (evenly spread over the data, both ends kept): every
#: output time is a step of the simulation, so fewer samples make the search's runs cheaper.
STEP_SEARCH_POINTS = 25
#: leastsq tolerances of the search (it only has to land where the fit converges in a few
#: iterations; the fit itself runs at lmfit's defaults, 1.5e-8).
STEP_SEARCH_LM = {"ftol": 1e-5, "xtol": 1e-5}


def fit_step(trajectory: xr.Dataset, *, problem: Any, poisson: float | None = None
             ) -> xr.Dataset:
    """Fit the exact model's response to the trajectory's drive (``step`` model: tau, E0, E_inf).

    Identifiability by the local test (a profile would cost a simulation per evaluation).

    Levenberg–Marquardt with the exact Jacobian of the simulated force (forward sensitivities
    integrated with it: one simulation an iteration, :class:`~viscoforce.fitting.models.
    StepResponse`, which also repeats a step grid near where it was chosen), in two stages: a
    search on ``STEP_SEARCH_POINTS`` of the samples at ``STEP_SEARCH_TOL`` × simulate's default
    tolerance from the data's guess, then the fit of all samples at the default tolerance from
    the search's optimum. The reported curve, χ², stderr and
    correlations come from one more simulation at the optimum with the default adaptive steps
    (the exact model at the default accuracy), not from a repeated grid.
    """
    from viscoforce.solvers.simulate import DEFAULT_TOL

    data, trace = trajectory_data(trajectory)
    fixed = {"problem": problem, "position_trace": trace}
    search = None
    if isinstance(problem, ContactProblem):
        tol = STEP_SEARCH_TOL * DEFAULT_TOL * problem.surface_force.decay_length
        pick = np.unique(np.round(np.linspace(0, data.x.size - 1, STEP_SEARCH_POINTS)
                                  ).astype(int))
        coarse = dataclasses.replace(
            data, x=data.x[pick], y=data.y[pick],
            weights=None if data.weights is None else data.weights[pick],
            sigma_dof=None if data.sigma_dof is None else data.sigma_dof[pick])
        try:
            search = _fit_step_stage(coarse, fixed | {"tol": tol}, lm=STEP_SEARCH_LM)
        except ConvergenceError:
            search = None  # the fit starts from the data's guess instead
    start = {} if search is None else {"start": search.values}
    best = _fit_step_stage(data, fixed | start, final=True,
                           warm=None if search is None else search.model.response)
    ds = result_dataset(best, data, profile=False)
    ds.attrs["nfev"] = int(best.result.nfev) + (0 if search is None else int(search.result.nfev))
    ds.attrs["validity"] = validity_note("step", ds)
    warn_fit(ds)
    ds = add_derived_moduli(ds, poisson)
    return ds


def _fit_step_stage(data: FitData, fixed: dict[str, Any], *, final: bool = False,
                    warm: Any = None, lm: dict[str, float] | None = None) -> Outcome:
    """One least-squares fit of the step model with its exact Jacobian (lmfit leastsq + Dfun).

    ``final``: χ², residual and covariance at the optimum from a fresh adaptive simulation.
    ``warm``: a StepResponse whose last run gives the first run's Newton starts; ``lm``:
    tolerances of leastsq (default lmfit's).
    """
    import lmfit

    from viscoforce.fitting import _params
    from viscoforce.fitting.outcome import _outcome, _residual

    model = make_model("step", **fixed)
    if warm is not None:
        model.response.warm_from(warm)
    params = model.internal_guess(data.y, data.x).to_lmfit()  # lmfit minimises (Dfun)
    residual = _residual(model, data)
    weights = 1.0 if data.weights is None else np.asarray(data.weights, dtype=float)[:, None]

    def jacobian(params: lmfit.Parameters) -> np.ndarray:
        values, grads = _params.to_reported(model.layout, params.valuesdict())
        # ∂F/∂v = Σ_name ∂F/∂ln(name) · (∂name/∂v) / name
        gradient = model.response.log_gradient(data.x, values)
        columns = [sum(gradient[n] * (grads[n].get(v, 0.0) / values[n]) for n in model.names)
                   for v, p in params.items() if p.vary]
        return -weights * np.column_stack(columns)

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            res = lmfit.minimize(residual, params, method="leastsq", Dfun=jacobian,
                                 scale_covar=not data.sigma_known, **(lm or {}))
            if final:
                model.response.reuse_grid = False
                model.response.forget()
                _evaluate_at(res, residual(res.params), jacobian(res.params),
                             scale=not data.sigma_known)
    except (ValueError, ArithmeticError, ParameterError) as exc:
        raise ConvergenceError(f"model 'step' could not be fitted: {exc}") from None
    if not np.isfinite(res.chisqr):
        raise ConvergenceError("model 'step' could not be fitted: non-finite chi-square")
    return _outcome(model, res, data)


def _evaluate_at(res: Any, residual: np.ndarray, jac: np.ndarray, *, scale: bool) -> None:
    """Set lmfit's statistics of ``res`` from a residual and its Jacobian at ``res.params``.

    The formulas of lmfit's leastsq: χ², reduced χ², AIC/BIC from n ln(χ²/n), and the
    covariance (JᵀJ)⁻¹ of the varied parameters, times the reduced χ² when ``scale``.
    """
    n, k = residual.size, int(res.nvarys)
    res.residual = residual
    res.ndata, res.nfree = n, max(n - k, 1)
    res.chisqr = float(residual @ residual)
    res.redchi = res.chisqr / res.nfree
    neg2_log_likelihood = n * math.log(max(res.chisqr, 1e-250) / n)
    res.aic = neg2_log_likelihood + 2 * k
    res.bic = neg2_log_likelihood + math.log(n) * k
    try:
        cov = np.linalg.inv(jac.T @ jac) * (res.redchi if scale else 1.0)
    except np.linalg.LinAlgError:
        cov = None
    ok = cov is not None and bool(np.all(np.isfinite(cov)) and np.all(np.diag(cov) > 0))
    res.covar = cov if ok else None
    res.errorbars = ok
    for i, name in enumerate(res.var_names):
        res.params[name].stderr = float(np.sqrt(cov[i, i])) if ok else None
