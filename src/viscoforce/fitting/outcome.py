"""One least-squares fit (:func:`fit_once`) and what it found (:class:`Outcome`).

The minimiser varies the internal parameters (:mod:`viscoforce.fitting._params`) through the
package's MINPACK driver (:mod:`viscoforce.fitting._engine`) from the model's data-driven
guess, and more starts for several modes while the best fit is not settled; the SPEC values
and their covariance follow exactly from the internal ones.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import lmfit
import numpy as np

from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.fitting import _engine, _params
from viscoforce.fitting.base import FitModel
from viscoforce.fitting.data import FitData
from viscoforce.fitting.identify import Profile, profile_parameters


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


def _vector_jacobian(model: FitModel, data: FitData, params: _params.ParameterSet):
    """d(weighted residual)/d(varied internal values) from the model's own derivative, or None.

    A model may carry ``model_jacobian(x, values)``: d model/d(SPEC parameter) over ``x`` as an
    array (points × ``model.names``; complex for a complex model). The internal values' chain
    rule (:func:`viscoforce.fitting._params.to_reported`) and the weights follow here; the
    engine adds its bound transforms. Models without one (all but ``exact``) get None: their
    fits run MINPACK's forward differences exactly as before.
    """
    derivative = getattr(model, "model_jacobian", None)
    if derivative is None:
        return None
    layout, names, x = model.layout, model.names, data.x
    varied = [n for n, p in params.items() if p.vary]
    fixed = {n: p.value for n, p in params.items() if not p.vary}
    weights = None if data.weights is None else (
        data.weights.view(float) if np.iscomplexobj(data.weights) else data.weights)

    def jacobian(argument: np.ndarray) -> np.ndarray:
        values, grads = _params.to_reported(layout, {**fixed, **dict(zip(
            varied, argument.tolist(), strict=True))})
        chain = np.array([[grads[n].get(v, 0.0) for v in varied] for n in names])
        d = -(np.asarray(derivative(x, values)) @ chain)  # residual = y − model
        if np.iscomplexobj(d):  # rows as the residual's (re, im) pairs
            d = np.stack([d.real, d.imag], axis=1).reshape(-1, len(varied))
        if weights is not None:
            d = d * weights[:, None]
        if not np.isfinite(d).all():
            raise ArithmeticError("the model's Jacobian gave NaN or inf at these parameters")
        return d

    return jacobian


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
    if data.weighting == "unweighted" and getattr(model, "autocorrelated", False):
        outcome.lag1 = residual_lag1(np.asarray(res.residual, dtype=float), data.x)
        if cov is not None:
            outcome.covariance = cov * outcome.stderr_factor ** 2
    return outcome


def ascending_order(t: np.ndarray) -> np.ndarray | None:
    """``numpy.argsort(t)``, or None where ``t`` ascends strictly (the order is the identity).

    NumPy's default sort (introsort) is slow on nearly sorted samples (an approach, ≈ 0.1 ms
    for 4000 of them: issue 41 item 4); its stable sort (a merge of runs) is fast there. Where
    the values are distinct the two give the one permutation that sorts them; only values that
    tie (or NaN) take the default sort, whose order of the ties this keeps.
    """
    if t.size < 2 or bool(np.all(t[1:] > t[:-1])):
        return None
    order = np.argsort(t, kind="stable")
    ordered = t[order]
    if bool(np.all(ordered[1:] > ordered[:-1])):  # distinct, no NaN: one sorting order
        return order
    return np.argsort(t)


def sorted_values(x: np.ndarray) -> np.ndarray:
    """``numpy.sort(x)`` (a new array), by the stable sort where the values are distinct.

    As :func:`ascending_order`: the same values in the same order, without the default sort's
    slow pass over nearly sorted samples.
    """
    if x.size < 2 or bool(np.all(x[1:] > x[:-1])):
        return x.copy()
    ordered = np.sort(x, kind="stable")
    if bool(np.all(ordered[1:] > ordered[:-1])):
        return ordered
    return np.sort(x)


def residual_lag1(residual: np.ndarray, t: np.ndarray) -> float:
    """Lag-1 autocorrelation of residuals ordered in time, Σ r_i r_{i+1} / Σ r_i² (0 if < 3)."""
    order = ascending_order(np.asarray(t))
    r = residual if order is None else residual[order]
    if r.size < 3:
        return 0.0
    r = r - r.mean()
    denom = float(r @ r)
    return float(r[:-1] @ r[1:]) / denom if denom > 0 else 0.0


def fit_once(model: FitModel, data: FitData, *, starts: int = 2, settle: bool = True,
             start: Mapping[str, float] | None = None) -> Outcome:
    """Least-squares fit of ``model`` from its data-driven guess (and ``starts`` − 1 more).

    With ``settle``, the other starts are tried only while the best fit so far is not settled
    (:func:`_settled`); a selection by criterion (``modes="auto"``, the measured-data chooser)
    passes False and tries them all, since its choice rests on differences in χ².
    ``start`` (SPEC name → value): the first start instead of the guess, within the windows
    these data give (a refit of part of the data from the whole's fit: the block halves of a
    one-mode curve fit's split-half check, ``fitting.fit._check_halves``, whose one minimum
    lies near the whole's and is reached in a few evaluations).

    Raises
    ------
    ParameterError
        Fewer data values than free parameters.
    ConvergenceError
        No start gave a finite fit.
    """
    prepare = getattr(model, "prepare", None)
    if prepare is not None:  # a model whose numerical accuracy follows the data (exact: the
        prepare(data)        # fitting grid's tolerance from the data's stderr)
    first = (model.internal_guess(data.y, data.x) if start is None
             else model.internal_start(start, data.y, data.x))
    n_free = sum(1 for p in first.values() if p.vary)
    if data.n_values <= n_free:
        raise ParameterError(
            f"model {model.spec.name!r} with {model.spec.modes} mode(s) has {n_free} free "
            f"parameters but the data give only {data.n_values} values "
            f"({data.y.size} points): fit fewer modes or measure more points")
    residual = _vector_residual(model, data, first)
    jacobian = _vector_jacobian(model, data, first)
    best: Outcome | None = None
    errors: list[str] = []
    # a model that searched its other starts itself (the exponential sums, by variable
    # projection: fitting._varpro) hands over the best of them: they are not run again here
    others = 0 if getattr(model, "searched_starts", False) else starts - 1
    for params in itertools.chain([first], _alternative_starts(model, first, others)):
        if settle and best is not None and _settled(best):
            break
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                res = _engine.leastsq(residual, params, scale_covar=not data.sigma_known,
                                      jacobian=jacobian)
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


def summary_stderr(outcome: Outcome) -> dict[str, float | None]:
    """Local stderr of each SPEC parameter (None when the covariance is singular)."""
    names = outcome.model.names
    if outcome.covariance is None:
        return {n: None for n in names}
    var = np.diag(outcome.covariance)
    if not np.all(var >= 0):
        return {n: None for n in names}
    return {n: float(e) for n, e in zip(names, np.sqrt(var), strict=True)}
