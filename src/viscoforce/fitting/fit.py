"""Fit one spectrum or one force curve; choose the number of modes by an information criterion.

The spectrum residual is complex: real and imaginary parts of k*_model − k*_data, each weighted by
its standard error propagated from the data's ``stiffness_stderr`` and ``phase_stderr`` (radial and
tangential errors of k* = S e^{iχ}). Points whose ``quality`` flag is set are left out, and so
are points with a NaN (with a note).

Statistics follow from what the weights are (``attrs["weighting"]``):

- ``stderr`` — the data's own errors. The covariance is NOT rescaled by the reduced χ² (the
  errors are known), AIC = χ² + 2k and BIC = χ² + k ln n use χ² itself, and the χ² goodness-of-fit
  p-value (``chi2_pvalue``) is reported; below :data:`PVALUE_WARN` the fit warns that the model
  does not describe these data (:class:`~viscoforce.exceptions.GoodnessOfFitWarning`). Points
  whose stderr is missing or zero get the median relative error of the others (a DataWarning
  names them).
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
"""

from __future__ import annotations

import itertools
import math
import re
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
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
    DataWarning,
    GoodnessOfFitWarning,
    ModelValidityError,
    ParameterError,
)
from viscoforce.fitting import _engine, _params
from viscoforce.fitting.identify import (
    IDENTIFIABILITY,
    QUADRATIC_CORRELATION,
    QUADRATIC_DECADES,
    Profile,
    needs_profile,
    profile_parameters,
    quadratic_limits,
)
from viscoforce.fitting.models import (
    MAX_AUTO_MODES,
    MAX_MODES,
    MODAL_MODELS,
    MODEL_NAMES,
    SPECTRUM_MODELS,
    FitModel,
    check_fixed,
    make_model,
    material_from,
    svda_position,
)
from viscoforce.fitting.report import attach, carry
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_fit_result, plain_variable, validate_spectrum
from viscoforce.svda import svda_error_estimate, svda_stiffness_kernel

#: Information criteria of ``modes="auto"`` (``--criterion``).
CRITERIA = ("bic", "aic")
#: Points of the best-fit curve written with a spectrum fit.
FIT_CURVE_POINTS = 200
#: χ² p-value below which a fit with known stderr warns that the model does not fit the data.
PVALUE_WARN = 1e-3
#: Spectrum weightings (``weights=``): the data's stderr or relative 1/|k*| (None: stderr when
#: the data have them, else relative with a DataWarning).
WEIGHTINGS = ("stderr", "relative")


@dataclass(frozen=True)
class FitData:
    """What a fit sees: x (ω [rad/s] or t [s]), y (k* [N/m] or F [N]) and weights.

    ``weighting`` is ``"stderr"`` (weights = 1/σ of the data: χ² is absolute), ``"relative"``
    or ``"unweighted"`` (χ² up to an unknown scale); ``notes`` say what was done to the data
    (points left out, fallbacks), each a sentence a DataWarning or a map's message can carry.
    """

    x: np.ndarray
    y: np.ndarray
    weights: np.ndarray | None
    source: Mapping[str, Any]
    weighting: str = "unweighted"
    notes: tuple[str, ...] = ()
    #: Degrees of freedom of each point's stderr where they were estimated from few values
    #: (lock-in: 2 × the residual-spectrum bins); None: taken as exact.
    sigma_dof: np.ndarray | None = None

    @property
    def sigma_known(self) -> bool:
        """Whether the weights are the data's own 1/σ (χ² absolute)."""
        return self.weighting == "stderr"

    @property
    def n_values(self) -> int:
        """Real numbers fitted (2 per complex point)."""
        return self.y.size * (2 if np.iscomplexobj(self.y) else 1)


# ── data ────────────────────────────────────────────────────────────────────────────────────────

def spectrum_data(ds: xr.Dataset, *, weights: str | None = None) -> FitData:
    """ω, k* and weights of one spectrum (1-D over ``omega``), flagged and NaN points left out.

    Parameters
    ----------
    ds : xarray.Dataset
        One spectrum (:mod:`viscoforce.schema.spectrum`) over ``omega`` only.
    weights : {"stderr", "relative"}, optional
        The residual weights (module docstring); None: the data's stderr where present, else
        relative. The notes of :func:`pixel_fit_data` (points left out, fallbacks) are issued
        as DataWarnings.

    Returns
    -------
    FitData
        ω [rad/s], k* [N/m], complex weights 1/σ_re + i/σ_im, provenance, weighting, notes.

    Raises
    ------
    ParameterError
        Extra dims, negative stiffness on a point not flagged, no point left, ``weights="stderr"``
        on data without stderr.
    """
    validate_spectrum(ds, require=("stiffness", "phase"))
    extra = [d for d in ds.variables["stiffness"].dims if d != "omega"]
    if extra:
        raise ParameterError(f"one spectrum is over 'omega' only; this one also has {extra} "
                             "(fit it as a map, or select one)")
    arrays = spectrum_arrays(ds, ())
    source = {"data_kind": "spectrum"}
    if "source" in ds.attrs:
        source["data_source"] = str(ds.attrs["source"])
    data = pixel_fit_data(np.asarray(ds.variables["omega"].values, dtype=float),
                          {k: v[0] for k, v in arrays.items()}, source, weights=weights)
    for note in data.notes:
        warnings.warn(note, DataWarning, stacklevel=3)
    return data


def spectrum_arrays(ds: xr.Dataset, dims: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The spectrum's variables as (pixel, omega) arrays (pixels in C order over ``dims``).

    Keys: ``stiffness``, ``phase`` [rad], ``stiffness_stderr``, ``phase_stderr`` [rad] (NaN when
    absent), ``quality`` (0 when absent), ``mean_indentation`` (NaN when absent),
    ``stderr_bins`` (the lock-in's ``lockin_stderr_bins``; 0 when absent: exact stderr).
    """
    order = (*dims, "omega")
    n_omega = ds.sizes["omega"]
    n_pixels = int(np.prod([ds.sizes[d] for d in dims]))
    shape = tuple(ds.sizes[d] for d in order)

    def grab(name: str, fill: float) -> np.ndarray:
        if name not in ds.variables:
            return np.full((n_pixels, n_omega), fill)
        da = ds.variables[name]  # scalar, per pixel, per frequency or per point: broadcast
        wanted = tuple(d for d in order if d in da.dims)
        values = np.asarray((da if da.dims == wanted else da.transpose(*wanted)).values,
                            dtype=float)
        index = tuple(slice(None) if d in da.dims else None for d in order)
        return np.broadcast_to(values[index], shape).reshape(n_pixels, n_omega)

    out = {"stiffness": grab("stiffness", np.nan), "phase": np.radians(grab("phase", np.nan)),
           "stiffness_stderr": grab("stiffness_stderr", np.nan),
           "phase_stderr": np.radians(grab("phase_stderr", np.nan)),
           "quality": grab("quality", 0.0), "mean_indentation": grab("mean_indentation", np.nan),
           "stderr_bins": grab("lockin_stderr_bins", 0.0)}
    return out


def pixel_fit_data(omega: np.ndarray, a: Mapping[str, np.ndarray],
                   source: Mapping[str, Any], *, weights: str | None = None) -> FitData:
    """FitData of one pixel's arrays (see :func:`spectrum_arrays`), with the checks of one spectrum.

    Points flagged in ``quality`` and points whose stiffness or phase is NaN/inf are left out
    (the latter with a note). ``weights`` as in :func:`spectrum_data`; what was done is in the
    result's ``notes`` (no warning here: maps carry the notes per pixel).
    """
    if weights is not None and weights not in WEIGHTINGS:
        raise ParameterError(f"weights must be one of {', '.join(WEIGHTINGS)} or None, got "
                             f"{weights!r}")
    stiffness, phase = a["stiffness"], a["phase"]
    keep = a["quality"] == 0
    if not keep.any():
        raise ParameterError(f"every one of the {omega.size} spectrum points is flagged in "
                             "'quality' (see its comment): nothing to fit; correct the phase "
                             "lag (load --phase-lag) or inspect the data")
    notes: list[str] = []
    bad = keep & ~(np.isfinite(stiffness) & np.isfinite(phase))
    if bad.any():
        shown = ", ".join(f"{w:.4g}" for w in omega[bad])
        notes.append(f"stiffness or phase is NaN/inf at omega = {shown} rad/s: "
                     f"{int(bad.sum())} point(s) left out of the fit")
        keep = keep & ~bad
        if not keep.any():
            raise ParameterError("no spectrum point is left to fit: every unflagged point has "
                                 "a NaN/inf stiffness or phase")
    negative = keep & (stiffness <= 0)
    if negative.any():
        i = int(np.flatnonzero(negative)[0])
        raise ParameterError(f"stiffness must be > 0 N/m, got {stiffness[i]!r} at omega = "
                             f"{omega[i]:.4g} rad/s (point {i})")
    k = stiffness * np.exp(1j * phase)
    with np.errstate(invalid="ignore", divide="ignore"):  # left-out points may be NaN
        w, weighting, note = _spectrum_weights(omega, k, stiffness, phase, a, keep, weights)
    notes.extend(note)
    info = {**source, "data_points": int(keep.sum()), "data_flagged": int((~keep).sum())}
    depth = a["mean_indentation"]
    if np.isfinite(depth[keep]).any():
        info["mean_indentation"] = float(np.nanmedian(depth[keep]))
    sigma_dof = None
    bins = np.asarray(a.get("stderr_bins", np.zeros_like(stiffness)), dtype=float)[keep]
    if weighting == "stderr" and np.any(bins > 0):
        sigma_dof = np.where(bins > 0, 2.0 * bins, np.inf)
    return FitData(omega[keep], k[keep], w[keep], info, weighting, tuple(notes), sigma_dof)


def _spectrum_weights(omega: np.ndarray, k: np.ndarray, stiffness: np.ndarray,
                      phase: np.ndarray, a: Mapping[str, np.ndarray], keep: np.ndarray,
                      weights: str | None) -> tuple[np.ndarray, str, list[str]]:
    """Complex weights 1/σ_re + i/σ_im, the weighting and the notes (module docstring)."""
    relative = (1.0 + 1j) / np.abs(k)
    if weights == "relative":
        return relative, "relative", []
    s_err, p_err = a["stiffness_stderr"], a["phase_stderr"]
    given = np.isfinite(s_err) | np.isfinite(p_err)
    if not given[keep].any():
        if weights == "stderr":
            raise ParameterError("weights='stderr' needs stiffness_stderr or phase_stderr in "
                                 "the data; these have none (use weights='relative')")
        return relative, "relative", [
            "the spectrum has no stiffness_stderr/phase_stderr: the fit weights every point by "
            "1/|k*| (relative), scales the covariance by the reduced chi-square and gives no "
            "p-value (pass weights='relative', --weights relative, to choose this)"]
    p_err = np.where(np.isfinite(p_err), p_err, s_err / stiffness)
    s_err = np.where(np.isfinite(s_err), s_err, p_err * stiffness)
    c, s = np.cos(phase), np.sin(phase)
    with np.errstate(invalid="ignore"):
        sig_re = np.sqrt((c * s_err) ** 2 + (stiffness * s * p_err) ** 2)
        sig_im = np.sqrt((s * s_err) ** 2 + (stiffness * c * p_err) ** 2)
    usable = np.isfinite(sig_re) & np.isfinite(sig_im) & (sig_re > 0) & (sig_im > 0)
    notes = []
    missing = keep & ~usable
    if not (keep & usable).any():
        if weights == "stderr":
            raise ParameterError("weights='stderr': every stderr of the points fitted is "
                                 "missing or zero")
        return relative, "relative", [
            "every stderr of the points fitted is missing or zero: the fit weights every point "
            "by 1/|k*| (relative), scales the covariance by the reduced chi-square and gives "
            "no p-value"]
    if missing.any():
        ok = keep & usable
        rel_re = float(np.median(sig_re[ok] / np.abs(k[ok])))
        rel_im = float(np.median(sig_im[ok] / np.abs(k[ok])))
        sig_re = np.where(missing, rel_re * np.abs(k), sig_re)
        sig_im = np.where(missing, rel_im * np.abs(k), sig_im)
        shown = ", ".join(f"{w:.4g}" for w in omega[missing])
        notes.append(f"stderr missing or zero at omega = {shown} rad/s: those points are "
                     f"weighted by the median relative error of the others ({rel_re:.3g}, "
                     f"{rel_im:.3g} of |k*| in the real and imaginary parts)")
    with np.errstate(divide="ignore"):
        return 1.0 / sig_re + 1j / sig_im, "stderr", notes


# ── one fit ─────────────────────────────────────────────────────────────────────────────────────

@dataclass
class Outcome:
    """One fit: the model, its data, its best SPEC values, their covariance and lmfit's result.

    The minimiser varies the internal parameters only (``log_…``, see
    :mod:`viscoforce.fitting._params`); the SPEC values and their covariance follow from them
    exactly (J C Jᵀ with the analytic Jacobian of the transform), which avoids evaluating lmfit
    expressions on every residual call (they cost more than the models themselves).
    """

    model: FitModel
    result: lmfit.minimizer.MinimizerResult | _engine.LeastSquares
    values: dict[str, float]
    covariance: np.ndarray | None
    data: FitData
    profiles: dict[str, Profile] | None = None
    #: Lag-1 autocorrelation of the residuals (curve fits; NaN for spectra).
    lag1: float = math.nan
    #: Effective number of independent values of the criteria (curve fits: shared by the
    #: candidates of one selection; None: all values).
    n_effective: float | None = None

    @property
    def stderr_factor(self) -> float:
        """Factor on the stderr for AR(1) residuals, √((1 + ρ1)/(1 − ρ1)) (1 when ρ1 ≤ 0)."""
        rho = self.lag1
        if not (math.isfinite(rho) and rho > 0):
            return 1.0
        return math.sqrt((1.0 + rho) / max(1.0 - rho, 1e-12))

    @property
    def n_values(self) -> int:
        """Real numbers fitted."""
        return self.data.n_values

    @property
    def n_free(self) -> int:
        """Free (varied) internal parameters."""
        return int(self.result.nvarys)

    @property
    def dof(self) -> int:
        """Degrees of freedom n − k (at least 1)."""
        return max(self.n_values - self.n_free, 1)

    @property
    def criterion(self) -> dict[str, float]:
        """AIC and BIC of the fit: χ² + 2k and χ² + k ln n with known stderr, else lmfit's."""
        if not self.data.sigma_known:
            if self.n_effective is None:
                return {"aic": float(self.result.aic), "bic": float(self.result.bic)}
            n, m, k = self.n_values, self.n_effective, self.n_free
            loglik = m * math.log(max(float(self.result.chisqr), 1e-300) / n)
            return {"aic": loglik + 2.0 * k, "bic": loglik + k * math.log(m)}
        chi2, k, n = float(self.result.chisqr), self.n_free, self.n_values
        return {"aic": chi2 + 2.0 * k, "bic": chi2 + k * math.log(n)}

    @property
    def pvalue(self) -> float:
        """χ² goodness-of-fit p-value P(χ²_dof ≥ χ²) with known stderr, else NaN.

        Stderr estimated from few values (``FitData.sigma_dof`` ν, the lock-in's) make each
        weighted residual a Student t_ν, not a normal deviate: each is mapped to the normal
        deviate of the same tail probability before the χ² is formed, so that a correct model
        is not rejected for the heavy tails of its error estimates.
        """
        if not self.data.sigma_known:
            return math.nan
        from scipy.special import chdtrc  # chi2.sf without scipy.stats' argument machinery

        return float(chdtrc(self.dof, self.calibrated_chisqr))

    @property
    def calibrated_chisqr(self) -> float:
        """χ² of the normal scores of the weighted residuals (χ² itself where σ is exact)."""
        nu = self.data.sigma_dof
        if nu is None:
            return float(self.result.chisqr)
        from scipy.special import ndtri, stdtr  # t.sf and norm.isf, without scipy.stats

        r = np.asarray(self.result.residual, dtype=float)
        nu = np.repeat(nu, r.size // nu.size)
        finite = np.isfinite(nu)
        z = r.copy()
        tail = stdtr(nu[finite], -np.abs(r[finite]))
        z[finite] = np.sign(r[finite]) * -ndtri(np.maximum(tail, 1e-300))
        return float(z @ z)

    def evaluate(self, x: np.ndarray) -> np.ndarray:
        """The best-fit model over ``x`` (ω or t)."""
        return self.model.raw(np.asarray(x, dtype=float), self.values)

    def profile(self, names: Sequence[str] | None = None) -> dict[str, Profile]:
        """Profile likelihood of ``names`` (default all; each computed once; :mod:`.identify`)."""
        if self.profiles is None:
            self.profiles = {}
        todo = [n for n in (self.model.names if names is None else names)
                if n not in self.profiles]
        if todo:
            stderr = summary_stderr(self)
            scale = 1.0 if self.data.sigma_known else max(float(self.result.redchi), 1e-300)
            scale *= self.stderr_factor ** 2
            self.profiles.update(profile_parameters(
                self.model.layout, _residual(self.model, self.data), self.result.params,
                stderr, float(self.result.chisqr), scale, names=todo))
        return {n: self.profiles[n] for n in (self.model.names if names is None else names)}


def _residual(model: FitModel, data: FitData):
    """The weighted residual (real) as a function of lmfit Parameters (internal names)."""
    layout = model.layout
    return _values_residual(model, data, lambda params: _params.reported_values(
        layout, params.valuesdict()))


def _vector_residual(model: FitModel, data: FitData, params: _params.ParameterSet):
    """The weighted residual of the varied internal values (in ``params``' order) as an array.

    Parameters that do not vary keep their values in ``params``.
    """
    decode = _params.decoder(model.layout, [n for n, p in params.items() if p.vary],
                             {n: p.value for n, p in params.items() if not p.vary})
    return _values_residual(model, data, lambda x: decode(x.tolist()))


def _values_residual(model: FitModel, data: FitData,
                     values: Callable[[Any], Mapping[str, float]]):
    """The weighted residual (real) at the SPEC values that ``values(argument)`` gives."""
    func, x, y = model.raw, data.x, data.y
    weights = None if data.weights is None else (
        data.weights.view(float) if np.iscomplexobj(data.weights) else data.weights)

    def residual(argument: Any) -> np.ndarray:
        diff = np.asarray(y - func(x, values(argument)))
        if np.iscomplexobj(diff):
            diff = diff.view(float)
        if weights is not None:
            diff = diff * weights
        if not np.isfinite(diff).all():
            raise ArithmeticError("the model gave NaN or inf at these parameters")
        return diff

    return residual


def _outcome(model: FitModel, res: lmfit.minimizer.MinimizerResult | _engine.LeastSquares,
             data: FitData) -> Outcome:
    values, grads = _params.to_reported(model.layout, res.params.valuesdict())
    cov = None
    if res.errorbars and res.covar is not None and np.all(np.isfinite(res.covar)):
        jac = np.array([[grads[n].get(v, 0.0) for v in res.var_names] for n in model.names])
        cov = jac @ res.covar @ jac.T
    outcome = Outcome(model, res, {n: values[n] for n in model.names}, cov, data)
    if data.weighting == "unweighted" and model.spec.name in AUTOCORRELATED_MODELS:
        outcome.lag1 = residual_lag1(np.asarray(res.residual, dtype=float), data.x)
        if cov is not None:
            outcome.covariance = cov * outcome.stderr_factor ** 2
    return outcome


#: Lag-1 residual autocorrelation above which a curve fit warns (its stderr are corrected).
LAG1_WARN = 0.5
#: Curve models of measured series whose stderr are corrected for residual autocorrelation
#: (the step model fits a simulated trajectory, whose residual is the solver's smooth error).
AUTOCORRELATED_MODELS = ("relaxation", "hertz", "creep", "ting")


def residual_lag1(residual: np.ndarray, t: np.ndarray) -> float:
    """Lag-1 autocorrelation of residuals ordered in time, Σ r_i r_{i+1} / Σ r_i² (0 if < 3)."""
    r = residual[np.argsort(t)]
    if r.size < 3:
        return 0.0
    r = r - r.mean()
    denom = float(r @ r)
    return float(r[:-1] @ r[1:]) / denom if denom > 0 else 0.0


def fit_once(model: FitModel, data: FitData, *, starts: int = 2, settle: bool = True
             ) -> Outcome:
    """Least-squares fit of ``model`` from its data-driven guess (and ``starts`` − 1 more).

    With ``settle``, the other starts are tried only while the best fit so far is not settled
    (:func:`_settled`); a selection by criterion (``modes="auto"``, the measured-data chooser)
    passes False and tries them all, since its choice rests on differences in χ².

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
    residual = _vector_residual(model, data, first)
    best: Outcome | None = None
    errors: list[str] = []
    for params in itertools.chain([first], _alternative_starts(model, first, starts - 1)):
        if settle and best is not None and _settled(best):
            break
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                res = _engine.leastsq(residual, params, scale_covar=not data.sigma_known)
        except (ValueError, ArithmeticError, ParameterError, ConvergenceError) as exc:
            errors.append(str(exc).splitlines()[0])
            continue
        if not np.isfinite(res.chisqr):
            errors.append("non-finite chi-square")
            continue
        if best is None or res.chisqr < best.result.chisqr:
            best = _outcome(model, res, data)
    if best is None:
        raise ConvergenceError(f"model {model.spec.name!r} could not be fitted from any start: "
                               + "; ".join(errors[:3]))
    return best


#: χ² p-value from which a first start's fit is taken without trying the others.
SETTLED_PVALUE = 0.05


def _settled(outcome: Outcome) -> bool:
    """Whether a fit needs no other start: it describes the data at an interior minimum.

    The other starts (:func:`_alternative_starts`) guard a several-mode fit against a minimum
    where two relaxation times merge or one runs to its window's edge. A fit that converged
    with a covariance, has no parameter on a bound and passes the χ² test (p ≥
    :data:`SETTLED_PVALUE`; with known stderr only) shows neither, and another start could
    lower its χ² by no more than the noise: it is kept (issue 22: each start is a whole fit).
    """
    res = outcome.result
    if not (outcome.data.sigma_known and res.success and res.errorbars):
        return False
    return not _params.at_bound(res.params) and outcome.pvalue >= SETTLED_PVALUE


def _alternative_starts(model: FitModel, first: _params.InternalParameters,
                        count: int) -> Iterator[_params.InternalParameters]:
    """More starts for several modes: the relaxation times spread wider, or closer.

    The start values are read now (the fit then moves ``first``); each start is built only when
    it is asked for.
    """
    if count <= 0 or model.spec.modes == 1:
        return iter(())
    values = {name: p.value for name, p in first.items()}

    def starts() -> Iterator[_params.InternalParameters]:
        for factor in (2.5, 0.4)[:count]:
            params = first.copy()
            for name, p in params.items():
                value = values[name]
                if name.startswith("log_tau_") and name != "log_tau_1" and p.vary:
                    value = min(max(value * factor, p.min), p.max)
                p.set(value=value)
                p.stderr, p.correl = None, None
            yield params

    return starts()


# ── results ─────────────────────────────────────────────────────────────────────────────────────

def summary_stderr(outcome: Outcome) -> dict[str, float | None]:
    """Local stderr of each SPEC parameter (None when the covariance is singular)."""
    names = outcome.model.names
    if outcome.covariance is None:
        return {n: None for n in names}
    var = np.diag(outcome.covariance)
    if not np.all(var >= 0):
        return {n: None for n in names}
    return {n: float(e) for n, e in zip(names, np.sqrt(var), strict=True)}


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
    corr = np.where(np.eye(len(names), dtype=bool), 1.0, np.nan)
    stderr = summary_stderr(outcome)
    if outcome.covariance is not None and all(e is not None for e in stderr.values()):
        sd = np.array([stderr[n] for n in names])
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = outcome.covariance / np.outer(sd, sd)
        np.fill_diagonal(corr, 1.0)
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
    (:func:`add_derived_moduli` re-derives them at another ν).
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
        lo, hi = float(np.min(data.x)), float(np.max(data.x))
        omega = np.union1d(np.geomspace(lo / 2, hi * 2, FIT_CURVE_POINTS), data.x)
        k = outcome.evaluate(omega)
        curves = {"omega": omega, "fit_stiffness": np.abs(k), "fit_phase": np.degrees(np.angle(k))}
    elif model.independent == "z":
        z = np.sort(data.x)
        curves = {"tip_position": z, "fit_approach_force": outcome.evaluate(z)}
    else:
        t = np.sort(data.x)
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


# ── the field's moduli ──────────────────────────────────────────────────────────────────────────

#: Fitted quantities in the paper's modulus convention (2/E = Σ(1 − ν²)/E_i), by name pattern:
#: moduli [Pa] and the structural viscosity μ [Pa s] (an E-like coefficient of iω).
PAPER_CONVENTION = re.compile(r"E0|E_inf|E_\d+|E_ref|E|mu")


def add_derived_moduli(ds: xr.Dataset, poisson: float | None = None) -> xr.Dataset:
    """``<name>_young`` and ``<name>_shear`` (with ``_stderr``) of every paper-convention modulus.

    Young's modulus Y = E(1 − ν²)/2 (a rigid tip; the paper's E is twice Johnson's E*) and the
    shear modulus G = Y/(2(1 + ν)); both linear in E, so the stderr convert the same way. At
    ν = 0.5, E = 8/3 Y = 8 G. Works on a single fit or a map (elementwise).

    Parameters
    ----------
    ds : xarray.Dataset
        A fit result.
    poisson : float, optional
        The sample's Poisson's ratio ν in [0, 0.5] (default 0.5, incompressible; recorded in
        ``attrs["poisson"]``).

    Returns
    -------
    xarray.Dataset
        ``ds`` with the derived variables.
    """
    from viscoforce.physics.tips import DEFAULT_POISSON

    nu = DEFAULT_POISSON if poisson is None else poisson
    names = [str(n) for n in ds.variables["param_i"].values]
    if ds.attrs.get("poisson") == nu and all(
            f"{n}_young" in ds.variables for n in names if PAPER_CONVENTION.fullmatch(n)):
        return ds  # already derived at this ν (result_dataset derives at the default)
    variables = ds.variables
    result = carry(ds, ds.assign(derived_variables(
        {n: (variables[n], variables[f"{n}_stderr"]) for n in names}, nu)))
    result.attrs.update(derived_attrs(nu))
    return result


def derived_variables(params: Mapping[str, tuple[Any, Any]], nu: float
                      ) -> dict[str, xr.Variable]:
    """``<name>_young``, ``<name>_shear`` and their ``_stderr`` of each paper-convention modulus.

    ``params``: name → (value, stderr) as :class:`xarray.Variable` (a map) or floats (one fit,
    units from :func:`viscoforce.schema.fit.parameter_units`). ν is validated here (the message
    names its range).
    """
    from viscoforce.physics.tips import shear_from_young, young_from_paper
    from viscoforce.schema.fit import parameter_units

    young_from_paper(1.0, nu)  # validates ν (the message names the range)
    out = {}
    for name, pair in params.items():
        if not PAPER_CONVENTION.fullmatch(name):
            continue
        first = pair[0]
        unit = (str(first.attrs.get("units", "Pa")) if isinstance(first, xr.Variable)
                else parameter_units(name))
        kind = "viscosity" if name == "mu" else "modulus"
        converted = {}
        for tail, source in zip(("", "_stderr"), pair, strict=True):
            dims = source.dims if isinstance(source, xr.Variable) else ()
            values = np.asarray(source.values if isinstance(source, xr.Variable) else (
                math.nan if source is None else source), dtype=float)
            young = young_from_paper(values, nu)  # checks the values (the message says how)
            converted[tail] = dims, {"young": young, "shear": shear_from_young(young, nu)}
        for suffix, what in (("young", "Young's"), ("shear", "shear")):
            for tail, (dims, moduli) in converted.items():
                value = moduli[suffix]
                out[f"{name}_{suffix}{tail}"] = plain_variable(
                    dims, value if dims else float(value), {
                        "units": unit, "poisson": float(nu),
                        "long_name": f"{'standard error of ' if tail else ''}{what} {kind} "
                                     f"from {name} (nu = {nu:g})"})
    return out


def derived_attrs(nu: float) -> dict[str, Any]:
    """The dataset attributes that go with :func:`derived_variables`."""
    return {"poisson": float(nu), "modulus_convention": (
        "E (and E0, E_inf, E_i, E_ref, mu) is the paper's: 2/E = sum (1 - nu_i^2)/E_i, twice "
        "Johnson's E*; <name>_young = E (1 - nu^2)/2, <name>_shear = <name>_young/(2 (1 + nu))")}


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
        _share_effective_size([outcome])
        return outcome, [{"modes": modes, **outcome.criterion}]
    outcomes: list[Outcome] = []
    worse = 0
    for n in range(1, max_modes + 1):
        model = make_model(name, n, **fixed)
        if len(model.names) >= data.n_values:  # one internal parameter per SPEC name
            break
        try:
            outcomes.append(fit_once(model, data, settle=False))
        except ConvergenceError:
            if not outcomes:
                raise
            break
        _share_effective_size(outcomes)  # the stopping rule scores as the final choice does
        scores = [o.criterion[criterion] for o in outcomes]
        worse = worse + 1 if len(scores) > 1 and scores[-1] >= min(scores[:-1]) else 0
        if worse >= 2:
            break
    _share_effective_size(outcomes)
    best = min(outcomes, key=lambda o: o.criterion[criterion])
    return best, [{"modes": o.model.spec.modes, **o.criterion} for o in outcomes]


def _share_effective_size(outcomes: list[Outcome]) -> None:
    """Curve fits: one effective sample size n (1 − ρ1)/(1 + ρ1) for every candidate.

    ρ1 is the residual lag-1 autocorrelation of the candidate with the smallest χ² (the least
    misfit, so the closest to the noise's own), so that the criteria stay comparable.
    """
    curve = [o for o in outcomes if math.isfinite(o.lag1)]
    if not curve:
        return
    rho = min(curve, key=lambda o: float(o.result.chisqr)).lag1
    n = curve[0].n_values
    n_eff = n * (1.0 - rho) / (1.0 + rho) if rho > 0 else float(n)
    # one m for all (the criteria differ by m ln(χ²_a/χ²_b): unit-free only with a common m)
    n_eff = min(max(n_eff, max(o.n_free for o in curve) + 2.0), float(n))
    for o in curve:
        o.n_effective = n_eff


def fit_data(data: FitData, name: str, *, modes: int | str = 1, criterion: str = "bic",
             max_modes: int = MAX_AUTO_MODES, profile: bool | str = "auto",
             **fixed: Any) -> xr.Dataset:
    """Fit prepared data (:class:`FitData`) with model ``name``; ``modes="auto"`` selects.

    Parameters
    ----------
    data : FitData
        What the fit sees (:func:`spectrum_data`, :func:`viscoforce.fitting.curves.hold_data`).
    name : str
        A model of :data:`viscoforce.fitting.models.MODEL_NAMES`.
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
    best, selection = select(data, name, modes=modes, criterion=criterion, max_modes=max_modes,
                             **fixed)
    ds = result_dataset(best, data, selection=selection if modes == "auto" else None,
                        profile=profile)
    if modes == "auto":
        ds.attrs["criterion"] = criterion
        if best.model.spec.modes == max(row["modes"] for row in selection) >= max_modes:
            ds.attrs["selection_note"] = (
                f"the {criterion.upper()} still improved at the largest number of modes tried "
                f"({max_modes}): more modes may describe these data better")
    return ds


def _scalar(ds: xr.Dataset, name: Any) -> float:
    """A scalar variable of ``ds`` as a float (read from the Variable: no DataArray is built)."""
    return float(ds.variables[str(name)].values)


def bound_text(ds: xr.Dataset, name: str) -> str | None:
    """How a parameter that is not determined should be reported (None when it is determined).

    ``"E0 > 2.1e+04 Pa"`` (lower bound only), ``"mu < 3.2 Pa s"``, ``"tau not determined"``.
    """
    if "identifiability" not in ds.variables:
        return None
    codes = dict(zip((str(n) for n in ds["param_i"].values),
                     np.asarray(ds["identifiability"].values).reshape(-1).tolist(), strict=True))
    code = int(codes.get(name, 0))
    unit = str(ds[name].attrs.get("units", ""))
    if code == 1 and f"{name}_lower" in ds.variables:
        return f"{name} > {_scalar(ds, f'{name}_lower'):.3g} {unit}".rstrip()
    if code == 2 and f"{name}_upper" in ds.variables:
        return f"{name} < {_scalar(ds, f'{name}_upper'):.3g} {unit}".rstrip()
    if code == 0:
        return None
    return f"{name} not determined"


def warn_unidentified(ds: xr.Dataset, *, stacklevel: int = 3) -> list[str]:
    """Warn (AccuracyWarning) about fitted parameters the data do not determine; return them.

    With the profile likelihood (``identifiability``): a parameter bounded on one side only is
    reported as that bound (e.g. "E0 > 2e4 Pa": the likelihood is flat towards larger values),
    one flat on both sides as not determined. Without it, the local test: stderr above the
    value, or none (the covariance is singular).
    """
    names = [str(n) for n in ds.variables["param_i"].values]
    if "identifiability" in ds.variables:
        codes = np.asarray(ds.variables["identifiability"].values).reshape(-1)
        bad = [n for n, c in zip(names, codes, strict=True) if int(c) != 0]
    else:
        bad = [n for n in names
               if not np.isfinite(_scalar(ds, f"{n}_stderr")) or
               abs(_scalar(ds, f"{n}_stderr")) > abs(_scalar(ds, n))]
    if bad:
        shown = "; ".join(
            f"{bound_text(ds, n) or n} (fitted {_scalar(ds, n):.4g} ± "
            f"{_scalar(ds, f'{n}_stderr'):.3g})" for n in bad)
        warnings.warn(
            f"the data do not determine {', '.join(bad)}: {shown}; report the bound, fix the "
            "parameter, fit fewer parameters, or measure where the spectrum depends on it",
            AccuracyWarning, stacklevel=stacklevel)
    return bad


def warn_goodness(ds: xr.Dataset, *, stacklevel: int = 3) -> bool:
    """Warn (GoodnessOfFitWarning) when the χ² p-value is below :data:`PVALUE_WARN`."""
    p = _scalar(ds, "chi2_pvalue") if "chi2_pvalue" in ds.variables else math.nan
    if math.isfinite(p) and p < PVALUE_WARN:
        warnings.warn(
            f"the model does not describe these data: chi-square {ds.attrs.get('chisqr', math.nan):.4g}"
            f"{_calibrated_text(ds)} for {ds.attrs.get('dof', '?')} degrees of freedom (redchi "
            f"{_scalar(ds, 'redchi'):.3g}), p = {p:.2g} < {PVALUE_WARN:g}; its stderr assume it "
            "does. Try another model or material (--model auto), or check the data's stderr",
            GoodnessOfFitWarning, stacklevel=stacklevel)
        return True
    return False


def _calibrated_text(ds: xr.Dataset) -> str:
    calibrated = float(ds.attrs.get("chisqr_calibrated", math.nan))
    if math.isfinite(calibrated) and not math.isclose(calibrated, float(ds.attrs["chisqr"])):
        return f" ({calibrated:.4g} with the residuals' stderr-dof calibration)"
    return ""


def warn_fit(ds: xr.Dataset, *, stacklevel: int = 4) -> None:
    """The warnings of a single fit: autocorrelated residuals, goodness of fit, identifiability."""
    rho = float(ds.attrs.get("residual_lag1", math.nan))
    if math.isfinite(rho) and rho > LAG1_WARN:
        warnings.warn(
            f"the residuals are strongly autocorrelated (lag-1 {rho:.3g}): the stderr are "
            f"multiplied by sqrt((1+rho)/(1-rho)) = {float(ds.attrs['stderr_correction']):.3g} "
            f"(effective sample size {float(ds.attrs['effective_samples']):.4g} of "
            f"{int(ds.attrs.get('data_points', 0))}); they hold for AR(1) noise only. The model "
            "may miss structure in the data (drift, more modes): compare windows or replicas",
            DataWarning, stacklevel=stacklevel)
    warn_goodness(ds, stacklevel=stacklevel)
    warn_unidentified(ds, stacklevel=stacklevel)


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
        moduli (:func:`add_derived_moduli`).
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
            from viscoforce.fitting.measured import fit_measured_auto

            if accuracy is not None:
                raise ParameterError(
                    "accuracy chooses between the theory's approximations (with position or "
                    "mean_force, --h0/--mean-force); on measured data model 'auto' compares "
                    "materials by the criterion instead: leave accuracy out")
            return add_derived_moduli(fit_measured_auto(
                spectrum, modes="auto" if modes is None else modes, criterion=criterion,
                weights=weights, profile=profile, **fixed), poisson)
        return add_derived_moduli(fit_spectrum_auto(
            spectrum, modes=1 if modes is None else modes, criterion=criterion,
            accuracy=accuracy, weights=weights, profile=profile, **fixed), poisson)
    modes = _check_modes(model, 1 if modes is None else modes) if model in MODEL_NAMES else 1
    if criterion not in CRITERIA:
        raise ParameterError(f"criterion must be one of {', '.join(CRITERIA)}, got {criterion!r}")
    if accuracy is not None:
        raise ParameterError(f"accuracy applies to model 'auto' only, not {model!r}")
    if model not in SPECTRUM_MODELS:
        raise ParameterError(f"model {model!r} fits force curves, not spectra; spectrum models: "
                             f"{', '.join(SPECTRUM_MODELS)} (or auto)")
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
    if model == "contact" and decay is not None:
        _warn_model_bias(ds, model, *contact_bias(ds, fixed, data.x, decay))
    ds.attrs["validity"] = validity_note(model, ds)
    warn_fit(ds)
    return add_derived_moduli(ds, poisson)


#: What the validity of each model rests on when no estimate is made (``attrs["validity"]``).
VALIDITY = {
    "exact": "the exact small-amplitude model: its error is the grid's (~1e-9 on the default "
             "grid) and the finite-amplitude bias of the measurement",
    "prony": "phenomenological (no geometry, no surface force): no model error to estimate",
    "relaxation": "phenomenological sum of exponentials: no model error to estimate",
    "step": "the exact model along the measured drive: its error is the stepper's",
    "contact": "not estimated: Hertz contact's bias needs the surface force's decay length "
               "(debye_length, --debye-length)",
    "svda": "not estimated",
    "hertz": "elastic contact of the tip's shape on a half-space (Sneddon/Hertz/Bilodeau): "
             "valid for indentations small against the sample's thickness, with no adhesion; a "
             "viscoelastic sample's E is an effective modulus at the approach speed",
    "creep": "phenomenological sum of exponentials of the tip position: its times are the creep "
             "compliance's exactly for a flat punch, to first order in dz/indentation for a "
             "sphere, paraboloid, cone or pyramid",
}


def validity_note(model: str, ds: xr.Dataset) -> str:
    """One sentence on the model error of a fit: the estimate made, or why there is none."""
    if "validity" in ds.attrs:
        return str(ds.attrs["validity"])
    if "estimated_model_error" in ds.attrs:
        return (f"estimated model error {float(ds.attrs['estimated_model_error']):.2g} "
                f"(relative, on the moduli)")
    return VALIDITY.get(model, "not estimated")


def svda_bias(ds: xr.Dataset, spectrum: xr.Dataset, position: float, radius: float,
              P: float, debye_length: float) -> tuple[float, str]:  # noqa: N803
    """Estimated relative bias of an svda fit's moduli and the reason.

    A stiffness error δ (0.6 κ|u0| at the fitted E_inf, :func:`viscoforce.svda.svda_error_estimate`)
    biases the moduli by ≈ δ / s, s = |∂ln k*/∂ln E| (E0, E_inf scaled together), which is small
    before contact: the SVDA error is O(κ|u0|) and so is s.
    """
    values = {n: _scalar(ds, n) for n in ("E0", "E_inf", "tau")}
    error = float(svda_error_estimate(position, values["E_inf"], radius, P, debye_length))
    omega = np.asarray(spectrum.variables["omega"].values, dtype=float)
    kernel = (position, values["E0"], values["E_inf"], values["tau"], radius, P)
    k = svda_stiffness_kernel(omega, *kernel, 1.0 / debye_length)
    scaled = (position, *(v * (1 + SENSITIVITY_STEP) for v in kernel[1:3]), *kernel[3:])
    k_up = svda_stiffness_kernel(omega, *scaled, 1.0 / debye_length)
    sensitivity = float(np.max(np.abs(k_up / k - 1.0))) / SENSITIVITY_STEP
    return error / sensitivity, (
        f"stiffness error 0.6 kappa|u0| ~{error:.1e} over the moduli sensitivity "
        f"|dln k*/dln E| = {sensitivity:.2g} at the fitted E_inf = {values['E_inf']:.3g} Pa")


def contact_bias(ds: xr.Dataset, fixed: Mapping[str, Any], omega: np.ndarray,
                 decay_length: float) -> tuple[float, str]:
    """Estimated relative bias of a contact fit against the exact model, and the reason.

    :func:`viscoforce.choice.hertz_error` at the fitted material: 2 × 1.5 |E*(ω_max)|/E_inf /
    (κδ0), measured for materials with a relaxed modulus (SLS, Prony). The power-law and
    structural materials have none (E → 0 as ω → 0): their bias is not estimated (NaN, with the
    reason), rather than extrapolated.
    """
    modes = int(ds.variables["modes"].values)
    kind = str(ds.attrs.get("material", fixed.get("material") or "sls"))
    if kind not in ("sls", "prony"):
        return math.nan, (f"not estimated: the Hertz-contact estimate needs a relaxed modulus, "
                          f"which material {kind} does not have")
    values = {str(n): _scalar(ds, n) for n in ds.variables["param_i"].values}
    return hertz_error(material_from(values, modes), float(fixed["indentation"]), decay_length,
                       float(np.max(omega)))


def _warn_model_bias(ds: xr.Dataset, model: str, bias: float, reason: str) -> None:
    """Warn (ApproximationWarning) when a fit's estimated model bias exceeds 1 %.

    A NaN bias (no estimate possible) is recorded in ``attrs["validity"]`` with its reason.
    """
    if math.isnan(bias):
        ds.attrs["validity"] = reason
        return
    ds.attrs["estimated_model_error"] = bias
    if bias > WARN_ERROR:
        lead = "the SVDA is about" if model == "svda" else "Hertz contact is about"
        fix = ("use model 'exact' (or 'auto')" if model == "svda" else
               "if the surface force is the double layer of that decay length, use model "
               "'exact' with --h0 or --mean-force (or 'auto' with them)")
        warnings.warn(
            f"{lead} {100 * bias:.2g} % off as a model of these data: the fitted moduli are "
            f"biased by about that much ({reason}); {fix}", ApproximationWarning, stacklevel=3)


def _sls_of(ds: xr.Dataset):
    """The standard linear solid of a one-mode fit result."""
    return material_from({n: _scalar(ds, n) for n in ("E0", "E_inf", "tau")}, 1)


#: Relative step of the moduli sensitivity of an svda fit (its bias estimate).
SENSITIVITY_STEP = 1e-4
#: The models ``model="auto"`` chooses from, in order of cost.
AUTO_MODELS = ("svda", "contact", "exact")


def _auto_candidate(spectrum: xr.Dataset, name: str, modes: int | str, criterion: str,
                    problem: ContactProblem, fixed: Mapping[str, Any],
                    data: FitData, profile: bool | str = False
                    ) -> tuple[xr.Dataset | None, float, str]:
    """Fit one candidate of ``model="auto"``: (result or None, estimated model error, reason).

    ``profile``: profile-likelihood identifiability (the kept candidate's refit only).
    """
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
            ds = fit_data(data, "svda", profile=profile, position=position,
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
            ds = fit_data(data, "contact", radius=radius,
                          profile=profile, indentation=depth,
                          drag=fixed.get("drag"))
        except (ModelValidityError, ConvergenceError) as exc:
            return None, math.inf, f"fit failed: {str(exc).split(';')[0]}"
        error, reason = contact_error(problem.with_material(_sls_of(ds)), position,
                                      float(np.max(spectrum["omega"])))
        return ds, error, f"{reason} at the fitted moduli (k* proportional to E: bias = error)"
    ds = fit_data(data, "exact", modes=modes,
                  criterion=criterion, profile=profile,
                  problem=problem, position=position, mean_force=mean_force)
    return ds, GRID_ERROR, "the exact model on the default grid"


def fit_spectrum_auto(spectrum: xr.Dataset, *, modes: int | str = 1, criterion: str = "bic",
                      accuracy: float | None = None, weights: str | None = None,
                      profile: bool | str = "auto", **fixed: Any) -> xr.Dataset:
    """``fit_spectrum(..., "auto")``: the cheapest spectrum model adequate at the fitted values.

    Tries svda (pre-contact, one mode), contact (Hertz, h̄0 < 0, one mode) and exact in order
    of cost; each approximate fit is kept if its model error estimated at the fitted parameters
    (:func:`viscoforce.choice.svda_error`, :func:`viscoforce.choice.contact_error`), divided by
    the sensitivity of k* to the moduli (the bias it puts on E0, E_inf), meets ``accuracy``,
    otherwise the next is fitted. Before contact the SVDA's stiffness error and the
    sensitivity are both O(κ|u0|), so its moduli are biased by an O(1) fraction of the
    relative error at any position: ``auto`` keeps svda only at a loose accuracy.
    ``attrs["explanation"]`` says what was compared; ``attrs["estimated_model_error"]`` holds
    the estimate of the model kept. ``profile`` (:data:`PROFILE_CHOICES`): the limits and
    identifiability of the kept fit.

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
    data = spectrum_data(spectrum, weights=weights)  # its notes warn once
    rows: list[tuple[str, float, str, dict[str, Any]]] = []
    kept = None
    for name in AUTO_MODELS:
        ds, error, reason = _auto_candidate(spectrum, name, modes, criterion, problem, fixed,
                                            data)
        rows.append((name, error, reason, {}))
        if ds is not None and error <= meets(accuracy):
            # the kept one again, with its profile likelihood (the same fit: deterministic)
            kept = _auto_candidate(spectrum, name, modes, criterion, problem, fixed, data,
                                   profile=profile)[0] if profile else ds
            break
    choice = finish("fit model", rows, accuracy, "")
    if kept is None:  # exact fits or raises; keep the loop honest anyway
        raise ConvergenceError(f"model 'auto' kept no fit: {choice.explanation}")
    kept.attrs["explanation"] = choice.explanation
    kept.attrs["estimated_model_error"] = choice.estimated_error
    kept.attrs["accuracy"] = accuracy
    kept.attrs["validity"] = validity_note(str(kept.attrs["model"]), kept)
    warn_fit(kept, stacklevel=5)
    return kept


def _data_indentation(spectrum: xr.Dataset, data: FitData | None = None) -> float:
    """The operating indentation δ0: the median ``mean_indentation`` of the points fitted.

    The same rule as a map's pixels (:func:`pixel_fit_data`), so a spectrum fitted alone and as
    a one-pixel map uses the same δ0.
    """
    if "mean_indentation" not in spectrum.variables:
        raise ModelValidityError(
            "the contact model needs the operating indentation: this spectrum has no "
            "mean_indentation (no contact point found, or pre-contact); give --indentation D0")
    value = (float(data.source["mean_indentation"]) if data is not None
             and "mean_indentation" in data.source else math.nan)
    if not math.isfinite(value):
        value = float(np.nanmedian(spectrum["mean_indentation"].values))
    if not value > 0:
        raise ModelValidityError(
            f"the contact model refuses a pre-contact spectrum: median mean_indentation "
            f"{value!r} m is not > 0 (use --model svda or exact, or give --indentation D0)")
    return value
