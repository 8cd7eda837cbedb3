"""Viscoelastic adhesive trajectories through jump-in and jump-out (issue 39, items 3 and 4).

With an attractive surface force (:class:`~viscoforce.physics.surface_forces.LennardJones`) the
static elastic equilibrium folds (:mod:`viscoforce.solvers.continuation`): on approach the far
branch ends (jump-in), on retraction the contact branch ends (jump-out). For a viscoelastic solid
the instantaneous response is the glassy one, E0: with the creep memory of Eq. 5 / Eq. 12 held
fixed, the rate equation stays regular as long as the *glassy* equilibrium
h = b + (2/E0)·A p(h) is (I − (2/E0)·A·diag p′(h) nonsingular), and a jump of the relaxed (E_inf)
equilibrium is a fast transient on the time scale of the creep, not a discontinuity.

The time stepping is :func:`viscoforce.solvers.simulate.simulate`'s: the exponential trapezoidal
stepper is implicit in the instantaneous response (each step solves h = b + c_eff·A p(h),
c_eff → 2/E0 as dt → 0) and has a local error estimate, so its step control shrinks through a
jump (a step whose Newton fails or whose error is too large is retried at a quarter or less of its
length). What this module adds:

* the grid check of an adhesive problem (the compact grid of
  :func:`~viscoforce.solvers.continuation.adhesion_grid` plus the rigid Derjaguin tail of the
  slowly decaying attraction, :func:`~viscoforce.solvers.continuation.load_with_tail`, as part 1
  does for the statics);
* jump events found on the accepted steps: a run of steps over which the central gap h(0) moves
  faster than :data:`JUMP_RATIO` times the drive and by more than half a decay length in all —
  closing (``jump_in``) or opening (``jump_out``) — reported at its onset (time, position, force)
  with its end;
* per loop: the pull-off force (−min F), the hysteresis energy −∮F dh0 [J] (the work the drive
  does on the bodies; ≥ 0 when the loop starts and ends at rest far apart) with its quadrature
  error, and Δγ_eff = pull-off/(1.5πR);
* a refusal with the reason where the glassy equilibrium itself folds (then the jump would be
  instantaneous even for the viscoelastic solid: a step the stepper cannot take).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import xarray as xr

from viscoforce._typing import FloatArray, SeparationHistory
from viscoforce._validation import (
    require_finite,
    require_increasing,
    require_instance,
    require_int,
    require_positive,
)
from viscoforce.exceptions import ConvergenceError, GapClosureError, ParameterError
from viscoforce.problem import ContactProblem, contact_radius
from viscoforce.schema import make_trajectory
from viscoforce.solvers.base import State, StepOutcome, TimeStepper
from viscoforce.solvers.continuation import _first_point, _Path, lennard_jones_term, load_with_tail
from viscoforce.solvers.newton import solve_gap
from viscoforce.solvers.steppers import DEFAULT_METHOD, METHODS
from viscoforce.solvers.time_loop import _march, _step_control, profile_variables

#: A step is part of a jump when |Δh(0)| exceeds this many times the drive's |Δh0| over it.
JUMP_RATIO = 5.0
#: A jump must move h(0) by at least this many decay lengths in all.
JUMP_MIN_TRAVEL = 0.5
#: The undeformed gap at the grid's edge must exceed this many decay lengths (as the statics).
MIN_OUTER_GAP = 10.0
#: Default local error tolerance of the adhesive march, in decay lengths (z0 for Lennard-Jones).
ADHESIVE_TOL = 1e-4


@dataclass(frozen=True)
class Jump:
    """A jump event of a trajectory (onset and end of the fast transient).

    Attributes
    ----------
    kind : str
        ``"jump_in"`` (the gap closes) or ``"jump_out"`` (the gap opens).
    time, position : float
        t [s] and h0 [m] of the jump's fastest step (a glassy jump's instant).
    force : float
        F [N] at the jump's onset (the force just before the jump).
    end_time, end_position, end_force : float
        At the end of the transient: t [s], h0 [m], F [N].
    """

    kind: str
    time: float
    position: float
    force: float
    end_time: float
    end_position: float
    end_force: float

    def as_dict(self) -> dict[str, float]:
        """{position, time, force, end_time, end_force} (SI), the CLI's JSON object."""
        return {"position": self.position, "time": self.time, "force": self.force,
                "end_time": self.end_time, "end_position": self.end_position,
                "end_force": self.end_force}


def is_adhesive(problem: ContactProblem) -> bool:
    """Whether the problem's surface force has an attractive Lennard-Jones term."""
    return lennard_jones_term(problem.surface_force) is not None


def check_adhesive_grid(problem: ContactProblem, deepest: float) -> None:
    """Raise unless the grid's undeformed gap at r_max exceeds 10 decay lengths at ``deepest``."""
    ell = problem.surface_force.decay_length
    outer_gap = deepest + problem.grid.outer_radius**2 / (2.0 * problem.sphere.radius)
    if outer_gap < MIN_OUTER_GAP * ell:
        raise ParameterError(
            f"the grid's outer_radius {problem.grid.outer_radius:.4g} m is too small for h0 = "
            f"{deepest:.4g} m: the undeformed gap there is {outer_gap:.3g} m, need >= "
            f"{MIN_OUTER_GAP:g} decay lengths ({MIN_OUTER_GAP * ell:.3g} m); build the grid with "
            "viscoforce.solvers.continuation.adhesion_grid")


def glassy_fold_reason(problem: ContactProblem, state: State) -> str | None:
    """Why a step from ``state`` cannot be taken, if the glassy equilibrium is (nearly) singular.

    Returns a sentence when the smallest eigenvalue of I − (2/E0)·A·diag p′(h) at the state is
    below 0.05 (the instantaneous, glassy equilibrium is at or past a fold: the jump would be
    instantaneous, the rate equation of Eq. 5 singular), else None.
    """
    e0 = problem.material.instantaneous_modulus
    smallest = _smallest_glassy_eigenvalue(problem, 2.0 / e0, state.gap)
    if smallest >= GLASSY_FOLD_EIGENVALUE:
        return None
    return (f"the glassy (E0 = {e0:.3g} Pa) equilibrium is at a fold at t = {state.time:.6g} s, "
            f"h0 = {state.position:.4g} m (smallest eigenvalue of I - (2/E0) A p'(h) is "
            f"{smallest:.3g}): even the instantaneous response jumps here, so the rate equation "
            "(Eq. 5 with Eq. 7) is singular and the instantaneous jump to the other branch did "
            "not settle; refine the grid or loosen tol")


#: A rejected step shorter than this fraction of the shortest creep time triggers the glassy jump.
GLASSY_JUMP_STEP = 1e-6
#: Smallest eigenvalue of the glassy Jacobian below which the glassy equilibrium is at a fold.
GLASSY_FOLD_EIGENVALUE = 0.05


def _glassy_spectrum(problem: ContactProblem, coupling: float, gap: FloatArray
                     ) -> tuple[FloatArray, FloatArray]:
    """Real parts of the eigenvalues and eigenvectors of I − coupling·A·diag p′(h)."""
    jac = -coupling * problem.influence * problem.surface_force.pressure_derivative(gap)[None, :]
    jac[np.diag_indices_from(jac)] += 1.0
    values, vectors = np.linalg.eig(jac)
    return np.real(values), np.real(vectors)


def _smallest_glassy_eigenvalue(problem: ContactProblem, coupling: float, gap: FloatArray) -> float:
    return float(np.min(_glassy_spectrum(problem, coupling, gap)[0]))


class GlassyJump:
    """The instantaneous jump of the glassy equilibrium at a fold (the march's ``rescue``).

    When the glassy equilibrium h = b + (2/E0)·A p(h) (b: the undeformed gap minus the frozen
    creep memory) itself folds, the rate equation is singular and even the viscoelastic solid
    jumps in no time. The jump follows the regularised flow ε dh/ds = −(h − b − (2/E0)·A p(h))
    (a vanishing dashpot in series with the glassy spring: it falls into the stable equilibrium
    the physics reaches) by implicit Euler in s, each substep the equilibrium
    h = (h_k + σb)/(1 + σ) + σ/(1 + σ)·(2/E0)·A p(h) of :func:`~viscoforce.solvers.newton.solve_gap`
    (regular for small σ), σ growing as the flow settles; the memory is unchanged.

    Parameters
    ----------
    stepper : TimeStepper
        The march's stepper (its glassy compliance, influence and tolerance).
    """

    def __init__(self, stepper: TimeStepper, max_step: float):
        self.stepper = stepper
        self.problem = stepper.problem
        tau_min = float(np.min(stepper.taus)) if stepper.taus.size else max_step
        #: Rejected steps shorter than this [s] try the jump.
        self.threshold = GLASSY_JUMP_STEP * min(tau_min, max_step)
        self.jumps = 0

    def __call__(self, state: State) -> State | None:
        """The state after the glassy jump from ``state``, or None (no fold there / no jump).

        The flow starts half a decay length along the null vector of the glassy Jacobian, both
        ways: one way falls back to the vanishing branch, the other into the new one.
        """
        problem, stepper = self.problem, self.stepper
        c = stepper.c_glassy
        values, vectors = _glassy_spectrum(problem, c, state.gap)
        k = int(np.argmin(values))
        if values[k] >= GLASSY_FOLD_EIGENVALUE:
            return None
        n = problem.grid.size
        ell = problem.surface_force.decay_length
        base = problem.undeformed_gap(state.position) - state.memory.sum(axis=0)[:n]
        null = vectors[:, k] * (0.5 * ell / float(np.max(np.abs(vectors[:, k]))))
        best = None
        for sign in (1.0, -1.0):
            gap = self._flow(base, np.maximum(state.gap + sign * null, 0.5 * state.gap))
            if gap is None:
                continue
            travel = float(np.max(np.abs(gap - state.gap)))
            if travel >= JUMP_MIN_TRAVEL * ell and (best is None or travel > best[0]):
                best = (travel, gap)
        if best is None:
            return None
        pressure = problem.surface_force.pressure(best[1])
        q = stepper.response(pressure)
        self.jumps += 1
        return State(state.time, state.position, best[1], pressure, q, state.memory,
                     -c * q + state.memory.sum(axis=0))

    def _flow(self, base: FloatArray, gap: FloatArray) -> FloatArray | None:
        """Follow the regularised flow from ``gap`` to a stable glassy equilibrium (or None)."""
        problem, stepper = self.problem, self.stepper
        c, sigma = stepper.c_glassy, 1e-2
        for _ in range(200):
            try:
                sol = solve_gap(problem, (gap + sigma * base) / (1 + sigma),
                                sigma * c / (1 + sigma), gap, xtol=stepper.xtol)
            except (ConvergenceError, GapClosureError):
                sigma *= 0.25
                if sigma < 1e-8:
                    return None
                continue
            gap = sol.gap
            if sigma > 1e4:
                break
            sigma *= 2.0
        try:
            sol = solve_gap(problem, base, c, gap, xtol=stepper.xtol)
        except (ConvergenceError, GapClosureError):
            return None
        if float(np.min(_glassy_spectrum(problem, c, sol.gap)[0])) <= 0.0:
            return None
        return sol.gap


def adhesive_equilibrium_gap(problem: ContactProblem, position: float, *,
                             modulus: float | None = None) -> FloatArray:
    """Nodal gaps [m] of a static elastic equilibrium at ``position`` [m], in contact if need be.

    The static solve, and where it fails (an adhesive contact) the attraction homotopy that
    lands on the contact branch (as :func:`equilibrium_path`'s first point). ``modulus``:
    E [Pa], default the relaxed modulus E_inf.
    """
    require_instance("problem", problem, ContactProblem)
    position = require_finite("position (h0)", position)
    modulus = (problem.material.relaxed_modulus if modulus is None
               else require_positive("modulus (E)", modulus))
    path = _Path(problem, modulus)
    return _first_point(path, position)[:-1] * path.ell


#: Largest change of any nodal gap in one step, in decay lengths: a jump is resolved in steps.
MAX_GAP_CHANGE = 0.5


def _guarded(cls: type[TimeStepper]) -> type[TimeStepper]:
    """``cls`` whose error estimate also counts a gap change above ``gap_limit`` [m] in one step.

    The memory-curvature estimate of the exponential steppers does not see a jump of the
    instantaneous gap (Newton may converge to the far branch within one step); scaling the
    error by (change/limit)^(order+1) makes the step control shrink through the jump instead.
    """
    class Guarded(cls):
        gap_limit = math.inf
        tol = math.inf

        def step(self, state, drive, dt):
            outcome = super().step(state, drive, dt)
            change = float(np.max(np.abs(outcome.state.gap - state.gap)))
            if change > self.gap_limit:
                error = max(outcome.error, self.tol * (change / self.gap_limit) ** (self.order + 1))
                outcome = StepOutcome(outcome.state, error, outcome.iterations)
            return outcome

    Guarded.__name__ = Guarded.__qualname__ = f"Guarded{cls.__name__}"
    return Guarded


def relaxed_adhesive_state(stepper: TimeStepper, position: float) -> State:
    """The static E_inf equilibrium at ``position`` [m] at t = 0, on the contact branch in contact.

    :meth:`~viscoforce.solvers.base.TimeStepper.relaxed_state` with the start of
    :func:`~viscoforce.solvers.continuation.adhesive_equilibrium_gap` (an adhesive contact is
    out of reach of Newton from the undeformed gap): every mode at rest, w_i = −c_i q.
    """
    problem = stepper.problem
    gap = adhesive_equilibrium_gap(problem, position)
    pressure = problem.surface_force.pressure(gap)
    q = stepper.response(pressure)
    memory = -stepper.c_modes[:, None] * q[None, :]
    return State(0.0, position, gap, pressure, q, memory,
                 -(2.0 / problem.material.relaxed_modulus) * q)


def simulate_adhesive(problem: ContactProblem, drive: SeparationHistory, *, t_end: float,
                      t_eval: FloatArray, tol: float | None = None, max_step: float | None = None,
                      contact_threshold: float | None = None,
                      method: str = DEFAULT_METHOD, profiles: int = 0) -> xr.Dataset:
    """The viscoelastic adhesive trajectory along ``drive`` with its jumps, pull-off and hysteresis.

    Parameters
    ----------
    problem : ContactProblem
        System with an attractive law and a grid from
        :func:`~viscoforce.solvers.continuation.adhesion_grid` (E = E_inf) reaching the drive's
        deepest position.
    drive : SeparationHistory
        Position h0(t) [m] (triangle, step, sine, trace).
    t_end : float
        End time [s].
    t_eval : array_like
        Output times [s] in [0, t_end], increasing.
    tol : float, optional
        Local error tolerance [m]; default :data:`ADHESIVE_TOL` decay lengths.
    max_step : float, optional
        Largest step [s]; default t_end/200.
    contact_threshold : float, optional
        Gap [m] defining contact; default the law's decay length.
    method : str
        An adaptive stepper of :data:`~viscoforce.solvers.steppers.METHODS`.
    profiles : int
        Store the profiles gap, deformation and pressure on the grid every ``profiles``-th
        output time (0: none), as :func:`~viscoforce.solvers.simulate.simulate` does: the
        surface shapes through the jumps (Fig. 7's kind).

    Returns
    -------
    xarray.Dataset
        The trajectory (force with the rigid tail beyond the grid) and in ``attrs``:
        ``pull_off`` [N], ``pull_off_time``, ``pull_off_position``, ``hysteresis_energy`` [J],
        ``hysteresis_quadrature_error`` [J], ``effective_work_of_adhesion`` [J/m²], ``n_jumps``,
        ``jump_in_*`` / ``jump_out_*`` (first of each: position, time, force) and the counters.

    Raises
    ------
    ConvergenceError, GapClosureError
        A step that cannot be taken at the smallest step size, with the reason (a glassy fold).
    """
    require_instance("problem", problem, ContactProblem)
    if not is_adhesive(problem):
        raise ParameterError("simulate_adhesive needs an attractive (Lennard-Jones) surface force")
    if method not in METHODS or not METHODS[method].adaptive:
        raise ParameterError(f"method must be an adaptive stepper "
                             f"{sorted(k for k, v in METHODS.items() if v.adaptive)}, got {method!r}")
    t_end = require_positive("t_end", t_end)
    profiles = require_int("profiles", profiles, 0)
    check_adhesive_grid(problem, float(drive.extent()[0]))
    law = problem.surface_force
    ell = law.decay_length
    tol = ADHESIVE_TOL * ell if tol is None else require_positive("tol", tol)
    stepper = _guarded(METHODS[method])(problem)
    stepper.gap_limit, stepper.tol = MAX_GAP_CHANGE * ell, tol
    max_step = t_end / 200 if max_step is None else max_step
    control = _step_control(problem, stepper, t_end, None, tol, max_step)
    threshold = ell if contact_threshold is None else require_positive("contact_threshold",
                                                                        contact_threshold)
    state = relaxed_adhesive_state(stepper, float(drive.position(0.0)))
    steps: list[tuple[float, State]] = [(0.0, state)]
    try:
        rescue = GlassyJump(stepper, max_step)
        records, counters = _march(stepper, drive, state, np.asarray(t_eval, dtype=float), t_end,
                                   control, None, every_step=steps, rescue=rescue)
    except (ConvergenceError, GapClosureError) as exc:
        last = steps[-1][1]
        reason = glassy_fold_reason(problem, last)
        if reason is None:
            raise
        raise type(exc)(f"{exc}; {reason}", time=last.time, iterations=exc.iterations,
                        residual_norm=exc.residual_norm) from None
    summary = loop_summary(problem, steps, drive)
    states = [s for _, s in records]
    times = np.array([t for t, _ in records])
    position = np.array([s.position for s in states])
    u_center = np.array([s.u_center for s in states])
    h_center = position - u_center
    radius = np.array([contact_radius(problem.grid, s.gap, hc, threshold)
                       for s, hc in zip(states, h_center, strict=True)])
    force = np.array([load_with_tail(problem, s.gap) for s in states])
    profile = profile_variables(problem, times, states, profiles)
    attrs = dict(problem.parameters())
    attrs.update({"stepper": stepper.name, "tol": tol, "t_end": t_end, "max_step": max_step,
                  "dt": 0.0, "contact_threshold": threshold, "steps": counters.steps,
                  "rejected_steps": counters.rejected, "newton_iterations": counters.newton,
                  "force_includes_tail": 1, "glassy_jumps": rescue.jumps})
    describe = getattr(drive, "describe", None)
    attrs["drive"] = describe() if callable(describe) else type(drive).__name__
    attrs.update(summary_attrs(summary))
    return make_trajectory(times, position=position, force=force, u_center=u_center,
                           h_center=h_center, contact_radius=radius, contact_threshold=threshold,
                           attrs=attrs, **profile)


def simulate_adhesive_route(problem: ContactProblem, drive: SeparationHistory, *, t_end, t_eval,
                       stepper, dt, tol, max_step, profiles, initial_state, contact_threshold,
                       output_kinks, accuracy) -> xr.Dataset:
    """Check simulate's options for an attractive law and pass them to :func:`simulate_adhesive`.

    The arguments are :func:`~viscoforce.solvers.simulate.simulate`'s.
    """
    refused = [name for name, value in (("dt", dt), ("initial_state", initial_state),
                                         ("accuracy", accuracy)) if value is not None]
    if refused:
        raise ParameterError(
            f"{', '.join(refused)} not supported with an adhesive (Lennard-Jones) law: its march "
            "is adaptive (it must shrink its step through the jumps) and starts from the relaxed "
            "state")
    if stepper == "auto":
        stepper = DEFAULT_METHOD
    if not (isinstance(stepper, str) and stepper in METHODS and METHODS[stepper].adaptive):
        raise ParameterError(
            f"stepper must be an adaptive stepper ('exponential' or 'exponential-euler') or "
            f"'auto' with an adhesive (Lennard-Jones) law, got {stepper!r}: a fixed step "
            "cannot resolve a jump-in or jump-out")
    t_end = require_positive("t_end", t_end)
    t_eval = require_increasing("t_eval", t_eval)
    if t_eval[0] < 0 or t_eval[-1] > t_end * (1 + 1e-12):
        raise ParameterError(f"t_eval must lie in [0, t_end = {t_end:g} s]")
    if output_kinks:
        kinks = np.asarray(drive.breakpoints(), dtype=float)
        t_eval = np.union1d(t_eval, kinks[(kinks >= 0) & (kinks <= t_end)])
    return simulate_adhesive(problem, drive, t_end=t_end, t_eval=t_eval, tol=tol,
                             max_step=max_step, contact_threshold=contact_threshold,
                             method=stepper, profiles=profiles)


@dataclass(frozen=True)
class LoopSummary:
    """What one adhesive trajectory measured (:func:`loop_summary`).

    Attributes
    ----------
    jumps : tuple of Jump
        Every jump event, in time order.
    pull_off : float
        −min F [N] over the trajectory (0 if the force never becomes tensile).
    pull_off_time, pull_off_position : float
        Where the minimum is reached [s], [m].
    hysteresis_energy : float
        −∮F dh0 [J] by the trapezoidal rule over every accepted step.
    quadrature_error : float
        |trapezoid over every step − over every other step| / 3 [J] (Richardson).
    effective_work_of_adhesion : float
        pull-off/(1.5πR) [J/m²] (JKR's relation).
    """

    jumps: tuple[Jump, ...]
    pull_off: float
    pull_off_time: float
    pull_off_position: float
    hysteresis_energy: float
    quadrature_error: float
    effective_work_of_adhesion: float

    def first(self, kind: str) -> Jump | None:
        """The first jump of ``kind`` ("jump_in" or "jump_out"), or None."""
        return next((j for j in self.jumps if j.kind == kind), None)


def loop_summary(problem: ContactProblem, steps: list[tuple[float, State]],
                 drive: SeparationHistory) -> LoopSummary:
    """Jumps, pull-off and hysteresis energy of the accepted steps ``steps`` [(t, State)]."""
    t = np.array([time for time, _ in steps])
    h0 = np.array([s.position for _, s in steps])
    hc = h0 - np.array([s.u_center for _, s in steps])
    force = np.array([load_with_tail(problem, s.gap) for _, s in steps])
    if not np.all(np.isfinite(force)):
        raise ConvergenceError("internal: a non-finite force on an accepted adhesive step")
    jumps = _find_jumps(t, h0, hc, force, drive, problem.surface_force.decay_length)
    k = int(np.argmin(force))
    pull_off = max(0.0, -_parabolic_minimum(t, force, k))
    energy = -float(np.trapezoid(force, h0))
    coarse = -float(np.trapezoid(force[::2], h0[::2])) if t.size > 4 else energy
    if t.size > 4 and (t.size - 1) % 2:  # the odd last interval of the coarse sum
        coarse -= float(0.5 * (force[-2] + force[-1]) * (h0[-1] - h0[-2]))
    return LoopSummary(tuple(jumps), pull_off, float(t[k]), float(h0[k]), energy,
                       abs(energy - coarse) / 3.0,
                       pull_off / (1.5 * math.pi * problem.sphere.radius))


def _parabolic_minimum(t: FloatArray, force: FloatArray, k: int) -> float:
    """Min F [N] refined by the parabola through the steps k−1, k, k+1.

    The step value itself at an end, a jump or where the parabola opens downwards.
    """
    if k == 0 or k == t.size - 1 or not np.all(np.diff(t[k - 1:k + 2]) > 0):
        return float(force[k])
    coeffs = np.polyfit(t[k - 1:k + 2] - t[k], force[k - 1:k + 2], 2)
    if coeffs[0] <= 0:
        return float(force[k])
    return float(min(force[k], coeffs[2] - coeffs[1] ** 2 / (4.0 * coeffs[0])))


def _find_jumps(t, h0, hc, force, drive, ell) -> list[Jump]:
    """Runs of fast steps (|Δh(0)| > JUMP_RATIO·max(|Δh0|, Δt·v_max)) moving h(0) one way.

    A run's time and position are those of its fastest step (largest |Δh(0)|/max(|Δh0|,
    Δt·v_max), the instant of a glassy jump; near a fold of the relaxed equilibrium the middle
    of the creep transient), its force the force at the run's onset (just before the jump).
    """
    dt = np.diff(t)
    moving = dt > 0
    speed = float(np.max(np.abs(np.diff(h0))[moving] / dt[moving])) if moving.any() else 0.0
    dh = np.diff(hc)
    drive_move = np.maximum(np.abs(np.diff(h0)), dt * speed)
    fast = np.abs(dh) > JUMP_RATIO * drive_move
    rate = np.abs(dh) / np.maximum(drive_move, 1e-300)
    jumps: list[Jump] = []
    i = 0
    while i < dh.size:
        if not fast[i]:
            i += 1
            continue
        sign = np.sign(dh[i])
        j = i
        while j + 1 < dh.size and fast[j + 1] and np.sign(dh[j + 1]) == sign:
            j += 1
        if abs(hc[j + 1] - hc[i]) > JUMP_MIN_TRAVEL * ell:
            kind = "jump_in" if sign < 0 else "jump_out"
            k = i + int(np.argmax(rate[i:j + 1]))
            jumps.append(Jump(kind, float(t[k]), float(h0[k]), float(force[i]), float(t[j + 1]),
                              float(h0[j + 1]), float(force[j + 1])))
        i = j + 1
    return jumps


def summary_attrs(summary: LoopSummary) -> dict[str, float | int]:
    """The summary as flat netCDF-safe attrs (first jump of each kind)."""
    out: dict[str, float | int] = {
        "pull_off": summary.pull_off, "pull_off_time": summary.pull_off_time,
        "pull_off_position": summary.pull_off_position,
        "hysteresis_energy": summary.hysteresis_energy,
        "hysteresis_quadrature_error": summary.quadrature_error,
        "effective_work_of_adhesion": summary.effective_work_of_adhesion,
        "n_jumps": len(summary.jumps)}
    for kind in ("jump_in", "jump_out"):
        jump = summary.first(kind)
        if jump is not None:
            for key, value in jump.as_dict().items():
                out[f"{kind}_{key}"] = value
    return out


def jumps_from_attrs(attrs: dict) -> dict[str, dict[str, float] | float | None]:
    """``{jump_in, jump_out, pull_off}`` of a trajectory's attrs (None where absent), for JSON."""
    out: dict[str, dict[str, float] | float | None] = {}
    for kind in ("jump_in", "jump_out"):
        if f"{kind}_time" in attrs:
            out[kind] = {key: float(attrs[f"{kind}_{key}"]) for key in
                         ("position", "time", "force", "end_time", "end_position", "end_force")}
        else:
            out[kind] = None
    out["pull_off"] = float(attrs["pull_off"]) if "pull_off" in attrs else None
    return out


__all__ = ["Jump", "LoopSummary", "simulate_adhesive", "simulate_adhesive_route", "loop_summary",
           "is_adhesive", "check_adhesive_grid", "glassy_fold_reason", "jumps_from_attrs", "ADHESIVE_TOL"]
