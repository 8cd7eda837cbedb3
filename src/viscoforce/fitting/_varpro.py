"""Variable projection for the sums of exponentials: level + Σ a_i e^{−t/τ_i} (issue 41 item 2).

The ``relaxation`` model (F_inf + Σ dF_i e^{−t/τ_i}) and the ``creep`` model without a tip
(z_inf + Σ dz_i e^{−t/τ_i}) are linear in the level and the amplitudes. For given times the
best of those is a linear least-squares solution, so the fit is a problem in the times alone
(Golub & Pereyra 1973): with Φ(τ) = [1, e^{−t/τ_1}, …] (weighted rows), c(τ) = Φ⁺y and the
residual r(τ) = P⊥y, P⊥ = 1 − ΦΦ⁺. Its Jacobian is Kaufman's (1975) approximation,
∂r/∂θ_k ≈ −P⊥ (∂Φ/∂θ_k) c, which converges as the full one does, at half the cost.

The times are varied as the fit varies them (:mod:`viscoforce.fitting._params`): the chain
log10 τ_1, log10(τ_2/τ_1) ≥ 0, … within the same windows and through the same bound transforms
(:class:`viscoforce.fitting._engine._Bounds`, lmfit's), by MINPACK's ``lmder`` with the
analytic Jacobian. The search of each candidate takes tens of evaluations of the
n-point basis instead of the thousands of model evaluations of finite differences over every
parameter, and it tries the same starts as :func:`viscoforce.fitting.outcome.fit_once` (the
guess, its times spread wider and closer) in the reduced space.

The result is the start of the ordinary fit (:meth:`ExponentialModel.internal_guess`): the
package's engine then converges from it in a few iterations, and its χ², covariance and stderr
are computed for the full parameter set exactly as before — only the search is projected.

References
----------
* G. H. Golub, V. Pereyra, "The differentiation of pseudo-inverses and nonlinear least squares
  problems whose variables separate", SIAM J. Numer. Anal. 10, 413–432 (1973).
* L. Kaufman, "A variable projection method for solving separable nonlinear least squares
  problems", BIT 15, 49–57 (1975).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import leastsq as minpack_leastsq

from viscoforce.fitting import _params as P
from viscoforce.fitting._engine import SETTINGS, _Bounds
from viscoforce.fitting.base import FitModel

__all__ = ["SEARCH_NFEV", "SPREAD_FACTORS", "ExponentialModel", "Projection", "exponential_model",
           "project", "search"]

#: Factors on the log-ratios of the times of the other starts: ``fit_once``'s other start of a
#: selection (``outcome._alternative_starts`` with ``starts=2``).
SPREAD_FACTORS = (2.5,)
#: Most residual evaluations of one projected search, per time varied.
SEARCH_NFEV = 100
_LN10 = math.log(10.0)
#: Smallest reciprocal condition of the unit-diagonal Gram matrix solved directly (below it the
#: times have nearly merged: least squares by lstsq, whose solution is the least-norm one).
_RCOND = 1e-10


@dataclass(frozen=True)
class Projection:
    """The projected fit at given times: coefficients, residual, Jacobian in log10 τ_i.

    ``coef`` = (level, a_1 … a_n); ``residual`` = w·(y − Φc); ``jacobian`` [n_data × n_modes]
    the Kaufman Jacobian of the residual over log10 τ_i; ``rank_ok`` False where Φ is
    numerically rank-deficient (merged times: the coefficients are a least-norm solution).
    """

    coef: np.ndarray
    residual: np.ndarray
    jacobian: np.ndarray
    rank_ok: bool

    @property
    def chisqr(self) -> float:
        """Σ residual²."""
        return float(self.residual @ self.residual)


def project(t: np.ndarray, y: np.ndarray, log_taus: Sequence[float],
            weights: np.ndarray | None = None) -> Projection:
    """Variable projection of level + Σ a_i e^{−t/τ_i} at τ_i = 10**log_taus.

    Parameters
    ----------
    t, y : numpy.ndarray
        Times [s] and data (any unit).
    log_taus : sequence of float
        log10 of the times [s].
    weights : numpy.ndarray, optional
        Weights of the residual (default 1).

    Returns
    -------
    Projection
    """
    t = np.asarray(t, dtype=float)
    taus = 10.0 ** np.asarray(log_taus, dtype=float)
    w = None if weights is None else np.asarray(weights, dtype=float)
    target = np.asarray(y, dtype=float) if w is None else w * np.asarray(y, dtype=float)
    # the basis as rows (contiguous): 1, e^{−t/τ_1}, …; its small Gram matrix does the
    # projections (a QR of the n × (m + 1) basis where that is ill-conditioned)
    basis = np.empty((taus.size + 1, t.size))
    basis[0] = 1.0
    np.exp(-t[None, :] / taus[:, None], out=basis[1:])
    decay = basis[1:].copy()
    if w is not None:
        basis *= w[None, :]
    gram = basis @ basis.T
    scale = np.sqrt(np.diag(gram))
    scale[scale == 0] = 1.0
    unit = gram / np.outer(scale, scale)
    try:
        chol = np.linalg.cholesky(unit)
        rank_ok = bool(np.min(np.diag(chol)) ** 2 > _RCOND)
    except np.linalg.LinAlgError:
        rank_ok = False

    def solve(rhs: np.ndarray) -> np.ndarray:
        """(ΦᵀΦ)⁻¹ rhs, rhs = Φᵀ x (by the Gram matrix, or least norm where rank-deficient)."""
        if rank_ok:
            z = np.linalg.solve(chol, (rhs.T / scale).T)
            return (np.linalg.solve(chol.T, z).T / scale).T
        return np.linalg.lstsq(gram, rhs, rcond=None)[0]

    coef = solve(basis @ target)
    residual = target - coef @ basis
    # ∂Φ_i/∂log10 τ_i = e^{−t/τ_i}·(t/τ_i)·ln 10 (weighted); Kaufman: J_i = −P⊥ (∂Φ_i c_i)
    moved = decay * (t[None, :] / taus[:, None]) * (_LN10 * coef[1:, None])
    if w is not None:
        moved *= w[None, :]
    jac = -(moved - solve(basis @ moved.T).T @ basis).T
    return Projection(coef, residual, jac, rank_ok)


def _chain_names(names: Sequence[str]) -> list[str]:
    return [f"log_{n}" for n in names]


def search(t: np.ndarray, y: np.ndarray, params: P.InternalParameters, level: str,
           steps: Sequence[str], taus: Sequence[str], weights: np.ndarray | None = None,
           *, spread: Sequence[float] = SPREAD_FACTORS) -> float:
    """Move ``params`` (internal, in place) to the projected least-squares optimum.

    The times' internal chain (``log_tau_1``, then log-ratios ≥ 0) is varied within its
    bounds by lmder with the Kaufman Jacobian; the level and the amplitudes are their linear
    least-squares values at the times found. Starts: ``params`` as given and, for several
    modes, its log-ratios times each factor of ``spread``; the lowest χ² is kept. Parameters
    that do not vary are left alone (no search then: returns NaN).

    Returns
    -------
    float
        χ² of the optimum kept (NaN where no start gave a finite one: ``params`` unchanged).
    """
    keys = _chain_names(taus)
    if not all(params[k].vary for k in (level, *steps, *keys)):
        return math.nan
    low = np.array([params[k].min for k in keys], dtype=float)
    high = np.array([params[k].max for k in keys], dtype=float)
    bounds = _Bounds(low, high)
    start = np.array([params[k].value for k in keys], dtype=float)
    starts = [start]
    if len(keys) > 1:
        for factor in spread:
            other = start.copy()
            other[1:] = np.clip(other[1:] * factor, low[1:], high[1:])
            starts.append(other)
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    cache: dict[bytes, Projection] = {}

    def at(v: np.ndarray) -> Projection:
        key = v.tobytes()
        if key not in cache:
            cache.clear()  # lmder asks for the residual, then the Jacobian, at one point
            cache[key] = project(t, y, np.cumsum(bounds.external(v)), weights)
        return cache[key]

    def residual(v: np.ndarray) -> np.ndarray:
        return at(v).residual

    # d/d(internal u_j) = Σ_{i ≥ j} d/d(log10 τ_i): the sum over the chain's members after j
    after = np.triu(np.ones((len(keys), len(keys))))

    def jacobian(v: np.ndarray) -> np.ndarray:
        # rows per internal parameter (col_deriv): times du/dv of the bound transform
        return (after @ at(v).jacobian.T) * bounds.gradient(v)[:, None]

    best: tuple[float, np.ndarray, np.ndarray] | None = None
    for u0 in starts:
        try:
            with warnings.catch_warnings(), np.errstate(all="ignore"):
                warnings.simplefilter("ignore", RuntimeWarning)
                v, _, _, _, ier = minpack_leastsq(
                    residual, bounds.internal(u0), Dfun=jacobian, col_deriv=True,
                    full_output=True,
                    maxfev=SEARCH_NFEV * (len(keys) + 1), ftol=SETTINGS["ftol"],
                    xtol=SETTINGS["xtol"], gtol=SETTINGS["gtol"], factor=SETTINGS["factor"])
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):
            continue
        v = np.atleast_1d(v)
        proj = project(t, y, np.cumsum(bounds.external(v)), weights)
        chi2 = proj.chisqr
        if math.isfinite(chi2) and np.all(np.isfinite(proj.coef)) and (
                best is None or chi2 < best[0]):
            best = (chi2, bounds.external(v), proj.coef)
    if best is None:
        return math.nan
    chi2, u, coef = best
    for key, value in zip(keys, u, strict=True):
        params[key].set(value=float(value))
    for key, value in zip((level, *steps), coef, strict=True):
        params[key].set(value=float(value))
    return chi2


class ExponentialModel(FitModel):
    """A sum-of-exponentials FitModel whose fit starts from the projected optimum.

    :meth:`internal_guess` is the data-driven guess refined by :func:`search`; everything
    else (the function, the layout, the windows) is the model's own. A guess the projection
    cannot improve (NaN or inf from every start) is returned as the data gave it.

    ``searched_starts``: the search already tried the other start of a selection (the times
    spread by :data:`SPREAD_FACTORS`) and kept the best; a fit need not run it again from the
    optimum (:func:`viscoforce.fitting.outcome.fit_once` reads it).
    """

    searched_starts = True

    def __init__(self, base: FitModel, level: str, step: str):
        super().__init__(base.spec, base.raw, base.layout, base.independent, base._guesser,
                         base._tau_window, base._bounded_windows)
        modes = base.spec.modes
        self.level = level
        self.steps = tuple(f"{step}_{i}" for i in range(1, modes + 1))
        self.taus = tuple(f"tau_{i}" for i in range(1, modes + 1))

    def internal_guess(self, data: np.ndarray, x: np.ndarray,
                       weights: np.ndarray | None = None) -> P.InternalParameters:
        """The guess's internal parameters moved to the projected optimum (class docstring).

        ``weights``: those of the residual (curve fits are unweighted: None).
        """
        params = super().internal_guess(data, x)
        y = np.asarray(data)
        if np.iscomplexobj(y) or not np.all(np.isfinite(y)):
            return params
        search(np.asarray(x, dtype=float), y, params, self.level, self.steps, self.taus,
               weights)
        return params


def exponential_model(base: FitModel, level: str, step: str) -> ExponentialModel:
    """``base`` (a level + Σ step_i e^{−t/τ_i} FitModel) with the projected search."""
    return ExponentialModel(base, level, step)
