"""Smoke test of benchmarks/bench_spectrum.py (its --quick mode; no timing asserted)."""

from __future__ import annotations

import csv
import json
import math
import warnings

import pytest
from scipy.special import i0

from tests._bench import run_main

# documented in benchmarks/README.md, section bench_spectrum.py
TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "linear",
            "time_domain", "paper_eta", "fig4_peak", "summary", "files"}
LINEAR_KEYS = {"scene", "h0", "eta", "spacing_factor", "spacing", "nodes", "is_default", "build_s",
               "time_median_s", "cpu_median_s", "repeats", "rel_stiffness_error",
               "max_phase_error_deg", "complex_rel_error", "passed"}
TD_KEYS = {"scene", "omega", "method", "mode", "n_per_period", "dt", "status", "time_median_s",
           "repeats", "steps", "stiffness", "phase_deg", "rel_stiffness_error", "phase_error_deg",
           "complex_rel_error", "linear_stiffness", "linear_phase_deg"}
SUMMARY_KEYS = {"linear_worst_time_s", "linear_worst_error", "time_passed", "error_passed",
                "passed", "verdict", "fig4_linear_peak_deg", "fig4_td_peak_deg", "wall_time_s"}
DECAY_LENGTH = 1e-9  # the paper's 1/κ [m]


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_spectrum")
    # main() in this process (tests._bench.run_main), not a child: no interpreter start and
    # imports. Its own warnings are recorded by the script where they matter; the rest are
    # not errors here, as in a child process.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code, stdout, stderr = run_main("bench_spectrum.py", "--quick", "--out", str(out))
    assert code == 0, stderr
    return out, stdout, json.loads((out / "spectrum_benchmark.json").read_text())


def td_rows(report, scene, method, mode):
    return sorted((r for r in report["time_domain"]["rows"] if r["scene"] == scene
                   and r["method"] == method and r["mode"] == mode),
                  key=lambda r: r["n_per_period"])


def test_quick_run_writes_documented_files(quick):
    out, stdout, report = quick
    assert set(report) == TOP_KEYS
    assert report["schema"] == "viscoforce.bench_spectrum/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]  # BLAS pinned to one thread
    target = report["target"]
    assert (target["time_s"], target["error"], target["n_omega"]) == (50e-3, 1e-4, 50)
    assert SUMMARY_KEYS <= set(report["summary"])
    assert report["summary"]["verdict"] in {"PASS", "FAIL"}
    assert f"-> {report['summary']['verdict']}" in stdout
    assert (out / "spectrum_speed_accuracy.png").stat().st_size > 10_000
    for name, rows in (("spectrum_linear.csv", report["linear"]["rows"]),
                       ("spectrum_time_domain.csv", report["time_domain"]["rows"])):
        with (out / name).open(newline="") as fh:
            csv_rows = list(csv.DictReader(fh))
        assert len(csv_rows) == len(rows)


def test_linear_method_is_accurate_on_the_default_grid(quick):
    # deterministic part: the default grid agrees with the 4x-refined grid far below the 1e-4
    # target, and refining from factor 2 to 1 reduces the error
    _, _, report = quick
    rows = report["linear"]["rows"]
    assert {(r["scene"], r["spacing_factor"]) for r in rows} == {
        (s, f) for s in ("Fig. 3", "Fig. 4") for f in (2.0, 1.0)}
    for scene in ("Fig. 3", "Fig. 4"):
        coarse, default = sorted((r for r in rows if r["scene"] == scene),
                                 key=lambda r: -r["spacing_factor"])
        assert LINEAR_KEYS <= set(default)
        assert default["is_default"] and not coarse["is_default"]
        assert default["nodes"] > coarse["nodes"]
        assert default["complex_rel_error"] < 1e-6
        assert default["complex_rel_error"] < coarse["complex_rel_error"]
        assert default["repeats"] >= 10 and "time_median_s" in default  # no wall-time asserts
    assert report["summary"]["error_passed"] is True


def test_time_domain_steppers_converge_at_their_orders(quick):
    # fixed dt = period/N at ω = 1e4 rad/s, η = 0.01 nm: doubling N halves explicit Euler's error
    # (first order) and quarters the exponential stepper's (second order); both errors (≥ 9e-5) are
    # above the O(η²) floor of the linear reference (≈ 3e-5)
    _, _, report = quick
    for scene in ("Fig. 3", "Fig. 4"):
        euler = td_rows(report, scene, "euler", "fixed dt")
        expo = td_rows(report, scene, "exponential", "fixed dt")
        assert [r["n_per_period"] for r in euler] == [16, 32]
        for r in euler + expo:
            assert TD_KEYS <= set(r)
            assert r["status"] == "ok", r
            assert r["steps"] == 20 * r["n_per_period"]  # 16 settling + 4 demodulated periods
        assert euler[0]["complex_rel_error"] / euler[1]["complex_rel_error"] == pytest.approx(
            2.0, rel=0.1)
        assert expo[0]["complex_rel_error"] / expo[1]["complex_rel_error"] == pytest.approx(
            4.0, rel=0.1)
        # the library sweep: adaptive exponential within 2e-4; euler runs at its default dt
        # 0.1 τ E_inf/E0 = 1e-5 s (not period/samples = 2e-5 s): half the error of dt = period/32
        (expo_sweep,) = td_rows(report, scene, "exponential", "sweep")
        assert expo_sweep["complex_rel_error"] < 2e-4
        (eu,) = td_rows(report, scene, "euler", "sweep")
        assert eu["dt"] == pytest.approx(1e-5, rel=1e-12)
        assert eu["complex_rel_error"] / euler[1]["complex_rel_error"] == pytest.approx(
            0.5, rel=0.1)


def test_paper_eta_difference_is_rectification(quick):
    # at the paper's η the mean force rises (⟨F⟩ of a convex F(h0)); for the nearly rigid Fig. 3
    # scene it is below the rigid-exponential value I0(η/λ) − 1 (compliance softens F(h0))
    _, _, report = quick
    rows = {r["scene"]: r for r in report["paper_eta"]}
    rigid = float(i0(0.1e-9 / DECAY_LENGTH)) - 1.0
    assert 0.3 * rigid < rows["Fig. 3"]["mean_force_shift_rel"] < rigid
    assert rows["Fig. 4"]["mean_force_shift_rel"] > rows["Fig. 3"]["mean_force_shift_rel"]
    # the paper's Fig. 4 load is 1.08 µN
    assert rows["Fig. 4"]["linear_mean_force"] == pytest.approx(1.08e-6, rel=0.01)


def test_fig4_peak_linear_time_domain_and_euler(quick):
    _, _, report = quick
    peak = report["fig4_peak"]
    lin, td = peak["linear"], peak["time_domain"]
    assert lin["phase_deg"] == pytest.approx(36.218, abs=0.01)
    assert lin["omega"] == pytest.approx(2342.0, rel=0.01)
    # the finite-amplitude (η = 1 nm) peak is about 0.4° below the linear one
    assert 35.5 < td["phase_deg"] < lin["phase_deg"] - 0.2
    # explicit Euler overshoots the phase at coarse steps and approaches it as dt shrinks
    euler = {r["steps_per_period"]: r for r in peak["euler_fixed_dt"]}
    assert euler[16]["phase_at_linear_peak_deg"] > euler[32]["phase_at_linear_peak_deg"] > 40.0
    assert euler[16]["peak_phase_deg"] > 50.0
    # sweep(method="euler") runs at the default dt = 10 µs: within 0.5° of the linear peak
    for r in peak["euler_sweep"]:
        assert r["dt_s"] == pytest.approx(1e-5, rel=1e-12)
        assert abs(r["phase_deg"] - lin["phase_deg"]) < 0.5
    assert math.isfinite(report["summary"]["fig4_td_peak_deg"])


def test_rejects_too_few_repeats(tmp_path):
    code, _, stderr = run_main("bench_spectrum.py", "--quick", "--repeats", "5", "--out",
                               str(tmp_path))
    assert code == 2
    assert "--repeats must be >= 10" in stderr
