"""Tests of viscoforce.svda: the SVDA ODE (paper Eqs. 17–18) against the closed forms."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import OptimizeResult

import viscoforce.svda as svda_module
from viscoforce.closed_form import (
    derjaguin_force,
    svda_harmonic_response,
    svda_peak_phase_frequency,
    svda_ramp_deformation,
    svda_static_deformation,
)
from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.svda import solve_svda, svda_harmonic_response_ode

E0, E_INF, TAU = 1e10, 1e9, 1e-3
R, P, DEBYE = 10e-6, 1e7, 1e-9
KAPPA = 1.0 / DEBYE
PARAMS = dict(E0=E0, E_inf=E_INF, tau=TAU, radius=R, pressure=P, debye_length=DEBYE)
SURFACE = dict(radius=R, pressure=P, debye_length=DEBYE)


@dataclass(frozen=True)
class _PiecewiseLinear:
    """Local test drive: linear interpolation through (times, positions), held outside."""

    times: tuple[float, ...]
    positions: tuple[float, ...]

    @property
    def duration(self) -> float:
        return self.times[-1]

    def position(self, t):
        return np.interp(np.asarray(t, dtype=float), self.times, self.positions)

    def velocity(self, t):
        tt = np.asarray(t, dtype=float)
        slopes = np.diff(self.positions) / np.diff(self.times)
        k = np.searchsorted(self.times, tt, side="right") - 1   # right-sided at kinks
        inside = (k >= 0) & (k < len(slopes))
        return np.where(inside, slopes[np.clip(k, 0, len(slopes) - 1)], 0.0)

    def breakpoints(self):
        return np.asarray(self.times, dtype=float)


def _ramp(start, speed, duration):
    return _PiecewiseLinear((0.0, duration), (start, start + speed * duration))


@dataclass(frozen=True)
class _BadVelocity:
    """A drive whose velocity turns NaN after 0.5 ms (to exercise the finite-RHS check)."""

    duration: float = 1e-3

    def position(self, t):
        return np.full(np.shape(t), 5e-9)

    def velocity(self, t):
        return np.where(np.asarray(t) > 0.5e-3, np.nan, 0.0)

    def breakpoints(self):
        return np.array([0.0, self.duration])


# ── basic behaviour ─────────────────────────────────────────────────────────────────────────────

def test_hold_stays_at_relaxed_static_state():
    drive = _ramp(2e-9, 0.0, 5 * TAU)
    run = solve_svda(drive, **PARAMS, t_eval=np.linspace(0, 5 * TAU, 6))
    u0 = float(svda_static_deformation(2e-9, E_INF, **SURFACE))
    np.testing.assert_allclose(run.deformation, u0, rtol=1e-9)
    np.testing.assert_allclose(run.force, derjaguin_force(2e-9 - u0, **SURFACE), rtol=1e-12)
    np.testing.assert_allclose(run.gap, run.position - run.deformation, rtol=0, atol=0)
    assert run.nfev > 0


def test_relaxation_from_glassy_state_at_linearised_rate():
    # Start in the instantaneous (E0) static state; relax towards the E_inf state. Close to the
    # end the linearised Eq. 17 gives δu ∝ exp(−t (1 + rc)/((1 + c) τ)).
    h0 = 2e-9
    u_glassy = float(svda_static_deformation(h0, E0, **SURFACE))
    u_inf = float(svda_static_deformation(h0, E_INF, **SURFACE))
    t = np.linspace(0, 12 * TAU, 241)
    run = solve_svda(_ramp(h0, 0.0, 12 * TAU), **PARAMS, t_eval=t, u_start=u_glassy,
                     rtol=1e-11, atol=1e-24)
    assert run.deformation[0] == u_glassy
    np.testing.assert_allclose(run.deformation[-1], u_inf, rtol=1e-4)
    c = -KAPPA * u_inf * E_INF / E0
    rate = (1 + E0 / E_INF * c) / ((1 + c) * TAU)
    late = t > 6 * TAU
    slope = np.polyfit(t[late], np.log(np.abs(run.deformation[late] - u_inf)), 1)[0]
    assert -slope == pytest.approx(rate, rel=1e-3)


def test_methods_agree_and_t_eval_need_not_start_at_zero():
    drive = _PiecewiseLinear((0.0, 4e-3, 8e-3), (6e-9, 2e-9, 6e-9))
    t = np.linspace(1e-3, 10e-3, 10)
    runs = [solve_svda(drive, **PARAMS, t_eval=t, method=m, rtol=1e-10)
            for m in svda_module.METHODS]
    for other in runs[1:]:
        np.testing.assert_allclose(other.deformation, runs[0].deformation, rtol=1e-6)
    only_start = solve_svda(drive, **PARAMS, t_eval=[0.0])
    assert only_start.deformation[0] == pytest.approx(
        float(svda_static_deformation(6e-9, E_INF, **SURFACE)), rel=1e-14)


def test_kinks_are_respected():
    # A triangle through a kink equals two runs glued at the kink (second started from u(kink)).
    t_kink = 4e-3
    drive = _PiecewiseLinear((0.0, t_kink, 8e-3), (6e-9, 1e-9, 6e-9))
    t = np.linspace(0, 8e-3, 17)
    whole = solve_svda(drive, **PARAMS, t_eval=t, rtol=1e-11, atol=1e-24)
    first = whole.deformation[t <= t_kink][-1]
    second_drive = _ramp(1e-9, 5e-9 / 4e-3, 4e-3)
    second = solve_svda(second_drive, **PARAMS, t_eval=t[t >= t_kink] - t_kink, u_start=first,
                        rtol=1e-11, atol=1e-24)
    np.testing.assert_allclose(whole.deformation[t >= t_kink], second.deformation, rtol=1e-8)
    # Hysteresis: at the same position the material has flattened more on unloading, so the gap
    # is larger and the force smaller than on loading.
    load = np.interp(3.5e-9, drive.position(t[t <= t_kink])[::-1],
                     whole.force[t <= t_kink][::-1])
    unload = np.interp(3.5e-9, drive.position(t[t >= t_kink]), whole.force[t >= t_kink])
    assert unload < load


# ── Eq. 20 (analytic ramp) against the ODE ──────────────────────────────────────────────────────

@pytest.mark.parametrize("speed", [-1e-6, -5e-6])
def test_eq20_equals_linearised_ode(speed):
    # Eq. 17 with f dropped from the denominator and κu dropped from the exponent is Eq. 19,
    # whose solution vanishing at t = 0 is Eq. 20.
    h0, duration = 10e-9, 8e-9 / abs(speed)
    s = math.sqrt(8 * math.pi * R * P**2 / KAPPA)

    def rhs(t, u):
        f = math.sqrt(8 * math.pi * KAPPA * R * P**2 / E0**2) * math.exp(-KAPPA * (h0 + speed * t))
        u_inf = -s / E_INF * math.exp(-KAPPA * (h0 + speed * t))
        return [f * speed - (u[0] - u_inf) / TAU]

    t = np.linspace(0, duration, 9)
    ode = solve_ivp(rhs, (0, duration), [0.0], t_eval=t, rtol=1e-11, atol=1e-25, method="Radau")
    np.testing.assert_allclose(ode.y[0], svda_ramp_deformation(t, h0, speed, E0, E_INF, TAU,
                                                               **SURFACE), rtol=1e-7, atol=1e-25)


def test_eq20_valid_at_large_separation_only():
    # Paper Fig. 2: from h0 = 10 nm at −1 µm/s, Eq. 20 follows the full Eq. 17 far out and
    # overestimates |u| near contact, where κu is no longer negligible.
    speed, h0 = -1e-6, 10e-9
    t = np.linspace(0, 9e-3, 10)              # positions 10, 9, …, 1 nm
    run = solve_svda(_ramp(h0, speed, 10e-3), **PARAMS, t_eval=t, u_start=0.0, rtol=1e-10,
                     atol=1e-24)
    eq20 = svda_ramp_deformation(t, h0, speed, E0, E_INF, TAU, **SURFACE)
    rel = eq20[1:] / run.deformation[1:] - 1
    far = run.position[1:] >= 6e-9 - 1e-15
    assert np.all(np.abs(rel[far]) < 6e-3)
    assert np.all(np.diff(rel) > 0)            # the error grows monotonically towards contact
    near = run.position[1:] <= 2e-9 + 1e-15
    assert near.sum() == 2
    assert np.all(rel[near] > 0.2)             # > 20 % overestimate at 2 and 1 nm


# ── harmonic response: ODE + projection against the closed form ───────────────────────────────

@pytest.mark.parametrize("omega_tau", [0.2, 1.17, 8.0])
def test_harmonic_ode_matches_closed_form_at_small_eta(omega_tau):
    eta, h_bar = 1e-12, 2e-9                   # η = 1e-3 nm
    w = omega_tau / TAU
    sim = svda_harmonic_response_ode(w, position=h_bar, eta=eta, **PARAMS, method="LSODA")
    cf = svda_harmonic_response(w, h_bar, eta, **PARAMS)
    assert sim.amplitude == pytest.approx(float(cf.amplitude), rel=1e-3)
    assert abs(sim.phase - float(cf.phase)) <= 0.05
    assert sim.nu == pytest.approx(float(cf.nu), rel=1e-3)
    assert abs(sim.phi - float(cf.phi)) <= math.radians(0.05)
    assert sim.stiffness == pytest.approx(float(cf.stiffness), rel=1e-3)
    assert sim.mean_force == pytest.approx(cf.mean_force, rel=1e-6)
    assert sim.mean_deformation == pytest.approx(cf.u0, rel=1e-6)


def test_harmonic_ode_fig3_phase_peak():
    # Fig. 3 amplitude η = 0.1 nm at the SVDA peak-phase frequency: the nonlinear ODE stays
    # within 0.1° and 0.2 % of the linear closed form (9.14°).
    w0 = svda_peak_phase_frequency(2e-9, **PARAMS)
    sim = svda_harmonic_response_ode(w0, position=2e-9, eta=1e-10, **PARAMS, method="LSODA")
    cf = svda_harmonic_response(w0, 2e-9, 1e-10, **PARAMS)
    assert abs(sim.phase - float(cf.phase)) < 0.1
    assert sim.amplitude == pytest.approx(float(cf.amplitude), rel=2e-3)


# ── raise branches ──────────────────────────────────────────────────────────────────────────────

_DRIVE = _ramp(5e-9, 0.0, 1e-3)
_T = np.linspace(0, 1e-3, 3)


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(drive=object()), "drive must provide position"),
    (dict(t_eval=[0.0, 2e-3, 1e-3]), "t_eval must be strictly increasing"),
    (dict(t_eval=[-1e-3, 0.0]), r"t_eval must start at >= 0"),
    (dict(method="RK45"), "method must be one of"),
    (dict(rtol=1e-16), r"rtol must be in \[1e-13, 0.1\]"),
    (dict(atol=0.0), "atol must be > 0"),
    (dict(E0=1e8), "E0 .* must be > E_inf"),
    (dict(pressure=-1.0), "pressure must be > 0"),
    (dict(radius=0.0), "radius must be > 0"),
    (dict(debye_length=np.nan), "debye_length must be finite"),
    (dict(u_start=np.inf), "u_start must be finite"),
])
def test_solve_svda_raises_parameter_error(kwargs, match):
    args = dict(drive=_DRIVE, t_eval=_T, **PARAMS)
    args.update(kwargs)
    drive = args.pop("drive")
    with pytest.raises(ParameterError, match=match):
        solve_svda(drive, **args)


def test_solve_svda_raises_on_non_finite_rhs():
    with pytest.raises(ConvergenceError, match="right-hand side is not finite") as info:
        solve_svda(_BadVelocity(), **PARAMS, t_eval=_T)
    assert info.value.time > 0.5e-3


def test_solve_svda_raises_on_gap_overflow():
    with pytest.raises(ConvergenceError, match="gap collapsed"):
        solve_svda(_DRIVE, **PARAMS, t_eval=_T, u_start=1e-6)


def test_solve_svda_raises_when_solve_ivp_fails(monkeypatch):
    def failing(fun, t_span, y0, **kwargs):
        return OptimizeResult(t=np.array([t_span[0]]), y=np.array([y0]).T, status=-1, nfev=3,
                         message="Required step size is less than spacing between numbers.")

    monkeypatch.setattr(svda_module, "solve_ivp", failing)
    with pytest.raises(ConvergenceError, match=r"solve_ivp \(Radau\) failed .*step size") as info:
        solve_svda(_DRIVE, **PARAMS, t_eval=_T)
    assert info.value.time == 0.0


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(omega=0.0), "omega must be > 0"),
    (dict(eta=0.0), "eta must be > 0"),
    (dict(position=np.nan), "position must be finite"),
    (dict(periods=0), "periods must be an integer >= 1"),
    (dict(samples_per_period=4), "samples_per_period must be an integer >= 8"),
    (dict(settle_time=-1.0), "settle_time must be >= 0"),
    (dict(tau=0.0), "tau must be > 0"),
    (dict(E_inf=2e10), "E0 .* must be > E_inf"),
])
def test_harmonic_ode_raises(kwargs, match):
    args = dict(omega=1e3, position=2e-9, eta=1e-12, **PARAMS)
    args.update(kwargs)
    omega = args.pop("omega")
    with pytest.raises(ParameterError, match=match):
        svda_harmonic_response_ode(omega, **args)
