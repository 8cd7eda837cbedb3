"""Radial discretisation of the axisymmetric interaction zone.

The interval [0, r_max] is cut into equal panels; each panel carries the ``order`` Gauss–Legendre
nodes of that panel. Fields (pressure, gap, deformation) are represented by their nodal values and
interpolated on each panel by the Lagrange polynomial through its nodes. This gives spectral accuracy
per panel for the smooth fields of a finite-ranged surface force, and it is the representation the
product-integration kernel (:mod:`viscoforce.kernel`) is built on.

This module is the discretisation only; which grid the physics needs is chosen by
:func:`viscoforce.problem.default_grid`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._typing import FloatArray
from viscoforce._validation import as_float_array, require_int, require_positive
from viscoforce.exceptions import ParameterError


@lru_cache(maxsize=64)
def gauss_legendre_unit(order: int) -> tuple[FloatArray, FloatArray]:
    """Gauss–Legendre nodes and weights on [0, 1].

    Parameters
    ----------
    order : int
        Number of nodes.

    Returns
    -------
    nodes, weights : ndarray
        Nodes in (0, 1) ascending and their weights (summing to 1).
    """
    x, w = np.polynomial.legendre.leggauss(order)
    nodes, weights = 0.5 * (x + 1.0), 0.5 * w
    nodes.flags.writeable = False
    weights.flags.writeable = False
    return nodes, weights


def barycentric_weights(nodes: FloatArray) -> FloatArray:
    """Barycentric weights of the Lagrange interpolant through ``nodes``."""
    diff = nodes[:, None] - nodes[None, :]
    np.fill_diagonal(diff, 1.0)
    return 1.0 / np.prod(diff, axis=1)


def lagrange_matrix(nodes: FloatArray, x: FloatArray) -> FloatArray:
    """Matrix L with L[m, j] = ℓ_j(x_m), the Lagrange basis through ``nodes`` evaluated at ``x``.

    Uses the second barycentric form; points that coincide with a node get the exact unit row.
    """
    x = np.asarray(x, dtype=float)
    bw = barycentric_weights(nodes)
    d = x[:, None] - nodes[None, :]
    exact = d == 0.0
    d[exact] = 1.0
    t = bw[None, :] / d
    out = t / t.sum(axis=1, keepdims=True)
    rows = exact.any(axis=1)
    out[rows] = exact[rows].astype(float)
    return out


#: Most Gauss–Legendre nodes per panel.
MAX_ORDER = 30


def _check_order(order: int) -> int:
    order = require_int("order", order, 2)
    if order > MAX_ORDER:
        raise ParameterError(f"order must be in [2, {MAX_ORDER}], got {order!r}")
    return order


@dataclass(frozen=True)
class RadialGrid:
    """Panels of Gauss–Legendre nodes on [0, outer_radius].

    Parameters
    ----------
    outer_radius : float
        r_max [m]; the surface pressure must be negligible beyond it.
    n_panels : int
        Number of equal panels (≥ 1).
    order : int
        Gauss–Legendre nodes per panel (2 … 30).
    """

    outer_radius: float
    n_panels: int
    order: int = 8

    def __post_init__(self):
        object.__setattr__(self, "outer_radius", require_positive("outer_radius", self.outer_radius))
        object.__setattr__(self, "n_panels", require_int("n_panels", self.n_panels, 1))
        object.__setattr__(self, "order", _check_order(self.order))

    @classmethod
    def from_spacing(cls, outer_radius: float, spacing: float, order: int = 8) -> RadialGrid:
        """Grid whose mean node spacing is at most ``spacing`` [m] on [0, ``outer_radius``]."""
        outer_radius = require_positive("outer_radius", outer_radius)
        spacing = require_positive("grid_spacing", spacing)
        order = _check_order(order)
        if spacing > outer_radius:
            raise ParameterError(
                f"grid_spacing must be <= outer_radius ({outer_radius:g} m), got {spacing!r}")
        n_panels = max(1, int(np.ceil(outer_radius / (spacing * order) - 1e-9)))
        return cls(outer_radius, n_panels, order)

    @property
    def panel_width(self) -> float:
        """Width of one panel [m]."""
        return self.outer_radius / self.n_panels

    @property
    def spacing(self) -> float:
        """Mean node spacing [m]."""
        return self.panel_width / self.order

    @property
    def size(self) -> int:
        """Number of nodes."""
        return self.n_panels * self.order

    @cached_property
    def unit_nodes(self) -> FloatArray:
        """Nodes in units of the panel width (panel k spans [k, k+1])."""
        x, _ = gauss_legendre_unit(self.order)
        return (np.arange(self.n_panels)[:, None] + x[None, :]).ravel()

    @cached_property
    def r(self) -> FloatArray:
        """Node radii [m], ascending."""
        out = self.unit_nodes * self.panel_width
        out.flags.writeable = False
        return out

    @cached_property
    def area_weights(self) -> FloatArray:
        """Weights W with 2π Σ W_j f(r_j) ≈ 2π ∫ f(r) r dr [m²] (exact for polynomial f·r per panel)."""
        _, w = gauss_legendre_unit(self.order)
        out = np.tile(w, self.n_panels) * self.panel_width * self.r
        out.flags.writeable = False
        return out

    def integrate_area(self, values: ArrayLike) -> FloatArray:
        """2π ∫ f(r) r dr over the grid for finite nodal values ``values`` (last axis = nodes)."""
        values = as_float_array("values", values, size=self.size)
        return 2.0 * np.pi * values @ self.area_weights

    def interpolate(self, values: ArrayLike, r: ArrayLike) -> FloatArray:
        """Evaluate the panel-wise Lagrange interpolant of nodal ``values`` at radii ``r`` [m].

        Radii beyond ``outer_radius`` raise; radii in [0, r_max] use their panel's polynomial
        (so r = 0 is an extrapolation to the panel end, which is accurate for smooth fields).
        """
        values = as_float_array("values", values, size=self.size)
        r = np.atleast_1d(as_float_array("r", r))
        if r.ndim != 1:
            raise ParameterError(f"r must be a number or a 1-D array of radii [m], got shape {r.shape}")
        if np.any(r < 0) or np.any(r > self.outer_radius * (1 + 1e-12)):
            raise ParameterError(
                f"r must lie in [0, {self.outer_radius:g}] m (the grid), got min {float(r.min())!r}, "
                f"max {float(r.max())!r}")
        x = r / self.panel_width
        panel = np.clip(np.floor(x).astype(int), 0, self.n_panels - 1)
        local_nodes, _ = gauss_legendre_unit(self.order)
        vals = values.reshape(values.shape[:-1] + (self.n_panels, self.order))
        out = np.empty(values.shape[:-1] + r.shape)
        for k in np.unique(panel):
            sel = panel == k
            lm = lagrange_matrix(local_nodes, x[sel] - k)
            out[..., sel] = vals[..., k, :] @ lm.T
        return out
