"""The map cost model (issue 22 item 3): decisions from injected costs, and what fit_map records.

Every decision is checked with given per-pixel costs and start-ups (no clock), so the tests are
deterministic; the fit_map tests check where the pixels went and the recorded attrs, never a
wall time.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from viscoforce import PAPER
from viscoforce.fitting import map_cost, maps
from viscoforce.fitting.map_cost import (
    ExecutionPlan,
    cluster_label,
    cluster_startup,
    expected_cluster,
    plan_execution,
    probe_indices,
)
from viscoforce.fitting.maps import fit_map
from viscoforce.schema import make_spectrum
from viscoforce.svda import svda_complex_stiffness

OMEGA = np.geomspace(10.0, 1e6, 20)
SVDA_FIXED = {"position": 2e-9, "radius": PAPER.R, "P": PAPER.P,
              "debye_length": PAPER.debye_length}

pytestmark = pytest.mark.filterwarnings(
    "ignore:the SVDA is about:viscoforce.exceptions.ModelValidityWarning")


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


# ── the decision, from given costs ──────────────────────────────────────────────────────────────

def test_few_or_cheap_pixels_stay_in_this_process():
    plan = plan_execution(16, 2e-3, cores=2, startup=0.3)
    assert plan.workers == 0 and plan.label == "in-process"
    assert plan.expected["in-process"] == pytest.approx(16 * 2e-3)
    assert plan.expected["local cluster (2 workers)"] > plan.expected["in-process"]
    assert plan.reason.startswith("cost model: 16 pixels x 2 ms measured; in-process expected")


def test_many_pixels_go_to_a_cluster_of_all_cores():
    plan = plan_execution(4096, 2e-3, cores=4, startup=0.3)
    assert plan.workers == 4 and plan.label == "local cluster (4 workers)"
    assert set(plan.expected) == {"in-process", *(cluster_label(w) for w in (2, 3, 4))}
    assert min(plan.expected, key=plan.expected.get) == plan.label


def test_the_break_even_follows_the_startup():
    # in-process r·c against S + r·(c + o)/(2e): the cluster wins once r·c exceeds about 2 S
    c, s = 2e-3, 1.0
    e, o = map_cost.PARALLEL_EFFICIENCY, map_cost.PIXEL_OVERHEAD
    r_even = s / (c - (c + o) / (2 * e))
    assert plan_execution(math.floor(r_even) - 1, c, cores=2, startup=s).workers == 0
    assert plan_execution(math.ceil(r_even) + 1, c, cores=2, startup=s).workers == 2
    assert plan_execution(math.ceil(r_even) + 1, c, cores=2, startup=10 * s).workers == 0


def test_slow_pixels_justify_a_cluster_for_a_small_map():
    # 16 pixels of 0.5 s: 8 s here, 2 s + 16 x 0.5 s / (2 e) on two workers
    assert plan_execution(16, 0.5, cores=2, startup=2.0).workers == 2
    assert plan_execution(16, 0.5, cores=2, startup=2.0, method="spawn").workers == 2


def test_a_tie_or_a_single_core_stays_in_this_process():
    assert plan_execution(10_000, 1.0, cores=1, startup=0.0).workers == 0
    assert plan_execution(1, 1.0, cores=2, startup=0.0).workers == 0  # never more workers
    assert plan_execution(0, 1.0, cores=2).reason == "cost model: the probe fitted every pixel"


def test_no_measured_cost_stays_in_this_process():
    plan = plan_execution(100, math.nan, cores=2, startup=0.3)
    assert plan.workers == 0 and plan.reason == "cost model: no pixel cost measured"


def test_the_startup_comes_from_the_start_method_and_the_first_cluster():
    assert cluster_startup(2, "fork") < 0.5 < 2.0 < cluster_startup(2, "spawn")
    assert cluster_startup(2, "unknown") == cluster_startup(2, "spawn")
    assert cluster_startup(2, "fork", warm=False) == pytest.approx(
        cluster_startup(2, "fork") + map_cost.FIRST_CLUSTER)
    # 400 pixels of 3 ms: forked workers pay off once a cluster has run in this process;
    # fresh interpreters never
    assert plan_execution(400, 3e-3, cores=2, method="fork", warm=True).workers == 2
    assert plan_execution(400, 3e-3, cores=2, method="fork", warm=False).workers == 0
    assert plan_execution(400, 3e-3, cores=2, method="fork").workers == 0  # cold by default
    assert plan_execution(400, 3e-3, cores=2, method="spawn", warm=True).workers == 0


def test_fit_map_tells_the_cost_model_whether_a_cluster_ran_here(monkeypatch, rng):
    seen = []

    def plan(*args, **kwargs):
        seen.append(kwargs["warm"])
        return map_cost.ExecutionPlan(0, math.nan, {}, "test")

    monkeypatch.setattr(maps, "plan_execution", plan)
    for count in (0, 1):
        monkeypatch.setattr(maps, "_local_clusters", count)
        fit_map(_svda_map(2, 2, rng), "svda", progress=False, **SVDA_FIXED)
    assert seen == [False, True]


def test_this_process_fits_while_fresh_interpreters_start():
    without = expected_cluster(1000, 1e-2, 2, 3.0)
    with_overlap = expected_cluster(1000, 1e-2, 2, 3.0, overlap=True)
    assert with_overlap == pytest.approx(without - 150 * (1e-2 + map_cost.PIXEL_OVERHEAD) / (
        2 * map_cost.PARALLEL_EFFICIENCY))  # 3 s at half speed: 150 pixels done here
    assert expected_cluster(10, 1e-2, 2, 3.0, overlap=True) == pytest.approx(3.0)


def test_start_method_is_fork_only_where_safe(monkeypatch):
    monkeypatch.setattr(map_cost.sys, "platform", "darwin")
    assert map_cost.start_method() == "spawn"
    monkeypatch.setattr(map_cost.sys, "platform", "linux")
    monkeypatch.setattr(map_cost.sys, "version_info", (3, 12, 0))
    assert map_cost.start_method() == "spawn"
    monkeypatch.setattr(map_cost.sys, "version_info", (3, 11, 7))
    assert map_cost.start_method() == ("fork" if "fork" in
                                       map_cost.multiprocessing.get_all_start_methods()
                                       else "spawn")


def test_probe_indices_spread_over_the_map_in_every_prefix():
    assert probe_indices(0) == [] and probe_indices(1) == [0] and probe_indices(3) == [0, 1, 2]
    assert probe_indices(10) == [0, 4, 2, 7, 1, 6, 3, 8, 5, 9]
    first = probe_indices(4096)
    assert len(first) == map_cost.PROBE_PIXELS == len(set(first))
    assert first[:4] == [0, 2048, 1024, 3071]
    assert sorted(probe_indices(5, count=5)) == [0, 1, 2, 3, 4]


# ── fit_map: the plan decides, the user's choice wins, the attrs say what happened ──────────────

def _plan(workers):
    def plan(pixels, pixel_cost, *, cores, warm):
        assert math.isfinite(pixel_cost) and pixel_cost > 0 and cores == maps.max_workers()
        assert warm == (maps._local_clusters > 0)
        return ExecutionPlan(workers, pixel_cost, {"in-process": 1.0, cluster_label(2): 0.5},
                             "injected")
    return plan


def test_fit_map_keeps_the_probe_and_records_an_in_process_choice(rng, monkeypatch):
    ds = _svda_map(3, 4, rng)
    monkeypatch.setattr(maps, "PROBE_SECONDS", 0.0)  # the probe stops after PROBE_MIN_PIXELS
    monkeypatch.setattr(maps, "plan_execution", _plan(0))
    result = fit_map(ds, "svda", progress=False, **SVDA_FIXED)
    serial = fit_map(ds, "svda", scheduler="synchronous", progress=False, **SVDA_FIXED)
    np.testing.assert_array_equal(result["tau"].values, serial["tau"].values)
    a = result.attrs
    assert a["execution"] == "in-process" and a["execution_reason"] == "injected"
    assert a["expected_time_s"] == 1.0 and a["pixels_in_process"] == 12
    assert a["pixel_cost_estimated_s"] > 0 and a["pixel_cost_measured_s"] > 0
    assert serial.attrs["execution"] == "in-process"
    assert serial.attrs["execution_reason"] == "scheduler='synchronous'"
    assert math.isnan(serial.attrs["pixel_cost_estimated_s"])


def test_fit_map_follows_a_cluster_choice_and_equals_the_serial_map(rng, monkeypatch):
    ds = _svda_map(2, 6, rng)
    monkeypatch.setattr(maps, "PROBE_SECONDS", 0.0)
    monkeypatch.setattr(maps, "plan_execution", _plan(2))
    result = fit_map(ds, "svda", progress=False, **SVDA_FIXED)
    serial = fit_map(ds, "svda", scheduler="synchronous", progress=False, **SVDA_FIXED)
    np.testing.assert_array_equal(result["tau"].values, serial["tau"].values)
    np.testing.assert_array_equal(result["success"].values, serial["success"].values)
    a = result.attrs
    assert a["execution"] == "local cluster (2 workers)" and a["expected_time_s"] == 0.5
    assert map_cost.PROBE_MIN_PIXELS <= a["pixels_in_process"] <= 12  # more while spawning


def test_explicit_workers_win_over_the_cost_model(rng, monkeypatch):
    def refused(*args, **kwargs):
        raise AssertionError("the cost model must not be asked")

    monkeypatch.setattr(maps, "plan_execution", refused)
    result = fit_map(_svda_map(1, 3, rng), "svda", workers=2, progress=False, **SVDA_FIXED)
    a = result.attrs
    assert a["execution"] == "local cluster (2 workers)"
    assert a["execution_reason"] == "workers=2"
    assert math.isnan(a["pixel_cost_estimated_s"]) and math.isnan(a["expected_time_s"])


def test_one_pixel_with_workers_is_one_worker(rng):
    result = fit_map(_svda_map(1, 1, rng), "svda", workers=2, progress=False, **SVDA_FIXED)
    assert result.attrs["execution"] == "local cluster (1 worker)"


def test_block_size_aims_at_a_tenth_of_a_second_and_four_tasks_per_worker():
    assert maps._block_size(4096, 2, 2e-3) == 50  # 0.1 s / 2 ms
    assert maps._block_size(4096, 2, 1e-5) == maps.MAX_BLOCK
    assert maps._block_size(40, 2, 1e-3) == 5  # 4 tasks per worker
    assert maps._block_size(4096, 2, math.nan) == maps.MAX_BLOCK
    assert maps._block_size(3, 2, 10.0) == 1


# ── the CLI leaves the choice to the cost model ─────────────────────────────────────────────────

def test_the_cli_map_fit_uses_the_cost_model(rng, tmp_path, capsys):
    import xarray as xr

    from viscoforce.cli import main

    path = tmp_path / "map.nc"
    _svda_map(2, 3, rng).to_netcdf(path)
    out = tmp_path / "fits.nc"
    assert main(["fit", str(path), "--model", "svda", "--h0", "2nm", "--json",
                 "--out", str(out)]) == 0
    capsys.readouterr()
    with xr.open_dataset(out) as fits:
        assert fits.attrs["execution"] == "in-process"  # 6 pixels: the probe fits them all
        assert fits.attrs["execution_reason"] == "cost model: the probe fitted every pixel"
        assert fits.attrs["pixels_in_process"] == 6


def test_a_blocks_results_cross_the_cluster_packed_and_come_back_the_same(rng):
    """maps._packed_results: every pixel's dict back with its keys in order, each array equal
    (dtype, shape, values) and its own memory range; failed pixels and odd arrays included."""
    from viscoforce.fitting.models import check_fixed
    from viscoforce.fitting.pixels import fit_block, pixel_data

    ds = _svda_map(2, 3, rng)
    items, _, _ = pixel_data(ds, "svda")
    results = fit_block(items, "svda", 1, "bic", check_fixed("svda", SVDA_FIXED),
                        omega=ds["omega"].values)
    results += [{"success": False, "message": "no point left"},
                {"a": np.array(1.5), "b": np.arange(4, dtype=np.int32),
                 "c": np.array(["E0", "tau"]), "d": np.zeros((0, 3)),
                 "e": np.ma.masked_array([1.0, 2.0], mask=[False, True]), "f": [1.0, 2.0]}]
    back = maps._unpacked_results(maps._packed_results(results))
    assert len(back) == len(results)
    for got, want in zip(back, results, strict=True):
        assert list(got) == list(want)
        for key, value in want.items():
            if isinstance(value, np.ndarray):
                assert type(got[key]) is type(value) and got[key].dtype == value.dtype
                assert got[key].shape == value.shape
                np.testing.assert_array_equal(got[key], value)
            else:
                np.testing.assert_equal(got[key], value)  # NaN equal to NaN, nested dicts
    first, second = back[0]["fit_k"], back[1]["fit_k"]
    before = second.copy()
    first[:] = 0.0  # a view of its own range: the next pixel's curve is untouched
    np.testing.assert_array_equal(second, before)
