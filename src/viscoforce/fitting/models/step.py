"""``step``: the exact model along a measured or simulated drive (Fig. 1's step)."""

from viscoforce.fitting.curve_models import _step_model
from viscoforce.fitting.models._inputs import POSITION_TRACE, PROBLEM, START, TOLERANCE
from viscoforce.fitting.registry import ModelEntry, register

ENTRY = register(ModelEntry(
    name="step", data="trajectory",
    summary="the exact model's force along the drive of a trajectory (time, position, force)",
    build=_step_model, inputs=(PROBLEM, POSITION_TRACE, TOLERANCE, START),
    parameters=lambda modes, material: ["tau", "E0", "E_inf"],
    validity="the exact model along the measured drive: its error is the stepper's"))
