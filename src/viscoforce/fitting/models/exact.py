"""``exact``: the exact small-amplitude response at any position, an n-mode Prony material."""

from viscoforce.fitting.base import MAX_MODES, material_names
from viscoforce.fitting.models._inputs import MEAN_FORCE, POSITION, PROBLEM
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.spectrum_models import _exact_model

ENTRY = register(ModelEntry(
    name="exact", data="spectrum",
    summary="the exact small-amplitude response (any position, contact included)",
    build=_exact_model, inputs=(POSITION, MEAN_FORCE, PROBLEM), parameters=material_names,
    max_modes=MAX_MODES,
    validity="the exact small-amplitude model: its error is the grid's (~1e-9 on the default "
             "grid) and the finite-amplitude bias of the measurement"))
