"""Lee–Radok's creep integral: the indentation of a rigid tip under a recorded load history.

A rigid axisymmetric tip whose elastic load is F = E·g(δ) (``g`` = :meth:`Tip.force_shape
<viscoforce.physics.tips.Tip.force_shape>` [m²], E the paper's modulus, see
:mod:`viscoforce.units`) pressed into a linear viscoelastic half-space of creep compliance C(t)
(:mod:`viscoforce.physics.materials`) by the load F(t) indents it by δ(t) with

    g(δ(t)) = ψ(t) = ∫ C(t − s) dF(s)

while the contact area grows (Lee & Radok 1960; where it shrinks Ting 1966 applies instead). For
a constant force F0 applied at t = 0, g(δ) = F0·C(t): δ^{3/2} ∝ C(t) for a paraboloid, δ² for a
cone or pyramid, δ itself only for a flat punch.

Numerics
--------
C is a creep Prony series C(t) = J_g + Σ ΔJ_i (1 − e^{−t/τ_i}), so ψ = J_inf·F − Σ ΔJ_i·h_i with
h_i(t) = ∫ e^{−(t−s)/τ_i} dF(s). F is taken piecewise linear between the samples and every interval
is integrated exactly (:func:`creep_integral`): h_i is a first-order recursion, summed in O(N) on
any grid by :func:`decayed_sums`. The map F → ψ is linear; :func:`creep_integral_adjoint` is its
transpose (what propagating the force's noise into a fit needs). :func:`indentation_from_shape`
inverts g; :func:`smoothing_matrix` is the Savitzky–Golay smoother (scipy's ``savgol_filter``,
mode ``interp``) as a sparse matrix, so that its transpose is at hand too.

References
----------
* E. H. Lee, J. R. M. Radok, "The contact problem for viscoelastic bodies", J. Appl. Mech. 27,
  438–444 (1960).
* T. C. T. Ting, "The contact stresses between a rigid indenter and a viscoelastic half-space",
  J. Appl. Mech. 33, 845–854 (1966).
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
import scipy.sparse
from scipy.signal import lfilter, savgol_coeffs

from viscoforce._typing import FloatArray

__all__ = ["creep_integral", "creep_integral_adjoint", "decayed_sums", "indentation_from_shape",
           "smoothing_matrix"]

#: A decayed sum is accumulated over blocks of at most this many time constants (e^400 < 1e174).
_BLOCK = 400.0
#: Creep times below the smallest sample step over this have no memory across a step (e^−40).
_NO_MEMORY = 40.0
#: Steps equal to this relative spread make a uniform grid (the recursion is then a filter).
_UNIFORM = 1e-9


def decayed_sums(t: FloatArray, u: FloatArray, tau: float) -> FloatArray:
    """h_k = Σ_{j≤k} u_j e^{−(t_k − t_j)/τ} for increasing ``t`` [s] (O(N), any grid).

    On a uniform grid the recursion h_k = e^{−Δ/τ} h_{k−1} + u_k runs as a first-order filter
    (``scipy.signal.lfilter``); otherwise it is summed in blocks of at most :data:`_BLOCK` time
    constants, each a cumulative sum scaled by e^{(t_j − t_s)/τ}, the state carried from block
    to block (no overflow, no Python loop per sample).
    """
    steps = np.diff(t)
    if steps.size and float(np.min(steps)) > _NO_MEMORY * tau:
        return np.array(u, dtype=float)
    if steps.size and float(np.ptp(steps)) <= _UNIFORM * float(np.mean(steps)):
        # a uniform grid: the recursion h_k = e^{−Δ/τ} h_{k−1} + u_k is a first-order filter
        return lfilter([1.0], [1.0, -math.exp(-float(np.mean(steps)) / tau)], u)
    x = (t - t[0]) / tau
    blocks = np.floor(x / _BLOCK)
    edges = np.flatnonzero(np.diff(blocks)) + 1
    out = np.empty(x.shape)
    carry, last = 0.0, x[0]
    for s, e in zip(np.concatenate(([0], edges)), np.concatenate((edges, [x.size])),
                    strict=True):
        xs = x[s:e] - x[s]
        run = np.exp(-xs) * np.cumsum(u[s:e] * np.exp(xs)) + carry * np.exp(-(x[s:e] - last))
        out[s:e] = run
        carry, last = float(run[-1]), float(x[e - 1])
    return out


def _phi(dt: FloatArray, tau: float) -> FloatArray:
    """(1 − e^{−Δ/τ})/(Δ/τ): the exact weight of a linear increment over Δ (1 at Δ = 0)."""
    r = dt / tau
    small = r < 1e-8
    return np.where(small, 1.0 - r / 2, -np.expm1(-r) / np.where(small, 1.0, r))


def creep_integral(t: FloatArray, f: FloatArray, glassy: float, deltas: FloatArray,
                   taus: FloatArray) -> FloatArray:
    """ψ(t_k) = ∫ C(t_k − s) dF(s) [m²] for F [N] piecewise linear between the samples.

    Parameters
    ----------
    t : numpy.ndarray
        Sample times [s], strictly increasing.
    f : numpy.ndarray
        The load [N] at ``t``; it rises from 0 to F(t_0) at t_0 (the integral's start).
    glassy : float
        J_g = 1/E0 [1/Pa].
    deltas, taus : numpy.ndarray
        ΔJ_i [1/Pa] and creep times τ_i [s] of C(t) = J_g + Σ ΔJ_i (1 − e^{−t/τ_i}).

    Returns
    -------
    numpy.ndarray
        ψ at ``t`` [N/Pa = m²]: J_inf F − Σ ΔJ_i h_i, each interval integrated exactly.
    """
    out = (glassy + float(np.sum(deltas))) * f
    dt, df = np.diff(t), np.diff(f)
    for dj, tau in zip(deltas, taus, strict=True):
        u = np.concatenate(([f[0]], df * _phi(dt, float(tau))))
        out = out - dj * decayed_sums(t, u, float(tau))
    return out


def creep_integral_adjoint(t: FloatArray, w: FloatArray, glassy: float, deltas: FloatArray,
                           taus: FloatArray) -> FloatArray:
    """Kᵀw for the linear map ψ = K F of :func:`creep_integral` (same arguments, ``w`` over ``t``).

    K = J_inf I − Σ ΔJ_i E_i D_i with D_i F = (F_0, φ_k (F_k − F_{k−1})) and E_i the decayed
    sums; Eᵀ is the decayed sum run backwards in time, Dᵀ a difference.
    """
    out = (glassy + float(np.sum(deltas))) * w
    dt = np.diff(t)
    back = -t[::-1]
    for dj, tau in zip(deltas, taus, strict=True):
        r = decayed_sums(back, w[::-1], float(tau))[::-1]
        a = np.concatenate(([1.0], _phi(dt, float(tau)))) * r
        out = out - dj * (a - np.concatenate((a[1:], [0.0])))
    return out


#: Points of the log–log table of a tip's force shape that starts :func:`indentation_from_shape`.
_TABLE_POINTS = 4000
#: Shallowest indentation of the table [m] (below it the start extrapolates the first interval).
_TABLE_FLOOR = 1e-12
#: Deepest indentation of the table of a tip without a limit [m].
_TABLE_CEILING = 1.0


@functools.lru_cache(maxsize=64)
def _shape_table(tip: Any) -> tuple[FloatArray, FloatArray, float]:
    """(ln δ, ln g(δ)) on a log grid up to the tip's deepest valid δ, and that depth [m]."""
    deepest = getattr(tip, "max_indentation", None)
    top = _TABLE_CEILING if deepest is None else 0.999 * float(deepest)
    log_d = np.linspace(math.log(_TABLE_FLOOR), math.log(top), _TABLE_POINTS)
    log_g = np.log(np.asarray(tip.force_shape(np.exp(log_d)), dtype=float))
    return log_d, log_g, top


def indentation_from_shape(tip: Any, shape: FloatArray, *, rtol: float = 1e-6) -> FloatArray:
    """δ [m] with g(δ) = ``shape`` (the tip's force shape [m²]); 0 where ``shape`` ≤ 0.

    Starts from a log–log table of g (exact for a power law: paraboloid 3/2, cone and pyramid 2,
    flat punch 1; ~1e-6 relative for Sneddon's sphere), then Newton's method on ln g(ln δ), whose
    slope is the local exponent n = δ·g'(δ)/g = δ·a(δ)/g (g' is the contact radius a for an
    axisymmetric punch); it stops after a step below ``rtol`` (the error is then of order
    ``rtol``², Newton's being quadratic). Depths beyond the table (a sphere's deepest valid
    indentation, 1 m otherwise) are clipped to it.
    """
    g = np.asarray(shape, dtype=float)
    out = np.zeros_like(g)
    inside = g > 0
    if not inside.any():
        return out
    target = np.log(g[inside])
    log_d, log_g, top = _shape_table(tip)
    slope = (log_g[1] - log_g[0]) / (log_d[1] - log_d[0])
    start = np.where(target < log_g[0], log_d[0] + (target - log_g[0]) / slope,
                     np.interp(target, log_g, log_d))
    d = np.minimum(np.exp(start), top)
    for _ in range(60):
        gd = np.asarray(tip.force_shape(d), dtype=float)
        n = d * np.asarray(tip.contact_stiffness_factor(d), dtype=float) / gd
        step = np.clip((target - np.log(gd)) / n, -2.0, 2.0)
        d = np.minimum(d * np.exp(step), top)
        if float(np.max(np.abs(step))) <= rtol:
            break
    out[inside] = d
    return out


def smoothing_matrix(n: int, window: int, order: int = 2) -> scipy.sparse.csr_matrix:
    """The Savitzky–Golay smoother of ``n`` samples as a sparse n × n matrix.

    The same numbers as ``scipy.signal.savgol_filter(f, window, order)`` (mode ``interp``: the
    first and last ``window // 2`` outputs evaluate the polynomial fitted to the end windows);
    the identity for ``window`` < ``order`` + 2 or ``n`` ≤ ``window``.
    """
    if window < order + 2 or n <= window:
        return scipy.sparse.identity(n, format="csr")
    half = window // 2
    centre = savgol_coeffs(window, order, use="dot")
    rows = [np.repeat(np.arange(half, n - half), window)]
    cols = [(np.arange(half, n - half)[:, None] + np.arange(-half, half + 1)).ravel()]
    vals = [np.tile(centre, n - 2 * half)]
    for pos in range(half):
        for row, first in ((pos, 0), (n - half + pos, n - window)):
            at = pos if first == 0 else half + 1 + pos
            rows.append(np.full(window, row))
            cols.append(np.arange(first, first + window))
            vals.append(savgol_coeffs(window, order, pos=at, use="dot"))
    return scipy.sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows),
                                                           np.concatenate(cols))), shape=(n, n))
