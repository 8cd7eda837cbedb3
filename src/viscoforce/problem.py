"""The contact problem: geometry, surface force, material and discretisation in one frozen bundle.

It knows how to turn a deformation into a gap, a gap into a pressure and a pressure into a load, and
it carries the elastic influence matrix of its grid. It has no time loop and no Newton iteration.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from viscoforce import kernel
from viscoforce._limits import SPHERE_RADIUS_RANGE
from viscoforce._typing import FloatArray
from viscoforce._validation import (
    as_float_array,
    require_finite,
    require_instance,
    require_int,
    require_plausible,
    require_positive,
)
from viscoforce.exceptions import (
    EffortError,
    ModelValidityError,
    ModelValidityWarning,
    ParameterError,
)
from viscoforce.physics.materials import ViscoelasticMaterial
from viscoforce.physics.particle import Particle
from viscoforce.physics.surface_forces import SurfaceForceLaw
from viscoforce.radial_grid import RadialGrid, barycentric_weights, gauss_legendre_unit
from viscoforce.units import format_quantity

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
#: Half-space validity (:func:`check_half_space`): contact radius a and central deformation |u(0)|
#: as fractions of R beyond which a result is refused (ModelValidityError) ...
HALF_SPACE_ERROR = {"contact_radius": 0.5, "deformation": 0.1}
#: ... and beyond which it is flagged (ModelValidityWarning). The paper's deepest cases reach
#: a/R = 0.036 and |u(0)|/R = 0.0011 (h0 = −10 nm, E = 1e9 and 1e10 Pa, R = 10 µm, Figs. 5–8 loops).
HALF_SPACE_WARNING = {"contact_radius": 0.1, "deformation": 0.01}

_SURFACE_FORCE_KIND = "SurfaceForceLaw (e.g. DoubleLayer(P, debye_length) + SoftWall(Pw, z0))"
_MATERIAL_KIND = "ViscoelasticMaterial (Elastic, StandardLinearSolid or PronySeries)"


def _check_geometry(sphere: Particle, law: SurfaceForceLaw) -> None:
    require_instance("sphere", sphere, Particle)
    # a subnormal R gave an outer radius of 0, 1e300 m a Newton solve that cannot converge
    require_plausible("radius (R)", sphere.radius, SPHERE_RADIUS_RANGE, "m",
                      why="the sphere of the contact problem")
    require_instance("surface_force", law, SurfaceForceLaw, what=_SURFACE_FORCE_KIND)


def interaction_length(sphere: Particle, law: SurfaceForceLaw) -> float:
    """sqrt(2 R λ) [m]: the radius over which the undeformed gap grows by one decay length λ."""
    _check_geometry(sphere, law)
    return float(np.sqrt(2.0 * sphere.radius * law.decay_length))


def default_outer_radius(sphere: Particle, law: SurfaceForceLaw, deepest_position: float) -> float:
    """r_max [m] such that the undeformed gap at r_max exceeds the law's negligible gap.

    Since a repulsive force only opens the gap (u ≤ 0), the pressure beyond r_max is below
    ``NEGLIGIBLE_PRESSURE_RTOL`` of the law's pressure scale for every position ≥
    ``deepest_position``. At least 3 interaction lengths.
    """
    _check_geometry(sphere, law)
    deepest_position = require_finite("deepest_position", deepest_position)
    h_cut = law.negligible_gap(NEGLIGIBLE_PRESSURE_RTOL)
    r_cut = sphere.radius_at_gap(deepest_position, h_cut)
    return max(r_cut, 3.0 * interaction_length(sphere, law))


def default_grid(sphere: Particle, law: SurfaceForceLaw, deepest_position: float, *,
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
    _check_geometry(sphere, law)
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
    sphere : Particle
        Geometry (radius R, within :data:`~viscoforce._limits.SPHERE_RADIUS_RANGE`).
    surface_force : SurfaceForceLaw
        Pressure law p(h).
    material : ViscoelasticMaterial
        Material in the paper's modulus convention.
    grid : RadialGrid
        Discretisation (see :func:`default_grid`, or :meth:`create`).
    """

    sphere: Particle
    surface_force: SurfaceForceLaw
    material: ViscoelasticMaterial
    grid: RadialGrid

    def __post_init__(self):
        _check_geometry(self.sphere, self.surface_force)
        require_instance("material", self.material, ViscoelasticMaterial, what=_MATERIAL_KIND)
        require_instance("grid", self.grid, RadialGrid)
        if self.grid.size > MAX_NODES:  # the influence matrix is dense: n² floats
            need = 8.0 * self.grid.size ** 2
            raise EffortError(
                f"the grid has {self.grid.size} nodes (> {MAX_NODES}): its dense influence "
                f"matrix would need {need / 2**30:.3g} GiB; use a coarser grid (fewer panels)",
                estimate=float(self.grid.size), limit=float(MAX_NODES))

    @classmethod
    def create(cls, *, sphere: Particle, surface_force: SurfaceForceLaw,
               material: ViscoelasticMaterial, deepest_position: float,
               grid_spacing: float | None = None, outer_radius: float | None = None,
               order: int = DEFAULT_ORDER) -> ContactProblem:
        """Bundle with the default grid for positions down to ``deepest_position`` [m]."""
        _check_geometry(sphere, surface_force)
        require_instance("material", material, ViscoelasticMaterial, what=_MATERIAL_KIND)
        grid = default_grid(sphere, surface_force, deepest_position, grid_spacing=grid_spacing,
                            outer_radius=outer_radius, order=order)
        return cls(sphere, surface_force, material, grid)

    def with_material(self, material: ViscoelasticMaterial) -> ContactProblem:
        """The same system and grid with another material, sharing the built kernel arrays.

        Fits change the material hundreds of times; the influence matrix (the costly part,
        material-free) is reused instead of rebuilt.
        """
        require_instance("material", material, ViscoelasticMaterial, what=_MATERIAL_KIND)
        new = ContactProblem(self.sphere, self.surface_force, material, self.grid)
        for name in ("influence", "center_row", "_sag"):
            if name in self.__dict__:
                new.__dict__[name] = self.__dict__[name]
        return new

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

    @cached_property
    def _sag(self) -> FloatArray:
        """r²/2R at the nodes [m] (read-only)."""
        out = self.sphere.undeformed_gap(0.0, self.grid.r)
        out.flags.writeable = False
        return out

    def undeformed_gap(self, position: float) -> FloatArray:
        """h0(r) = h0 + r²/2R at the nodes [m] for a finite apex position ``position`` [m]."""
        return require_finite("position (h0)", position) + self._sag

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
        position = require_finite("position (h0)", position)
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


def check_half_space(radius: float, deformation: ArrayLike, contact_radius: ArrayLike, *,
                     where: str = "", stacklevel: int = 2) -> tuple[float, float]:
    """Check that a result stays inside the half-space (small-slope) model: a ≪ R and |u(0)| ≪ R.

    The elastic half-space kernel (paper Eq. 2) and the paraboloid h0 + r²/2R hold only while the
    contact radius and the deformation are small against the sphere radius R. A result far
    outside (usually an input with a wrong unit, e.g. a Debye length of 1 m) is refused.

    Parameters
    ----------
    radius : float
        Sphere radius R [m], > 0.
    deformation : float or array_like
        Central deformation(s) u(0) [m] (any sign; the largest magnitude counts).
    contact_radius : float or array_like
        Contact radius (radii) a [m], ≥ 0 (the largest counts).
    where : str
        Context for the message, e.g. ``"at h0 = -5 nm"``.
    stacklevel : int
        Passed to :func:`warnings.warn`.

    Returns
    -------
    a_ratio, u_ratio : float
        max a / R and max |u(0)| / R.

    Raises
    ------
    ModelValidityError
        a > ``HALF_SPACE_ERROR["contact_radius"]`` R (0.5 R) or |u(0)| >
        ``HALF_SPACE_ERROR["deformation"]`` R (0.1 R).

    Warns
    -----
    ModelValidityWarning
        a > ``HALF_SPACE_WARNING["contact_radius"]`` R (0.1 R) or |u(0)| >
        ``HALF_SPACE_WARNING["deformation"]`` R (0.01 R).
    """
    radius = require_positive("radius (R)", radius)
    u = as_float_array("deformation", deformation)
    a = as_float_array("contact_radius", contact_radius)
    if np.any(a < 0):
        raise ParameterError(f"contact_radius must be >= 0 m, got min {float(np.min(a))!r}")
    a_max = float(np.max(a)) if a.size else 0.0
    u_max = float(np.max(np.abs(u))) if u.size else 0.0
    ratios = {"contact_radius": a_max / radius, "deformation": u_max / radius}
    labels = {"contact_radius": f"the contact radius a = {format_quantity(a_max, 'length')}",
              "deformation": f"the central deformation |u(0)| = {format_quantity(u_max, 'length')}"}

    def offending(limits: dict[str, float], word: str) -> list[str]:
        return [f"{labels[k]} = {ratios[k]:.3g} R ({word} {limits[k]:g} R)"
                for k in ("contact_radius", "deformation") if ratios[k] > limits[k]]

    context = f" {where.strip()}" if where and where.strip() else ""
    model = (f"the half-space (small-slope) model assumes deformations and contact radii small "
             f"against the sphere radius R = {format_quantity(radius, 'length')}")
    errors = offending(HALF_SPACE_ERROR, "limit")
    if errors:
        raise ModelValidityError(
            f"result outside the model{context}: {' and '.join(errors)}; {model}, so this result "
            "is meaningless; check the inputs' units and magnitudes (a Debye length or decay "
            "length in m instead of nm, a modulus far too small, a position far too deep)")
    notes = offending(HALF_SPACE_WARNING, "warning above")
    if notes:
        warnings.warn(
            f"result near the edge of the model{context}: {' and '.join(notes)}; {model}, so "
            "expect errors of the order of these ratios", ModelValidityWarning,
            stacklevel=stacklevel)
    return ratios["contact_radius"], ratios["deformation"]


def contact_radius(grid: RadialGrid, gap: ArrayLike, gap_center: float, threshold: float) -> float:
    """Largest radius [m] where the gap is below ``threshold`` [m] (0 if nowhere).

    The crossing is located on the panel's Lagrange interpolant of the nodal gaps (barycentric
    form, bracketing root search), so it is as accurate as the discretisation.
    """
    require_instance("grid", grid, RadialGrid)
    threshold = require_positive("contact_threshold", threshold)
    gap = as_float_array("gap", gap, size=grid.size)
    if gap.ndim != 1:
        raise ParameterError(f"gap must be 1-D (one value per node), got shape {gap.shape}")
    gap_center = require_finite("gap_center", gap_center)
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
    return _bracketed_root(f, lo, hi, f_lo, f_hi, xtol=1e-9 * grid.spacing)


def _bracketed_root(f, lo: float, hi: float, f_lo: float, f_hi: float, *, xtol: float) -> float:
    """Root of ``f`` in [lo, hi] with f(lo)·f(hi) < 0, to ``xtol`` [same unit as lo, hi].

    Illinois (modified regula falsi): superlinear on the smooth panel interpolants, a handful of
    evaluations; bisection takes over if it has not converged after 60 evaluations, so it always
    terminates with the bracket below ``xtol``. (Replaces scipy.optimize.brentq, whose import
    alone costs more than a static solve.)
    """
    side = 0
    for _ in range(60):
        x = (lo * f_hi - hi * f_lo) / (f_hi - f_lo)
        fx = f(x)
        if fx == 0.0:
            return float(x)
        if (fx < 0) == (f_hi < 0):
            step, hi, f_hi = hi - x, x, fx
            if side == -1:
                f_lo *= 0.5
            side = -1
        else:
            step, lo, f_lo = x - lo, x, fx
            if side == 1:
                f_hi *= 0.5
            side = 1
        if hi - lo <= xtol or abs(step) <= 0.5 * xtol:
            return float(x)
    while hi - lo > xtol:
        mid = 0.5 * (lo + hi)
        f_mid = f(mid)
        if f_mid == 0.0:
            return float(mid)
        if (f_mid < 0) == (f_hi < 0):
            hi, f_hi = mid, f_mid
        else:
            lo, f_lo = mid, f_mid
    return float(0.5 * (lo + hi))
