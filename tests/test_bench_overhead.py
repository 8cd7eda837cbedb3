"""Smoke test of benchmarks/bench_overhead.py (its --quick mode; no timing asserted)."""

from __future__ import annotations

import csv
import json

import pytest

from tests._bench import run_benchmark

# documented in benchmarks/README.md, section bench_overhead.py
TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "cases", "summary",
            "files"}
CASE_KEYS = {"case", "model", "modes", "points", "floor_nfev", "library_nfev", "profiled",
             "samples", "target_ratio", "passed"} | {
    f"{path}_{what}" for path in ("library", "floor", "local", "profile", "pixel")
    for what in ("cpu_s", "cpu_min_s", "ratio")} | {
    "library_all_cpu_s", "floor_all_cpu_s", "library_all_ratio", "paired_samples"}
SUMMARY_KEYS = {"worst_closed_form_ratio", "worst_closed_form_all_ratio", "exact_ratio",
                "closed_form_passed", "exact_passed", "passed", "verdict", "wall_time_s",
                "loadavg_end"}


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_overhead")
    proc = run_benchmark("bench_overhead.py", "--quick", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout, json.loads((out / "overhead.json").read_text())


def test_quick_run_writes_documented_files(quick):
    out, stdout, report = quick
    assert set(report) == TOP_KEYS
    assert report["schema"] == "viscoforce.bench_overhead/2"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]
    assert [c["case"] for c in report["cases"]] == ["svda", "contact", "prony", "relaxation",
                                                    "exact"]
    for case in report["cases"]:
        assert set(case) == CASE_KEYS
        assert case["floor_ratio"] == pytest.approx(1.0)
    assert set(report["summary"]) == SUMMARY_KEYS
    assert report["summary"]["verdict"] in ("PASS", "FAIL")
    assert (out / "overhead.png").stat().st_size > 10_000
    with (out / "overhead.csv").open(newline="") as fh:
        assert len(list(csv.DictReader(fh))) == 5
    assert "closed-form fits: worst" in stdout and stdout.rstrip().endswith(("PASS", "FAIL"))
