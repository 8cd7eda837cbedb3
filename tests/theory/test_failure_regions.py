"""Inside each failure region of studies/validity_maps/validity_maps.py the code raises or warns.

One small case per region (issue 15 item 2): explicit Euler above its step limit, a gap that
closes, the half-space model's own limits, an SVDA or Hertz spectrum outside its domain, a linear
spectrum at a large drive. Each test asserts the exception or warning class and a distinctive
part of its message, so a region that turns silent (or raises something else) fails.

The error-estimate warnings of the approximate spectra (SVDA 0.6 κ|u0|, Hertz contact, linear at
large κη) have their own section. The last section holds the regions the maps first found silent
(explicit Euler at its default step, the lock-in bias in contact at κη = 0.25, Hertz at a short
Debye length): each now warns (AccuracyWarning for the fixed step), or is accurate.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import viscoforce as vf
from viscoforce.exceptions import (
    AccuracyWarning,
    GapClosureError,
    ModelValidityError,
    ModelValidityWarning,
    ParameterError,
    StabilityError,
)
from viscoforce.physics.surface_forces import DoubleLayer
from viscoforce.problem import check_half_space
from viscoforce.svda import svda_complex_stiffness

R = vf.PAPER.R  # [m]
OMEGA = np.array([1e2, 1e3, 1e5])  # [rad/s]: 0.1/τ … 100/τ


def sls(ratio: float = 10.0) -> vf.StandardLinearSolid:
    return vf.StandardLinearSolid(E0=ratio * vf.PAPER.E_inf, E_inf=vf.PAPER.E_inf,
                                  tau=vf.PAPER.tau)


def problem(material, deepest: float, law=None) -> vf.ContactProblem:
    return vf.ContactProblem.create(sphere=vf.Sphere(R),
                                    surface_force=law or vf.paper_pressure_law(),
                                    material=material, deepest_position=deepest)


def euler(p, drive, t_end: float, dt: float):
    # Two output times only: the time loop lands on every output, which would cap dt.
    return vf.simulate(p, drive, t_end=t_end, t_eval=np.array([0.0, t_end]), stepper="euler",
                       dt=dt, progress=False, output_kinks=False)


def no_validity_warning(fn):
    with warnings.catch_warnings():
        warnings.simplefilter("error", ModelValidityWarning)
        return fn()


# ── explicit Euler (map 4) ───────────────────────────────────────────────────────────────────────

def test_euler_above_the_stability_limit_raises():
    # in contact the limit is ≈ 2τ·E_inf/E0 = 0.2 ms; a 0.5 ms step is refused at step 1
    p = problem(sls(), -5e-9)
    with pytest.raises(StabilityError, match="exceeds the stability limit"):
        euler(p, vf.Hold(-5e-9, 1e-3), 1e-3, 5e-4)


def test_euler_limit_scales_with_modulus_ratio():
    # at h0 = −20 nm the limit is 2.1e-4 s for E0/E_inf = 10 but 3.1e-5 s for 100
    euler(problem(sls(10.0), -20e-9), vf.Hold(-20e-9, 1e-3), 1e-3, 1e-4)  # accepted
    with pytest.raises(StabilityError, match="exceeds the stability limit"):
        euler(problem(sls(100.0), -20e-9), vf.Hold(-20e-9, 1e-3), 1e-3, 1e-4)


def test_euler_step_moving_the_gap_too_far_raises():
    # pre-contact (limit ≈ 2τ) but a 2 nm move in 0.1 ms: one 0.1 ms step moves the gap by
    # more than half a decay length
    p = problem(sls(), 3e-9)
    with pytest.raises(StabilityError, match="the gap changed by"):
        euler(p, vf.Step(5e-9, 3e-9, 1e-4), 2e-4, 1e-4)


def test_euler_step_closing_the_gap_raises():
    p = problem(sls(), -7e-9)
    with pytest.raises(GapClosureError, match="drove the gap through zero"):
        euler(p, vf.Step(-5e-9, -7e-9, 1e-4), 2e-4, 1e-4)


# ── Newton static equilibrium (map 5) ────────────────────────────────────────────────────────────

def test_newton_without_a_wall_raises_when_the_gap_closes():
    # double layer alone, stiff solid, in contact: the force cannot hold the gap open
    p = problem(vf.Elastic(1e10), -10e-9, law=DoubleLayer(vf.PAPER.P, vf.PAPER.debye_length))
    with pytest.raises(GapClosureError, match="the gap closes"):
        vf.static_equilibrium(p, -10e-9)


# ── half-space model (map 6) ─────────────────────────────────────────────────────────────────────

def test_half_space_warns_near_its_edge():
    # |u0| ≈ 100 nm = 0.01 R (and a ≈ 0.1 R) at h0 = −100 nm
    p = problem(vf.Elastic(1e9), -100e-9)
    with pytest.warns(ModelValidityWarning, match="result near the edge of the model"):
        vf.static_equilibrium(p, -100e-9)


def test_half_space_raises_beyond_its_limit():
    p = problem(vf.Elastic(1e6), -1e-6)
    with pytest.raises(ModelValidityError, match=r"result outside the model .*0\.1 R"):
        vf.static_equilibrium(p, -1e-6)


def test_grid_deeper_than_a_tenth_of_the_radius_is_refused():
    with pytest.raises(ParameterError, match=r"deepest_position must be >= -0\.1 R"):
        problem(vf.Elastic(1e9), -1.5e-6)


@pytest.mark.parametrize(("u", "a", "word"), [(0.02 * R, 0.0, "central deformation"),
                                              (0.0, 0.2 * R, "contact radius")])
def test_check_half_space_warn_thresholds(u, a, word):
    with pytest.warns(ModelValidityWarning, match=word):
        check_half_space(R, u, a)


@pytest.mark.parametrize(("u", "a", "word"), [(0.11 * R, 0.0, "central deformation"),
                                              (0.0, 0.51 * R, "contact radius")])
def test_check_half_space_error_thresholds(u, a, word):
    with pytest.raises(ModelValidityError, match=word):
        check_half_space(R, u, a)


def test_check_half_space_is_silent_inside():
    assert no_validity_warning(lambda: check_half_space(R, 0.009 * R, 0.09 * R)) == (
        pytest.approx(0.09), pytest.approx(0.009))


# ── SVDA and Hertz outside their domain (maps 1, 2) ─────────────────────────────────────────────

def test_svda_spectrum_in_contact_raises():
    p = problem(sls(), -5e-9)
    with pytest.raises(ParameterError, match="holds before contact only"):
        vf.spectrum(p, -5e-9, 1e-11, OMEGA, method="svda")


def test_svda_and_linear_are_quiet_inside_their_domain():
    # 10 nm: SVDA error 1.3e-4; κη = 0.05: linear bias ≈ 3e-4
    p = problem(sls(), 10e-9)
    no_validity_warning(lambda: vf.spectrum(p, 10e-9, 1e-11, OMEGA, method="svda"))
    no_validity_warning(lambda: vf.spectrum(p, 10e-9, 0.05e-9, OMEGA, method="linear"))
    no_validity_warning(lambda: svda_complex_stiffness(OMEGA, 10e-9, vf.PAPER.E0,
                                                       vf.PAPER.E_inf, vf.PAPER.tau, R,
                                                       vf.PAPER.P, vf.PAPER.debye_length))


# ── the approximations' error estimates (the lead adds these warnings) ───────────────────────────

def test_svda_closed_form_warns_at_4nm():
    # measured SVDA error 4.5 % at 4 nm (estimate 0.6 κ|u0| ≈ 5 %)
    with pytest.warns(ModelValidityWarning, match="the SVDA is about"):
        svda_complex_stiffness(OMEGA, 4e-9, vf.PAPER.E0, vf.PAPER.E_inf, vf.PAPER.tau, R,
                               vf.PAPER.P, vf.PAPER.debye_length)


def test_svda_spectrum_warns_at_4nm():
    p = problem(sls(), 4e-9)
    with pytest.warns(ModelValidityWarning, match="the SVDA is about"):
        vf.spectrum(p, 4e-9, 1e-11, OMEGA, method="svda")


def test_linear_spectrum_warns_at_large_kappa_eta():
    # Fig. 4 drive: κη = 1, (κη)²/8 ≈ 12 % estimated bias
    p = problem(sls(), -6e-9)
    with pytest.warns(ModelValidityWarning, match=r"kappa\*eta = 1"):
        vf.spectrum(p, -5e-9, 1e-9, OMEGA, method="linear")


def test_linear_response_warns_at_large_kappa_eta():
    from viscoforce.experiments.linear_response import linear_response

    p = problem(sls(), -6e-9)
    with pytest.warns(ModelValidityWarning, match=r"kappa\*eta = 1"):
        linear_response(p, -5e-9, 1e-9, OMEGA)


def test_contact_spectrum_warns_at_100nm():
    # measured Hertz error 6.6 % at δ0 = 100 nm over ω ≤ 100/τ
    p = problem(sls(), -100e-9)
    with pytest.warns(ModelValidityWarning, match="Hertz contact is about"):
        vf.spectrum(p, -100e-9, 1e-11, OMEGA, method="contact")


def test_contact_spectrum_before_contact_raises():
    p = problem(sls(), 2e-9)
    with pytest.raises(ModelValidityError, match="needs an indentation"):
        vf.spectrum(p, 2e-9, 1e-11, OMEGA, method="contact")


# ── regions the maps found silent at first (now warned: issue 15) ───────────────────────────────────────

def test_euler_default_step_on_fig1_warns_or_is_accurate():
    p = problem(sls(), -7e-9)
    drive, t_end = vf.Step(-5e-9, -7e-9, 1e-4), 6e-4
    t_eval = np.array([0.0, 1e-4, 3.5e-4, 6e-4])
    ref = vf.simulate(p, drive, t_end=t_end, t_eval=t_eval, progress=False,
                      output_kinks=False).force.values
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        f = vf.simulate(p, drive, t_end=t_end, t_eval=t_eval, stepper="euler", progress=False,
                        output_kinks=False).force.values
    warned = any(issubclass(w.category, AccuracyWarning) for w in caught)
    assert warned or np.max(np.abs(f - ref)) / np.max(np.abs(ref)) < 0.01


def _warned(fn):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fn()
    return result, any(issubclass(w.category, ModelValidityWarning) for w in caught)


def _kstar(ds):
    return ds.stiffness.values * np.exp(1j * np.radians(ds.phase.values))


def test_linear_spectrum_in_contact_at_kappa_eta_quarter_warns_or_is_accurate():
    h, eta, omega = -5e-9, 0.25e-9, np.array([20 / vf.PAPER.tau])
    p = problem(sls(), h - eta)
    lin, warned = _warned(lambda: vf.spectrum(p, h, eta, omega, method="linear"))
    td = vf.spectrum(p, h, eta, omega, method="time-domain", progress=False)
    error = np.max(np.abs(_kstar(lin) - _kstar(td)) / np.abs(_kstar(td)))
    assert warned or error < 0.01


def test_contact_spectrum_deep_short_debye_warns_or_is_accurate():
    from viscoforce.experiments.linear_response import linear_stiffness

    h, omega = -600e-9, np.logspace(2, 5, 13)
    p = problem(sls(), h, law=vf.paper_pressure_law(debye_length=0.3e-9))
    ds, warned = _warned(lambda: vf.spectrum(p, h, 1e-12, omega, method="contact"))
    k_exact, _ = linear_stiffness(p, h, omega)
    assert warned or np.max(np.abs(_kstar(ds) - k_exact) / np.abs(k_exact)) < 0.01


# ── SVDA time domain and SVDA fits (silent in the speed-accuracy study, now warned) ─────────────

SVDA_PARAMS = dict(E0=vf.PAPER.E0, E_inf=vf.PAPER.E_inf, tau=vf.PAPER.tau, radius=R,
                   P=vf.PAPER.P, debye_length=vf.PAPER.debye_length)


def test_svda_ode_spectrum_warns_at_2nm():
    from viscoforce.experiments.spectroscopy import svda_sweep

    with pytest.warns(ModelValidityWarning, match="the SVDA is about"):
        svda_sweep(problem(sls(), 2e-9), 2e-9, 1e-11, [1e3], periods=1, progress=False)


def test_svda_ode_into_contact_warns():
    from viscoforce.solvers.svda_ode import solve_svda

    drive = vf.Triangle(10e-9, -10e-9, 5e-6)  # the Fig. 5 loop: 56 % off, measured
    with pytest.warns(ModelValidityWarning, match="the SVDA is used in contact"):
        solve_svda(drive, **SVDA_PARAMS, t_eval=np.linspace(0.0, drive.duration, 41))


def test_svda_ramp_into_contact_warns():
    from viscoforce.svda import svda_ramp_deformation

    t = np.linspace(0.0, 4e-3, 41)  # 10 nm → −10 nm at 5 µm/s: 100 % off in contact, measured
    with pytest.warns(ModelValidityWarning, match=r"the SVDA is about .* on this ramp \(Eq. 20\)"):
        svda_ramp_deformation(t, 10e-9, -5e-6, **SVDA_PARAMS)


def test_svda_ode_before_contact_is_quiet():
    from viscoforce.solvers.svda_ode import solve_svda

    drive = vf.Ramp(20e-9, 12e-9, 1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        solve_svda(drive, **SVDA_PARAMS, t_eval=np.linspace(0.0, 1e-3, 11))
