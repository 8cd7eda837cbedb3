"""``ting``: approach and retract by Ting's hereditary integral for the tip shape."""

from viscoforce.fitting.base import MAX_MODES, material_names
from viscoforce.fitting.models._inputs import (
    CONTACT_POINT,
    CONTACT_WINDOW,
    DRAG,
    FIT_DRAG,
    POSITION_TRACE,
    REFERENCE_FREQUENCY,
    SAMPLE_BASE,
    SAMPLE_HEIGHT,
    TIP,
    material_input,
    require_bool,
)
from viscoforce.fitting.registry import Input, ModelEntry, register
from viscoforce.fitting.ting_model import ting_data, ting_model

#: Material families of the ting model.
MATERIALS = ("sls", "prony", "structural")


def parameters(modes: int, material: str | None) -> list[str]:
    """The material's, then contact_point, baseline, baseline_slope (and drag when fitted)."""
    own = ["E_ref", "alpha", "mu"] if material == "structural" else material_names(modes)
    return [*own, "contact_point", "baseline", "baseline_slope"]


ENTRY = register(ModelEntry(
    name="ting", data="curve",
    summary="approach-retract force curve by Ting's hereditary integral, contact point, drag",
    build=ting_model,
    inputs=(TIP, POSITION_TRACE, material_input(MATERIALS), DRAG, FIT_DRAG, CONTACT_POINT,
            CONTACT_WINDOW, REFERENCE_FREQUENCY,
            Input("newtonian", require_bool, "", "the structural material's Newtonian term "
                  "mu (False: none)", "--no-newtonian"), SAMPLE_HEIGHT, SAMPLE_BASE),
    parameters=parameters, units={"drag": "N s/m"}, max_modes=MAX_MODES, materials=MATERIALS,
    cut=ting_data,
    validity="not estimated", autocorrelated=True))
