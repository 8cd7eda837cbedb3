"""``svda``: the SVDA closed forms, Eqs. 23-26, at the mean position (pre-contact only)."""

from viscoforce.fitting.models._inputs import DEBYE_LENGTH, MEAN_FORCE, POSITION, PRESSURE, RADIUS
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.spectrum_models import _svda_model

ENTRY = register(ModelEntry(
    name="svda", data="spectrum",
    summary="the SVDA closed forms (Eqs. 23-26) at h0: pre-contact spectra only",
    build=_svda_model, inputs=(POSITION, MEAN_FORCE, RADIUS, PRESSURE, DEBYE_LENGTH),
    parameters=lambda modes, material: ["tau", "E0", "E_inf"],
    validity="not estimated"))
