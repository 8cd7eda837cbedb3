"""Lmfit's ``leastsq``, without lmfit's per-fit machinery: the same MINPACK call, the same numbers.

A closed-form fit of 20 points takes ≈ 0.3 ms of model evaluations; ``lmfit.minimize`` adds
≈ 0.6 ms around them (a deep copy of the Parameters with a new asteval interpreter, a Python
layer on every evaluation, uncertainties objects), which is most of a fit's cost (issue 22).
:func:`leastsq` does what :meth:`lmfit.Minimizer.leastsq` does for the parameters this package
varies — values with optional bounds, no expressions — and nothing else:

- bounds by lmfit's transforms (MINUIT's): x = min + (sin u + 1)(max − min)/2 with both
  bounds, x = min − 1 + √(u² + 1) with a lower bound only, x = max + 1 − √(u² + 1) with an
  upper bound only, x = u without bounds;
- :func:`scipy.optimize.leastsq` with lmfit's settings (ftol = xtol = 1.5e-8, gtol = 0,
  epsfcn = 1e-10, factor = 100, at most 2000 (n + 1) evaluations);
- the covariance moved to the parameters' own scale by the transforms' gradients and scaled
  by the reduced χ² when ``scale_covar``; χ², AIC and BIC as lmfit defines them.

The result has the attributes of :class:`lmfit.minimizer.MinimizerResult` that the fitting code
reads, and its ``params`` are the given Parameters, set to the best values with their stderr
and correlations. ``tests/test_fit_engine.py`` checks it against ``lmfit.minimize`` (values,
covariance, statistics) on every closed-form model. Where a model needs lmfit itself
(expressions, an analytic Jacobian), the callers use lmfit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import lmfit
import numpy as np
from scipy.optimize import leastsq as minpack_leastsq

#: lmfit's leastsq settings (``Minimizer.leastsq``).
SETTINGS = {"ftol": 1.5e-8, "xtol": 1.5e-8, "gtol": 0.0, "epsfcn": 1e-10, "factor": 100}
#: lmfit's ``tiny``: an internal start closer to 0 is 0 (``Parameter.setup_bounds``).
TINY = 1e-15
#: lmfit's messages by MINPACK's ``ier``.
MESSAGES = {0: "Invalid Input Parameters. I.e. more variables than data points given, "
               "tolerance < 0.0, or no data provided.",
            4: "One or more variable did not affect the fit.",
            5: "Too many function evaluations."}


@dataclass
class LeastSquares:
    """The attributes of lmfit's ``MinimizerResult`` that this package reads."""

    params: lmfit.Parameters
    var_names: list[str]
    residual: np.ndarray
    covar: np.ndarray | None
    nfev: int
    ier: int
    success: bool
    message: str
    nvarys: int
    ndata: int = field(init=False)
    nfree: int = field(init=False)
    chisqr: float = field(init=False)
    redchi: float = field(init=False)
    aic: float = field(init=False)
    bic: float = field(init=False)
    method: str = "leastsq"

    def __post_init__(self) -> None:
        self.ndata = int(self.residual.size)
        self.nfree = self.ndata - self.nvarys
        self.chisqr = float(self.residual @ self.residual)
        self.redchi = self.chisqr / max(1, self.nfree)
        loglik = self.ndata * (math.log(self.chisqr / self.ndata) if self.chisqr > 0
                               else -math.inf)
        self.aic = loglik + 2 * self.nvarys
        self.bic = loglik + math.log(self.ndata) * self.nvarys

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

    def internal(self, x: np.ndarray) -> np.ndarray:
        u = x.copy()
        b, lo, hi = self.both, self.lower, self.upper
        u[b] = np.arcsin(np.clip((x[b] - self.low[b]) / self.half[b] - 1.0, -1.0, 1.0))
        u[lo] = np.sqrt((x[lo] - self.low[lo] + 1.0) ** 2 - 1.0)
        u[hi] = np.sqrt((self.high[hi] - x[hi] + 1.0) ** 2 - 1.0)
        u[np.abs(u) < TINY] = 0.0  # as lmfit: MINPACK's difference step is then eps, not eps·|u|
        return u

    def external(self, u: np.ndarray) -> np.ndarray:
        x = u.copy()
        b, lo, hi = self.both, self.lower, self.upper
        x[b] = self.low[b] + (np.sin(u[b]) + 1.0) * self.half[b]
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


def leastsq(residual: Callable[[np.ndarray], np.ndarray], params: lmfit.Parameters, *,
            scale_covar: bool = True) -> LeastSquares:
    """Minimise Σ residual² over the varied ``params`` as ``lmfit.minimize(method="leastsq")``.

    ``residual(x)`` takes the varied parameters' values (in the order of ``params``) as an
    array and returns real residuals. ``params`` (no expressions) are updated in place to the
    best fit; they are the result's ``params``.

    Raises
    ------
    ValueError
        A parameter with an expression (lmfit's own minimiser handles those).
    """
    names = [name for name, p in params.items() if p.vary]
    if any(p.expr for p in params.values()):
        raise ValueError("parameters with expressions need lmfit.minimize")
    low = np.array([params[n].min for n in names], dtype=float)
    high = np.array([params[n].max for n in names], dtype=float)
    bounds = _Bounds(low, high)
    start = np.array([params[n].value for n in names], dtype=float)
    start = np.clip(start, low, high)

    def internal_residual(u: np.ndarray) -> np.ndarray:
        return residual(bounds.external(u))

    max_nfev = 2000 * (len(names) + 1)
    best, cov, info, _, ier = minpack_leastsq(
        internal_residual, bounds.internal(start), full_output=True, maxfev=2 * max_nfev,
        **SETTINGS)
    best = np.atleast_1d(best)
    x = bounds.external(best)
    fvec = np.asarray(info["fvec"], dtype=float)
    result = LeastSquares(params, names, fvec, None, int(info["nfev"]), int(ier),
                          ier in (1, 2, 3, 4),
                          "Fit succeeded." if ier in (1, 2, 3) else MESSAGES.get(
                              ier, "Tolerance seems to be too small."), len(names))
    for name, value in zip(names, x, strict=True):
        params[name].value = float(value)
        params[name].stderr, params[name].correl = None, None
    if cov is not None:
        g = bounds.gradient(best)
        cov = cov * np.outer(g, g)
        if scale_covar:
            cov = cov * result.redchi
        result.covar = cov
        with np.errstate(invalid="ignore"):
            sd = np.sqrt(np.diag(cov))
        for i, name in enumerate(names):
            params[name].stderr = float(sd[i])
            params[name].correl = {other: float(cov[i, j] / (sd[i] * sd[j]))
                                   for j, other in enumerate(names)
                                   if j != i and sd[i] > 0 and sd[j] > 0}
    else:
        result.message += " Could not estimate error-bars."
    return result
