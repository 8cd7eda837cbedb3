"""``contact``: linear-viscoelastic Hertz contact at the operating indentation (deep contact)."""

from viscoforce.fitting.base import CONTACT_MATERIALS, MAX_MODES, material_names
from viscoforce.fitting.models._inputs import (
    DEBYE_LENGTH,
    DRAG,
    INDENTATION,
    NEWTONIAN,
    RADIUS,
    REFERENCE_FREQUENCY,
    TIP,
    material_input,
)
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.spectrum_models import _contact_model


def parameters(modes: int, material: str | None) -> list[str]:
    """The material's parameters (sls and prony as ``exact``; ``mu`` where it may be fitted)."""
    if material == "power-law":
        return ["E0", "C1", "m", "mu"]
    if material == "structural":
        return ["E_ref", "alpha", "mu"]
    return material_names(modes)


ENTRY = register(ModelEntry(
    name="contact", data="spectrum",
    summary="k* = E(omega) sqrt(R delta0) + i omega B: Hertz contact of a viscoelastic material",
    build=_contact_model,
    inputs=(RADIUS, TIP, INDENTATION, DRAG, material_input(CONTACT_MATERIALS), DEBYE_LENGTH,
            NEWTONIAN, REFERENCE_FREQUENCY),
    parameters=parameters, max_modes=MAX_MODES, materials=CONTACT_MATERIALS,
    validity="not estimated: Hertz contact's bias needs the surface force's decay length "
             "(debye_length, --debye-length)"))
