"""The one time loop: simulate a contact problem along any drive (paper Eqs. 3–12).

:func:`simulate` starts from the static E_inf equilibrium at the drive's initial position (or a given
state), advances a :class:`~viscoforce.solvers.base.TimeStepper` over the drive, lands exactly on
every drive kink and output time, controls the step size for adaptive steppers, and returns an
``xarray.Dataset`` over time.
"""

from __future__ import annotations

import sys
import warnings
from dataclasses import dataclass

import numpy as np
import xarray as xr

from viscoforce._limits import MAX_MEMORY_BYTES, MAX_SAMPLES, MAX_STEPS, check_effort
from viscoforce._typing import FloatArray, SeparationHistory
from viscoforce._validation import (
    describe_value,
    require_increasing,
    require_instance,
    require_int,
    require_positive,
)
from viscoforce.choice import DEFAULT_ACCURACY, choose_simulation
from viscoforce.exceptions import (
    AccuracyWarning,
    ParameterError,
)
from viscoforce.problem import ContactProblem, check_half_space, contact_radius
from viscoforce.schema import make_trajectory
from viscoforce.solvers.adhesive_dynamics import is_adhesive, simulate_adhesive_route
from viscoforce.solvers.base import State, TimeStepper
from viscoforce.solvers.steppers import DEFAULT_METHOD, METHODS
from viscoforce.solvers.time_loop import (
    DEFAULT_TOL,
    EULER_DEFAULT_FRACTION,
    MIN_STEP_FRACTION,
    _Counters,
    _march,
    _step_control,
    _StepControl,
    profile_variables,
)

#: Default output samples when ``t_eval`` is not given.
DEFAULT_OUTPUTS = 801
def _resolve_stepper(stepper: str | type[TimeStepper]) -> type[TimeStepper]:
    if isinstance(stepper, str):
        if stepper not in METHODS:
            raise ParameterError(
                f"stepper must be one of {sorted(METHODS)} or a TimeStepper subclass, got {stepper!r}")
        return METHODS[stepper]
    if isinstance(stepper, type) and issubclass(stepper, TimeStepper):
        return stepper
    raise ParameterError(f"stepper must be a name or a TimeStepper subclass, got {stepper!r}")


def default_end_time(problem: ContactProblem, drive: SeparationHistory) -> float:
    """Drive end plus five times the longest creep time [s]."""
    require_instance("problem", problem, ContactProblem)
    if not isinstance(drive, SeparationHistory):
        raise ParameterError(f"drive must be a drive (e.g. Triangle), got {describe_value(drive)}")
    taus = problem.material.prony().taus
    return float(drive.duration) + 5.0 * (max(taus) if taus else 0.0)


def simulate(problem: ContactProblem, drive: SeparationHistory, *, t_end: float | None = None,
             t_eval: FloatArray | None = None, stepper: str | type[TimeStepper] = DEFAULT_METHOD,
             dt: float | None = None, tol: float | None = None, max_step: float | None = None,
             profiles: int = 0, initial_state: State | None = None,
             contact_threshold: float | None = None, progress: bool | None = None,
             output_kinks: bool = True, accuracy: float | None = None) -> xr.Dataset:
    """Time-dependent viscoelastic response along the drive ``drive``.

    Parameters
    ----------
    problem : ContactProblem
        System, material (any Prony material) and grid; the grid must reach the drive's deepest
        position (``ContactProblem.create(..., deepest_position=drive.extent()[0])``).
    drive : SeparationHistory
        Position h0(t) [m], e.g. :class:`~viscoforce.experiments.drives.Triangle`.
    t_end : float, optional
        End time [s]; default the drive's end plus 5 τ_max.
    t_eval : array_like, optional
        Output times [s] in [0, t_end], increasing; default 801 equally spaced times.
    stepper : str or TimeStepper subclass
        ``"exponential"`` (default: second-order, unconditionally stable, adaptive),
        ``"exponential-euler"`` (first order), ``"euler"`` (the paper's explicit Euler) or
        ``"auto"``: the stepper and ``tol`` of :func:`viscoforce.choice.choose_simulation` for
        ``accuracy`` (its reason in ``attrs["explanation"]``; ``dt`` and ``tol`` not accepted).
    dt : float, optional
        Fixed time step [s] (disables adaptivity). Explicit Euler defaults to
        0.1·τ_min·E_inf/E0.
    tol : float, optional
        Local error tolerance of adaptive steps [m]; default 1e-5 × the force's decay length.
    max_step : float, optional
        Largest adaptive step [s]; default (t_end)/50.
    profiles : int
        Store the profiles gap, deformation and pressure every ``profiles``-th output time
        (0: none).
    initial_state : State, optional
        Start here instead of the static E_inf equilibrium at h0(0).
    contact_threshold : float, optional
        Gap [m] defining contact (default: the force's decay length, 1/κ).
    progress : bool, optional
        Show a progress bar (default: only when stderr is a terminal).
    output_kinks : bool
        Add every drive kink in [0, t_end] (a triangle's turning point, the end of a step's rise,
        every sample of a measured trace) to the output times, so that reported extremes are the
        true extremes (default True; a lock-in that needs exactly ``t_eval`` passes False).
    accuracy : float, optional
        Required relative force error of ``stepper="auto"`` (default 1e-3); only with "auto".

    Returns
    -------
    xarray.Dataset
        ``position``, ``force``, ``u_center``, ``h_center``, ``contact_radius`` over ``time``
        (and profiles over ``profile_time``, ``r``); attrs hold all parameters and counters.

    An attractive (Lennard-Jones) law goes to
    :func:`~viscoforce.solvers.adhesive_dynamics.simulate_adhesive` (adaptive steps through the
    jumps; attrs add the jumps, pull-off and hysteresis energy; ``dt``, ``initial_state`` and
    ``accuracy`` refused there).

    Raises
    ------
    StabilityError
        Explicit Euler with a step above its stability limit (names the step and the fix).
    GapClosureError, ConvergenceError
        The gap went through zero or Newton failed at the smallest step.
    """
    if not isinstance(problem, ContactProblem):
        raise ParameterError(f"problem must be a ContactProblem, got {type(problem).__name__}")
    if not isinstance(drive, SeparationHistory):
        raise ParameterError(
            "drive must be a drive with position(t), velocity(t), duration and breakpoints() "
            f"(e.g. viscoforce.experiments.Triangle), got {type(drive).__name__}")
    for name, flag in (("output_kinks", output_kinks), ("progress", progress)):
        if not (isinstance(flag, bool | np.bool_) or (name == "progress" and flag is None)):
            raise ParameterError(f"{name} must be True or False, got {flag!r}")
    if t_eval is not None:  # before sorting or differencing them (10 M of them took ~1 s)
        check_effort("output times of simulate", int(np.size(t_eval)), MAX_SAMPLES,
                     hint="request fewer output samples")
    if is_adhesive(problem):
        t_end = (default_end_time(problem, drive) if t_end is None
                 else require_positive("t_end", t_end))
        t_eval = np.linspace(0.0, t_end, DEFAULT_OUTPUTS) if t_eval is None else t_eval
        return simulate_adhesive_route(problem, drive, t_end=t_end, t_eval=t_eval, stepper=stepper,
                                  dt=dt, tol=tol, max_step=max_step, profiles=profiles,
                                  initial_state=initial_state,
                                  contact_threshold=contact_threshold,
                                  output_kinks=output_kinks, accuracy=accuracy)
    choice = None
    if isinstance(stepper, str) and stepper == "auto":
        if dt is not None or tol is not None:
            raise ParameterError("stepper='auto' chooses the stepper and tol itself; give "
                                 "stepper='exponential' (or another) to set dt or tol")
        choice = choose_simulation(problem, drive,
                                   accuracy=DEFAULT_ACCURACY if accuracy is None else accuracy)
        stepper, tol = choice.method, choice.options.get("tol")
    elif accuracy is not None:
        raise ParameterError(f"accuracy applies to stepper 'auto' only, not {stepper!r}")
    stepper = _resolve_stepper(stepper)(problem)
    law = problem.surface_force
    t_end = default_end_time(problem, drive) if t_end is None else require_positive("t_end", t_end)
    problem.check_covers(float(drive.extent()[0]))
    t_eval = np.linspace(0.0, t_end, DEFAULT_OUTPUTS) if t_eval is None else t_eval
    t_eval = require_increasing("t_eval", t_eval)
    if t_eval[0] < 0 or t_eval[-1] > t_end * (1 + 1e-12):
        raise ParameterError(f"t_eval must lie in [0, t_end = {t_end:g} s]")
    if output_kinks:
        kinks = np.asarray(drive.breakpoints(), dtype=float)
        t_eval = np.union1d(t_eval, kinks[(kinks >= 0) & (kinks <= t_end)])
    profiles = require_int("profiles", profiles, 0)
    threshold = (law.decay_length if contact_threshold is None
                 else require_positive("contact_threshold", contact_threshold))
    control = _step_control(problem, stepper, t_end, dt, tol, max_step)
    _check_effort(problem, drive, stepper, t_eval, t_end, control, profiles)
    if initial_state is None:
        state = stepper.relaxed_state(0.0, float(drive.position(0.0)))
    else:
        state = _checked_initial_state(problem, stepper, drive, initial_state)
    records, counters = _march(stepper, drive, state, t_eval, t_end, control,
                               _progress(progress, t_end))
    ds = _trajectory_dataset(problem, drive, stepper, records, profiles, threshold, counters,
                             {"dt": control.dt if control.fixed else 0.0,
                              "tol": 0.0 if control.fixed else control.tol,
                              "t_end": t_end, "max_step": control.max_step})
    check_half_space(problem.sphere.radius, ds.u_center.values, ds.contact_radius.values,
                     where=f"along {_describe(drive)}", stacklevel=2)
    if control.fixed:
        _check_fixed_step_error(ds, STEP_ERROR_SAFETY * counters.error_bound / law.decay_length,
                                control.dt)
    if choice is not None:
        ds.attrs.update({"explanation": choice.explanation,
                         "estimated_error": choice.estimated_error, "accuracy": choice.accuracy})
    return ds


#: Estimated relative force error of a fixed-step run above which simulate warns.
STEP_ERROR_WARNING = 1e-2
#: Factor on κ × the decaying sum of local errors: measured on explicit Euler's Fig. 1 step
#: (h0 = 2, 0, −5 nm; E0 = 1e10, 1e11 Pa; dt = 2–20 µs) the unscaled estimate is 0.52–1.6× the
#: true force error at 1–5 % in contact (0.5× only at 41 %) and 1–11× elsewhere; on the Fig. 5
#: loop it is 9–10× (the stiff modes' damped oscillations count as curvature). × 1.5 keeps every
#: measured case above 1 % true error above the 1 % warning.
STEP_ERROR_SAFETY = 1.5


@dataclass(frozen=True)
class ForceResponse:
    """The force along a drive and, optionally, its sensitivities (:func:`simulate_force`).

    Attributes
    ----------
    time : ndarray
        Output times [s].
    force : ndarray
        F(t) [N] at ``time``.
    sensitivity : ndarray or None
        ∂F/∂ρ [N per unit of ρ], shape (time, k), ρ = (c_g, c_1 … c_m, ln τ_1 … ln τ_m) the
        material's Prony data (:class:`~viscoforce.solvers.base.Tangent`); None when not asked.
    steps, rejected, newton : int
        Accepted and rejected time steps, Newton iterations.
    step_time : ndarray
        End times [s] of the accepted steps (the grid ``simulate_force(..., grid=step_time)``
        repeats).
    step_gap : ndarray
        Nodal gaps h [m] at ``step_time``, shape (steps, N).
    step_gap_sensitivity : ndarray or None
        ∂h/∂ρ [m per unit of ρ] at ``step_time``, shape (steps, k, N).
    """

    time: FloatArray
    force: FloatArray
    sensitivity: FloatArray | None
    steps: int
    rejected: int
    newton: int
    step_time: FloatArray
    step_gap: FloatArray
    step_gap_sensitivity: FloatArray | None = None


def simulate_force(problem: ContactProblem, drive: SeparationHistory, *, t_eval: FloatArray,
                   t_end: float | None = None, tol: float | None = None,
                   sensitivities: bool = False,
                   warm_start: tuple[FloatArray, FloatArray] | None = None,
                   grid: FloatArray | None = None) -> ForceResponse:
    """The force of :func:`simulate` (default stepper) at exactly ``t_eval``, without a Dataset.

    The same time loop, steps and checks as ``simulate(problem, drive, t_end=t_end,
    t_eval=t_eval, output_kinks=False)``, so the force is the same to the last bit; what it
    leaves out is the labelled output. ``sensitivities=True`` also integrates the forward
    sensitivities of the state to the material's Prony data along the same steps (one more
    factorisation and k back-substitutions a step), which give the exact Jacobian of the force
    for fits.

    Parameters
    ----------
    problem : ContactProblem
        System, material and grid (covering the drive's deepest position).
    drive : SeparationHistory
        Position h0(t) [m].
    t_eval : array_like
        Output times [s] in [0, t_end], increasing.
    t_end : float, optional
        End time [s]; default the drive's end plus 5 τ_max.
    tol : float, optional
        Local error tolerance of the adaptive steps [m]; default 1e-5 × the force's decay length.
    sensitivities : bool
        Also return ∂F/∂ρ (:attr:`ForceResponse.sensitivity`).
    warm_start : (times, gaps), optional
        Newton starts [m] (shape (len(times), N)) for the steps that end at ``times`` [s] (a fit
        passes the previous evaluation's gaps moved along their sensitivities). They change
        where Newton starts, not what it converges to (the same tolerance).
    grid : array_like, optional
        Step end times [s] to step along instead of choosing steps (e.g. the ``step_time`` of an
        earlier run at nearby parameters: the same discretisation, no rejected steps; the step
        lands on every output and kink as well). No error control: the caller answers for the
        grid's accuracy.

    Returns
    -------
    ForceResponse

    Raises
    ------
    GapClosureError, ConvergenceError
        As :func:`simulate`.
    """
    require_instance("problem", problem, ContactProblem)
    if not isinstance(drive, SeparationHistory):
        raise ParameterError(f"drive must be a drive (e.g. Triangle), got {describe_value(drive)}")
    if not isinstance(sensitivities, bool | np.bool_):
        raise ParameterError(f"sensitivities must be True or False, got {sensitivities!r}")
    stepper = METHODS[DEFAULT_METHOD](problem)
    t_end = default_end_time(problem, drive) if t_end is None else require_positive("t_end", t_end)
    problem.check_covers(float(drive.extent()[0]))
    t_eval = require_increasing("t_eval", t_eval)
    if t_eval[0] < 0 or t_eval[-1] > t_end * (1 + 1e-12):
        raise ParameterError(f"t_eval must lie in [0, t_end = {t_end:g} s]")
    control = _step_control(problem, stepper, t_end, None, tol, None)
    if grid is not None:
        grid = require_increasing("grid", grid)
        control = _StepControl(True, t_end, control.tol, t_end, t_end)
    else:
        stepper.tangent_tol = control.tol  # no sensitivities for the steps _march rejects
    _check_effort(problem, drive, stepper, t_eval, t_end, control, 0)
    if warm_start is not None:
        stepper.gap_guess = _gap_guesses(problem, *warm_start)
    state = stepper.relaxed_state(0.0, float(drive.position(0.0)), tangent=bool(sensitivities))
    steps: list[tuple[float, State]] = []
    records, counters = _march(stepper, drive, state, t_eval, t_end, control, None, grid=grid,
                               every_step=steps)
    states = [s for _, s in records]
    threshold = problem.surface_force.decay_length
    u_center = np.array([s.u_center for s in states])
    radius = [contact_radius(problem.grid, s.gap, s.position - s.u_center, threshold)
              for s in states]
    check_half_space(problem.sphere.radius, u_center, radius, where=f"along {_describe(drive)}",
                     stacklevel=2)
    force = problem.load(np.array([s.pressure for s in states]))
    sensitivity = gap_sensitivity = None
    if sensitivities:
        sensitivity = problem.load(np.array([s.tangent.pressure for s in states]))
        gap_sensitivity = np.array([s.tangent.gap for _, s in steps])
    return ForceResponse(np.array([t for t, _ in records]), force, sensitivity, counters.steps,
                         counters.rejected, counters.newton, np.array([t for t, _ in steps]),
                         np.array([s.gap for _, s in steps]), gap_sensitivity)


def _gap_guesses(problem: ContactProblem, times: FloatArray, gaps: FloatArray):
    """``gap_guess(t)``: the row of ``gaps`` whose time equals t (to 1e-10 of the span), else None."""
    times = require_increasing("warm_start times", times)
    gaps = np.asarray(gaps, dtype=float)
    if gaps.shape != (times.size, problem.grid.size) or not np.all(gaps > 0):
        raise ParameterError(f"warm_start gaps must be positive with shape ({times.size}, "
                             f"{problem.grid.size}), got shape {gaps.shape}")
    span = float(times[-1] - times[0]) or 1.0

    def guess(t: float) -> FloatArray | None:
        i = int(np.searchsorted(times, t))
        for j in (i - 1, i):
            if 0 <= j < times.size and abs(times[j] - t) <= 1e-10 * span:
                return gaps[j]
        return None

    return guess


def _check_fixed_step_error(ds: xr.Dataset, estimate: float, dt: float) -> None:
    """Record the fixed-step error estimate of a run and warn (AccuracyWarning) above 1 %.

    A fixed step has no error control. The estimate is 1.5 κ × the largest running sum of the
    local truncation errors (dt²/2)|u''|, each decaying like the creep memory, e^{−Δt/τ_max}
    (the force's relative sensitivity to the gap is κ); see :data:`STEP_ERROR_SAFETY`.
    """
    ds.attrs["step_error_estimate"] = estimate
    if estimate > STEP_ERROR_WARNING:
        warnings.warn(
            f"{ds.attrs['stepper']} at the fixed step dt = {dt:.3g} s: the estimated force error "
            f"is ~{100 * estimate:.2g} % (from the local truncation errors; above "
            f"{100 * STEP_ERROR_WARNING:g} %); use a smaller dt or the adaptive stepper "
            "'exponential' (or stepper='auto')", AccuracyWarning, stacklevel=3)


def _check_effort(problem: ContactProblem, drive: SeparationHistory, stepper: TimeStepper,
                  t_eval: FloatArray, t_end: float, control: _StepControl, profiles: int) -> None:
    """Refuse a run beyond the effort limits before any step is taken (estimates in the message)."""
    check_effort("output times of simulate", t_eval.size, MAX_SAMPLES,
                 hint="request fewer output samples")
    kinks = int(np.count_nonzero(np.asarray(drive.breakpoints(), dtype=float) < t_end))
    if control.fixed:
        steps = t_end / control.dt
        hint = "raise dt or shorten t_end"
    else:
        min_steps = getattr(drive, "min_steps", None)
        steps = max(t_end / control.max_step, float(min_steps()) if callable(min_steps) else 0.0)
        hint = "shorten the drive (fewer periods) or t_end"
    check_effort("time steps of simulate", steps + kinks + t_eval.size, MAX_STEPS, hint=hint)
    n = problem.grid.size
    per_output = 8.0 * n * (3 + stepper.c_modes.size)  # gap, pressure, deformation + memory
    per_profile = 8.0 * 3 * n if profiles else 0.0
    stored = t_eval.size * per_output + (t_eval.size / max(profiles, 1)) * per_profile
    check_effort("memory of the stored states", stored, MAX_MEMORY_BYTES, unit="bytes",
                 hint="request fewer output samples or profiles")


def _checked_initial_state(problem: ContactProblem, stepper: TimeStepper,
                           drive: SeparationHistory, state: State) -> State:
    """Reject a given start state that does not belong to this problem and drive."""
    if not isinstance(state, State):
        raise ParameterError(f"initial_state must be a State, got {type(state).__name__}")
    shape = (stepper.c_modes.size, problem.grid.size + 1)
    if state.memory.shape != shape or state.gap.shape != (problem.grid.size,):
        raise ParameterError(
            f"initial_state belongs to another grid or material: memory shape "
            f"{state.memory.shape}, expected {shape}")
    if state.time != 0.0:
        raise ParameterError(f"initial_state.time must be 0 (drives start at t = 0), got {state.time!r}")
    start = float(drive.position(0.0))
    if abs(state.position - start) > 1e-15 + 1e-9 * abs(start):
        raise ParameterError(
            f"initial_state.position {state.position!r} m differs from the drive's start {start!r} m")
    return state


def _progress(progress: bool | None, total: float):
    if progress is None:
        progress = sys.stderr.isatty()
    if not progress:
        return None
    from tqdm.auto import tqdm

    return tqdm(total=total, unit="s", desc="simulate", leave=False,
                bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]")


def _trajectory_dataset(problem: ContactProblem, drive: SeparationHistory, stepper: TimeStepper,
                        records: list[tuple[float, State]], profiles: int, threshold: float,
                        counters: _Counters, settings: dict[str, float]) -> xr.Dataset:
    times = np.array([t for t, _ in records])
    states = [s for _, s in records]
    position = np.array([s.position for s in states])
    gaps = np.array([s.gap for s in states])
    u_center = np.array([s.u_center for s in states])
    h_center = position - u_center
    radius = np.array([contact_radius(problem.grid, g, hc, threshold)
                       for g, hc in zip(gaps, h_center, strict=True)])
    profile = profile_variables(problem, times, states, profiles)
    attrs = dict(problem.parameters())
    attrs.update(settings)
    attrs.update({"stepper": stepper.name, "drive": _describe(drive),
                  "contact_threshold": threshold, "steps": counters.steps,
                  "rejected_steps": counters.rejected, "newton_iterations": counters.newton})
    return make_trajectory(times, position=position,
                           force=problem.load(np.array([s.pressure for s in states])),
                           u_center=u_center, h_center=h_center, contact_radius=radius,
                           contact_threshold=threshold, attrs=attrs, **profile)


def _describe(drive: SeparationHistory) -> str:
    describe = getattr(drive, "describe", None)
    return describe() if callable(describe) else type(drive).__name__


__all__ = ["simulate", "simulate_force", "ForceResponse", "default_end_time", "DEFAULT_TOL",
           "EULER_DEFAULT_FRACTION", "MIN_STEP_FRACTION"]
