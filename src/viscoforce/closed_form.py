"""Closed-form material laws and the slowly varying deformation approximation (SVDA).

Pure, vectorised functions of floats (SI units in, SI units out) with full physical keyword
names, so that lmfit can wrap them as models and use those names as parameter names:
``tau``, ``E0``, ``E_inf``, ``radius``, ``pressure`` (the paper's P), ``debye_length`` (1/κ),
``position`` (h0), ``omega`` and ``eta`` (drive amplitude).

Conventions
-----------
- τ (``tau``) is the decay time of the CREEP compliance of the paper's Eq. 3,
  C(t) = 1/E_inf + (1/E0 − 1/E_inf) e^{−t/τ} (a retardation time). The stress-relaxation time of
  the same solid is τ·E_inf/E0; never mix the two.
- Complex quantities use the e^{+iωt} convention: C*(ω) = C(0) + ∫0^∞ C'(t) e^{−iωt} dt, so a
  lossy material has Im C* < 0 for ω > 0.
- The paper's E is defined by 2/E = Σ(1 − ν_i²)/E_i (twice Johnson's contact modulus E*).
- Position h0 is the undeformed apex separation (may be negative), u < 0 is flattening and the
  central gap is h = h0 − u.
- Spectroscopy (SPEC): drive h0(t) = h̄0 + η sin ωt, force F ≈ F̄ + |F1| sin(ωt + ψ); the relative
  amplitude is a = |F1|/F̄, the stiffness |F1|/η [N/m], and the phase χ [deg] is the angle by
  which the force oscillation LEADS the compression −(h0 − h̄0); χ > 0 for a viscoelastic solid.

SVDA (paper Sec. II.E, Eqs. 15–26): the deformation is replaced everywhere by its central value
u(t), giving the scalar ODE (Eq. 17)

    u̇ (1 + f) = f ḣ0 − (u − u_∞)/τ,   f = sqrt(8πκR P²/E0²) exp{−κ[h0 − u]},
    u_∞ = −(E0/(E_inf κ)) f                                   (Eq. 18)

and the Derjaguin-like force F = 2πR κ⁻¹ P exp{−κ[h0 − u]} (Eq. 22). The time integrator of
Eq. 17 lives in :mod:`viscoforce.svda`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import exprel, lambertw

from viscoforce._typing import FloatArray
from viscoforce._validation import (
    as_float_1d,
    require_finite,
    require_nonnegative,
    require_positive,
    require_sls_moduli,
)
from viscoforce.exceptions import ParameterError

__all__ = [
    "sls_creep_compliance",
    "sls_complex_compliance",
    "prony_creep_compliance",
    "prony_complex_compliance",
    "derjaguin_force",
    "svda_static_deformation",
    "svda_ramp_deformation",
    "SVDAHarmonicResponse",
    "svda_harmonic_response",
    "svda_complex_stiffness",
    "svda_peak_phase_frequency",
]

# Largest exponent passed to exp() before it overflows a float64 (e^709.78 = 1.8e308).
_MAX_EXPONENT = 700.0


# ── helpers ──────────────────────────────────────────────────────────────────────────────────────

def _as_array(name: str, values: ArrayLike) -> FloatArray:
    """Return ``values`` as a float array of any shape (0-d for a scalar), raising unless finite."""
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be real numbers, got {values!r}") from None
    if not np.all(np.isfinite(arr)):
        bad = np.flatnonzero(~np.isfinite(arr.ravel()))[0]
        raise ParameterError(f"{name} must be finite; entry {bad} is {arr.ravel()[bad]!r}")
    return arr


def _as_nonnegative_array(name: str, values: ArrayLike) -> FloatArray:
    arr = _as_array(name, values)
    if np.any(arr < 0):
        bad = np.flatnonzero(arr.ravel() < 0)[0]
        raise ParameterError(f"{name} must be >= 0; entry {bad} is {arr.ravel()[bad]!r}")
    return arr


def _sls_moduli(E0: float, E_inf: float, tau: float) -> tuple[float, float, float]:
    """Validate the standard-linear-solid triple (E0 > E_inf > 0, tau > 0)."""
    return require_sls_moduli(E0, E_inf, tau)


def _surface(radius: float, pressure: float, debye_length: float, *,
             signed_pressure: bool = False) -> tuple[float, float, float]:
    """Validate (R, P, 1/κ) and return (R, P, κ)."""
    r = require_positive("radius", radius)
    p = require_finite("pressure", pressure) if signed_pressure else require_positive(
        "pressure", pressure)
    kappa = 1.0 / require_positive("debye_length", debye_length)
    return r, p, kappa


# ── material laws ───────────────────────────────────────────────────────────────────────────────

def sls_creep_compliance(t: ArrayLike, E0: float, E_inf: float, tau: float) -> FloatArray:
    """Creep compliance of the paper's standard linear solid (Eq. 3) [1/Pa].

    C(t) = 1/E_inf + (1/E0 − 1/E_inf) e^{−t/τ}: 1/E0 at t = 0, 1/E_inf as t → ∞.

    Parameters
    ----------
    t : float or array_like
        Times since the load was applied [s], >= 0.
    E0 : float
        Instantaneous (short-time, glassy) modulus [Pa], >= E_inf.
    E_inf : float
        Relaxed (long-time) modulus [Pa], > 0.
    tau : float
        Creep (retardation) time of Eq. 3 [s], > 0.

    Returns
    -------
    numpy.ndarray
        C(t) [1/Pa], same shape as ``t``.

    Raises
    ------
    ParameterError
        If a time is negative or not finite, or the moduli or ``tau`` are out of range.
    """
    tt = _as_nonnegative_array("t", t)
    e0, e_inf, tau_ = _sls_moduli(E0, E_inf, tau)
    return 1.0 / e_inf + (1.0 / e0 - 1.0 / e_inf) * np.exp(-tt / tau_)


def sls_complex_compliance(omega: ArrayLike, E0: float, E_inf: float, tau: float) -> np.ndarray:
    """Complex compliance C*(ω) of the standard linear solid, e^{+iωt} convention [1/Pa].

    C*(ω) = C(0) + ∫0^∞ C'(t) e^{−iωt} dt = 1/E_inf + (1/E0 − 1/E_inf)·iωτ/(1 + iωτ), so
    C*(0) = 1/E_inf, C*(∞) = 1/E0 and Im C* < 0 for ω > 0 (the strain lags the stress).

    Parameters
    ----------
    omega : float or array_like
        Angular frequencies [rad/s], >= 0.
    E0 : float
        Instantaneous modulus [Pa], >= E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep (retardation) time of Eq. 3 [s], > 0. The stress-relaxation time of the same solid
        is tau·E_inf/E0.

    Returns
    -------
    numpy.ndarray
        Complex C*(ω) [1/Pa], same shape as ``omega``.

    Raises
    ------
    ParameterError
        If a frequency is negative or not finite, or the material parameters are out of range.
    """
    w = _as_nonnegative_array("omega", omega)
    e0, e_inf, tau_ = _sls_moduli(E0, E_inf, tau)
    iwt = 1j * w * tau_
    return 1.0 / e_inf + (1.0 / e0 - 1.0 / e_inf) * iwt / (1.0 + iwt)


def _prony_data(glassy_compliance: float, delta_compliances: ArrayLike,
                taus: ArrayLike) -> tuple[float, FloatArray, FloatArray]:
    jg = require_positive("glassy_compliance", glassy_compliance)
    dj = as_float_1d("delta_compliances", delta_compliances, min_size=0)
    tt = as_float_1d("taus", taus, min_size=0)
    if dj.size != tt.size:
        raise ParameterError(
            f"delta_compliances and taus must have the same length, got {dj.size} and {tt.size}")
    if np.any(dj < 0):
        i = int(np.flatnonzero(dj < 0)[0])
        raise ParameterError(f"delta_compliances must be >= 0 [1/Pa]; entry {i} is {dj[i]!r}")
    if np.any(tt <= 0):
        i = int(np.flatnonzero(tt <= 0)[0])
        raise ParameterError(f"taus must be > 0 [s]; entry {i} is {tt[i]!r}")
    return jg, dj, tt


def prony_creep_compliance(t: ArrayLike, glassy_compliance: float, delta_compliances: ArrayLike,
                           taus: ArrayLike) -> FloatArray:
    """Creep compliance of an n-mode Prony (generalised Kelvin) solid [1/Pa].

    C(t) = J_g + Σ_i ΔJ_i (1 − e^{−t/τ_i}). It is the paper's Eq. 8, C(t) = Σ c_i e^{−t/τ_i} with
    a τ = ∞ mode, rewritten with J_g = C(0) = Σ c_i and ΔJ_i = −c_i (finite τ_i); the relaxed
    compliance is C(∞) = J_g + Σ ΔJ_i. One mode with J_g = 1/E0, ΔJ = 1/E_inf − 1/E0 is the
    standard linear solid of Eq. 3.

    Parameters
    ----------
    t : float or array_like
        Times [s], >= 0.
    glassy_compliance : float
        J_g = C(0) [1/Pa], > 0.
    delta_compliances : array_like
        ΔJ_i [1/Pa], each >= 0.
    taus : array_like
        Creep (retardation) times τ_i [s], each > 0, same length as ``delta_compliances``.

    Returns
    -------
    numpy.ndarray
        C(t) [1/Pa], same shape as ``t``.

    Raises
    ------
    ParameterError
        If a time is negative, a compliance or time is out of range, or the lengths differ.
    """
    tt = _as_nonnegative_array("t", t)
    jg, dj, taus_ = _prony_data(glassy_compliance, delta_compliances, taus)
    modes = -np.expm1(-tt[..., np.newaxis] / taus_)
    return jg + modes @ dj


def prony_complex_compliance(omega: ArrayLike, glassy_compliance: float,
                             delta_compliances: ArrayLike, taus: ArrayLike) -> np.ndarray:
    """Complex compliance of an n-mode Prony solid, e^{+iωt} convention [1/Pa].

    C*(ω) = J_g + Σ_i ΔJ_i/(1 + iωτ_i): C*(0) = J_g + Σ ΔJ_i (relaxed), C*(∞) = J_g (glassy).

    Parameters
    ----------
    omega : float or array_like
        Angular frequencies [rad/s], >= 0.
    glassy_compliance : float
        J_g = C(0) [1/Pa], > 0.
    delta_compliances : array_like
        ΔJ_i [1/Pa], each >= 0.
    taus : array_like
        Creep (retardation) times τ_i [s], each > 0.

    Returns
    -------
    numpy.ndarray
        Complex C*(ω) [1/Pa], same shape as ``omega``.

    Raises
    ------
    ParameterError
        If a frequency is negative, a compliance or time is out of range, or the lengths differ.
    """
    w = _as_nonnegative_array("omega", omega)
    jg, dj, taus_ = _prony_data(glassy_compliance, delta_compliances, taus)
    return jg + (1.0 / (1.0 + 1j * w[..., np.newaxis] * taus_)) @ dj


# ── surface force ───────────────────────────────────────────────────────────────────────────────

def derjaguin_force(gap: ArrayLike, radius: float, pressure: float,
                    debye_length: float) -> FloatArray:
    """Derjaguin force of an exponential pressure P e^{−κh} on a sphere (paper Eq. 22) [N].

    F = 2πR κ⁻¹ P e^{−κh}. With the SVDA gap h = h0 − u this is the SVDA force of Eq. 22; with
    h = h0 it is the rigid-particle force.

    Parameters
    ----------
    gap : float or array_like
        Central surface separation h [m] (may be negative).
    radius : float
        Sphere radius R [m], > 0 (1/R = 1/R1 + 1/R2 for two spheres).
    pressure : float
        Pressure amplitude P [Pa] at zero gap; negative for an attractive exponential.
    debye_length : float
        Decay length 1/κ [m], > 0.

    Returns
    -------
    numpy.ndarray
        Force [N], same shape as ``gap``; positive is repulsive.

    Raises
    ------
    ParameterError
        If an input is out of range, or a gap is so negative that the force overflows.
    """
    h = _as_array("gap", gap)
    r, p, kappa = _surface(radius, pressure, debye_length, signed_pressure=True)
    z = -kappa * h
    if np.any(z > _MAX_EXPONENT):
        raise ParameterError(
            f"gap must be > {-_MAX_EXPONENT / kappa:g} m (= −{_MAX_EXPONENT:g}/κ) or the force "
            f"overflows; got min(gap)={float(np.min(h))!r}")
    return 2.0 * math.pi * r * p / kappa * np.exp(z)


# ── SVDA statics ────────────────────────────────────────────────────────────────────────────────

def _omega_log_w(log_x: FloatArray) -> FloatArray:
    """Principal Lambert W of x = e^{log_x} > 0, for any log_x (no overflow of e^{log_x})."""
    out = np.empty_like(log_x)
    small = log_x < _MAX_EXPONENT
    out[small] = lambertw(np.exp(log_x[small]), k=0).real
    big = ~small
    if np.any(big):
        # w + ln w = L; Newton from the asymptote w ≈ L − ln L converges in a few steps.
        L = log_x[big]
        w = L - np.log(L)
        for _ in range(8):
            w = w * (1.0 + L - np.log(w)) / (1.0 + w)
        out[big] = w
    return out


def svda_static_deformation(position: ArrayLike, E: float, radius: float, pressure: float,
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
    pressure : float
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
    h0 = _as_array("position", position)
    e = require_positive("E", E)
    r, p, kappa = _surface(radius, pressure, debye_length, signed_pressure=True)
    if p == 0.0:
        return np.zeros_like(h0)
    prefactor = kappa * math.sqrt(8.0 * math.pi * r / kappa) * p / e   # z = prefactor e^{−κh0}
    if p > 0.0:
        return -_omega_log_w(math.log(prefactor) - kappa * h0) / kappa
    log_abs_z = math.log(-prefactor) - kappa * h0
    if np.any(log_abs_z > -1.0):   # z < −1/e
        i = int(np.flatnonzero(log_abs_z.ravel() > -1.0)[0])
        bad = float(h0.ravel()[i])
        z = -math.exp(min(float(log_abs_z.ravel()[i]), _MAX_EXPONENT))
        raise ParameterError(
            f"no real SVDA static solution at position={bad!r} m with modulus E={E!r} Pa: the "
            f"attraction pressure={pressure!r} Pa beats the elastic stiffness (Lambert-W "
            f"argument {z:.4g} < −1/e); increase position or E")
    z = -np.exp(log_abs_z)
    return -lambertw(z, k=0).real / kappa


# ── SVDA ramp (Eqs. 19–21) ──────────────────────────────────────────────────────────────────────

def svda_ramp_deformation(t: ArrayLike, position: float, speed: float, E0: float, E_inf: float,
                          tau: float, radius: float, pressure: float,
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
        Instantaneous modulus [Pa], >= E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time of Eq. 3 [s], > 0.
    radius : float
        Sphere radius R [m], > 0.
    pressure : float
        Pressure amplitude P [Pa], > 0.
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
    tt = _as_nonnegative_array("t", t)
    h0 = require_finite("position", position)
    v = require_finite("speed", speed)
    e0, e_inf, tau_ = _sls_moduli(E0, E_inf, tau)
    r, p, kappa = _surface(radius, pressure, debye_length)
    lam = kappa * v
    mu = 1.0 / tau_
    # (e^{−λt} − e^{−μt})/(μ − λ) = t e^{−min(λ,μ)t} exprel(−|μ − λ|t): no cancellation, no
    # overflow of exprel, finite at λ = μ.
    log_s = 0.5 * math.log(8.0 * math.pi * r / kappa) + math.log(p) - kappa * h0
    exponent = log_s - min(lam, mu) * tt
    if np.any(exponent > _MAX_EXPONENT):
        raise ParameterError(
            f"t must be shorter: e^(−κ(position + speed·t)) overflows before max(t)="
            f"{float(tt.max())!r} s (position={position!r} m, speed={speed!r} m/s); Eq. 20 is a "
            f"large-separation approximation")
    return (lam * tau_ / e0 - 1.0 / e_inf) * (tt / tau_) * np.exp(exponent) * exprel(
        -abs(mu - lam) * tt)


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
                     pressure: float, debye_length: float
                     ) -> tuple[float, float, float, float, float]:
    """Validate and return (u0 [m], c, E0/E_inf, τ [s], F̄ [N]) of the SVDA mean state."""
    h0 = require_finite("position", position)
    e0, e_inf, tau_ = _sls_moduli(E0, E_inf, tau)
    _, _, kappa = _surface(radius, pressure, debye_length)
    u0 = float(svda_static_deformation(h0, e_inf, radius, pressure, debye_length))
    c = -kappa * u0 * e_inf / e0
    mean_force = float(derjaguin_force(h0 - u0, radius, pressure, debye_length))
    return u0, c, e0 / e_inf, tau_, mean_force


def _svda_transfer(x: FloatArray, c: float, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Return (ν̂/η, k*/(F̄κ)) at x = ωτ for SVDA parameters c and ratio = E0/E_inf."""
    denominator = (1.0 + ratio * c) + 1j * x * (1.0 + c)
    nu_hat = c * (ratio + 1j * x) / denominator
    return nu_hat, (1.0 + 1j * x) / denominator


def svda_harmonic_response(omega: ArrayLike, position: float, eta: float, E0: float,
                           E_inf: float, tau: float, radius: float, pressure: float,
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
        Instantaneous modulus [Pa], >= E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time of Eq. 3 [s], > 0.
    radius : float
        Sphere radius R [m], > 0.
    pressure : float
        Pressure amplitude P [Pa], > 0.
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
    w = _as_nonnegative_array("omega", omega)
    eta_ = require_nonnegative("eta", eta)
    u0, c, ratio, tau_, mean_force = _svda_mean_state(position, E0, E_inf, tau, radius,
                                                      pressure, debye_length)
    kappa = 1.0 / float(debye_length)
    x = w * tau_
    nu_hat, k_rel = _svda_transfer(x, c, ratio)
    theta = np.arctan2(x * (1.0 + c), 1.0 + ratio * c) - 0.5 * math.pi
    return SVDAHarmonicResponse(
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


def svda_complex_stiffness(omega: ArrayLike, position: float, E0: float, E_inf: float,
                           tau: float, radius: float, pressure: float,
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
        Instantaneous modulus [Pa], >= E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time of Eq. 3 [s], > 0.
    radius : float
        Sphere radius R [m], > 0.
    pressure : float
        Pressure amplitude P [Pa], > 0.
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
    w = _as_nonnegative_array("omega", omega)
    _, c, ratio, tau_, mean_force = _svda_mean_state(position, E0, E_inf, tau, radius, pressure,
                                                     debye_length)
    _, k_rel = _svda_transfer(w * tau_, c, ratio)
    return (mean_force / float(debye_length)) * k_rel


def svda_peak_phase_frequency(position: float, E0: float, E_inf: float, tau: float,
                              radius: float, pressure: float, debye_length: float) -> float:
    """Frequency ω0 [rad/s] of the SVDA force-phase maximum, (ω0τ)² = (1 + cE0/E_inf)/(1 + c).

    This is the maximum of the FORCE phase χ(ω) = atan(ωτ) − atan(ωτ(1 + c)/(1 + rc)) (r =
    E0/E_inf); the deformation phase φ peaks elsewhere, at (ωτ)² = r(1 + rc)/(1 + c). The peak
    value is tan χ_max = (1 − q)/(2 sqrt q), q = (1 + c)/(1 + rc).

    Parameters
    ----------
    position : float
        Mean position h̄0 [m].
    E0 : float
        Instantaneous modulus [Pa], >= E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time of Eq. 3 [s], > 0.
    radius : float
        Sphere radius R [m], > 0.
    pressure : float
        Pressure amplitude P [Pa], > 0.
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
    _, c, ratio, tau_, _ = _svda_mean_state(position, E0, E_inf, tau, radius, pressure,
                                            debye_length)
    return math.sqrt((1.0 + c * ratio) / (1.0 + c)) / tau_
