"""``step``: the exact model along a measured or simulated drive (Fig. 1's step)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from viscoforce.fitting.base import (
    FitModel,
    ModelSpec,
    material_layout,
    need,
)
from viscoforce.fitting.curve_models import (
    StepResponse,
    corners,
)
from viscoforce.fitting.guesses import solve_modulus, time_window
from viscoforce.fitting.models._inputs import POSITION_TRACE, PROBLEM, START, TOLERANCE
from viscoforce.fitting.registry import ModelEntry, register


def _step_model(spec: ModelSpec) -> FitModel:
    (problem, position_trace) = need(spec, "problem", "position_trace")
    from viscoforce.experiments.drives import MeasuredTrace

    trace_t, trace_h = (np.asarray(a, dtype=float) for a in position_trace)
    response = StepResponse(problem, MeasuredTrace(*corners(trace_t, trace_h)),
                            tol=spec.fixed.get("tol"))

    def guesser(f: np.ndarray, t: np.ndarray) -> dict[str, float]:
        start = spec.fixed.get("start")
        if start is not None:
            return dict(start)
        from viscoforce.solvers.static import equilibrium_gap

        f = np.asarray(f, dtype=float)
        i_peak = int(np.argmax(np.abs(f - f[0])))
        end = float(np.interp(t[-1], trace_t, trace_h))
        peak_position = float(np.interp(t[i_peak], trace_t, trace_h))

        def load(position: float) -> Callable[[float], float]:
            return lambda e: abs(float(problem.load(problem.pressure(
                equilibrium_gap(problem, position, e).gap))))

        e_inf = solve_modulus(load(end), max(abs(float(f[-1])), 1e-15), 1e9)
        e0 = solve_modulus(load(peak_position), max(abs(float(f[i_peak])), 1e-15), 2 * e_inf)
        tail = np.abs(f[i_peak:] - f[-1])
        below = np.flatnonzero(tail < tail[0] / math.e)
        tau = float(t[i_peak + below[0]] - t[i_peak]) if below.size else float(np.ptp(t)) / 5
        return {"E_inf": e_inf, "E0": max(e0, 1.05 * e_inf), "tau": max(tau, 1e-9)}

    model = FitModel(spec, response.force, material_layout(1), "t", guesser, time_window)
    model.response = response  # type: ignore[attr-defined]
    return model


ENTRY = register(ModelEntry(
    name="step", data="trajectory",
    summary="the exact model's force along the drive of a trajectory (time, position, force)",
    build=_step_model, inputs=(PROBLEM, POSITION_TRACE, TOLERANCE, START),
    parameters=lambda modes, material: ["tau", "E0", "E_inf"],
    validity="the exact model along the measured drive: its error is the stepper's"))
