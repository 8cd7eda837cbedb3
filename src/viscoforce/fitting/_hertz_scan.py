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
* **The least squares** (:func:`hertz_least_squares`, the depth check's refit): the scan, then
  the minimum of the closed-form SSE over the contact point (variable projection, a bounded
  Brent search): the four-parameter least squares without a second fit.

The kept candidate's SSE is summed from its residuals, its baseline and slope are the straight
line through F − E·shape; they equal the per-candidate ``numpy.linalg.lstsq``
(:func:`~viscoforce.fitting.curve_models.hertz_linear`) to rounding.
tests/fitting/test_hertz_fast_path.py compares both modes with that loop.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from viscoforce.exceptions import ParameterError

#: Most samples the coarse pass of :func:`hertz_scan` reads (every ``stride``-th sample).
COARSE_SAMPLES = 512
#: Noise variances (of the coarse pass's best fit) within which a candidate's coarse SSE is
#: re-read on every sample (:func:`_coarse_pick`): a 5σ margin.
COARSE_MARGIN = 25.0
#: Quantile candidates on each side of a coarse minimum that the local pass re-reads on every
#: sample.
LOCAL_NEIGHBOURS = 3
#: Matrix entries (candidates × samples) per block of :func:`scan_costs` (memory stays bounded
#: on long approaches).
_BLOCK = 1 << 19
#: Candidates per refinement of the best quantile (as the per-candidate loop).
_REFINE_POINTS = 21
#: Brent's tolerance in the contact point of :func:`hertz_least_squares`, in refinement-grid
#: spacings.
_BRENT_XATOL = 1e-6
#: Most brackets :func:`hertz_least_squares` tries (each one refinement-grid spacing on either
#: side of the best point so far).
_BRENT_SHIFTS = 8
#: Relative size of |g⊥|² below which a candidate's shape is a straight line on the samples
#: (no E to fit: the candidate is not eligible, as lstsq's E = 0 there).
_DEGENERATE = 1e-12


class _Costs:
    """The closed-form least squares of one approach at any candidate contact points.

    What does not depend on the candidate (the centred z, the force with its straight line in z
    removed) is computed once per approach.
    """

    def __init__(self, tip: Any, z: np.ndarray, f: np.ndarray):
        self.tip, self.z, self.f = tip, z, f
        self.n = z.size
        self.z_mean = float(z.mean())
        self.zc = z - self.z_mean
        self.szz = float(self.zc @ self.zc)
        fc = f - f.mean()
        self.fp = fc - self.zc * (float(self.zc @ fc) / self.szz) if self.szz > 0 else fc
        self.ss_perp = float(self.fp @ self.fp)

    def __call__(self, contacts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(SSE [N²], E [Pa]) at each candidate (:func:`scan_costs`)."""
        z, n, szz = self.z, self.n, self.szz
        contacts = np.asarray(contacts, dtype=float).reshape(-1)
        sse = np.full(contacts.size, self.ss_perp)
        modulus = np.zeros(contacts.size)
        if contacts.size == 0:
            return sse, modulus
        order = np.argsort(contacts, kind="stable")
        sorted_c = contacts[order]
        step = max(1, _BLOCK // max(n, 1))
        for k in range(0, sorted_c.size, step):
            block = sorted_c[k:k + step]
            inside = z > block[0]  # g = 0 for every candidate of the block elsewhere
            if not inside.any():
                continue
            zcs, fps = self.zc[inside], self.fp[inside]
            delta = z[inside][None, :] - block[:, None]
            np.maximum(delta, 0.0, out=delta)
            g = np.asarray(self.tip.force_shape(delta.ravel()), dtype=float).reshape(delta.shape)
            s1 = g.sum(axis=1)
            sz = g @ zcs
            sgg = np.einsum("ij,ij->i", g, g)
            sgf = g @ fps
            gperp = sgg - s1 * s1 / n - (sz * sz / szz if szz > 0 else 0.0)
            ok = gperp > _DEGENERATE * sgg
            e = np.divide(sgf, gperp, out=np.zeros_like(sgf), where=ok)
            idx = order[k:k + step]
            modulus[idx] = e
            sse[idx] = np.where(ok, self.ss_perp - sgf * e, self.ss_perp)
        return sse, modulus

    def solve(self, contact: float, modulus: float) -> tuple[float, np.ndarray]:
        """SSE [N²] and (E, baseline [N], slope [N/m]) at ``contact`` given its E [Pa].

        The baseline and slope are the straight line through F − E·shape (the least squares in
        them given E); the SSE is summed from the residuals.
        """
        z, f = self.z, self.f
        g = np.asarray(self.tip.force_shape(np.maximum(z - contact, 0.0)), dtype=float)
        rest = f - modulus * g
        slope = float(self.zc @ rest) / self.szz if self.szz > 0 else 0.0
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


def _quantiles(values: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``numpy.quantile(values, q)`` (linear method) of already sorted ``values``."""
    position = q * (values.size - 1)
    below = np.floor(position).astype(int)
    above = np.minimum(below + 1, values.size - 1)
    t = position - below
    a, b = values[below], values[above]
    diff = b - a
    return np.where(t >= 0.5, b - diff * (1 - t), a + diff * t)


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
    (c, _, e), costs, _ = found
    sse, coef = costs.solve(c, e)
    return c, sse, coef


def hertz_least_squares(tip: Any, z: np.ndarray, f: np.ndarray, window: tuple[float, float], *,
                        points: int) -> tuple[float, float, np.ndarray] | None:
    """The Hertz least squares of an approach: :func:`hertz_scan`, then its minimum in c.

    Variable projection: (E, baseline, slope) are linear given the contact point c, so the least
    squares of all four is the minimum over c of the closed-form SSE(c) (:class:`_Costs`), found
    by a bounded Brent search between the scan's best point's neighbours on its refinement grid
    (within the contact ``window``; a minimum with E > 0; bracketed again where it lands on the
    bracket's end). What the fitting engine's
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
    (c, sse, e), costs, spacing = found

    def cost(x: float) -> float:
        value, modulus = costs(np.array([x]))
        return float(value[0]) if modulus[0] > 0 else costs.ss_perp

    for _ in range(_BRENT_SHIFTS):  # a minimum at the bracket's end: bracket it again there
        lo, hi = max(c - spacing, window[0]), min(c + spacing, window[1])
        if not hi > lo:
            break
        opt = minimize_scalar(cost, bounds=(lo, hi), method="bounded",
                              options={"xatol": _BRENT_XATOL * spacing})
        if not opt.fun < sse:
            break
        c, sse = float(opt.x), float(opt.fun)
        e = float(costs(np.array([c]))[1][0])
        edge = 4 * _BRENT_XATOL * spacing
        if not ((c - lo < edge and lo > window[0]) or (hi - c < edge and hi < window[1])):
            break
    sse, coef = costs.solve(c, e)
    return c, sse, coef


def _scan(tip: Any, z: np.ndarray, f: np.ndarray, window: tuple[float, float], points: int,
          coarse: bool) -> tuple[tuple[float, float, float], _Costs, float] | None:
    """The grid's best (contact point, closed-form SSE, E), its costs and refinement spacing.

    The costs are the approach's :class:`_Costs`, the spacing that of the 21-point refinement
    grid [m]; None where no candidate gives E > 0.
    """
    z = np.asarray(z, dtype=float)
    f = np.asarray(f, dtype=float)
    lo, hi = window
    inner = np.sort(z[(z >= lo) & (z <= hi)])
    if inner.size < 4:
        raise ParameterError("the approach has fewer than 4 points where contact may lie")
    grid = _quantiles(inner, np.linspace(0.02, 0.98, points))
    costs = _Costs(tip, z, f)
    best = None
    if coarse and z.size > 2 * COARSE_SAMPLES:
        stride = -(-z.size // COARSE_SAMPLES)
        sse, e = _Costs(tip, z[::stride], f[::stride])(grid)
        if np.any(e > 0):
            local = grid[_coarse_pick(sse, e, -(-z.size // stride))]
            sse, e = costs(local)
            i = _best(sse, e)
            if i is not None:
                best = (float(local[i]), float(sse[i]), float(e[i]))
    if best is None:
        sse, e = costs(grid)
        i = _best(sse, e)
        if i is None:
            return None
        best = (float(grid[i]), float(sse[i]), float(e[i]))
    step = float(np.median(np.diff(grid))) if grid.size > 1 else float(np.ptp(z)) / 10
    fine = np.linspace(best[0] - step, best[0] + step, _REFINE_POINTS)
    fine = fine[(fine >= lo) & (fine <= hi)]
    sse, e = costs(fine)
    i = _best(sse, e)
    if i is not None and sse[i] < best[1]:
        best = (float(fine[i]), float(sse[i]), float(e[i]))
    return best, costs, 2.0 * step / (_REFINE_POINTS - 1)
