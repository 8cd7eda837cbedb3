"""Smoke test of benchmarks/bench_fit.py (its --quick mode; keys and fit quality, no timing asserted).

One --quick run (module fixture) serves every test: 1 timed repeat, no warm-up, the exact model on
a 2x coarser grid, one profiled fit per profile case, the 8x8 and 4x4 maps.
"""

from __future__ import annotations

import csv
import json

import pytest

from tests._bench import run_benchmark

#: The paper's Fig. 3 scene (2 nm) is deliberately evaluated with the SVDA, which warns there
#: (estimated error > 1 %, issue 15); the warning itself is tested in tests/test_failure_regions.py.
pytestmark = pytest.mark.filterwarnings(
    "ignore:the SVDA is about:viscoforce.exceptions.ModelValidityWarning")


pytest.importorskip("dask.distributed")

# documented in benchmarks/README.md, section bench_fit.py
TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "single", "profiles",
            "maps", "summary", "files"}
CASES = {"svda", "exact1_2nm", "exact1_-5nm", "exact2_2nm", "exact2_-5nm"}
SINGLE_KEYS = {"case", "model", "modes", "position", "n_omega", "status", "time_median_s",
               "time_min_s", "cpu_median_s", "repeats", "warm_time_median_s", "nfev", "redchi",
               "chisqr", "values", "stderr", "truth", "rel_error", "error_over_stderr",
               "max_rel_error", "plain"}
PLAIN_KEYS = {"status", "time_median_s", "nfev", "chisqr", "success", "values",
              "rel_diff_to_lmfit", "max_rel_diff_to_lmfit", "rel_error", "speedup_vs_lmfit"}
PROFILE_KEYS = {"case", "total_s", "split_s", "share", "evaluations", "guess_evaluations",
                "state_calls", "state_builds", "states_s", "profiled_fit_s", "file"}
MAP_KEYS = {"map", "model", "ny", "nx", "pixels", "workers", "status", "total_s", "startup_s",
            "startup_teardown_s", "teardown_s", "fit_s", "in_cluster_s", "pixel_split_s",
            "per_pixel_s", "worker_blas_threads", "n_failed", "median_rel_error",
            "peak_rss_bytes", "peak_rss_processes", "memory_method", "client_cpu_s",
            "worker_cpu_s", "loadavg_before", "loadavg_after", "worker_core_share"}
SUMMARY_KEYS = {"svda_fit_s", "exact_1mode_fit_s", "exact_2mode_fit_s", "svda_map_s",
                "svda_map_startup_s", "svda_map_speedup", "svda_map_speedup_fit_only",
                "exact_map_s", "map_memory_bytes", "checks", "passed", "verdict", "errors",
                "wall_time_s", "loadavg_end"}


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_fit")
    proc = run_benchmark("bench_fit.py", "--quick", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout, json.loads((out / "fit_benchmark.json").read_text())


def test_quick_run_writes_documented_files(quick):
    out, stdout, report = quick
    assert set(report) == TOP_KEYS
    assert report["schema"] == "viscoforce.bench_fit/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]  # BLAS pinned to one thread
    assert report["settings"]["repeats"] == 1
    assert report["settings"]["exact_grid_factor"] == 2.0  # --quick: half the nodes
    assert (report["settings"]["svda_map"], report["settings"]["exact_map"]) == (8, 4)
    target = report["target"]
    assert (target["svda_fit_s"], target["exact_1mode_fit_s"], target["exact_2mode_fit_s"]) == (
        20e-3, 0.3, 1.0)
    assert SUMMARY_KEYS <= set(report["summary"])
    assert report["summary"]["verdict"] in {"PASS", "FAIL"}
    assert f"-> {report['summary']['verdict']}" in stdout
    # quick maps are too small for the map targets: only the single-fit targets are judged
    assert set(report["summary"]["checks"]) == {"svda_fit_s", "exact_1mode_fit_s",
                                                "exact_2mode_fit_s"}
    assert (out / "fit_timings.png").stat().st_size > 10_000
    for name, rows in (("fit_single.csv", report["single"]), ("fit_maps.csv", report["maps"])):
        with (out / name).open(newline="") as fh:
            assert len(list(csv.DictReader(fh))) == len(rows)
    assert {p["case"] for p in report["profiles"]} == {"svda", "exact1_2nm", "exact2_2nm"}
    for p in report["profiles"]:
        assert PROFILE_KEYS <= set(p)
        # the svda guess inverts its closed form (no evaluation); the exact one solves for them
        assert p["evaluations"] > p["guess_evaluations"] >= (p["case"] != "svda")
        # the exact model decomposes one static state per E_inf tried; svda never
        assert (p["state_builds"] > 0) == p["case"].startswith("exact")
        assert (out / f"fit_profile_{p['case']}.txt").stat().st_size > 0


def test_single_fits_recover_the_truth_and_agree_with_plain_least_squares(quick):
    _, _, report = quick
    rows = {r["case"]: r for r in report["single"]}
    assert set(rows) == CASES
    for case, r in rows.items():
        assert r["status"] == "ok", (case, r.get("message"))
        assert SINGLE_KEYS <= set(r)
        assert r["repeats"] == 1 and r["nfev"] > 0
        assert set(r["values"]) == set(r["truth"])
        # 1 % noise on 30 points: every parameter within 5 stderr, and the one-mode ones within
        # 10 % of the truth (deterministic: a fixed seed)
        assert max(r["error_over_stderr"].values()) < 5.0, (case, r["error_over_stderr"])
        if r["modes"] == 1:
            assert r["max_rel_error"] < 0.1, (case, r["rel_error"])
        for method in ("lm", "trf"):
            plain = r["plain"][method]
            assert PLAIN_KEYS <= set(plain)
            assert plain["status"] == "ok"
            assert plain["max_rel_diff_to_lmfit"] < 1e-3, (case, method, plain)


def test_maps_fit_every_pixel(quick):
    _, _, report = quick
    rows = {(r["map"], r["workers"]): r for r in report["maps"]}
    assert set(rows) == {("svda", 1), ("svda", 2), ("exact", 2)}
    for key, r in rows.items():
        assert r["status"] == "ok", (key, r.get("message"))
        assert MAP_KEYS <= set(r)
        assert r["n_failed"] == 0
        assert r["worker_blas_threads"] == [1]  # the workers inherit the pinned BLAS
        assert r["median_rel_error"]["tau"] < 0.1
        assert r["peak_rss_bytes"] > 0 and r["peak_rss_processes"] >= 1 + r["workers"]
    assert rows[("svda", 1)]["pixels"] == 64 and rows[("exact", 2)]["pixels"] == 16
