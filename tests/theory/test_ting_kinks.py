"""Ting's integral where the indentation's velocity jumps between two samples (issue 37 item 6).

An approach–retract triangle whose turning point, or a dwell whose two ends, fall between samples:
the sampled chord cuts the corner, and against a power-law kernel E(t) = E0 (t/t0)^−β (an
integrable singularity at zero lag) that cut weighs ~(h/T)^(1−β) of the load: 0.08–0.18 of the
peak at β = 0.7 on the sample after the kink before the kinks were located. Oracles, for g = C δ^p
(Ting 1966; Efremov et al. 2017), δ = v t up to t_a, held to t_b, then v(t_a + t_b − t)
(t_a = t_b: the triangle):

* loading branch (t ≤ t_b): F = E0 t0^β C p v^p t^{p−β} B(min(t, t_a)/t; p, 1 − β)
  (B(x; a, b) the incomplete beta function, not regularised);
* retract: Ting's ∫_{t₁}^{t} E(t − s) dδ = 0 gives (t − t₁)^{1−β} = (t − t_a)^{1−β} + (t − t_b)^{1−β},
  and F is the loading formula with t₁ in place of t_a (0 once t₁ ≤ 0: the tip has left);
* the flat punch (g = a δ, the approach formula throughout, clipped at 0):
  F = a v E0 t0^β/(1 − β)·[t^{1−β} − (t − t_a)^{1−β} − (t − t_b)^{1−β}].
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.special import beta as beta_function
from scipy.special import betainc

from viscoforce.physics.ting import (
    PowerLawRelaxation,
    PronyRelaxation,
    locate_kinks,
    ting_error,
    ting_force,
    ting_solve,
)
from viscoforce.physics.tips import Cone, Flat, Paraboloid

R = 5e-6
V = 10e-6  # ramp speed [m/s]
E0 = 1000.0
PARABOLOID = (Paraboloid(R), 2 / 3 * math.sqrt(R), 1.5)  # tip, C, p of g = C δ^p
CONE = (Cone.from_degrees(20), math.tan(math.radians(20)) / math.pi, 2.0)


def position(t, t_a, t_b):
    """δ = z: v t, held at v t_a from t_a to t_b, then v(t_a + t_b − t) (contact point 0)."""
    return np.where(t <= t_a, V * t, np.where(t <= t_b, V * t_a, V * (t_a + t_b - t)))


def closed_form(t, beta, c, p, t_a, t_b):
    out = np.zeros_like(t)
    pre = E0 * c * p * V**p * beta_function(p, 1 - beta)
    for i, ti in enumerate(t):
        if ti <= 0:
            continue
        if ti <= t_b:
            t1 = min(ti, t_a)
        else:
            t1 = ti - ((ti - t_a) ** (1 - beta) + (ti - t_b) ** (1 - beta)) ** (1 / (1 - beta))
        if t1 > 0:
            out[i] = pre * ti ** (p - beta) * betainc(p, 1 - beta, t1 / ti)
    return out


def grid(samples_per_ramp, fraction, t_a=0.1, end=0.3):
    """Uniform samples, h = t_a/samples_per_ramp, offset by ``fraction`` of h: every corner and
    the first contact (t = 0) fall inside a sample interval."""
    h = t_a / samples_per_ramp
    return (np.arange(-5, round(end / h)) + fraction) * h


@pytest.mark.parametrize(("tip", "c", "p"), [PARABOLOID, CONE])
@pytest.mark.parametrize("beta", [0.4, 0.7])
@pytest.mark.parametrize("fraction", [0.1, 0.5, 0.85])
def test_turning_point_between_samples_matches_the_closed_form(tip, c, p, beta, fraction):
    t = grid(1000, fraction)
    z = position(t, 0.1, 0.1)
    kernel = PowerLawRelaxation(E0, beta)
    force = ting_solve(t, z, 0.0, tip, kernel).contact_force
    exact = closed_form(t, beta, c, p, 0.1, 0.1)
    peak = exact.max()
    after = int(np.searchsorted(t, 0.1))  # the first sample past the turning point
    # measured (1000 samples per ramp), of the peak, at the sample after the kink: ≤ 1.7e-6
    # (paraboloid) and ≤ 3.8e-6 (cone), below the error just before it (the first contact's
    # tail, ≤ 4.8e-5); on the whole retract ≤ 3.8e-6
    assert abs(force[after] - exact[after]) < 1e-5 * peak
    assert np.max(np.abs(force - exact)[t > 0.1]) < 1e-5 * peak
    # the largest error is the first contact's (g ∝ δ^p linear between nodes against t^−β):
    # 7.8e-4 of the peak for the paraboloid at β = 0.7, ≤ 5.3e-5 otherwise
    assert np.max(np.abs(force - exact)) < 1e-3 * peak


@pytest.mark.parametrize("beta", [0.4, 0.7])
@pytest.mark.parametrize("fraction", [0.2, 0.6])
def test_dwell_ends_between_samples_match_the_closed_form(beta, fraction):
    tip, c, p = PARABOLOID
    t = grid(1000, fraction, end=0.35)
    z = position(t, 0.1, 0.15)
    kernel = PowerLawRelaxation(E0, beta)
    _, at, _ = locate_kinks(t, z)
    np.testing.assert_allclose(at, [0.1, 0.15], rtol=1e-9)
    force = ting_force(t, z, 0.0, tip, kernel)
    exact = closed_form(t, beta, c, p, 0.1, 0.15)
    peak = exact.max()
    # measured: ≤ 3.9e-6 of the peak after the dwell's start, ≤ 3.5e-8 after its end, ≤ 7.3e-7
    # on the retract
    for corner in (0.1, 0.15):
        after = int(np.searchsorted(t, corner))
        assert abs(force[after] - exact[after]) < 1e-5 * peak
    assert np.max(np.abs(force - exact)[t > 0.15]) < 1e-5 * peak


def test_flat_punch_turning_point_between_samples():
    tip = Flat(2e-6)
    t = grid(500, 0.4)
    z = position(t, 0.1, 0.1)
    beta = 0.6
    kernel = PowerLawRelaxation(E0, beta)
    a = float(tip.force_shape(1.0))  # g = a δ
    lag = np.maximum(t, 0.0)
    exact = a * V * E0 / (1 - beta) * (lag ** (1 - beta)
                                        - 2 * np.maximum(t - 0.1, 0.0) ** (1 - beta))
    exact = np.maximum(exact, 0.0)
    force = ting_force(t, z, 0.0, tip, kernel)
    # exact for a flat punch (g linear in δ, δ linear between nodes): measured 1e-13 of the peak
    np.testing.assert_allclose(force, exact, rtol=0, atol=1e-9 * exact.max())


def test_nonuniform_grid_with_a_kink_between_samples(rng):
    tip, c, p = PARABOLOID
    h = 1e-4
    t = np.arange(-5, 3000) * h + rng.uniform(-0.3, 0.3, 3005) * h
    t[np.abs(t - 0.1) < 0.35 * h] = 0.1 + 0.37 * h  # no sample at the turning point
    t = np.sort(t)
    z = position(t, 0.1, 0.1)
    kernel = PowerLawRelaxation(E0, 0.7)
    force = ting_force(t, z, 0.0, tip, kernel)
    exact = closed_form(t, 0.7, c, p, 0.1, 0.1)
    after = int(np.searchsorted(t, 0.1))
    # the loop path (non-uniform): measured 5.1e-7 of the peak after the kink, 6.2e-7 on the retract
    assert abs(force[after] - exact[after]) < 1e-5 * exact.max()
    assert np.max(np.abs(force - exact)[t > 0.1]) < 1e-5 * exact.max()


def test_the_fft_path_equals_the_loop_path_with_kinks_and_crossings(monkeypatch):
    from viscoforce.physics import ting

    t = grid(400, 0.37, end=0.35)
    z = position(t, 0.1, 0.15) - 3e-8  # contact point crossed between samples, both ways
    tip = PARABOLOID[0]
    kernel = PowerLawRelaxation(E0, 0.5, mu=0.1)
    fast = ting_solve(t, z, 0.0, tip, kernel)
    monkeypatch.setattr(ting, "UNIFORM_RTOL", -1.0)  # every grid takes the general path
    loop = ting_solve(t, z, 0.0, tip, kernel)
    # the exponential sum's 1e-6 tolerance on the history; measured 3e-9 of the peak
    np.testing.assert_allclose(fast.force, loop.force, rtol=0, atol=1e-6 * fast.force.max())
    np.testing.assert_array_equal(fast.in_contact, loop.in_contact)


def test_locate_kinks_finds_corners_between_samples_only(rng):
    t = grid(50, 0.3)
    z = position(t, 0.1, 0.15)
    cell, at, where = locate_kinks(t, z)
    np.testing.assert_allclose(at, [0.1, 0.15], rtol=1e-12)
    np.testing.assert_allclose(where, V * 0.1, rtol=1e-12)
    assert np.all((t[cell] < at) & (at < t[cell + 1]))
    on_grid = np.arange(0, 31) * 0.01  # the corners are samples: nothing to locate
    assert locate_kinks(on_grid, position(on_grid, 0.1, 0.15))[0].size == 0
    noisy = z + 1e-12 * rng.standard_normal(t.size)
    assert locate_kinks(t, noisy)[0].size == 0  # no straight runs: the chord stays


@pytest.mark.parametrize("beta", [0.2, 0.7])
@pytest.mark.parametrize("fraction", [0.1, 0.5, 0.9])
def test_ting_error_bounds_the_error_everywhere(beta, fraction):
    tip, c, p = PARABOLOID
    t = grid(250, fraction, end=0.25)
    z = position(t, 0.1, 0.1)
    kernel = PowerLawRelaxation(E0, beta)
    exact = closed_form(t, beta, c, p, 0.1, 0.1)
    error = np.abs(ting_force(t, z, 0.0, tip, kernel) - exact)
    estimate = ting_error(t, z, 0.0, tip, kernel)
    # measured min estimate/error 1.29 (β = 0.7, at the first contact, where the every-other-
    # sample comparison alone gave 0.59); at the sample after the turning point 9–90
    assert np.all(estimate + 1e-12 * exact.max() >= error)  # 1e-12: the FFT's round-off
    after = int(np.searchsorted(t, 0.1))
    assert estimate[after] >= error[after] > 0


@pytest.mark.parametrize("fraction", [0.3, 0.8])
def test_ting_error_bounds_a_kink_it_cannot_locate(fraction):
    """A smooth 1e-4 ripple on the ramps: no straight runs, the turning point stays unlocated."""
    tip = PARABOLOID[0]
    kernel = PowerLawRelaxation(E0, 0.7)

    def trace(times):
        return position(times, 0.1, 0.1) + 1e-10 * np.sin(2 * np.pi * times / 0.13)

    t = grid(250, fraction, end=0.2)
    assert locate_kinks(t, trace(t))[0].size == 0
    fine = np.arange(round(t[0] / 6.25e-6), round(t[-1] / 6.25e-6) + 1) * 6.25e-6  # 64× finer
    reference = np.interp(t, fine, ting_force(fine, trace(fine), 0.0, tip, kernel))
    error = np.abs(ting_force(t, trace(t), 0.0, tip, kernel) - reference)
    estimate = ting_error(t, trace(t), 0.0, tip, kernel)
    after = int(np.searchsorted(t, 0.1))
    # measured: the error 0.18 (fraction 0.3) and 0.06 (0.8) of the peak on the sample after the
    # kink, the estimate 1.005× and 3.1× it (the bound is attained by a kink there); the
    # every-other-sample comparison alone gave 0.3–0.4×
    assert error[after] > 0.03 * reference.max()
    near = slice(after - 3, after + 6)
    assert np.all(estimate[near] >= error[near])


def test_prony_kernel_turning_point_between_samples():
    from scipy.optimize import brentq
    from scipy.special import dawsn

    tip, c, _ = PARABOLOID
    e_inf, e1, rho = 1000.0, 20000.0, 0.002  # a fast mode: 10 samples per relaxation time
    kernel = PronyRelaxation(e_inf, (e1,), (rho,))

    def load(t1, tn):
        x1 = t1 / rho
        return (e_inf * c * (V * t1) ** 1.5 + 1.5 * e1 * c * V**1.5 * rho**1.5
                * math.exp(-(tn - t1) / rho) * (math.sqrt(x1) - dawsn(math.sqrt(x1))))

    def condition(t1, tn):
        back = math.exp(-(tn - 0.1) / rho)
        return (e_inf * ((0.1 - t1) - (tn - 0.1))
                + e1 * rho * ((back - math.exp(-(tn - t1) / rho)) - (1 - back)))

    t = grid(500, 0.45, end=0.25)
    exact = np.zeros_like(t)
    for i, tn in enumerate(t):
        if 0 < tn <= 0.1:
            exact[i] = load(tn, tn)
        elif tn > 0.1 and condition(0.0, tn) > 0:
            exact[i] = load(brentq(condition, 0.0, 0.1, args=(tn,), xtol=1e-16), tn)
    force = ting_force(t, position(t, 0.1, 0.1), 0.0, tip, kernel)
    # measured, of the peak: 2.2e-6 on the retract (the chord across the corner: 8.9e-4)
    assert np.max(np.abs(force - exact)[t > 0.1]) < 1e-5 * exact.max()
    assert np.max(np.abs(force - exact)) < 1e-4 * exact.max()  # 2.1e-5, at the first contact
