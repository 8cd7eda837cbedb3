"""``relaxation``: the force on a hold, F_inf + sum dF_i exp(-t/tau_i) (force-relaxation times)."""

from __future__ import annotations

from viscoforce.fitting._varpro import exponential_model
from viscoforce.fitting.base import (
    MAX_MODES,
    FitModel,
    ModelSpec,
)
from viscoforce.fitting.curve_models import (
    _exponential_model,
)
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.segments import hold_data


def parameters(modes: int, material: str | None = None) -> list[str]:
    """F_inf, dF_1 ... dF_n, tau_1 ... tau_n."""
    return ["F_inf", *(f"dF_{i}" for i in range(1, modes + 1)),
            *(f"tau_{i}" for i in range(1, modes + 1))]


def _relaxation_model(spec: ModelSpec) -> FitModel:
    # several modes: the search of each fit by variable projection (amplitudes linear; issue
    # 41 item 2); one mode converges from its guess in a few evaluations without it
    base = _exponential_model(spec, "F_inf", "dF")
    return exponential_model(base, "F_inf", "dF") if spec.modes > 1 else base


ENTRY = register(ModelEntry(
    name="relaxation", data="curve",
    summary="force relaxation on a hold segment: a sum of exponentials",
    build=_relaxation_model, parameters=parameters, max_modes=MAX_MODES, cut=hold_data,
    validity="phenomenological sum of exponentials: no model error to estimate",
    autocorrelated=True))
