"""Closed-form material laws and the Derjaguin force of an exponential pressure.

Pure, vectorised functions of floats (SI units in, SI units out) with full physical keyword
names, so that lmfit can wrap them as models and use those names as parameter names:
``tau``, ``E0``, ``E_inf``, ``radius``, ``P`` (the paper's pressure amplitude, the CLI's ``--P``),
``debye_length`` (1/κ), ``omega``.

* Material laws: the standard linear solid of the paper's Eq. 3 and the n-mode Prony solid
  (creep compliance C(t) and complex compliance C*(ω)); :mod:`viscoforce.physics.materials`
  evaluates its materials with them.
* Cell rheology (beyond the paper): the structural-damping (power-law rheology) modulus with a
  Newtonian term, E*(ω) = E_ref (iω/ω_ref)^α + iωμ (Fabry et al., PRL 87, 148102 (2001);
  Alcaraz et al., Biophys. J. 84, 2071 (2003)), and the paper's liquid-like power-law creep
  C(t) = 1/E0 + C1 t^m with an optional Newtonian term in parallel.
* :func:`derjaguin_force`: F = 2πR κ⁻¹ P e^{−κh} (the paper's Eq. 22). It is the Derjaguin
  approximation of the exponential law for a rigid sphere (h = h0, the far-field oracle of the
  exact solver) as well as the SVDA force (h = h0 − u), so it lives here, below both users.
* Public validation helpers shared with the SVDA closed forms (:mod:`viscoforce.svda`) and the
  SVDA ODE (:mod:`viscoforce.solvers.svda_ode`): :func:`as_finite_array`,
  :func:`as_nonnegative_array`, :func:`require_exponential_law`, :func:`require_representable`
  (a result that overflowed raises :class:`~viscoforce.exceptions.ParameterError` — never a NaN
  or a RuntimeWarning) and :data:`MAX_EXPONENT`.

The slowly varying deformation approximation (paper Sec. II.E, Eqs. 15–26) is in
:mod:`viscoforce.svda`.

Conventions
-----------
- τ (``tau``) is the decay time of the CREEP compliance of the paper's Eq. 3,
  C(t) = 1/E_inf + (1/E0 − 1/E_inf) e^{−t/τ} (a retardation time). The stress-relaxation time of
  the same solid is τ·E_inf/E0; never mix the two.
- Complex quantities use the e^{+iωt} convention: C*(ω) = C(0) + ∫0^∞ C'(t) e^{−iωt} dt, so a
  lossy material has Im C* < 0 for ω > 0.
- The paper's E is defined by 2/E = Σ(1 − ν_i²)/E_i (twice Johnson's contact modulus E*).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.special import gamma

from viscoforce._typing import FloatArray
from viscoforce._validation import (
    as_float_1d,
    as_real_array,
    describe_value,
    require_finite,
    require_in_range,
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
    "structural_complex_modulus",
    "power_law_complex_modulus",
    "derjaguin_force",
    # validation helpers shared with viscoforce.svda and viscoforce.solvers.svda_ode
    "MAX_EXPONENT",
    "as_finite_array",
    "as_nonnegative_array",
    "require_exponential_law",
    "require_representable",
]

#: Largest exponent passed to exp() before it would overflow a float64 (e^709.78 = 1.8e308).
MAX_EXPONENT = 700.0


# ── validation helpers ──────────────────────────────────────────────────────────────────────────

def as_finite_array(name: str, values: ArrayLike) -> FloatArray:
    """Return ``values`` as a float array of any shape (0-d for a scalar), all finite.

    Parameters
    ----------
    name : str
        Parameter name used in the error message.
    values : float or array_like
        Real numbers.

    Returns
    -------
    numpy.ndarray
        ``values`` as float64, same shape.

    Raises
    ------
    ParameterError
        If an entry is not a real number or not finite (the message names the first bad entry).
    """
    try:
        arr = as_real_array(name, values)  # refuses None, text, complex (no ComplexWarning)
    except ParameterError:
        raise ParameterError(f"{name} must be real numbers, got {describe_value(values)}") from None
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr.ravel()))[0])
        raise ParameterError(f"{name} must be finite; entry {bad} is {float(arr.ravel()[bad])!r}")
    return arr


def as_nonnegative_array(name: str, values: ArrayLike) -> FloatArray:
    """Return ``values`` as a finite float array of any shape with every entry >= 0.

    Parameters
    ----------
    name : str
        Parameter name used in the error message.
    values : float or array_like
        Real numbers, >= 0 (times [s], frequencies [rad/s], ...).

    Returns
    -------
    numpy.ndarray
        ``values`` as float64, same shape.

    Raises
    ------
    ParameterError
        If an entry is not a finite real number or is negative.
    """
    arr = as_finite_array(name, values)
    if np.any(arr < 0):
        bad = int(np.flatnonzero(arr.ravel() < 0)[0])
        raise ParameterError(f"{name} must be >= 0; entry {bad} is {float(arr.ravel()[bad])!r}")
    return arr


def require_representable(result: Any, what: str, inputs: str) -> Any:
    """Return ``result`` unchanged, raising if any entry overflowed (is not finite).

    Closed forms evaluate under ``np.errstate(over="ignore", invalid="ignore")``: an intermediate
    that overflows to ±inf either gives the right limit (e^{−inf} = 0) or a non-finite result,
    which this check turns into a clear error instead of a NaN or a RuntimeWarning.

    Parameters
    ----------
    result : float, complex or array_like
        The computed value(s).
    what : str
        What was computed, e.g. ``"C(t)"``.
    inputs : str
        The inputs that set its size, e.g. ``"t, E0, E_inf, tau"``.

    Returns
    -------
    Any
        ``result``.

    Raises
    ------
    ParameterError
        If an entry of ``result`` is NaN or ±inf.
    """
    arr = np.asarray(result)
    if not np.all(np.isfinite(arr)):
        raise ParameterError(
            f"the inputs are outside the representable range: {what} overflows a float64 "
            f"(not finite); check {inputs}")
    return result


def require_exponential_law(radius: float, P: float, debye_length: float, *,
                            allow_attraction: bool = False) -> tuple[float, float, float]:
    """Validate a sphere facing the exponential pressure p(h) = P e^{−κh}; return (R, P, κ).

    Parameters
    ----------
    radius : float
        Sphere radius R [m], > 0.
    P : float
        Pressure amplitude P [Pa] at zero gap: > 0, or any finite value (an attraction for
        P < 0) when ``allow_attraction`` is true.
    debye_length : float
        Decay length 1/κ [m], > 0.
    allow_attraction : bool
        Accept P <= 0 (the Derjaguin force and the elastic SVDA statics hold for either sign).

    Returns
    -------
    tuple of float
        R [m], P [Pa] and κ = 1/debye_length [1/m].

    Raises
    ------
    ParameterError
        If an input is out of range (the message names it and the allowed range).
    """
    r = require_positive("radius", radius)
    p = require_finite("P", P) if allow_attraction else require_positive("P", P)
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
        Instantaneous (short-time, glassy) modulus [Pa], > E_inf.
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
    tt = as_nonnegative_array("t", t)
    e0, e_inf, tau_ = require_sls_moduli(E0, E_inf, tau)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        c = 1.0 / e_inf + (1.0 / e0 - 1.0 / e_inf) * np.exp(-tt / tau_)
    return require_representable(c, "C(t)", "t, E0, E_inf, tau")


def sls_complex_compliance(omega: ArrayLike, E0: float, E_inf: float, tau: float) -> np.ndarray:
    """Complex compliance C*(ω) of the standard linear solid, e^{+iωt} convention [1/Pa].

    C*(ω) = C(0) + ∫0^∞ C'(t) e^{−iωt} dt = 1/E_inf + (1/E0 − 1/E_inf)·iωτ/(1 + iωτ), so
    C*(0) = 1/E_inf, C*(∞) = 1/E0 and Im C* < 0 for ω > 0 (the strain lags the stress).

    Parameters
    ----------
    omega : float or array_like
        Angular frequencies [rad/s], >= 0.
    E0 : float
        Instantaneous modulus [Pa], > E_inf.
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
    w = as_nonnegative_array("omega", omega)
    e0, e_inf, tau_ = require_sls_moduli(E0, E_inf, tau)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        iwt = 1j * w * tau_
        c = 1.0 / e_inf + (1.0 / e0 - 1.0 / e_inf) * iwt / (1.0 + iwt)
    return require_representable(c, "C*(omega)", "omega, E0, E_inf, tau")


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
    tt = as_nonnegative_array("t", t)
    jg, dj, taus_ = _prony_data(glassy_compliance, delta_compliances, taus)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        modes = -np.expm1(-tt[..., np.newaxis] / taus_)
        c = jg + modes @ dj
    return require_representable(c, "C(t)", "t, glassy_compliance, delta_compliances, taus")


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
    w = as_nonnegative_array("omega", omega)
    jg, dj, taus_ = _prony_data(glassy_compliance, delta_compliances, taus)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        c = prony_compliance_core(w, jg, dj, taus_)
    return require_representable(c, "C*(omega)",
                                 "omega, glassy_compliance, delta_compliances, taus")


def prony_compliance_core(omega: np.ndarray, glassy_compliance: float, delta_compliances: np.ndarray,
                          taus: np.ndarray) -> np.ndarray:
    """C*(ω) = J_g + Σ ΔJ_i/(1 + iωτ_i) without validation, for inputs already checked (fit loops).

    Parameters
    ----------
    omega : numpy.ndarray
        Angular frequencies [rad/s].
    glassy_compliance : float
        J_g [1/Pa].
    delta_compliances, taus : numpy.ndarray
        ΔJ_i [1/Pa] and τ_i [s], same length.

    Returns
    -------
    numpy.ndarray
        Complex C*(ω) [1/Pa].
    """
    return glassy_compliance + (1.0 / (1.0 + 1j * omega[..., np.newaxis] * taus)) @ delta_compliances


# ── surface force ───────────────────────────────────────────────────────────────────────────────

def structural_complex_modulus(omega: ArrayLike, E_ref: float, alpha: float, mu: float,  # noqa: N803
                               reference_frequency: float = 1.0) -> np.ndarray:
    """E*(ω) = E_ref (iω/ω_ref)^α + iωμ of power-law (structural-damping) rheology [Pa].

    ω_ref = 2π·``reference_frequency``. The power-law part has the frequency-independent loss
    tangent tan(πα/2) (α → 0 an elastic solid, α → 1 a Newtonian liquid); μ adds a Newtonian
    viscosity in parallel, which dominates at high frequency. E is the paper's modulus
    (2/E = Σ(1 − ν²)/E_i), like E0 and E_inf; e^{+iωt} convention (Im E* > 0: loss).

    Parameters
    ----------
    omega : float or array_like
        Angular frequencies [rad/s], > 0 (the power law is singular at ω = 0).
    E_ref : float
        Modulus magnitude of the power-law part at ω_ref [Pa], > 0.
    alpha : float
        Power-law exponent, in (0, 1).
    mu : float
        Newtonian viscosity [Pa·s], >= 0.
    reference_frequency : float
        f_ref [Hz] of E_ref, > 0 (default 1 Hz).

    Returns
    -------
    numpy.ndarray
        Complex E*(ω) [Pa], same shape as ``omega``.

    Raises
    ------
    ParameterError
        A frequency <= 0 or not finite, or a parameter out of its range.
    """
    w = _positive_omega(omega)
    e_ref = require_positive("E_ref", E_ref)
    f_ref = require_positive("reference_frequency", reference_frequency)
    a = require_in_range("alpha", alpha, 0.0, 1.0, inclusive=(False, False))
    mu_ = require_nonnegative("mu", mu)
    with np.errstate(over="ignore", invalid="ignore"):
        e = e_ref * (1j * w / (2.0 * math.pi * f_ref)) ** a + 1j * w * mu_
    return require_representable(e, "E*(omega)", "omega, E_ref, alpha, mu")


def power_law_complex_modulus(omega: ArrayLike, E0: float, C1: float, m: float,  # noqa: N803
                              mu: float = 0.0) -> np.ndarray:
    """E*(ω) = 1/C*(ω) + iωμ of the power-law creep C(t) = 1/E0 + C1 t^m [Pa].

    C*(ω) = 1/E0 + C1 Γ(1 + m)(iω)^−m (e^{+iωt}); the paper's liquid-like material for m → 1.
    μ (default 0) is an optional Newtonian viscosity in parallel.

    Parameters
    ----------
    omega : float or array_like
        Angular frequencies [rad/s], > 0.
    E0 : float
        Instantaneous modulus 1/C(0) [Pa], > 0.
    C1 : float
        Creep coefficient [Pa⁻¹ s⁻ᵐ], > 0.
    m : float
        Creep exponent, in (0, 1).
    mu : float
        Newtonian viscosity [Pa·s], >= 0.

    Returns
    -------
    numpy.ndarray
        Complex E*(ω) [Pa].

    Raises
    ------
    ParameterError
        A frequency <= 0 or not finite, or a parameter out of its range.
    """
    w = _positive_omega(omega)
    e0, c1 = require_positive("E0", E0), require_positive("C1", C1)
    m_ = require_in_range("m", m, 0.0, 1.0, inclusive=(False, False))
    mu_ = require_nonnegative("mu", mu)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        e = 1.0 / (1.0 / e0 + c1 * gamma(1.0 + m_) * (1j * w) ** (-m_)) + 1j * w * mu_
    return require_representable(e, "E*(omega)", "omega, E0, C1, m, mu")


def _positive_omega(omega: ArrayLike) -> FloatArray:
    w = as_finite_array("omega", omega)
    if np.any(w <= 0):
        raise ParameterError(f"omega must be > 0 rad/s for a power-law material, got min "
                             f"{float(np.min(w))!r}")
    return w


def derjaguin_force(gap: ArrayLike, radius: float, P: float,
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
    P : float
        Pressure amplitude P [Pa] at zero gap of p(h) = P e^{−κh}; negative for an attractive
        exponential.
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
    h = as_finite_array("gap", gap)
    r, p, kappa = require_exponential_law(radius, P, debye_length, allow_attraction=True)
    with np.errstate(over="ignore"):  # κh = ±inf: e^{−inf} = 0 is right, +inf is refused below
        z = -kappa * h
    if np.any(z > MAX_EXPONENT):
        raise ParameterError(
            f"gap must be > {-MAX_EXPONENT / kappa:g} m (= −{MAX_EXPONENT:g}/κ) or the force "
            f"overflows; got min(gap)={float(np.min(h))!r}")
    with np.errstate(over="ignore", invalid="ignore"):
        force = 2.0 * math.pi * r * p / kappa * np.exp(z)
    return require_representable(force, "the Derjaguin force", "gap, radius, P, debye_length")
