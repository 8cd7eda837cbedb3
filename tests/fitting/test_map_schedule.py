"""The map cost model sees the host (issue 41 item 5): decisions on injected capacities.

The host's parallel capacity is measured at decision time only where a cluster would win on
free cores by more than twice the probe's cost; these tests inject the measurement (no clock
in any assertion) and check the arithmetic against the model's formula written out here, the
stated reason, and that a map's fitted values do not depend on where it was fitted.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from viscoforce import PAPER
from viscoforce.fitting import map_cost, maps
from viscoforce.fitting.map_cost import (
    CAPACITY_PROBE_COST,
    PARALLEL_EFFICIENCY,
    PIXEL_OVERHEAD,
    ExecutionPlan,
    cluster_startup,
    measure_capacity,
    plan_execution,
    replan,
    settle_plan,
)
from viscoforce.fitting.maps import fit_map
from viscoforce.schema import make_spectrum
from viscoforce.svda import svda_complex_stiffness

OMEGA = np.geomspace(10.0, 1e6, 20)
SVDA_FIXED = {"position": 2e-9, "radius": PAPER.R, "P": PAPER.P,
              "debye_length": PAPER.debye_length}

pytestmark = pytest.mark.filterwarnings(
    "ignore:the SVDA is about:viscoforce.exceptions.ModelValidityWarning")


def _never(processes):
    raise AssertionError("the capacity must not be measured here")


def _measured(value, calls):
    def measure(processes):
        calls.append(processes)
        return value
    return measure


# ── the decision, from injected capacities ──────────────────────────────────────────────────────

def test_a_busy_host_keeps_a_map_the_free_host_would_send_to_a_cluster():
    # the case: 13 hertz curves left of 170 ms each, a warm forked cluster
    free = plan_execution(13, 0.17, cores=2, method="fork", warm=True)
    assert free.workers == 2  # on free cores the cluster wins by ≈ 0.5 s
    calls = []
    plan, capacity = settle_plan(free, _measured(0.9, calls))
    assert calls == [2] and capacity == 0.9
    assert plan.workers == 0 and plan.label == "in-process"
    s = cluster_startup(2, "fork", warm=True)
    # the model's cluster time at capacity 0.9, written out: S + r (c + o) / (min(w, C) e)
    assert plan.expected["local cluster (2 workers)"] == pytest.approx(
        s + 13 * (0.17 + PIXEL_OVERHEAD) / (0.9 * PARALLEL_EFFICIENCY), rel=1e-12)
    assert plan.expected["in-process"] == pytest.approx(13 * 0.17)
    assert "in-process expected 2.21 s" in plan.reason
    assert "measured capacity 0.90 of 2 cores" in plan.reason


def test_a_free_host_and_a_big_map_go_to_the_cluster():
    free = plan_execution(4096, 2e-3, cores=2, method="fork", warm=False)
    calls = []
    plan, capacity = settle_plan(free, _measured(2.0, calls))
    assert calls == [2] and capacity == 2.0
    assert plan.workers == 2
    s = cluster_startup(2, "fork", warm=False)
    assert plan.expected["local cluster (2 workers)"] == pytest.approx(
        s + 4096 * (2e-3 + PIXEL_OVERHEAD) / (2 * PARALLEL_EFFICIENCY), rel=1e-12)
    assert plan.reason.startswith("cost model: 4096 pixels x 2 ms measured; local cluster "
                                  "(2 workers) expected")
    assert "measured capacity 2.00 of 2 cores" in plan.reason


def test_the_break_even_capacity_follows_the_formula():
    # r c = S + r (c + o) / (C e)  ⇒  C* = r (c + o) / (e (r c − S))
    r, c = 400, 5e-3
    s = cluster_startup(2, "fork", warm=True)
    even = r * (c + PIXEL_OVERHEAD) / (PARALLEL_EFFICIENCY * (r * c - s))
    assert 1.0 < even < 2.0
    free = plan_execution(r, c, cores=2, method="fork", warm=True)
    assert replan(free, even * 0.98).workers == 0
    assert replan(free, even * 1.02).workers == 2


def test_capacity_beyond_the_workers_or_unmeasured_is_free_cores():
    free = plan_execution(4096, 2e-3, cores=2, method="fork")
    for capacity in (2.0, 3.5, math.nan):
        again = replan(free, capacity)
        assert again.workers == free.workers
        assert again.expected == pytest.approx(free.expected)
    assert "2 free cores (not measured)" in replan(free, math.nan).reason


def test_a_small_expected_gain_is_not_worth_measuring():
    # 13 exact-model pixels of 30 ms: on free cores a warm cluster saves < 2 × the probe
    free = plan_execution(13, 0.03, cores=2, method="fork", warm=True, startup=0.0)
    gain = free.expected["in-process"] - free.expected[free.label]
    assert free.workers == 2 and 0 < gain <= 2 * CAPACITY_PROBE_COST
    plan, capacity = settle_plan(free, _never)
    assert plan.workers == 0 and math.isnan(capacity)
    assert "twice the capacity probe's cost" in plan.reason


def test_in_process_plans_and_the_users_choice_are_never_measured():
    stay = plan_execution(16, 2e-3, cores=2, startup=0.3)
    assert settle_plan(stay, _never) == (stay, pytest.approx(math.nan, nan_ok=True))
    given = ExecutionPlan(2, math.nan, {}, "workers=2")
    plan, capacity = settle_plan(given, _never)
    assert plan is given and math.isnan(capacity)
    assert replan(given, 0.5) is given


def test_the_probe_asks_for_no_more_processes_than_pixels_or_its_cap():
    free = plan_execution(3, 10.0, cores=8, method="fork", warm=True)
    calls = []
    settle_plan(free, _measured(8.0, calls))
    assert calls == [3]
    # 32 cores: 8 processes probed, their share taken for all 32
    many = plan_execution(10_000, 1e-2, cores=32, method="fork", warm=True)
    calls.clear()
    plan, capacity = settle_plan(many, _measured(4.0, calls))
    assert calls == [map_cost.CAPACITY_PROBE_PROCESSES] == [8]
    assert capacity == pytest.approx(16.0)
    assert plan.workers >= 16 and "measured capacity 16.00" in plan.reason


# ── the probe itself ────────────────────────────────────────────────────────────────────────────

def test_measure_capacity_is_a_share_of_the_processes_and_leaves_none_behind():
    psutil = pytest.importorskip("psutil")
    me = psutil.Process()
    before = {p.pid for p in me.children(recursive=True)}
    capacity = measure_capacity(2, seconds=0.005)
    assert 0.0 < capacity <= 2.0
    assert {p.pid for p in me.children(recursive=True)} <= before


def test_measure_capacity_without_an_interpreter_is_nan(monkeypatch, tmp_path):
    monkeypatch.setattr(map_cost.sys, "executable", "")
    assert math.isnan(measure_capacity(2, seconds=0.001))
    monkeypatch.setattr(map_cost.sys, "executable", str(tmp_path / "no-python"))
    assert math.isnan(measure_capacity(2, seconds=0.001))


# ── fit_map: where the map was fitted does not change what was fitted ──────────────────────────

def _svda_map(ny, nx, rng):
    with warnings.catch_warnings():  # the SVDA's validity estimate at 2 nm: the truth here
        warnings.simplefilter("ignore")
        k0 = svda_complex_stiffness(OMEGA, 2e-9, PAPER.E0, PAPER.E_inf, PAPER.tau, PAPER.R,
                                    PAPER.P, PAPER.debye_length)
    k = k0 * (1 + 0.01 * rng.standard_normal((ny, nx, OMEGA.size)))
    return make_spectrum(OMEGA, k, np.full(k.shape, 1e-7), 1e-10,
                         stderr={"stiffness": 0.01 * np.abs(k),
                                 "phase": np.full(k.shape, np.degrees(0.01))},
                         dims=("y", "x", "omega"), source="synthetic")


def test_the_measured_capacity_decides_and_the_fitted_map_is_the_same(rng, monkeypatch):
    ds = _svda_map(2, 3, rng)
    real_plan = maps.plan_execution

    def free_cluster(pixels, pixel_cost, **kwargs):  # a cluster that starts for free
        return real_plan(pixels, pixel_cost, **{**kwargs, "startup": 0.0})

    monkeypatch.setattr(maps, "PROBE_SECONDS", 0.0)  # the probe stops after 3 pixels
    monkeypatch.setattr(maps, "plan_execution", free_cluster)
    monkeypatch.setattr(map_cost, "CAPACITY_PROBE_COST", 0.0)  # every gain is worth measuring
    fits = {}
    for capacity in (0.9, 2.0):
        monkeypatch.setattr(maps, "measure_capacity", lambda processes, c=capacity: c)
        fits[capacity] = fit_map(ds, "svda", progress=False, **SVDA_FIXED)
    busy, free = fits[0.9], fits[2.0]
    assert busy.attrs["execution"] == "in-process" and busy.attrs["parallel_capacity"] == 0.9
    assert free.attrs["execution"] == "local cluster (2 workers)"
    assert free.attrs["parallel_capacity"] == 2.0
    assert "measured capacity 0.90" in busy.attrs["execution_reason"]
    assert busy.attrs["pixels_in_process"] == 6 and free.attrs["pixels_in_process"] == 3
    serial = fit_map(ds, "svda", scheduler="synchronous", progress=False, **SVDA_FIXED)
    assert math.isnan(serial.attrs["parallel_capacity"])
    for other in (busy, free):  # every variable and coordinate, to the bit
        assert set(other.variables) == set(serial.variables)
        for name in serial.variables:
            np.testing.assert_array_equal(other[name].values, serial[name].values,
                                          err_msg=name)
