"""What the spectrum models share (the builders live with their models).

The SVDA's position and levels, the exact stiffness, the contact tip and the structural and
viscosity guesses.

The builders themselves live with their models, one module each in
:mod:`viscoforce.fitting.models` (``svda``, ``exact``, ``contact``, ``prony``); build a model
with :func:`viscoforce.fitting.models.make_model`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from viscoforce.closed_form import prony_compliance_core
from viscoforce.exceptions import ModelValidityError, ParameterError
from viscoforce.fitting.base import (
    MODULUS_BOUNDS,
    ModelSpec,
    moduli_names,
    tau_names,
)
from viscoforce.fitting.guesses import (
    geometric,
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


def _expand_one_mode(v: Mapping[str, float], modes: int) -> dict[str, float]:
    """An n-mode parameter set equivalent to the one-mode ``v`` (all modes at ``tau``)."""
    moduli = geometric(v["E0"], v["E_inf"], modes)
    out = dict(zip(moduli_names(modes), moduli, strict=True))
    out.update({n: v["tau"] * (1 + 1e-9 * i) for i, n in enumerate(tau_names(modes))})
    return out


def exact_stiffness(problem: ContactProblem, position: float | None, mean_force: float | None,
                    material: ViscoelasticMaterial, omega: np.ndarray, *,
                    states: Any = None, taylor_rtol: float | None = None) -> np.ndarray:
    """Exact small-amplitude k*(ω) [N/m] of ``material`` at h̄0 = ``position`` or at the load.

    ``states``: the :class:`~viscoforce.experiments.linear_response.ModulusStates` to evaluate
    on (the exact model's fitting grid: Newton warm-started from the nearest solved E_inf,
    direct solves for a few frequencies; ``problem`` is then not used); else at a position
    those of :func:`~viscoforce.experiments.linear_response.modulus_states` on ``problem``, at
    a load :func:`~viscoforce.experiments.linear_response.linearized_state`. ``taylor_rtol``:
    the largest estimated relative error of a first-order step in E_inf from a decomposed state
    (:meth:`~viscoforce.experiments.linear_response.ModulusStates.stiffness`; default its
    ``TAYLOR_RTOL``).
    """
    from viscoforce.experiments.linear_response import linearized_state, modulus_states

    e_inf = material.relaxed_modulus
    compliance = 2.0 * _compliance(material, omega)
    if states is not None:
        return states.stiffness(e_inf, compliance, taylor_rtol=taylor_rtol)
    if position is not None:
        return modulus_states(problem, position).stiffness(e_inf, compliance)
    return linearized_state(problem, None, e_inf, load=mean_force).stiffness(compliance)


def _compliance(material: ViscoelasticMaterial, omega: np.ndarray) -> np.ndarray:
    """C*(ω) [1/Pa] of a Prony ``material`` (its closed form) at frequencies ``omega``.

    Without the argument checks for the 1-D nonnegative finite frequencies a fit passes (else
    the material's checked method, which names a bad value): 75 µs of checks per call.
    """
    w = np.asarray(omega)
    if w.ndim != 1 or w.dtype.kind != "f" or not bool(np.all(w >= 0) and np.all(np.isfinite(w))):
        return np.asarray(material.complex_compliance(omega), dtype=complex)
    p = material.prony()
    return prony_compliance_core(w, p.glassy_compliance, np.asarray(p.delta_compliances),
                                 np.asarray(p.taus))


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


