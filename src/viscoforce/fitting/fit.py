"""Fit one spectrum or one force curve; choose the number of modes by an information criterion.

The spectrum residual is complex: real and imaginary parts of k*_model − k*_data, each weighted by
its standard error propagated from the data's ``stiffness_stderr`` and ``phase_stderr`` (radial and
tangential errors of k* = S e^{iχ}); without them every point is weighted by 1/|k*| (a relative
fit, so that a spectrum over decades of stiffness is not fitted at its stiffest end only).
Points whose ``quality`` flag is set are left out. lmfit scales the covariance by the reduced
chi-square (its default), so the stderr are honest when the data's errors are not.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import lmfit
import numpy as np
import xarray as xr

from viscoforce.choice import (
    DEFAULT_ACCURACY,
    GRID_ERROR,
    WARN_ERROR,
    contact_error,
    double_layer,
    finish,
    hertz_error,
    meets,
    require_accuracy,
    svda_error,
)
from viscoforce.exceptions import (
    AccuracyWarning,
    ApproximationWarning,
    ConvergenceError,
    ModelValidityError,
    ParameterError,
)
from viscoforce.fitting import _params
from viscoforce.fitting.models import (
    MAX_AUTO_MODES,
    MAX_MODES,
    MODAL_MODELS,
    SPECTRUM_MODELS,
    FitModel,
    check_fixed,
    make_model,
    material_from,
    svda_position,
)
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_fit_result, validate_spectrum
from viscoforce.svda import svda_error_estimate, svda_stiffness_kernel

#: Information criteria of ``modes="auto"`` (``--criterion``).
CRITERIA = ("bic", "aic")
#: Points of the best-fit curve written with a spectrum fit.
FIT_CURVE_POINTS = 200


@dataclass(frozen=True)
class FitData:
    """What a fit sees: x (ω [rad/s] or t [s]), y (k* [N/m] or F [N]) and weights."""

    x: np.ndarray
    y: np.ndarray
    weights: np.ndarray | None
    source: Mapping[str, Any]

    @property
    def n_values(self) -> int:
        """Real numbers fitted (2 per complex point)."""
        return self.y.size * (2 if np.iscomplexobj(self.y) else 1)


# ── data ────────────────────────────────────────────────────────────────────────────────────────

def spectrum_data(ds: xr.Dataset) -> FitData:
    """ω, k* and weights of one spectrum (1-D over ``omega``), flagged points left out.

    Raises
    ------
    ParameterError
        Extra dims, NaN or negative stiffness on a point not flagged, every point flagged.
    """
    validate_spectrum(ds, require=("stiffness", "phase"))
    extra = [d for d in ds["stiffness"].dims if d != "omega"]
    if extra:
        raise ParameterError(f"one spectrum is over 'omega' only; this one also has {extra} "
                             "(fit it as a map, or select one)")
    arrays = spectrum_arrays(ds, ())
    source = {"data_kind": "spectrum"}
    if "source" in ds.attrs:
        source["data_source"] = str(ds.attrs["source"])
    return pixel_fit_data(np.asarray(ds["omega"].values, dtype=float),
                          {k: v[0] for k, v in arrays.items()}, source)


def spectrum_arrays(ds: xr.Dataset, dims: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The spectrum's variables as (pixel, omega) arrays (pixels in C order over ``dims``).

    Keys: ``stiffness``, ``phase`` [rad], ``stiffness_stderr``, ``phase_stderr`` [rad] (NaN when
    absent), ``quality`` (0 when absent), ``mean_indentation`` (NaN when absent).
    """
    order = (*dims, "omega")
    n_omega = ds.sizes["omega"]

    def grab(name: str, fill: float) -> np.ndarray:
        if name not in ds.variables:
            return np.full((int(np.prod([ds.sizes[d] for d in dims])), n_omega), fill)
        da = ds[name]
        da = da.broadcast_like(ds["stiffness"]).transpose(*order)
        return np.asarray(da.values, dtype=float).reshape(-1, n_omega)

    out = {"stiffness": grab("stiffness", np.nan), "phase": np.radians(grab("phase", np.nan)),
           "stiffness_stderr": grab("stiffness_stderr", np.nan),
           "phase_stderr": np.radians(grab("phase_stderr", np.nan)),
           "quality": grab("quality", 0.0), "mean_indentation": grab("mean_indentation", np.nan)}
    return out


def pixel_fit_data(omega: np.ndarray, a: Mapping[str, np.ndarray],
                   source: Mapping[str, Any]) -> FitData:
    """FitData of one pixel's arrays (see :func:`spectrum_arrays`), with the checks of one spectrum."""
    stiffness, phase = a["stiffness"], a["phase"]
    keep = a["quality"] == 0
    if not keep.any():
        raise ParameterError(f"every one of the {omega.size} spectrum points is flagged in "
                             "'quality' (see its comment): nothing to fit; correct the phase "
                             "lag (load --phase-lag) or inspect the data")
    bad = keep & ~(np.isfinite(stiffness) & np.isfinite(phase))
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ParameterError(f"stiffness or phase is NaN/inf at omega = {omega[i]:.4g} rad/s "
                             f"(point {i}) and the point is not flagged")
    negative = keep & (stiffness <= 0)
    if negative.any():
        i = int(np.flatnonzero(negative)[0])
        raise ParameterError(f"stiffness must be > 0 N/m, got {stiffness[i]!r} at omega = "
                             f"{omega[i]:.4g} rad/s (point {i})")
    k = stiffness * np.exp(1j * phase)
    weights = None
    s_err, p_err = a["stiffness_stderr"], a["phase_stderr"]
    if np.isfinite(s_err[keep]).any() or np.isfinite(p_err[keep]).any():
        p_err = np.where(np.isfinite(p_err), p_err, s_err / stiffness)
        s_err = np.where(np.isfinite(s_err), s_err, p_err * stiffness)
        c, s = np.cos(phase), np.sin(phase)
        sig_re = np.sqrt((c * s_err) ** 2 + (stiffness * s * p_err) ** 2)
        sig_im = np.sqrt((s * s_err) ** 2 + (stiffness * c * p_err) ** 2)
        usable = np.isfinite(sig_re) & np.isfinite(sig_im) & (sig_re > 0) & (sig_im > 0)
        if usable[keep].all():
            weights = 1.0 / sig_re + 1j / sig_im
    if weights is None:
        weights = (1.0 + 1j) / np.abs(k)
    info = {**source, "data_points": int(keep.sum()), "data_flagged": int((~keep).sum())}
    depth = a["mean_indentation"]
    if np.isfinite(depth).any():
        info["mean_indentation"] = float(np.nanmedian(depth))
    return FitData(omega[keep], k[keep], weights[keep], info)


# ── one fit ─────────────────────────────────────────────────────────────────────────────────────

@dataclass
class Outcome:
    """One fit: the model, its best SPEC values, their covariance and lmfit's result.

    The minimiser varies the internal parameters only (``log_…``, see
    :mod:`viscoforce.fitting._params`); the SPEC values and their covariance follow from them
    exactly (J C Jᵀ with the analytic Jacobian of the transform), which avoids evaluating lmfit
    expressions on every residual call (they cost more than the models themselves).
    """

    model: FitModel
    result: lmfit.minimizer.MinimizerResult
    values: dict[str, float]
    covariance: np.ndarray | None

    @property
    def criterion(self) -> dict[str, float]:
        """AIC and BIC of the fit."""
        return {"aic": float(self.result.aic), "bic": float(self.result.bic)}

    def evaluate(self, x: np.ndarray) -> np.ndarray:
        """The best-fit model over ``x`` (ω or t)."""
        return self.model.raw(np.asarray(x, dtype=float), self.values)


def _residual(model: FitModel, data: FitData):
    func, layout, x, y = model.raw, model.layout, data.x, data.y
    weights = None if data.weights is None else (
        data.weights.view(float) if np.iscomplexobj(data.weights) else data.weights)

    def residual(params: lmfit.Parameters) -> np.ndarray:
        values, _ = _params.to_reported(layout, params.valuesdict())
        diff = np.asarray(y - func(x, values))
        if np.iscomplexobj(diff):
            diff = diff.view(float)
        if weights is not None:
            diff = diff * weights
        if not np.all(np.isfinite(diff)):
            raise ArithmeticError("the model gave NaN or inf at these parameters")
        return diff

    return residual


def _outcome(model: FitModel, res: lmfit.minimizer.MinimizerResult) -> Outcome:
    values, grads = _params.to_reported(model.layout, res.params.valuesdict())
    cov = None
    if res.errorbars and res.covar is not None and np.all(np.isfinite(res.covar)):
        jac = np.array([[grads[n].get(v, 0.0) for v in res.var_names] for n in model.names])
        cov = jac @ res.covar @ jac.T
    return Outcome(model, res, {n: values[n] for n in model.names}, cov)


def fit_once(model: FitModel, data: FitData, *, starts: int = 2) -> Outcome:
    """Least-squares fit of ``model`` from its data-driven guess (and ``starts`` − 1 more).

    Raises
    ------
    ParameterError
        Fewer data values than free parameters.
    ConvergenceError
        No start gave a finite fit.
    """
    first = model.internal_guess(data.y, data.x)
    n_free = sum(1 for p in first.values() if p.vary)
    if data.n_values <= n_free:
        raise ParameterError(
            f"model {model.spec.name!r} with {model.spec.modes} mode(s) has {n_free} free "
            f"parameters but the data give only {data.n_values} values "
            f"({data.y.size} points): fit fewer modes or measure more points")
    residual = _residual(model, data)
    best: Outcome | None = None
    errors: list[str] = []
    for params in [first, *_alternative_starts(model, first, starts - 1)]:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                res = lmfit.minimize(residual, params, method="leastsq")
        except (ValueError, ArithmeticError, ParameterError, ConvergenceError) as exc:
            errors.append(str(exc).splitlines()[0])
            continue
        if not np.isfinite(res.chisqr):
            errors.append("non-finite chi-square")
            continue
        if best is None or res.chisqr < best.result.chisqr:
            best = _outcome(model, res)
    if best is None:
        raise ConvergenceError(f"model {model.spec.name!r} could not be fitted from any start: "
                               + "; ".join(errors[:3]))
    return best


def _alternative_starts(model: FitModel, first: lmfit.Parameters,
                        count: int) -> list[lmfit.Parameters]:
    """More starts for several modes: the relaxation times spread wider, or closer."""
    if count <= 0 or model.spec.modes == 1:
        return []
    out = []
    for factor in (2.5, 0.4)[:count]:
        params = first.copy()
        for name, p in params.items():
            if name.startswith("log_tau_") and name != "log_tau_1" and p.vary:
                p.set(value=min(max(p.value * factor, p.min), p.max))
        out.append(params)
    return out


# ── results ─────────────────────────────────────────────────────────────────────────────────────

def summary(outcome: Outcome) -> dict[str, Any]:
    """Values, stderr, correlations and statistics of a fit (SPEC names, SI)."""
    res, names = outcome.result, outcome.model.names
    values = dict(outcome.values)
    corr = np.where(np.eye(len(names), dtype=bool), 1.0, np.nan)
    stderr: dict[str, float | None] = {n: None for n in names}
    if outcome.covariance is not None:
        var = np.diag(outcome.covariance)
        if np.all(var >= 0):
            sd = np.sqrt(var)
            stderr = {n: float(e) for n, e in zip(names, sd, strict=True)}
            with np.errstate(invalid="ignore", divide="ignore"):
                corr = outcome.covariance / np.outer(sd, sd)
            np.fill_diagonal(corr, 1.0)
    success = bool(res.success) and all(math.isfinite(v) for v in values.values())
    return {"values": values, "stderr": stderr, "correlation": corr, "success": success,
            "redchi": float(res.redchi), "aic": float(res.aic), "bic": float(res.bic),
            "nfev": int(res.nfev), "at_bound": _params.at_bound(res.params),
            "message": str(res.message)}


def result_dataset(outcome: Outcome, data: FitData, *,
                   selection: list[dict[str, Any]] | None = None) -> xr.Dataset:
    """The fit-result dataset (schema.fit) of one fit, with its best-fit curve."""
    info = summary(outcome)
    model = outcome.model
    attrs: dict[str, Any] = {**data.source, "nfev": info["nfev"], "message": info["message"],
                             "at_bound": ", ".join(info["at_bound"]) or "none"}
    attrs.update(_fixed_attrs(model.spec.fixed))
    curves: dict[str, Any]
    if model.independent == "omega":
        lo, hi = float(np.min(data.x)), float(np.max(data.x))
        omega = np.geomspace(lo / 2, hi * 2, FIT_CURVE_POINTS)
        k = outcome.evaluate(omega)
        curves = {"omega": omega, "fit_stiffness": np.abs(k), "fit_phase": np.degrees(np.angle(k))}
    else:
        t = np.sort(data.x)
        curves = {"time": t, "fit_force": outcome.evaluate(t)}
    ds = make_fit_result({n: (info["values"][n], info["stderr"][n]) for n in model.names},
                         correlation=info["correlation"], success=info["success"],
                         redchi=info["redchi"], aic=info["aic"], bic=info["bic"],
                         modes=model.spec.modes, model=model.spec.name, attrs=attrs, **curves)
    if selection:
        ds = ds.assign(
            selection_modes=("candidate", [s["modes"] for s in selection],
                             {"units": "1", "long_name": "modes of the candidate"}),
            selection_aic=("candidate", [s["aic"] for s in selection],
                           {"units": "1", "long_name": "AIC of the candidate"}),
            selection_bic=("candidate", [s["bic"] for s in selection],
                           {"units": "1", "long_name": "BIC of the candidate"}))
    return ds


def _fixed_attrs(fixed: Mapping[str, Any]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in fixed.items():
        if key == "problem":
            out.update({f"system_{k}": v for k, v in value.parameters().items()
                        if not k.startswith(("E", "tau", "delta", "material"))})
        elif isinstance(value, int | float | str) and not isinstance(value, bool):
            out[key] = value
    return out


# ── public entry points ─────────────────────────────────────────────────────────────────────────

def _check_modes(name: str, modes: Any) -> int | str:
    if isinstance(modes, str) and modes == "auto":
        if name not in MODAL_MODELS:
            raise ParameterError(f"modes='auto' needs a model with several modes "
                                 f"({', '.join(MODAL_MODELS)}), got {name!r}")
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
    parameters would outnumber the data, or ``max_modes``; it keeps the lowest criterion.
    """
    modes = _check_modes(name, modes)
    if criterion not in CRITERIA:
        raise ParameterError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
    if modes != "auto":
        outcome = fit_once(make_model(name, modes, **fixed), data)
        return outcome, [{"modes": modes, **outcome.criterion}]
    outcomes: list[Outcome] = []
    worse = 0
    for n in range(1, max_modes + 1):
        model = make_model(name, n, **fixed)
        if len(model.names) >= data.n_values:  # one internal parameter per SPEC name
            break
        try:
            outcomes.append(fit_once(model, data))
        except ConvergenceError:
            if not outcomes:
                raise
            break
        scores = [o.criterion[criterion] for o in outcomes]
        worse = worse + 1 if len(scores) > 1 and scores[-1] >= min(scores[:-1]) else 0
        if worse >= 2:
            break
    best = min(outcomes, key=lambda o: o.criterion[criterion])
    return best, [{"modes": o.model.spec.modes, **o.criterion} for o in outcomes]


def fit_data(data: FitData, name: str, *, modes: int | str = 1, criterion: str = "bic",
             max_modes: int = MAX_AUTO_MODES, **fixed: Any) -> xr.Dataset:
    """Fit prepared data (:class:`FitData`) with model ``name``; ``modes="auto"`` selects."""
    best, selection = select(data, name, modes=modes, criterion=criterion, max_modes=max_modes,
                             **fixed)
    ds = result_dataset(best, data, selection=selection if modes == "auto" else None)
    if modes == "auto":
        ds.attrs["criterion"] = criterion
        if best.model.spec.modes == max(row["modes"] for row in selection) >= max_modes:
            ds.attrs["selection_note"] = (
                f"the {criterion.upper()} still improved at the largest number of modes tried "
                f"({max_modes}): more modes may describe these data better")
    return ds


def warn_unidentified(ds: xr.Dataset, *, stacklevel: int = 3) -> list[str]:
    """Warn (AccuracyWarning) about fitted parameters the data do not determine; return them.

    A parameter whose stderr exceeds its value, or has none (the covariance is singular), is
    not identified by the data: its value may be anything (e.g. the moduli of a spectrum far
    before contact, where the viscoelastic part of k* is below the noise).
    """
    names = [str(n) for n in ds["param_i"].values]
    bad = [n for n in names
           if not np.isfinite(float(ds[f"{n}_stderr"])) or
           abs(float(ds[f"{n}_stderr"])) > abs(float(ds[n]))]
    if bad:
        shown = ", ".join(f"{n} = {float(ds[n]):.4g} ± {float(ds[f'{n}_stderr']):.3g}"
                          for n in bad)
        warnings.warn(
            f"the data do not determine {', '.join(bad)} (stderr above the value, or none): "
            f"{shown}; fix it, fit fewer parameters, or measure where the spectrum depends on it",
            AccuracyWarning, stacklevel=stacklevel)
    return bad


def fit_spectrum(spectrum: xr.Dataset, model: str, *, modes: int | str = 1,
                 criterion: str = "bic", accuracy: float | None = None,
                 **fixed: Any) -> xr.Dataset:
    """Fit one spectrum (over ``omega``) with a spectrum model.

    Parameters
    ----------
    spectrum : xarray.Dataset
        A spectrum (:mod:`viscoforce.schema.spectrum`) over ``omega`` only.
    model : str
        ``svda``, ``exact``, ``contact``, ``prony``, or ``auto``: the cheapest of svda, contact
        and exact whose model error, estimated at the fitted parameters, meets ``accuracy``
        (needs ``problem`` and ``position`` or ``mean_force``; the reason in
        ``attrs["explanation"]``).
    modes : int or "auto"
        Relaxation modes; ``"auto"`` tries 1, 2, … and keeps the lowest ``criterion``.
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.
    accuracy : float, optional
        Required relative model error of ``model="auto"`` (default 1e-3); only with "auto".
    **fixed
        The model's fixed inputs (see :func:`viscoforce.fitting.models.make_model`); for
        ``contact`` the ``indentation`` defaults to the data's median ``mean_indentation``.

    Returns
    -------
    xarray.Dataset
        Fit result (:mod:`viscoforce.schema.fit`); with ``"auto"`` also ``selection_modes``,
        ``selection_aic``, ``selection_bic`` over ``candidate``.
    """
    if model == "auto":
        return fit_spectrum_auto(spectrum, modes=modes, criterion=criterion,
                                 accuracy=accuracy, **fixed)
    if accuracy is not None:
        raise ParameterError(f"accuracy applies to model 'auto' only, not {model!r}")
    if model not in SPECTRUM_MODELS:
        raise ParameterError(f"model {model!r} fits force curves, not spectra; spectrum models: "
                             f"{', '.join(SPECTRUM_MODELS)} (or auto)")
    fixed = check_fixed(model, fixed)
    data = spectrum_data(spectrum)
    if model == "contact" and fixed.get("indentation") is None:
        fixed["indentation"] = _data_indentation(spectrum)
    if model in ("svda", "exact") and fixed.get("position") is None and fixed.get(
            "mean_force") is None:
        mean = float(np.nanmedian(spectrum["mean_force"].values))
        raise ParameterError(
            f"model {model!r} needs the mean position: give h0 (--h0) or the mean force "
            f"(--mean-force; this spectrum's median mean_force is {mean:.4g} N)")
    decay = fixed.pop("debye_length", None) if model == "contact" else None
    ds = fit_data(data, model, modes=modes, criterion=criterion, **fixed)
    if model == "svda":
        h0 = fixed.get("position")
        if h0 is None:
            h0 = svda_position(fixed["mean_force"], float(ds["E_inf"]), fixed["radius"],
                               fixed["P"], fixed["debye_length"])
        _warn_model_bias(ds, model, *svda_bias(ds, spectrum, h0, fixed["radius"], fixed["P"],
                                               fixed["debye_length"]))
    if model == "contact" and decay is not None and modes == 1 and (
            fixed.get("material", "sls") == "sls"):
        _warn_model_bias(ds, model, *hertz_error(_sls_of(ds), fixed["indentation"], decay,
                                                 float(np.max(spectrum["omega"]))))
    warn_unidentified(ds)
    return ds


def svda_bias(ds: xr.Dataset, spectrum: xr.Dataset, position: float, radius: float,
              P: float, debye_length: float) -> tuple[float, str]:  # noqa: N803
    """Estimated relative bias of an svda fit's moduli and the reason.

    A stiffness error δ (0.6 κ|u0| at the fitted E_inf, :func:`viscoforce.svda.svda_error_estimate`)
    biases the moduli by ≈ δ / s, s = |∂ln k*/∂ln E| (E0, E_inf scaled together), which is small
    before contact: the SVDA error is O(κ|u0|) and so is s.
    """
    values = {n: float(ds[n]) for n in ("E0", "E_inf", "tau")}
    error = float(svda_error_estimate(position, values["E_inf"], radius, P, debye_length))
    omega = np.asarray(spectrum["omega"].values, dtype=float)
    kernel = (position, values["E0"], values["E_inf"], values["tau"], radius, P)
    k = svda_stiffness_kernel(omega, *kernel, 1.0 / debye_length)
    scaled = (position, *(v * (1 + SENSITIVITY_STEP) for v in kernel[1:3]), *kernel[3:])
    k_up = svda_stiffness_kernel(omega, *scaled, 1.0 / debye_length)
    sensitivity = float(np.max(np.abs(k_up / k - 1.0))) / SENSITIVITY_STEP
    return error / sensitivity, (
        f"stiffness error 0.6 kappa|u0| ~{error:.1e} over the moduli sensitivity "
        f"|dln k*/dln E| = {sensitivity:.2g} at the fitted E_inf = {values['E_inf']:.3g} Pa")


def _warn_model_bias(ds: xr.Dataset, model: str, bias: float, reason: str) -> None:
    """Warn (ApproximationWarning) when a fit's estimated model bias exceeds 1 %."""
    ds.attrs["estimated_model_error"] = bias
    if bias > WARN_ERROR:
        lead = "the SVDA is about" if model == "svda" else "Hertz contact is about"
        warnings.warn(
            f"{lead} {100 * bias:.2g} % off as a model of these data: the fitted moduli are "
            f"biased by about that much ({reason}); use model 'exact' (or 'auto')",
            ApproximationWarning, stacklevel=3)


def _sls_of(ds: xr.Dataset):
    """The standard linear solid of a one-mode fit result."""
    return material_from({n: float(ds[n]) for n in ("E0", "E_inf", "tau")}, 1)


#: Relative step of the moduli sensitivity of an svda fit (its bias estimate).
SENSITIVITY_STEP = 1e-4
#: The models ``model="auto"`` chooses from, in order of cost.
AUTO_MODELS = ("svda", "contact", "exact")


def _auto_candidate(spectrum: xr.Dataset, name: str, modes: int | str, criterion: str,
                    problem: ContactProblem, fixed: Mapping[str, Any]
                    ) -> tuple[xr.Dataset | None, float, str]:
    """Fit one candidate of ``model="auto"``: (result or None, estimated model error, reason)."""
    position, mean_force = fixed.get("position"), fixed.get("mean_force")
    radius = problem.sphere.radius
    if name == "svda":
        if modes != 1:
            return None, math.inf, f"one relaxation time only, modes={modes!r} asked"
        layer = double_layer(problem)
        if layer is None or problem.material.prony().n_modes != 1:
            return None, math.inf, "needs one relaxation time and exactly one DoubleLayer term"
        # applicability only (pre-contact); the value is re-estimated at the fitted moduli below
        error, reason = svda_error(problem, position) if position is not None else (0.0, "")
        if math.isinf(error):
            return None, error, reason
        try:
            ds = fit_data(spectrum_data(spectrum), "svda", position=position,
                          mean_force=mean_force, radius=radius, P=layer.P,
                          debye_length=layer.debye_length)
        except (ModelValidityError, ConvergenceError) as exc:
            return None, math.inf, f"fit failed: {str(exc).split(';')[0]}"
        e_inf = float(ds["E_inf"])
        h0 = position if position is not None else svda_position(
            mean_force, e_inf, radius, layer.P, layer.debye_length)
        return (ds, *svda_bias(ds, spectrum, h0, radius, layer.P, layer.debye_length))
    if name == "contact":
        depth = -position if position is not None else None
        if modes != 1:
            return None, math.inf, (f"one relaxation time here, modes={modes!r} asked (model "
                                    "'contact' with material='prony' fits more)")
        if depth is None or not depth > 0:
            return None, math.inf, "needs an indentation (a position h0 < 0)"
        try:
            ds = fit_data(spectrum_data(spectrum), "contact", radius=radius, indentation=depth,
                          drag=fixed.get("drag"))
        except (ModelValidityError, ConvergenceError) as exc:
            return None, math.inf, f"fit failed: {str(exc).split(';')[0]}"
        error, reason = contact_error(problem.with_material(_sls_of(ds)), position,
                                      float(np.max(spectrum["omega"])))
        return ds, error, f"{reason} at the fitted moduli (k* proportional to E: bias = error)"
    ds = fit_data(spectrum_data(spectrum), "exact", modes=modes, criterion=criterion,
                  problem=problem, position=position, mean_force=mean_force)
    return ds, GRID_ERROR, "the exact model on the default grid"


def fit_spectrum_auto(spectrum: xr.Dataset, *, modes: int | str = 1, criterion: str = "bic",
                      accuracy: float | None = None, **fixed: Any) -> xr.Dataset:
    """``fit_spectrum(..., "auto")``: the cheapest spectrum model adequate at the fitted values.

    Tries svda (pre-contact, one mode), contact (Hertz, h̄0 < 0, one mode) and exact in order
    of cost; each approximate fit is kept if its model error estimated at the fitted parameters
    (:func:`viscoforce.choice.svda_error`, :func:`viscoforce.choice.contact_error`), divided by
    the sensitivity of k* to the moduli (the bias it puts on E0, E_inf), meets ``accuracy``,
    otherwise the next is fitted. Before contact the SVDA's stiffness error and the
    sensitivity are both O(κ|u0|), so its moduli are biased by an O(1) fraction of the
    relative error at any position: ``auto`` keeps svda only at a loose accuracy.
    ``attrs["explanation"]`` says what was compared; ``attrs["estimated_model_error"]`` holds
    the estimate of the model kept.

    Raises
    ------
    ParameterError
        No ``problem`` (the exact fallback needs it), or neither ``position`` nor ``mean_force``.
    TypeError
        A fixed input none of the candidates takes.
    """
    accuracy = require_accuracy(DEFAULT_ACCURACY if accuracy is None else accuracy)
    allowed = {"problem", "position", "mean_force", "drag"}
    unknown = sorted(set(fixed) - allowed)
    if unknown:
        raise TypeError(f"model 'auto' takes no input {', '.join(unknown)}; its inputs: "
                        f"{', '.join(sorted(allowed))} (radius and the surface force come "
                        "from problem)")
    problem = fixed.get("problem")
    if not isinstance(problem, ContactProblem):
        raise ParameterError("model 'auto' needs problem= (a ContactProblem: the sphere, surface "
                             "force and grid of the exact model it may fall back to)")
    if fixed.get("position") is None and fixed.get("mean_force") is None:
        raise ParameterError("model 'auto' needs the mean position: give position (--h0) or "
                             "mean_force (--mean-force)")
    fixed = check_fixed("exact", {k: v for k, v in fixed.items() if k != "drag"}) | {
        "drag": fixed.get("drag")}
    rows: list[tuple[str, float, str, dict[str, Any]]] = []
    kept = None
    for name in AUTO_MODELS:
        ds, error, reason = _auto_candidate(spectrum, name, modes, criterion, problem, fixed)
        rows.append((name, error, reason, {}))
        if ds is not None and error <= meets(accuracy):
            kept = ds
            break
    choice = finish("fit model", rows, accuracy, "")
    if kept is None:  # exact fits or raises; keep the loop honest anyway
        raise ConvergenceError(f"model 'auto' kept no fit: {choice.explanation}")
    kept.attrs["explanation"] = choice.explanation
    kept.attrs["estimated_model_error"] = choice.estimated_error
    kept.attrs["accuracy"] = accuracy
    warn_unidentified(kept, stacklevel=4)
    return kept


def _data_indentation(spectrum: xr.Dataset) -> float:
    if "mean_indentation" not in spectrum.variables:
        raise ModelValidityError(
            "the contact model needs the operating indentation: this spectrum has no "
            "mean_indentation (no contact point found, or pre-contact); give --indentation D0")
    value = float(np.nanmedian(spectrum["mean_indentation"].values))
    if not value > 0:
        raise ModelValidityError(
            f"the contact model refuses a pre-contact spectrum: median mean_indentation "
            f"{value!r} m is not > 0 (use --model svda or exact, or give --indentation D0)")
    return value
