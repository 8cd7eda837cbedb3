"""Time integration of the slowly varying deformation approximation (SVDA), paper Eqs. 17–18.

The SVDA replaces the deformation everywhere by its central value u(t) (Eq. 15); with the
exponential double-layer pressure p(h) = P e^{−κh} this gives the scalar ODE (Eq. 17)

    u̇ = [f ḣ0 − (u − u_∞)/τ] / (1 + f),   f = sqrt(8πκR P²/E0²) e^{−κ(h0 − u)},
    u_∞ = −(E0/(E_inf κ)) f                                             (Eq. 18)

and the force F = 2πR κ⁻¹ P e^{−κ(h0 − u)} (Eq. 22). :func:`solve_svda` integrates it for any
drive satisfying :class:`viscoforce._typing.SeparationHistory`;
:func:`svda_harmonic_response_ode` runs a sine drive to steady state and extracts the first
harmonic, the time-domain check of :func:`viscoforce.closed_form.svda_harmonic_response`.

Internally the state is y = κu (dimensionless) and the time stays in seconds; the drive is
integrated piecewise between its breakpoints so that velocity jumps are never stepped across.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp

from viscoforce._typing import FloatArray, SeparationHistory
from viscoforce._validation import (
    require_finite,
    require_in_range,
    require_increasing,
    require_int,
    require_nonnegative,
    require_positive,
)
from viscoforce.closed_form import (
    _sls_moduli,
    _surface,
    derjaguin_force,
    svda_static_deformation,
)
from viscoforce.exceptions import ConvergenceError, ParameterError

__all__ = ["SVDATrajectory", "solve_svda", "SVDAHarmonicSimulation",
           "svda_harmonic_response_ode"]

METHODS = ("Radau", "BDF", "LSODA")

# Exponent −κh beyond which e^{−κh} is treated as an overflow (the SVDA state is then absurd).
_MAX_EXPONENT = 700.0
# Velocity inside a segment [a, b] is sampled at most at b − _EDGE·(b − a): the drive's velocity
# is right-sided at kinks, so sampling at b itself would pick the NEXT segment's velocity.
_EDGE = 1e-10


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
                f"SVDA right-hand side is not finite at t={t!r} s (position={h0!r} m, "
                f"velocity={v!r} m/s, kappa*u={y!r}); check the drive", time=t)
        if exponent > _MAX_EXPONENT:
            raise ConvergenceError(
                f"SVDA gap collapsed at t={t!r} s: kappa*(h0 − u) = {-exponent:.4g} makes "
                f"exp(−kappa*h) overflow; the drive is far outside the SVDA's validity", time=t)
        return self.f_prefactor * math.exp(exponent), v

    def rate(self, t: float, y: FloatArray) -> FloatArray:
        """dy/dt = κ u̇ [1/s]."""
        yy = float(y[0])
        f, v = self._state(t, yy)
        numerator = f * self.kappa * v - (yy + self.ratio * f) / self.tau
        return np.array([numerator / (1.0 + f)])

    def jacobian(self, t: float, y: FloatArray) -> FloatArray:
        """d(dy/dt)/dy [1/s]."""
        yy = float(y[0])
        f, v = self._state(t, yy)
        numerator = f * self.kappa * v - (yy + self.ratio * f) / self.tau
        d_numerator = f * self.kappa * v - (1.0 + self.ratio * f) / self.tau
        return np.array([[(d_numerator * (1.0 + f) - numerator * f) / (1.0 + f) ** 2]])


def _check_solver(method: str, rtol: float, atol: float | None,
                  debye_length: float) -> tuple[float, float]:
    if method not in METHODS:
        raise ParameterError(f"method must be one of {METHODS}, got {method!r}")
    rtol_ = require_in_range("rtol", rtol, 1e-13, 0.1)
    atol_ = 1e-12 * debye_length if atol is None else require_positive("atol", atol)
    return rtol_, atol_


def solve_svda(drive: SeparationHistory, *, E0: float, E_inf: float, tau: float, radius: float,
               pressure: float, debye_length: float, t_eval: ArrayLike,
               u_start: float | None = None, method: str = "Radau", rtol: float = 1e-8,
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
        Instantaneous modulus [Pa], >= E_inf.
    E_inf : float
        Relaxed modulus [Pa], > 0.
    tau : float
        Creep time of Eq. 3 [s], > 0.
    radius : float
        Sphere radius R [m], > 0.
    pressure : float
        Double-layer pressure amplitude P [Pa], > 0.
    debye_length : float
        Decay length 1/κ [m], > 0.
    t_eval : array_like
        Output times [s], strictly increasing, >= 0.
    u_start : float, optional
        Central deformation at t = 0 [m]; default: the E_inf static state at h0(0).
    method : {"Radau", "BDF", "LSODA"}
        ``solve_ivp`` method. Radau (default) is implicit and L-stable: Eq. 17 is stiff when
        τ is short compared with the drive time scale or f is large.
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
        If an input is out of range or ``drive`` lacks the SeparationHistory methods.
    ConvergenceError
        If ``solve_ivp`` fails, or the right-hand side becomes non-finite or overflows.
    """
    if not isinstance(drive, SeparationHistory):
        raise ParameterError(
            f"drive must provide position(t), velocity(t), duration and breakpoints() "
            f"(SeparationHistory), got {type(drive).__name__}")
    e0, e_inf, tau_ = _sls_moduli(E0, E_inf, tau)
    r, p, kappa = _surface(radius, pressure, debye_length)
    lam = float(debye_length)
    times = require_increasing("t_eval", t_eval)
    if times[0] < 0:
        raise ParameterError(f"t_eval must start at >= 0 s, got t_eval[0]={times[0]!r}")
    rtol_, atol_ = _check_solver(method, rtol, atol, lam)
    h_start = float(drive.position(0.0))
    if u_start is None:
        u0 = float(svda_static_deformation(h_start, e_inf, r, p, lam))
    else:
        u0 = require_finite("u_start", u_start)

    t_end = float(times[-1])
    inner = [float(b) for b in np.asarray(drive.breakpoints(), dtype=float).ravel()]
    inner.append(float(drive.duration))
    edges = np.unique(np.array([0.0, t_end] + [b for b in inner if 0.0 < b < t_end]))
    y_out = np.empty(times.size)
    y = kappa * u0
    y_out[times == 0.0] = y
    nfev = 0
    f_prefactor = math.sqrt(8.0 * math.pi * kappa * r) * p / e0
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        mask = (times > a) & (times <= b)
        seg_eval = np.union1d(times[mask], [b])
        rates = _SVDARates(drive, kappa, f_prefactor, e0 / e_inf, tau_, float(a),
                           float(b - _EDGE * (b - a)))
        sol = solve_ivp(rates.rate, (float(a), float(b)), [y], method=method, t_eval=seg_eval,
                        rtol=rtol_, atol=kappa * atol_, jac=rates.jacobian)
        nfev += int(sol.nfev)
        if sol.status != 0 or sol.y.shape[1] != seg_eval.size:
            t_fail = float(sol.t[-1]) if sol.t.size else float(a)
            raise ConvergenceError(
                f"solve_ivp ({method}) failed on the segment [{a:g}, {b:g}] s near "
                f"t={t_fail:g} s: {sol.message}; try method='Radau' or a looser rtol",
                time=t_fail)
        y_out[mask] = sol.y[0, :-1] if seg_eval.size > mask.sum() else sol.y[0]
        y = float(sol.y[0, -1])
    u = y_out / kappa
    position = np.asarray(drive.position(times), dtype=float)
    force = derjaguin_force(position - u, r, p, lam)
    return SVDATrajectory(time=times, position=position, deformation=u, force=force, nfev=nfev)


@dataclass(frozen=True)
class _SineDrive:
    """h0(t) = mean + eta sin(ωt) on [0, duration], held afterwards (internal helper)."""

    mean: float
    eta: float
    omega: float
    duration: float

    def position(self, t: ArrayLike) -> FloatArray:
        tt = np.minimum(np.asarray(t, dtype=float), self.duration)
        return self.mean + self.eta * np.sin(self.omega * tt)

    def velocity(self, t: ArrayLike) -> FloatArray:
        tt = np.asarray(t, dtype=float)
        v = self.eta * self.omega * np.cos(self.omega * tt)
        return np.where((tt >= 0.0) & (tt < self.duration), v, 0.0)

    def breakpoints(self) -> FloatArray:
        return np.array([0.0, self.duration])


@dataclass(frozen=True)
class SVDAHarmonicSimulation:
    """First harmonic of the simulated SVDA response to h0(t) = h̄0 + η sin ωt.

    Attributes
    ----------
    omega : float
        Angular frequency [rad/s].
    nu : float
        Deformation amplitude ν [m].
    phi : float
        Deformation phase φ relative to the drive [rad] (the paper's φ).
    amplitude : float
        Relative force amplitude a = |F1|/F̄ [1].
    phase : float
        Force phase χ [deg], SPEC convention (lead of the force over the compression).
    stiffness : float
        |F1|/η [N/m].
    mean_force : float
        F̄, mean force over the analysed periods [N].
    mean_deformation : float
        Mean central deformation over the analysed periods [m].
    """

    omega: float
    nu: float
    phi: float
    amplitude: float
    phase: float
    stiffness: float
    mean_force: float
    mean_deformation: float


def svda_harmonic_response_ode(omega: float, *, position: float, eta: float, E0: float,
                               E_inf: float, tau: float, radius: float, pressure: float,
                               debye_length: float, periods: int = 4,
                               samples_per_period: int = 64, settle_time: float | None = None,
                               method: str = "Radau", rtol: float = 1e-10,
                               atol: float | None = None) -> SVDAHarmonicSimulation:
    """Simulate a sine drive with the SVDA ODE and extract the first harmonic.

    The drive h0(t) = h̄0 + η sin ωt starts from the E_inf static state at h̄0, runs for a whole
    number of settling periods (at least ``settle_time``), then ``periods`` more periods are
    sampled uniformly and projected on e^{−iωt} with the trapezoidal rule (spectrally accurate for
    periodic samples over whole periods). The complex stiffness is the force projection divided
    by the projection of the compression −(h0 − h̄0); its angle is the SPEC phase χ.

    Parameters
    ----------
    omega : float
        Angular frequency ω [rad/s], > 0.
    position : float
        Mean position h̄0 [m].
    eta : float
        Drive amplitude η [m], > 0.
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
    periods : int
        Periods analysed after settling, >= 1.
    samples_per_period : int
        Samples per analysed period, >= 8.
    settle_time : float, optional
        Minimum settling time before the analysis [s], >= 0; default 20τ (the linearised SVDA
        transient decays at least as fast as e^{−t/τ}).
    method : {"Radau", "BDF", "LSODA"}
        ``solve_ivp`` method.
    rtol : float
        Relative tolerance, in [1e-13, 0.1].
    atol : float, optional
        Absolute tolerance on u [m]; default 1e-12·debye_length.

    Returns
    -------
    SVDAHarmonicSimulation
        ν, φ, a, χ [deg], stiffness, mean force and mean deformation.

    Raises
    ------
    ParameterError
        If an input is out of range.
    ConvergenceError
        If the time integration fails.
    """
    w = require_positive("omega", omega)
    h_mean = require_finite("position", position)
    eta_ = require_positive("eta", eta)
    _, _, tau_ = _sls_moduli(E0, E_inf, tau)
    n_periods = require_int("periods", periods, 1)
    n_samples = require_int("samples_per_period", samples_per_period, 8)
    settle = 20.0 * tau_ if settle_time is None else require_nonnegative("settle_time",
                                                                          settle_time)
    period = 2.0 * math.pi / w
    n_settle = math.ceil(settle / period)
    t_start = n_settle * period
    t_stop = (n_settle + n_periods) * period
    times = np.linspace(t_start, t_stop, n_periods * n_samples + 1)
    drive = _SineDrive(h_mean, eta_, w, t_stop)
    run = solve_svda(drive, E0=E0, E_inf=E_inf, tau=tau, radius=radius, pressure=pressure,
                     debye_length=debye_length, t_eval=times, method=method, rtol=rtol,
                     atol=atol)
    span = t_stop - t_start
    phasor = np.exp(-1j * w * times)

    def project(x: FloatArray) -> complex:
        return complex(2.0 / span * np.trapezoid(x * phasor, times))

    mean_force = float(np.trapezoid(run.force, times) / span)
    mean_u = float(np.trapezoid(run.deformation, times) / span)
    z_drive = project(run.position - h_mean)
    z_force = project(run.force - mean_force)
    z_u = project(run.deformation - mean_u)
    stiffness = z_force / -z_drive
    return SVDAHarmonicSimulation(
        omega=w,
        nu=abs(z_u),
        phi=float(np.angle(z_u / z_drive)),
        amplitude=abs(z_force) / mean_force,
        phase=float(np.degrees(np.angle(stiffness))),
        stiffness=abs(z_force) / eta_,
        mean_force=mean_force,
        mean_deformation=mean_u,
    )
