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
g(δ(t)) and δ(t) are taken piecewise linear between nodes, and every node interval is integrated
exactly against the kernel through its primitive R(u) = ∫₀ᵘ E(v) dv (product integration):
F(t_n) = Σ_i Δg_i/h_i·[R(t_n − t_{i−1}) − R(t_n − t_i)]. This is exact for the singular power-law
kernel (R(u) = E0 t0^β u^(1−β)/(1 − β)), for which a rectangle or trapezoid rule of E(t − s)
diverges at s = t. The nodes are the samples plus, inside a sample interval, (i) the crossing of
the contact point (δ = max(z − c, 0) of the linear z has a kink there) and (ii) a velocity jump
located by :func:`locate_kinks` where the samples on each side lie on straight lines: the turning
point of a triangle or the ends of a dwell sampled off their corners. Taking the chord across such
a corner instead weighs ~(h/T)^(1−β) of the load on the next samples against a power law (0.06–
0.18 of the peak at β = 0.7, 250–1000 samples per ramp; ≤ 4e-6 once located).
On a uniform grid the sums are discrete convolutions (FFT, O(N log N)) with the few split
intervals added one by one: the approach load, and for the retract Ting's condition and the load
at both ends of the loading branch (the last node out of contact t_j0 and the turning point t_m),
which decide whether the tip still touches and give the load where t₁ sits at an end. In
between, t₁ is found for every retract sample at once by bisection over the loading nodes
(O(N log N)): there the kernel at lags ≥ one sample is a sum of exponentials, exact for a Prony
kernel and a quadrature of t^(−β) = Γ(β)⁻¹∫ x^(β−1) e^(−xt) dx for the power law (trapezoidal in
log x, relative error ≤ ``rtol``, about 45 terms over 4 decades), so that the histories
∫ e^{−x(t_m−s)} dδ over the loading branch are one cumulative sum over its nodes (exact on any
grid). Inside the bracketing node interval δ is linear and the condition is solved exactly with
R (bisection on the fraction), and the load follows with R as well. Grids recorded segment by
segment at different rates (JPK files) are piecewise uniform: each uniformly sampled run takes
the FFT sums, the earlier runs enter through the exponentials
(:mod:`viscoforce.physics._ting_segments`; 20,424 samples in 8 runs: ~45 ms per evaluation
against 0.6–1.3 s for the loop). Scattered grids take the exponential recursion for every lag
beyond the current interval (which stays exact): O(N·K) with a Python loop.

The discretisation error is second order in the sample spacing except near the first contact of
a curved tip (g ∝ t^{3/2} taken linear between nodes against t^−β: order 1.5 − β for a
paraboloid); :func:`ting_error` estimates it by the difference from the same history on every
other sample and bounds it from the shape of the history between nodes, which also covers a
corner that could not be located (a noisy trace). Measured on the real curve of
``studies/ting_real/ting_real.py`` (4000 + 4000 samples, power law): one evaluation 2.8 ms, a
whole fit 0.3 s; its 4000-sample approach alone 0.3 ms and 0.08 s.

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
    KINK_RTOL,
    Exponentials,
    PowerLawRelaxation,
    PronyRelaxation,
    RelaxationKernel,
    locate_kinks,
    relaxation_from_creep,
)
from viscoforce.physics._ting_kernels import SECULAR_STEPS as SECULAR_STEPS
from viscoforce.physics._ting_segments import (
    BOUND,
    Runs,
    branch_weights,
    grid_sums,
    sample_runs,
)
from viscoforce.physics.tips import Flat, Tip

__all__ = [
    "DEFAULT_RTOL",
    "Exponentials",
    "PowerLawRelaxation",
    "PronyRelaxation",
    "RelaxationKernel",
    "TingSolution",
    "locate_kinks",
    "relaxation_from_creep",
    "ting_error",
    "ting_force",
    "ting_solve",
]

#: Largest relative spread of the sample spacing treated as a uniform grid (FFT, filters).
UNIFORM_RTOL = 1e-6
#: Order of the discretisation error assumed by :func:`ting_error` (Richardson factor 2^p − 1).
ERROR_ORDER = 1.0
#: A velocity change across a sample interval counts as an unlocated kink in :func:`ting_error`
#: when it exceeds this many times the median change across the trace's intervals.
KINK_OUTLIER = 8.0


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


@dataclass(frozen=True)
class _History:
    """The piecewise-linear indentation history: nodes at the samples and between them.

    ``nodes`` [s], ``delta`` δ [m] and ``g`` = force_shape(δ) [m²]; the first node is a virtual
    sample one interval before t[0] at δ = 0 (a trace that starts in contact is indented from 0
    over it). ``base`` indexes the samples among the nodes, ``step`` is their spacing on a
    uniform grid (else None), ``runs`` the uniformly spaced runs of a piecewise-uniform grid
    (else None: uniform, or the loop over the nodes), ``kinks`` the sample intervals whose kink
    was located.
    """

    nodes: FloatArray
    delta: FloatArray
    g: FloatArray
    base: np.ndarray
    step: float | None
    runs: Runs | None
    kinks: np.ndarray

    @property
    def shortest(self) -> float:
        """The shortest lag [s] the exponentials serve (module docstring, Numerics)."""
        if self.step is not None:
            return self.step
        if self.runs is not None:
            return float(np.min(self.runs.steps))
        return float(np.min(np.diff(self.nodes)))


def _history(t: FloatArray, z: FloatArray, c: float, tip: Tip) -> _History:
    """The history's nodes: the samples, the kinks located in contact and the contact crossings.

    δ is linear on both pieces of a kink in contact; at a crossing of the contact point δ =
    max(z − c, 0) of the linear z has its own kink.
    """
    delta = np.maximum(z - c, 0.0)
    tt = np.concatenate(([t[0] - (t[1] - t[0])], t))
    steps = np.diff(tt)
    uniform = float(np.ptp(steps)) <= UNIFORM_RTOL * float(np.mean(steps))
    cell, t_kink, z_kink = locate_kinks(t, z)
    keep = (z_kink > c) & (delta[cell] > 0) & (delta[cell + 1] > 0)
    cross = np.flatnonzero((z[:-1] - c) * (z[1:] - c) < 0)
    t_cross = t[cross] + (c - z[cross]) / (z[cross + 1] - z[cross]) * (t[cross + 1] - t[cross])
    split = np.concatenate((cell[keep], cross))
    order = np.argsort(split)
    at = split[order] + 2  # before tt[i + 2]: between the samples i and i + 1
    nodes = np.insert(tt, at, np.concatenate((t_kink[keep], t_cross))[order])
    dd = np.insert(np.concatenate(([0.0], delta)), at,
                   np.concatenate((z_kink[keep] - c, np.zeros(cross.size)))[order])
    base = np.arange(tt.size) + np.searchsorted(at, np.arange(tt.size), side="right")
    runs = None if uniform else sample_runs(tt, UNIFORM_RTOL)
    return _History(nodes, dd, np.asarray(tip.force_shape(dd), dtype=float), base,
                    float(np.mean(steps)) if uniform else None, runs, cell[keep])


def ting_solve(t: ArrayLike, position: ArrayLike, contact_point: float, tip: Tip,
               kernel: RelaxationKernel, *, drag: float = 0.0, velocity: ArrayLike | None = None,
               rtol: float = DEFAULT_RTOL) -> TingSolution:
    """Ting's load on the tip for a tip-position trace z(t) (approach and retract).

    Parameters
    ----------
    t : array_like
        Sample times [s], strictly increasing, ≥ 3 samples (uniform spacing, or uniform runs
        at different rates, takes the fast path: FFT and exponential sums, O(N log N + N·K);
        scattered times O(N·K) with a Python loop).
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
    history = _history(t, z, c, tip)
    load, t1, contact = _hereditary(history, kernel, rtol, flat=isinstance(tip, Flat))
    delta = history.delta[history.base[1:]]
    if v is None:
        v = np.gradient(z, t)
    drag_force = b * v
    m = int(np.argmax(delta))
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

    The larger of two estimates, plus ``rtol`` of the load (the exponential sum's share):

    * the comparison with the load on every other sample F_2h at the shared samples:
      |F_h − F_2h|/(2^p − 1) with p = :data:`ERROR_ORDER` (1: below the orders measured on
      constant-speed ramps), linearly interpolated to the other samples;
    * a bound (:func:`_error_bound`) on g(δ) taken linear between nodes (it limits the order
      near the first contact: the comparison alone gave 0.59 of the error there at β = 0.7) and
      on a velocity jump inside a sample interval that could not be located (a noisy or rippled
      trace: 0.06–0.18 of the peak at β = 0.7 on the sample after such a turning point, the
      comparison alone 0.3–0.4 of it; the bound is attained by a kink, 1.005× there).

    The drag term has no discretisation error of its own (it is B times the given velocity) and
    is left out.

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
    rtol = require_in_range("rtol", rtol, 1e-15, 1e-2)
    history = _history(t, z, c, tip)
    fine, t1, _ = _hereditary(history, kernel, rtol, flat=isinstance(tip, Flat))
    coarse = ting_solve(t[::2], z[::2], c, tip, kernel, rtol=rtol).contact_force
    richardson = np.interp(t, t[::2], np.abs(fine[1:][::2] - coarse) / (2.0**ERROR_ORDER - 1.0))
    bound = _error_bound(history, z, t1, tip, kernel)
    return np.maximum(richardson, bound) + rtol * np.abs(fine[1:])


def _error_bound(history: _History, z: FloatArray, t1: FloatArray, tip: Tip,
                 kernel: RelaxationKernel) -> FloatArray:
    """Bound [N] on the load's error from the history's shape between nodes, at each sample.

    Inside a node interval of length h the load's integrand E(t_n − s)·dg/ds differs from the
    product integration's by E(t_n − s)·w(s), w the deviation of dg/ds from the chord Δg/h: w has
    zero mean, and since E decreases with the lag, |∫E·w| ≤ max|w|·D(u) with D(u) = 2R(u + h/2)
    − R(u) − R(u + h) (u = t_n − the interval's end) and, for w ∈ [lo, hi], ≤ the worst case of
    w = hi near t_n and lo before it. On the retract the load integrates up to t₁, inside an
    interval [t_j, t_j+1]: there w has no zero mean, and max|w|·(R(t_n − t_j) − R(t_n − t₁)) is
    added. Two sources of w are bounded:

    * g(δ) between nodes, δ linear there: dg/ds = g'(δ)·δ' runs between its values at the two
      ends (g' monotone, as for every tip here);
    * a velocity jump inside a sample interval that no kink was located for: the tip's velocity
      there is taken within the range of the interval's and its two neighbours' chord slopes,
      where that range stands out of the trace's own slope changes (> :data:`KINK_OUTLIER`
      times their median: a turning point or a dwell end, not noise or a smooth bend). It enters
      the load through g'(δ) (directly, or through Ting's t₁ on the retract:
      |ΔF| ≤ g'(δ_max)·|ΔΦ|).
    """
    t, d, g, base = history.nodes, history.delta, history.g, history.base
    h = np.diff(t)
    ends = np.diff(d) / h * np.stack((tip.contact_stiffness_factor(d[:-1]),
                                      tip.contact_stiffness_factor(d[1:]))) - np.diff(g) / h
    r = kernel.primitive
    worst = np.max(np.abs(ends), axis=0)
    soe = kernel.exponentials(history.shortest, float(t[-1] - t[0]))
    bound = grid_sums(t, worst[None, :], kernel, soe, base, history.step, history.runs,
                      BOUND)[0]
    tn = t[base]
    partial = np.flatnonzero(np.isfinite(t1) & (t1 < tn))  # retract samples in contact
    j = np.clip(np.searchsorted(t, t1[partial], side="right") - 1, 0, h.size - 1)
    bound[partial] += worst[j] * (r(tn[partial] - t[j]) - r(tn[partial] - t1[partial]))
    # velocity jumps inside a sample interval i (samples i, i + 1; nodes base[i + 1], base[i + 2])
    ts = t[base[1:]]
    slope = np.diff(z) / np.diff(ts)
    i = np.arange(1, slope.size - 1)
    three = np.stack((slope[i - 1], slope[i], slope[i + 1]))
    lo, hi = three.min(axis=0) - slope[i], three.max(axis=0) - slope[i]
    spread = hi - lo
    ds = d[base[1:]]
    jump = ((spread > KINK_OUTLIER * np.median(spread))
            & (spread > 100 * KINK_RTOL * float(np.max(np.abs(slope))))
            & ~np.isin(i, history.kinks) & (ds[i] > 0) & (ds[i + 1] > 0) & (lo < 0) & (hi > 0))
    for k in np.flatnonzero(jump):
        n, width = i[k], ts[i[k] + 1] - ts[i[k]]
        u_end, u_start = ts[n + 1:] - ts[n + 1], ts[n + 1:] - ts[n]
        extreme = 0.0
        for top, bottom in ((hi[k], lo[k]), (lo[k], hi[k])):  # `top` on the part next to t_n
            near = width * bottom / (bottom - top)
            extreme = np.maximum(extreme, np.abs(top * (r(u_end + near) - r(u_end))
                                                 + bottom * (r(u_start) - r(u_end + near))))
        gp = float(tip.contact_stiffness_factor(max(ds[n], ds[n + 1]) + max(hi[k], -lo[k])
                                                * width))
        bound[n + 2:] += gp * extreme
    return bound[1:]


# ── the two branches ──────────────────────────────────────────────────────────────────────────


def _hereditary(history: _History, kernel: RelaxationKernel, rtol: float, *, flat: bool
                ) -> tuple[FloatArray, FloatArray, np.ndarray]:
    """Load, t₁ (NaN out of contact) and the contact flag at the samples (the virtual one first)."""
    t, delta, g, base, step = (history.nodes, history.delta, history.g, history.base,
                               history.step)
    n = t.size
    dg, dd = np.diff(g), np.diff(delta)
    # the exponentials serve lags ≥ one sample interval on a (piecewise) uniform grid (the
    # retract's branch before t_m seen from a later sample, the earlier runs), ≥ the shortest
    # node interval on the loop's
    soe = kernel.exponentials(history.shortest, float(t[-1] - t[0]), rtol)
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
    sums = grid_sums(t, np.array(parts), kernel, soe, base, step, history.runs)
    load, tb, db = sums[0], t[base], delta[base]
    if flat:  # constant contact radius: the approach formula throughout, no tension
        contact = ((load > 0) & (np.arange(base.size) >= int(np.argmax(db > 0)))
                   & (delta[m] > 0))
        return np.maximum(load, 0.0), np.where(contact, tb, np.nan), contact
    contact = db > 0
    t1 = np.where(contact, tb, np.nan)
    if not retract:
        return load, t1, contact
    later = base > m
    force, t1_retract, lost = _unloading(t, delta, g, m, j0, tb[later], sums[1:, later], soe,
                                         kernel)
    load = load.copy()
    load[later] = force
    t1[later] = np.where(lost, np.nan, t1_retract)
    contact[later] = ~lost
    return load, t1, contact


#: Bisection steps on the position of t₁ inside its sample interval.
THETA_STEPS = 30


def _unloading(t: FloatArray, delta: FloatArray, g: FloatArray, m: int, j0: int,
               later: FloatArray, ends: FloatArray, soe: Exponentials,
               kernel: RelaxationKernel) -> tuple[FloatArray, FloatArray, np.ndarray]:
    """Ting's t₁ and load at the samples ``later`` after the turning point t_m (node m).

    ``ends`` holds Φ(t_n, t_j0), Φ(t_n, t_m), Φ(t_n, t_j) = ∫_{t_j}^{t_n} E(t_n − s) dδ, and the
    loads ∫_0^{t_j} E(t_n − s) dg at j0 and m (all exact, from the product-integration sums). In
    between, the loading branch's histories since t_j0 go through the exponentials.
    """
    phi_bottom, phi_top, load_bottom, load_top = ends
    dd, dg = np.diff(delta), np.diff(g)
    lost = phi_bottom <= 0
    at_top = phi_top >= 0
    force = np.where(lost, load_bottom, load_top)
    t1 = np.where(lost, t[j0], t[m])
    active = np.flatnonzero(~lost & ~at_top)
    if not active.size:
        return force, t1, lost
    x, c, c0 = soe.rates, soe.amplitudes, soe.constant
    # the loading branch's histories seen from the turning point, Q[j, k] = ∫_{t_j0}^{t_j}
    # e^{−x_k(t_m − s)} dx(s) for x = δ (and g, at the end): a cumulative sum over its node
    # intervals, exact on any grid (x linear on each: Δx·e^{−x_k(t_m − end)}·(1 − e^{−x_k h})/
    # (x_k h), the last factor once per distinct interval length h); |Q| ≤ ∫|dx|
    weight = branch_weights(x, t[j0:m + 1])
    qa = np.zeros((x.size, m - j0 + 1))  # (K, nodes of the branch)
    np.cumsum(weight * dd[j0:m], axis=1, out=qa[:, 1:])
    tn = later[active]
    p = np.exp(-np.outer(tn - t[m], x)) * c  # (n, k): c_k e^{−x_k(t_n − t_m)}
    base_phi = phi_bottom[active]
    rows = np.arange(active.size)

    def phi(j: np.ndarray, n: np.ndarray) -> np.ndarray:
        """Φ(t_n, t_j) = Φ(t_n, t_j0) − ∫_{t_j0}^{t_j} E(t_n − s) dδ for j0 ≤ j ≤ m."""
        return base_phi[n] - c0 * (delta[j] - delta[j0]) - np.einsum(
            "nk,kn->n", p[n], qa[:, j - j0])

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
    width = t[j + 1] - t[j]
    lag = tn - t[j]  # t_n − t_j
    # inside [t_j, t_j+1]: Φ(t_n, t_j + θh) = Φ(t_n, t_j) − (Δδ/h)[R(t_n − t_j) − R(t_n − t_j − θh)]
    # exactly (δ linear there): θ by bisection (monotone where Δδ > 0)
    r_lag = kernel.primitive(lag)
    rate_d = dd[j] / width
    theta_lo, theta_hi = np.zeros(active.size), np.ones(active.size)
    for _ in range(THETA_STEPS):
        mid = 0.5 * (theta_lo + theta_hi)
        left = phi_lo - rate_d * (r_lag - kernel.primitive(np.maximum(lag - mid * width, 0.0)))
        up = left > 0
        theta_lo = np.where(up, mid, theta_lo)
        theta_hi = np.where(up, theta_hi, mid)
    theta = np.where(rate_d > 0, 0.5 * (theta_lo + theta_hi), 0.0)
    t1_active = t[j] + theta * width
    # F(t_n) = ∫_0^{t1} E(t_n − s) dg = load(t_n, t_j0) + ∫_{t_j0}^{t_j} … + (Δg/h)[R(t_n − t_j)
    # − R(t_n − t1)]
    inner = c0 * (g[j] - g[j0]) + np.einsum("nk,nk->n", p, _prefix(weight * dg[j0:m], j - j0))
    edge = dg[j] / width * (r_lag - kernel.primitive(tn - t1_active))
    force[active] = load_bottom[active] + inner + np.where(theta > 0, edge, 0.0)
    t1[active] = t1_active
    return force, t1, lost



def _prefix(terms: FloatArray, at: np.ndarray) -> FloatArray:
    """Σ_{i < at_n} terms[:, i] for each n, as rows (n, K): sums of blocks, not a whole cumsum."""
    stops, back = np.unique(at, return_inverse=True)
    lead = stops[0] > 0
    sums = np.cumsum(np.add.reduceat(terms, np.concatenate(([0], stops)) if lead else stops,
                                     axis=1), axis=1).T
    if not lead:
        sums = np.concatenate((np.zeros((1, terms.shape[0])), sums))
    return sums[back]
