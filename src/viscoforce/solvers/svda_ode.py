"""Time integration of the slowly varying deformation approximation (SVDA), paper Eqs. 17–18.

The SVDA replaces the deformation everywhere by its central value u(t) (Eq. 15); with the
exponential double-layer pressure p(h) = P e^{−κh} this gives the scalar ODE (Eq. 17)

    u̇ = [f ḣ0 − (u − u_∞)/τ] / (1 + f),   f = sqrt(8πκR P²/E0²) e^{−κ(h0 − u)},
    u_∞ = −(E0/(E_inf κ)) f                                             (Eq. 18)

and the force F = 2πR κ⁻¹ P e^{−κ(h0 − u)} (Eq. 22). :func:`solve_svda` integrates it with
scipy's ``solve_ivp`` (``ode_method``) for any drive satisfying
:class:`viscoforce._typing.SeparationHistory`. Its closed forms (statics, Eq. 20 ramp, Eqs. 23–26
harmonic response) are in :mod:`viscoforce.svda`; the sine sweep with lock-in that checks them is
:func:`viscoforce.experiments.spectroscopy.svda_sweep`.

Internally the state is y = κu (dimensionless) and the time stays in seconds; the drive is
integrated piecewise between its breakpoints so that velocity jumps are never stepped across.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._limits import MAX_SAMPLES, check_effort
from viscoforce._typing import FloatArray, SeparationHistory
from viscoforce._validation import (
    require_finite,
    require_in_range,
    require_increasing,
    require_positive,
    require_sls_moduli,
)
from viscoforce.closed_form import (
    MAX_EXPONENT,
    derjaguin_force,
    require_exponential_law,
)
from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.svda import svda_static_deformation, warn_if_in_contact

__all__ = ["ODE_METHODS", "MAX_RATE", "SVDATrajectory", "solve_svda", "check_ode_settings"]

#: ``solve_ivp`` methods accepted as ``ode_method`` (implicit or stiffness-switching: Eq. 17 is
#: stiff when τ is short against the drive time scale or f is large).
ODE_METHODS = ("Radau", "BDF", "LSODA")

# Velocity inside a segment [a, b] is sampled at most at b − _EDGE·(b − a): the drive's velocity
# is right-sided at kinks, so sampling at b itself would pick the NEXT segment's velocity.
_EDGE = 1e-10

#: Largest rate scale (E0/E_inf)/τ [1/s] the integration accepts: solve_ivp's error norms square
#: the rates, which overflows a float64 beyond ≈ 1e150 1/s. (A creep time this short relaxes
#: instantly: the solid is then elastic with E_inf.)
MAX_RATE = 1e120


@dataclass(frozen=True, eq=False)
class SVDATrajectory:
    """Result of :func:`solve_svda` (arrays sampled at ``time``).

    Attributes
    ----------
    time : numpy.ndarray
        Times [s] (the requested ``t_eval``).
    position : numpy.ndarray
        Drive position h0(t) [m].
    deformation : numpy.ndarray
        Central deformation u(t) [m] (< 0 is flattening).
    force : numpy.ndarray
        SVDA force, Eq. 22 [N].
    nfev : int
        Number of right-hand-side evaluations.
    """

    time: FloatArray
    position: FloatArray
    deformation: FloatArray
    force: FloatArray
    nfev: int

    @property
    def gap(self) -> FloatArray:
        """Central surface separation h = h0 − u [m]."""
        return self.position - self.deformation


@dataclass(frozen=True)
class _SVDARates:
    """Right-hand side of Eq. 17 in y = κu, with its y-derivative, for one drive segment."""

    drive: SeparationHistory
    kappa: float       # 1/m
    f_prefactor: float  # sqrt(8πκR) P/E0 [1]
    ratio: float       # E0/E_inf [1]
    tau: float         # s
    start: float       # segment start [s]
    last: float        # latest time at which the in-segment velocity is sampled [s]

    def _state(self, t: float, y: float) -> tuple[float, float]:
        h0 = float(self.drive.position(t))
        v = float(self.drive.velocity(min(max(t, self.start), self.last)))
        exponent = y - self.kappa * h0
        if not (math.isfinite(h0) and math.isfinite(v) and math.isfinite(y)):
            raise ConvergenceError(
                f"SVDA right-hand side is not finite at t={float(t)!r} s (position={h0!r} m, "
                f"velocity={v!r} m/s, kappa*u={y!r}); check the drive", time=t)
        if exponent > MAX_EXPONENT:
            raise ConvergenceError(
                f"SVDA gap collapsed at t={float(t)!r} s: kappa*(h0 − u) = {-exponent:.4g} makes "
                f"exp(−kappa*h) overflow; the drive is far outside the SVDA's validity", time=t)
        return self.f_prefactor * math.exp(exponent), v

    def rate(self, t: float, y: FloatArray) -> FloatArray:
        """dy/dt = κ u̇ [1/s]."""
        yy = float(y[0])
        f, v = self._state(t, yy)
        numerator = f * self.kappa * v - (yy + self.ratio * f) / self.tau
        return np.array([self._finite(t, yy, numerator / (1.0 + f))])

    def jacobian(self, t: float, y: FloatArray) -> FloatArray:
        """d(dy/dt)/dy [1/s]."""
        yy = float(y[0])
        f, v = self._state(t, yy)
        numerator = f * self.kappa * v - (yy + self.ratio * f) / self.tau
        d_numerator = f * self.kappa * v - (1.0 + self.ratio * f) / self.tau
        # (d_numerator − numerator·f/(1 + f))/(1 + f): no (1 + f)² that could overflow
        return np.array([[self._finite(t, yy, (d_numerator - numerator * (f / (1.0 + f)))
                                       / (1.0 + f))]])

    def _finite(self, t: float, y: float, value: float) -> float:
        """Return ``value``, raising if the rate scale of the inputs overflowed a float64."""
        if not math.isfinite(value):
            raise ParameterError(
                f"the inputs are outside the representable range: the SVDA rate (Eq. 17) "
                f"overflows a float64 at t={float(t)!r} s (tau={self.tau!r} s, "
                f"E0/E_inf={self.ratio!r}, kappa={self.kappa!r} 1/m, kappa*u={y!r})")
        return value


def check_ode_settings(ode_method: str, rtol: float, atol: float | None,
                       debye_length: float) -> tuple[float, float]:
    """Validate the ``solve_ivp`` settings of the SVDA ODE; return (rtol, atol [m]).

    Parameters
    ----------
    ode_method : {"Radau", "BDF", "LSODA"}
        ``solve_ivp`` method (one of :data:`ODE_METHODS`).
    rtol : float
        Relative tolerance, in [1e-13, 0.1].
    atol : float or None
        Absolute tolerance on u [m], > 0; None gives 1e-12·``debye_length``.
    debye_length : float
        Decay length 1/κ [m] that scales the default ``atol``.

    Returns
    -------
    tuple of float
        ``rtol`` and ``atol`` [m].

    Raises
    ------
    ParameterError
        If a setting is out of range (the message names it and the allowed values).
    """
    if not isinstance(ode_method, str) or ode_method not in ODE_METHODS:
        raise ParameterError(f"ode_method must be one of {ODE_METHODS}, got {ode_method!r}")
    rtol_ = require_in_range("rtol", rtol, 1e-13, 0.1)
    atol_ = 1e-12 * debye_length if atol is None else require_positive("atol", atol)
    return rtol_, atol_


def solve_svda(drive: SeparationHistory, *, E0: float, E_inf: float, tau: float, radius: float,
               P: float, debye_length: float, t_eval: ArrayLike,
               u_start: float | None = None, ode_method: str = "Radau", rtol: float = 1e-8,
               atol: float | None = None) -> SVDATrajectory:
    """Integrate the SVDA ODE (paper Eqs. 17–18) along a prescribed drive.

    The integration runs from t = 0 to ``t_eval[-1]``, piecewise between the drive's breakpoints
    (velocity jumps are never stepped across), with scipy's ``solve_ivp`` and the analytic
    Jacobian. It starts from the relaxed (E_inf) SVDA static state at h0(0) unless ``u_start`` is
    given.

    Parameters
    ----------
    drive : SeparationHistory
        Position h0(t) [m] and velocity [m/s], with ``duration`` [s] and ``breakpoints()`` [s].
    E0 : float
        Instantaneous modulus [Pa], > E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time of Eq. 3 [s], > 0.
    radius : float
        Sphere radius R [m], > 0.
    P : float
        Double-layer pressure amplitude P [Pa] of p(h) = P e^{−κh}, > 0.
    debye_length : float
        Decay length 1/κ [m], > 0.
    t_eval : array_like
        Output times [s], strictly increasing, >= 0 (at most ``MAX_SAMPLES``).
    u_start : float, optional
        Central deformation at t = 0 [m]; default: the E_inf static state at h0(0).
    ode_method : {"Radau", "BDF", "LSODA"}
        ``solve_ivp`` method (:data:`ODE_METHODS`). Radau (default) is implicit and L-stable:
        Eq. 17 is stiff when τ is short compared with the drive time scale or f is large.
    rtol : float
        Relative tolerance, in [1e-13, 0.1].
    atol : float, optional
        Absolute tolerance on u [m], > 0; default 1e-12·debye_length.

    Returns
    -------
    SVDATrajectory
        Time, position, deformation u(t), force (Eq. 22) and the evaluation count.

    Raises
    ------
    ParameterError
        If an input is out of range, ``drive`` lacks the SeparationHistory methods, or the inputs
        are outside the representable range (the rate scale (E0/E_inf)/τ above
        :data:`MAX_RATE`, κ·u_start or the prefactor of f overflowing a float64).
    EffortError
        If ``t_eval`` holds more than :data:`~viscoforce._limits.MAX_SAMPLES` times.
    ConvergenceError
        If ``solve_ivp`` fails, or the right-hand side becomes non-finite or overflows.
    """
    if not isinstance(drive, SeparationHistory):
        raise ParameterError(
            f"drive must provide position(t), velocity(t), duration and breakpoints() "
            f"(SeparationHistory), got {type(drive).__name__}")
    from scipy.integrate import solve_ivp  # here, not at import: keeps the CLI start-up fast

    e0, e_inf, tau_ = require_sls_moduli(E0, E_inf, tau)
    r, p, kappa = require_exponential_law(radius, P, debye_length)
    lam = float(debye_length)
    ratio = e0 / e_inf
    f_prefactor = math.sqrt(8.0 * math.pi * kappa * r) * p / e0
    if not math.isfinite(f_prefactor):
        raise ParameterError(
            f"the inputs are outside the representable range: sqrt(8*pi*R/debye_length)*P/E0 "
            f"= {f_prefactor!r} overflows a float64 (radius={radius!r} m, P={P!r} Pa, "
            f"debye_length={debye_length!r} m, E0={E0!r} Pa)")
    if not max(1.0, ratio) / tau_ <= MAX_RATE:
        raise ParameterError(
            f"the inputs are outside the representable range: the rate scale (E0/E_inf)/tau = "
            f"{max(1.0, ratio) / tau_:.3g} 1/s of Eq. 17 exceeds {MAX_RATE:g} 1/s (E0={E0!r} "
            f"Pa, E_inf={E_inf!r} Pa, tau={tau!r} s): raise tau or E_inf (a solid that relaxes "
            f"this fast is elastic with E = E_inf)")
    times = require_increasing("t_eval", t_eval)
    if times[0] < 0:
        raise ParameterError(f"t_eval must start at >= 0 s, got t_eval[0]={times[0]!r}")
    check_effort("output times of solve_svda", times.size, MAX_SAMPLES,
                 hint="request fewer output times")
    rtol_, atol_ = check_ode_settings(ode_method, rtol, atol, lam)
    h_start = float(drive.position(0.0))
    if u_start is None:
        u0 = float(svda_static_deformation(h_start, e_inf, r, p, lam))
    else:
        u0 = require_finite("u_start", u_start)
    if not math.isfinite(kappa * u0):
        raise ParameterError(
            f"u_start is outside the representable range: u_start/debye_length = "
            f"{kappa * u0!r} overflows a float64 (u_start={u_start!r} m, "
            f"debye_length={debye_length!r} m)")

    t_end = float(times[-1])
    inner = [float(b) for b in np.asarray(drive.breakpoints(), dtype=float).ravel()]
    inner.append(float(drive.duration))
    edges = np.unique(np.array([0.0, t_end] + [b for b in inner if 0.0 < b < t_end]))
    y_out = np.empty(times.size)
    y = kappa * u0
    y_out[times == 0.0] = y
    nfev = 0
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        mask = (times > a) & (times <= b)
        seg_eval = np.union1d(times[mask], [b])
        rates = _SVDARates(drive, kappa, f_prefactor, ratio, tau_, float(a),
                           float(b - _EDGE * (b - a)))
        try:
            with np.errstate(over="raise", invalid="raise"):
                sol = solve_ivp(rates.rate, (float(a), float(b)), [y], method=ode_method,
                                t_eval=seg_eval, rtol=rtol_, atol=kappa * atol_,
                                jac=rates.jacobian)
        except FloatingPointError as exc:
            raise ConvergenceError(
                f"solve_ivp ({ode_method}) overflowed on the segment [{a:g}, {b:g}] s ({exc}); "
                f"the inputs are probably outside the representable range", time=float(a)
            ) from None
        nfev += int(sol.nfev)
        if sol.status != 0 or sol.y.shape[1] != seg_eval.size:
            t_fail = float(sol.t[-1]) if sol.t.size else float(a)
            raise ConvergenceError(
                f"solve_ivp ({ode_method}) failed on the segment [{a:g}, {b:g}] s near "
                f"t={t_fail:g} s: {sol.message}; try ode_method='Radau' or a looser rtol",
                time=t_fail)
        y_out[mask] = sol.y[0, :-1] if seg_eval.size > mask.sum() else sol.y[0]
        y = float(sol.y[0, -1])
    u = y_out / kappa
    position = np.asarray(drive.position(times), dtype=float)
    force = derjaguin_force(position - u, r, p, lam)
    warn_if_in_contact(position - u, lam, "the SVDA ODE")
    return SVDATrajectory(time=times, position=position, deformation=u, force=force, nfev=nfev)
