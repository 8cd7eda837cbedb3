"""``exact``: the exact small-amplitude response at any position, an n-mode Prony material."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from viscoforce.fitting.base import (
    MAX_MODES,
    FitModel,
    ModelSpec,
    material_from,
    material_layout,
    material_names,
    need,
)
from viscoforce.fitting.guesses import (
    SpectrumFeatures,
    material_guess,
    moduli_from_levels,
    omega_window,
)
from viscoforce.fitting.models._inputs import MEAN_FORCE, POSITION, PROBLEM
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.spectrum_models import (
    _expand_one_mode,
    _position_choice,
    exact_stiffness,
)


def _exact_model(spec: ModelSpec) -> FitModel:
    (problem,) = need(spec, "problem")
    position, mean_force = _position_choice(spec)
    modes = spec.modes

    def function(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        full = dict(v)
        if modes > 1 and "tau" in full:  # the level search passes one-mode names
            full = _expand_one_mode(full, modes)
        return exact_stiffness(problem, position, mean_force, material_from(full, modes), omega)

    def guesser(k: np.ndarray, omega: np.ndarray) -> dict[str, float]:
        feats = SpectrumFeatures.of(k, omega)
        e_inf, e0 = moduli_from_levels(function, feats, problem.material.relaxed_modulus)
        return material_guess(e0, e_inf, feats.sls_tau(), modes, omega_window(omega))

    return FitModel(spec, function, material_layout(modes), "omega", guesser, omega_window)


ENTRY = register(ModelEntry(
    name="exact", data="spectrum",
    summary="the exact small-amplitude response (any position, contact included)",
    build=_exact_model, inputs=(POSITION, MEAN_FORCE, PROBLEM), parameters=material_names,
    max_modes=MAX_MODES,
    validity="the exact small-amplitude model: its error is the grid's (~1e-9 on the default "
             "grid) and the finite-amplitude bias of the measurement"))
