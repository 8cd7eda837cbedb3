"""Smoke test of benchmarks/bench_regression.py and its previous-release harness (no timing asserted)."""

from __future__ import annotations

import csv
import json

import pytest

from tests._bench import benchmark_module, run_benchmark, run_main

# documented in benchmarks/README.md, section bench_regression.py
TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "workers", "accuracy",
            "rows", "checks", "summary", "files"}
CASES = ["linear_response -5 nm cold", "linear_response -5 nm warm", "reference -5 nm",
         "linear_response +2 nm cold", "linear_response +2 nm warm", "reference +2 nm",
         "linear_stiffness -5 nm cold", "linear_stiffness -5 nm warm",
         "static_equilibrium -5 nm", "static_equilibrium +2 nm"]
ROW_KEYS = {"case", "function", "position", "calls_per_sample", "rounds", "note", "current_cpu_median_s",
            "current_cpu_min_s", "current_wall_median_s", "previous_cpu_median_s",
            "previous_cpu_min_s", "previous_wall_median_s", "ratio_current_previous"}
CHECK_KEYS = {"check", "kind", "case", "ratio", "ratio_low", "ratio_high", "margin", "limit",
              "passed"}
SUMMARY_KEYS = {"speedup_reference_over_current_cold", "speedup_passed", "no_slower_passed",
                "worst_ratio_current_previous", "accuracy_passed", "info_ratios",
                "previous_timed", "wall_time_s", "loadavg_end", "passed", "verdict"}


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_regression")
    proc = run_benchmark("bench_regression.py", "--quick", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout, json.loads((out / "regression_benchmark.json").read_text())


def test_quick_run_writes_documented_files(quick):
    out, stdout, report = quick
    assert set(report) == TOP_KEYS
    assert report["schema"] == "viscoforce.bench_regression/1"
    assert report["quick"] is True
    assert report["settings"]["n_omega"] == 12 and report["settings"]["rounds"] == 3
    assert set(report["summary"]) == SUMMARY_KEYS
    assert report["summary"]["verdict"] in {"PASS", "FAIL"}
    assert [r["case"] for r in report["rows"]] == CASES
    for r in report["rows"]:
        assert ROW_KEYS <= set(r)
        assert r["current_cpu_median_s"] > 0  # no wall-time asserts
    assert (out / "regression_timings.png").stat().st_size > 10_000
    with (out / "regression_timings.csv").open(newline="") as fh:
        assert [row["case"] for row in csv.DictReader(fh)] == CASES
    assert "reference / current cold at -5 nm" in stdout
    assert stdout.count("target >= 5: ") == 1


def test_workers_are_pinned_and_import_their_own_tree(quick):
    _, stdout, report = quick
    workers = report["workers"]
    assert workers["current"]["blas_threads"] == [1]
    assert workers["current"]["viscoforce_file"].startswith(workers["current"]["src"])
    if workers["previous"] is None:  # no git or no such revision here: skipped with a note
        assert workers["note"] and f"note: {workers['note']}" in stdout
        assert report["summary"]["previous_timed"] is False
        return
    assert workers["note"] is None
    assert workers["previous"]["blas_threads"] == [1]
    assert workers["previous"]["viscoforce_file"].startswith(workers["previous"]["src"])
    assert "viscoforce-previous-" in workers["previous"]["src"]
    assert len(workers["previous_commit"]) == 40
    no_slower = [c for c in report["checks"] if c["kind"] == "no_slower"]
    assert [c["case"] for c in no_slower] == [c for c in CASES if not c.startswith("reference")]
    for c in report["checks"]:
        assert set(c) == CHECK_KEYS
        assert c["ratio_low"] <= c["ratio"] <= c["ratio_high"]
    for c in no_slower:
        assert 0.04 <= c["margin"] <= 0.05
        assert f"{c['case']:28}" in stdout


def test_reference_and_previous_agree_with_linear_response(quick):
    _, stdout, report = quick
    for entry in report["accuracy"].values():  # deterministic: measured <= 2e-14
        assert entry["k_rel_diff_reference"] <= 1e-10
        assert entry["bias_rel_diff_reference"] <= 1e-10
        assert entry["warned_current"] is entry["warned_reference"] is True  # kappa*eta = 1
        cleared = entry["caches_cleared_current"]  # cold means cold
        assert {"linearized_state", "_modal.DECOMPOSITIONS", "finite_amplitude._BIAS_MODES",
                "finite_amplitude._BIAS_RESULTS"} <= set(cleared)
        if entry["k_rel_diff_previous"] is not None:
            assert entry["k_rel_diff_previous"] <= 1e-10
        assert entry["passed"] is True
    assert report["summary"]["accuracy_passed"] is True
    assert stdout.count("(<= 1e-10, same flag): PASS") == 2


def test_unknown_revision_is_unavailable_not_an_error():
    previous = benchmark_module("_previous.py")
    with pytest.raises(previous.PreviousUnavailable, match="is not a commit"):
        previous.resolve_revision("no-such-revision-0123")


def test_rejects_too_few_rounds(tmp_path):
    code, _, stderr = run_main("bench_regression.py", "--quick", "--repeats", "0", "--out",
                               str(tmp_path))
    assert code == 2
    assert "--repeats must be >= 1" in stderr
