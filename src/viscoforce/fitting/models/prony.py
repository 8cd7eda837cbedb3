"""``prony``: the phenomenological complex stiffness k_inf + sum dk_i i omega tau_i/(1 + i omega tau_i)."""

from viscoforce.fitting.base import MAX_MODES
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.spectrum_models import _prony_model


def parameters(modes: int, material: str | None = None) -> list[str]:
    """k_inf, dk_1 ... dk_n, tau_1 ... tau_n."""
    return ["k_inf", *(f"dk_{i}" for i in range(1, modes + 1)),
            *(f"tau_{i}" for i in range(1, modes + 1))]


ENTRY = register(ModelEntry(
    name="prony", data="spectrum",
    summary="phenomenological complex stiffness: a sum of Debye relaxations (no geometry)",
    build=_prony_model, parameters=parameters, max_modes=MAX_MODES,
    validity="phenomenological (no geometry, no surface force): no model error to estimate"))
