"""Smoke test of benchmarks/bench_startup.py (--quick: one round, no warm-up; no timing asserted)."""

from __future__ import annotations

import csv
import json

import pytest

from tests._bench import run_benchmark

TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "results", "ratio",
            "extra_imports", "summary", "files"}
RESULT_KEYS = {"time_median_s", "time_min_s", "cpu_median_s", "runs"}


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_startup")
    proc = run_benchmark("bench_startup.py", "--quick", "--repeats", "1", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout, json.loads((out / "startup.json").read_text())


def test_writes_the_documented_json(report):
    _, stdout, data = report
    assert set(data) == TOP_KEYS
    assert data["schema"] == "viscoforce.bench_startup/1"
    assert data["machine"]["blas_threads"] == [1]
    assert data["settings"]["env"] == {"OPENBLAS_NUM_THREADS": "1"}
    assert data["settings"]["repeats"] == 1
    assert data["target"]["ratio"] == 1.15
    for name in ("cli", "baseline"):
        assert set(data["results"][name]) == RESULT_KEYS
        assert data["results"][name]["runs"] == 1
    assert set(data["ratio"]) == {"median", "min", "cpu_median"}
    assert data["summary"]["verdict"] in {"PASS", "FAIL"}
    assert data["summary"]["passed"] == (data["summary"]["verdict"] == "PASS")
    assert "OPENBLAS_NUM_THREADS=1" in stdout
    assert f"target <= 1.15: {data['summary']['verdict']}" in stdout


def test_writes_one_csv_row_per_run(report):
    out, _, _ = report
    with (out / "startup.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert sorted(r["command"] for r in rows) == ["baseline", "cli"]
    assert set(rows[0]) == {"round", "command", "wall_s", "cpu_s"}
