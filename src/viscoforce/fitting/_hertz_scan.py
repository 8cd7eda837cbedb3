"""The Hertz contact-point scan, all candidates at once: the exhaustive grid and a coarse-then-local one.

Given a contact point c, the Hertz model F = b + s·(z − c) + E·shape(max(z − c, 0)) is linear
in (E, b, s), so the guess of the fit (:func:`~viscoforce.fitting.curve_models.hertz_grid`)
tries a grid of contact points, each with a linear least squares, and keeps the lowest sum of
squares with E > 0. This module computes those least squares for many candidates at once
(issue 41 item 4: 85 ``numpy.linalg.lstsq`` calls on the whole approach, four times per curve,
were 87 % of a Hertz fit):

* **Closed form per candidate** (Frisch–Waugh–Lovell): with f⊥ the force with its straight
  line in z removed and g = shape(max(z − c, 0)), E = Σ g·f⊥ / |g⊥|² and
  SSE = |f⊥|² − (Σ g·f⊥)² / |g⊥|², where |g⊥|² = Σg² − (Σg)²/n − (Σ g·(z − z̄))²/Σ(z − z̄)².
  One evaluation of the tip's ``force_shape`` on a (candidates × samples) block, four sums per
  candidate; samples at or below every candidate of a block (g = 0 there) are left out.
* **The same grid** as :func:`~viscoforce.fitting.curve_models.hertz_grid`
  (:data:`~viscoforce.fitting.curve_models.HERTZ_GUESS_POINTS` quantiles of the samples in the
  contact window, then 21 points within one median grid step of the best): with
  ``coarse=False`` every candidate on every sample (:func:`hertz_scan`'s exhaustive mode,
  the reference).
* **Coarse then local** (``coarse=True``, the default): the quantile grid on every
  ``stride``-th sample (at most :data:`COARSE_SAMPLES`), then on every sample the quantile
  candidates whose coarse SSE lies within :data:`COARSE_MARGIN` noise variances of the
  coarse minimum and their :data:`LOCAL_NEIGHBOURS` (:func:`_coarse_pick`), then the 21-point
  refinement. Where the coarse pass finds no candidate with E > 0, or the local one none, the
  exhaustive scan decides.
* **The least squares** (:func:`hertz_least_squares`: the hertz model's start, the depth
  check's refit): the scan, then the minimum of the closed-form SSE over the contact point
  (variable projection; Brent's bounded search, :func:`~viscoforce.fitting._brent.brent`,
  started from the refinement grid's best point and its two neighbours, whose costs the scan
  knows): the four-parameter
  least squares without a second fit.
* **Per fit, once** (issue 41 item 4, part 2): the samples sorted once per approach (a
  candidate's samples are then a slice), the tip's law without its input checks
  (:func:`unchecked_shape`), blocks in per-thread scratch arrays (:func:`_scratch`), the
  start's scan kept for the checks' sum of squares and mirrored into the direction check's
  costs (:data:`_MEMO_SIZE`, :meth:`_Costs.mirrored`).
* **The direction check screened** (part 3): :func:`hertz_screen`, the grid's subsample pass
  and its best three candidates on every sample, an SSE never below the grid's best; the check
  asks the whole grid only near its threshold.

The kept candidate's SSE is summed from its residuals, its baseline and slope are the straight
line through F − E·shape; they equal the per-candidate ``numpy.linalg.lstsq``
(:func:`~viscoforce.fitting.curve_models.hertz_linear`) to rounding.
tests/fitting/test_hertz_fast_path.py compares both modes with that loop.
"""

from __future__ import annotations

import functools
import threading
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np

from viscoforce.exceptions import ParameterError
from viscoforce.fitting._brent import brent

#: Most samples the coarse pass of :func:`hertz_scan` reads (every ``stride``-th sample).
COARSE_SAMPLES = 512
#: Noise variances (of the coarse pass's best fit) within which a candidate's coarse SSE is
#: re-read on every sample (:func:`_coarse_pick`): a 5σ margin.
COARSE_MARGIN = 25.0
#: Quantile candidates on each side of a coarse minimum that the local pass re-reads on every
#: sample.
LOCAL_NEIGHBOURS = 3
#: Matrix entries (candidates × samples) per block of :func:`scan_costs` (memory stays bounded
#: on long approaches: two such arrays of scratch per thread, :func:`_scratch`).
_BLOCK = 1 << 17
_SCRATCH = threading.local()
#: Blocks of at most this many candidates over at least this many samples set their negative
#: indentations to 0 row by row (each row's are a prefix: one slice each) instead of a pass over
#: the whole block (the direction check's scan reads nearly every sample for each candidate).
_ROW_ZEROING = 24
_ROW_ZEROING_SAMPLES = 2048
#: Candidates per refinement of the best quantile (as the per-candidate loop).
_REFINE_POINTS = 21
#: Brent's tolerance in the contact point of :func:`hertz_least_squares`, in refinement-grid
#: spacings.
_BRENT_XATOL = 1e-6
#: Most brackets :func:`hertz_least_squares` tries (each one refinement-grid spacing on either
#: side of the best point so far).
_BRENT_SHIFTS = 8
#: Scans :func:`_scan` keeps (the last ones), reused on the same inputs: within one Hertz fit
#: the start's scan serves its checks' sum of squares and, mirrored, the direction check's
#: costs; two, so that a later fit of the same curve scans afresh (its timing is its work).
_MEMO_SIZE = 2
_memo: deque = deque(maxlen=_MEMO_SIZE)
#: Relative size of |g⊥|² below which a candidate's shape is a straight line on the samples
#: (no E to fit: the candidate is not eligible, as lstsq's E = 0 there).
_DEGENERATE = 1e-12


def unchecked_shape(tip: Any) -> Callable[..., np.ndarray]:
    """``shape(depth, work=None)``: the tip's ``force_shape`` written over ``depth``, unchecked.

    The tips of :mod:`viscoforce.physics.tips` compute their law in a private ``_shape`` that
    ``force_shape`` calls on a copy after checking its input; the scan and the hertz model's
    function check their indentations once (``max(z − c, 0)`` of finite samples) and call the
    law directly, on a temporary of their own (``work``: optional scratch of its shape). Any
    other object with a ``force_shape`` gets that (checked) written over ``depth``.
    """
    law = getattr(tip, "_shape", None)
    if callable(law):
        return law

    def checked(depth: np.ndarray, work: np.ndarray | None = None) -> np.ndarray:
        depth[...] = tip.force_shape(depth)
        return depth

    return checked


def _scratch(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Two float64 scratch arrays of ``size`` entries, kept per thread.

    A block of the scan is hundreds of kB: fresh arrays of that size come from the operating
    system page by page on every block, which cost more than the arithmetic (measured 4x).
    """
    held = getattr(_SCRATCH, "arrays", None)
    if held is None or held[0].size < size:
        held = (np.empty(size), np.empty(size))
        _SCRATCH.arrays = held
    return held[0][:size], held[1][:size]


class _Costs:
    """The closed-form least squares of one approach at any candidate contact points.

    What does not depend on the candidate is computed once per approach: the samples in
    ascending z (as given where they already ascend, an approach's usual order), the centred z,
    the force with its straight line in z removed, and the basis (1, z − z̄, f⊥) whose products
    with a block of shapes give three of the four sums in one matrix product. The samples of a
    candidate c are then the slice beyond ``searchsorted(z, c)`` (a view, no mask).
    """

    def __init__(self, tip: Any, z: np.ndarray, f: np.ndarray):
        self.tip, self.z, self.f = tip, z, f
        self.shape = unchecked_shape(tip)
        self.n = z.size
        if z.size < 2 or bool(np.all(z[1:] >= z[:-1])):
            zs, fs = z, f
        elif bool(np.all(z[1:] <= z[:-1])):  # descending (the direction check's −z)
            zs, fs = np.ascontiguousarray(z[::-1]), np.ascontiguousarray(f[::-1])
        else:
            order = np.argsort(z, kind="stable")
            zs, fs = z[order], f[order]
        self.zs = zs
        self.z_mean = float(zs.sum()) / self.n  # as numpy's mean, without its wrapper
        zc = zs - self.z_mean
        self.szz = float(zc @ zc)
        fc = fs - float(fs.sum()) / self.n
        fp = fc - zc * (float(zc @ fc) / self.szz) if self.szz > 0 else fc
        self.ss_perp = float(fp @ fp)
        self.basis = np.empty((self.n, 3))
        self.basis[:, 0] = 1.0
        self.basis[:, 1] = zc
        self.basis[:, 2] = fp
        self._sub: tuple[int, _Costs] | None = None

    def subsample(self, stride: int) -> _Costs:
        """The costs of every ``stride``-th sample (in the order given), made once."""
        if self._sub is None or self._sub[0] != stride:
            self._sub = (stride, _Costs(self.tip, self.z[::stride], self.f[::stride]))
        return self._sub[1]

    def mirrored(self) -> _Costs:
        """The costs of (−z, F) (the direction check's), from these without a sort.

        The samples in reverse, z − z̄ negated; f⊥, |f⊥|² and Σ(z − z̄)² are the same.
        """
        out = object.__new__(_Costs)
        out.tip, out.shape, out.n = self.tip, self.shape, self.n
        out.z, out.f = -self.z, self.f
        out.zs = np.ascontiguousarray(-self.zs[::-1])
        out.z_mean, out.szz, out.ss_perp = -self.z_mean, self.szz, self.ss_perp
        out.basis = np.ascontiguousarray(self.basis[::-1])
        out.basis[:, 1] *= -1.0
        out._sub = None if self._sub is None else (self._sub[0], self._sub[1].mirrored())
        return out

    def _sums(self, g: np.ndarray, basis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(SSE, E) from the shapes ``g`` (candidates × samples) over the basis rows given."""
        n, szz = self.n, self.szz
        s1, sz, sgf = (g @ basis).T
        sgg = np.einsum("ij,ij->i", g, g)
        gperp = sgg - s1 * s1 / n - (sz * sz / szz if szz > 0 else 0.0)
        ok = gperp > _DEGENERATE * sgg
        e = np.divide(sgf, gperp, out=np.zeros_like(sgf), where=ok)
        return self.ss_perp - sgf * e, e  # E = 0: the straight line's SSE

    def __call__(self, contacts: np.ndarray, *, ascending: bool = False
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(SSE [N²], E [Pa]) at each candidate (:func:`scan_costs`; ``ascending``: they are)."""
        n, zs = self.n, self.zs
        contacts = np.asarray(contacts, dtype=float).reshape(-1)
        sse = np.full(contacts.size, self.ss_perp)
        modulus = np.zeros(contacts.size)
        if contacts.size == 0:
            return sse, modulus
        order = np.arange(contacts.size) if ascending else np.argsort(contacts, kind="stable")
        sorted_c = contacts if ascending else contacts[order]
        step = max(1, _BLOCK // max(n, 1))
        buffers = _scratch(min(step, sorted_c.size) * n)
        for k in range(0, sorted_c.size, step):
            block = sorted_c[k:k + step]
            first = int(np.searchsorted(zs, block[0], side="right"))
            if first >= n:  # g = 0 for every candidate of the block (and the later ones)
                break
            size = (block.size, n - first)
            delta, work = (b[:size[0] * size[1]].reshape(size) for b in buffers)
            np.subtract(zs[None, first:], block[:, None], out=delta)
            if block.size <= _ROW_ZEROING and size[1] >= _ROW_ZEROING_SAMPLES:
                # z ≤ c is a prefix of each row (z ascends): zero those slices only
                ends = np.searchsorted(zs, block, side="right") - first
                for row, end in enumerate(ends.tolist()):
                    delta[row, :end] = 0.0
            else:
                np.maximum(delta, 0.0, out=delta)
            idx = order[k:k + step]
            sse[idx], modulus[idx] = self._sums(self.shape(delta, work), self.basis[first:])
        return sse, modulus

    def one(self, contact: float) -> tuple[float, float]:
        """(SSE [N²], E [Pa]) at one candidate: :meth:`__call__` without the blocks.

        The same sums in scalars (a 1-D minimisation calls this a dozen times per approach).
        """
        first = int(np.searchsorted(self.zs, contact, side="right"))
        if first >= self.n:
            return self.ss_perp, 0.0
        g = self.shape(self.zs[first:] - contact)
        s1, sz, sgf = (self.basis[first:].T @ g).tolist()
        sgg = float(g @ g)
        gperp = sgg - s1 * s1 / self.n - (sz * sz / self.szz if self.szz > 0 else 0.0)
        if not gperp > _DEGENERATE * sgg:
            return self.ss_perp, 0.0
        e = sgf / gperp
        return self.ss_perp - sgf * e, e

    def solve(self, contact: float, modulus: float) -> tuple[float, np.ndarray]:
        """SSE [N²] and (E, baseline [N], slope [N/m]) at ``contact`` given its E [Pa].

        The baseline and slope are the straight line through F − E·shape (the least squares in
        them given E); the SSE is summed from the residuals.
        """
        z, f = self.z, self.f
        g = self.shape(np.maximum(z - contact, 0.0))
        rest = f - modulus * g
        zc = z - self.z_mean
        slope = float(zc @ rest) / self.szz if self.szz > 0 else 0.0
        baseline = float(rest.mean()) + slope * (contact - self.z_mean)
        residual = rest - baseline - slope * (z - contact)
        return float(residual @ residual), np.array([modulus, baseline, slope])


def scan_costs(tip: Any, z: np.ndarray, f: np.ndarray, contacts: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Sum of squares and E of the linear Hertz fit at each candidate contact point.

    Parameters
    ----------
    tip : Tip
        The tip (its ``force_shape`` F/E [m²] of the indentation [m]).
    z, f : numpy.ndarray
        The approach: tip position [m], force [N] (1-D, one length).
    contacts : numpy.ndarray
        Candidate contact points [m].

    Returns
    -------
    sse : numpy.ndarray
        Σ (F − b − s·(z − c) − E·shape)² [N²] at each candidate's least squares.
    modulus : numpy.ndarray
        The least-squares E [Pa] at each candidate (0 where the shape is a straight line on the
        samples: no contact beyond the candidate).
    """
    return _Costs(tip, np.asarray(z, dtype=float), np.asarray(f, dtype=float))(contacts)


def _best(sse: np.ndarray, modulus: np.ndarray) -> int | None:
    """Index of the lowest SSE with E > 0 (the first on ties), or None."""
    ok = np.flatnonzero(modulus > 0)
    if ok.size == 0:
        return None
    return int(ok[np.argmin(sse[ok])])


def _coarse_pick(sse: np.ndarray, modulus: np.ndarray, samples: int) -> np.ndarray:
    """Quantile indices the local pass re-reads on every sample, from the coarse SSE.

    Every candidate whose coarse SSE lies within :data:`COARSE_MARGIN` noise variances of the
    coarse minimum with E > 0 (the variance per sample of that fit over ``samples`` samples),
    whatever the sign of its coarse E: one the subsampling could have ranked wrong; each with
    :data:`LOCAL_NEIGHBOURS` on either side. A curve with a contact rises by far more than that
    one quantile away from its minimum; an approach of noise only is flat within it, and the
    local pass re-reads it whole.
    """
    low = float(np.min(sse[modulus > 0]))
    margin = COARSE_MARGIN * max(low, 0.0) / max(samples - 3, 1)
    picks = np.flatnonzero(sse <= low + margin)  # E's sign too is noisy there
    near = (picks[:, None] + np.arange(-LOCAL_NEIGHBOURS, LOCAL_NEIGHBOURS + 1)).ravel()
    return np.unique(near[(near >= 0) & (near < sse.size)])


@functools.lru_cache(maxsize=8)
def _levels(points: int) -> np.ndarray:
    """The quantile levels of the grid, ``numpy.linspace(0.02, 0.98, points)`` (read-only)."""
    levels = np.linspace(0.02, 0.98, points)
    levels.flags.writeable = False
    return levels


def _median(values: np.ndarray) -> float:
    """``numpy.median`` of a 1-D array (without its wrapper's checks)."""
    ordered = np.sort(values)
    half = ordered.size // 2
    return float(ordered[half] if ordered.size % 2 else (ordered[half - 1] + ordered[half]) / 2)


def _quantiles(values: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``numpy.quantile(values, q)`` (linear method) of already sorted ``values``."""
    position = q * (values.size - 1)
    below = np.floor(position).astype(int)
    above = np.minimum(below + 1, values.size - 1)
    t = position - below
    a, b = values[below], values[above]
    diff = b - a
    return np.where(t >= 0.5, b - diff * (1 - t), a + diff * t)


def _window_grid(costs: _Costs, window: tuple[float, float], points: int) -> np.ndarray:
    """The quantile candidates (``points`` levels) of the samples in the contact ``window``.

    Raises
    ------
    ParameterError
        Fewer than 4 samples in the window.
    """
    zs = costs.zs
    inner = zs[int(np.searchsorted(zs, window[0], side="left")):
               int(np.searchsorted(zs, window[1], side="right"))]
    if inner.size < 4:
        raise ParameterError("the approach has fewer than 4 points where contact may lie")
    return _quantiles(inner, _levels(points))


def hertz_scan(tip: Any, z: np.ndarray, f: np.ndarray, window: tuple[float, float], *,
               points: int, coarse: bool = True) -> tuple[float, float, np.ndarray] | None:
    """The best (contact point, SSE, (E, baseline, slope)) of the Hertz grid of contact points.

    Parameters
    ----------
    tip : Tip
        The tip of the fit.
    z, f : numpy.ndarray
        The approach: tip position [m], force [N].
    window : (float, float)
        Where the contact point may lie [m] (``contact_window``).
    points : int
        Quantile candidates of the first pass (``HERTZ_GUESS_POINTS``).
    coarse : bool
        Coarse then local (default); False: every candidate on every sample.

    Returns
    -------
    tuple or None
        The contact point [m], the SSE [N²] and (E [Pa], baseline [N], slope [N/m]) there; None
        where no candidate gives E > 0.

    Raises
    ------
    ParameterError
        Fewer than 4 samples in the window.
    """
    found = _scan(tip, z, f, window, points, coarse)
    if found is None:
        return None
    (c, _, e), costs, _, _ = found
    sse, coef = costs.solve(c, e)
    return c, sse, coef


def hertz_least_squares(tip: Any, z: np.ndarray, f: np.ndarray, window: tuple[float, float], *,
                        points: int) -> tuple[float, float, np.ndarray] | None:
    """The Hertz least squares of an approach: :func:`hertz_scan`, then its minimum in c.

    Variable projection: (E, baseline, slope) are linear given the contact point c, so the least
    squares of all four is the minimum over c of the closed-form SSE(c) (:class:`_Costs`), found
    by a bounded Brent search between the scan's best point's neighbours on its refinement grid
    (:func:`~viscoforce.fitting._brent.brent`, from those three points; within the contact
    ``window``; a minimum with E > 0; bracketed again where it lands on the bracket's end).
    What the fitting engine's
    Levenberg–Marquardt reaches from the scan's start at an interior minimum, to its tolerance
    (the depth check's refit, :func:`viscoforce.fitting.hertz_checks.depth_check`).

    Returns
    -------
    tuple or None
        The contact point [m], the SSE [N²] and (E [Pa], baseline [N], slope [N/m]); None where
        no contact point gives E > 0.

    Raises
    ------
    ParameterError
        Fewer than 4 samples in the window.
    """
    found = _scan(tip, np.asarray(z, dtype=float), np.asarray(f, dtype=float), window, points,
                  True)
    if found is None:
        return None
    (c, sse, e), costs, spacing, fine = found

    def cost(x: float) -> float:
        value, modulus = costs.one(x)
        return value if modulus > 0 else costs.ss_perp

    for _ in range(_BRENT_SHIFTS):  # a minimum at the bracket's end: bracket it again there
        lo, hi = max(c - spacing, window[0]), min(c + spacing, window[1])
        if not hi > lo:
            break
        # the refinement grid's points on either side, their costs known: Brent's first points
        known = [(x, fx) for x, fx in fine if lo <= x <= hi and abs(x - c) > 0.5 * spacing]
        x_opt, f_opt = brent(cost, lo, hi, c, sse, known, _BRENT_XATOL * spacing)
        fine = []
        if not f_opt < sse:
            break
        c, sse = x_opt, f_opt
        e = costs.one(c)[1]
        edge = 4 * _BRENT_XATOL * spacing
        if not ((c - lo < edge and lo > window[0]) or (hi - c < edge and hi < window[1])):
            break
    sse, coef = costs.solve(c, e)
    return c, sse, coef


#: Quantile candidates of the subsample pass that :func:`hertz_screen` re-reads on every sample.
SCREEN_KEEP = 3


def hertz_screen(tip: Any, z: np.ndarray, f: np.ndarray, window: tuple[float, float], *,
                 points: int) -> tuple[float, float, np.ndarray] | None:
    """A quick upper bound on the Hertz grid's best SSE: the subsample pass's best, re-read.

    The quantile grid of :func:`hertz_scan` on every ``stride``-th sample (its coarse pass), then
    its :data:`SCREEN_KEEP` best candidates with E > 0 on every sample; no local pass, no
    refinement. The SSE is that of a candidate of the grid, so it is never below the grid's
    best (:func:`hertz_scan`); the direction check
    (:func:`viscoforce.fitting.hertz_checks.approach_direction`, which decides at 25 noise
    variances) screens with it and asks the grid where it comes near. Approaches of at most
    2 × :data:`COARSE_SAMPLES` samples (no subsample pass) and those where the pass finds no
    candidate with E > 0 get :func:`hertz_scan`'s answer.

    Returns
    -------
    tuple or None
        As :func:`hertz_scan`: the contact point [m], the SSE [N²] and (E [Pa], baseline [N],
        slope [N/m]); None where no candidate gives E > 0.
    """
    z = np.asarray(z, dtype=float)
    f = np.asarray(f, dtype=float)
    if z.size <= 2 * COARSE_SAMPLES:
        return hertz_scan(tip, z, f, window, points=points)
    costs = _recall_mirror(tip, z, f) or _Costs(tip, z, f)
    grid = _window_grid(costs, window, points)
    sse, e = costs.subsample(-(-z.size // COARSE_SAMPLES))(grid, ascending=True)
    eligible = np.flatnonzero(e > 0)
    best = None
    if eligible.size:
        picks = np.sort(grid[eligible[np.argsort(sse[eligible], kind="stable")[:SCREEN_KEEP]]])
        sse, e = costs(picks, ascending=True)
        i = _best(sse, e)
        if i is not None:
            c = float(picks[i])
            value, coef = costs.solve(c, float(e[i]))
            best = (c, value, coef)
    # kept as the scans are (a later scan of these samples, or of their mirror, is another key)
    _memo.append(((tuple(map(float, window)), int(points), "screen"), tip, z.copy(), f.copy(),
                  (None,), costs))
    if best is None:
        return hertz_scan(tip, z, f, window, points=points)
    return best


def _scan(tip: Any, z: np.ndarray, f: np.ndarray, window: tuple[float, float], points: int,
          coarse: bool) -> tuple[tuple[float, float, float], _Costs, float, list] | None:
    """The grid's best (contact point, closed-form SSE, E), its costs, refinement spacing and grid.

    The costs are the approach's :class:`_Costs`, the spacing that of the 21-point refinement
    grid [m], the grid its (contact point, SSE) pairs (the SSE of the straight line where
    E ≤ 0); None where no candidate gives E > 0. The last :data:`_MEMO_SIZE` scans are kept
    (:func:`_recall`): the same tip, window and samples again (the hertz model's start, then
    its checks' sum of squares, ``hertz_sse``) reuse the scan.
    """
    z = np.asarray(z, dtype=float)
    f = np.asarray(f, dtype=float)
    key = (tuple(map(float, window)), int(points), bool(coarse))
    kept = _recall(key, tip, z, f)
    if kept is not None:
        return kept[0]
    costs = _recall_mirror(tip, z, f) or _Costs(tip, z, f)
    found = _scan_afresh(tip, z, f, window, points, coarse, costs)
    _memo.append((key, tip, z.copy(), f.copy(), (found,), costs))
    return found


def _same_tip(a: Any, b: Any) -> bool:
    try:
        return a is b or bool(a == b)
    except (TypeError, ValueError):
        return False


def _recall(key: tuple, tip: Any, z: np.ndarray, f: np.ndarray) -> tuple | None:
    """The kept result (in a 1-tuple: it may be None) of a scan of these inputs, or None."""
    for kept_key, kept_tip, kept_z, kept_f, result, _ in tuple(_memo):
        if kept_key != key or kept_z.shape != z.shape:
            continue
        if _same_tip(kept_tip, tip) and np.array_equal(kept_z, z) and np.array_equal(kept_f, f):
            return result
    return None


def _recall_mirror(tip: Any, z: np.ndarray, f: np.ndarray) -> _Costs | None:
    """The costs of the last scan mirrored (:meth:`_Costs.mirrored`) where it scanned (−z, F).

    The last only: the direction check right after the start's scan (not a later fit of the
    same curve, which makes its costs afresh).
    """
    entries = tuple(_memo)
    kept = entries[-1] if entries else None
    if kept is None or kept[2].shape != z.shape or not _same_tip(kept[1], tip):
        return None
    if np.array_equal(kept[2], -z) and np.array_equal(kept[3], f):
        return kept[5].mirrored()
    return None


def _scan_afresh(tip: Any, z: np.ndarray, f: np.ndarray, window: tuple[float, float],
                 points: int, coarse: bool, costs: _Costs | None = None
                 ) -> tuple[tuple[float, float, float], _Costs, float, list] | None:
    """:func:`_scan` without its memory (``costs``: the approach's, where made already)."""
    lo, hi = window
    costs = _Costs(tip, z, f) if costs is None else costs
    grid = _window_grid(costs, window, points)
    best = None
    if coarse and z.size > 2 * COARSE_SAMPLES:
        stride = -(-z.size // COARSE_SAMPLES)
        sse, e = costs.subsample(stride)(grid, ascending=True)
        if np.any(e > 0):
            local = grid[_coarse_pick(sse, e, -(-z.size // stride))]
            sse, e = costs(local, ascending=True)
            i = _best(sse, e)
            if i is not None:
                best = (float(local[i]), float(sse[i]), float(e[i]))
    if best is None:
        sse, e = costs(grid, ascending=True)
        i = _best(sse, e)
        if i is None:
            return None
        best = (float(grid[i]), float(sse[i]), float(e[i]))
    step = _median(np.diff(grid)) if grid.size > 1 else float(np.ptp(z)) / 10
    fine = np.linspace(best[0] - step, best[0] + step, _REFINE_POINTS)
    fine = fine[(fine >= lo) & (fine <= hi)]
    sse, e = costs(fine, ascending=True)
    i = _best(sse, e)
    if i is not None and sse[i] < best[1]:
        best = (float(fine[i]), float(sse[i]), float(e[i]))
    grid_costs = list(zip(fine.tolist(), np.where(e > 0, sse, costs.ss_perp).tolist(),
                          strict=True))
    return best, costs, 2.0 * step / (_REFINE_POINTS - 1), grid_costs

