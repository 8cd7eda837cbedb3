"""Smoke test of benchmarks/bench_maps.py (--quick: the 4x4 map in-process and by the cost model,
one round; no timing asserted)."""

from __future__ import annotations

import csv
import json

import pytest

from tests._bench import run_benchmark

TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "startup", "capacity",
            "results", "checks", "summary", "files", "wall_time_s", "loadavg_end"}


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_maps")
    proc = run_benchmark("bench_maps.py", "--quick", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout, json.loads((out / "maps.json").read_text())


def test_writes_the_documented_json(report):
    _, stdout, data = report
    assert set(data) == TOP_KEYS
    assert data["schema"] == "viscoforce.bench_maps/1" and data["quick"] is True
    assert data["machine"]["blas_threads"] == [1]
    assert data["settings"]["sizes"] == [4] and data["settings"]["repeats"] == 1
    assert data["settings"]["ways"] == ["in_process", "auto"]
    assert data["target"]["cluster_64_s"] == 10.0 and data["target"]["speedup_64"] == 1.6
    assert data["startup"] is None and data["capacity"] is None  # no CLI, no cluster: --quick
    res = data["results"]["4x4"]
    assert res["pixels"] == 16
    for way in ("in_process", "auto"):
        assert {"time_median_s", "time_min_s", "runs", "executions", "n_good"} <= set(res[way])
    assert res["auto"]["executions"] == ["in-process"]  # 16 pixels: the probe fits most
    assert {"expected_time_s", "pixel_cost_estimated_s", "pixel_cost_measured_s",
            "pixels_in_process", "reasons"} <= set(res["auto"])
    assert set(data["checks"]) == {"auto_4x4"}
    assert data["summary"]["verdict"] in {"PASS", "FAIL"}
    assert f"overall: {data['summary']['verdict']}" in stdout
    assert "cost model on 4x4 (in-process)" in stdout


def test_writes_one_csv_row_per_run_and_the_chart(report):
    out, _, _ = report
    with (out / "maps.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert sorted(r["way"] for r in rows) == ["auto", "in_process"]
    assert set(rows[0]) == {"size", "pixels", "round", "way", "wall_s", "execution",
                            "cluster_startup_s", "loadavg_1min"}
    assert (out / "maps.png").stat().st_size > 0
