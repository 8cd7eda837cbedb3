"""The fixed inputs models share, each with its check, unit and flag (:class:`~.registry.Input`).

A model module takes the ones it needs (``POSITION``, ``TIP``, …) or builds its own with
:func:`material_input` (a material family among its own). The checks name the input and its
range (:mod:`viscoforce._limits`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from viscoforce._limits import (
    DRAG_RANGE,
    MEAN_FORCE_RANGE,
    MIN_POSITION_SPAN,
    POSITION_RANGE,
    REFERENCE_FREQUENCY_RANGE,
    SAMPLE_HEIGHT_RANGE,
    SPHERE_RADIUS_RANGE,
    SURFACE_FORCE_LENGTH_RANGE,
    SURFACE_PRESSURE_RANGE,
)
from viscoforce._validation import (
    require_finite,
    require_instance,
    require_nonnegative,
    require_plausible,
    require_positive,
)
from viscoforce.exceptions import ParameterError
from viscoforce.fitting.registry import Input
from viscoforce.problem import ContactProblem


def plausible(first: Callable[[str, Any], float], bounds: tuple[float, float], unit: str
              ) -> Callable[[str, Any], float]:
    """A check: ``first`` (its message for a sign or a non-number), then the plausible range."""
    return lambda name, value: require_plausible(name, first(name, value), bounds, unit)


def require_bool(name: str, value: Any) -> bool:
    """``value`` as a bool (True or False only)."""
    if not isinstance(value, bool | np.bool_):
        raise ParameterError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _as_tip(name: str, value: Any):
    from viscoforce.physics.tips import tip_from

    return tip_from(value)


def _window(name: str, value: Any) -> tuple[float, float]:
    """(low, high) tip positions [m] within POSITION_RANGE, at least MIN_POSITION_SPAN apart."""
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be (low, high) tip positions [m], got {value!r}"
                             ) from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ParameterError(f"{name} must be finite (low, high) with low < high [m], got "
                             f"{value!r}")
    if not POSITION_RANGE[0] <= lo < hi <= POSITION_RANGE[1] or hi - lo < MIN_POSITION_SPAN:
        raise ParameterError(
            f"{name} must lie within the plausible range [{POSITION_RANGE[0]:g}, "
            f"{POSITION_RANGE[1]:g}] m and be at least {MIN_POSITION_SPAN:g} m wide (the fit "
            f"bounds the contact point within it), got {value!r}")
    return lo, hi


def _step_start(name: str, value: Any) -> dict[str, float]:
    """A start of the step model: positive ``E0`` > ``E_inf`` and ``tau`` [SI]."""
    if not isinstance(value, Mapping) or set(value) != {"E0", "E_inf", "tau"}:
        raise ParameterError(f"{name} must map E0, E_inf and tau to values, got {value!r}")
    return {k: require_positive(f"{name}[{k!r}]", v) for k, v in value.items()}


def material_input(families: tuple[str, ...]) -> Input:
    """The ``material`` input of a model whose material families are ``families``."""

    def check(name: str, value: Any) -> str:
        if not isinstance(value, str) or value not in families:
            raise ParameterError(f"{name} must be one of {', '.join(families)}, got {value!r}")
        return value

    return Input("material", check, "", f"material family: {', '.join(families)}", "--material")


POSITION = Input("position", require_finite, "m", "mean position h0 of the drive", "--h0")
MEAN_FORCE = Input("mean_force", plausible(require_positive, MEAN_FORCE_RANGE, "N"), "N",
                   "mean force (the static E_inf load; h0 follows E_inf)", "--mean-force")
RADIUS = Input("radius", plausible(require_positive, SPHERE_RADIUS_RANGE, "m"), "m",
               "sphere radius R", "--R")
PRESSURE = Input("P", plausible(require_positive, SURFACE_PRESSURE_RANGE, "Pa"), "Pa",
                 "double-layer pressure scale", "--P")
DEBYE_LENGTH = Input("debye_length",
                     plausible(require_positive, SURFACE_FORCE_LENGTH_RANGE, "m"), "m",
                     "decay length 1/kappa of the surface force", "--debye-length")
PROBLEM = Input("problem", lambda n, v: require_instance(n, v, ContactProblem), "",
                "the ContactProblem (sphere, surface force, grid) of the exact model")
# the contact model's floor (INDENTATION_RANGE) where it needs the indentation > 0
INDENTATION = Input("indentation", plausible(require_finite, POSITION_RANGE, "m"), "m",
                    "operating indentation delta0", "--indentation")
DRAG = Input("drag", plausible(require_nonnegative, DRAG_RANGE, "N*s/m"), "N s/m",
             "hydrodynamic drag B, subtracted as i omega B (fixed)", "--drag")
TIP = Input("tip", _as_tip, "", "tip shape: a Tip or its text (sphere:R, cone:ANGLE, ...)",
            "--tip")
NEWTONIAN = Input("newtonian", require_bool, "", "fit a Newtonian viscosity mu too",
                  "--newtonian")
REFERENCE_FREQUENCY = Input(
    "reference_frequency", plausible(require_positive, REFERENCE_FREQUENCY_RANGE, "Hz"), "Hz",
    "reference frequency f_ref of E_ref (structural damping)", "--reference-frequency")
CONTACT_WINDOW = Input("contact_window", _window, "m",
                       "(low, high) tip positions where the contact point may lie")
CONTACT_POINT = Input("contact_point", plausible(require_finite, POSITION_RANGE, "m"), "m",
                      "the contact point, fixed (tip position at contact)", "--contact-point")
POSITION_TRACE = Input("position_trace", lambda n, v: v, "",
                       "(t, position) of the measured or simulated drive")
SAMPLE_HEIGHT = Input("sample_height", plausible(require_positive, SAMPLE_HEIGHT_RANGE, "m"), "m",
                      "the sample's thickness on a rigid support (bottom-effect correction)",
                      "--sample-height")


def _base(name: str, value: Any) -> str:
    if value not in ("bonded", "sliding"):
        raise ParameterError(f"{name} must be 'bonded' or 'sliding', got {value!r}")
    return str(value)


SAMPLE_BASE = Input("sample_base", _base, "", "the layer bonded to or sliding on its support",
                    "--sample-base")
FIT_DRAG = Input("fit_drag", require_bool, "", "fit the drag B", "--fit-drag")
TOLERANCE = Input("tol", require_positive, "", "relative tolerance of the step model's stepper")
START = Input("start", _step_start, "", "start values {E0, E_inf, tau} of the step model")
