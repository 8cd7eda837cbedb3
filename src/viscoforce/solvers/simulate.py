"""The one time loop: simulate a contact problem along any drive (paper Eqs. 3–12).

:func:`simulate` starts from the static E_inf equilibrium at the drive's initial position (or a given
state), advances a :class:`~viscoforce.solvers.base.TimeStepper` over the drive, lands exactly on
every drive kink and output time, controls the step size for adaptive steppers, and returns an
``xarray.Dataset`` over time.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np
import xarray as xr

from viscoforce._typing import FloatArray, SeparationHistory
from viscoforce._validation import require_increasing, require_int, require_positive
from viscoforce.exceptions import ConvergenceError, GapClosureError, ParameterError, StabilityError
from viscoforce.problem import ContactProblem, contact_radius
from viscoforce.solvers.base import State, TimeStepper
from viscoforce.solvers.steppers import DEFAULT_METHOD, METHODS

#: Default local error tolerance of adaptive steppers, in decay lengths of the surface force.
DEFAULT_TOL = 1e-5
#: Default output samples when ``t_eval`` is not given.
DEFAULT_OUTPUTS = 801
#: Default fixed step of explicit Euler, as a fraction of τ_min·E_inf/E0 (the limit is 2).
EULER_DEFAULT_FRACTION = 0.1
#: Smallest dt or max_step accepted, as a fraction of t_end.
MIN_STEP_FRACTION = 1e-12


@dataclass(frozen=True)
class _Counters:
    steps: int
    rejected: int
    newton: int


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
    taus = problem.material.prony().taus
    return float(drive.duration) + 5.0 * (max(taus) if taus else 0.0)


def simulate(problem: ContactProblem, drive: SeparationHistory, *, t_end: float | None = None,
             t_eval: FloatArray | None = None, stepper: str | type[TimeStepper] = DEFAULT_METHOD,
             dt: float | None = None, tol: float | None = None, max_step: float | None = None,
             profiles: int = 0, initial_state: State | None = None,
             contact_threshold: float | None = None, progress: bool | None = None,
             output_kinks: bool = True) -> xr.Dataset:
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
        ``"exponential-euler"`` (first order) or ``"euler"`` (the paper's explicit Euler).
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

    Returns
    -------
    xarray.Dataset
        ``position``, ``force``, ``u_center``, ``h_center``, ``contact_radius`` over ``time``
        (and profiles over ``profile_time``, ``r``); attrs hold all parameters and counters.

    Raises
    ------
    StabilityError
        Explicit Euler with a step above its stability limit (names the step and the fix).
    GapClosureError, ConvergenceError
        The gap went through zero or Newton failed at the smallest step.
    """
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
    if initial_state is None:
        state = stepper.relaxed_state(0.0, float(drive.position(0.0)))
    else:
        state = _checked_initial_state(problem, stepper, drive, initial_state)
    records, counters = _march(stepper, drive, state, t_eval, t_end, control,
                               _progress(progress, t_end))
    return _trajectory_dataset(problem, drive, stepper, records, profiles, threshold, counters,
                               {"dt": control.dt if control.fixed else 0.0,
                                "tol": 0.0 if control.fixed else control.tol,
                                "t_end": t_end, "max_step": control.max_step})


@dataclass(frozen=True)
class _StepControl:
    fixed: bool
    dt: float
    tol: float
    max_step: float
    first_step: float


def _step_control(problem: ContactProblem, stepper: TimeStepper, t_end: float, dt: float | None,
                  tol: float | None, max_step: float | None) -> _StepControl:
    """Resolve the step-size settings (fixed dt or adaptive tolerance) with their defaults."""
    tau_min = min(problem.material.prony().taus, default=np.inf)
    fixed = dt is not None or not stepper.adaptive
    if dt is None and not stepper.adaptive:
        ratio = problem.material.relaxed_modulus / problem.material.instantaneous_modulus
        dt = EULER_DEFAULT_FRACTION * tau_min * ratio if np.isfinite(tau_min) else t_end / 1000
    smallest = MIN_STEP_FRACTION * t_end
    if dt is not None:
        dt = require_positive("dt", dt)
        if dt < smallest:
            raise ParameterError(f"dt must be >= {smallest:.3g} s (1e-12 t_end), got {dt!r}")
    tol = DEFAULT_TOL * problem.surface_force.decay_length if tol is None else require_positive(
        "tol", tol)
    max_step = t_end / 50 if max_step is None else require_positive("max_step", max_step)
    if max_step < smallest:
        raise ParameterError(f"max_step must be >= {smallest:.3g} s (1e-12 t_end), got {max_step!r}")
    first = dt if fixed else min(1e-3 * (tau_min if np.isfinite(tau_min) else t_end), max_step)
    return _StepControl(fixed, float(dt or 0.0), tol, max_step, float(first))


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


def _march(stepper: TimeStepper, drive: SeparationHistory, state: State, t_eval: FloatArray,
           t_end: float, control: _StepControl, bar) -> tuple[list[tuple[float, State]], _Counters]:
    """The time loop: land on every kink and output, control the step, record the outputs."""
    kinks = {float(b) for b in np.asarray(drive.breakpoints(), dtype=float) if 0 < b < t_end}
    stops = np.unique(np.concatenate([t_eval, sorted(kinks), [t_end]]))
    outputs = set(t_eval.tolist())
    records: list[tuple[float, State]] = [(0.0, state)] if 0.0 in outputs else []
    t, step = 0.0, control.first_step
    steps = rejected = newton = 0
    try:
        for target in stops[stops > 0]:
            while t < target:
                remaining = target - t
                h = min(step, remaining)
                if remaining - h < 1e-9 * remaining:
                    h = remaining
                elif remaining < 1.2 * h:
                    h = 0.5 * remaining
                if t + h <= t:
                    raise ConvergenceError(
                        f"step size underflow at t = {t:.6g} s (dt = {h:.3g} s): the step control "
                        "cannot meet the tolerance; loosen tol or check the drive", time=t)
                try:
                    outcome = stepper.step(state, drive, h)
                except StabilityError as exc:
                    raise StabilityError(f"step {steps + 1}: {exc}") from None
                except (ConvergenceError, GapClosureError) as exc:
                    if control.fixed or h < 1e-9 * control.max_step:
                        raise type(exc)(
                            f"step {steps + 1} at t = {t:.6g} s (dt = {h:.3g} s) failed: {exc}",
                            time=t, iterations=exc.iterations,
                            residual_norm=exc.residual_norm) from None
                    step, rejected = 0.25 * h, rejected + 1
                    continue
                newton += outcome.iterations
                if not control.fixed:
                    ratio = outcome.error / control.tol
                    factor = 5.0 if ratio == 0 else 0.9 * ratio ** (-1.0 / (stepper.order + 1))
                    if ratio > 1.0:
                        step, rejected = h * max(0.2, factor), rejected + 1
                        continue
                    step = min(h * min(5.0, max(0.2, factor)), control.max_step)
                state, steps = outcome.state, steps + 1
                t = target if h == remaining else t + h
                if bar is not None:
                    bar.update(h)
            if target in outputs:
                records.append((target, state))
            if target in kinks:
                state = state.without_history()
    finally:
        if bar is not None:
            bar.close()
    return records, _Counters(steps, rejected, newton)


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
    force = problem.load(np.array([s.pressure for s in states]))
    u_center = np.array([s.u_center for s in states])
    h_center = position - u_center
    radius = np.array([contact_radius(problem.grid, g, hc, threshold)
                       for g, hc in zip(gaps, h_center, strict=True)])

    def series(values, units, name):
        return xr.DataArray(values, dims="time", attrs={"units": units, "long_name": name})

    data = {
        "position": series(position, "m", "apex position h0"),
        "force": series(force, "N", "load F"),
        "u_center": series(u_center, "m", "central deformation u(0)"),
        "h_center": series(h_center, "m", "central gap h(0)"),
        "contact_radius": series(radius, "m", f"radius where the gap < {threshold:g} m"),
    }
    coords = {"time": xr.DataArray(times, dims="time", attrs={"units": "s", "long_name": "time"})}
    if profiles:
        pick = np.arange(0, len(states), profiles)
        coords["profile_time"] = xr.DataArray(times[pick], dims="profile_time",
                                              attrs={"units": "s", "long_name": "profile time"})
        coords["r"] = xr.DataArray(problem.grid.r, dims="r",
                                   attrs={"units": "m", "long_name": "radial coordinate"})
        dims = ("profile_time", "r")
        data["gap"] = xr.DataArray(gaps[pick], dims=dims,
                                   attrs={"units": "m", "long_name": "local gap h(r, t)"})
        data["deformation"] = xr.DataArray(
            np.array([states[i].deformation[:-1] for i in pick]), dims=dims,
            attrs={"units": "m", "long_name": "deformation u(r, t)"})
        data["pressure"] = xr.DataArray(
            np.array([states[i].pressure for i in pick]), dims=dims,
            attrs={"units": "Pa", "long_name": "pressure p(r, t)"})
    attrs = dict(problem.parameters())
    attrs.update(settings)
    attrs.update({"stepper": stepper.name, "drive": _describe(drive),
                  "contact_threshold": threshold, "steps": counters.steps,
                  "rejected_steps": counters.rejected, "newton_iterations": counters.newton})
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _describe(drive: SeparationHistory) -> str:
    describe = getattr(drive, "describe", None)
    return describe() if callable(describe) else type(drive).__name__


__all__ = ["simulate", "default_end_time", "DEFAULT_TOL"]
