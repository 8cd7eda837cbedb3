"""The contact problem: geometry, surface force, material and discretisation in one frozen bundle.

It knows how to turn a deformation into a gap, a gap into a pressure and a pressure into a load, and
it carries the elastic influence matrix of its grid. It has no time loop and no Newton iteration.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from viscoforce import kernel
from viscoforce._typing import FloatArray
from viscoforce._validation import require_finite, require_int, require_positive
from viscoforce.exceptions import ParameterError
from viscoforce.physics.materials import ViscoelasticMaterial
from viscoforce.physics.particle import Sphere
from viscoforce.physics.surface_forces import SurfaceForceLaw
from viscoforce.radial_grid import RadialGrid, barycentric_weights, gauss_legendre_unit

#: Relative pressure below which the surface force is treated as zero when sizing the grid.
NEGLIGIBLE_PRESSURE_RTOL = 1e-10
#: Default panel width in units of the interaction length sqrt(2 R λ).
DEFAULT_PANEL_WIDTH = 0.5
#: Default Gauss–Legendre nodes per panel.
DEFAULT_ORDER = 8
#: Largest grid a dense solve is allowed to build (a 4000² matrix is 128 MB).
MAX_NODES = 4000
#: Deepest position allowed, as a fraction of R (the model assumes |h0| ≪ R).
MAX_DEPTH_FRACTION = 0.1


def interaction_length(sphere: Sphere, law: SurfaceForceLaw) -> float:
    """sqrt(2 R λ) [m]: the radius over which the undeformed gap grows by one decay length λ."""
    return float(np.sqrt(2.0 * sphere.radius * law.decay_length))


def default_outer_radius(sphere: Sphere, law: SurfaceForceLaw, deepest_position: float) -> float:
    """r_max [m] such that the undeformed gap at r_max exceeds the law's negligible gap.

    Since a repulsive force only opens the gap (u ≤ 0), the pressure beyond r_max is below
    ``NEGLIGIBLE_PRESSURE_RTOL`` of the law's pressure scale for every position ≥
    ``deepest_position``. At least 3 interaction lengths.
    """
    h_cut = law.negligible_gap(NEGLIGIBLE_PRESSURE_RTOL)
    r_cut = sphere.radius_at_gap(deepest_position, h_cut)
    return max(r_cut, 3.0 * interaction_length(sphere, law))


def default_grid(sphere: Sphere, law: SurfaceForceLaw, deepest_position: float, *,
                 grid_spacing: float | None = None, outer_radius: float | None = None,
                 order: int = DEFAULT_ORDER) -> RadialGrid:
    """The radial grid the physics needs for positions down to ``deepest_position`` [m].

    Parameters
    ----------
    sphere, law :
        Geometry and surface-force law.
    deepest_position : float
        Smallest apex position h0 [m] the grid must serve.
    grid_spacing : float, optional
        Mean node spacing [m]; default ``DEFAULT_PANEL_WIDTH`` × sqrt(2Rλ) / ``order``.
    outer_radius : float, optional
        r_max [m]; default :func:`default_outer_radius`.
    order : int
        Gauss nodes per panel.
    """
    deepest_position = require_finite("deepest_position", deepest_position)
    order = require_int("order", order, 2)
    if deepest_position < -MAX_DEPTH_FRACTION * sphere.radius:
        raise ParameterError(
            f"deepest_position must be >= -{MAX_DEPTH_FRACTION:g} R = "
            f"{-MAX_DEPTH_FRACTION * sphere.radius:.3g} m (the paraboloid and half-space model needs "
            f"|h0| << R), got {deepest_position!r}; did you forget a unit such as 'nm'?")
    if outer_radius is None:
        outer_radius = default_outer_radius(sphere, law, deepest_position)
    if grid_spacing is None:
        grid_spacing = DEFAULT_PANEL_WIDTH * interaction_length(sphere, law) / order
    grid = RadialGrid.from_spacing(outer_radius, grid_spacing, order)
    if grid.size > MAX_NODES:
        raise ParameterError(
            f"the grid would have {grid.size} nodes (> {MAX_NODES}): grid_spacing "
            f"{grid_spacing:.3g} m over outer_radius {outer_radius:.3g} m (deepest_position "
            f"{deepest_position:.3g} m); use a coarser grid_spacing or a shallower position")
    return grid


@dataclass(frozen=True)
class ContactProblem:
    """Sphere against flat with a surface-force law, a material and a radial grid.

    Parameters
    ----------
    sphere : Sphere
        Geometry (radius R).
    surface_force : SurfaceForceLaw
        Pressure law p(h).
    material : ViscoelasticMaterial
        Material in the paper's modulus convention.
    grid : RadialGrid
        Discretisation (see :func:`default_grid`, or :meth:`create`).
    """

    sphere: Sphere
    surface_force: SurfaceForceLaw
    material: ViscoelasticMaterial
    grid: RadialGrid

    def __post_init__(self):
        for name, cls in (("sphere", Sphere), ("surface_force", SurfaceForceLaw),
                          ("material", ViscoelasticMaterial), ("grid", RadialGrid)):
            if not isinstance(getattr(self, name), cls):
                raise ParameterError(
                    f"{name} must be a {cls.__name__}, got {type(getattr(self, name)).__name__}")

    @classmethod
    def create(cls, *, sphere: Sphere, surface_force: SurfaceForceLaw,
               material: ViscoelasticMaterial, deepest_position: float,
               grid_spacing: float | None = None, outer_radius: float | None = None,
               order: int = DEFAULT_ORDER) -> ContactProblem:
        """Bundle with the default grid for positions down to ``deepest_position`` [m]."""
        grid = default_grid(sphere, surface_force, deepest_position, grid_spacing=grid_spacing,
                            outer_radius=outer_radius, order=order)
        return cls(sphere, surface_force, material, grid)

    @cached_property
    def influence(self) -> FloatArray:
        """Influence matrix A [m] on the nodes: u = −2 C · A p for compliance C."""
        return kernel.influence_matrix(self.grid)

    @cached_property
    def center_row(self) -> FloatArray:
        """Row c [m]: u(0) = −2 C · c @ p."""
        return kernel.center_row(self.grid)

    @property
    def r(self) -> FloatArray:
        """Node radii [m]."""
        return self.grid.r

    def undeformed_gap(self, position: float) -> FloatArray:
        """h0(r) = h0 + r²/2R at the nodes [m]."""
        return self.sphere.undeformed_gap(position, self.grid.r)

    def pressure(self, gap: ArrayLike) -> FloatArray:
        """p(h) [Pa] at nodal gaps [m]."""
        return self.surface_force.pressure(gap)

    def load(self, pressure: ArrayLike) -> FloatArray:
        """F = 2π ∫ p r dr [N] of nodal pressures (Eq. 14); vectorised over leading axes."""
        return self.grid.integrate_area(pressure)

    def rigid_load(self, position: float) -> float:
        """Load between undeformed bodies [N]: exactly 2πR W(h0) for a paraboloid (inf if h0 ≤ 0).

        The Derjaguin form is exact here because the gap is h0 + r²/2R and the integral runs to ∞.
        """
        position = require_finite("position", position)
        if position <= 0:
            return float("inf")
        return float(2.0 * np.pi * self.sphere.radius * self.surface_force.energy(position))

    def check_covers(self, position: float) -> None:
        """Raise if the grid is too small for apex position ``position`` [m]."""
        need = default_outer_radius(self.sphere, self.surface_force, position)
        if self.grid.outer_radius < 0.999 * need:
            raise ParameterError(
                f"outer_radius {self.grid.outer_radius:.4g} m is too small for position "
                f"{position:.4g} m: the surface force is not negligible out to {need:.4g} m; "
                "build the problem with a deeper deepest_position or a larger outer_radius")

    def parameters(self) -> dict[str, float | int | str]:
        """All parameters as flat attrs (SI)."""
        out: dict[str, float | int | str] = {"radius": self.sphere.radius}
        out.update(self.surface_force.parameters())
        out["material"] = type(self.material).__name__
        out.update(self.material.parameters())
        out.update({"outer_radius": self.grid.outer_radius, "n_panels": self.grid.n_panels,
                    "order": self.grid.order, "grid_spacing": self.grid.spacing})
        return out


def contact_radius(grid: RadialGrid, gap: ArrayLike, gap_center: float, threshold: float) -> float:
    """Largest radius [m] where the gap is below ``threshold`` [m] (0 if nowhere).

    The crossing is located on the panel's Lagrange interpolant of the nodal gaps (barycentric
    form, bracketing root search), so it is as accurate as the discretisation.
    """
    from scipy.optimize import brentq

    threshold = require_positive("contact_threshold", threshold)
    gap = np.asarray(gap, dtype=float)
    below = np.flatnonzero(gap < threshold)
    if below.size == 0:
        if gap_center >= threshold:
            return 0.0
        i = -1
    else:
        i = int(below[-1])
        if i == gap.size - 1:
            raise ParameterError(
                "the contact zone reaches the outer radius of the grid; enlarge outer_radius")
    lo = 0.0 if i < 0 else float(grid.r[i])
    hi = float(grid.r[i + 1])
    k = (i + 1) // grid.order  # the crossing lies in the panel of node i + 1 or at its left edge
    nodes, _ = gauss_legendre_unit(grid.order)
    bary = barycentric_weights(nodes)
    values = gap[k * grid.order:(k + 1) * grid.order]
    width = grid.panel_width

    def f(r):
        d = r / width - k - nodes
        if np.any(d == 0.0):
            return float(values[np.flatnonzero(d == 0.0)[0]]) - threshold
        t = bary / d
        return float(t @ values / t.sum()) - threshold

    if i >= 0 and lo < k * width:  # node i sits in the previous panel: start at the panel edge
        lo = k * width
    f_lo, f_hi = f(lo), f(hi)
    if f_lo * f_hi > 0:  # the interpolant does not bracket (rare): interpolate the nodes linearly
        g_lo = gap_center if i < 0 else gap[i]
        lo = 0.0 if i < 0 else float(grid.r[i])
        return lo + (threshold - g_lo) * (hi - lo) / (gap[i + 1] - g_lo)
    if f_lo == 0.0:
        return lo
    return float(brentq(f, lo, hi, xtol=1e-9 * grid.spacing))
