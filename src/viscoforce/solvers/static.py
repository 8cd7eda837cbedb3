"""Static elastic equilibrium at a fixed position (paper Eq. 2 with Eq. 13)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from viscoforce._limits import MEAN_FORCE_RANGE
from viscoforce._validation import (
    require_finite,
    require_instance,
    require_plausible,
    require_positive,
)
from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.problem import ContactProblem, _bracketed_root, check_half_space, contact_radius
from viscoforce.schema import SIGN_CONVENTION, make_equilibrium
from viscoforce.solvers.newton import _GETRS, NewtonResult, solve_gap
from viscoforce.units import format_quantity

#: Newton tolerance on the gap update, in units of the surface force's decay length.
STATIC_XTOL = 1e-9
#: Tolerance of :func:`position_at_load` on the position, in units of the decay length.
LOAD_POSITION_XTOL = 1e-6
#: Most static solves :func:`position_at_load` spends on bracketing the load.
_MAX_BRACKET_STEPS = 60


def equilibrium_gap(problem: ContactProblem, position: float, modulus: float, *,
                    initial: np.ndarray | None = None) -> NewtonResult:
    """Nodal gaps of the elastic equilibrium h = h0(r) + (2/E) A p(h) at ``position`` [m].

    Parameters
    ----------
    problem : ContactProblem
        System and grid.
    position : float
        Apex position h0 [m].
    modulus : float
        Elastic modulus E [Pa] (paper convention).
    initial : ndarray, optional
        Starting gaps [m]; default max(h0(r), λ) with λ the decay length of the law.
    """
    require_instance("problem", problem, ContactProblem)
    modulus = require_positive("modulus (E)", modulus)
    base = problem.undeformed_gap(position)
    if initial is None:
        initial = np.maximum(base, problem.surface_force.decay_length)
    xtol = STATIC_XTOL * problem.surface_force.decay_length
    return solve_gap(problem, base, 2.0 / modulus, initial, xtol=xtol)


def modulus_slope(problem: ContactProblem, position: float, modulus: float,
                  sol: NewtonResult) -> np.ndarray:
    """dh/dE [m/Pa]: how the equilibrium gaps of :func:`equilibrium_gap` move with the modulus.

    Differentiating h − b − (2/E) A p(h) = 0 gives J dh/dE = (b − h)/E, with J = I − (2/E) A p'
    the Newton Jacobian and (2/E) A p = h − b at the solution. ``sol.factor`` holds J's LU
    factors at the last Newton iterate (within the tolerance of ``sol.gap``), so this is one
    back-substitution: a predictor for a nearby modulus (:func:`equilibrium_gap`'s ``initial``),
    accurate to first order, not a sensitivity to rely on beyond that.

    Parameters
    ----------
    problem : ContactProblem
        The system ``sol`` was solved for.
    position : float
        Apex position h0 [m] of ``sol``.
    modulus : float
        Modulus E [Pa] of ``sol``, > 0.
    sol : NewtonResult
        A solution of :func:`equilibrium_gap` with its factors.

    Returns
    -------
    numpy.ndarray
        dh/dE at the nodes [m/Pa].

    Raises
    ------
    ParameterError
        ``sol`` carries no factors (``factor`` is None) or ``modulus`` ≤ 0.
    """
    modulus = require_positive("modulus (E)", modulus)
    if sol.factor is None:
        raise ParameterError("sol must carry the Newton Jacobian's factors (sol.factor is None)")
    rhs = (problem.undeformed_gap(position) - sol.gap) / modulus
    lu, piv = sol.factor
    out, info = _GETRS(lu, piv, rhs)
    if info != 0:  # pragma: no cover - factors of a nonsingular Jacobian
        raise ConvergenceError(f"LAPACK getrs reported illegal argument {-info}", iterations=0)
    return out


def static_equilibrium(problem: ContactProblem, position: float, *, modulus: float | None = None,
                       contact_threshold: float | None = None) -> xr.Dataset:
    """Static elastic equilibrium of the sphere at apex position ``position``.

    Parameters
    ----------
    problem : ContactProblem
        System and grid; the grid must reach far enough for ``position``
        (build it with ``ContactProblem.create(..., deepest_position=position)``).
    position : float
        Apex position h0 [m] (may be negative for deformable bodies).
    modulus : float, optional
        Elastic modulus E [Pa]; default the material's relaxed modulus E_inf.
    contact_threshold : float, optional
        Gap [m] below which the surfaces count as in contact; default the law's decay length (1/κ).

    Returns
    -------
    xarray.Dataset
        Profiles ``gap``, ``deformation``, ``pressure``, ``undeformed_gap`` over ``r`` [m]; scalars
        ``position``, ``force``, ``force_rigid``, ``u_center``, ``h_center``, ``contact_radius``;
        attrs hold every parameter, the Newton iteration count and the final update norm.

    Raises
    ------
    ParameterError
        Bad position/modulus or a grid too small for the position.
    ConvergenceError
        Newton failed (never returns a partial result).
    ModelValidityError
        The result lies far outside the half-space model (contact radius or deformation not small
        against R; :func:`~viscoforce.problem.check_half_space`).

    Warns
    -----
    ModelValidityWarning
        The contact radius or deformation approaches R (the model degrades).
    """
    require_instance("problem", problem, ContactProblem)
    position = require_finite("position (h0)", position)
    modulus = (problem.material.relaxed_modulus if modulus is None
               else require_positive("modulus (E)", modulus))
    threshold = (problem.surface_force.decay_length if contact_threshold is None
                 else require_positive("contact_threshold", contact_threshold))
    problem.check_covers(position)
    sol = equilibrium_gap(problem, position, modulus)
    return equilibrium_dataset(problem, position, modulus, sol, threshold)


def equilibrium_dataset(problem: ContactProblem, position: float, modulus: float,
                        sol: NewtonResult, threshold: float) -> xr.Dataset:
    """Package one equilibrium as a Dataset (:func:`viscoforce.schema.make_equilibrium`)."""
    base = problem.undeformed_gap(position)
    u_center = float(-(2.0 / modulus) * problem.center_row @ sol.pressure)
    h_center = position - u_center
    attrs = dict(problem.parameters())
    attrs.update({"modulus": modulus, "contact_threshold": threshold,
                  "newton_iterations": sol.iterations, "newton_update_norm": sol.update_norm,
                  "sign_convention": SIGN_CONVENTION})
    radius = contact_radius(problem.grid, sol.gap, h_center, threshold)
    check_half_space(problem.sphere.radius, u_center, radius,
                     where=f"at h0 = {format_quantity(position, 'length')}", stacklevel=4)
    return make_equilibrium(
        problem.grid.r, gap=sol.gap, deformation=base - sol.gap, pressure=sol.pressure,
        undeformed_gap=base, position=position, force=float(problem.load(sol.pressure)),
        force_rigid=problem.rigid_load(position), u_center=u_center, h_center=h_center,
        contact_radius=radius, contact_threshold=threshold, attrs=attrs)


def position_at_load(problem: ContactProblem, load: float, modulus: float, *,
                     guess: float | None = None) -> float:
    """The position h̄0 [m] whose static equilibrium with modulus ``modulus`` carries ``load``.

    Parameters
    ----------
    problem : ContactProblem
        System and grid; the grid must reach the position sought (see
        :meth:`~viscoforce.problem.ContactProblem.check_covers`).
    load : float
        Static load F [N], > 0 and within :data:`~viscoforce._limits.MEAN_FORCE_RANGE`.
    modulus : float
        Elastic modulus E [Pa], > 0 (the relaxed modulus E_inf for a linearisation).
    guess : float, optional
        Starting position [m] (e.g. the answer for a nearby modulus); default 0 (moved up to
        the shallowest the grid covers if it does not cover 0).

    Returns
    -------
    float
        The position, to ``LOAD_POSITION_XTOL`` decay lengths (1e-15 m for the paper's law).

    Raises
    ------
    ParameterError
        ``load`` ≤ 0, not finite or outside :data:`~viscoforce._limits.MEAN_FORCE_RANGE`,
        ``modulus`` ≤ 0, ``guess`` not finite.
    ConvergenceError
        The load cannot be bracketed within the positions the grid covers (build the problem
        with a deeper ``deepest_position``), or a static solve fails.

    Notes
    -----
    See :func:`equilibrium_at_load`, which also returns the equilibrium found there.
    """
    return equilibrium_at_load(problem, load, modulus, guess=guess)[0]


def equilibrium_at_load(problem: ContactProblem, load: float, modulus: float, *,
                        guess: float | None = None) -> tuple[float, NewtonResult]:
    """:func:`position_at_load` and the static equilibrium (:class:`NewtonResult`) at it.

    The load F(h0) of a repulsive law grows monotonically as h0 decreases. The position is
    bracketed by steps of one decay length λ from ``guess``, doubled each time (downward steps
    are halved where the grid stops covering the position), then refined by the project's
    Illinois root search (:func:`viscoforce.problem._bracketed_root`) on
    asinh(F/ε) − asinh(load/ε) with ε = 1e-6·load: logarithmic in F well above ε, where
    F ∝ e^{−h0/λ} makes it nearly linear in h0, and still defined for a net attraction (F ≤ 0).
    Each static Newton solve starts from the gaps of the previous one (warm start: 4–5 Newton
    iterations in contact instead of 7 from the default start; shifting the gaps by the change
    of position was measured to be worse there, 10, since the deformation absorbs most of it).

    Parameters and exceptions are those of :func:`position_at_load`.

    Returns
    -------
    position : float
        h̄0 [m].
    equilibrium : NewtonResult
        The static solution at ``position``; ``problem.load(equilibrium.pressure)`` ≈ ``load``.
    """
    require_instance("problem", problem, ContactProblem)
    try:
        load = require_positive("load", load)
    except ParameterError:
        raise ParameterError(f"load must be > 0 [N] (finite), got {load!r}") from None
    # a subnormal load made the bracketing's scale 1e-6·load underflow to 0 (a division by it)
    load = require_plausible("load", load, MEAN_FORCE_RANGE, "N")
    modulus = require_positive("modulus (E)", modulus)
    x0 = 0.0 if guess is None else require_finite("guess", guess)
    decay = problem.surface_force.decay_length
    scale = 1e-6 * load
    target = float(np.arcsinh(load / scale))
    solved: dict[float, NewtonResult] = {}
    last: list[NewtonResult] = []  # the latest solve: the next one starts from its gaps

    def solve(x: float) -> NewtonResult:
        if x in solved:
            return solved[x]
        sol = equilibrium_gap(problem, x, modulus, initial=last[0].gap if last else None)
        solved[x] = sol
        last[:] = [sol]
        return sol

    def f(x: float) -> float:
        force = float(problem.load(solve(x).pressure))
        return float(np.arcsinh(force / scale)) - target

    step = decay
    while not _covers(problem, x0):  # start inside the grid
        x0, step = x0 + step, 2.0 * step
        if step > 2.0**_MAX_BRACKET_STEPS * decay:
            raise ConvergenceError(f"no position covered by the grid above {x0:.4g} m",
                                   iterations=0)
    f0 = f(x0)
    if f0 == 0.0:
        return x0, solve(x0)
    if f0 > 0:  # more than ``load`` at x0: step up (the load falls off with the position)
        lo, f_lo, hi, f_hi = x0, f0, x0 + step, f(x0 + step)
        for _ in range(_MAX_BRACKET_STEPS):
            if f_hi <= 0:
                break
            step *= 2.0
            lo, f_lo, hi = hi, f_hi, hi + step
            f_hi = f(hi)
        else:
            raise ConvergenceError(
                f"cannot bracket the load {load:.4g} N: it still exceeds it at {hi:.4g} m after "
                f"{_MAX_BRACKET_STEPS} steps up from {x0:.4g} m", iterations=len(solved))
    else:  # less than ``load``: step down, within the grid
        hi, f_hi, lo, f_lo = x0, f0, x0, f0
        for _ in range(_MAX_BRACKET_STEPS):
            if f_lo >= 0:
                break
            x = lo - step
            while not _covers(problem, x) and step > LOAD_POSITION_XTOL * decay:
                step *= 0.5
                x = lo - step
            if not _covers(problem, x):
                raise ConvergenceError(
                    f"cannot bracket the load {load:.4g} N within the grid: the deepest position "
                    f"it covers ({lo:.4g} m) carries "
                    f"{float(problem.load(solve(lo).pressure)):.4g} N at E = {modulus:.4g} Pa; "
                    "build the problem with a deeper deepest_position", iterations=len(solved))
            hi, f_hi, lo = lo, f_lo, x
            f_lo = f(lo)
            step *= 2.0
        else:
            raise ConvergenceError(
                f"cannot bracket the load {load:.4g} N: it is still not reached at {lo:.4g} m "
                f"after {_MAX_BRACKET_STEPS} steps down from {x0:.4g} m", iterations=len(solved))
    if f_lo == 0.0:
        return lo, solve(lo)
    if f_hi == 0.0:
        return hi, solve(hi)
    x = _bracketed_root(f, lo, hi, f_lo, f_hi, xtol=LOAD_POSITION_XTOL * decay)
    return x, solve(x)


def _covers(problem: ContactProblem, position: float) -> bool:
    """Whether the grid of ``problem`` reaches far enough for ``position`` [m]."""
    try:
        problem.check_covers(position)
    except ParameterError:
        return False
    return True
