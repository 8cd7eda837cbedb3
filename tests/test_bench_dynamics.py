"""Smoke test of benchmarks/bench_dynamics.py (its --quick mode).

No wall time is asserted or compared (timings depend on the machine and its load): only the JSON
keys, the deterministic accuracy figures and step counts, and the exit status.
"""

from __future__ import annotations

import csv
import json
import warnings

import pytest

from tests._bench import run_main

# documented in benchmarks/README.md, section bench_dynamics.py
TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "reference", "sweep",
            "equal_accuracy", "outputs_effect", "profile", "summary", "files"}
ROW_KEYS = {"method", "mode", "tol", "dt", "is_default", "status", "time_median_s", "time_min_s",
            "cpu_median_s", "repeats", "steps", "rejected_steps", "newton_iterations",
            "max_force_error"}
SUMMARY_KEYS = {"default_method", "default_tol", "default_time_s", "default_error",
                "speedup_vs_euler", "time_passed", "error_passed", "speedup_passed", "passed",
                "verdict"}
LINES = {"exponential (adaptive tol)", "exponential (fixed dt)",
         "exponential-euler (adaptive tol)", "exponential-euler (fixed dt)", "euler (fixed dt)"}


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_dynamics")
    # main() in this process (tests._bench.run_main), not a child: no interpreter start and
    # imports. Its own warnings are recorded by the script where they matter; the rest are
    # not errors here, as in a child process.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code, stdout, stderr = run_main("bench_dynamics.py", "--quick", "--out", str(out))
    assert code == 0, stderr
    return out, stdout, json.loads((out / "dynamics_benchmark.json").read_text())


def rows_of(report, method, mode):
    return sorted((r for r in report["sweep"] if r["method"] == method and r["mode"] == mode),
                  key=lambda r: -(r["dt"] if mode == "fixed dt" else r["tol"]))


def test_quick_run_writes_documented_files(quick):
    out, stdout, report = quick
    assert set(report) == TOP_KEYS
    assert report["schema"] == "viscoforce.bench_dynamics/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]  # BLAS pinned to one thread
    target = report["target"]
    assert (target["time_s"], target["max_force_error"], target["speedup_vs_euler"]) == (
        0.2, 1e-3, 5.0)
    assert report["settings"]["duration"] == pytest.approx(8e-3, rel=1e-12)  # 2·20 nm / 5 µm/s
    assert set(report["equal_accuracy"]["lines"]) == LINES
    assert SUMMARY_KEYS <= set(report["summary"])
    assert report["summary"]["verdict"] in {"PASS", "FAIL"}
    assert f"-> {report['summary']['verdict']}" in stdout
    assert (out / "dynamics_speed_accuracy.png").stat().st_size > 10_000
    with (out / "dynamics_speed_accuracy.csv").open(newline="") as fh:
        csv_rows = list(csv.DictReader(fh))
    assert len(csv_rows) == len(report["sweep"])
    assert ROW_KEYS <= set(csv_rows[0])


def test_sweep_rows_are_complete_and_one_default(quick):
    _, _, report = quick
    for r in report["sweep"]:
        assert ROW_KEYS <= set(r)
        assert r["status"] == "ok", r
        assert r["steps"] > 0 and r["newton_iterations"] >= r["steps"]
    defaults = [r for r in report["sweep"] if r["is_default"]]
    assert len(defaults) == 1
    assert defaults[0]["method"] == "exponential"
    assert defaults[0]["tol"] == pytest.approx(1e-14, rel=1e-12)  # 1e-5 × decay length 1 nm


def test_errors_converge_at_the_steppers_orders(quick):
    # deterministic part: halving dt halves explicit Euler's error (first order) and quarters the
    # fixed-step exponential trapezoidal error (second order); the quick reference (tol 1e-16 m) is
    # ~2e-6 accurate, far below the 1e-4…1e-2 errors compared here
    _, _, report = quick
    euler = rows_of(report, "euler", "fixed dt")
    expo = rows_of(report, "exponential", "fixed dt")
    assert [r["dt"] for r in euler] == [2e-5, 1e-5]
    assert euler[0]["max_force_error"] / euler[1]["max_force_error"] == pytest.approx(2.0, rel=0.1)
    assert expo[0]["max_force_error"] / expo[1]["max_force_error"] == pytest.approx(4.0, rel=0.1)
    # explicit Euler at dt = 2e-5 s is ~1 % off (the paper's scheme, first order)
    assert 5e-3 < euler[0]["max_force_error"] < 2e-2


def test_default_setting_accuracy_and_reference(quick):
    _, _, report = quick
    ref = report["reference"]
    assert len(ref["force"]) == 81
    assert ref["check_difference"] < 1e-4
    # the paper's Fig. 5 peak load is a few µN
    assert 1e-6 < ref["max_force"] < 1e-5
    assert report["summary"]["default_error"] < 1e-3
    assert report["summary"]["error_passed"] is True
    out81, out401 = report["outputs_effect"]
    assert (out81["outputs"], out401["outputs"]) == (81, 401)
    assert out401["steps"] > out81["steps"]  # every output time forces a landing step
    speedup = report["equal_accuracy"]["speedup_default_vs_euler"]  # a ratio of wall times:
    assert speedup is None or isinstance(speedup, float)  # only its presence and type are checked


def test_rejects_nonpositive_repeats(tmp_path):
    code, _, stderr = run_main("bench_dynamics.py", "--quick", "--repeats", "0", "--out",
                               str(tmp_path))
    assert code == 2
    assert "--repeats must be >= 1" in stderr
