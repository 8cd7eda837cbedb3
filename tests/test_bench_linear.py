"""Smoke test of benchmarks/bench_linear.py (its --quick mode; no timing asserted)."""

from __future__ import annotations

import csv
import json

import pytest

from tests._bench import run_benchmark, run_main

# documented in benchmarks/README.md, section bench_linear.py
TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "rows", "summary",
            "files"}
ROW_KEYS = {"scene", "h0", "path", "nodes", "modes", "n_omega", "mean_force", "time_median_s",
            "time_min_s", "calls_per_sample", "samples", "max_rel_error", "speedup",
            "calls_in_fit_budget"}
SUMMARY_KEYS = {"speedup_build", "speedup_cached", "worst_time_build_s", "worst_time_cached_s",
                "worst_rel_error", "accurate", "wall_time_s", "loadavg_end"}
PATHS = ["direct", "build", "build_at_load", "cached", "public_cached"]


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_linear")
    proc = run_benchmark("bench_linear.py", "--quick", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout, json.loads((out / "linear_benchmark.json").read_text())


def test_quick_run_writes_documented_files(quick):
    out, stdout, report = quick
    assert set(report) == TOP_KEYS
    assert report["schema"] == "viscoforce.bench_linear/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]  # BLAS pinned to one thread
    assert report["settings"]["n_omega"] == 30
    assert set(report["summary"]) == SUMMARY_KEYS
    assert (out / "linear_timings.png").stat().st_size > 10_000
    with (out / "linear_timings.csv").open(newline="") as fh:
        assert len(list(csv.DictReader(fh))) == len(report["rows"])
    assert "speed-up over direct (worst position)" in stdout


def test_every_path_at_both_positions_agrees_with_the_direct_solve(quick):
    _, _, report = quick
    rows = report["rows"]
    assert [(r["scene"], r["path"]) for r in rows] == [
        (s, p) for s in ("Fig. 3", "Fig. 4") for p in PATHS]
    for r in rows:
        assert set(r) == ROW_KEYS
        assert r["n_omega"] == 30 and r["samples"] == 5
        assert r["max_rel_error"] <= 1e-10, r  # deterministic; measured ≤ 2e-15
        assert r["time_median_s"] > 0  # no wall-time asserts
    assert report["summary"]["accurate"] is True
    direct = {r["scene"]: r for r in rows if r["path"] == "direct"}
    assert direct["Fig. 3"]["mean_force"] == pytest.approx(61.0e-9, rel=0.01)  # paper Fig. 3
    assert direct["Fig. 4"]["mean_force"] == pytest.approx(1.08e-6, rel=0.01)  # paper Fig. 4


def test_rejects_too_few_repeats(tmp_path):
    code, _, stderr = run_main("bench_linear.py", "--quick", "--repeats", "0", "--out",
                               str(tmp_path))
    assert code == 2
    assert "--repeats must be >= 1" in stderr
