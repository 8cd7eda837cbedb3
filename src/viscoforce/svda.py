"""The slowly varying deformation approximation (SVDA): closed forms, paper Eqs. 15–26.

Pure, vectorised functions of floats (SI in, SI out; numpy and scipy.special only) with the
physical keyword names lmfit uses as parameter names: ``position`` (h0), ``E`` or ``E0``,
``E_inf``, ``tau``, ``radius``, ``P`` (the paper's pressure amplitude, the CLI's ``--P``),
``debye_length`` (1/κ), ``omega`` and ``eta`` (drive amplitude).

The SVDA (paper Sec. II.E) replaces the deformation everywhere by its central value u(t)
(Eq. 15); with the exponential double-layer pressure p(h) = P e^{−κh} this gives the scalar ODE
(Eq. 17)

    u̇ (1 + f) = f ḣ0 − (u − u_∞)/τ,   f = sqrt(8πκR P²/E0²) exp{−κ[h0 − u]},
    u_∞ = −(E0/(E_inf κ)) f                                   (Eq. 18)

and the Derjaguin-like force F = 2πR κ⁻¹ P exp{−κ[h0 − u]} (Eq. 22,
:func:`viscoforce.closed_form.derjaguin_force`). This module holds its closed forms:

* :func:`svda_static_deformation` — the elastic static state (Lambert W);
* :func:`svda_ramp_deformation` — the analytic constant-speed solution, Eqs. 19–21;
* :func:`svda_harmonic_response`, :func:`svda_complex_stiffness`,
  :func:`svda_peak_phase_frequency` — the small-amplitude harmonic response, Eqs. 23–26 (Eq. 24
  corrected), in the SPEC spectroscopy convention.

The time integration of Eq. 17 is :func:`viscoforce.solvers.svda_ode.solve_svda`; the SVDA
spectra (closed form and ODE + lock-in) are
:func:`viscoforce.experiments.spectroscopy.svda_spectrum` and
:func:`~viscoforce.experiments.spectroscopy.svda_sweep`.

Conventions (as in :mod:`viscoforce.closed_form`): τ is the creep (retardation) time of Eq. 3;
complex quantities use e^{+iωt}; position h0 is the undeformed apex separation (may be
negative), u < 0 is flattening and the central gap is h = h0 − u. Spectroscopy (SPEC): drive
h0(t) = h̄0 + η sin ωt, force F ≈ F̄ + |F1| sin(ωt + ψ); the relative amplitude is a = |F1|/F̄,
the stiffness |F1|/η [N/m], and the phase χ [deg] is the angle by which the force oscillation
LEADS the compression −(h0 − h̄0); χ > 0 for a viscoelastic solid.
"""

from __future__ import annotations

import math
import warnings
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import exprel, lambertw

from viscoforce._typing import FloatArray
from viscoforce._validation import (
    require_finite,
    require_nonnegative,
    require_positive,
    require_sls_moduli,
)
from viscoforce.closed_form import (
    MAX_EXPONENT,
    as_finite_array,
    as_nonnegative_array,
    derjaguin_force,
    require_exponential_law,
    require_representable,
)
from viscoforce.exceptions import ApproximationWarning, ParameterError

__all__ = [
    "svda_static_deformation",
    "svda_ramp_deformation",
    "SVDAHarmonicResponse",
    "svda_harmonic_response",
    "svda_complex_stiffness",
    "svda_peak_phase_frequency",
    "svda_error_estimate",
    "warn_svda_error",
    "warn_if_in_contact",
]


# ── SVDA statics ────────────────────────────────────────────────────────────────────────────────

def lambert_w_of_exp(log_x: FloatArray) -> FloatArray:
    """Principal Lambert W of x = e^{log_x} > 0, for any log_x (no overflow of e^{log_x})."""
    out = np.full_like(log_x, np.nan)  # NaN stays NaN (neither branch below takes it)
    small = log_x < MAX_EXPONENT
    out[small] = lambertw(np.exp(log_x[small]), k=0).real
    big = ~small & np.isfinite(log_x)
    if np.any(big):
        # w + ln w = L; Newton from the asymptote w ≈ L − ln L converges in a few steps.
        # w/(1 + w) first: w·(1 + L − ln w) alone overflows for L ≳ 1e154.
        L = log_x[big]
        w = L - np.log(L)
        for _ in range(8):
            w = (w / (1.0 + w)) * (1.0 + L - np.log(w))
        out[big] = w
    out[log_x == np.inf] = np.inf   # W(e^inf) = inf: refused by the caller
    return out


def svda_static_deformation(position: ArrayLike, E: float, radius: float, P: float,
                            debye_length: float) -> FloatArray:
    """Elastic SVDA central deformation u at a fixed position (static Eqs. 17–18) [m].

    Solves u = −sqrt(8πR/κ)·(P/E)·exp(−κ(h0 − u)) (for P > 0: u = −sqrt(8πR P²/κ)/E ·
    exp(−κ(h0 − u))). With x = −κu this is x e^{x} = z, z = κ sqrt(8πR/κ)(P/E) e^{−κh0}, so
    u = −W0(z)/κ with the principal (real) branch of the Lambert W function. For a repulsion
    (P > 0) z > 0 and the solution always exists. For an attraction (P < 0) the surfaces bulge
    towards each other (u > 0) and a real solution exists only while z >= −1/e; beyond that the
    elastic bodies jump into contact.

    The viscoelastic SVDA rests in the static state with E = E_inf (the paper's
    u(t0) = −E0 c/(E_inf κ)); with E = E0 it gives the instantaneous (glassy) response.

    Parameters
    ----------
    position : float or array_like
        Position h0 [m] (undeformed apex separation; may be negative).
    E : float
        The paper's elastic modulus E [Pa] (2/E = Σ(1 − ν_i²)/E_i), > 0.
    radius : float
        Sphere radius R [m], > 0.
    P : float
        Pressure amplitude P [Pa] of p(h) = P e^{−κh}; negative for an attraction.
    debye_length : float
        Decay length 1/κ [m], > 0.

    Returns
    -------
    numpy.ndarray
        Central deformation u [m] (< 0 for a repulsion), same shape as ``position``.

    Raises
    ------
    ParameterError
        If an input is out of range, or (P < 0) no real solution exists at a position.
    """
    h0 = as_finite_array("position", position)
    e = require_positive("E", E)
    r, p, kappa = require_exponential_law(radius, P, debye_length, allow_attraction=True)
    if p == 0.0:
        return np.zeros_like(h0)
    # z = prefactor e^{−κh0}, prefactor = sqrt(8πRκ)·P/E, taken in logs: it overflows a float64
    # for a tiny E or debye_length although u stays finite.
    log_abs_prefactor = (0.5 * (math.log(8.0 * math.pi) + math.log(r) + math.log(kappa))
                         + math.log(abs(p)) - math.log(e))
    with np.errstate(over="ignore", invalid="ignore"):  # κh0 = ±inf: refused or e^{−inf} = 0
        log_abs_z = log_abs_prefactor - kappa * h0
    if p > 0.0:
        with np.errstate(over="ignore", invalid="ignore"):
            u = -lambert_w_of_exp(log_abs_z) / kappa
        return require_representable(u, "the SVDA static deformation u",
                                     "position, E, radius, P, debye_length")
    if np.any(log_abs_z > -1.0):   # z < −1/e
        i = int(np.flatnonzero(log_abs_z.ravel() > -1.0)[0])
        bad = float(h0.ravel()[i])
        z = -math.exp(min(float(log_abs_z.ravel()[i]), MAX_EXPONENT))
        raise ParameterError(
            f"no real SVDA static solution at position={bad!r} m with modulus E={E!r} Pa: the "
            f"attraction P={P!r} Pa beats the elastic stiffness (Lambert-W "
            f"argument {z:.4g} < −1/e); increase position or E")
    z = -np.exp(log_abs_z)
    return require_representable(-lambertw(z, k=0).real / kappa, "the SVDA static deformation u",
                                 "position, E, radius, P, debye_length")


#: max over ω of |k*_SVDA/k*_exact − 1| ≈ SVDA_ERROR_COEFFICIENT·κ|u0| (u0 the relaxed central
#: deformation): measured 0.585 for κ|u0| ≤ 0.03 (0.3–0.55 above) over R 1–100 µm, E 0.1–10 GPa,
#: 1/κ 0.3–3 nm, E0/E_inf 3–100 (studies/validity_maps/validity_maps.py).
SVDA_ERROR_COEFFICIENT = 0.6
#: Estimated SVDA error above which the closed forms warn (ModelValidityWarning).
SVDA_WARN_ERROR = 1e-2


def svda_error_estimate(position: ArrayLike, E_inf: float, radius: float, P: float,  # noqa: N803
                        debye_length: float) -> FloatArray:
    """Estimated relative error of the SVDA stiffness against the exact model: 0.6 κ|u0|.

    u0 is the relaxed (E = E_inf) SVDA central deformation at ``position``
    (:func:`svda_static_deformation`); see :data:`SVDA_ERROR_COEFFICIENT` for where the
    coefficient was measured. The SVDA assumes a deformation uniform over the interaction zone,
    so its error grows with the deformation measured in decay lengths.
    """
    u0 = svda_static_deformation(position, E_inf, radius, P, debye_length)
    return SVDA_ERROR_COEFFICIENT * np.abs(u0) / float(debye_length)


def warn_svda_error(position: float, E_inf: float, radius: float, P: float,  # noqa: N803
                    debye_length: float, *, stacklevel: int = 3) -> float:
    """Warn (ModelValidityWarning) when :func:`svda_error_estimate` exceeds 1 %; return it."""
    error = float(np.max(svda_error_estimate(position, E_inf, radius, P, debye_length)))
    if error > SVDA_WARN_ERROR:
        warnings.warn(
            f"the SVDA is about {100 * error:.2g} % off the exact model at position "
            f"{float(position) * 1e9:.4g} nm (estimate 0.6 kappa|u0|; above "
            f"{100 * SVDA_WARN_ERROR:g} %): the deformation is not small against the decay "
            "length 1/kappa; use the exact model (method 'linear', model 'exact')",
            ApproximationWarning, stacklevel=stacklevel)
    return error


def warn_if_in_contact(gap: ArrayLike, debye_length: float, what: str, *,
                       stacklevel: int = 3) -> None:
    """Warn (ModelValidityWarning) when an SVDA trajectory's central gap goes below 1/κ.

    The SVDA holds before contact only; along a drive into contact it is tens of per cent off
    (56 % on the paper's Fig. 5 loop for the ODE, 100 % for the closed-form ramp;
    studies/speed_accuracy/speed_accuracy.py).
    """
    g = np.asarray(gap, dtype=float)
    if g.size and float(np.min(g)) < float(debye_length):
        warnings.warn(
            f"the SVDA is used in contact: {what}'s central gap reaches "
            f"{float(np.min(g)) * 1e9:.3g} nm, below the decay length 1/kappa = "
            f"{float(debye_length) * 1e9:.3g} nm, where the SVDA does not hold (tens of % off); "
            "use the exact solver (viscoforce.simulate)", ApproximationWarning,
            stacklevel=stacklevel)


# ── SVDA ramp (Eqs. 19–21) ──────────────────────────────────────────────────────────────────────

def svda_ramp_deformation(t: ArrayLike, position: float, speed: float, E0: float, E_inf: float,
                          tau: float, radius: float, P: float,
                          debye_length: float) -> FloatArray:
    """Analytic SVDA deformation under a constant-speed drive, Eqs. 20–21 [m].

    u(t) = A [e^{−κḣt} − e^{−t/τ}] with
    A = (κḣτ/E0 − 1/E_inf)/(1 − κḣτ) · sqrt(8πR P²/κ) e^{−κh0}, the solution of the linearised
    Eq. 19 (f neglected against 1 in the denominator of Eq. 17, κu neglected in the exponent)
    that vanishes at t = 0. It is written as
    u = (κḣτ/E0 − 1/E_inf) S (t/τ) e^{−mt} exprel(−|1/τ − κḣ| t), m = min(κḣ, 1/τ),
    S = sqrt(8πR P²/κ) e^{−κh0}, exprel(x) = (e^x − 1)/x: the same expression without
    cancellation and finite at the removable singularity κḣτ = 1 (a retraction at speed
    1/(κτ)), where u = (1/E0 − 1/E_inf) S (t/τ) e^{−t/τ}.

    Valid at large separation (κ|u| ≪ 1 and f ≪ 1); it overestimates |u| near contact.

    Parameters
    ----------
    t : float or array_like
        Times since the start of the ramp [s], >= 0.
    position : float
        Position h0 at t = 0 [m].
    speed : float
        Drive velocity ḣ [m/s]; negative when approaching (h0(t) = position + speed·t).
    E0 : float
        Instantaneous modulus [Pa], > E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time of Eq. 3 [s], > 0.
    radius : float
        Sphere radius R [m], > 0.
    P : float
        Pressure amplitude P [Pa] of p(h) = P e^{−κh}, > 0.
    debye_length : float
        Decay length 1/κ [m], > 0.

    Returns
    -------
    numpy.ndarray
        Central deformation u(t) [m], same shape as ``t``.

    Raises
    ------
    ParameterError
        If an input is out of range, or ``t`` is so long that the exponentials overflow.
    """
    tt = as_nonnegative_array("t", t)
    h0 = require_finite("position", position)
    v = require_finite("speed", speed)
    e0, e_inf, tau_ = require_sls_moduli(E0, E_inf, tau)
    r, p, kappa = require_exponential_law(radius, P, debye_length)
    lam = kappa * v
    mu = 1.0 / tau_
    if not (math.isfinite(lam) and math.isfinite(mu)):
        raise ParameterError(
            f"the inputs are outside the representable range: kappa*speed = {lam!r} 1/s or "
            f"1/tau = {mu!r} 1/s overflows a float64 (speed={speed!r} m/s, "
            f"debye_length={debye_length!r} m, tau={tau!r} s)")
    # (e^{−λt} − e^{−μt})/(μ − λ) = t e^{−min(λ,μ)t} exprel(−|μ − λ|t): no cancellation, no
    # overflow of exprel, finite at λ = μ.
    log_s = 0.5 * math.log(8.0 * math.pi * r / kappa) + math.log(p) - kappa * h0
    with np.errstate(over="ignore", invalid="ignore"):
        exponent = log_s - min(lam, mu) * tt
    if np.any(exponent > MAX_EXPONENT):
        raise ParameterError(
            f"t must be shorter: e^(−κ(position + speed·t)) overflows before max(t)="
            f"{float(tt.max())!r} s (position={position!r} m, speed={speed!r} m/s); Eq. 20 is a "
            f"large-separation approximation")
    with np.errstate(over="ignore", invalid="ignore"):
        u = (lam * tau_ / e0 - 1.0 / e_inf) * (tt / tau_) * np.exp(exponent) * exprel(
            -abs(mu - lam) * tt)
    u = require_representable(u, "the SVDA ramp deformation u(t)",
                              "t, position, speed, E0, E_inf, tau, radius, P, debye_length")
    # Eq. 20 linearises the force in u: its error grows like κ|u| (measured at Fig. 2, 2 nm:
    # u 10 % too deep at κ|u| = 0.17, i.e. ≈ 0.6 κ|u|); into contact it diverges
    error = SVDA_ERROR_COEFFICIENT * kappa * float(np.max(np.abs(u))) if u.size else 0.0
    if error > SVDA_WARN_ERROR:
        warnings.warn(
            f"the SVDA is about {100 * min(error, 1.0):.2g} % off or worse on this ramp (Eq. 20): "
            f"the deformation reaches |u| = {float(np.max(np.abs(u))) * 1e9:.3g} nm, not small "
            f"against 1/kappa = {1e9 / kappa:.3g} nm (estimate 0.6 kappa|u|); use the SVDA ODE "
            "(solve_svda) before contact or the exact solver", ApproximationWarning,
            stacklevel=2)
    return u


# ── SVDA harmonic response (Eqs. 23–26, corrected Eq. 24) ───────────────────────────────────────

class SVDAHarmonicResponse(NamedTuple):
    """Small-amplitude SVDA response to h0(t) = h̄0 + η sin ωt (arrays shaped like ``omega``).

    Attributes
    ----------
    nu : numpy.ndarray
        Deformation amplitude ν [m] of u(t) = u0 + ν sin(ωt + φ).
    phi : numpy.ndarray
        Deformation phase φ [rad] relative to the drive (the paper's φ; <= 0, u lags h0).
    theta : numpy.ndarray
        The paper's auxiliary angle θ [rad], tan θ = −(1 + cE0/E_inf)/(ωτ(1 + c)), θ in
        [−π/2, 0] (θ = −π/2 at ω = 0).
    c : float
        The paper's c = sqrt(8πκR P²/E0²) exp{−κ[h̄0 − u0]} = −κ u0 E_inf/E0 [1].
    u0 : float
        Mean (static, E_inf) central deformation u(t0) [m].
    amplitude : numpy.ndarray
        Relative force amplitude a = |F1|/F̄ [1] (Eq. 26).
    phase : numpy.ndarray
        Force phase χ [deg], SPEC convention: lead of the force over the compression, >= 0.
    stiffness : numpy.ndarray
        |F1|/η [N/m].
    mean_force : float
        F̄ = 2πR κ⁻¹ P exp{−κ[h̄0 − u0]} [N] (Eq. 22 at the mean state).
    """

    nu: FloatArray
    phi: FloatArray
    theta: FloatArray
    c: float
    u0: float
    amplitude: FloatArray
    phase: FloatArray
    stiffness: FloatArray
    mean_force: float


def _svda_mean_state(position: float, E0: float, E_inf: float, tau: float, radius: float,
                     P: float, debye_length: float
                     ) -> tuple[float, float, float, float, float]:
    """Validate and return (u0 [m], c, E0/E_inf, τ [s], F̄ [N]) of the SVDA mean state."""
    h0 = require_finite("position", position)
    e0, e_inf, tau_ = require_sls_moduli(E0, E_inf, tau)
    _, _, kappa = require_exponential_law(radius, P, debye_length)
    if not math.isfinite(e0 / e_inf):
        raise ParameterError(
            f"the inputs are outside the representable range: E0/E_inf overflows a float64 "
            f"(E0={E0!r} Pa, E_inf={E_inf!r} Pa)")
    u0 = float(svda_static_deformation(h0, e_inf, radius, P, debye_length))
    c = -kappa * u0 * e_inf / e0
    mean_force = float(derjaguin_force(h0 - u0, radius, P, debye_length))
    return u0, c, e0 / e_inf, tau_, mean_force


def _svda_transfer(x: FloatArray, c: float, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Return (ν̂/η, k*/(F̄κ)) at x = ωτ for SVDA parameters c and ratio = E0/E_inf."""
    denominator = (1.0 + ratio * c) + 1j * x * (1.0 + c)
    nu_hat = c * (ratio + 1j * x) / denominator
    return nu_hat, (1.0 + 1j * x) / denominator


def svda_harmonic_response(omega: ArrayLike, position: float, eta: float, E0: float,
                           E_inf: float, tau: float, radius: float, P: float,
                           debye_length: float) -> SVDAHarmonicResponse:
    r"""SVDA small-amplitude harmonic response, paper Eqs. 23–26 with Eq. 24 corrected.

    Derivation. Eq. 17 reads u̇(1 + f) = f ḣ0 − (u − u_∞)/τ with f = c̃ e^{−κ(h0 − u)},
    c̃ = sqrt(8πκR P²/E0²), and u_∞ = −(E0/(E_inf κ)) f (Eq. 18). The mean state (ḣ0 = 0,
    u̇ = 0) is u0 = u_∞, i.e. u0 = −(E0/(E_inf κ)) c with c = f(h̄0 − u0): the elastic SVDA
    static equation with E = E_inf (:func:`svda_static_deformation`), so c = −κu0 E_inf/E0.
    Write h0 = h̄0 + η e^{iωt}, u = u0 + ν̂ e^{iωt}, r = E0/E_inf, x = ωτ. To first order
    δf = cκ(δu − δh0) and δu_∞ = rc(δh0 − δu) (both f and u_∞ depend on h0 − u), hence
    iωτ(1 + c)ν̂ = iωτ c η − ν̂ + rc(η − ν̂), i.e.

        ν̂/η = c (r + ix) / [(1 + rc) + ix(1 + c)].

    With the sine drive, ν = |ν̂| and φ = arg ν̂. Writing θ = arg[(1 + rc) + ix(1 + c)] − π/2
    reproduces the printed tan θ = −(1 + cE0/E_inf)/(ωτ(1 + c)) and Eq. 23,
    tan(θ + φ) = −E0/(E_inf ωτ) (θ + φ = arg(r + ix) − π/2), and then
    |r + ix| = x / cos(θ + φ), |(1 + rc) + ix(1 + c)| = x(1 + c)/cos θ, so

        printed Eq. 24:   ν = η c cos θ / [1 + c cos(θ + φ)]       (wrong)
        corrected:        ν = η c cos θ / [(1 + c) cos(θ + φ)].

    The printed form misplaces the bracket: it agrees at ω → ∞ (ν → cη/(1 + c)) but gives
    ν → 0 as ω → 0, contradicting the paper's own limit ν → −κηu0/(1 − κu0) (= rcη/(1 + rc)),
    which the corrected form reproduces. Eq. 23 and the θ definition are right.

    Force. Eq. 22 linearised: F = F̄[1 + κ(δu − δh0)], so the complex force per unit drive is
    F̄κ(ν̂/η − 1) and, per unit compression D̂ = −η,

        k* = F̂/D̂ = F̄ κ (1 − ν̂/η) = F̄ κ (1 + ix) / [(1 + rc) + ix(1 + c)],

    giving a = κ|η − ν̂| = κ sqrt(η² + ν² − 2ην cos φ) (Eq. 26) and the SPEC phase
    χ = arg k* = atan(x) − atan(x(1 + c)/(1 + rc)) >= 0. Eq. 25, tan χ = −ν sin φ/(η − ν cos φ),
    taken on its principal branch (η − ν cos φ > 0), is exactly this SPEC χ (the lead of the force
    over the compression). Read literally, the paper's F = F̄[1 + a sin(ωt + χ)] with a > 0 would
    need χ + 180° (the force rises as h0 falls); this function returns the SPEC χ.

    Limits: ω → 0: φ, χ → 0, ν → −κηu0/(1 − κu0), a → κη/(1 − κu0) (the paper's printed limits);
    ω → ∞: φ, θ, χ → 0, ν → cη/(1 + c), a → κη/(1 + c). The force phase peaks at
    (ωτ)² = (1 + rc)/(1 + c) (:func:`svda_peak_phase_frequency`), the high/low amplitude ratio is
    (1 + rc)/(1 + c).

    Parameters
    ----------
    omega : float or array_like
        Angular frequencies ω [rad/s], >= 0.
    position : float
        Mean position h̄0 [m].
    eta : float
        Drive amplitude η [m], >= 0 (the result is linear in η).
    E0 : float
        Instantaneous modulus [Pa], > E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time of Eq. 3 [s], > 0.
    radius : float
        Sphere radius R [m], > 0.
    P : float
        Pressure amplitude P [Pa] of p(h) = P e^{−κh}, > 0.
    debye_length : float
        Decay length 1/κ [m], > 0.

    Returns
    -------
    SVDAHarmonicResponse
        ν, φ, θ, c, u0, a, χ [deg], stiffness and mean force (see its attributes).

    Raises
    ------
    ParameterError
        If an input is out of range.
    """
    w = as_nonnegative_array("omega", omega)
    eta_ = require_nonnegative("eta", eta)
    u0, c, ratio, tau_, mean_force = _svda_mean_state(position, E0, E_inf, tau, radius,
                                                      P, debye_length)
    kappa = 1.0 / float(debye_length)
    with np.errstate(over="ignore", invalid="ignore"):
        x = w * tau_
        nu_hat, k_rel = _svda_transfer(x, c, ratio)
        theta = np.arctan2(x * (1.0 + c), 1.0 + ratio * c) - 0.5 * math.pi
        response = SVDAHarmonicResponse(
            nu=eta_ * np.abs(nu_hat),
            phi=np.angle(nu_hat),
            theta=theta,
            c=c,
            u0=u0,
            amplitude=kappa * eta_ * np.abs(k_rel),
            phase=np.degrees(np.angle(k_rel)),
            stiffness=mean_force * kappa * np.abs(k_rel),
            mean_force=mean_force,
        )
    for value in response:
        require_representable(value, "the SVDA harmonic response",
                              "omega, position, eta, E0, E_inf, tau, radius, P, debye_length")
    warn_svda_error(position, E_inf, radius, P, debye_length)
    return response


def svda_deformation_kernel(position: float, E: float, radius: float, P: float,  # noqa: N803
                            kappa: float) -> float:
    """:func:`svda_static_deformation` u0 [m] of one position, without input checks (inner loops).

    u0 = −W0(z)/κ, log z = ½ log(8πRκ) + log(P/E) − κh0, for a repulsion; the caller guarantees
    R, P, κ, E > 0 and a finite position.
    """
    log_z = (0.5 * (math.log(8.0 * math.pi) + math.log(radius) + math.log(kappa))
             + math.log(P) - math.log(E) - kappa * position)
    # lambert_w_of_exp on one value: its scalar branch without the array's masks (to 1 ulp: libm's
    # exp in place of NumPy's), its asymptotic branch beyond exp's range
    w = (float(lambertw(math.exp(log_z), k=0).real) if log_z < MAX_EXPONENT
         else float(lambert_w_of_exp(np.array([log_z]))[0]))
    return -w / kappa


def svda_stiffness_kernel(omega: FloatArray, position: float, E0: float, E_inf: float,  # noqa: N803
                          tau: float, radius: float, P: float, kappa: float) -> np.ndarray:
    """SVDA k*(ω) [N/m] without input checks, for inner loops (fits) over validated inputs.

    The same algebra as :func:`svda_complex_stiffness` for a repulsion (P > 0): u0 = −W0(z)/κ
    with log z = ½ log(8πRκ) + log(P/E_inf) − κh̄0, c = −κu0 E_inf/E0, F̄ = (2πRP/κ) e^{−κ(h̄0−u0)}.
    The caller guarantees ω ≥ 0, R, P, κ > 0 and E0 > E_inf > 0, τ > 0 (all finite).
    """
    u0 = svda_deformation_kernel(position, E_inf, radius, P, kappa)
    c = -kappa * u0 * E_inf / E0
    mean_force = 2.0 * math.pi * radius * P / kappa * math.exp(-kappa * (position - u0))
    x = omega * tau
    return (mean_force * kappa) * (1.0 + 1j * x) / ((1.0 + (E0 / E_inf) * c) + 1j * x * (1.0 + c))


def svda_complex_stiffness(omega: ArrayLike, position: float, E0: float, E_inf: float,
                           tau: float, radius: float, P: float,
                           debye_length: float) -> np.ndarray:
    """SVDA complex stiffness k*(ω) = F̂/D̂ per unit compression [N/m].

    k* = F̄ κ (1 + iωτ)/[(1 + rc) + iωτ(1 + c)], r = E0/E_inf, c = −κu0/r (see
    :func:`svda_harmonic_response` for the derivation). |k*| is the SPEC stiffness |F1|/η and
    arg k* the SPEC phase χ (force leading the compression, >= 0). It is real and equal to
    F̄κ/(1 − κu0) at ω = 0 and to F̄κ/(1 + c) at ω → ∞.

    Parameters
    ----------
    omega : float or array_like
        Angular frequencies ω [rad/s], >= 0 (the independent variable of the lmfit model).
    position : float
        Mean position h̄0 [m].
    E0 : float
        Instantaneous modulus [Pa], > E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time of Eq. 3 [s], > 0.
    radius : float
        Sphere radius R [m], > 0.
    P : float
        Pressure amplitude P [Pa] of p(h) = P e^{−κh}, > 0.
    debye_length : float
        Decay length 1/κ [m], > 0.

    Returns
    -------
    numpy.ndarray
        Complex stiffness [N/m], same shape as ``omega``.

    Raises
    ------
    ParameterError
        If an input is out of range.
    """
    w = as_nonnegative_array("omega", omega)
    _, c, ratio, tau_, mean_force = _svda_mean_state(position, E0, E_inf, tau, radius, P,
                                                     debye_length)
    with np.errstate(over="ignore", invalid="ignore"):
        _, k_rel = _svda_transfer(w * tau_, c, ratio)
        k = (mean_force / float(debye_length)) * k_rel
    k = require_representable(k, "the SVDA complex stiffness",
                              "omega, position, E0, E_inf, tau, radius, P, debye_length")
    warn_svda_error(position, E_inf, radius, P, debye_length)
    return k


def svda_peak_phase_frequency(position: float, E0: float, E_inf: float, tau: float,
                              radius: float, P: float, debye_length: float) -> float:
    """Frequency ω0 [rad/s] of the SVDA force-phase maximum, (ω0τ)² = (1 + cE0/E_inf)/(1 + c).

    This is the maximum of the FORCE phase χ(ω) = atan(ωτ) − atan(ωτ(1 + c)/(1 + rc)) (r =
    E0/E_inf); the deformation phase φ peaks elsewhere, at (ωτ)² = r(1 + rc)/(1 + c). The peak
    value is tan χ_max = (1 − q)/(2 sqrt q), q = (1 + c)/(1 + rc).

    Parameters
    ----------
    position : float
        Mean position h̄0 [m].
    E0 : float
        Instantaneous modulus [Pa], > E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time of Eq. 3 [s], > 0.
    radius : float
        Sphere radius R [m], > 0.
    P : float
        Pressure amplitude P [Pa] of p(h) = P e^{−κh}, > 0.
    debye_length : float
        Decay length 1/κ [m], > 0.

    Returns
    -------
    float
        ω0 [rad/s].

    Raises
    ------
    ParameterError
        If an input is out of range.
    """
    _, c, ratio, tau_, _ = _svda_mean_state(position, E0, E_inf, tau, radius, P,
                                            debye_length)
    omega0 = math.sqrt((1.0 + c * ratio) / (1.0 + c)) / tau_
    return require_representable(omega0, "the peak-phase frequency",
                                 "position, E0, E_inf, tau, radius, P, debye_length")
