"""Lmfit's ``leastsq``, without lmfit's per-fit machinery: the same MINPACK call, the same numbers.

``lmfit.minimize`` wraps every fit in a deep copy of the Parameters (a new asteval interpreter),
a Python layer on every evaluation and uncertainties objects: on a closed form of 20 points
that is a sizeable part of the fit (issue 22; benchmarks/README.md, bench_overhead).
:func:`leastsq` does what :meth:`lmfit.Minimizer.leastsq` does for the parameters this package
varies — values with optional bounds, no expressions — and nothing else:

- bounds by lmfit's transforms (MINUIT's): x = min + (sin u + 1)(max − min)/2 with both
  bounds, x = min − 1 + √(u² + 1) with a lower bound only, x = max + 1 − √(u² + 1) with an
  upper bound only, x = u without bounds;
- :func:`scipy.optimize.leastsq` with lmfit's settings (ftol = xtol = 1.5e-8, gtol = 0,
  epsfcn = 1e-10, factor = 100); at most 2000 (n + 1) evaluations, after which the fit is a
  failure, as lmfit aborts it;
- the covariance moved to the parameters' own scale by the transforms' gradients and scaled
  by the reduced χ² when ``scale_covar``; χ², AIC and BIC as lmfit defines them.

The result has the attributes of :class:`lmfit.minimizer.MinimizerResult` that the fitting code
reads, and its ``params`` are the given Parameters, set to the best values with their stderr
and correlations. ``tests/fitting/test_fit_engine.py`` checks it against ``lmfit.minimize`` (values,
covariance, statistics) on every closed-form model. Where a model needs lmfit itself
(expressions), the callers use lmfit; an analytic Jacobian is passed as ``jacobian``
(MINPACK's ``lmder``: the exact model's, issue 41 item 3).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType

import numpy as np
from scipy.optimize import leastsq as minpack_leastsq

from viscoforce.fitting._params import ParameterSet

#: lmfit's leastsq settings (``Minimizer.leastsq``).
SETTINGS = {"ftol": 1.5e-8, "xtol": 1.5e-8, "gtol": 0.0, "epsfcn": 1e-10, "factor": 100}
#: lmfit's ``tiny``: an internal start closer to 0 is 0 (``Parameter.setup_bounds``).
TINY = 1e-15
#: lmfit's messages by MINPACK's ``ier`` (read-only).
MESSAGES: Mapping[int, str] = MappingProxyType({
    0: "Invalid Input Parameters. I.e. more variables than data points given, tolerance < 0.0, "
       "or no data provided.",
    4: "One or more variable did not affect the fit.",
    5: "Too many function evaluations."})


@dataclass(frozen=True)
class LeastSquares:
    """The attributes of lmfit's ``MinimizerResult`` that this package reads.

    The statistics are lmfit's (``MinimizerResult._calculate_statistics``): ``redchi`` from the
    sum of squares, then χ² clamped to ≥ 1e-250·n before AIC and BIC take its logarithm.
    """

    params: ParameterSet
    var_names: list[str]
    residual: np.ndarray
    covar: np.ndarray | None
    nfev: int
    ier: int
    success: bool
    message: str
    nvarys: int
    method: str = "leastsq"
    ndata: int = field(init=False)
    nfree: int = field(init=False)
    chisqr: float = field(init=False)
    redchi: float = field(init=False)
    aic: float = field(init=False)
    bic: float = field(init=False)

    def __post_init__(self) -> None:
        ndata = int(self.residual.size)
        squares = float(self.residual @ self.residual)
        chisqr = max(squares, 1e-250 * ndata)
        loglik = ndata * math.log(chisqr / ndata)
        for key, value in (("ndata", ndata), ("nfree", ndata - self.nvarys),
                           ("redchi", squares / max(1, ndata - self.nvarys)),
                           ("chisqr", chisqr), ("aic", loglik + 2 * self.nvarys),
                           ("bic", loglik + math.log(ndata) * self.nvarys)):
            object.__setattr__(self, key, value)

    @property
    def errorbars(self) -> bool:
        """Whether the covariance was estimated, with every stderr > 0."""
        return self.covar is not None and bool(np.all(np.diag(self.covar) > 0))


class _Bounds:
    """Lmfit's bound transforms of the varied parameters, vectorised."""

    def __init__(self, low: np.ndarray, high: np.ndarray):
        self.low, self.high = low, high
        self.both = np.isfinite(low) & np.isfinite(high)
        self.lower = np.isfinite(low) & ~self.both
        self.upper = np.isfinite(high) & ~self.both
        self.half = np.where(self.both, (high - low) / 2.0, 1.0)
        #: every parameter bounded on both sides (the usual case): one expression, no masks
        self.all_both = bool(self.both.all())
        self.any_both = bool(self.both.any())
        self.any_one_sided = bool(self.lower.any() or self.upper.any())

    def internal(self, x: np.ndarray) -> np.ndarray:
        u = x.copy()
        b, lo, hi = self.both, self.lower, self.upper
        u[b] = np.arcsin(np.clip((x[b] - self.low[b]) / self.half[b] - 1.0, -1.0, 1.0))
        u[lo] = np.sqrt((x[lo] - self.low[lo] + 1.0) ** 2 - 1.0)
        u[hi] = np.sqrt((self.high[hi] - x[hi] + 1.0) ** 2 - 1.0)
        u[np.abs(u) < TINY] = 0.0  # as lmfit: MINPACK's difference step is then eps, not eps·|u|
        return u

    def external(self, u: np.ndarray) -> np.ndarray:
        if self.all_both:  # the masked expression below, elementwise the same operations
            return self.low + (np.sin(u) + 1.0) * self.half
        x = u.copy()
        b, lo, hi = self.both, self.lower, self.upper
        if self.any_both:
            x[b] = self.low[b] + (np.sin(u[b]) + 1.0) * self.half[b]
        if self.any_one_sided:
            x[lo] = self.low[lo] - 1.0 + np.sqrt(u[lo] ** 2 + 1.0)
            x[hi] = self.high[hi] + 1.0 - np.sqrt(u[hi] ** 2 + 1.0)
        return x

    def gradient(self, u: np.ndarray) -> np.ndarray:
        """dx/du at ``u`` (lmfit's ``Parameter.scale_gradient``)."""
        g = np.ones_like(u)
        b, lo, hi = self.both, self.lower, self.upper
        g[b] = np.cos(u[b]) * self.half[b]
        g[lo] = u[lo] / np.sqrt(u[lo] ** 2 + 1.0)
        g[hi] = -u[hi] / np.sqrt(u[hi] ** 2 + 1.0)
        return g


def leastsq(residual: Callable[[np.ndarray], np.ndarray], params: ParameterSet, *,
            scale_covar: bool = True,
            jacobian: Callable[[np.ndarray], np.ndarray] | None = None) -> LeastSquares:
    """Minimise Σ residual² over the varied ``params`` as ``lmfit.minimize(method="leastsq")``.

    Parameters
    ----------
    residual : callable
        ``residual(x)``: the varied parameters' values (in the order of ``params``) as an
        array → real residuals (an exception raised here propagates).
    params : lmfit.Parameters or viscoforce.fitting._params.InternalParameters
        Start values and bounds, without expressions; updated in place to the best fit (values,
        stderr, correlations): they are the result's ``params``.
    scale_covar : bool
        Scale the covariance by the reduced χ² (unknown stderr), as lmfit does.
    jacobian : callable, optional
        ``jacobian(x)``: d residual/dx at the varied values ``x`` (rows: residuals, columns:
        the varied parameters in order). Given, MINPACK's ``lmder`` uses it (times the bound
        transforms' dx/du) instead of forward differences (``lmdif``), with the same settings;
        the covariance is then the analytic Jacobian's. Repeated calls at the same point (scipy
        checks the shapes at the start) are answered from the last one. None: lmfit's path,
        unchanged.

    Returns
    -------
    LeastSquares
        The fit; ``success`` is False when MINPACK stopped without converging (e.g. after
        2000 (n + 1) evaluations, where lmfit aborts).

    Raises
    ------
    TypeError
        A parameter with an expression (lmfit's own minimiser handles those).
    """
    constrained = [name for name, p in params.items() if p.expr]
    if constrained:
        raise TypeError(f"params[{constrained[0]!r}] has the expression "
                        f"{params[constrained[0]].expr!r}: use lmfit.minimize for constrained "
                        "parameters")
    names = [name for name, p in params.items() if p.vary]
    low = np.array([params[n].min for n in names], dtype=float)
    high = np.array([params[n].max for n in names], dtype=float)
    bounds = _Bounds(low, high)
    start = np.clip(np.array([params[n].value for n in names], dtype=float), low, high)

    def internal_residual(u: np.ndarray) -> np.ndarray:
        return residual(bounds.external(u))

    if jacobian is None:
        best, cov, info, _, ier = minpack_leastsq(
            internal_residual, bounds.internal(start), full_output=True,
            maxfev=2000 * (len(names) + 1), **SETTINGS)
    else:
        best, cov, info, _, ier = minpack_leastsq(
            _last(internal_residual), bounds.internal(start), full_output=True,
            Dfun=_last(lambda u: jacobian(bounds.external(u)) * bounds.gradient(u)[None, :]),
            maxfev=2000 * (len(names) + 1), **SETTINGS)
    best = np.atleast_1d(best)
    fvec = np.asarray(info["fvec"], dtype=float)
    message = "Fit succeeded." if ier in (1, 2, 3) else MESSAGES.get(
        ier, "Tolerance seems to be too small.")
    for name, value in zip(names, bounds.external(best), strict=True):
        params[name].value = float(value)
        params[name].stderr, params[name].correl = None, None
    result = LeastSquares(params, names, fvec, None, int(info["nfev"]), int(ier),
                          ier in (1, 2, 3, 4), message + (
                              " Could not estimate error-bars." if cov is None else ""),
                          len(names))
    if cov is None:
        return result
    g = bounds.gradient(best)
    cov = cov * np.outer(g, g) * (result.redchi if scale_covar else 1.0)
    with np.errstate(invalid="ignore"):
        sd = np.sqrt(np.diag(cov))
    for i, name in enumerate(names):
        params[name].stderr = float(sd[i])
        params[name].correl = {other: float(cov[i, j] / (sd[i] * sd[j]))
                               for j, other in enumerate(names)
                               if j != i and sd[i] > 0 and sd[j] > 0}
    return replace(result, covar=cov)


def _last(function: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
    """``function`` answering a call at the previous call's point from its result (a copy)."""
    memo: list[tuple[np.ndarray, np.ndarray]] = []

    def call(u: np.ndarray) -> np.ndarray:
        if memo and np.array_equal(memo[0][0], u):
            return memo[0][1].copy()
        out = np.asarray(function(u), dtype=float)
        memo[:] = [(np.array(u, dtype=float), out.copy())]
        return out

    return call
