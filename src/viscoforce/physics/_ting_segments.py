"""Ting's hereditary integral on a piecewise-uniform grid (:mod:`viscoforce.physics.ting`).

Instruments record the segments of a curve at different rates (a JPK approach, pause, modulation
and retract: steps 1.25–150× apart), each segment uniformly. The samples then fall into a few
maximal runs of one spacing (:func:`sample_runs`), and the sums of the hereditary integral are
taken run by run:

* within a run, the uniform machinery of :mod:`viscoforce.physics._ting_kernels`: the product
  integration with the kernel's primitive R as one FFT convolution (:func:`interval_sums`, exact);
* from the earlier runs, through the kernel's sum of exponentials E(t) ≈ c0 + Σ c_k e^{−x_k t}:
  the intervals of the earlier runs are carried as one state per exponential, which decays by
  e^{−x_k Δt} from the end of a run to every later sample. The lags are then ≥ the first sample
  step of the later run, inside the range the sum was built for (exact for a Prony kernel,
  relative error ≤ ``rtol`` for the power law: what the loop over the nodes used for every lag
  beyond the current interval).

A response that is a combination of R, r(h, u) = Σ_j w_j R(u + s_j h)/(h or 1) with Σ_j w_j = 0
(:class:`Stencil`: the interval's load per unit increment, the error bound's), splits into a
constant and one exponential each: Σ_j w_j R_soe(u + s_j h) = c0 Σ_j w_j s_j h − Σ_k (c_k/x_k)
Σ_j w_j e^{−x_k s_j h}·e^{−x_k u}. The cost is O(N log N + N·K) for N samples and K exponentials,
plus a few operations per run; grids with runs shorter than :data:`MIN_MEAN_RUN` samples on
average (jittered or scattered times) keep the loop over the nodes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from viscoforce._typing import FloatArray
from viscoforce.physics._ting_kernels import (
    Exponentials,
    RelaxationKernel,
    history_nonuniform,
    interval_sums,
    split_intervals,
)

__all__ = ["BOUND", "HISTORY", "MIN_MEAN_RUN", "NEGLIGIBLE", "SPLIT_LOOP", "Runs", "Stencil",
           "branch_weights", "decays", "grid_sums", "piecewise_sums", "sample_runs",
           "split_intervals", "split_sums"]

#: Fewest sample intervals per run, on average, for the piecewise-uniform path (fewer: the loop).
MIN_MEAN_RUN = 4
#: An exponential e^{−x·lag} is dropped where x·lag exceeds this (its share of the load ≤ 1e-16).
NEGLIGIBLE = 40.0


@dataclass(frozen=True)
class Runs:
    """Maximal runs of uniformly spaced samples.

    Run r covers the samples ``edges[r]`` … ``edges[r + 1]`` (sample indices, the virtual first
    sample of :class:`~viscoforce.physics.ting._History` included; neighbouring runs share their
    edge sample) at the mean spacing ``steps[r]`` [s].
    """

    edges: np.ndarray
    steps: FloatArray


def sample_runs(times: FloatArray, rtol: float) -> Runs | None:
    """The maximal runs of ``times`` whose spacing spreads by ≤ ``rtol`` of its mean.

    Parameters
    ----------
    times : ndarray
        Sample times [s], strictly increasing, ≥ 2.
    rtol : float
        Largest relative spread (max − min)/mean of the spacing within a run.

    Returns
    -------
    Runs or None
        The runs, or None when they hold fewer than :data:`MIN_MEAN_RUN` intervals on average
        (a scattered grid: the loop over the nodes is cheaper).
    """
    h = np.diff(times)
    with np.errstate(invalid="ignore"):
        jump = np.abs(np.diff(h)) > rtol * np.minimum(h[:-1], h[1:])
    starts = np.concatenate(([0], np.flatnonzero(jump) + 1, [h.size]))
    if h.size < MIN_MEAN_RUN * (starts.size - 1):
        return None
    edges, pending = [], list(zip(starts[-2::-1], starts[:0:-1], strict=True))
    while pending:  # a run whose spacing drifts (no single jump) is halved until it holds
        a, b = pending.pop()
        part = h[a:b]
        if b - a == 1 or float(np.ptp(part)) <= rtol * float(np.mean(part)):
            edges.append((a, b))
        else:
            pending += [(a + (b - a) // 2, b), (a, a + (b - a) // 2)]
    if h.size < MIN_MEAN_RUN * len(edges):
        return None
    return Runs(np.array([a for a, _ in edges] + [h.size]),
                np.array([float(np.mean(h[a:b])) for a, b in edges]))


@dataclass(frozen=True)
class Stencil:
    """A response r(h, u) = Σ_j weights_j·R(u + shifts_j·h) / (h if ``per_length`` else 1).

    R is a kernel's primitive, h an interval's length and u the lag from its end [s]; the
    weights sum to 0 (a load from increments, not from levels).
    """

    shifts: tuple[float, ...]
    weights: tuple[float, ...]
    per_length: bool

    def exact(self, primitive: Callable[[FloatArray], FloatArray]
              ) -> Callable[[float, FloatArray], FloatArray]:
        """r(h, u) through the primitive itself (the uniform runs' FFT weights)."""
        def response(h, u):
            out = sum(w * primitive(u + s * h) for s, w in zip(self.shifts, self.weights,
                                                                 strict=True))
            return out / h if self.per_length else out
        return response

    def far(self, h: FloatArray, soe: Exponentials) -> tuple[FloatArray, FloatArray]:
        """r(h, u) = a0(h) + Σ_k a_k(h) e^{−x_k u} through the sum of exponentials.

        Returns a0 of shape (n,) and a_k of shape (n, K) for the n lengths ``h``.
        """
        x = soe.rates
        norm = h if self.per_length else np.ones_like(h)
        a0 = soe.constant * sum(w * s for s, w in zip(self.shifts, self.weights, strict=True)) * h
        ak = sum(w * np.expm1(-np.outer(s * h, x)) for s, w in zip(self.shifts, self.weights,
                                                                   strict=True))
        return a0 / norm, -ak * (soe.amplitudes / x) / norm[:, None]


#: The load of an interval per unit increment: (R(u + h) − R(u))/h.
HISTORY = Stencil((1.0, 0.0), (1.0, -1.0), per_length=True)
#: The error bound's D(u) = 2R(u + h/2) − R(u) − R(u + h) (:func:`~viscoforce.physics.ting.ting_error`).
BOUND = Stencil((0.5, 0.0, 1.0), (2.0, -1.0, -1.0), per_length=False)


#: Bytes of :func:`decays` results kept for the next evaluations of a fit (the same rates and
#: lags come back: the grid is the curve's, the rates change only with the exponent's lattice).
DECAYS_CACHE_BYTES = 32 << 20
_DECAYS: dict[tuple[bytes, bytes], FloatArray] = {}


def decays(rates: FloatArray, lag: FloatArray) -> FloatArray:
    """e^{−x_k·lag_n} as (K, n) for ascending lags ≥ 0, 0 where x_k·lag_n > :data:`NEGLIGIBLE`.

    The exponentials are computed per rate only as far as they are not negligible (rates
    grouped by that length rounded up to a power of two): the fast rates of a power law's sum
    die within a few samples. Results are kept (read-only, :data:`DECAYS_CACHE_BYTES` in all)
    by the bytes of ``rates`` and ``lag``: a fit evaluates the same ones again and again.
    """
    rates = np.ascontiguousarray(rates, dtype=float)
    lag = np.ascontiguousarray(lag, dtype=float)
    key = (rates.tobytes(), lag.tobytes())
    out = _DECAYS.get(key)
    if out is None:
        out = _decays(rates, lag)
        out.flags.writeable = False
        if sum(a.nbytes for a in _DECAYS.values()) + out.nbytes > DECAYS_CACHE_BYTES:
            _DECAYS.clear()
        if out.nbytes <= DECAYS_CACHE_BYTES:
            _DECAYS[key] = out
    return out


def _decays(rates: FloatArray, lag: FloatArray) -> FloatArray:
    out = np.zeros((rates.size, lag.size))
    need = np.searchsorted(lag, NEGLIGIBLE / rates)
    size = np.minimum(lag.size, 2 ** np.ceil(np.log2(np.maximum(need, 1))).astype(int))
    for n in np.unique(size):
        k = np.flatnonzero(size == n)
        out[k, :n] = np.exp(-np.outer(rates[k], lag[:n]))
    return out


_WEIGHTS: dict[tuple[bytes, bytes], FloatArray] = {}


def branch_weights(x: FloatArray, branch: FloatArray) -> FloatArray:
    """e^{−x_k(t_m − t_j+1)}·(1 − e^{−x_k h_j})/(x_k h_j) over the branch's node intervals (K, n).

    Kept (read-only, a few) by the bytes of the rates and the branch's times: a fit evaluates
    the same branch with the same rates again and again (only the contact point moves j0).
    """
    key = (np.ascontiguousarray(x).tobytes(), np.ascontiguousarray(branch).tobytes())
    weight = _WEIGHTS.get(key)
    if weight is None:
        lengths, which = np.unique(np.diff(branch), return_inverse=True)
        xh = np.outer(x, lengths)
        weight = decays(x, branch[-1] - branch[:0:-1])[:, ::-1] * (-np.expm1(-xh) / xh)[:, which]
        weight.flags.writeable = False
        if len(_WEIGHTS) >= 4:
            _WEIGHTS.clear()
        _WEIGHTS[key] = weight
    return weight


def piecewise_sums(t: FloatArray, x: FloatArray, base: np.ndarray, runs: Runs, stencil: Stencil,
                   kernel: RelaxationKernel, soe: Exponentials) -> FloatArray:
    """Σ_i x_i·r(h_i, t_n − t_i+1) over the node intervals that end by t_n = ``t[base]``.

    As :func:`~viscoforce.physics._ting_kernels.interval_sums` (one row per history in ``x``),
    run by run: exact within a run, the earlier runs through ``soe`` (module docstring).
    """
    out = np.zeros((x.shape[0], base.size))
    response = stencil.exact(kernel.primitive)
    rates = soe.rates
    shortest = float(np.min(runs.steps))  # the shortest lag soe serves (History.shortest)
    constant, state, at = np.zeros(x.shape[0]), np.zeros((x.shape[0], rates.size)), None
    last = runs.steps.size - 1
    for r, step in enumerate(runs.steps):
        a, b = int(runs.edges[r]), int(runs.edges[r + 1])
        lo, hi = int(base[a]), int(base[b])
        if at is not None:  # the earlier runs, through the exponentials still awake
            lag = t[base[a + 1:b + 1]] - at
            out[:, a + 1:b + 1] += constant[:, None] + state @ decays(rates, lag)
        xs, local_base = x[:, lo:hi], base[a:b + 1] - lo
        pieces = split_intervals(local_base, hi - lo)
        pieces = pieces[np.any(xs[:, pieces] != 0, axis=0)]
        if pieces.size > SPLIT_LOOP:  # through the exponentials beyond the shortest step
            whole = xs.copy()
            whole[:, pieces] = 0.0
            local = interval_sums(t[lo:hi + 1], whole, local_base, float(step), response)
            local += split_sums(t[lo:hi + 1], xs, local_base, pieces, stencil, response, soe,
                                shortest)
        else:
            local = interval_sums(t[lo:hi + 1], xs, local_base, float(step), response)
        out[:, a + 1:b + 1] += local[:, 1:]
        if r == last:
            break
        # this run's intervals carried to its end t[hi]: the whole sample intervals at the run's
        # step (as its FFT weights take them), the pieces of split ones at their own lengths
        piece = np.ones(hi - lo, dtype=bool)
        piece[(base[a:b] - lo)[np.diff(base[a:b + 1]) == 1]] = False
        decay = decays(rates, t[hi] - t[hi:lo:-1])[:, ::-1].T
        xs = x[:, lo:hi]
        whole = np.where(piece, 0.0, xs)
        a0, ak = stencil.far(np.array([step]), soe)
        p0, pk = stencil.far(np.diff(t[lo:hi + 1])[piece], soe)
        if at is not None:
            state = state * np.exp(-rates * (t[hi] - at))
        state = state + (whole @ decay) * ak[0] + xs[:, piece] @ (pk * decay[piece])
        constant = constant + whole.sum(axis=1) * a0[0] + xs[:, piece] @ p0
        at = t[hi]
    return out


#: A run with more split intervals than this takes them through the exponentials
#: (:func:`split_sums`); fewer: one by one, exactly (:func:`interval_sums`).
SPLIT_LOOP = 8
#: Samples per block of :func:`split_sums`' exponential part (bounds its memory).
_SPLIT_BLOCK = 2048


def split_sums(t: FloatArray, x: FloatArray, base: np.ndarray, pieces: np.ndarray,
               stencil: Stencil, response: Callable[[float, FloatArray], FloatArray],
               soe: Exponentials, shortest: float) -> FloatArray:
    """Σ over the split node intervals ``pieces`` of x_i·r(h_i, t_n − t_i+1) at t_n = t[base].

    A run's kinks and contact crossings split sample intervals into pieces the FFT does not
    take (:func:`interval_sums` adds them one by one, O(pieces × samples) evaluations of the
    primitive). Here each piece is exact at the samples closer to its end than ``shortest``
    (at most a step), and through the sum of exponentials beyond, where it is valid (the
    module docstring: as the earlier runs): a0(h) + Σ_k a_k(h) e^{−x_k u} summed as one state
    per exponential carried from piece to piece, O((pieces + samples)·K).
    """
    rows, nb = x.shape[0], base.size
    out = np.zeros((rows, nb))
    tb, ends = t[base], t[pieces + 1]
    width = t[pieces + 1] - t[pieces]
    weight = x[:, pieces]  # (rows, P)
    first = np.searchsorted(base, pieces + 1)  # the first sample at or after each piece's end
    far = np.maximum(np.searchsorted(tb, ends + shortest), first)  # lags ≥ shortest from here
    near = far - first
    if near.any():  # exact: the few samples within `shortest` of a piece's end
        p = np.repeat(np.arange(pieces.size), near)
        at = np.repeat(first - np.cumsum(near) + near, near) + np.arange(p.size)
        values = weight[:, p] * response(width[p], tb[at] - ends[p])
        for r in range(rows):
            np.add.at(out[r], at, values[r])
    a0, ak = stencil.far(width, soe)  # r(h, u) = a0(h) + Σ_k a_k(h) e^{−x_k u}
    level = np.zeros((rows, nb + 1))
    for r in range(rows):
        np.add.at(level[r], far, weight[r] * a0)
    out += np.cumsum(level, axis=1)[:, :nb]
    rates = soe.rates
    groups, starts = np.unique(far, return_index=True)  # far is non-decreasing
    stops = np.append(starts[1:], pieces.size)
    keep = groups < nb  # pieces whose lags all stay below `shortest` have no far part
    groups, starts, stops = groups[keep], starts[keep], stops[keep]
    if not groups.size:
        return out
    state = np.zeros((groups.size, rows, rates.size))  # at each group's first sample time
    carried = np.zeros((rows, rates.size))
    previous = None
    for g, (n, a, b) in enumerate(zip(groups, starts, stops, strict=True)):
        at = tb[n]
        if previous is not None:
            carried = carried * np.exp(-rates * (at - previous))
        carried = carried + weight[:, a:b] @ (ak[a:b] * np.exp(-np.outer(at - ends[a:b], rates)))
        state[g], previous = carried, at
    segment = np.searchsorted(groups, np.arange(groups[0], nb), side="right") - 1
    for lo in range(0, segment.size, _SPLIT_BLOCK):
        seg = segment[lo:lo + _SPLIT_BLOCK]
        cols = groups[0] + lo + np.arange(seg.size)
        decay = np.exp(-np.outer(rates, tb[cols] - tb[groups[seg]]))  # (K, block)
        out[:, cols] += np.einsum("brk,kb->rb", state[seg], decay)
    return out


def grid_sums(t: FloatArray, dx: FloatArray, kernel: RelaxationKernel, soe: Exponentials,
              base: np.ndarray, step: float | None, runs: Runs | None,
              stencil: Stencil = HISTORY) -> FloatArray:
    """The product-integration sums at the samples ``t[base]`` on any grid.

    Uniform (``step``): :func:`interval_sums` (FFT); piecewise uniform (``runs``):
    :func:`piecewise_sums`; otherwise the loop over the nodes (:func:`history_nonuniform` for
    :data:`HISTORY`, :func:`interval_sums` one interval at a time for another stencil).
    """
    if step is not None or (runs is None and stencil is not HISTORY):
        return interval_sums(t, dx, base, step, stencil.exact(kernel.primitive))
    if runs is not None:
        return piecewise_sums(t, dx, base, runs, stencil, kernel, soe)
    return np.array([history_nonuniform(t, row, kernel, soe) for row in dx])[:, base]

