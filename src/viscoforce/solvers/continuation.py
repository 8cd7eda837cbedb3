"""Static elastic equilibria along the position h0 by pseudo-arclength continuation (issue 39).

With an attractive surface force (:class:`~viscoforce.physics.surface_forces.LennardJones`) the
elastic equilibrium h = h0 + r²/2R + (2/E)·A p(h) (paper Eq. 2, the same discretised half-space
operator A as :func:`~viscoforce.solvers.static.static_equilibrium`) is not unique: the load F(h0)
is an S-shaped curve. Natural continuation in h0 stops at its folds; here the unknowns are the
nodal gaps h *and* h0, and each new point solves the residual

    G(h, h0) = h − h0 − r²/2R − (2/E)·A p(h) = 0

bordered by the pseudo-arclength condition ⟨t, y − y_k⟩ = Δs (Keller), where y = (h, h0)/ℓ, ℓ the
law's decay length, and the inner product weighs the n gap components by 1/n against h0:
⟨a, b⟩ = a_h·b_h/n + a_h0·b_h0. The bordered Jacobian [[I − (2/E)A·diag p′(h), −1], [t_hᵀ/n, t_h0]]
stays regular through a fold, where I − (2/E)A·diag p′ becomes singular.

Folds are sign changes of dh0/ds (the h0 component of the unit tangent); each is refined by a root
search on the arclength (:func:`viscoforce.problem._bracketed_root`). On the path from far away:
the far branch is stable; every simple fold exchanges stability. The first fold is the **jump-in**
(on approach, the far branch ends there); the last is the **jump-out** (on retraction, the
contact branch ends there). The **pull-off force** is −min F on the contact branch (from the last
fold to the deep end; the whole path if it has no fold): the largest tensile load a quasi-static
retraction sustains under load control (Bradley 2πRΔγ for rigid bodies, JKR 1.5πRΔγ for soft
ones); the force at the jump-out is the (smaller) one of a rigid, displacement-controlled probe.

The load includes the rigid Derjaguin tail beyond the grid, 2πR·W(h(r_max)) with
h(r_max) ≈ h_n + (r_max² − r_n²)/2R extrapolated from the outermost node (the attractive
Lennard-Jones tail decays only as h⁻², so a compact grid needs it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import xarray as xr

from viscoforce._typing import FloatArray
from viscoforce._validation import require_finite, require_instance, require_int, require_positive
from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.physics.particle import Particle
from viscoforce.physics.surface_forces import LennardJones, SoftWall, SumOfLaws, SurfaceForceLaw
from viscoforce.problem import ContactProblem, _bracketed_root, contact_radius
from viscoforce.radial_grid import RadialGrid
from viscoforce.solvers.static import equilibrium_gap

#: Corrector tolerance on the max-norm of the last Newton update, in decay lengths (Newton
#: converges quadratically here: the error left after that update is ~1e-14).
CORRECTOR_XTOL = 1e-7
#: Most corrector iterations before a step is rejected (and the arclength step halved).
_MAX_CORRECTOR = 8
#: Predictor error (max-norm of the first corrector update, decay lengths) the step control aims
#: at: ds_new = ds·sqrt(target/error), within [0.5, 2]·ds.
_TARGET_PREDICTOR_ERROR = 0.02
#: Largest angle [rad] between successive unit tangents (resolves the folds' curvature).
_MAX_TURN = 0.25
#: Smallest arclength step [decay lengths] before the continuation gives up.
_MIN_STEP = 1e-9
#: Fraction-to-boundary rule: one corrector update shrinks a gap by at most this factor.
_SHRINK = 0.2
#: Undeformed gap at r_max, in decay lengths, below which the grid is too small for the tail.
_MIN_OUTER_GAP = 10.0


@dataclass(frozen=True)
class Fold:
    """A fold (turning point) of the equilibrium path: an elastic instability.

    Attributes
    ----------
    kind : str
        ``"jump_in"`` (end of the far branch, met on approach), ``"jump_out"`` (end of the
        contact branch, met on retraction) or ``"fold"`` (an inner fold of a multi-fold path).
    position : float
        h0 at the fold [m].
    force : float
        Load at the fold [N] (the force just before the jump).
    arclength : float
        Path arclength at the fold [decay lengths].
    """

    kind: str
    position: float
    force: float
    arclength: float


@dataclass(frozen=True)
class EquilibriumPath:
    """Static elastic equilibria along h0 (:func:`equilibrium_path`), in path order.

    Attributes
    ----------
    arclength : ndarray
        Pseudo-arclength s of each point [decay lengths].
    position, force, u_center, h_center, contact_radius : ndarray
        h0 [m], load F [N] (with the rigid tail), u(0) [m], h(0) [m], contact radius [m].
    gap : ndarray
        Nodal gaps [m] of every point, shape (points, nodes).
    stable : ndarray of bool
        Whether the point is stable under displacement control (rigid probe): the first
        point is, and every fold exchanges stability.
    folds : tuple of Fold
        Every fold, in path order.
    pull_off : float or None
        −min F on the contact branch [N] (> 0 for an attractive law; see the module notes);
        None if the path never reached the contact branch (an approach stopped between folds).
    pull_off_position : float or None
        h0 where that minimum is reached [m].
    modulus : float
        Elastic modulus E [Pa] (paper convention).
    parameters : dict
        The problem's parameters (SI), the contact threshold and the iteration counts.
    """

    arclength: FloatArray
    position: FloatArray
    force: FloatArray
    u_center: FloatArray
    h_center: FloatArray
    contact_radius: FloatArray
    stable: np.ndarray
    gap: FloatArray
    folds: tuple[Fold, ...]
    pull_off: float | None
    pull_off_position: float | None
    modulus: float
    parameters: dict = field(default_factory=dict)

    @property
    def jump_in(self) -> Fold | None:
        """The fold where the far branch ends (met on approach), or None."""
        return next((f for f in self.folds if f.kind == "jump_in"), None)

    @property
    def jump_out(self) -> Fold | None:
        """The fold where the contact branch ends (met on retraction), or None."""
        return next((f for f in self.folds if f.kind == "jump_out"), None)

    def to_dataset(self) -> xr.Dataset:
        """The path as an ``xarray.Dataset`` over ``point`` (units in attrs; netCDF-safe)."""
        def var(values, units, long_name):
            return ("point", np.asarray(values), {"units": units, "long_name": long_name})

        ds = xr.Dataset(
            {"position": var(self.position, "m", "apex position h0"),
             "force": var(self.force, "N", "load F (> 0 repulsive)"),
             "u_center": var(self.u_center, "m", "central deformation u(0)"),
             "h_center": var(self.h_center, "m", "central gap h(0)"),
             "contact_radius": var(self.contact_radius, "m", "contact radius"),
             "stable": var(self.stable.astype(np.int8), "1",
                           "1 if stable under displacement control")},
            coords={"arclength": var(self.arclength, "1",
                                     "pseudo-arclength in decay lengths")})
        attrs = dict(self.parameters)
        attrs.update({"modulus": self.modulus, "n_folds": len(self.folds)})
        if self.pull_off is not None:
            attrs.update({"pull_off": self.pull_off, "pull_off_position": self.pull_off_position})
        for name, fold in (("jump_in", self.jump_in), ("jump_out", self.jump_out)):
            if fold is not None:
                attrs[f"{name}_position"] = fold.position
                attrs[f"{name}_force"] = fold.force
        ds.attrs.update(attrs)
        return ds


def lennard_jones_term(law: SurfaceForceLaw) -> LennardJones | None:
    """The :class:`LennardJones` term of ``law`` (itself, or the first in a sum), or None."""
    terms = law.terms if isinstance(law, SumOfLaws) else (law,)
    return next((t for t in terms if isinstance(t, LennardJones)), None)


def adhesion_grid(sphere: Particle, law: SurfaceForceLaw, modulus: float, deepest_position: float,
                  *, resolution: float = 1.0, order: int = 8) -> RadialGrid:
    """A compact radial grid for adhesive equilibria down to ``deepest_position`` [m].

    The outer radius reaches an undeformed gap of (20 + 2μ) z0 at the deepest position (the rest
    is the rigid tail that :func:`equilibrium_path` adds); the mean spacing is
    sqrt(2R z0) / (12·resolution·max(1, μ)^{3/2}), since the cohesive zone at the contact edge
    narrows as a·μ⁻² ∝ sqrt(R z0)·μ^{-3/2} (μ Tabor's parameter, z0 the law's decay length).

    Parameters
    ----------
    sphere : Particle
        Geometry.
    law : SurfaceForceLaw
        The surface force (its Lennard-Jones term sets μ; without one, μ = 1).
    modulus : float
        Elastic modulus E [Pa] (paper convention).
    deepest_position : float
        Smallest h0 the path reaches [m].
    resolution : float
        Refinement factor (> 0): 2 halves the spacing.
    order : int
        Gauss nodes per panel.
    """
    require_instance("sphere", sphere, Particle)
    require_instance("law", law, SurfaceForceLaw)
    modulus = require_positive("modulus (E)", modulus)
    deepest_position = require_finite("deepest_position", deepest_position)
    resolution = require_positive("resolution", resolution)
    lj = lennard_jones_term(law)
    z0 = law.decay_length if lj is None else lj.z0
    mu = 1.0 if lj is None else lj.tabor_parameter(sphere.radius, modulus)
    # (20 + 2μ) z0 for the attraction's tail, and the check's 10 decay lengths (+2) of the whole
    # law (a double layer added to the Lennard-Jones law decays more slowly than z0)
    outer_gap = max((20.0 + 2.0 * mu) * z0, (_MIN_OUTER_GAP + 2.0) * law.decay_length)
    outer = np.sqrt(2.0 * sphere.radius * max(outer_gap - deepest_position, outer_gap))
    spacing = np.sqrt(2.0 * sphere.radius * z0) / (12.0 * resolution * max(1.0, mu) ** 1.5)
    return RadialGrid.from_spacing(float(outer), float(spacing), order)


def edge_gap(problem: ContactProblem, gap: FloatArray) -> float:
    """h(r_max) ≈ h_n + (r_max² − r_n²)/2R [m]: the gap at the grid's edge.

    The deformation is taken constant beyond the outermost node r_n (where the rigid tail of the
    attraction starts).
    """
    r = problem.grid.r
    return float(gap[-1] + (problem.grid.outer_radius**2 - r[-1] ** 2)
                 / (2.0 * problem.sphere.radius))


def load_with_tail(problem: ContactProblem, gap: FloatArray) -> float:
    """Load [N] of nodal gaps ``gap`` [m]: the grid's 2π∫p r dr plus the rigid tail beyond r_max.

    The tail is 2πR·W(h(r_max)), h(r_max) ≈ h_n + (r_max² − r_n²)/2R (the deformation taken
    constant beyond the outermost node r_n): exact for a rigid paraboloid (Derjaguin).
    """
    require_instance("problem", problem, ContactProblem)
    gap = np.asarray(gap, dtype=float)
    edge = edge_gap(problem, gap)
    tail = 2.0 * np.pi * problem.sphere.radius * float(problem.surface_force.energy(edge))
    return float(problem.load(problem.surface_force.pressure(gap))) + tail


class _Path:
    """The numerical state of one continuation (internal; :func:`equilibrium_path` drives it)."""

    def __init__(self, problem: ContactProblem, modulus: float):
        self.problem = problem
        self.law = problem.surface_force
        self.ell = self.law.decay_length
        self.coupling = 2.0 / modulus
        self.a_mat = problem.influence
        self.n = problem.grid.size
        self.sag = problem.undeformed_gap(0.0) / self.ell
        self.weights = np.full(self.n + 1, 1.0 / self.n)
        self.weights[-1] = 1.0
        self.newton_iterations = 0
        self.rejected = 0

    def residual(self, y: FloatArray) -> FloatArray:
        h = y[:-1] * self.ell
        return y[:-1] - y[-1] - self.sag - self.coupling * (self.a_mat @ self.law.pressure(h)) / self.ell

    def matrix(self, y: FloatArray, border: FloatArray) -> FloatArray:
        """The bordered Jacobian at ``y`` with last row ``border`` (already weighted)."""
        n = self.n
        m = np.empty((n + 1, n + 1))
        m[:n, :n] = self.a_mat * (-self.coupling * self.law.pressure_derivative(y[:-1] * self.ell))
        m[np.arange(n), np.arange(n)] += 1.0
        m[:n, n] = -1.0
        m[n] = border
        return m

    def norm(self, t: FloatArray) -> float:
        return float(np.sqrt(np.sum(self.weights * t * t)))

    def tangent(self, lu, border: FloatArray) -> FloatArray:
        """Unit tangent from a factored bordered matrix whose last row is ``border``."""
        rhs = np.zeros(self.n + 1)
        rhs[-1] = 1.0
        t = scipy.linalg.lu_solve(lu, rhs)
        return t / self.norm(t)

    def correct(self, y_pred: FloatArray, t: FloatArray, xtol: float):
        """Newton on G = 0, ⟨t, y − y_pred⟩ = 0 from ``y_pred``; (y, factor) or None on failure."""
        y = y_pred.copy()
        border = self.weights * t
        first = None
        for _ in range(_MAX_CORRECTOR):
            g = np.append(self.residual(y), border @ (y - y_pred))
            try:
                lu = scipy.linalg.lu_factor(self.matrix(y, border), check_finite=False)
            except (ValueError, np.linalg.LinAlgError):
                return None
            delta = scipy.linalg.lu_solve(lu, -g)
            if not np.all(np.isfinite(delta)):
                return None
            step = 1.0
            shrinking = delta[:-1] < (_SHRINK - 1.0) * y[:-1]
            if shrinking.any():
                step = float(np.min((_SHRINK - 1.0) * y[:-1][shrinking] / delta[:-1][shrinking]))
            y = y + step * delta
            self.newton_iterations += 1
            size = float(np.abs(delta).max())
            first = size if first is None else first
            if step == 1.0 and size <= xtol:
                return y, lu, first
        return None

    def force(self, y: FloatArray) -> float:
        return load_with_tail(self.problem, y[:-1] * self.ell)

    def force_slope(self, y: FloatArray, t: FloatArray) -> float:
        """dF/ds along the unit tangent ``t`` [N per decay length] (the tail's share omitted)."""
        h = y[:-1] * self.ell
        return float(self.problem.load(self.law.pressure_derivative(h) * t[:-1] * self.ell))


def equilibrium_path(problem: ContactProblem, start: float, stop: float, *,
                     modulus: float | None = None, max_step: float | None = None,
                     contact_threshold: float | None = None, until_fold: bool = False,
                     max_points: int = 5000) -> EquilibriumPath:
    """Trace the static elastic equilibria from h0 = ``start`` to ``stop`` through folds.

    ``start > stop`` is an approach: the path starts on the far (non-contact) branch, passes the
    jump-in fold, the unstable branch and the jump-out fold, and ends on the contact branch.
    ``start < stop`` is a retraction from contact: the path starts on the contact branch (the
    static solve from the undeformed gap, see :func:`~viscoforce.solvers.static.equilibrium_gap`)
    and meets the jump-out first.

    Parameters
    ----------
    problem : ContactProblem
        System and grid (e.g. ``ContactProblem(sphere, law, material, adhesion_grid(...))``).
        The grid's undeformed gap at r_max must exceed 10 decay lengths at min(start, stop).
    start : float
        First position h0 [m].
    stop : float
        The path ends once it passes this position [m] moving towards it.
    modulus : float, optional
        Elastic modulus E [Pa]; default the material's relaxed modulus E_inf.
    max_step : float, optional
        Largest arclength step [m] (default half a decay length).
    contact_threshold : float, optional
        Gap [m] defining the contact radius; default the law's decay length.
    until_fold : bool
        Stop at the first fold (e.g. the jump-out of a retraction: enough for the pull-off).
    max_points : int
        Most accepted points (≥ 10).

    Returns
    -------
    EquilibriumPath
        The path in the order traced, its folds and the pull-off force (stability, jump-in and
        jump-out labels are those of an approach; a retraction's folds come in reverse order).

    Raises
    ------
    ParameterError
        start == stop, a grid too small for the range, or bad options.
    ConvergenceError
        The first equilibrium fails, the step size collapses, or ``max_points`` is exceeded.
    """
    require_instance("problem", problem, ContactProblem)
    start = require_finite("start", start)
    stop = require_finite("stop", stop)
    if start == stop:
        raise ParameterError(f"start must differ from stop, both are {start!r} m")
    modulus = (problem.material.relaxed_modulus if modulus is None
               else require_positive("modulus (E)", modulus))
    max_points = require_int("max_points", max_points, 10)
    law = problem.surface_force
    ell = law.decay_length
    ds_max = 0.5 if max_step is None else require_positive("max_step", max_step) / ell
    threshold = (ell if contact_threshold is None
                 else require_positive("contact_threshold", contact_threshold))
    deepest = min(start, stop)
    outer_gap = deepest + problem.grid.outer_radius**2 / (2.0 * problem.sphere.radius)
    if outer_gap < _MIN_OUTER_GAP * ell:
        raise ParameterError(
            f"the grid's outer_radius {problem.grid.outer_radius:.4g} m is too small for h0 = "
            f"{deepest:.4g} m: the undeformed gap there is {outer_gap:.3g} m, need >= "
            f"{_MIN_OUTER_GAP:g} decay lengths ({_MIN_OUTER_GAP * ell:.3g} m); use adhesion_grid")
    direction = -1.0 if stop < start else 1.0
    path = _Path(problem, modulus)
    y = _first_point(path, start)
    # first tangent: J dh = dh0·1, with dh0 pointing towards stop
    lu0 = scipy.linalg.lu_factor(path.matrix(y, np.eye(path.n + 1)[-1])[:-1, :-1])
    t = direction * np.append(scipy.linalg.lu_solve(lu0, np.ones(path.n)), 1.0)
    t /= path.norm(t)
    xtol = CORRECTOR_XTOL
    points = [(0.0, y)]
    folds: list[tuple[float, FloatArray]] = []
    extrema: list[tuple[float, FloatArray]] = []
    s, ds = 0.0, min(0.05, ds_max)
    far = abs(start - stop) * 10.0
    while True:
        if len(points) >= max_points:
            raise ConvergenceError(
                f"the continuation took {max_points} points without reaching stop {stop:.4g} m "
                f"(at h0 = {y[-1] * ell:.4g} m); raise max_points or max_step",
                iterations=path.newton_iterations)
        out = path.correct(y + ds * t, t, xtol)
        if out is not None:
            y_new, lu, error = out
            t_new = path.tangent(lu, path.weights * t)
            if np.sum(path.weights * t * t_new) < np.cos(_MAX_TURN):
                out = None
        if out is None:
            path.rejected += 1
            ds *= 0.5
            if ds < _MIN_STEP:
                raise ConvergenceError(
                    f"the continuation step collapsed at h0 = {y[-1] * ell:.6g} m (force "
                    f"{path.force(y):.4g} N): no equilibrium near the path; refine the grid",
                    iterations=path.newton_iterations)
            continue
        if np.sign(t_new[-1]) != np.sign(t[-1]):
            folds.append(_refine(path, y, t, ds, s, xtol, lambda yy, tt: tt[-1]))
        if np.sign(path.force_slope(y_new, t_new)) != np.sign(path.force_slope(y, t)):
            extrema.append(_refine(path, y, t, ds, s, xtol, path.force_slope))
        s += ds
        y, t = y_new, t_new
        points.append((s, y))
        h0 = y[-1] * ell
        if (until_fold and folds) or ((h0 - stop) * direction >= 0 and t[-1] * direction > 0):
            break
        if abs(h0 - start) > far:
            raise ConvergenceError(f"the path left the range (h0 = {h0:.4g} m)",
                                   iterations=path.newton_iterations)
        grow = np.sqrt(_TARGET_PREDICTOR_ERROR / max(error, 1e-12))
        ds = min(ds_max, ds * min(2.0, max(0.5, grow)))
        if t[-1] * direction > 0:  # do not overshoot stop by more than needed
            ds = min(ds, max((stop - h0) * direction / ell / abs(t[-1]) + 1e-3, 1e-3))
    return _assemble(path, points, folds, extrema, modulus, threshold, direction)


@dataclass(frozen=True)
class _ScaledAttraction(SurfaceForceLaw):
    """−k·A/(6π h³): the attractive half of a Lennard-Jones law, scaled by k (a homotopy)."""

    hamaker: float
    z0: float
    k: float

    def pressure(self, gap):
        return -self.k * self.hamaker / (6.0 * np.pi) / np.asarray(gap) ** 3

    def pressure_derivative(self, gap):
        return 3.0 * self.k * self.hamaker / (6.0 * np.pi) / np.asarray(gap) ** 4

    def energy(self, gap):
        return -self.k * self.hamaker / (12.0 * np.pi) / np.asarray(gap) ** 2

    @property
    def decay_length(self) -> float:
        return self.z0

    def negligible_gap(self, rtol: float) -> float:
        return self.z0 / rtol ** (1.0 / 3.0)


def _first_point(path: _Path, position: float) -> FloatArray:
    """The scaled state (h/ℓ, h0/ℓ) of an equilibrium at ``position`` [m].

    The static solver (:func:`~viscoforce.solvers.static.equilibrium_gap`) first. Where its line
    search fails (an adhesive contact: Newton from the undeformed gap does not converge), a
    homotopy in the attraction: the law's repulsive part (each Lennard-Jones term replaced by its
    (z0/h)⁹ wall) is solved first, then k·(the attraction) is switched on, k = 0 → 1, by Newton
    steps with h0 held fixed (k halved on failure). This lands on the contact branch.
    """
    problem = path.problem
    try:
        sol = equilibrium_gap(problem, position, 2.0 / path.coupling)
        return np.append(sol.gap / path.ell, position / path.ell)
    except ConvergenceError as exc:
        failure = exc
    terms = (problem.surface_force.terms if isinstance(problem.surface_force, SumOfLaws)
             else (problem.surface_force,))
    walls = [SoftWall(t.hamaker / (6.0 * np.pi * t.z0**3), t.z0)
             if isinstance(t, LennardJones) else t for t in terms]
    attractions = [t for t in terms if isinstance(t, LennardJones)]

    def sub_path(k: float) -> _Path:
        law = sum(walls[1:], walls[0])
        for t in attractions:
            law = law + _ScaledAttraction(t.hamaker, t.z0, k)
        sub = ContactProblem(problem.sphere, law, problem.material, problem.grid)
        sub.__dict__["influence"] = problem.influence  # share the built kernel
        out = _Path(sub, 2.0 / path.coupling)
        out.ell = path.ell
        return out

    try:
        gap = equilibrium_gap(sub_path(0.0).problem, position, 2.0 / path.coupling).gap
    except ConvergenceError:
        raise ConvergenceError(f"no static equilibrium found at the start h0 = {position:.4g} m "
                               f"({failure}); start the path elsewhere",
                               iterations=path.newton_iterations) from failure
    y = np.append(gap / path.ell, position / path.ell)
    fixed = np.eye(path.n + 1)[-1]
    k, dk = 0.0, 0.125
    while k < 1.0:
        k_next = min(1.0, k + dk)
        sub = sub_path(k_next) if k_next < 1.0 else path
        out = sub.correct(y, fixed, CORRECTOR_XTOL)
        path.newton_iterations += sub.newton_iterations if sub is not path else 0
        if out is None:
            dk *= 0.5
            if dk < 1e-4:
                raise ConvergenceError(
                    f"no static equilibrium found at the start h0 = {position:.4g} m ({failure}; "
                    f"the attraction homotopy stalled at k = {k:.4g}); start the path elsewhere",
                    iterations=path.newton_iterations) from failure
            continue
        y, k, dk = out[0], k_next, min(0.5, 1.5 * dk)
    return y


def _refine(path: _Path, y: FloatArray, t: FloatArray, ds: float, s: float, xtol: float,
            event) -> tuple[float, FloatArray]:
    """Arclength and state where ``event(y, t)`` changes sign between s and s + ds."""
    cache: dict[float, tuple[FloatArray, FloatArray]] = {}

    def state(sigma: float):
        if sigma not in cache:
            if sigma == 0.0:
                cache[sigma] = (y, t)
            else:
                out = path.correct(y + sigma * t, t, xtol)
                if out is None:
                    raise ConvergenceError(f"fold refinement failed at s = {s + sigma:.6g}",
                                           iterations=path.newton_iterations)
                cache[sigma] = (out[0], path.tangent(out[1], path.weights * t))
        return cache[sigma]

    def f(sigma: float) -> float:
        yy, tt = state(sigma)
        return float(event(yy, tt))

    lo, hi = 0.0, ds
    f_lo, f_hi = f(lo), f(hi)
    try:
        sigma = lo if f_lo == 0.0 else hi if f_hi == 0.0 else _bracketed_root(
            f, lo, hi, f_lo, f_hi, xtol=1e-9 * ds)
    except ConvergenceError:  # no equilibrium inside the step: keep the nearer end point
        sigma = lo if abs(f_lo) <= abs(f_hi) else hi
    return s + sigma, state(sigma)[0]


def _assemble(path: _Path, points, folds, extrema, modulus: float, threshold: float,
              direction: float) -> EquilibriumPath:
    problem, ell = path.problem, path.ell
    rows = []
    for s, y in points:
        rows.append(_describe(path, s, y, threshold))
    arr = np.array(rows)
    s_all = arr[:, 0]
    fold_s = np.array([f[0] for f in folds])
    stable = (np.searchsorted(fold_s, s_all, side="left") % 2) == 0
    kinds = ["fold"] * len(folds)
    approach = direction < 0
    if folds:  # an approach meets the jump-in first, a retraction the jump-out
        kinds[0] = "jump_in" if approach else "jump_out"
        if len(folds) > 1:
            kinds[-1] = "jump_out" if approach else "jump_in"
    fold_objs = tuple(Fold(k, float(y[-1] * ell), path.force(y), float(s))
                      for k, (s, y) in zip(kinds, folds, strict=True))
    # the contact branch: after the last fold of an approach, before the first of a retraction
    if not folds:
        on_branch = np.ones(s_all.shape, dtype=bool)
    elif approach:
        on_branch = s_all >= fold_s[-1] if len(folds) % 2 == 0 else np.zeros(s_all.shape, bool)
    else:
        on_branch = s_all <= fold_s[0]
    candidates = [(f, p) for f, p in zip(arr[on_branch, 2], arr[on_branch, 1], strict=True)]
    for s, y in extrema:
        if (not folds or (approach and len(folds) % 2 == 0 and s >= fold_s[-1])
                or (not approach and s <= fold_s[0])):
            candidates.append((path.force(y), float(y[-1] * ell)))
    f_min, p_min = min(candidates) if candidates else (None, None)
    params = dict(problem.parameters())
    lj = lennard_jones_term(problem.surface_force)
    if lj is not None:
        params["work_of_adhesion"] = lj.work_of_adhesion
        params["tabor_parameter"] = lj.tabor_parameter(problem.sphere.radius, modulus)
    params.update({"contact_threshold": threshold, "newton_iterations": path.newton_iterations,
                   "rejected_steps": path.rejected})
    return EquilibriumPath(
        arclength=s_all, position=arr[:, 1], force=arr[:, 2], u_center=arr[:, 3],
        h_center=arr[:, 4], contact_radius=arr[:, 5], stable=stable,
        gap=np.array([y[:-1] * ell for _, y in points]), folds=fold_objs,
        pull_off=None if f_min is None else float(-f_min),
        pull_off_position=None if p_min is None else float(p_min), modulus=modulus,
        parameters=params)


def _describe(path: _Path, s: float, y: FloatArray, threshold: float) -> tuple:
    problem, ell = path.problem, path.ell
    h = y[:-1] * ell
    h0 = float(y[-1] * ell)
    p = path.law.pressure(h)
    u_c = float(-path.coupling * problem.center_row @ p)
    h_c = h0 - u_c
    a = contact_radius(problem.grid, h, h_c, threshold)
    return (s, h0, path.force(y), u_c, h_c, a)
