"""``svda``: the SVDA closed forms, Eqs. 23-26, at the mean position (pre-contact only)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from viscoforce.fitting.base import (
    FitModel,
    ModelSpec,
    material_layout,
    need,
)
from viscoforce.fitting.guesses import (
    SpectrumFeatures,
    omega_window,
)
from viscoforce.fitting.models._inputs import DEBYE_LENGTH, MEAN_FORCE, POSITION, PRESSURE, RADIUS
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.spectrum_models import (
    _position_choice,
    check_svda_precontact,
    svda_moduli_from_levels,
    svda_position,
)


def _svda_model(spec: ModelSpec) -> FitModel:
    radius, p_amp, debye = need(spec, "radius", "P", "debye_length")
    position, mean_force = _position_choice(spec)

    def mean_position(v: Mapping[str, float]) -> float:
        if position is not None:
            return float(position)
        return svda_position(mean_force, v["E_inf"], radius, p_amp, debye)

    from viscoforce.closed_form import require_exponential_law
    from viscoforce.svda import svda_stiffness_kernel

    radius, p_amp, kappa = require_exponential_law(radius, p_amp, debye)  # once, not per call

    def function(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        return svda_stiffness_kernel(np.asarray(omega, dtype=float), mean_position(v), v["E0"],
                                     v["E_inf"], v["tau"], radius, p_amp, kappa)

    def guesser(k: np.ndarray, omega: np.ndarray) -> dict[str, float]:
        feats = SpectrumFeatures.of(k, omega)
        e_inf, e0 = svda_moduli_from_levels(feats.k_low, max(feats.k_high, 1.01 * feats.k_low),
                                            radius, p_amp, debye, position=position,
                                            mean_force=mean_force)
        check_svda_precontact(mean_position({"E_inf": e_inf}), e_inf, radius, p_amp, debye)
        return {"E_inf": e_inf, "E0": e0, "tau": feats.sls_tau()}

    model = FitModel(spec, function, material_layout(1), "omega", guesser, omega_window)
    model.mean_position = mean_position  # type: ignore[attr-defined]
    return model


ENTRY = register(ModelEntry(
    name="svda", data="spectrum",
    summary="the SVDA closed forms (Eqs. 23-26) at h0: pre-contact spectra only",
    build=_svda_model, inputs=(POSITION, MEAN_FORCE, RADIUS, PRESSURE, DEBYE_LENGTH),
    parameters=lambda modes, material: ["tau", "E0", "E_inf"],
    validity="not estimated"))
