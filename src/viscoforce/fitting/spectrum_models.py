"""The spectrum models of the SPEC table: svda, exact, contact (with its materials) and prony.

Each builder takes a :class:`~viscoforce.fitting.base.ModelSpec` and returns a
:class:`~viscoforce.fitting.base.FitModel` of k*(ω) [N/m]; build them with
:func:`viscoforce.fitting.models.make_model`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from scipy.special import gamma

from viscoforce._limits import INDENTATION_RANGE
from viscoforce._validation import require_plausible
from viscoforce.exceptions import ModelValidityError, ParameterError
from viscoforce.fitting import _params as P
from viscoforce.fitting.base import (
    CONTACT_MATERIALS,
    EXPONENT_BOUNDS,
    MODULUS_BOUNDS,
    REFERENCE_FREQUENCY,
    FitModel,
    ModelSpec,
    material_from,
    material_layout,
    moduli_names,
    need,
    tau_names,
)
from viscoforce.fitting.guesses import (
    SpectrumFeatures,
    geometric,
    material_guess,
    moduli_from_levels,
    omega_window,
    spread,
)
from viscoforce.physics.materials import ViscoelasticMaterial
from viscoforce.problem import ContactProblem


def _position_choice(spec: ModelSpec) -> tuple[float | None, float | None]:
    position, mean_force = spec.fixed.get("position"), spec.fixed.get("mean_force")
    if (position is None) == (mean_force is None):
        raise ParameterError(
            f"model {spec.name!r} needs the mean position: give h0 (--h0) or the mean force "
            "(--mean-force, the static E_inf load of the setpoint), not "
            + ("both" if position is not None else "neither"))
    return position, mean_force


def svda_position(mean_force: float, E_inf: float, radius: float, P: float,  # noqa: N803
                  debye_length: float) -> float:
    """h̄0 [m] whose static SVDA (E_inf) load is ``mean_force`` [N] (explicit for p = P e^{−κh}).

    The Derjaguin load F = (2πRP/κ) e^{−κg} gives the centre gap g, and the static Eq. 18
    u0 = −√(8πR/κ)(P/E_inf) e^{−κg} the deformation: h̄0 = g + u0.
    """
    kappa = 1.0 / debye_length
    scale = 2.0 * math.pi * radius * P / kappa
    if not mean_force > 0:
        raise ParameterError(f"mean_force must be > 0 N for the svda model, got {mean_force!r}")
    gap = -math.log(mean_force / scale) / kappa
    u0 = -math.sqrt(8.0 * math.pi * radius / kappa) * (P / E_inf) * math.exp(-kappa * gap)
    return gap + u0


def svda_moduli_from_levels(k_relaxed: float, k_glassy: float, radius: float, P: float,  # noqa: N803
                            debye_length: float, *, position: float | None = None,
                            mean_force: float | None = None) -> tuple[float, float]:
    """E_inf and E0 [Pa] whose SVDA stiffness is ``k_relaxed`` at ω = 0 and ``k_glassy`` as ω → ∞.

    The closed forms of :func:`viscoforce.svda.svda_complex_stiffness` inverted: k*(0) =
    F̄κ/(1 + s) and k*(∞) = F̄κ/(1 + c), with s = −κu0 = W0(z) the relaxed deformation in decay
    lengths, c = s E_inf/E0 and the centre gap g = h̄0 + s/κ. At a fixed ``position`` F̄κ =
    B e^{−s}, B = 2πRP e^{−κh̄0} (the rigid stiffness), so (1 + s) e^{1 + s} = e B/k*(0); at a
    fixed ``mean_force`` 1 + s = F̄κ/k*(0). Then E_inf = √(8πRκ) P e^{−κg}/s (Eq. 18) and
    E0 = s E_inf/c, c = F̄κ/k*(∞) − 1.

    A level at or above the rigid stiffness has no soft solution: that modulus is the top of the
    guess window, as are moduli beyond it; E0 is at least 1.05 E_inf. Both lie in
    [10 Pa, 1e12 Pa] (a decade inside :data:`~viscoforce.fitting.base.MODULUS_BOUNDS`). Used for
    the svda model's starting values (no model evaluation, where a secant search took ~16).
    """
    from viscoforce.svda import lambert_w_of_exp

    lo, hi = MODULUS_BOUNDS[0] * 10, MODULUS_BOUNDS[1] / 10
    kappa = 1.0 / debye_length
    scale = 2.0 * math.pi * radius * P  # F̄κ = scale e^{−κg}
    if position is not None:
        log_arg = 1.0 + math.log(scale) - kappa * position - math.log(k_relaxed)
        s = float(lambert_w_of_exp(np.array([max(log_arg, 1.0)]))[0]) - 1.0
        force_kappa = scale * math.exp(-kappa * position - s)
    else:
        force_kappa = mean_force * kappa
        s = max(force_kappa / k_relaxed - 1.0, 0.0)
    if not s > 0.0:
        return hi, hi
    # E_inf s = √(8πRκ) P e^{−κg} = √(8πRκ) F̄κ/(2πR) (the gap's exponential from F̄κ)
    e_inf = math.sqrt(8.0 * math.pi * radius * kappa) * force_kappa / (2.0 * math.pi * radius) / s
    e_inf = min(max(e_inf, lo), hi)
    c = force_kappa / k_glassy - 1.0
    e0 = s * e_inf / c if c > 0.0 else hi
    return e_inf, max(min(max(e0, lo), hi), 1.05 * e_inf)


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


def check_svda_precontact(position: float, E_inf: float, radius: float, P: float,  # noqa: N803
                          debye_length: float) -> None:
    """Raise ModelValidityError if the SVDA mean state is in contact (centre gap < 1/κ).

    The inputs are the model's, checked when it was built (the kernel checks none).
    """
    from viscoforce.svda import svda_deformation_kernel

    u0 = svda_deformation_kernel(position, E_inf, radius, P, 1.0 / debye_length)
    gap = position - u0
    if gap < debye_length:
        raise ModelValidityError(
            f"the svda model describes only pre-contact spectra: at h0 = {position:.3g} m with "
            f"E_inf = {E_inf:.3g} Pa the centre gap would be {gap:.3g} m < the contact threshold "
            f"1/kappa = {debye_length:.3g} m; use --model exact (any position) or contact")


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


def _expand_one_mode(v: Mapping[str, float], modes: int) -> dict[str, float]:
    """An n-mode parameter set equivalent to the one-mode ``v`` (all modes at ``tau``)."""
    moduli = geometric(v["E0"], v["E_inf"], modes)
    out = dict(zip(moduli_names(modes), moduli, strict=True))
    out.update({n: v["tau"] * (1 + 1e-9 * i) for i, n in enumerate(tau_names(modes))})
    return out


def exact_stiffness(problem: ContactProblem, position: float | None, mean_force: float | None,
                    material: ViscoelasticMaterial, omega: np.ndarray) -> np.ndarray:
    """Exact small-amplitude k*(ω) [N/m] of ``material`` at h̄0 = ``position`` or at the load."""
    from viscoforce.experiments.linear_response import linearized_state

    e_inf = material.relaxed_modulus
    state = (linearized_state(problem, position, e_inf) if position is not None
             else linearized_state(problem, None, e_inf, load=mean_force))
    return state.stiffness(2.0 * np.asarray(material.complex_compliance(omega), dtype=complex))


def _contact_model(spec: ModelSpec) -> FitModel:
    (depth,) = need(spec, "indentation")
    tip = contact_tip(spec.fixed.get("radius"), spec.fixed.get("tip"))
    drag = float(spec.fixed.get("drag") or 0.0)
    kind = spec.fixed.get("material", "sls")
    newtonian = bool(spec.fixed.get("newtonian") or False)
    f_ref = float(spec.fixed.get("reference_frequency") or REFERENCE_FREQUENCY)
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
    return FitModel(ModelSpec(spec.name, modes, fixed), function,
                    _contact_layout(kind, modes, newtonian), "omega", guesser, window)


def contact_tip(radius: float | None, tip: Any = None):
    """The tip of the contact model: ``tip``, or the paper's sphere of ``radius``.

    ``tip`` is a :class:`viscoforce.physics.tips.Tip` or its CLI text; ``radius`` stands for the
    paper's sphere (paraboloidal profile h0 + r²/2R: Hertz).

    Raises
    ------
    ParameterError
        Neither or both given.
    """
    from viscoforce.physics.tips import Paraboloid, tip_from

    if (radius is None) == (tip is None):
        raise ParameterError(
            "the contact model needs the tip: give tip= (--tip sphere:R | paraboloid:R | "
            "cone:ANGLE | pyramid:ANGLE | flat:RADIUS) or radius= (--R, the paper's sphere), "
            + ("not both" if radius is not None else "neither was given"))
    return Paraboloid(radius) if tip is None else tip_from(tip)


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


def structural_guess(modulus: np.ndarray, omega: np.ndarray, reference_frequency: float
                     ) -> dict[str, float]:
    """E_ref, alpha, mu of E*(ω) = E_ref (iω/ω_ref)^α + iωμ by linear least squares on a grid of α.

    For fixed α the model is linear in (E_ref, μ); each is solved in closed form on the real and
    imaginary parts, weighted by 1/|E*| (a relative fit), and the α of the smallest residual
    is kept. Negative solutions are clipped to small positive values.
    """
    w = np.asarray(omega, dtype=float)
    e = np.asarray(modulus, dtype=complex)
    scale = 1.0 / np.abs(e)
    target = np.concatenate([e.real * scale, e.imag * scale])
    best: tuple[float, float, float, float] | None = None
    for alpha in np.linspace(0.02, 0.95, 94):
        z = (1j * w / (2.0 * math.pi * reference_frequency)) ** alpha
        design = np.column_stack([np.concatenate([z.real, z.imag]) * np.tile(scale, 2),
                                  np.concatenate([np.zeros_like(w), w]) * np.tile(scale, 2)])
        coef, *_ = np.linalg.lstsq(design, target, rcond=None)
        e_ref, mu = float(coef[0]), float(coef[1])
        if not e_ref > 0:
            continue
        mu = max(mu, 0.0)
        misfit = float(np.sum((design @ np.array([e_ref, mu]) - target) ** 2))
        if best is None or misfit < best[0]:
            best = (misfit, e_ref, float(alpha), mu)
    if best is None:  # no positive power law: start from the magnitude and the mean phase
        alpha = min(max(2.0 * float(np.median(np.angle(e))) / math.pi, 0.05), 0.9)
        return {"E_ref": float(np.median(np.abs(e))), "alpha": alpha,
                "mu": _viscosity_guess(e, w)}
    _, e_ref, alpha, mu = best
    floor = 1e-4 * float(np.max(np.abs(e)) / np.max(w))  # |iωμ| 1e-4 of |E*| at the top
    return {"E_ref": e_ref, "alpha": alpha, "mu": max(mu, floor)}


def _viscosity_guess(modulus: np.ndarray, omega: np.ndarray) -> float:
    """μ from the imaginary part at the highest frequency (a tenth of it), > 0."""
    i = int(np.argmax(omega))
    return max(0.1 * abs(float(modulus[i].imag)), 1e-6 * abs(modulus[i])) / float(omega[i])


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
