"""Smoke test of benchmarks/bench_load.py (a 4x4 synthetic map; keys only, no timing asserted)."""

from __future__ import annotations

import csv
import json

import pytest

from tests._bench import run_benchmark

pytest.importorskip("dask.distributed")

TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "real", "synthetic",
            "summary", "files"}
SYNTHETIC_KEYS = {"archive", "reopen", "serial", "profile", "dask"}
DASK_KEYS = {"curves", "blocks", "wall_s", "read_scatter_s", "tasks_s", "concat_s",
             "cluster_startup_s", "per_curve_s", "workers", "threads", "worker_blas_threads",
             "scheduler", "open_mode", "worker_peak_rss_bytes", "workers_peak_rss_sum_bytes",
             "check", "client_peak_rss_bytes", "client_peak_rss_before_bytes",
             "total_peak_rss_bytes"}
SUMMARY_KEYS = {"wall_s", "memory_bytes", "time_passed", "memory_passed", "passed", "verdict",
                "wall_time_s", "loadavg_end"}


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_load")
    proc = run_benchmark("bench_load.py", "--quick", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout, json.loads((out / "load.json").read_text())


def test_writes_the_documented_json(report):
    _, stdout, data = report
    assert set(data) == TOP_KEYS
    assert data["schema"] == "viscoforce.bench_load/1"
    assert data["quick"] is True
    assert data["machine"]["blas_threads"] == [1]
    assert data["settings"]["grid"] == 4
    assert set(data["synthetic"]) == SYNTHETIC_KEYS
    assert set(data["synthetic"]["dask"]) == DASK_KEYS
    assert data["synthetic"]["dask"]["curves"] == 16
    assert data["synthetic"]["dask"]["worker_blas_threads"] == [1]
    assert data["synthetic"]["dask"]["check"]["ok"] is True
    assert "skipped" in data["real"]
    if not data["real"]["skipped"]:
        assert data["real"]["curves"] == 16 and data["real"]["check"]["ok"] is True
    assert set(data["summary"]) == SUMMARY_KEYS
    assert data["summary"]["verdict"] in {"PASS", "FAIL"}
    assert data["summary"]["passed"] == (data["summary"]["verdict"] == "PASS")
    assert "OPENBLAS_NUM_THREADS=1" in stdout
    assert f": {data['summary']['verdict']}" in stdout


def test_writes_csv_and_chart(report):
    out, _, data = report
    with (out / "load.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert {"part", "mode", "curves", "wall_s", "per_curve_s", "memory_bytes",
            "extrapolated"} <= set(rows[0])
    assert {r["part"] for r in rows} >= {"synthetic"}
    assert (out / "load.png").stat().st_size > 0
    assert set(data["files"]) == {"json", "csv", "png"}
