"""Ting's hereditary integral: the force of a rigid tip on a linear viscoelastic half-space.

For an axisymmetric tip whose elastic load is F = E·g(δ) (``g`` = :meth:`Tip.force_shape
<viscoforce.physics.tips.Tip.force_shape>` [m²], E the paper's modulus, see
:mod:`viscoforce.units`), a sample with relaxation modulus E(t) pressed by the indentation
history δ(t) carries the load (Lee & Radok 1960; Ting 1966)

* while the contact area grows (the approach, up to the time t_m of the deepest indentation)

      F(t) = ∫₀ᵗ E(t − s) d/ds g(δ(s)) ds,

* while it shrinks (t > t_m), with t₁(t) ≤ t_m the earlier time of the same contact radius, fixed by

      ∫_{t₁}^{t} E(t − s) dδ/ds ds = 0,     F(t) = ∫₀^{t₁} E(t − s) d/ds g(δ(s)) ds.

  When no t₁ after the first contact satisfies it (∫ from the contact on is ≤ 0) the tip has left
  the sample surface: F = 0 (the surface recovers more slowly than the tip retracts).

A viscous drag B·dz/dt of the cantilever in the liquid adds to it (z the tip position toward the
sample). The indentation is δ(t) = max(z(t) − z_c, 0) for the contact point z_c. One loading–
unloading cycle is assumed (the contact area grows to one maximum, then shrinks); a hold at the
maximum is part of it. The flat punch has a constant contact radius: its load follows the
approach formula throughout, clipped at 0 (it cannot pull).

Relaxation moduli
-----------------
* :class:`PronyRelaxation` — E(t) = E_inf + Σ E_k e^{−t/ρ_k} (ρ_k stress-relaxation times). The
  project's materials are creep Prony series (:mod:`viscoforce.physics.materials`, creep times
  τ_i); :func:`relaxation_from_creep` converts them exactly (:meth:`PronyRelaxation.from_material`):
  the ρ_k are the zeros of C*(ω) at ω = i/ρ (eigenvalues of a symmetric arrowhead matrix) and the
  E_k its residues. For the standard linear solid ρ = τ·E_inf/E0 and E_1 = E0 − E_inf.
* :class:`PowerLawRelaxation` — Ting's E(t) = E0 (t/t0)^(−β) (+ μ δ_D(t), a Newtonian term whose
  load is μ·dg/dt). It is the structural material E*(ω) = E_ref (iω/ω_ref)^α + iωμ with α = β and
  E_ref = E0 Γ(1 − β) (ω_ref t0)^β, ω_ref = 2π f_ref (:meth:`PowerLawRelaxation.from_structural`,
  :meth:`PowerLawRelaxation.reference_modulus`).

Numerics
--------
g(δ(t)) and δ(t) are taken piecewise linear between the samples, and every sample interval is
integrated exactly against the kernel through its primitive R(u) = ∫₀ᵘ E(v) dv (product
integration): F(t_n) = Σ_i Δg_i/h_i·[R(t_n − t_{i−1}) − R(t_n − t_i)]. This is exact for the
singular power-law kernel (R(u) = E0 t0^β u^(1−β)/(1 − β)), for which a rectangle or trapezoid
rule of E(t − s) diverges at s = t. On a uniform grid these sums are discrete convolutions (FFT,
O(N log N)): the approach load, and for the retract Ting's condition and the load at both ends of
the loading branch (the last sample out of contact t_j0 and the turning point t_m), which decide
whether the tip still touches and give the load where t₁ sits at an end. In between, t₁ is found
for every retract sample at once by bisection over the loading samples (O(N log N)): there the
kernel at lags ≥ one sample is a sum of exponentials, exact for a Prony kernel and a quadrature
of t^(−β) = Γ(β)⁻¹∫ x^(β−1) e^(−xt) dx for the power law (trapezoidal in log x, relative error ≤
``rtol``, about 45 terms over 4 decades), so that the histories ∫ e^{−x(t−s)} dδ over the loading
branch are recursive (batched FFT convolutions on a uniform grid). Inside the bracketing sample
interval δ is linear and the condition is solved exactly with R (bisection on the fraction), and
the load follows with R as well. Non-uniform grids take the exponential recursion for every lag
beyond the current interval (which stays exact): O(N·K) with a Python loop over the samples.

The discretisation error is second order in the sample spacing except near the first contact of
a curved tip (g ∝ t^{3/2} taken linear between samples: order 1.3 measured for a paraboloid);
:func:`ting_error` estimates it by the difference from the same history on every other sample.
Measured on the real curve of ``benchmarks/ting_real.py`` (4000 + 4000 samples, power law): one
evaluation 2.8 ms, a whole fit 0.3 s; its 4000-sample approach alone 0.3 ms and 0.08 s.

References
----------
* E. H. Lee, J. R. M. Radok, "The contact problem for viscoelastic bodies", J. Appl. Mech. 27,
  438–444 (1960).
* T. C. T. Ting, "The contact stresses between a rigid indenter and a viscoelastic half-space",
  J. Appl. Mech. 33, 845–854 (1966).
* Y. M. Efremov, W.-H. Wang, S. D. Hardy, R. L. Geahlen, A. Raman, "Measuring nanoscale
  viscoelastic parameters of cells directly from AFM force-displacement curves", Sci. Rep. 7,
  1541 (2017): the power-law ramp solutions (approach and retract) that the tests reproduce.
* S. Jiang, J. Zhang, Q. Zhang, Z. Zhang, "Fast evaluation of the Caputo fractional derivative
  and its applications to fractional diffusion equations", Commun. Comput. Phys. 21, 650–678
  (2017): sums of exponentials for the power-law history.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.signal import fftconvolve

from viscoforce._limits import DRAG_RANGE, POSITION_RANGE
from viscoforce._typing import FloatArray
from viscoforce._validation import (
    as_float_1d,
    require_in_range,
    require_increasing,
    require_instance,
    require_nonnegative,
    require_plausible,
)
from viscoforce.exceptions import ParameterError
from viscoforce.physics._ting_kernels import (
    DEFAULT_RTOL,
    Exponentials,
    PowerLawRelaxation,
    PronyRelaxation,
    RelaxationKernel,
    relaxation_from_creep,
)
from viscoforce.physics._ting_kernels import SECULAR_STEPS as SECULAR_STEPS
from viscoforce.physics.tips import Flat, Tip

__all__ = [
    "DEFAULT_RTOL",
    "Exponentials",
    "PowerLawRelaxation",
    "PronyRelaxation",
    "RelaxationKernel",
    "TingSolution",
    "relaxation_from_creep",
    "ting_error",
    "ting_force",
    "ting_solve",
]

#: Largest relative spread of the sample spacing treated as a uniform grid (FFT, filters).
UNIFORM_RTOL = 1e-6
#: Order of the discretisation error assumed by :func:`ting_error` (Richardson factor 2^p − 1).
ERROR_ORDER = 1.0


# ── the hereditary integral ───────────────────────────────────────────────────────────────────


@dataclass(frozen=True)
class TingSolution:
    """Ting's load along an indentation history.

    Attributes
    ----------
    time : ndarray
        Sample times t [s].
    force : ndarray
        Total load [N]: ``contact_force`` + ``drag_force``.
    contact_force : ndarray
        The hereditary-integral load [N] (≥ 0 on the approach; 0 out of contact).
    drag_force : ndarray
        B·dz/dt [N].
    indentation : ndarray
        δ(t) = max(z − z_c, 0) [m].
    t1 : ndarray
        Ting's t₁ [s]: t itself on the loading branch, the earlier time of the same contact
        radius on the unloading branch (NaN before the first contact).
    in_contact : ndarray of bool
        Whether the tip touches the sample (δ > 0 while loading; t₁ after the first contact while
        unloading).
    turning_index : int
        Index of the deepest indentation t_m (the end of the loading branch).
    """

    time: FloatArray
    force: FloatArray
    contact_force: FloatArray
    drag_force: FloatArray
    indentation: FloatArray
    t1: FloatArray
    in_contact: np.ndarray
    turning_index: int


def _inputs(t: ArrayLike, position: ArrayLike, contact_point: float, tip: Tip,
            kernel: RelaxationKernel, drag: float, velocity: ArrayLike | None
            ) -> tuple[FloatArray, FloatArray, float, float, FloatArray | None]:
    t = require_increasing("t (time)", t)
    if t.size < 3:
        raise ParameterError(f"t (time) needs at least 3 samples, got {t.size}")
    z = as_float_1d("position (tip position)", position)
    if z.size != t.size:
        raise ParameterError(f"position (tip position) must have one value per time sample "
                             f"({t.size}), got {z.size}")
    # 1e300 m: every sample off contact, a fit of nothing (POSITION_RANGE: no piezo moves a metre)
    c = require_plausible("contact_point", contact_point, POSITION_RANGE, "m")
    require_instance("tip", tip, Tip)
    require_instance("kernel", kernel, RelaxationKernel)
    b = require_plausible("drag", require_nonnegative("drag", drag), DRAG_RANGE, "N*s/m",
                          why="a hydrodynamic drag B")
    v = None
    if velocity is not None:
        v = as_float_1d("velocity", velocity)
        if v.size != t.size:
            raise ParameterError(f"velocity must have one value per time sample ({t.size}), "
                                 f"got {v.size}")
    return t, z, c, b, v


def ting_solve(t: ArrayLike, position: ArrayLike, contact_point: float, tip: Tip,
               kernel: RelaxationKernel, *, drag: float = 0.0, velocity: ArrayLike | None = None,
               rtol: float = DEFAULT_RTOL) -> TingSolution:
    """Ting's load on the tip for a tip-position trace z(t) (approach and retract).

    Parameters
    ----------
    t : array_like
        Sample times [s], strictly increasing, ≥ 3 samples (uniform spacing takes the fast path:
        FFT and recursive filters, O(N log N); otherwise O(N·K) with a Python loop).
    position : array_like
        Tip position z(t) [m] toward the sample (``tip_position`` of a curves dataset), finite.
    contact_point : float
        z_c [m], within :data:`~viscoforce._limits.POSITION_RANGE`: the indentation is
        δ = max(z − z_c, 0). A trace that starts in contact is taken as indented from 0 over
        the sample interval before t[0].
    tip : Tip
        The indenter (:mod:`viscoforce.physics.tips`); g = ``tip.force_shape``.
    kernel : RelaxationKernel
        The relaxation modulus (:class:`PronyRelaxation`, :class:`PowerLawRelaxation`), paper
        convention.
    drag : float
        Viscous drag coefficient B [N·s/m], ≥ 0 and within
        :data:`~viscoforce._limits.DRAG_RANGE` (load B·dz/dt).
    velocity : array_like, optional
        dz/dt [m/s] for the drag (default the central differences of ``position``; give a
        smoothed one for noisy traces).
    rtol : float
        Relative accuracy of the power law's exponential sum (retract only), in [1e-15, 1e-2].

    Returns
    -------
    TingSolution
        The load and its parts, δ, t₁ and the contact flag per sample.

    Raises
    ------
    ParameterError
        Non-increasing or non-finite times, a position of the wrong length or not finite, a
        non-finite contact point, a negative drag, or a tip or kernel of the wrong type.
    """
    t, z, c, b, v = _inputs(t, position, contact_point, tip, kernel, drag, velocity)
    rtol = require_in_range("rtol", rtol, 1e-15, 1e-2)
    delta = np.maximum(z - c, 0.0)
    # a virtual sample one interval before t[0] at zero indentation: a trace that starts in
    # contact is indented from 0 over that interval (nothing changes otherwise)
    tt = np.concatenate(([t[0] - (t[1] - t[0])], t))
    dd = np.concatenate(([0.0], delta))
    gg = np.concatenate(([0.0], np.asarray(tip.force_shape(delta), dtype=float)))
    steps = np.diff(tt)
    uniform = float(np.ptp(steps)) <= UNIFORM_RTOL * float(np.mean(steps))
    load, t1, contact = _hereditary(tt, dd, gg, kernel, uniform, rtol, flat=isinstance(tip, Flat))
    if v is None:
        v = np.gradient(z, t)
    drag_force = b * v
    m = max(int(np.argmax(dd)) - 1, 0)
    return TingSolution(t, load[1:] + drag_force, load[1:], drag_force, delta, t1[1:],
                        contact[1:], m)


def ting_force(t: ArrayLike, position: ArrayLike, contact_point: float, tip: Tip,
               kernel: RelaxationKernel, *, drag: float = 0.0, velocity: ArrayLike | None = None,
               rtol: float = DEFAULT_RTOL) -> FloatArray:
    """Ting's total load [N] (hereditary integral plus drag) at the times ``t``.

    The arguments are those of :func:`ting_solve`, which also returns the parts.

    Parameters
    ----------
    t : array_like
        Sample times [s], strictly increasing.
    position : array_like
        Tip position z(t) [m] toward the sample.
    contact_point : float
        z_c [m].
    tip : Tip
        The indenter.
    kernel : RelaxationKernel
        The relaxation modulus.
    drag : float
        B [N·s/m], ≥ 0.
    velocity : array_like, optional
        dz/dt [m/s] of the drag term.
    rtol : float
        Accuracy of the power law's exponential sum.

    Returns
    -------
    ndarray
        F(t) [N], one per sample.

    Raises
    ------
    ParameterError
        As :func:`ting_solve`.
    """
    return ting_solve(t, position, contact_point, tip, kernel, drag=drag, velocity=velocity,
                      rtol=rtol).force


def ting_error(t: ArrayLike, position: ArrayLike, contact_point: float, tip: Tip,
               kernel: RelaxationKernel, *, rtol: float = DEFAULT_RTOL) -> FloatArray:
    """Estimated discretisation error [N] of the hereditary load at each sample.

    The load on every other sample F_2h is compared with F_h at the shared samples:
    |F_h − F_2h|/(2^p − 1) with p = :data:`ERROR_ORDER` (1: below the orders measured on the
    constant-speed ramps, 1.3 near the first contact of a paraboloid and 2 elsewhere, so the
    estimate is conservative), linearly interpolated to the other samples. The drag term has no discretisation
    error of its own (it is B times the given velocity) and is left out.

    Parameters
    ----------
    t, position, contact_point, tip, kernel, rtol :
        As :func:`ting_solve` (t needs ≥ 6 samples).

    Returns
    -------
    ndarray
        Error estimate [N], ≥ 0, one per sample.

    Raises
    ------
    ParameterError
        As :func:`ting_solve`, or fewer than 6 samples.
    """
    t, z, c, _, _ = _inputs(t, position, contact_point, tip, kernel, 0.0, None)
    if t.size < 6:
        raise ParameterError(f"ting_error needs at least 6 samples (3 on every other one), got "
                             f"{t.size}")
    fine = ting_solve(t, z, c, tip, kernel, rtol=rtol).contact_force
    coarse = ting_solve(t[::2], z[::2], c, tip, kernel, rtol=rtol).contact_force
    diff = np.abs(fine[::2] - coarse) / (2.0**ERROR_ORDER - 1.0)
    return np.interp(t, t[::2], diff)


# ── the two branches ──────────────────────────────────────────────────────────────────────────


def _hereditary(t: FloatArray, delta: FloatArray, g: FloatArray, kernel: RelaxationKernel,
                uniform: bool, rtol: float, *, flat: bool
                ) -> tuple[FloatArray, FloatArray, np.ndarray]:
    """Load, t₁ (NaN out of contact) and the contact flag on a grid whose first sample has δ = 0."""
    n = t.size
    dg, dd = np.diff(g), np.diff(delta)
    h_min = float(np.min(np.diff(t)))
    soe = kernel.exponentials(h_min, float(t[-1] - t[0]), rtol)
    m = int(np.argmax(delta))
    retract = not flat and 0 < m < n - 1 and delta[m] > 0
    j0 = int(np.flatnonzero(delta[:m + 1] <= 0)[-1]) if retract else 0
    # the product-integration sums Σ_i Δx_i/h_i [R(t_n − t_{i−1}) − R(t_n − t_i)] of: g (the
    # approach load), δ after t_j0 and after t_m (Ting's condition at the two ends of the
    # loading branch), g up to t_j0 and up to t_m (the retract load at those ends)
    after = np.arange(1, n)  # interval i ends at t_i
    parts = [dg]
    if retract:
        parts += [dd * (after > j0), dd * (after > m), dg * (after <= j0), dg * (after <= m)]
    if uniform:
        h = float(t[-1] - t[0]) / (n - 1)
        weights = np.diff(kernel.primitive(h * np.arange(n))) / h  # W_k, k = 0 … n−2
        sums = fftconvolve(np.array(parts), weights[None, :], axes=1)[:, :n - 1]
    else:
        sums = np.array([_history_nonuniform(t, x, kernel, soe)[1:] for x in parts])
    sums = np.concatenate([np.zeros((len(parts), 1)), sums], axis=1)
    load = sums[0]
    if flat:  # constant contact radius: the approach formula throughout, no tension
        contact = (load > 0) & (np.arange(n) >= int(np.argmax(delta > 0))) & (delta[m] > 0)
        return np.maximum(load, 0.0), np.where(contact, t, np.nan), contact
    contact = delta > 0
    t1 = np.where(contact, t, np.nan)
    if not retract:
        return load, t1, contact
    later = slice(m + 1, None)
    force, t1_retract, lost = _unloading(t, delta, g, dd, dg, m, j0, sums[1, later],
                                         sums[2, later], sums[3, later], sums[4, later], soe,
                                         kernel, uniform)
    load = load.copy()
    load[later] = force
    t1[later] = np.where(lost, np.nan, t1_retract)
    contact[later] = ~lost
    return load, t1, contact


def _history_nonuniform(t: FloatArray, dx: FloatArray, kernel: RelaxationKernel,
                        soe: Exponentials) -> FloatArray:
    """Σ_i Δx_i/h_i [R(t_n − t_{i−1}) − R(t_n − t_i)] on any grid.

    The interval ending at t_n exactly, the earlier ones through the exponentials (their lags are
    ≥ the shortest interval).
    """
    steps = np.diff(t)
    local = dx / steps * kernel.primitive(steps)  # the interval ending at t_n
    x, c = soe.rates, soe.amplitudes
    out = np.zeros(t.size)
    state = np.zeros(x.size)  # ∫_0^{t_j} e^{−x(t_j − s)} dx/ds ds
    level = 0.0  # x(t_j) − x(t_0)
    for j in range(1, t.size):
        h = steps[j - 1]
        decay = np.exp(-x * h)
        out[j] = soe.constant * level + float(c @ (decay * state)) + local[j - 1]
        state = decay * state + dx[j - 1] / h * (-np.expm1(-x * h)) / x
        level += dx[j - 1]
    return out


def _filtered(t: FloatArray, dx: FloatArray, rates: FloatArray, uniform: bool) -> FloatArray:
    """A[j, k, :] = ∫_{t_0}^{t_j} e^{−x_k(t_j − s)} dx/ds ds on the grid ``t`` (x piecewise linear).

    ``dx`` holds the increments over the intervals of ``t`` (one column per history). On a
    uniform grid the sums Σ_i b_k a_k^{j−i} u_i are one batched FFT convolution.
    """
    out = np.zeros((t.size, rates.size, dx.shape[1]))
    if t.size < 2 or not rates.size:
        return out
    steps = np.diff(t)
    rate_in = dx / steps[:, None]
    if uniform:
        h = float(steps[0])
        lags = np.arange(t.size - 1) * h
        kern = np.exp(-np.outer(rates, lags)) * (-np.expm1(-rates * h) / rates)[:, None]
        out[1:] = fftconvolve(kern[:, :, None], rate_in[None, :, :], axes=1)[:, :t.size - 1
                                                                            ].transpose(1, 0, 2)
        return out
    decay = np.exp(-np.outer(steps, rates))
    gain = -np.expm1(-np.outer(steps, rates)) / rates
    state = np.zeros((rates.size, dx.shape[1]))
    for j in range(t.size - 1):
        state = decay[j, :, None] * state + gain[j, :, None] * rate_in[j]
        out[j + 1] = state
    return out


#: Bisection steps on the position of t₁ inside its sample interval.
THETA_STEPS = 30


def _unloading(t: FloatArray, delta: FloatArray, g: FloatArray, dd: FloatArray, dg: FloatArray,
               m: int, j0: int, phi_bottom: FloatArray, phi_top: FloatArray,
               load_bottom: FloatArray, load_top: FloatArray, soe: Exponentials,
               kernel: RelaxationKernel, uniform: bool
               ) -> tuple[FloatArray, FloatArray, np.ndarray]:
    """Ting's t₁ and load for the samples after the turning point m.

    ``phi_bottom``/``phi_top`` are Φ(t_n, t_j0) and Φ(t_n, t_m), Φ(t_n, t_j) = ∫_{t_j}^{t_n}
    E(t_n − s) dδ; ``load_bottom``/``load_top`` the loads ∫_0^{t_j} E(t_n − s) dg at j0 and m
    (all exact, from the product-integration sums). In between, the loading branch's histories
    since t_j0 go through the exponentials.
    """
    later = t[m + 1:]
    lost = phi_bottom <= 0
    at_top = phi_top >= 0
    force = np.where(lost, load_bottom, load_top)
    t1 = np.where(lost, t[j0], t[m])
    active = np.flatnonzero(~lost & ~at_top)
    if not active.size:
        return force, t1, lost
    x, c, c0 = soe.rates, soe.amplitudes, soe.constant
    branch = slice(j0, m + 1)
    hist = _filtered(t[branch], np.column_stack([dd[j0:m], dg[j0:m]]), x, uniform)
    # scaled to the turning point: Q[j, k] = e^{−x_k(t_m − t_j)}·A[j, k] (≤ |A|: no overflow)
    to_m = np.exp(-np.outer(t[m] - t[branch], x))
    qa, qb = to_m * hist[:, :, 0], to_m * hist[:, :, 1]
    tn = later[active]
    p = np.exp(-np.outer(tn - t[m], x)) * c  # (n, k): c_k e^{−x_k(t_n − t_m)}
    base_phi = phi_bottom[active]
    rows = np.arange(active.size)

    def phi(j: np.ndarray, n: np.ndarray) -> np.ndarray:
        """Φ(t_n, t_j) = Φ(t_n, t_j0) − ∫_{t_j0}^{t_j} E(t_n − s) dδ for j0 ≤ j ≤ m."""
        return base_phi[n] - c0 * (delta[j] - delta[j0]) - np.einsum(
            "nk,nk->n", p[n], qa[j - j0])

    lo = np.full(active.size, j0)
    hi = np.full(active.size, m)
    phi_lo = base_phi.copy()
    while True:
        open_ = np.flatnonzero(hi - lo > 1)
        if not open_.size:
            break
        mid = (lo[open_] + hi[open_]) // 2
        value = phi(mid, rows[open_])
        up = value > 0
        lo[open_[up]], phi_lo[open_[up]] = mid[up], value[up]
        hi[open_[~up]] = mid[~up]
    j = lo
    step = t[j + 1] - t[j]
    lag = tn - t[j]  # t_n − t_j
    # inside [t_j, t_j+1]: Φ(t_n, t_j + θh) = Φ(t_n, t_j) − (Δδ/h)[R(t_n − t_j) − R(t_n − t_j − θh)]
    # exactly (δ linear there): θ by bisection (monotone where Δδ > 0)
    r_lag = kernel.primitive(lag)
    rate_d = dd[j] / step
    theta_lo, theta_hi = np.zeros(active.size), np.ones(active.size)
    for _ in range(THETA_STEPS):
        mid = 0.5 * (theta_lo + theta_hi)
        left = phi_lo - rate_d * (r_lag - kernel.primitive(np.maximum(lag - mid * step, 0.0)))
        up = left > 0
        theta_lo = np.where(up, mid, theta_lo)
        theta_hi = np.where(up, theta_hi, mid)
    theta = np.where(rate_d > 0, 0.5 * (theta_lo + theta_hi), 0.0)
    t1_active = t[j] + theta * step
    # F(t_n) = ∫_0^{t1} E(t_n − s) dg = load(t_n, t_j0) + ∫_{t_j0}^{t_j} … + (Δg/h)[R(t_n − t_j)
    # − R(t_n − t1)]
    inner = c0 * (g[j] - g[j0]) + np.einsum("nk,nk->n", p, qb[j - j0])
    edge = dg[j] / step * (r_lag - kernel.primitive(tn - t1_active))
    force[active] = load_bottom[active] + inner + np.where(theta > 0, edge, 0.0)
    t1[active] = t1_active
    return force, t1, lost
