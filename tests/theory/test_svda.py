"""The SVDA ODE (paper Eqs. 17–18, viscoforce.solvers.svda_ode) and its sine sweep + lock-in
(experiments.spectroscopy.svda_sweep) against the closed forms of viscoforce.svda."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import OptimizeResult

import viscoforce as vf
import viscoforce.solvers.svda_ode as svda_ode
from viscoforce.closed_form import derjaguin_force
from viscoforce.exceptions import ConvergenceError, EffortError, ParameterError
from viscoforce.experiments.spectroscopy import svda_spectrum, svda_sweep
from viscoforce.schema import validate_spectrum
from viscoforce.solvers.svda_ode import ODE_METHODS, solve_svda
from viscoforce.svda import (
    svda_harmonic_response,
    svda_peak_phase_frequency,
    svda_ramp_deformation,
    svda_static_deformation,
)

#: The paper's Fig. 3 scene (2 nm) is deliberately evaluated with the SVDA, which warns there
#: (estimated error > 1 %, issue 15); the warning itself is tested in tests/theory/test_failure_regions.py.
pytestmark = pytest.mark.filterwarnings(
    "ignore:the SVDA is about:viscoforce.exceptions.ModelValidityWarning")


E0, E_INF, TAU = 1e10, 1e9, 1e-3
R, P, DEBYE = 10e-6, 1e7, 1e-9
KAPPA = 1.0 / DEBYE
PARAMS = dict(E0=E0, E_inf=E_INF, tau=TAU, radius=R, P=P, debye_length=DEBYE)
SURFACE = dict(radius=R, P=P, debye_length=DEBYE)
SLS = vf.StandardLinearSolid(E0=E0, E_inf=E_INF, tau=TAU)


def svda_problem(material=SLS, deepest=1.9e-9):
    """The SVDA system as a ContactProblem (one DoubleLayer; the grid is not used by the SVDA)."""
    return vf.ContactProblem.create(sphere=vf.Sphere(R), surface_force=vf.DoubleLayer(P, DEBYE),
                                    material=material, deepest_position=deepest)


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
    runs = [solve_svda(drive, **PARAMS, t_eval=t, ode_method=m, rtol=1e-10)
            for m in ODE_METHODS]
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


# ── harmonic response: ODE + sine drive + lock-in against the closed form ────────────────────

@pytest.mark.parametrize("omega_tau", [0.2, 1.17, 8.0])
def test_harmonic_ode_matches_closed_form_at_small_eta(omega_tau):
    # Measured: |Δa|/a, |Δν|/ν ≤ 2e-7, |Δχ| ≤ 4e-6°, |Δφ| ≤ 2e-6 rad, |ΔF̄|/F̄ ≤ 2e-7 (the
    # O((κη)²) = 1e-6 nonlinearity and rtol); the bounds below are the original ones.
    eta, h_bar = 1e-12, 2e-9                   # η = 1e-3 nm
    w = omega_tau / TAU
    sim = svda_sweep(svda_problem(), h_bar, eta, [w], ode_method="LSODA")
    cf = svda_harmonic_response(w, h_bar, eta, **PARAMS)
    assert sim.attrs["method"] == "svda-ode"
    assert float(sim.amplitude[0]) == pytest.approx(float(cf.amplitude), rel=1e-3)
    assert abs(float(sim.phase[0]) - float(cf.phase)) <= 0.05
    assert float(sim.deformation_amplitude[0]) == pytest.approx(float(cf.nu), rel=1e-3)
    assert abs(float(sim.deformation_phase[0]) - math.degrees(float(cf.phi))) <= 0.05
    assert float(sim.stiffness[0]) == pytest.approx(float(cf.stiffness), rel=1e-3)
    assert float(sim.mean_force[0]) == pytest.approx(cf.mean_force, rel=1e-6)
    assert float(sim.mean_deformation[0]) == pytest.approx(cf.u0, rel=1e-6)


def test_harmonic_ode_fig3_phase_peak():
    # Fig. 3 amplitude η = 0.1 nm at the SVDA peak-phase frequency: the nonlinear ODE stays
    # within 0.1° and 0.2 % of the linear closed form (9.14°).
    w0 = svda_peak_phase_frequency(2e-9, **PARAMS)
    sim = svda_sweep(svda_problem(), 2e-9, 1e-10, [w0], ode_method="LSODA")
    cf = svda_harmonic_response(w0, 2e-9, 1e-10, **PARAMS)
    assert abs(float(sim.phase[0]) - float(cf.phase)) < 0.1
    assert float(sim.amplitude[0]) == pytest.approx(float(cf.amplitude), rel=2e-3)


def test_svda_sweep_equals_svda_spectrum_and_follows_the_schema():
    # Two SVDA routes, one Spectrum convention: the ODE + lock-in and the closed form.
    problem = svda_problem()
    w = np.array([0.5, 2.0]) / TAU
    sim = svda_sweep(problem, 2e-9, 1e-12, w, periods=2, samples_per_period=32,
                     ode_method="LSODA", progress=False)
    cf = svda_spectrum(problem, 2e-9, 1e-12, w)
    validate_spectrum(sim)
    np.testing.assert_allclose(sim.stiffness, cf.stiffness, rtol=1e-3)
    np.testing.assert_allclose(sim.phase, cf.phase, atol=0.05)
    np.testing.assert_allclose(sim.mean_force, cf.mean_force, rtol=1e-6)
    assert sim.deformation_phase.attrs["units"] == "degree"
    assert np.all(sim.deformation_phase < 0) and np.all(sim.nfev > 0)
    assert sim.attrs["ode_method"] == "LSODA" and sim.attrs["settle"] == 20 * TAU


# ── raise branches ──────────────────────────────────────────────────────────────────────────────

_DRIVE = _ramp(5e-9, 0.0, 1e-3)
_T = np.linspace(0, 1e-3, 3)


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(drive=object()), "drive must provide position"),
    (dict(t_eval=[0.0, 2e-3, 1e-3]), "t_eval must be strictly increasing"),
    (dict(t_eval=[-1e-3, 0.0]), r"t_eval must start at >= 0"),
    (dict(ode_method="RK45"), r"ode_method must be one of \('Radau', 'BDF', 'LSODA'\)"),
    (dict(rtol=1e-16), r"rtol must be in \[1e-13, 0.1\]"),
    (dict(atol=0.0), "atol must be > 0"),
    (dict(E0=1e8), "E0 .* must be > E_inf"),
    (dict(P=-1.0), "P must be > 0"),
    (dict(radius=0.0), "radius must be > 0"),
    (dict(debye_length=np.nan), "debye_length must be finite"),
    (dict(u_start=np.inf), "u_start must be finite"),
    # outside the representable range (the probe found scipy ValueErrors here)
    (dict(E_inf=1e-300), r"outside the representable range: the rate scale \(E0/E_inf\)/tau = "
                         r"inf 1/s of Eq. 17 exceeds 1e\+120 1/s .*raise tau or E_inf"),
    (dict(tau=1e-300), r"outside the representable range: the rate scale .* = 1e\+301 1/s"),
    (dict(E0=1e300), r"outside the representable range: the rate scale"),
    (dict(radius=1e300), r"outside the representable range: sqrt\(8\*pi\*R/debye_length\)"
                         r"\*P/E0 = inf"),
    (dict(u_start=1e300), r"u_start is outside the representable range: u_start/debye_length = "
                          r"inf"),
])
def test_solve_svda_raises_parameter_error(kwargs, match):
    args = dict(drive=_DRIVE, t_eval=_T, **PARAMS)
    args.update(kwargs)
    drive = args.pop("drive")
    with pytest.raises(ParameterError, match=match):
        solve_svda(drive, **args)


def test_solve_svda_is_quiet_for_short_but_representable_creep_times():
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fast = solve_svda(_DRIVE, **{**PARAMS, "tau": 1e-100}, t_eval=_T)
    assert np.all(np.isfinite(fast.force))


def test_scipy_integrate_is_imported_where_it_is_used():
    # CLI start-up: `spectrum` imports this module, which must not pull in scipy.integrate
    assert not hasattr(svda_ode, "solve_ivp")


def test_solve_svda_refuses_too_many_output_times():
    with pytest.raises(EffortError, match=r"output times of solve_svda: about 1e\+07 needed"):
        solve_svda(_DRIVE, **PARAMS, t_eval=np.arange(10_000_001) * 1e-9)


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

    monkeypatch.setattr("scipy.integrate.solve_ivp", failing)  # imported where it is used
    with pytest.raises(ConvergenceError, match=r"solve_ivp \(Radau\) failed .*step size") as info:
        solve_svda(_DRIVE, **PARAMS, t_eval=_T)
    assert info.value.time == 0.0


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(problem=None), "problem must be a ContactProblem"),
    (dict(omega=[0.0]), r"omega must be > 0 rad/s; entry 0 is 0.0"),
    (dict(omega=[]), r"omega must be a non-empty 1-D array .* > 0 rad/s"),
    (dict(omega=None), r"omega must be a non-empty 1-D array"),
    (dict(omega=[np.nan]), r"omega must be .* finite"),
    (dict(eta=0.0), r"eta must be > 0 \[m\]"),
    (dict(eta=None), r"eta must be > 0 \[m\] \(finite\), got None"),
    (dict(position=np.nan), r"position must be finite \[m\]"),
    (dict(position="2nm"), r"position must be finite \[m\]"),
    (dict(position=-5e-9), "holds before contact only"),
    (dict(periods=0), "periods must be an integer >= 1"),
    (dict(samples_per_period=4), "samples_per_period must be an integer >= 8"),
    (dict(settle=-1.0), r"settle must be >= 0 \[s\]"),
    (dict(settle=np.nan), r"settle must be >= 0 \[s\].*got nan"),
    (dict(ode_method="RK45"), "ode_method must be one of"),
    (dict(rtol=0.5), r"rtol must be in \[1e-13, 0.1\]"),
    (dict(atol=-1.0), "atol must be > 0"),
    (dict(progress="yes"), "progress must be True, False or None"),
])
def test_svda_sweep_raises(kwargs, match):
    args = dict(problem=svda_problem(deepest=-6e-9), position=2e-9, eta=1e-12, omega=[1e3])
    args.update(kwargs)
    with pytest.raises(ParameterError, match=match):
        svda_sweep(args.pop("problem"), args.pop("position"), args.pop("eta"), args.pop("omega"),
                   **args)


def test_svda_sweep_needs_the_svda_material_and_law():
    prony = vf.PronySeries.from_moduli([1e10, 3e9, 1e9], [1e-4, 1e-3])
    with pytest.raises(ParameterError, match="single-relaxation-time material, got 2 modes"):
        svda_sweep(svda_problem(prony), 2e-9, 1e-12, [1e3])
    walls = vf.ContactProblem.create(sphere=vf.Sphere(R), surface_force=vf.SoftWall(1e7, 0.5e-9),
                                     material=SLS, deepest_position=1.9e-9)
    with pytest.raises(ParameterError, match="exactly one DoubleLayer term"):
        svda_sweep(walls, 2e-9, 1e-12, [1e3])


def test_svda_sweep_refuses_huge_effort_before_integrating(monkeypatch):
    import viscoforce.experiments.svda_routes as sp_module

    def forbidden(*args, **kwargs):
        raise AssertionError("integrated although the request should have been refused")

    monkeypatch.setattr(sp_module, "solve_svda", forbidden)
    # ω = 1e9 rad/s with 20τ = 20 ms settling: 3.2e6 periods, ≥ 2.5e7 steps > MAX_STEPS.
    with pytest.raises(EffortError, match=r"time steps of the SVDA ODE sweep \(1 frequency.*"
                                          r"about 2.55e\+07 needed, beyond the limit of 5e\+06"):
        svda_sweep(svda_problem(), 2e-9, 1e-12, [1e9])
    with pytest.raises(EffortError, match=r"output samples of the SVDA ODE sweep"):
        svda_sweep(svda_problem(), 2e-9, 1e-12, [1e3], settle=0.0, periods=1,
                   samples_per_period=20_000_000)
