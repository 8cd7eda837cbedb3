"""Ting's integral on piecewise-uniform grids: segments recorded at different rates (issue 41 item 1).

The piecewise-uniform path (FFT within each uniformly sampled run, the earlier runs through the
exponentials, :mod:`viscoforce.physics._ting_segments`) against three references:

* the loop over the nodes, the path every non-uniform grid took before (``sample_runs``
  switched off): equal to rounding for Prony kernels (both exact), within the power law's
  exponential-sum tolerance (1e-6 of the load) and the error estimate for the power law;
* the ramp–dwell–retract closed forms of Ting/Efremov (tests/theory/test_ting_kinks.py) on a
  grid whose step changes by 1.25× and 7.8×, the turning point between samples;
* the real JPK modulation map's curve 0 (9 segments at 7 rates), a crop of it here and the
  whole curve as a slow test.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import REAL_DATA_DIR
from tests.theory.test_ting_kinks import E0, PARABOLOID, closed_form, position
from viscoforce.physics import ting
from viscoforce.physics._ting_kernels import interval_sums
from viscoforce.physics._ting_segments import (
    BOUND,
    HISTORY,
    MIN_MEAN_RUN,
    decays,
    sample_runs,
    split_intervals,
    split_sums,
)
from viscoforce.physics.ting import (
    PowerLawRelaxation,
    PronyRelaxation,
    ting_error,
    ting_solve,
)
from viscoforce.physics.tips import Sphere

REAL_MAP = REAL_DATA_DIR / "PyFMReader" / "map-data-2021.11.05-17.37.44.432.jpk-force-map"


def segments(start, steps, lengths):
    """Times from ``start``: ``lengths[i]`` intervals of ``steps[i]`` one after the other."""
    t = [np.array([start])]
    for h, n in zip(steps, lengths, strict=True):
        t.append(t[-1][-1] + h * np.arange(1, n + 1))
    return np.concatenate(t)


def loop_path(monkeypatch, *args, **kwargs):
    """ting_solve with the runs switched off: the loop over the nodes (the path before)."""
    with monkeypatch.context() as m:
        m.setattr(ting, "sample_runs", lambda *a: None)
        return ting_solve(*args, **kwargs)


def test_sample_runs_finds_the_segments_and_refuses_scattered_grids(rng):
    t = segments(-1e-3, (1e-4, 1.25e-4, 7.8e-4), (40, 30, 20))
    runs = sample_runs(t, 1e-6)
    np.testing.assert_array_equal(runs.edges, [0, 40, 70, 90])
    np.testing.assert_allclose(runs.steps, [1e-4, 1.25e-4, 7.8e-4], rtol=1e-9)
    jittered = np.sort(np.arange(90) * 1e-4 + rng.uniform(-0.3, 0.3, 90) * 1e-4)
    assert sample_runs(jittered, 1e-6) is None  # runs of 1 interval: the loop is cheaper
    drift = np.cumsum(1e-4 * (1 + 1e-7 * np.arange(200)))  # no jump, but a spread of 2e-5
    halves = sample_runs(drift, 1e-6)
    assert halves.steps.size > 1 and np.all(np.diff(halves.edges) >= MIN_MEAN_RUN)
    for a, b in zip(halves.edges[:-1], halves.edges[1:], strict=True):
        h = np.diff(drift[a:b + 1])
        assert np.ptp(h) <= 1e-6 * h.mean()


def test_decays_drop_only_the_negligible_exponentials():
    rates = np.logspace(-3, 6, 40)
    lag = np.linspace(0, 2.0, 3001)
    full = np.exp(-np.outer(rates, lag))
    fast = decays(rates, lag)
    assert np.all((fast == full) | ((fast == 0) & (full <= np.exp(-40.0))))


#: Approach to the turning point t_a = 0.1 s between samples, dwell to t_b, retract; the step
#: changes at the turning point's neighbourhood and in the retract by the ratios of real files.
GRIDS = {
    "ratio 1.25": segments(-0.0103, (1e-4, 1.25e-4, 1e-4), (1000, 700, 1500)),
    "ratio 7.8": segments(-0.0103, (1e-4, 7.8e-4, 2e-4), (1000, 100, 1200)),
}


@pytest.mark.parametrize("grid", GRIDS)
@pytest.mark.parametrize("kernel", [PowerLawRelaxation(E0, 0.7, mu=0.1),
                                    PowerLawRelaxation(E0, 0.2),
                                    PronyRelaxation(500.0, (1000.0, 300.0), (0.01, 0.1))],
                         ids=["power-0.7-mu", "power-0.2", "prony-2"])
def test_piecewise_path_equals_the_loop_path(grid, kernel, monkeypatch):
    t = GRIDS[grid]
    z = position(t, 0.1, 0.15)
    tip = PARABOLOID[0]
    assert ting._history(t, z, 0.0, tip).runs is not None  # the path under test
    fast = ting_solve(t, z, 0.0, tip, kernel)
    loop = loop_path(monkeypatch, t, z, 0.0, tip, kernel)
    peak = np.max(fast.force)
    np.testing.assert_array_equal(fast.in_contact, loop.in_contact)
    if isinstance(kernel, PronyRelaxation):  # both exact: rounding (measured 1.2e-12, 2.2e-12)
        np.testing.assert_allclose(fast.force, loop.force, rtol=0, atol=1e-10 * peak)
        np.testing.assert_allclose(fast.t1, loop.t1, rtol=0, atol=1e-9 * t[-1])
    else:  # the loop's exponential sum at every lag: measured 3e-9 to 6e-9 of the peak
        np.testing.assert_allclose(fast.force, loop.force, rtol=0, atol=1e-6 * peak)
        estimate = ting_error(t, z, 0.0, tip, kernel)
        assert np.all(np.abs(fast.force - loop.force) <= estimate + 1e-12 * peak)


@pytest.mark.parametrize("ratio", [1.25, 7.8])
@pytest.mark.parametrize("beta", [0.3, 0.7])
def test_piecewise_grid_matches_the_closed_form_within_the_error_estimate(ratio, beta):
    # approach at h, from just before the turning point t_a = 0.1 s at ratio·h (the corner inside
    # an interval), retract back at h; the retract formula holds to the tip's departure
    h = 1e-4
    t = segments(-0.00537, (h, ratio * h, h), (1040, round(0.03 / (ratio * h)), 1000))
    z = position(t, 0.1, 0.1)
    tip, c, p = PARABOLOID
    kernel = PowerLawRelaxation(E0, beta)
    force = ting_solve(t, z, 0.0, tip, kernel).contact_force
    exact = closed_form(t, beta, c, p, 0.1, 0.1)
    estimate = ting_error(t, z, 0.0, tip, kernel)
    assert np.all(np.abs(force - exact) <= estimate + 1e-9 * exact.max())
    assert np.max(np.abs(force - exact)) < 1e-3 * exact.max()


def test_elastic_limit_is_exact_on_a_piecewise_grid():
    t = GRIDS["ratio 7.8"]
    z = position(t, 0.1, 0.15) * 30
    tip = Sphere(5e-6)
    force = ting_solve(t, z, 0.0, tip, PronyRelaxation(2000.0)).force
    hertz = 2000.0 * tip.force_shape(np.maximum(z, 0.0))
    # the retract samples do not mirror the approach's: t₁ falls inside a node interval, located
    # to 2^-30 of it (THETA_STEPS); measured 4.0e-9 of the peak, the loop path the same
    np.testing.assert_allclose(force, hertz, rtol=0, atol=1e-8 * np.max(hertz))


def test_ting_error_is_the_same_on_both_paths(monkeypatch):
    t = GRIDS["ratio 1.25"]
    z = position(t, 0.1, 0.15)
    tip, kernel = PARABOLOID[0], PowerLawRelaxation(E0, 0.5)
    fast = ting_error(t, z, 0.0, tip, kernel)
    with monkeypatch.context() as m:
        m.setattr(ting, "sample_runs", lambda *a: None)
        loop = ting_error(t, z, 0.0, tip, kernel)
    # the estimate's largest value (what a fit reports) agrees closely; sample by sample within
    # the exponential sum's tolerance of the load
    assert fast.max() == pytest.approx(loop.max(), rel=1e-3)
    peak = ting_solve(t, z, 0.0, tip, kernel).force.max()
    np.testing.assert_allclose(fast, loop, rtol=0, atol=1e-6 * peak)


def real_curve():
    if not REAL_MAP.is_file():
        pytest.skip("the real JPK modulation map is absent")
    from viscoforce.fitting.ting_model import ting_data
    from viscoforce.measured import open_data

    t, z = ting_data(open_data(REAL_MAP, raw=True), curve=0).position_trace
    return t, z


#: The best fit's structural material and contact point on curve 0 (E_ref, alpha, mu; m).
REAL_FIT = (518.3, 0.0558, 0.4975, -9.217e-6)


def _compare_real(t, z, monkeypatch):
    tip = Sphere(5e-6)
    e_ref, alpha, mu, c = REAL_FIT
    for kernel in (PowerLawRelaxation.from_structural(e_ref, alpha, mu),
                   PronyRelaxation(200.0, (500.0,), (0.05,))):
        fast = ting_solve(t, z, c, tip, kernel)
        loop = loop_path(monkeypatch, t, z, c, tip, kernel)
        estimate = ting_error(t, z, c, tip, kernel)
        peak = np.max(np.abs(fast.force))
        np.testing.assert_array_equal(fast.in_contact, loop.in_contact)
        assert np.all(np.abs(fast.force - loop.force) <= estimate + 1e-12 * peak)
        atol = (1e-10 if isinstance(kernel, PronyRelaxation) else 1e-6) * peak
        np.testing.assert_allclose(fast.force, loop.force, rtol=0, atol=atol)


def test_real_curve_crop_equals_the_loop_path(monkeypatch):
    t, z = real_curve()
    keep = slice(0, 4600)  # approach, pause and two modulation segments: 4 runs, 3 rates
    assert ting._history(t[keep], z[keep], REAL_FIT[3], Sphere(5e-6)).runs.steps.size == 4
    _compare_real(t[keep], z[keep], monkeypatch)


@pytest.mark.slow
def test_real_curve_equals_the_loop_path(monkeypatch):
    t, z = real_curve()  # 20,424 samples, 8 runs; the loop path takes ~1 s per evaluation
    _compare_real(t, z, monkeypatch)


@pytest.mark.parametrize("stencil", [HISTORY, BOUND], ids=["history", "bound"])
@pytest.mark.parametrize("kernel", [ting.PronyRelaxation(500.0, (800.0, 300.0), (1e-3, 5e-2)),
                                    ting.PowerLawRelaxation.from_structural(1e3, 0.15, 0.0)],
                         ids=["prony", "power-law"])
def test_split_intervals_through_the_exponentials_equal_them_one_by_one(stencil, kernel, rng):
    """A run's split intervals (virtual nodes in 40 of 400 sample intervals, two in one of them,
    one in the last) through the sum of exponentials beyond the shortest lag equal the exact
    one-by-one sums: to rounding for a Prony kernel (its sum is exact), within the sum's rtol
    (1e-6) for the power law (measured 9e-9 and 5e-8 of the largest sum)."""
    step, n = 1e-3, 400
    samples = np.arange(n) * step
    split = np.concatenate((np.sort(rng.choice(n - 2, 38, replace=False)), [n - 2]))
    extra = samples[split] + step * rng.uniform(0.01, 0.99, split.size)
    extra = np.append(extra, samples[split[0]] + 0.995 * step)  # a second node in one interval
    t = np.sort(np.concatenate((samples, extra)))
    base = np.searchsorted(t, samples)
    x = rng.normal(size=(3, t.size - 1))
    soe = kernel.exponentials(step, float(t[-1] - t[0]))
    response = stencil.exact(kernel.primitive)
    exact = interval_sums(t, x, base, step, response)
    pieces = split_intervals(base, t.size - 1)
    assert pieces.size == 2 * split.size + 1
    whole = x.copy()
    whole[:, pieces] = 0.0
    fast = (interval_sums(t, whole, base, step, response)
            + split_sums(t, x, base, pieces, stencil, response, soe, step))
    rtol = 1e-11 if isinstance(kernel, ting.PronyRelaxation) else 1e-6
    assert np.max(np.abs(fast - exact)) <= rtol * np.max(np.abs(exact))
