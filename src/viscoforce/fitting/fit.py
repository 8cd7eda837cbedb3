"""Fit one spectrum or one force curve; choose the number of modes by an information criterion.

The spectrum residual is complex: real and imaginary parts of k*_model − k*_data, each weighted by
its standard error propagated from the data's ``stiffness_stderr`` and ``phase_stderr`` (radial and
tangential errors of k* = S e^{iχ}). Points whose ``quality`` flag is set are left out, and so
are points with a NaN (with a note).

Statistics follow from what the weights are (``attrs["weighting"]``):

- ``stderr`` — the data's own errors. The covariance is NOT rescaled by the reduced χ² (the
  errors are known), AIC = χ² + 2k and BIC = χ² + k ln n use χ² itself, and the χ² goodness-of-fit
  p-value (``chi2_pvalue``) is reported; below :data:`~viscoforce.fitting.verdict.PVALUE_WARN`
  the fit warns that the model does not describe these data
  (:class:`~viscoforce.exceptions.GoodnessOfFitWarning`). Points whose stderr is missing or zero
  get the median relative error of the others (a DataWarning names them).
- ``relative`` — every point weighted by 1/|k*| (a relative fit, so that a spectrum over decades
  of stiffness is not fitted at its stiffest end only). The errors are unknown: the covariance is
  scaled by the reduced χ² (lmfit's ``scale_covar``), AIC/BIC are lmfit's n ln(χ²/n) forms and
  there is no p-value. It is used when asked (``weights="relative"``) or, with a DataWarning,
  when the data carry no usable stderr.
- ``unweighted`` — force curves (relaxation, step, hertz, creep): as ``relative`` with unit
  weights; the stderr of measured curves are corrected for autocorrelated residuals.

Each single fit also profiles the parameters whose curvature can mislead
(:mod:`viscoforce.fitting.identify`; ``identifiability="profile"`` all of them): a parameter
whose likelihood is one-sided is reported as a bound, not as a value with an error.

This module selects the modes, builds the result dataset and holds the entry points
(:func:`fit_data`, :func:`fit_spectrum`); the pieces live beside it: what a fit sees
(:mod:`viscoforce.fitting.data`), one least-squares fit (:mod:`viscoforce.fitting.outcome`), the
warnings of a result (:mod:`viscoforce.fitting.verdict`), the model error of a spectrum fit
(:mod:`viscoforce.fitting.model_error`), the field's moduli (:mod:`viscoforce.fitting.moduli`)
and the theory's model choice (:mod:`viscoforce.fitting.auto`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.fitting import _params
from viscoforce.fitting.base import MAX_AUTO_MODES, MAX_MODES
from viscoforce.fitting.data import FitData, _data_indentation, spectrum_data
from viscoforce.fitting.identify import (
    IDENTIFIABILITY,
    QUADRATIC_CORRELATION,
    QUADRATIC_DECADES,
    needs_profile,
    quadratic_limits,
)
from viscoforce.fitting.model_error import (
    _warn_model_bias,
    svda_bias,
    validity_note,
    warn_contact_bias,
)
from viscoforce.fitting.models import MODELS, check_fixed, make_model
from viscoforce.fitting.moduli import add_derived_moduli, derived_attrs, derived_variables
from viscoforce.fitting.outcome import Outcome, fit_once, sorted_values, summary_stderr
from viscoforce.fitting.registry import entries
from viscoforce.fitting.report import attach
from viscoforce.fitting.selection import (
    CRITERIA,
    Candidate,
    Tried,
    check_criterion,
    compare,
    explain,
    halves_z,
    keep,
    mode_robustness,
)
from viscoforce.fitting.spectrum_models import svda_position
from viscoforce.fitting.verdict import warn_fit
from viscoforce.schema import make_fit_result, plain_variable

#: Points of the best-fit curve written with a spectrum fit.
FIT_CURVE_POINTS = 200
#: The log grid's exponents 0 … 1 of :func:`curve_omega` (from FIT_CURVE_POINTS, made once).
_CURVE_STEPS = np.linspace(0.0, 1.0, FIT_CURVE_POINTS)
_CURVE_STEPS.flags.writeable = False


def curve_omega(omega: np.ndarray) -> np.ndarray:
    """ω of a spectrum fit's best-fit curve [rad/s], sorted and unique.

    ``np.geomspace`` gives the same grid (to ~1e-14 relative) at 3× the cost of a small fit's
    curve.

    Parameters
    ----------
    omega : numpy.ndarray
        The data's ω [rad/s] (finite, > 0).

    Returns
    -------
    numpy.ndarray
        The data's ω and :data:`FIT_CURVE_POINTS` log-spaced from half the lowest to twice the
        highest, sorted, without repeats.
    """
    lo, hi = float(omega.min()) / 2, float(omega.max()) * 2
    grid = lo * (hi / lo) ** _CURVE_STEPS
    grid[-1] = hi
    return np.unique(np.concatenate((grid, omega)))


# ── results ─────────────────────────────────────────────────────────────────────────────────────

def local_identifiability(values: Mapping[str, float], stderr: Mapping[str, float | None],
                          at_bound: list[str]) -> dict[str, int]:
    """The local test: 3 (not determined) where stderr > |value|, none, or at a bound; else 0."""
    return {n: 3 if (stderr[n] is None or not math.isfinite(stderr[n])
                     or abs(stderr[n]) > abs(v) or n in at_bound) else 0
            for n, v in values.items()}


#: ``profile=`` of :func:`summary` and :func:`result_dataset`: every parameter (True), none
#: (False: the local test, no limits), or where the curvature can mislead ("auto":
#: :func:`viscoforce.fitting.identify.needs_profile`; the others get the curvature's ±2σ).
PROFILE_CHOICES = (True, False, "auto")


#: ``identifiability=`` of the single-fit functions → ``profile=``.
IDENTIFIABILITY_CHOICES = {"auto": "auto", "profile": True, "local": False}


def profile_choice(identifiability: Any) -> bool | str:
    """``profile=`` for ``identifiability`` (one of :data:`IDENTIFIABILITY_CHOICES`)."""
    if not isinstance(identifiability, str) or identifiability not in IDENTIFIABILITY_CHOICES:
        raise ParameterError(f"identifiability must be one of "
                             f"{', '.join(map(repr, IDENTIFIABILITY_CHOICES))}, got "
                             f"{identifiability!r}")
    return IDENTIFIABILITY_CHOICES[identifiability]


def summary(outcome: Outcome, *, profile: bool | str = False) -> dict[str, Any]:
    """Values, stderr, correlations, statistics and identifiability of a fit (SPEC names, SI).

    ``profile`` (:data:`PROFILE_CHOICES`) adds 2σ limits and identifiability codes from the
    profile likelihood (:mod:`viscoforce.fitting.identify`) of every parameter (True) or of the
    ones whose curvature can mislead ("auto"); otherwise the identifiability is the local test.
    """
    res, names = outcome.result, outcome.model.names
    values = dict(outcome.values)
    stderr = summary_stderr(outcome)
    if outcome.covariance is not None and all(e is not None for e in stderr.values()):
        sd = np.array([stderr[n] for n in names])
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = outcome.covariance / np.outer(sd, sd)
        np.fill_diagonal(corr, 1.0)
    else:
        corr = np.where(np.eye(len(names), dtype=bool), 1.0, np.nan)
    success = bool(res.success) and all(math.isfinite(v) for v in values.values())
    bound = _params.at_bound(res.params)
    at_bound = [n for n in names if n in bound]
    ident = local_identifiability(values, stderr, at_bound)
    lower = {n: math.nan for n in names}
    upper = dict(lower)
    profiled: list[str] = []
    if profile:
        layout = outcome.model.layout
        profiled = (list(names) if profile is True
                    else needs_profile(layout, values, stderr, corr, at_bound))
        limits = {**quadratic_limits(layout, values, stderr,
                                     [n for n in names if n not in profiled]),
                  **outcome.profile(profiled)}
        for n, prof in limits.items():
            ident[n], lower[n], upper[n] = prof.code, prof.lower, prof.upper
    return {"values": values, "stderr": stderr, "correlation": corr, "success": success,
            "redchi": float(res.redchi), "chisqr": float(res.chisqr), "dof": outcome.dof,
            "chi2_pvalue": outcome.pvalue, **outcome.criterion, "nfev": int(res.nfev),
            "at_bound": bound, "message": str(res.message), "weighting": outcome.data.weighting,
            "identifiability": ident, "lower": lower, "upper": upper,
            "notes": list(outcome.data.notes), "profiled": profiled}


def result_dataset(outcome: Outcome, data: FitData, *,
                   selection: list[dict[str, Any]] | None = None,
                   profile: bool | str = "auto") -> xr.Dataset:
    """The fit-result dataset (schema.fit) of one fit, with its best-fit curve.

    Besides the schema's variables: ``chi2_pvalue``, ``identifiability`` over ``param_i``
    (codes of :data:`viscoforce.fitting.identify.IDENTIFIABILITY`) and, with ``profile``
    (:data:`PROFILE_CHOICES`), ``<name>_lower`` / ``<name>_upper`` (the 2σ limits, NaN on an
    unbounded side) and ``profiled`` over ``param_i`` (1: the limits are the profile
    likelihood's; 0: the curvature's ±2σ); the derived moduli at ν = 0.5
    (:func:`~viscoforce.fitting.moduli.add_derived_moduli` re-derives them at another ν).
    """
    info = summary(outcome, profile=profile)
    model = outcome.model
    attrs: dict[str, Any] = {**data.source, "nfev": info["nfev"], "message": info["message"],
                             "at_bound": ", ".join(info["at_bound"]) or "none",
                             "weighting": info["weighting"], "chisqr": info["chisqr"],
                             "chisqr_calibrated": outcome.calibrated_chisqr,
                             "dof": info["dof"],
                             "identifiability_method": _method_text(profile, info["profiled"])}
    if info["notes"]:
        attrs["data_notes"] = "; ".join(info["notes"])
    if math.isfinite(outcome.lag1):
        attrs.update(residual_lag1=outcome.lag1, stderr_correction=outcome.stderr_factor,
                     effective_samples=float(outcome.n_effective or data.n_values),
                     stderr_method=(
                         "least squares scaled by the reduced chi-square, times "
                         "sqrt((1 + rho1)/(1 - rho1)) for AR(1) residuals of lag-1 "
                         "autocorrelation rho1; AIC/BIC with the effective sample size "
                         "n (1 - rho1)/(1 + rho1)"))
    attrs.update(_fixed_attrs(model.spec.fixed))
    curves: dict[str, Any]
    if model.independent == "omega":
        omega = curve_omega(data.x)
        k = outcome.evaluate(omega)
        curves = {"omega": omega, "fit_stiffness": np.abs(k), "fit_phase": np.degrees(np.angle(k))}
    elif model.independent == "z":
        z = sorted_values(data.x)
        curves = {"tip_position": z, "fit_approach_force": outcome.evaluate(z)}
    else:
        t = sorted_values(data.x)
        name = "fit_tip_position" if model.spec.name == "creep" else "fit_force"
        curves = {"time": t, name: outcome.evaluate(t)}
    extra = _statistics_variables(info, model.names, bool(profile))
    if selection:
        def per_candidate(key: str, long_name: str) -> xr.Variable:
            return plain_variable("candidate", [s[key] for s in selection],
                               {"units": "1", "long_name": long_name})

        extra.update(selection_modes=per_candidate("modes", "modes of the candidate"),
                     selection_aic=per_candidate("aic", "AIC of the candidate"),
                     selection_bic=per_candidate("bic", "BIC of the candidate"))
    from viscoforce.physics.tips import DEFAULT_POISSON

    params = {n: (info["values"][n], info["stderr"][n]) for n in model.names}
    extra.update(derived_variables(params, DEFAULT_POISSON))
    attrs.update(derived_attrs(DEFAULT_POISSON))
    return attach(make_fit_result(params,
                           correlation=info["correlation"], success=info["success"],
                           redchi=info["redchi"], aic=info["aic"], bic=info["bic"],
                           modes=model.spec.modes, model=model.spec.name, attrs=attrs,
                           extra=extra, fresh_extra=True, check=False, **curves), outcome)


def _statistics_variables(info: Mapping[str, Any], names: list[str],
                          limits: bool) -> dict[str, xr.Variable]:
    from viscoforce.schema.fit import parameter_units

    out = {"chi2_pvalue": plain_variable((), info["chi2_pvalue"], {
        "units": "1", "long_name": "chi-square goodness-of-fit p-value (NaN: stderr unknown)",
        "comment": "residuals whose stderr were estimated with nu degrees of freedom (the "
                   "lock-in's 2 x lockin_stderr_bins) enter as normal scores of their t_nu "
                   "tail probability"}),
        "identifiability": plain_variable(
            ("param_i",), np.array([info["identifiability"][n] for n in names], dtype=np.int8),
            {"long_name": "identifiability of the fitted parameter",
             "flag_values": np.array(list(IDENTIFIABILITY), dtype=np.int8),
             "flag_meanings": " ".join(IDENTIFIABILITY.values())})}
    if limits:
        out["profiled"] = plain_variable(
            ("param_i",), np.array([n in info["profiled"] for n in names], dtype=np.int8),
            {"units": "1", "long_name": "limits from the profile likelihood (1) or from the "
                                        "curvature, +-2 stderr in log10 for positive parameters (0)"})
        for n in names:
            unit = parameter_units(n)
            out[f"{n}_lower"] = plain_variable((), info["lower"][n], {
                "units": unit, "long_name": f"2-sigma lower limit of {n}"})
            out[f"{n}_upper"] = plain_variable((), info["upper"][n], {
                "units": unit, "long_name": f"2-sigma upper limit of {n}"})
    return out


def _method_text(profile: bool | str, profiled: Sequence[str]) -> str:
    """``attrs["identifiability_method"]``: how the codes and 2σ limits were found."""
    if not profile:
        return "local (stderr > value, none, or at a bound)"
    if profile is True:
        return "profile likelihood (2 sigma)"
    quadratic = (f"curvature (+-2 stderr, log10 for positive parameters) where the local 2 "
                 f"sigma spans <= {QUADRATIC_DECADES} decade and |correlation| <= "
                 f"{QUADRATIC_CORRELATION}")
    if not profiled:
        return quadratic
    return f"profile likelihood (2 sigma) of {', '.join(profiled)}; elsewhere {quadratic}"


def _fixed_attrs(fixed: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in fixed.items():
        if key == "problem":
            out.update({f"system_{k}": v for k, v in value.parameters().items()
                        if not k.startswith(("E", "tau", "delta", "material"))})
            out.update(tip_shape="paraboloid", tip_radius=float(value.sphere.radius),
                       tip="the paper's sphere (paraboloidal profile), R = "
                           f"{float(value.sphere.radius):.4g} m")
        elif key == "tip" and hasattr(value, "as_attrs"):
            out.update(value.as_attrs())
            out["tip"] = value.describe()
        elif isinstance(value, int | float | str) and not isinstance(value, bool):
            out[key] = value
    return out


# ── selection of the modes ──────────────────────────────────────────────────────────────────────

def _check_modes(name: str, modes: Any) -> int | str:
    if isinstance(modes, str) and modes == "auto":
        if name in MODELS and not MODELS[name].modal:
            raise ParameterError(f"modes='auto' needs a model with several modes "
                                 f"({', '.join(entries(modal=True))}), got {name!r}")
        return "auto"
    if isinstance(modes, bool) or not isinstance(modes, int | np.integer) or not (
            1 <= modes <= MAX_MODES):
        raise ParameterError(f"modes must be an integer in [1, {MAX_MODES}] or 'auto', got "
                             f"{modes!r}")
    return int(modes)


def select(data: FitData, name: str, *, modes: int | str = 1, criterion: str = "bic",
           max_modes: int = MAX_AUTO_MODES, **fixed: Any
           ) -> tuple[Outcome, list[dict[str, Any]]]:
    """The best fit of model ``name`` and the candidates tried (one unless ``modes="auto"``).

    ``"auto"`` fits 1, 2, … modes until the criterion has not improved twice in a row, the
    parameters would outnumber the data, or ``max_modes``; it keeps the lowest criterion (the
    one loop and rule of :mod:`viscoforce.fitting.selection`).
    """
    best, tried = select_tried(data, name, modes=modes, criterion=criterion,
                               max_modes=max_modes, **fixed)
    return best.outcome, [{"modes": t.modes, **t.outcome.criterion} for t in tried
                          if t.outcome is not None]


def select_tried(data: FitData, name: str, *, modes: int | str = 1, criterion: str = "bic",
                 max_modes: int = MAX_AUTO_MODES, **fixed: Any) -> tuple[Tried, list[Tried]]:
    """:func:`select` with the candidates as :class:`~viscoforce.fitting.selection.Tried`."""
    modes = _check_modes(name, modes)
    check_criterion(criterion)
    counts = range(1, max_modes + 1) if modes == "auto" else [modes]
    family = [Candidate(f"{n} mode{'s' if n > 1 else ''}",
                        lambda n=n: make_model(name, n, **fixed)) for n in counts]
    halves = name in MODELS and MODELS[name].data == "curve"  # a series in time: block halves

    def robust(outcome: Outcome) -> str | None:
        refit = (lambda d: fit_once(outcome.model, d, settle=False)) if halves else None
        return mode_robustness(outcome, refit)

    tried = compare([family], data, criterion, robust=robust)
    return keep(tried, criterion), tried


# ── public entry points ─────────────────────────────────────────────────────────────────────────

def fit_data(data: FitData, name: str, *, modes: int | str = 1, criterion: str = "bic",
             max_modes: int = MAX_AUTO_MODES, profile: bool | str = "auto",
             **fixed: Any) -> xr.Dataset:
    """Fit prepared data (:class:`~viscoforce.fitting.data.FitData`) with model ``name``.

    ``modes="auto"`` selects the number of modes.

    Parameters
    ----------
    data : FitData
        What the fit sees (:func:`~viscoforce.fitting.data.spectrum_data`,
        :func:`viscoforce.fitting.curves.hold_data`).
    name : str
        A model of :data:`viscoforce.fitting.registry.MODELS`.
    modes : int or "auto"
        Relaxation modes; "auto" tries 1, 2, … (:func:`select`).
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.
    max_modes : int
        Most modes "auto" tries.
    profile : bool or "auto"
        Profile-likelihood identifiability of the kept fit (:data:`PROFILE_CHOICES`; default
        "auto": the parameters whose curvature can mislead; False: the local test).
    **fixed
        The model's fixed inputs (:func:`viscoforce.fitting.models.make_model`).

    Returns
    -------
    xarray.Dataset
        The fit result (:func:`result_dataset`).
    """
    kept, tried = select_tried(data, name, modes=modes, criterion=criterion,
                               max_modes=max_modes, **fixed)
    best = kept.outcome
    selection = [{"modes": t.modes, **t.outcome.criterion} for t in tried if t.outcome]
    ds = result_dataset(best, data, selection=selection if modes == "auto" else None,
                        profile=profile)
    if modes == "auto":
        ds.attrs["criterion"] = criterion
        ds.attrs["explanation"] = explain(tried, kept, criterion, 0.0,
                                          f"modes of model {name!r}").explanation
        if best.model.spec.modes == max(row["modes"] for row in selection) >= max_modes:
            ds.attrs["selection_note"] = (
                f"the {criterion.upper()} still improved at the largest number of modes tried "
                f"({max_modes}): more modes may describe these data better")
    if name in MODELS and MODELS[name].data == "curve" and MODELS[name].modal:
        _check_halves(ds, best)
    return ds


#: |z| of a parameter between the two block halves above which the stderr are said to understate
#: the scatter of the data (3: a 0.3 % false alarm per parameter for honest Gaussian stderr).
HALVES_WARN_Z = 3.0


def _check_halves(ds: xr.Dataset, best: Outcome) -> None:
    """The kept curve fit's stderr against its two block halves (issue 37 item 4), in place.

    ``attrs["split_half_z"]`` is the largest |a − b|/√(σa² + σb²) over the parameters fitted on
    the two halves (:func:`~viscoforce.fitting.selection.block_halves`); above
    :data:`HALVES_WARN_Z` a GoodnessOfFitWarning names the parameter.
    """
    import warnings

    from viscoforce.exceptions import ConvergenceError, GoodnessOfFitWarning

    # one mode: one minimum, so each half starts at the whole's (the same fit in a few
    # evaluations); several: each half from its own guess, as a robustness check refits them (a
    # half may find other modes, which is what the check is for)
    start = best.values if best.model.spec.modes == 1 else None
    try:
        z = halves_z(best, lambda d: fit_once(best.model, d, settle=False,
                                              starts=1 if start else 2, start=start))
    except (ConvergenceError, ParameterError) as exc:
        ds.attrs["split_half_check"] = f"not made: a half could not be fitted ({exc})"
        return
    finite = {n: v for n, v in z.items() if math.isfinite(v)}
    if not finite:
        return
    worst = max(finite, key=lambda n: abs(finite[n]))
    ds.attrs["split_half_z"] = abs(finite[worst])
    ds.attrs["split_half_check"] = "; ".join(f"{n} {v:+.1f}" for n, v in finite.items()) + (
        " standard errors between the two halves of the data (alternate blocks)")
    if abs(finite[worst]) > HALVES_WARN_Z:
        warnings.warn(
            f"the two halves of the data give {worst} {finite[worst]:+.1f} standard errors apart: "
            "the stated stderr understate the scatter of these data (the model may miss "
            "structure: drift, a controller's overshoot, more or fewer modes)",
            GoodnessOfFitWarning, stacklevel=4)


#: The choosers of model ``"auto"``, registered by the modules that define them (they fit through
#: this module, so it does not import them): ``"theory"``
#: (:func:`viscoforce.fitting.auto.fit_spectrum_auto`, a position or mean force given) and
#: ``"measured"`` (:func:`viscoforce.fitting.measured.fit_measured_auto`). Importing
#: :mod:`viscoforce.fitting` registers both.
AUTO_CHOOSERS: dict[str, Callable[..., xr.Dataset]] = {}


def fit_spectrum(spectrum: xr.Dataset, model: str, *, modes: int | str | None = None,
                 criterion: str = "bic", accuracy: float | None = None,
                 weights: str | None = None, poisson: float | None = None,
                 identifiability: str = "auto", **fixed: Any) -> xr.Dataset:
    """Fit one spectrum (over ``omega``) with a spectrum model.

    Parameters
    ----------
    spectrum : xarray.Dataset
        A spectrum (:mod:`viscoforce.schema.spectrum`) over ``omega`` only.
    model : str
        ``svda``, ``exact``, ``contact``, ``prony``, or ``auto``. With ``position`` or
        ``mean_force`` (the theory's system), ``auto`` is the cheapest of svda, contact and exact
        whose model error, estimated at the fitted parameters, meets ``accuracy`` (needs
        ``problem``). Without them (measured data: an indentation from the data or
        ``indentation``), ``auto`` compares the contact materials sls, prony n, power-law (with
        and without a Newtonian term) and structural by the criterion
        (:func:`viscoforce.fitting.measured.fit_measured_auto`). The reason is in
        ``attrs["explanation"]``.
    modes : int or "auto", optional
        Relaxation modes; ``"auto"`` tries 1, 2, … and keeps the lowest ``criterion``. Default
        1 (``"auto"`` for the measured-data chooser).
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.
    accuracy : float, optional
        Required relative model error of ``model="auto"`` (default 1e-3); only with "auto"
        and a position or mean force.
    weights : {"stderr", "relative"}, optional
        Weights of the residual (module docstring); default: the data's stderr when present,
        else relative with a DataWarning.
    poisson : float, optional
        The sample's Poisson's ratio in [0, 0.5] (default 0.5) of the derived Young's and shear
        moduli (:func:`~viscoforce.fitting.moduli.add_derived_moduli`).
    identifiability : {"auto", "profile", "local"}
        How each parameter's identifiability codes and 2σ limits ``<name>_lower``/``_upper``
        are found: "auto" (default) walks the profile likelihood of the parameters whose
        curvature can mislead (not determined by the local test, a local 2σ wider than 0.1
        decade, or correlated beyond 0.98: :func:`viscoforce.fitting.identify.needs_profile`)
        and takes ±2σ of the curvature for the others; "profile" walks every parameter (several
        refits each); "local" only the local test (no limits).
    **fixed
        The model's fixed inputs (see :func:`viscoforce.fitting.models.make_model`); for
        ``contact`` the ``indentation`` defaults to the data's median ``mean_indentation``.

    Returns
    -------
    xarray.Dataset
        Fit result (:mod:`viscoforce.schema.fit`); with ``"auto"`` also ``selection_modes``,
        ``selection_aic``, ``selection_bic`` over ``candidate``.
    """
    profile = profile_choice(identifiability)
    if model == "auto":
        if fixed.get("position") is None and fixed.get("mean_force") is None:
            if accuracy is not None:
                raise ParameterError(
                    "accuracy chooses between the theory's approximations (with position or "
                    "mean_force, --h0/--mean-force); on measured data model 'auto' compares "
                    "materials by the criterion instead: leave accuracy out")
            return add_derived_moduli(AUTO_CHOOSERS["measured"](
                spectrum, modes="auto" if modes is None else modes, criterion=criterion,
                weights=weights, profile=profile, **fixed), poisson)
        return add_derived_moduli(AUTO_CHOOSERS["theory"](
            spectrum, modes=1 if modes is None else modes, criterion=criterion,
            accuracy=accuracy, weights=weights, profile=profile, **fixed), poisson)
    modes = _check_modes(model, 1 if modes is None else modes) if model in MODELS else 1
    if criterion not in CRITERIA:
        raise ParameterError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
    if accuracy is not None:
        raise ParameterError(f"accuracy applies to model 'auto' only, not {model!r}")
    if model not in entries(data="spectrum"):
        raise ParameterError(f"model {model!r} fits force curves, not spectra; spectrum models: "
                             f"{', '.join(entries(data='spectrum'))} (or auto)")
    fixed = check_fixed(model, fixed)
    data = spectrum_data(spectrum, weights=weights)
    if model == "contact" and fixed.get("indentation") is None:
        fixed["indentation"] = _data_indentation(spectrum, data)
    if model in ("svda", "exact") and fixed.get("position") is None and fixed.get(
            "mean_force") is None:
        mean = float(np.nanmedian(spectrum["mean_force"].values))
        raise ParameterError(
            f"model {model!r} needs the mean position: give h0 (--h0) or the mean force "
            f"(--mean-force; this spectrum's median mean_force is {mean:.4g} N)")
    decay = fixed.pop("debye_length", None) if model == "contact" else None
    ds = fit_data(data, model, modes=modes, criterion=criterion, profile=profile, **fixed)
    if model == "svda":
        h0 = fixed.get("position")
        if h0 is None:
            h0 = svda_position(fixed["mean_force"], float(ds["E_inf"]), fixed["radius"],
                               fixed["P"], fixed["debye_length"])
        _warn_model_bias(ds, model, *svda_bias(ds, spectrum, h0, fixed["radius"], fixed["P"],
                                               fixed["debye_length"]))
    if model == "contact":  # without a decay length: the paper's, and said so
        warn_contact_bias(ds, fixed, data.x, decay)
    ds.attrs["validity"] = validity_note(model, ds)
    warn_fit(ds)
    # result_dataset derived the moduli at the default ν already
    return ds if poisson is None else add_derived_moduli(ds, poisson)
