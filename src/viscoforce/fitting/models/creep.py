"""``creep``: the tip position on a constant-force pause, in one of two forms.

* With a tip (``tip``): Lee–Radok's creep integral of the recorded force,
  z(t) = contact_point + g⁻¹(∫ C(t − s) dF(s)) with g the tip's force shape
  (:mod:`viscoforce.fitting.creep_model`): the material's ``tau``, ``E0``, ``E_inf`` (n modes:
  ``E0``, ``E_1`` … ``E_inf``, ``tau_1`` … ``tau_n``) and ``contact_point``.
* Without one: the phenomenological z_inf + Σ dz_i e^{−t/τ_i} (``z_inf``, ``dz_i``, ``tau_i``),
  whose τ_i are the creep times of C(t) only for a flat punch (module :data:`PHENOMENOLOGICAL`).
"""

from __future__ import annotations

from typing import Any

from viscoforce.exceptions import ParameterError
from viscoforce.fitting._varpro import exponential_model
from viscoforce.fitting.base import (
    MAX_MODES,
    FitModel,
    ModelSpec,
    material_names,
)
from viscoforce.fitting.creep_model import check_history, lee_radok_model
from viscoforce.fitting.curve_models import (
    _exponential_model,
)
from viscoforce.fitting.models._inputs import CONTACT_POINT, CONTACT_WINDOW, TIP
from viscoforce.fitting.registry import Input, ModelEntry, register
from viscoforce.fitting.segments import creep_data

#: What the fit without a tip rests on (its result's ``attrs["validity"]``).
PHENOMENOLOGICAL = (
    "phenomenological sum of exponentials of the tip position (no tip given): its tau_i are "
    "the creep times of C(t) only for a flat punch. For a curved tip the indentation's force "
    "shape follows C(t) (delta^(3/2) for a sphere or paraboloid, delta^2 for a cone or "
    "pyramid), so the exponentials' times are biased: by -1 to -13 % (paraboloid) and -2 to "
    "-19 % (cone) under a force step as measured in issue 37, and the loading ramp and the "
    "controller's overshoot, which this fit ignores, move them further; no modulus is "
    "reported. Give the tip (tip=, --tip) for the Lee-Radok fit of tau, E0 and E_inf")
#: What the fit with a tip rests on.
LEE_RADOK = (
    "Lee-Radok creep integral of the recorded force for the tip's shape: a linear viscoelastic "
    "half-space, a contact area that does not shrink (contact_area_decrease), no adhesion or "
    "surface forces; the contact point and the loading ramp come from the approach above "
    "half the held force")


def parameters(modes: int, material: str | None = None, *, tip: Any = None) -> list[str]:
    """The reported names: without a tip z_inf, dz_1 … dz_n, tau_1 … tau_n (creep times).

    With a tip (``tip`` not None) the material's (``tau``, ``E0``, ``E_inf``; n modes ``E0``,
    ``E_1`` … ``E_inf``, ``tau_1`` … ``tau_n``) and ``contact_point`` (unless it is given).
    """
    if tip is not None:
        return [*material_names(modes), "contact_point"]
    return ["z_inf", *(f"dz_{i}" for i in range(1, modes + 1)),
            *(f"tau_{i}" for i in range(1, modes + 1))]


def _creep_model(spec: ModelSpec) -> FitModel:
    if spec.fixed.get("tip") is not None:
        return lee_radok_model(spec)
    extra = sorted(k for k in ("creep_history", "contact_point", "contact_window")
                   if spec.fixed.get(k) is not None)
    if extra:
        raise ParameterError(f"model 'creep' takes {', '.join(extra)} with a tip only (the "
                             "Lee-Radok form); give tip= (--tip)")
    # several modes: the search of each fit by variable projection (amplitudes linear; issue
    # 41 item 2); one mode converges from its guess in a few evaluations without it
    base = _exponential_model(spec, "z_inf", "dz")
    return exponential_model(base, "z_inf", "dz") if spec.modes > 1 else base


CREEP_HISTORY = Input("creep_history", check_history, "",
                      "(t, force, tip position) from before contact to the end of the pause "
                      "(CreepData.history; the Lee-Radok form)")

ENTRY = register(ModelEntry(
    name="creep", data="curve",
    summary="creep of the tip position on a constant-force pause: Lee-Radok's integral of the "
            "recorded force for the tip's shape, or (no tip) a sum of exponentials",
    build=_creep_model, inputs=(TIP, CONTACT_POINT, CONTACT_WINDOW, CREEP_HISTORY),
    parameters=parameters, max_modes=MAX_MODES, cut=creep_data,
    validity=f"with a tip: {LEE_RADOK}; without: {PHENOMENOLOGICAL}",
    autocorrelated=True))
