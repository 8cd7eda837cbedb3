"""``contact``: linear-viscoelastic Hertz contact at the operating indentation (deep contact)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np
from scipy.special import gamma

from viscoforce._limits import INDENTATION_RANGE
from viscoforce._validation import require_plausible
from viscoforce.exceptions import ModelValidityError, ParameterError
from viscoforce.fitting import _params as P
from viscoforce.fitting.base import (
    CONTACT_MATERIALS,
    EXPONENT_BOUNDS,
    MAX_MODES,
    MODULUS_BOUNDS,
    FitModel,
    ModelSpec,
    material_layout,
    material_names,
    moduli_names,
    need,
    tau_names,
)
from viscoforce.fitting.base import REFERENCE_FREQUENCY as DEFAULT_REFERENCE_FREQUENCY
from viscoforce.fitting.guesses import (
    SpectrumFeatures,
    material_guess,
    omega_window,
)
from viscoforce.fitting.models._inputs import (
    DEBYE_LENGTH,
    DRAG,
    INDENTATION,
    NEWTONIAN,
    RADIUS,
    REFERENCE_FREQUENCY,
    SAMPLE_BASE,
    SAMPLE_HEIGHT,
    TIP,
    material_input,
)
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.spectrum_models import (
    _expand_one_mode,
    _viscosity_guess,
    contact_tip,
    structural_guess,
)


def parameters(modes: int, material: str | None) -> list[str]:
    """The material's parameters (sls and prony as ``exact``; ``mu`` where it may be fitted)."""
    if material == "power-law":
        return ["E0", "C1", "m", "mu"]
    if material == "structural":
        return ["E_ref", "alpha", "mu"]
    return material_names(modes)


def _contact_model(spec: ModelSpec) -> FitModel:
    (depth,) = need(spec, "indentation")
    tip = contact_tip(spec.fixed.get("radius"), spec.fixed.get("tip"))
    drag = float(spec.fixed.get("drag") or 0.0)
    kind = spec.fixed.get("material", "sls")
    newtonian = bool(spec.fixed.get("newtonian") or False)
    f_ref = float(spec.fixed.get("reference_frequency") or DEFAULT_REFERENCE_FREQUENCY)
    if kind not in CONTACT_MATERIALS:
        raise ParameterError(f"material must be one of {', '.join(CONTACT_MATERIALS)}, "
                             f"got {kind!r}")
    if spec.fixed.get("reference_frequency") is not None and kind != "structural":
        raise ParameterError(f"reference_frequency is the f_ref of material 'structural'; "
                             f"material {kind!r} has none")
    if newtonian and kind != "power-law":
        raise ParameterError(f"newtonian=True adds a viscosity to material 'power-law'; "
                             f"material {kind!r} has {'one' if kind == 'structural' else 'none'}")
    if not depth > 0:
        raise ModelValidityError(
            f"the contact model needs a positive operating indentation, got {depth!r} m: this "
            "spectrum is pre-contact (use --model svda or exact), or give --indentation D0")
    # a positive but subnormal δ0 makes S(δ0) underflow to 0: no modulus to fit
    depth = require_plausible("indentation", depth, INDENTATION_RANGE, "m",
                              why="the operating indentation of the contact model")
    root = float(tip.contact_stiffness_factor(depth))  # S(δ0) = (dF/dδ)/E: √(Rδ0) for Hertz
    bottom = _bottom_effect(tip, depth, spec.fixed)
    root *= bottom
    modes = spec.modes if kind == "prony" else 1
    moduli = _contact_modulus_function(kind, modes, newtonian, f_ref)

    def function(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        return root * moduli(omega, v) + 1j * omega * drag

    def guesser(k: np.ndarray, omega: np.ndarray) -> dict[str, float]:
        modulus = (k - 1j * omega * drag) / root
        return _contact_guess(kind, modes, newtonian, f_ref, modulus, omega)

    window = omega_window if kind in ("sls", "prony") else None
    fixed = {**spec.fixed, "reference_frequency": f_ref} if kind == "structural" else dict(
        spec.fixed)
    fixed["tip"] = tip
    if spec.fixed.get("sample_height") is not None:
        fixed["bottom_effect_factor"] = bottom
    return FitModel(ModelSpec(spec.name, modes, fixed), function,
                    _contact_layout(kind, modes, newtonian), "omega", guesser, window)


def _bottom_effect(tip, depth: float, fixed: Mapping[str, object]) -> float:
    """(dF/dδ) on the sample's layer over that of a half-space at δ0 (1 without a height).

    :func:`viscoforce.physics.bottom_effect.stiffness_factor` for an incompressible layer
    (ν = 0.5, the series' own) bonded to or sliding on its support.
    """
    height = fixed.get("sample_height")
    if height is None:
        return 1.0
    from viscoforce.physics.bottom_effect import stiffness_factor

    return float(stiffness_factor(tip, depth, float(height),
                                  bonded=fixed.get("sample_base", "bonded") == "bonded"))


def _contact_modulus_function(kind: str, modes: int, newtonian: bool, f_ref: float
                              ) -> Callable[[np.ndarray, Mapping[str, float]], np.ndarray]:
    """E*(ω) [Pa] of a contact material from its SPEC values (the paper's E)."""
    from viscoforce.closed_form import (
        power_law_complex_modulus,
        prony_compliance_core,
        structural_complex_modulus,
    )

    if kind == "structural":
        return lambda omega, v: structural_complex_modulus(omega, v["E_ref"], v["alpha"],
                                                           v["mu"], f_ref)
    if kind == "power-law":
        return lambda omega, v: power_law_complex_modulus(
            omega, v["E0"], v["C1"], v["m"], v["mu"] if newtonian else 0.0)

    moduli, taus = moduli_names(modes), tau_names(modes)

    def prony(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        # the fit loop's values are ordered and positive by the layout: no material object
        # (its validation costs more than the closed form), C* = 1/E0 + Σ ΔJ_i/(1 + iωτ_i)
        full = _expand_one_mode(v, modes) if modes > 1 and "tau" in v else v
        e = np.array([full[n] for n in moduli])
        tau = np.array([full[n] for n in taus])
        compliance = prony_compliance_core(np.asarray(omega, dtype=float), 1.0 / e[0],
                                           1.0 / e[1:] - 1.0 / e[:-1], tau)
        return 1.0 / compliance

    return prony


def _contact_layout(kind: str, modes: int, newtonian: bool) -> list[P.Item]:
    if kind == "structural":
        return [P.Chain(("E_ref",), MODULUS_BOUNDS), P.Bounded("alpha", *EXPONENT_BOUNDS),
                P.Chain(("mu",))]
    if kind == "power-law":
        return [P.Chain(("E0",)), P.Chain(("C1",)), P.Bounded("m", *EXPONENT_BOUNDS),
                *([P.Chain(("mu",))] if newtonian else [])]
    return material_layout(modes)


def _contact_guess(kind: str, modes: int, newtonian: bool, f_ref: float, modulus: np.ndarray,
                   omega: np.ndarray) -> dict[str, float]:
    """A start for a contact material from E*(ω) = (k* − iωB)/√(Rδ0) alone."""
    feats = SpectrumFeatures.of(modulus, omega)
    if kind == "structural":
        return structural_guess(modulus, omega, f_ref)
    if kind == "power-law":  # |E| falls like ω^−m … rises like ω^m: slope of log|E|
        slope = np.polyfit(np.log(omega), np.log(np.abs(modulus)), 1)[0]
        m = min(max(float(slope), 0.05), 0.95)
        c1 = 1.0 / (feats.k_low * gamma(m + 1)) * feats.omega_low ** m
        out = {"E0": 2.0 * feats.k_high, "C1": c1, "m": m}
        if newtonian:
            out["mu"] = _viscosity_guess(modulus, omega)
        return out
    e_inf, e0 = feats.k_low, max(feats.k_high, 1.05 * feats.k_low)
    return material_guess(e0, e_inf, feats.sls_tau(), modes, omega_window(omega))


ENTRY = register(ModelEntry(
    name="contact", data="spectrum",
    summary="k* = E(omega) sqrt(R delta0) + i omega B: Hertz contact of a viscoelastic material",
    build=_contact_model,
    inputs=(RADIUS, TIP, INDENTATION, DRAG, material_input(CONTACT_MATERIALS), DEBYE_LENGTH,
            NEWTONIAN, REFERENCE_FREQUENCY, SAMPLE_HEIGHT, SAMPLE_BASE),
    parameters=parameters, max_modes=MAX_MODES, materials=CONTACT_MATERIALS,
    validity="not estimated: Hertz contact's bias needs the surface force's decay length "
             "(debye_length, --debye-length)"))
