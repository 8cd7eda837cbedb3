"""lmfit models of the SPEC's Models table.

svda, exact, contact, prony, relaxation, step, hertz and creep.

Each model is an :class:`lmfit.Model` over plain functions of the project's physics whose
parameters carry the SPEC's exact names (``tau``, ``E0``, ``E_inf``; ``E_1``…, ``tau_1``…;
``k_inf``, ``dk_i``; ``F_inf``, ``dF_i``; ``C1``, ``m``; ``E``, ``contact_point``; ``z_inf``,
``dz_i``). The spectrum models return the complex stiffness k*(ω) = F̂/δ̂ [N/m] (phase = lead of
the force over the indentation); the curve models a force [N] over time (relaxation, step), a
force [N] over the tip position (hertz) or a tip position [m] over time (creep).
:meth:`~viscoforce.fitting.base.FitModel.guess` derives a start from the data alone
(:mod:`viscoforce.fitting.guesses`), with the ordering constraints of
:mod:`viscoforce.fitting._params`.

Build a model with :func:`make_model`; the ``spec`` (name, modes, fixed inputs) is what travels to
dask workers, which rebuild the model there (closures over a problem do not pickle cheaply). The
pieces: :mod:`viscoforce.fitting.base` (:class:`~viscoforce.fitting.base.FitModel`, the tables,
the names), :mod:`viscoforce.fitting.spectrum_models` and :mod:`viscoforce.fitting.curve_models`
(the builders); this module checks the fixed inputs and builds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from viscoforce.exceptions import ParameterError
from viscoforce.fitting.base import (
    CONTACT_MATERIALS,
    MAX_MODES,
    MODAL_MODELS,
    MODEL_NAMES,
    FitModel,
    ModelSpec,
)
from viscoforce.fitting.curve_models import (
    _creep_model,
    _hertz_model,
    _relaxation_model,
    _step_model,
    _ting_model,
)
from viscoforce.fitting.spectrum_models import (
    _contact_model,
    _exact_model,
    _prony_model,
    _svda_model,
)
from viscoforce.problem import ContactProblem

_FIXED: dict[str, tuple[str, ...]] = {
    "svda": ("position", "mean_force", "radius", "P", "debye_length"),
    "exact": ("position", "mean_force", "problem"),
    "contact": ("radius", "tip", "indentation", "drag", "material", "debye_length",
                "newtonian", "reference_frequency"),
    "prony": (), "relaxation": (), "step": ("problem", "position_trace", "tol", "start"),
    "hertz": ("tip", "contact_window"), "creep": (),
    "ting": ("tip", "position_trace", "material", "drag", "fit_drag", "contact_point",
             "contact_window", "reference_frequency", "newtonian")}


def check_fixed(name: str, fixed: Mapping[str, Any]) -> dict[str, Any]:
    """The fixed inputs of model ``name``, validated (None means not given).

    Raises
    ------
    TypeError
        An input the model does not take.
    ParameterError
        A value out of range (the message names it and the range).
    """
    from viscoforce._limits import (
        DRAG_RANGE,
        MEAN_FORCE_RANGE,
        POSITION_RANGE,
        REFERENCE_FREQUENCY_RANGE,
        SPHERE_RADIUS_RANGE,
        SURFACE_FORCE_LENGTH_RANGE,
        SURFACE_PRESSURE_RANGE,
    )
    from viscoforce._validation import (
        require_finite,
        require_instance,
        require_nonnegative,
        require_positive,
    )

    unknown = sorted(set(fixed) - set(_FIXED[name]))
    if unknown:
        raise TypeError(f"model {name!r} takes no input {', '.join(unknown)}; its inputs: "
                        f"{', '.join(_FIXED[name]) or 'none'}")
    checks: dict[str, Callable[[str, Any], Any]] = {
        "position": require_finite,
        "mean_force": _plausible(require_positive, MEAN_FORCE_RANGE, "N"),
        "radius": _plausible(require_positive, SPHERE_RADIUS_RANGE, "m"),
        "P": _plausible(require_positive, SURFACE_PRESSURE_RANGE, "Pa"),
        "debye_length": _plausible(require_positive, SURFACE_FORCE_LENGTH_RANGE, "m"),
        # the contact model's floor (INDENTATION_RANGE) where it needs the indentation > 0
        "indentation": _plausible(require_finite, POSITION_RANGE, "m"),
        "drag": _plausible(require_nonnegative, DRAG_RANGE, "N*s/m"),
        "problem": lambda n, v: require_instance(n, v, ContactProblem),
        "material": lambda n, v: v if v in CONTACT_MATERIALS else _bad_material(v),
        "newtonian": _require_bool,
        "reference_frequency": _plausible(require_positive, REFERENCE_FREQUENCY_RANGE, "Hz"),
        "tip": lambda n, v: _as_tip(v), "contact_window": _window,
        "position_trace": lambda n, v: v, "fit_drag": _require_bool,
        "tol": require_positive, "start": _step_start,
        "contact_point": _plausible(require_finite, POSITION_RANGE, "m")}
    return {k: (None if v is None else checks[k](k, v)) for k, v in fixed.items()}


def _plausible(first: Callable[[str, Any], float], bounds: tuple[float, float], unit: str
               ) -> Callable[[str, Any], float]:
    """A check: ``first`` (its message for a sign or a non-number), then the plausible range."""
    from viscoforce._validation import require_plausible

    return lambda name, value: require_plausible(name, first(name, value), bounds, unit)


def _step_start(name: str, value: Any) -> dict[str, float]:
    """A start of the step model: positive ``E0`` > ``E_inf`` and ``tau`` [SI]."""
    from viscoforce._validation import require_positive

    if not isinstance(value, Mapping) or set(value) != {"E0", "E_inf", "tau"}:
        raise ParameterError(f"{name} must map E0, E_inf and tau to values, got {value!r}")
    return {k: require_positive(f"{name}[{k!r}]", v) for k, v in value.items()}


def _as_tip(value: Any):
    from viscoforce.physics.tips import tip_from

    return tip_from(value)


def _window(name: str, value: Any) -> tuple[float, float]:
    """(low, high) tip positions [m] within POSITION_RANGE, at least MIN_POSITION_SPAN apart."""
    from viscoforce._limits import MIN_POSITION_SPAN, POSITION_RANGE

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


def _require_bool(name: str, value: Any) -> bool:
    if not isinstance(value, bool | np.bool_):
        raise ParameterError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _bad_material(value: Any) -> None:
    raise ParameterError(f"material must be one of {', '.join(CONTACT_MATERIALS)}, "
                         f"got {value!r}")


_BUILDERS: dict[str, Callable[[ModelSpec], FitModel]] = {
    "svda": _svda_model, "exact": _exact_model, "contact": _contact_model,
    "prony": _prony_model, "relaxation": _relaxation_model, "step": _step_model,
    "hertz": _hertz_model, "creep": _creep_model, "ting": _ting_model}


def make_model(name: str, modes: int = 1, **fixed: Any) -> FitModel:
    """The lmfit model ``name`` (one of :data:`~viscoforce.fitting.base.MODEL_NAMES`) with ``modes`` modes.

    Parameters
    ----------
    name : str
        ``svda``, ``exact``, ``contact``, ``prony``, ``relaxation``, ``step``, ``hertz`` or
        ``creep``.
    modes : int
        Relaxation modes (≥ 1; only the models in
        :data:`~viscoforce.fitting.base.MODAL_MODELS` take more than one).
    **fixed
        Fixed inputs in SI: ``position`` or ``mean_force`` (svda, exact); ``radius``, ``P``,
        ``debye_length`` (svda); ``problem`` (exact, step); ``radius``, ``indentation``,
        ``drag``, ``material`` (contact: ``sls``, ``prony``, ``power-law``, ``structural``),
        ``newtonian`` (contact power-law: fit a viscosity ``mu`` too), ``reference_frequency``
        [Hz] (contact structural: f_ref of ``E_ref``, default 1 Hz), ``debye_length`` (contact:
        the validity estimate); ``position_trace`` = (t, h0) (step); ``tip`` (hertz: a
        :class:`~viscoforce.physics.tips.Tip` or its text, required) and ``contact_window`` =
        (low, high) [m] (hertz: where the contact point may lie; default the approach).

    Raises
    ------
    ParameterError
        Unknown model, bad modes, or a missing fixed input (the message names it).
    ModelValidityError
        The model cannot describe the scene (contact at no indentation).
    """
    if not isinstance(name, str) or name not in _BUILDERS:
        raise ParameterError(f"model must be one of {', '.join(MODEL_NAMES)}, got {name!r}")
    if isinstance(modes, bool) or not isinstance(modes, int | np.integer) or not (
            1 <= modes <= MAX_MODES):
        raise ParameterError(f"modes must be an integer in [1, {MAX_MODES}], got {modes!r}")
    fixed = check_fixed(name, fixed)
    if modes > 1 and name not in MODAL_MODELS:
        raise ParameterError(f"model {name!r} has one mode (modes=1), got modes={modes}; "
                             f"models with several: {', '.join(MODAL_MODELS)}")
    if name == "contact" and modes > 1 and fixed.get("material", "sls") != "prony":
        raise ParameterError("contact with modes > 1 needs material='prony' (--material prony)")
    return _BUILDERS[name](ModelSpec(name, int(modes), fixed))
