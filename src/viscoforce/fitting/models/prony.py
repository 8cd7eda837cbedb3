"""``prony``: the phenomenological complex stiffness k_inf + sum dk_i i omega tau_i/(1 + i omega tau_i)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from viscoforce.fitting import _params as P
from viscoforce.fitting.base import (
    MAX_MODES,
    FitModel,
    ModelSpec,
)
from viscoforce.fitting.guesses import (
    SpectrumFeatures,
    omega_window,
    spread,
)
from viscoforce.fitting.registry import ModelEntry, register


def parameters(modes: int, material: str | None = None) -> list[str]:
    """k_inf, dk_1 ... dk_n, tau_1 ... tau_n."""
    return ["k_inf", *(f"dk_{i}" for i in range(1, modes + 1)),
            *(f"tau_{i}" for i in range(1, modes + 1))]


def _prony_model(spec: ModelSpec) -> FitModel:
    modes = spec.modes
    dks = [f"dk_{i}" for i in range(1, modes + 1)]
    taus = [f"tau_{i}" for i in range(1, modes + 1)]

    def function(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        k = np.full(np.shape(omega), v["k_inf"], dtype=complex)
        for dk, tau in zip(dks, taus, strict=True):
            x = 1j * omega * v[tau]
            k += v[dk] * x / (1.0 + x)
        return k

    def guesser(k: np.ndarray, omega: np.ndarray) -> dict[str, float]:
        feats = SpectrumFeatures.of(k, omega)
        k_inf = feats.k_low
        total = max(feats.k_high - feats.k_low, 0.05 * feats.k_low)
        tau = 1.0 / (feats.omega_peak * math.sqrt(max(feats.k_high / feats.k_low, 1.0001)))
        out = {"k_inf": k_inf, **{dk: total / modes for dk in dks}}
        out.update(zip(taus, spread(tau, modes, omega_window(omega)), strict=True))
        return out

    layout: list[P.Item] = [P.Chain(("k_inf",)), *(P.Chain((dk,)) for dk in dks),
                            P.Chain(tuple(taus))]
    return FitModel(spec, function, layout, "omega", guesser, omega_window)


ENTRY = register(ModelEntry(
    name="prony", data="spectrum",
    summary="phenomenological complex stiffness: a sum of Debye relaxations (no geometry)",
    build=_prony_model, parameters=parameters, max_modes=MAX_MODES,
    validity="phenomenological (no geometry, no surface force): no model error to estimate"))
