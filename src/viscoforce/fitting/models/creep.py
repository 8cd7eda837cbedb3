"""``creep``: the tip position on a constant-force pause, z_inf + sum dz_i exp(-t/tau_i)."""

from __future__ import annotations

from viscoforce.fitting.base import (
    MAX_MODES,
    FitModel,
    ModelSpec,
)
from viscoforce.fitting.curve_models import (
    _exponential_model,
)
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.segments import creep_data


def parameters(modes: int, material: str | None = None) -> list[str]:
    """z_inf, dz_1 ... dz_n, tau_1 ... tau_n (creep times)."""
    return ["z_inf", *(f"dz_{i}" for i in range(1, modes + 1)),
            *(f"tau_{i}" for i in range(1, modes + 1))]


def _creep_model(spec: ModelSpec) -> FitModel:
    return _exponential_model(spec, "z_inf", "dz")


ENTRY = register(ModelEntry(
    name="creep", data="curve",
    summary="creep of the tip position on a constant-force pause: a sum of exponentials",
    build=_creep_model, parameters=parameters, max_modes=MAX_MODES, cut=creep_data,
    validity="phenomenological sum of exponentials of the tip position: its times are the creep "
             "compliance's exactly for a flat punch, to first order in dz/indentation for a "
             "sphere, paraboloid, cone or pyramid",
    autocorrelated=True))
