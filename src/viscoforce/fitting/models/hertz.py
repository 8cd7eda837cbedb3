"""``hertz``: the approach of a force curve, elastic contact of the tip's shape, baseline and tilt."""

from viscoforce.fitting.curve_models import _hertz_model
from viscoforce.fitting.models._inputs import CONTACT_WINDOW, TIP
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.segments import approach_data

ENTRY = register(ModelEntry(
    name="hertz", data="curve",
    summary="the approach: contact point, tilted baseline, Hertz/Sneddon law of the tip",
    build=_hertz_model, inputs=(TIP, CONTACT_WINDOW),
    parameters=lambda modes, material: ["E", "contact_point", "baseline", "baseline_slope"],
    cut=approach_data,
    validity="elastic contact of the tip's shape on a half-space (Sneddon/Hertz/Bilodeau): "
             "valid for indentations small against the sample's thickness, with no adhesion; a "
             "viscoelastic sample's E is an effective modulus at the approach speed",
    autocorrelated=True))
