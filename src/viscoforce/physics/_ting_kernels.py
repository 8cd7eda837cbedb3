"""Relaxation kernels of Ting's hereditary integral (:mod:`viscoforce.physics.ting`).

:class:`RelaxationKernel` (a relaxation modulus E(t) and what the integral needs from it),
:class:`PronyRelaxation`, :class:`PowerLawRelaxation`, their sums of exponentials
(:class:`Exponentials`) and :func:`relaxation_from_creep` (creep Prony series → relaxation Prony
series); then the numerics of a piecewise-linear history against a kernel: the corners located
between samples (:func:`locate_kinks`) and the product integration on the history's nodes
(:func:`history_sums`: FFT on a uniform grid, the loop otherwise; piecewise-uniform grids in
:mod:`viscoforce.physics._ting_segments`). The
conventions, the numerics and the references are told in :mod:`viscoforce.physics.ting`, the
public module that re-exports the kernels and :func:`locate_kinks`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.signal import fftconvolve
from scipy.special import gamma

from viscoforce._limits import REFERENCE_FREQUENCY_RANGE
from viscoforce._typing import FloatArray
from viscoforce._validation import (
    as_real_array,
    describe_value,
    require_in_range,
    require_nonnegative,
    require_plausible,
    require_positive,
)
from viscoforce.exceptions import ParameterError

__all__ = [
    "DEFAULT_RTOL",
    "KINK_MARGIN",
    "KINK_RTOL",
    "SECULAR_STEPS",
    "Exponentials",
    "PowerLawRelaxation",
    "PronyRelaxation",
    "RelaxationKernel",
    "history_nonuniform",
    "history_sums",
    "interval_sums",
    "locate_kinks",
    "relaxation_from_creep",
]

#: Relative accuracy of the power law's sum of exponentials over the lags of a curve.
DEFAULT_RTOL = 1e-6
#: Newton steps (at most) on each relaxation rate of :func:`relaxation_from_creep`.
SECULAR_STEPS = 100


# ── relaxation kernels ────────────────────────────────────────────────────────────────────────


@dataclass(frozen=True)
class Exponentials:
    """E(t) ≈ constant + Σ amplitudes_k·exp(−rates_k·t) over a range of lags.

    Attributes
    ----------
    constant : float
        The constant term [Pa].
    amplitudes : ndarray
        Amplitudes [Pa] of the exponentials.
    rates : ndarray
        Their decay rates [1/s], > 0.
    """

    constant: float
    amplitudes: FloatArray
    rates: FloatArray


class RelaxationKernel(ABC):
    """A relaxation modulus E(t) [Pa] (the paper's convention) and what Ting's integral needs.

    Subclasses are frozen dataclasses implementing :meth:`modulus`, :meth:`primitive`,
    :meth:`complex_modulus` and :meth:`exponentials`. Phase convention e^{+iωt}: E*(ω) =
    iω ∫₀^∞ E(t) e^{−iωt} dt, Im E* ≥ 0 (as :mod:`viscoforce.physics.materials`).
    """

    @abstractmethod
    def modulus(self, t: ArrayLike) -> FloatArray:
        """E(t) [Pa] at lags ``t`` [s] > 0 (without a Newtonian δ_D term)."""

    @abstractmethod
    def primitive(self, u: ArrayLike) -> FloatArray:
        """R(u) = ∫₀ᵘ E(v) dv [Pa·s] at ``u`` [s] ≥ 0 (a Newtonian μ δ_D(t) adds μ for u > 0)."""

    @abstractmethod
    def complex_modulus(self, omega: ArrayLike) -> np.ndarray:
        """E*(ω) [Pa] at angular frequency ``omega`` [rad/s] > 0."""

    @abstractmethod
    def exponentials(self, shortest: float, longest: float, rtol: float = DEFAULT_RTOL
                     ) -> Exponentials:
        """E(t) as a constant plus exponentials, relative error ≤ ``rtol`` on [shortest, longest] [s]."""

    @property
    def newtonian(self) -> float:
        """μ [Pa·s] of a Newtonian term μ δ_D(t) in E(t) (0 without one)."""
        return 0.0


def _lags(name: str, values: ArrayLike, *, positive: bool) -> FloatArray:
    arr = as_real_array(name, values)
    bad = ~np.isfinite(arr) | ((arr <= 0) if positive else (arr < 0))
    if bad.any():
        i = int(np.flatnonzero(bad.ravel())[0])
        raise ParameterError(f"{name} must be finite and {'> 0' if positive else '>= 0'} s; "
                             f"entry {i} is {float(arr.ravel()[i])!r}")
    return arr


def _omega(values: ArrayLike) -> FloatArray:
    return _lags("omega", values, positive=True)


@dataclass(frozen=True)
class PronyRelaxation(RelaxationKernel):
    """E(t) = E_inf + Σ_k E_k exp(−t/ρ_k): a relaxation Prony series.

    Parameters
    ----------
    E_inf : float
        Relaxed modulus [Pa], ≥ 0 (0: a liquid).
    moduli : tuple of float
        Mode moduli E_k [Pa], each > 0 (none: elastic, E(t) = E_inf).
    times : tuple of float
        Stress-relaxation times ρ_k [s], each > 0, one per modulus.
    """

    E_inf: float  # noqa: N815
    moduli: tuple[float, ...] = ()
    times: tuple[float, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "E_inf", require_nonnegative("E_inf", self.E_inf))
        moduli = np.atleast_1d(as_real_array("moduli", self.moduli, "a 1-D array"))
        times = np.atleast_1d(as_real_array("times", self.times, "a 1-D array"))
        if moduli.ndim != 1 or times.ndim != 1 or moduli.size != times.size:
            raise ParameterError(f"moduli and times must be 1-D and of the same length, got "
                                 f"shapes {moduli.shape} and {times.shape}")
        for i, (e, r) in enumerate(zip(moduli, times, strict=True)):
            require_positive(f"moduli[{i}]", e)
            require_positive(f"times[{i}]", r)
        if self.E_inf == 0 and moduli.size == 0:
            raise ParameterError("a relaxation modulus needs E_inf > 0 or at least one mode, "
                                 "got E_inf = 0 and no modes")
        object.__setattr__(self, "moduli", tuple(float(x) for x in moduli))
        object.__setattr__(self, "times", tuple(float(x) for x in times))

    @classmethod
    def from_material(cls, material) -> PronyRelaxation:
        """The relaxation modulus of a creep-Prony material (:mod:`viscoforce.physics.materials`).

        Parameters
        ----------
        material : ViscoelasticMaterial
            Any material with ``prony()`` (Elastic, StandardLinearSolid, PronySeries); its
            ``taus`` are creep times.

        Returns
        -------
        PronyRelaxation
            E(t) with E(0) = E0 = 1/C(0) and E(∞) = E_inf = 1/C(∞).

        Raises
        ------
        ParameterError
            If ``material`` has no ``prony()`` method.
        """
        prony = getattr(material, "prony", None)
        if not callable(prony):
            raise ParameterError(f"material must be a viscoelastic material (with prony()), got "
                                 f"{describe_value(material)}")
        p = prony()
        e_inf, moduli, times = relaxation_from_creep(p.glassy_compliance, p.delta_compliances,
                                                     p.taus)
        return cls(e_inf, tuple(moduli), tuple(times))

    @property
    def instantaneous_modulus(self) -> float:
        """E(0) = E_inf + Σ E_k [Pa]."""
        return self.E_inf + float(sum(self.moduli))

    def modulus(self, t: ArrayLike) -> FloatArray:
        """E(t) = E_inf + Σ E_k e^{−t/ρ_k} [Pa] at lags ``t`` [s] ≥ 0."""
        t = _lags("t", t, positive=False)
        out = np.full(t.shape, self.E_inf)
        for e, r in zip(self.moduli, self.times, strict=True):
            out = out + e * np.exp(-t / r)
        return out

    def primitive(self, u: ArrayLike) -> FloatArray:
        """R(u) = E_inf·u + Σ E_k ρ_k (1 − e^{−u/ρ_k}) [Pa·s]."""
        u = _lags("u", u, positive=False)
        out = self.E_inf * u
        for e, r in zip(self.moduli, self.times, strict=True):
            out = out - e * r * np.expm1(-u / r)
        return out

    def complex_modulus(self, omega: ArrayLike) -> np.ndarray:
        """E*(ω) = E_inf + Σ E_k iωρ_k/(1 + iωρ_k) [Pa]."""
        w = _omega(omega)
        out = np.full(w.shape, self.E_inf, dtype=complex)
        for e, r in zip(self.moduli, self.times, strict=True):
            x = 1j * w * r
            out = out + e * x / (1.0 + x)
        return out

    def exponentials(self, shortest: float, longest: float, rtol: float = DEFAULT_RTOL
                     ) -> Exponentials:
        """The series itself (exact at every lag)."""
        return Exponentials(self.E_inf, np.array(self.moduli, dtype=float),
                            1.0 / np.array(self.times, dtype=float))


def _reference_frequency(value: float) -> float:
    """f_ref [Hz]: > 0, within :data:`~viscoforce._limits.REFERENCE_FREQUENCY_RANGE`.

    5e-320 Hz made (2π f_ref t0)^α underflow: a power law fitted to nothing.
    """
    return require_plausible("reference_frequency",
                             require_positive("reference_frequency", value),
                             REFERENCE_FREQUENCY_RANGE, "Hz")


@dataclass(frozen=True)
class PowerLawRelaxation(RelaxationKernel):
    """Ting's power law E(t) = E0 (t/t0)^(−β), plus a Newtonian μ δ_D(t).

    E*(ω) = E0 Γ(1 − β) (iω t0)^β + iωμ: the structural material of the ``contact`` model with
    α = β and E_ref = E0 Γ(1 − β)(2π f_ref t0)^β (:meth:`from_structural`).

    Parameters
    ----------
    E0 : float
        E(t0) [Pa] (paper convention), > 0.
    beta : float
        Exponent β in (0, 1) (0: elastic solid, 1: Newtonian liquid).
    t0 : float
        Reference time t0 [s], > 0 (default 1 s, Efremov et al. 2017).
    mu : float
        Newtonian viscosity coefficient μ [Pa·s], ≥ 0 (paper convention, like E).
    """

    E0: float  # noqa: N815
    beta: float
    t0: float = 1.0
    mu: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "E0", require_positive("E0", self.E0))
        object.__setattr__(self, "beta", require_in_range("beta", self.beta, 0.0, 1.0,
                                                          inclusive=(False, False)))
        object.__setattr__(self, "t0", require_positive("t0", self.t0))
        object.__setattr__(self, "mu", require_nonnegative("mu", self.mu))

    @classmethod
    def from_structural(cls, E_ref: float, alpha: float, mu: float = 0.0,  # noqa: N803
                        reference_frequency: float = 1.0, t0: float = 1.0) -> PowerLawRelaxation:
        """Ting's form of E*(ω) = E_ref (iω/ω_ref)^α + iωμ, ω_ref = 2π·``reference_frequency``.

        Parameters
        ----------
        E_ref : float
            |E*| of the power-law part at ω_ref [Pa], > 0.
        alpha : float
            Exponent α in (0, 1).
        mu : float
            Newtonian coefficient μ [Pa·s], ≥ 0.
        reference_frequency : float
            f_ref [Hz], > 0, within :data:`~viscoforce._limits.REFERENCE_FREQUENCY_RANGE`.
        t0 : float
            Ting's reference time [s], > 0.

        Returns
        -------
        PowerLawRelaxation
            E0 = E_ref / (Γ(1 − α)(2π f_ref t0)^α), β = α.
        """
        e_ref = require_positive("E_ref", E_ref)
        a = require_in_range("alpha", alpha, 0.0, 1.0, inclusive=(False, False))
        f_ref = _reference_frequency(reference_frequency)
        t0 = require_positive("t0", t0)
        e0 = e_ref / (gamma(1.0 - a) * (2.0 * math.pi * f_ref * t0) ** a)
        return cls(float(e0), a, t0, mu)

    def reference_modulus(self, reference_frequency: float = 1.0) -> float:
        """E_ref = E0 Γ(1 − β)(2π f_ref t0)^β [Pa] of the structural form at f_ref [Hz]."""
        f_ref = _reference_frequency(reference_frequency)
        return float(self.E0 * gamma(1.0 - self.beta)
                     * (2.0 * math.pi * f_ref * self.t0) ** self.beta)

    @property
    def newtonian(self) -> float:
        """μ [Pa·s]."""
        return self.mu

    def modulus(self, t: ArrayLike) -> FloatArray:
        """E(t) = E0 (t/t0)^(−β) [Pa] at lags ``t`` [s] > 0."""
        t = _lags("t", t, positive=True)
        return self.E0 * (t / self.t0) ** (-self.beta)

    def primitive(self, u: ArrayLike) -> FloatArray:
        """R(u) = E0 t0^β u^(1−β)/(1 − β) + μ·[u > 0] [Pa·s]."""
        u = _lags("u", u, positive=False)
        out = self.E0 * self.t0 * (u / self.t0) ** (1.0 - self.beta) / (1.0 - self.beta)
        if self.mu:
            out = out + self.mu * (u > 0)
        return out

    def complex_modulus(self, omega: ArrayLike) -> np.ndarray:
        """E*(ω) = E0 Γ(1 − β)(iω t0)^β + iωμ [Pa]."""
        w = _omega(omega)
        return (self.E0 * gamma(1.0 - self.beta) * (1j * w * self.t0) ** self.beta
                + 1j * w * self.mu)

    def exponentials(self, shortest: float, longest: float, rtol: float = DEFAULT_RTOL
                     ) -> Exponentials:
        """E0 t0^β t^(−β) ≈ c0 + Σ c_k e^(−x_k t) for t in [shortest, longest].

        The trapezoidal rule in y = ln x of t^(−β) = Γ(β)⁻¹ ∫ e^(βy − e^y t) dy converges like
        e^(−π²/Δy) (the integrand is analytic in |Im y| < π/2); nodes with e^y·longest below
        rtol^(1/(1+β)) are summed analytically into the constant c0 (they are flat over the
        range), nodes with e^y·shortest beyond ln(1/rtol) + 10 are dropped.
        """
        lo = require_positive("shortest", shortest)
        hi = require_positive("longest", longest)
        rtol = require_in_range("rtol", rtol, 1e-15, 1e-2)
        hi = max(hi, lo)
        beta = self.beta
        log_inv = -math.log(rtol)
        dy = math.pi**2 / (log_inv + 3.0)
        y_lo = -log_inv / (1.0 + beta) - math.log(hi)
        y_hi = math.log((log_inv + 10.0) / lo)
        k = np.arange(math.floor(y_lo / dy), math.ceil(y_hi / dy) + 1)
        y = k * dy
        scale = self.E0 * self.t0**beta / gamma(beta)
        amplitudes = scale * dy * np.exp(beta * y)
        # the nodes below y[0]: Σ_{j≥1} dy e^{β(y0 − j dy)} = dy e^{β y0} e^{−β dy}/(1 − e^{−β dy})
        constant = scale * dy * math.exp(beta * y[0]) / math.expm1(beta * dy)
        return Exponentials(float(constant), amplitudes, np.exp(y))


def relaxation_from_creep(glassy_compliance: float, delta_compliances: ArrayLike,
                          taus: ArrayLike) -> tuple[float, FloatArray, FloatArray]:
    """Relaxation Prony series of a creep Prony series (paper Eq. 8 → E(t)).

    The creep compliance C(t) = J_g + Σ ΔJ_i (1 − e^{−t/τ_i}) has C*(s) = J_g + Σ ΔJ_i/(1 + sτ_i)
    (Laplace variable s = iω). The relaxation modulus E(t) = E_inf + Σ E_k e^{−t/ρ_k} has
    E*(s) = 1/C*(s): its rates 1/ρ_k are the zeros x of J_g + Σ ΔJ_i u_i/(u_i − x) (u_i = 1/τ_i),
    i.e. the eigenvalues of the symmetric matrix diag(u) + v vᵀ with v_i² = ΔJ_i u_i/J_g (they
    interlace the u_i: each relaxation time is shorter than its creep time), and the moduli are
    the residues E_k = 1/(x_k Σ_i ΔJ_i u_i/(u_i − x_k)²). E_inf = 1/(J_g + Σ ΔJ_i) and
    E_inf + Σ E_k = 1/J_g.

    Parameters
    ----------
    glassy_compliance : float
        J_g = 1/E0 [1/Pa], > 0.
    delta_compliances : array_like
        ΔJ_i [1/Pa], each > 0.
    taus : array_like
        Creep (retardation) times τ_i [s], each > 0.

    Returns
    -------
    E_inf : float
        Relaxed modulus [Pa].
    moduli : ndarray
        E_k [Pa] (> 0), ordered by ascending relaxation time.
    times : ndarray
        Relaxation times ρ_k [s], ascending.

    Raises
    ------
    ParameterError
        A compliance or time that is not finite and > 0, or lengths that differ.
    """
    jg = require_positive("glassy_compliance", glassy_compliance)
    dj = np.atleast_1d(as_real_array("delta_compliances", delta_compliances, "a 1-D array"))
    tau = np.atleast_1d(as_real_array("taus", taus, "a 1-D array"))
    if dj.ndim != 1 or tau.ndim != 1 or dj.size != tau.size:
        raise ParameterError(f"delta_compliances and taus must be 1-D and of the same length, "
                             f"got shapes {dj.shape} and {tau.shape}")
    for i, (d, t) in enumerate(zip(dj, tau, strict=True)):
        require_positive(f"delta_compliances[{i}]", d)
        require_positive(f"taus[{i}]", t)
    e_inf = 1.0 / (jg + float(np.sum(dj)))
    if dj.size == 0:
        return e_inf, np.empty(0), np.empty(0)
    order = np.argsort(tau)[::-1]  # ascending creep rates u_i = 1/τ_i
    u, dj = 1.0 / tau[order], dj[order]
    w = dj * u / jg
    # the k-th rate is u_k + s_k with s_k in (0, u_{k+1} − u_k) (the last: (0, Σ w)); start from
    # the eigenvalues, then safeguarded Newton on the secular equation in s, whose differences
    # u_i − u_k − s keep their relative accuracy over decades of rates
    gaps = np.append(np.diff(u), float(np.sum(w)) * (1.0 + 1e-12))
    apart = u[None, :] - u[:, None]  # (k, i): u_i − u_k
    start = np.sort(np.linalg.eigvalsh(np.diag(u) + np.outer(np.sqrt(w), np.sqrt(w)))) - u
    lo, hi = np.zeros(u.size), gaps.copy()
    s = np.where((start > 0) & (start < gaps), start, 0.5 * gaps)
    eye = np.eye(u.size, dtype=bool)
    for _ in range(SECULAR_STEPS):
        d = np.where(eye, -s[:, None], apart - s[:, None])  # u_i − x_k
        f = 1.0 + np.sum(w / d, axis=1)
        slope = np.sum(w / d**2, axis=1)
        lo, hi = np.where(f < 0, s, lo), np.where(f < 0, hi, s)
        step = s - f / slope
        inside = (step > lo) & (step < hi)
        new = np.where(inside, step, np.where(lo > 0, np.sqrt(lo * hi), 0.5 * hi))
        done = np.abs(new - s) <= 4 * np.finfo(float).eps * new
        s = new
        if done.all():
            break
    d = np.where(eye, -s[:, None], apart - s[:, None])
    rates = u + s
    moduli = 1.0 / (rates * np.sum(dj * u / d**2, axis=1))
    back = np.argsort(rates)[::-1]  # ascending relaxation time
    return e_inf, moduli[back], 1.0 / rates[back]


# ── a piecewise-linear history against a kernel ──────────────────────────────────────────────


#: Tolerance on the slopes of a straight run of samples, relative to the trace's largest speed,
#: when a kink is located between two samples (:func:`locate_kinks`).
KINK_RTOL = 1e-9
#: A located kink closer to a sample than this fraction of the interval is left on the sample.
KINK_MARGIN = 1e-9


def locate_kinks(t: FloatArray, z: FloatArray) -> tuple[np.ndarray, FloatArray, FloatArray]:
    """Velocity jumps of a piecewise-linear trace that fall between two samples.

    The sample interval i (from t_i to t_i+1) holds a kink when the samples i − 2, i − 1, i lie
    on one straight line (slope a) and i + 1, i + 2, i + 3 on another (slope b ≠ a), to
    :data:`KINK_RTOL` of the trace's largest speed, and the two lines meet strictly inside the
    interval, at the fraction θ = (s_i − b)/(a − b) of it (s_i the interval's chord slope): the
    turning point of an approach–retract ramp or the end of a dwell sampled off its corner.
    Noisy traces have no such lines and keep the chord.

    Parameters
    ----------
    t, z : ndarray
        Sample times [s] (strictly increasing) and positions [m] of the trace.

    Returns
    -------
    cell : ndarray of int
        The interval index i of each kink.
    time, position : ndarray
        Its time t* [s] and position z(t*) [m].
    """
    slope = np.diff(z) / np.diff(t)
    i = np.arange(2, slope.size - 2)
    if not i.size:
        return np.empty(0, dtype=int), np.empty(0), np.empty(0)
    tol = KINK_RTOL * float(np.max(np.abs(slope)))
    a, b = slope[i - 1], slope[i + 1]
    lines = ((np.abs(slope[i - 1] - slope[i - 2]) <= tol)
             & (np.abs(slope[i + 2] - slope[i + 1]) <= tol) & (np.abs(a - b) > 100 * tol))
    with np.errstate(divide="ignore", invalid="ignore"):
        theta = (slope[i] - b) / (a - b)
    inside = lines & (theta > KINK_MARGIN) & (theta < 1 - KINK_MARGIN)
    i, a, theta = i[inside], a[inside], theta[inside]
    h = t[i + 1] - t[i]
    return i, t[i] + theta * h, z[i] + a * theta * h


def history_sums(t: FloatArray, dx: FloatArray, kernel: RelaxationKernel, soe: Exponentials,
                 base: np.ndarray, step: float | None) -> FloatArray:
    """Σ_i Δx_i/h_i [R(t_n − t_{i−1}) − R(t_n − t_i)] at the samples t_n = ``t[base]``.

    One row per history in ``dx`` (increments over the intervals of ``t``): on a uniform grid
    :func:`interval_sums` (FFT), otherwise :func:`history_nonuniform` over every node.
    """
    if step is None:
        return np.array([history_nonuniform(t, x, kernel, soe) for x in dx])[:, base]
    r = kernel.primitive
    return interval_sums(t, dx, base, step, lambda h, u: (r(u + h) - r(u)) / h)


def split_intervals(base: np.ndarray, intervals: int) -> np.ndarray:
    """The node intervals (of ``intervals``) that are not whole sample intervals of ``base``."""
    split = np.ones(intervals, dtype=bool)
    split[base[:-1][np.diff(base) == 1]] = False
    return np.flatnonzero(split)


def interval_sums(t: FloatArray, x: FloatArray, base: np.ndarray, step: float | None,
                  response: Callable[[float, FloatArray], FloatArray]) -> FloatArray:
    """Σ_i x_i·response(h_i, t_n − t_i+1) over the intervals i of ``t`` that end by t_n = t[base].

    One row per history in ``x``. On a uniform grid (``step``) the whole sample intervals are one
    FFT convolution and the pieces of an interval split by a node are added one by one; on any
    other grid every interval is added one by one (O(N²)).
    """
    nb = base.size
    out = np.zeros((x.shape[0], nb))
    pieces = np.arange(t.size - 1)
    if step is not None:
        whole = np.diff(base) == 1
        cells = np.where(whole[None, :], x[:, base[:-1]], 0.0)
        weights = response(step, step * np.arange(nb - 1))
        out[:, 1:] = fftconvolve(cells, weights[None, :], axes=1)[:, :nb - 1]
        pieces = split_intervals(base, t.size - 1)
    for i in pieces[np.any(x[:, pieces] != 0, axis=0)]:
        first = int(np.searchsorted(base, i + 1))  # the samples after the interval
        out[:, first:] += np.outer(x[:, i], response(t[i + 1] - t[i], t[base[first:]] - t[i + 1]))
    return out


def history_nonuniform(t: FloatArray, dx: FloatArray, kernel: RelaxationKernel,
                       soe: Exponentials) -> FloatArray:
    """Σ_i Δx_i/h_i [R(t_n − t_{i−1}) − R(t_n − t_i)] on any grid.

    The interval ending at t_n exactly, the earlier ones through the exponentials (their lags are
    ≥ the shortest interval).
    """
    steps = np.diff(t)
    local = dx / steps * kernel.primitive(steps)  # the interval ending at t_n
    x, c = soe.rates, soe.amplitudes
    out = np.zeros(t.size)
    state = np.zeros(x.size)  # ∫_0^{t_j} e^{−x(t_j − s)} dx/ds ds
    level = 0.0  # x(t_j) − x(t_0)
    for j in range(1, t.size):
        h = steps[j - 1]
        decay = np.exp(-x * h)
        out[j] = soe.constant * level + float(c @ (decay * state)) + local[j - 1]
        state = decay * state + dx[j - 1] / h * (-np.expm1(-x * h)) / x
        level += dx[j - 1]
    return out

