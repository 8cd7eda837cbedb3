"""Smoke test of benchmarks/bench_stream.py (maps of 4 and 16 curves; keys only, no timing asserted)."""

from __future__ import annotations

import csv
import json

import pytest

from tests._bench import run_benchmark, run_main

pytest.importorskip("dask.distributed")

TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "maps", "runs",
            "summary", "files"}
RUN_KEYS = {"command", "curves", "wall_s", "per_curve_s", "peak_bytes", "tree_peak_bytes",
            "maxrss_children_bytes", "output_bytes", "memory_passed"}
COMMAND_KEYS = {"peak_bytes", "memory_passed", "per_curve_ratio", "time_passed",
                "marginal_per_curve_s"}


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_stream")
    proc = run_benchmark("bench_stream.py", "--quick", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout, json.loads((out / "stream.json").read_text())


def test_writes_the_documented_json(report):
    _, stdout, data = report
    assert set(data) == TOP_KEYS
    assert data["schema"] == "viscoforce.bench_stream/1"
    assert data["quick"] is True
    assert data["machine"]["blas_threads"] == [1]
    assert data["settings"]["sizes"] == [4, 16]
    assert [m["curves"] for m in data["maps"]] == [4, 16]
    assert {(r["command"], r["curves"]) for r in data["runs"]} == {
        (c, n) for c in ("load", "raw", "fit") for n in (4, 16)}
    for run in data["runs"]:
        assert set(run) == RUN_KEYS
        assert run["peak_bytes"] > 0 and run["output_bytes"] > 0
    assert set(data["summary"]["commands"]) == {"load", "raw", "fit"}
    for entry in data["summary"]["commands"].values():
        assert set(entry) == COMMAND_KEYS
    assert data["summary"]["verdict"] in {"PASS", "FAIL"}
    assert data["summary"]["passed"] == (data["summary"]["verdict"] == "PASS")
    assert "OPENBLAS_NUM_THREADS=1" in stdout
    summary_lines = [line for line in stdout.splitlines() if line.startswith("summary:")]
    assert len(summary_lines) == 7
    assert all(line.endswith(("PASS", "FAIL")) for line in summary_lines)


def test_writes_csv_and_chart(report):
    out, _, data = report
    with (out / "stream.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 6 and RUN_KEYS <= set(rows[0])
    assert (out / "stream.png").stat().st_size > 0
    assert set(data["files"]) == {"json", "csv", "png"}


def test_refuses_sizes_that_are_not_squares():
    status, _, err = run_main("bench_stream.py", "--sizes", "16", "20")
    assert status == 2 and "--sizes must be at least two square numbers" in err
