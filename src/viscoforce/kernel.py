"""Axisymmetric elastic half-space operator by product integration (paper Eq. 2).

The surface deformation under an axisymmetric pressure p(r) is

    u(r) = −(2/E) ∫₀^∞ s k(r, s) p(s) ds,   k(r, s) = 4 K(m) / (π (r + s)),   m = 4rs/(r + s)²,

with K the complete elliptic integral of the first kind (parameter m) and the paper's modulus
convention 2/E = Σ(1 − ν_i²)/E_i. K diverges logarithmically at s = r.

Discretisation (product integration): on every panel of the :class:`~viscoforce.radial_grid.RadialGrid`
the pressure is replaced by its Lagrange interpolant through the panel's nodes, and the kernel times
each basis polynomial is integrated *accurately*:

* panels at least one panel width away from the target: an 18-point Gauss rule (the nearest
  singularity is then outside the Bernstein ellipse of parameter ≥ 5.8, error < 1e-25);
* the target's own panel and its neighbours: a composite Gauss rule geometrically graded towards the
  singular point s = r (ratio 0.3, 26 levels, 10 points per level), which integrates the log
  singularity to ~1e-13 relative.

The result is the influence matrix A [m] with u_i = −(2/E) Σ_j A_ij p_j. A scales linearly with the
panel width, so the matrix is built once per (n_panels, order) in panel-width units and cached.
1 − m = ((r − s)/(r + s))² is formed directly and passed to ``scipy.special.ellipkm1`` so that no
precision is lost near the singularity.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import ellipkm1

from viscoforce._typing import FloatArray
from viscoforce._validation import as_float_array, require_instance
from viscoforce.exceptions import ParameterError
from viscoforce.radial_grid import RadialGrid, gauss_legendre_unit, lagrange_matrix

_FAR_POINTS = 18
_GRADE_RATIO = 0.3
_GRADE_LEVELS = 26
_GRADE_POINTS = 10


def kernel_times_s(r: ArrayLike, s: ArrayLike, *, offset: ArrayLike | None = None) -> FloatArray:
    """The integrand factor s·k(r, s) = 4 s K(m) / (π (r + s)) [dimensionless].

    Parameters
    ----------
    r : array_like
        Target radius (any length unit, ≥ 0).
    s : array_like
        Source radius (same unit, > 0).
    offset : array_like, optional
        s − r computed without cancellation; when given, 1 − m is formed from it, which keeps full
        precision within a few ulps of the singularity.

    Returns
    -------
    ndarray
        s·k(r, s), broadcast over the inputs; +inf at s = r (the logarithmic singularity).
    """
    r = as_float_array("r", r)
    s = as_float_array("s", s)
    if np.any(r < 0):
        raise ParameterError(f"r must be >= 0, got min {float(np.min(r))!r}")
    if np.any(s <= 0):
        raise ParameterError(f"s must be > 0, got min {float(np.min(s))!r}")
    if offset is not None:
        offset = as_float_array("offset", offset)
    try:
        return _kernel_times_s(r, s, offset)
    except ValueError as exc:  # shapes that do not broadcast
        raise ParameterError(f"r, s and offset must broadcast together: {exc}") from None


def _kernel_times_s(r: FloatArray, s: FloatArray, offset: FloatArray | None) -> FloatArray:
    """:func:`kernel_times_s` without the input checks (float arrays, r ≥ 0, s > 0)."""
    total = r + s
    diff = (r - s) if offset is None else -np.asarray(offset, dtype=float)
    q = diff / total
    return 4.0 * s * ellipkm1(q * q) / (np.pi * total)


def _graded_rule(c: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Composite Gauss rule on [0, 1] graded geometrically towards the point c ∈ [0, 1].

    Returns the nodes, their weights and their signed offsets from c (exact, no cancellation).
    """
    x, w = gauss_legendre_unit(_GRADE_POINTS)
    edges = np.append(_GRADE_RATIO ** np.arange(_GRADE_LEVELS + 1), 0.0)
    left, right = edges[1:], edges[:-1]
    dist = (left[:, None] + (right - left)[:, None] * x[None, :]).ravel()
    wt = ((right - left)[:, None] * w[None, :]).ravel()
    offsets, weights = [], []
    for length, sign in ((c, -1.0), (1.0 - c, 1.0)):
        if length > 0:
            offsets.append(sign * dist * length)
            weights.append(wt * length)
    off = np.concatenate(offsets)
    return c + off, np.concatenate(weights), off


def _rows_unit(n_panels: int, order: int, targets: FloatArray) -> FloatArray:
    """Influence rows in panel-width units for arbitrary targets (also in panel-width units)."""
    local, _ = gauss_legendre_unit(order)
    xf, wf = gauss_legendre_unit(_FAR_POINTS)
    lag_far = lagrange_matrix(local, xf)  # (_FAR_POINTS, order)
    panels = np.arange(n_panels)
    # far rule everywhere first
    s = panels[:, None] + xf[None, :]  # (P, F)
    integrand = _kernel_times_s(targets[:, None, None], s[None, :, :], None) * wf  # (T, P, F)
    out = np.einsum("tpf,fj->tpj", integrand, lag_far)
    # replace blocks of panels within one panel width of the target
    for t, x in enumerate(targets):
        near = panels[(panels <= x + 1.0) & (panels + 1.0 >= x - 1.0)]
        for k in near:
            c = min(max(x - k, 0.0), 1.0)
            y, wy, off = _graded_rule(c)
            vals = _kernel_times_s(x, k + y, (k + c - x) + off) * wy
            out[t, k, :] = vals @ lagrange_matrix(local, y)
    return out.reshape(len(targets), n_panels * order)


@lru_cache(maxsize=16)
def _node_matrix_unit(n_panels: int, order: int) -> FloatArray:
    local, _ = gauss_legendre_unit(order)
    targets = (np.arange(n_panels)[:, None] + local[None, :]).ravel()
    mat = _rows_unit(n_panels, order, targets)
    mat.flags.writeable = False
    return mat


def influence_matrix(grid: RadialGrid) -> FloatArray:
    """Influence matrix A [m] on the grid nodes: u_i = −(2/E) Σ_j A_ij p(r_j).

    Parameters
    ----------
    grid : RadialGrid
        The discretisation.

    Returns
    -------
    ndarray, shape (grid.size, grid.size)
        Read-only product-integration matrix (cached per panel count and order).
    """
    require_instance("grid", grid, RadialGrid)
    mat = grid.panel_width * _node_matrix_unit(grid.n_panels, grid.order)
    mat.flags.writeable = False
    return mat


def influence_rows(grid: RadialGrid, r: ArrayLike) -> FloatArray:
    """Influence rows [m] for arbitrary target radii ``r`` [m] (u(r) = −(2/E) rows @ p).

    Use it for output at points that are not nodes, e.g. the centre r = 0; 0 ≤ r ≤ outer_radius.
    """
    require_instance("grid", grid, RadialGrid)
    r = np.atleast_1d(as_float_array("r", r))
    if r.ndim != 1:
        raise ParameterError(f"r must be a number or a 1-D array of radii [m], got shape {r.shape}")
    if np.any(r < 0) or np.any(r > grid.outer_radius * (1 + 1e-12)):
        raise ParameterError(
            f"r must lie in [0, {grid.outer_radius:g}] m (the grid), got min {float(r.min())!r}, "
            f"max {float(r.max())!r}")
    return grid.panel_width * _rows_unit(grid.n_panels, grid.order, r / grid.panel_width)


def center_row(grid: RadialGrid) -> FloatArray:
    """Row c [m] with u(0) = −(2/E) c @ p: since s·k(0, s) = 2, c_j = 2 × (quadrature weight of node j)."""
    require_instance("grid", grid, RadialGrid)
    _, w = gauss_legendre_unit(grid.order)
    return 2.0 * grid.panel_width * np.tile(w, grid.n_panels)
