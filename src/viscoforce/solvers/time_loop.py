"""The time loop of :func:`~viscoforce.solvers.simulate.simulate` and its step control.

:func:`_march` lands on every kink and output time, controls the step size of adaptive steppers
(rejecting a step whose Newton fails or whose error estimate exceeds the tolerance) and records
the outputs. Shared by :mod:`~viscoforce.solvers.simulate` and
:mod:`~viscoforce.solvers.adhesive_dynamics` (which passes a ``rescue`` for the instantaneous
glassy jumps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from viscoforce._typing import FloatArray, SeparationHistory
from viscoforce._validation import require_positive
from viscoforce.exceptions import ConvergenceError, GapClosureError, ParameterError, StabilityError
from viscoforce.problem import ContactProblem
from viscoforce.solvers.base import State, TimeStepper

#: Default local error tolerance of adaptive steppers, in decay lengths of the surface force.
DEFAULT_TOL = 1e-5
#: Default fixed step of explicit Euler, as a fraction of τ_min·E_inf/E0 (the limit is 2).
EULER_DEFAULT_FRACTION = 0.1
#: Smallest dt or max_step accepted, as a fraction of t_end.
MIN_STEP_FRACTION = 1e-12


@dataclass(frozen=True)
class _Counters:
    steps: int
    rejected: int
    newton: int
    error_bound: float = 0.0  # max of the decaying sum of local error estimates [m] (fixed steps)


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


def _march(stepper: TimeStepper, drive: SeparationHistory, state: State, t_eval: FloatArray,
           t_end: float, control: _StepControl, bar, *, grid: FloatArray | None = None,
           every_step: list[tuple[float, State]] | None = None, rescue=None
           ) -> tuple[list[tuple[float, State]], _Counters]:
    """The time loop: land on every kink and output, control the step, record the outputs.

    ``grid``: more times to land on (with a fixed control of step t_end: the steps of a given
    grid); ``every_step``: a list that receives (t, state) after every accepted step;
    ``rescue``: ``rescue(state) -> State | None`` called when an adaptive step of length below
    ``rescue.threshold`` [s] is rejected (the adhesive march's instantaneous glassy jump,
    :mod:`viscoforce.solvers.adhesive_dynamics`): a State returned replaces the current one at
    the same time (an accepted zero-length step), None lets the step control go on. The march
    starts at ``state.time``.
    """
    kinks = {float(b) for b in np.asarray(drive.breakpoints(), dtype=float) if 0 < b < t_end}
    extra = [] if grid is None else [grid[(grid > 0) & (grid < t_end)]]
    stops = np.unique(np.concatenate([t_eval, sorted(kinks), [t_end], *extra]))
    outputs = set(t_eval.tolist())
    t, step = float(state.time), control.first_step
    records: list[tuple[float, State]] = [(t, state)] if t in outputs else []
    steps = rejected = newton = 0
    error_bound = error_max = 0.0
    tau_max = float(np.max(stepper.taus)) if stepper.taus.size else math.inf

    def decay(h: float) -> float:
        return math.exp(-h / tau_max)

    try:
        for target in stops[stops > t]:
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
                    jumped = _rescued(rescue, control, state, h)
                    if jumped is not None:
                        state, steps = jumped, steps + 1
                        if every_step is not None:
                            every_step.append((t, state))
                        continue
                    if control.fixed or h < 1e-9 * control.max_step:
                        raise type(exc)(
                            f"step {steps + 1} at t = {t:.6g} s (dt = {h:.3g} s) failed: {exc}",
                            time=t, iterations=exc.iterations,
                            residual_norm=exc.residual_norm) from None
                    step, rejected = 0.25 * h, rejected + 1
                    continue
                newton += outcome.iterations
                if control.fixed:  # errors of the past decay with the creep memory
                    error_bound = error_bound * decay(h) + outcome.error
                    error_max = max(error_max, error_bound)
                else:
                    ratio = outcome.error / control.tol
                    factor = 5.0 if ratio == 0 else 0.9 * ratio ** (-1.0 / (stepper.order + 1))
                    if ratio > 1.0:
                        jumped = _rescued(rescue, control, state, h)
                        if jumped is not None:
                            state, steps = jumped, steps + 1
                            if every_step is not None:
                                every_step.append((t, state))
                            continue
                        step, rejected = h * max(0.2, factor), rejected + 1
                        continue
                    if state.tangent is not None and outcome.state.tangent is None:
                        raise RuntimeError("internal: an accepted step lost its sensitivities "
                                           "(the stepper's tangent_tol is not the march's tol)")
                    step = min(h * min(5.0, max(0.2, factor)), control.max_step)
                state, steps = outcome.state, steps + 1
                t = target if h == remaining else t + h
                if every_step is not None:
                    every_step.append((t, state))
                if bar is not None:
                    bar.update(h)
            if target in outputs:
                records.append((target, state))
            if target in kinks:
                state = state.without_history()
    finally:
        if bar is not None:
            bar.close()
    return records, _Counters(steps, rejected, newton, error_max)


def _rescued(rescue, control: _StepControl, state: State, h: float) -> State | None:
    """The rescue's replacement state when a rejected adaptive step is below its threshold."""
    if rescue is None or control.fixed or h > rescue.threshold:
        return None
    return rescue(state)


def profile_variables(problem: ContactProblem, times: FloatArray, states: list[State],
                      every: int) -> dict[str, FloatArray]:
    """The trajectory's optional profiles: every ``every``-th state's gap, deformation, pressure.

    ``{}`` for ``every`` = 0; else ``profile_time``, ``r``, ``gap``, ``deformation`` and
    ``pressure`` as :func:`~viscoforce.schema.make_trajectory` takes them.
    """
    if not every:
        return {}
    pick = np.arange(0, len(states), every)
    return {"profile_time": np.asarray(times)[pick], "r": problem.grid.r,
            "gap": np.array([states[i].gap for i in pick]),
            "deformation": np.array([states[i].deformation[:-1] for i in pick]),
            "pressure": np.array([states[i].pressure for i in pick])}
