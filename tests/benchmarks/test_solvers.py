"""Checks of the solver timing suites' smoke runs: bench_static, bench_dynamics, bench_spectrum,
bench_linear, bench_regression and bench_step (and the previous-release harness _previous.py).

Each suite's smoke run is the session's one (``quick_run``, shared with test_smoke.py, which
checks the top-level keys and the files). No wall time is asserted or compared (timings depend
on the machine and its load): only the JSON keys, the deterministic accuracy figures, step counts
and the printed verdicts.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pandas as pd
import pytest
from scipy.special import i0

from tests._bench import benchmark_module
from tests.benchmarks._smoke import passed

#: The FFT peer's loads, copied into the repository (see tests/data/README.md).
PEER_CSV = Path(__file__).resolve().parents[1] / "data" / "static_loads_fft_peer.csv"


# ── bench_static.py ──────────────────────────────────────────────────────────────────────────────

# documented in benchmarks/README.md, section bench_static.py
STATIC_ROW_KEYS = {"E", "h0", "nodes", "n_panels", "order", "newton_iterations", "force",
                   "force_refined", "rel_error_refined", "force_peer", "rel_error_peer",
                   "time_public_s", "time_public_cpu_s", "time_newton_s"}
STATIC_SWEEP_KEYS = {"case", "E", "h0", "order", "spacing_factor", "nodes", "status",
                     "time_public_s", "time_newton_s", "rel_error", "is_default"}
STATIC_SUMMARY_KEYS = {"worst_time_public_s", "worst_time_newton_s", "worst_rel_error_refined",
                       "worst_rel_error_peer", "passed", "verdict"}


@pytest.fixture(scope="module")
def static(quick_run):
    return passed(quick_run("bench_static"))


def test_bench_static_quick_writes_documented_json(static):
    report, stdout, out = static.report, static.stdout, static.out
    assert report["schema"] == "viscoforce.bench_static/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]  # BLAS pinned to one thread
    assert report["target"]["time_per_solve_s"] == 5e-3
    assert report["target"]["relative_error"] == 1e-4
    rows = report["default_grid"]
    assert len(rows) == 16  # 2 moduli × 8 positions
    assert {(r["E"], round(r["h0"] * 1e9)) for r in rows} == {
        (e, h) for e in (1e9, 1e10) for h in (-10, -7, -5, -3, 0, 2, 5, 10)}
    for row in rows:
        assert STATIC_ROW_KEYS <= set(row)
        assert row["newton_iterations"] >= 1
    assert len(report["build"]) == 8
    assert STATIC_SUMMARY_KEYS <= set(report["summary"])
    assert report["summary"]["verdict"] in {"PASS", "FAIL"}
    assert f"-> {report['summary']['verdict']}" in stdout
    assert (out / "static_speed_accuracy.png").stat().st_size > 10_000
    assert (out / "static_speed_accuracy.csv").read_text().startswith("case,")


def _peer_loads() -> dict[tuple[float, int], float]:
    """FFT-peer loads [N] keyed by (E [Pa], h0 [pm]) from tests/data (always present)."""
    df = pd.read_csv(PEER_CSV)
    return {(float(e), round(h * 1e12)): float(f)
            for e, h, f in zip(df["E (Pa)"], df["h0 (m)"], df["force (N)"], strict=True)}


def test_bench_static_default_grid_is_accurate(static):
    # deterministic part of the benchmark: the default grid's load agrees with a 4x-refined grid to
    # far better than the 1e-4 target, and with the independent FFT peer (the copy in tests/data,
    # so this always runs) to its stated ~1e-4
    report = static.report
    peer = _peer_loads()
    compared = 0
    for row in report["default_grid"]:
        assert row["rel_error_refined"] < 1e-5, row
        key = (float(row["E"]), round(row["h0"] * 1e12))
        if key in peer:
            assert math.isclose(row["force"], peer[key], rel_tol=1e-4), (row, peer[key])
            compared += 1
    assert compared >= 10  # the benchmark's table shares most of its positions with the peer
    sweep = report["sweep"]
    assert {r["order"] for r in sweep} == {4, 8}
    assert sum(r["is_default"] for r in sweep) == 2  # one default point per sweep case
    for r in sweep:
        assert STATIC_SWEEP_KEYS <= set(r)
        assert r["status"] == "ok"


# ── bench_dynamics.py ────────────────────────────────────────────────────────────────────────────

# documented in benchmarks/README.md, section bench_dynamics.py
DYNAMICS_ROW_KEYS = {"method", "mode", "tol", "dt", "is_default", "status", "time_median_s",
                     "time_min_s", "cpu_median_s", "repeats", "steps", "rejected_steps",
                     "newton_iterations", "max_force_error"}
DYNAMICS_SUMMARY_KEYS = {"default_method", "default_tol", "default_time_s", "default_error",
                         "speedup_vs_euler", "time_passed", "error_passed", "speedup_passed",
                         "passed", "verdict"}
DYNAMICS_LINES = {"exponential (adaptive tol)", "exponential (fixed dt)",
                  "exponential-euler (adaptive tol)", "exponential-euler (fixed dt)",
                  "euler (fixed dt)"}


@pytest.fixture(scope="module")
def dynamics(quick_run):
    return passed(quick_run("bench_dynamics"))


def dynamics_rows(report, method, mode):
    return sorted((r for r in report["sweep"] if r["method"] == method and r["mode"] == mode),
                  key=lambda r: -(r["dt"] if mode == "fixed dt" else r["tol"]))


def test_bench_dynamics_quick_run_writes_documented_files(dynamics):
    out, stdout, report = dynamics.out, dynamics.stdout, dynamics.report
    assert report["schema"] == "viscoforce.bench_dynamics/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]  # BLAS pinned to one thread
    target = report["target"]
    assert (target["time_s"], target["max_force_error"], target["speedup_vs_euler"]) == (
        0.2, 1e-3, 5.0)
    assert report["settings"]["duration"] == pytest.approx(8e-3, rel=1e-12)  # 2·20 nm / 5 µm/s
    assert set(report["equal_accuracy"]["lines"]) == DYNAMICS_LINES
    assert DYNAMICS_SUMMARY_KEYS <= set(report["summary"])
    assert report["summary"]["verdict"] in {"PASS", "FAIL"}
    assert f"-> {report['summary']['verdict']}" in stdout
    assert (out / "dynamics_speed_accuracy.png").stat().st_size > 10_000
    with (out / "dynamics_speed_accuracy.csv").open(newline="") as fh:
        csv_rows = list(csv.DictReader(fh))
    assert len(csv_rows) == len(report["sweep"])
    assert DYNAMICS_ROW_KEYS <= set(csv_rows[0])


def test_bench_dynamics_sweep_rows_are_complete_and_one_default(dynamics):
    report = dynamics.report
    for r in report["sweep"]:
        assert DYNAMICS_ROW_KEYS <= set(r)
        assert r["status"] == "ok", r
        assert r["steps"] > 0 and r["newton_iterations"] >= r["steps"]
    defaults = [r for r in report["sweep"] if r["is_default"]]
    assert len(defaults) == 1
    assert defaults[0]["method"] == "exponential"
    assert defaults[0]["tol"] == pytest.approx(1e-14, rel=1e-12)  # 1e-5 × decay length 1 nm


def test_bench_dynamics_errors_converge_at_the_steppers_orders(dynamics):
    # deterministic part: halving dt halves explicit Euler's error (first order) and quarters the
    # fixed-step exponential trapezoidal error (second order); the quick reference (tol 1e-16 m) is
    # ~2e-6 accurate, far below the 1e-4…1e-2 errors compared here
    report = dynamics.report
    euler = dynamics_rows(report, "euler", "fixed dt")
    expo = dynamics_rows(report, "exponential", "fixed dt")
    assert [r["dt"] for r in euler] == [2e-5, 1e-5]
    assert euler[0]["max_force_error"] / euler[1]["max_force_error"] == pytest.approx(2.0, rel=0.1)
    assert expo[0]["max_force_error"] / expo[1]["max_force_error"] == pytest.approx(4.0, rel=0.1)
    # explicit Euler at dt = 2e-5 s is ~1 % off (the paper's scheme, first order)
    assert 5e-3 < euler[0]["max_force_error"] < 2e-2


def test_bench_dynamics_default_setting_accuracy_and_reference(dynamics):
    report = dynamics.report
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


# ── bench_spectrum.py ────────────────────────────────────────────────────────────────────────────

# documented in benchmarks/README.md, section bench_spectrum.py
SPECTRUM_LINEAR_KEYS = {"scene", "h0", "eta", "spacing_factor", "spacing", "nodes", "is_default",
                        "build_s", "time_median_s", "cpu_median_s", "repeats",
                        "rel_stiffness_error", "max_phase_error_deg", "complex_rel_error",
                        "passed"}
SPECTRUM_TD_KEYS = {"scene", "omega", "method", "mode", "n_per_period", "dt", "status",
                    "time_median_s", "repeats", "steps", "stiffness", "phase_deg",
                    "rel_stiffness_error", "phase_error_deg", "complex_rel_error",
                    "linear_stiffness", "linear_phase_deg"}
SPECTRUM_SUMMARY_KEYS = {"linear_worst_time_s", "linear_worst_error", "time_passed",
                         "error_passed", "passed", "verdict", "fig4_linear_peak_deg",
                         "fig4_td_peak_deg", "wall_time_s"}
DECAY_LENGTH = 1e-9  # the paper's 1/κ [m]


@pytest.fixture(scope="module")
def spectrum(quick_run):
    return passed(quick_run("bench_spectrum"))


def td_rows(report, scene, method, mode):
    return sorted((r for r in report["time_domain"]["rows"] if r["scene"] == scene
                   and r["method"] == method and r["mode"] == mode),
                  key=lambda r: r["n_per_period"])


def test_bench_spectrum_quick_run_writes_documented_files(spectrum):
    out, stdout, report = spectrum.out, spectrum.stdout, spectrum.report
    assert report["schema"] == "viscoforce.bench_spectrum/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]  # BLAS pinned to one thread
    target = report["target"]
    assert (target["time_s"], target["error"], target["n_omega"]) == (50e-3, 1e-4, 50)
    assert SPECTRUM_SUMMARY_KEYS <= set(report["summary"])
    assert report["summary"]["verdict"] in {"PASS", "FAIL"}
    assert f"-> {report['summary']['verdict']}" in stdout
    assert (out / "spectrum_speed_accuracy.png").stat().st_size > 10_000
    for name, rows in (("spectrum_linear.csv", report["linear"]["rows"]),
                       ("spectrum_time_domain.csv", report["time_domain"]["rows"])):
        with (out / name).open(newline="") as fh:
            csv_rows = list(csv.DictReader(fh))
        assert len(csv_rows) == len(rows)


def test_bench_spectrum_linear_method_is_accurate_on_the_default_grid(spectrum):
    # deterministic part: the default grid agrees with the 4x-refined grid far below the 1e-4
    # target, and refining from factor 2 to 1 reduces the error
    report = spectrum.report
    rows = report["linear"]["rows"]
    assert {(r["scene"], r["spacing_factor"]) for r in rows} == {
        (s, f) for s in ("Fig. 3", "Fig. 4") for f in (2.0, 1.0)}
    for scene in ("Fig. 3", "Fig. 4"):
        coarse, default = sorted((r for r in rows if r["scene"] == scene),
                                 key=lambda r: -r["spacing_factor"])
        assert SPECTRUM_LINEAR_KEYS <= set(default)
        assert default["is_default"] and not coarse["is_default"]
        assert default["nodes"] > coarse["nodes"]
        assert default["complex_rel_error"] < 1e-6
        assert default["complex_rel_error"] < coarse["complex_rel_error"]
        assert default["repeats"] >= 10 and "time_median_s" in default  # no wall-time asserts
    assert report["summary"]["error_passed"] is True


def test_bench_spectrum_time_domain_steppers_converge_at_their_orders(spectrum):
    # fixed dt = period/N at ω = 1e4 rad/s, η = 0.01 nm: doubling N halves explicit Euler's error
    # (first order) and quarters the exponential stepper's (second order); both errors (≥ 9e-5) are
    # above the O(η²) floor of the linear reference (≈ 3e-5)
    report = spectrum.report
    for scene in ("Fig. 3", "Fig. 4"):
        euler = td_rows(report, scene, "euler", "fixed dt")
        expo = td_rows(report, scene, "exponential", "fixed dt")
        assert [r["n_per_period"] for r in euler] == [16, 32]
        for r in euler + expo:
            assert SPECTRUM_TD_KEYS <= set(r)
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


def test_bench_spectrum_paper_eta_difference_is_rectification(spectrum):
    # at the paper's η the mean force rises (⟨F⟩ of a convex F(h0)); for the nearly rigid Fig. 3
    # scene it is below the rigid-exponential value I0(η/λ) − 1 (compliance softens F(h0))
    report = spectrum.report
    rows = {r["scene"]: r for r in report["paper_eta"]}
    rigid = float(i0(0.1e-9 / DECAY_LENGTH)) - 1.0
    assert 0.3 * rigid < rows["Fig. 3"]["mean_force_shift_rel"] < rigid
    assert rows["Fig. 4"]["mean_force_shift_rel"] > rows["Fig. 3"]["mean_force_shift_rel"]
    # the paper's Fig. 4 load is 1.08 µN
    assert rows["Fig. 4"]["linear_mean_force"] == pytest.approx(1.08e-6, rel=0.01)


def test_bench_spectrum_fig4_peak_linear_time_domain_and_euler(spectrum):
    report = spectrum.report
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


# ── bench_linear.py ──────────────────────────────────────────────────────────────────────────────

# documented in benchmarks/README.md, section bench_linear.py
LINEAR_ROW_KEYS = {"scene", "h0", "path", "nodes", "modes", "n_omega", "mean_force",
                   "time_median_s", "time_min_s", "calls_per_sample", "samples", "max_rel_error",
                   "speedup", "calls_in_fit_budget"}
LINEAR_SUMMARY_KEYS = {"speedup_build", "speedup_cached", "worst_time_build_s",
                       "worst_time_cached_s", "worst_rel_error", "accurate", "wall_time_s",
                       "loadavg_end"}
LINEAR_PATHS = ["direct", "build", "build_at_load", "cached", "public_cached"]


@pytest.fixture(scope="module")
def linear(quick_run):
    return passed(quick_run("bench_linear"))


def test_bench_linear_quick_run_writes_documented_files(linear):
    out, stdout, report = linear.out, linear.stdout, linear.report
    assert report["schema"] == "viscoforce.bench_linear/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]  # BLAS pinned to one thread
    assert report["settings"]["n_omega"] == 30
    assert set(report["summary"]) == LINEAR_SUMMARY_KEYS
    assert (out / "linear_timings.png").stat().st_size > 10_000
    with (out / "linear_timings.csv").open(newline="") as fh:
        assert len(list(csv.DictReader(fh))) == len(report["rows"])
    assert "speed-up over direct (worst position)" in stdout


def test_bench_linear_every_path_at_both_positions_agrees_with_the_direct_solve(linear):
    report = linear.report
    rows = report["rows"]
    assert [(r["scene"], r["path"]) for r in rows] == [
        (s, p) for s in ("Fig. 3", "Fig. 4") for p in LINEAR_PATHS]
    for r in rows:
        assert set(r) == LINEAR_ROW_KEYS
        assert r["n_omega"] == 30 and r["samples"] == 5
        assert r["max_rel_error"] <= 1e-10, r  # deterministic; measured ≤ 2e-15
        assert r["time_median_s"] > 0  # no wall-time asserts
    assert report["summary"]["accurate"] is True
    direct = {r["scene"]: r for r in rows if r["path"] == "direct"}
    assert direct["Fig. 3"]["mean_force"] == pytest.approx(61.0e-9, rel=0.01)  # paper Fig. 3
    assert direct["Fig. 4"]["mean_force"] == pytest.approx(1.08e-6, rel=0.01)  # paper Fig. 4


# ── bench_regression.py and _previous.py ─────────────────────────────────────────────────────────

# documented in benchmarks/README.md, section bench_regression.py
REGRESSION_CASES = ["linear_response -5 nm cold", "linear_response -5 nm warm", "reference -5 nm",
                    "linear_response +2 nm cold", "linear_response +2 nm warm", "reference +2 nm",
                    "linear_stiffness -5 nm cold", "linear_stiffness -5 nm warm",
                    "static_equilibrium -5 nm", "static_equilibrium +2 nm"]
REGRESSION_ROW_KEYS = {"case", "function", "position", "calls_per_sample", "rounds", "note",
                       "current_cpu_median_s", "current_cpu_min_s", "current_wall_median_s",
                       "previous_cpu_median_s", "previous_cpu_min_s", "previous_wall_median_s",
                       "ratio_current_previous"}
REGRESSION_CHECK_KEYS = {"check", "kind", "case", "ratio", "ratio_low", "ratio_high", "margin",
                         "limit", "passed"}
REGRESSION_SUMMARY_KEYS = {"speedup_reference_over_current_cold", "speedup_passed",
                           "no_slower_passed", "worst_ratio_current_previous", "accuracy_passed",
                           "info_ratios", "previous_timed", "wall_time_s", "loadavg_end",
                           "passed", "verdict"}


@pytest.fixture(scope="module")
def regression(quick_run):
    return passed(quick_run("bench_regression"))


def test_bench_regression_quick_run_writes_documented_files(regression):
    out, stdout, report = regression.out, regression.stdout, regression.report
    assert report["schema"] == "viscoforce.bench_regression/1"
    assert report["quick"] is True
    assert report["settings"]["n_omega"] == 12 and report["settings"]["rounds"] == 3
    assert set(report["summary"]) == REGRESSION_SUMMARY_KEYS
    assert report["summary"]["verdict"] in {"PASS", "FAIL"}
    assert [r["case"] for r in report["rows"]] == REGRESSION_CASES
    for r in report["rows"]:
        assert REGRESSION_ROW_KEYS <= set(r)
        assert r["current_cpu_median_s"] > 0  # no wall-time asserts
    assert (out / "regression_timings.png").stat().st_size > 10_000
    with (out / "regression_timings.csv").open(newline="") as fh:
        assert [row["case"] for row in csv.DictReader(fh)] == REGRESSION_CASES
    assert "reference / current cold at -5 nm" in stdout
    assert stdout.count("target >= 5: ") == 1


def test_bench_regression_workers_are_pinned_and_import_their_own_tree(regression):
    stdout, report = regression.stdout, regression.report
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
    assert [c["case"] for c in no_slower] == [c for c in REGRESSION_CASES
                                              if not c.startswith("reference")]
    for c in report["checks"]:
        assert set(c) == REGRESSION_CHECK_KEYS
        assert c["ratio_low"] <= c["ratio"] <= c["ratio_high"]
    for c in no_slower:
        assert 0.04 <= c["margin"] <= 0.05
        assert f"{c['case']:28}" in stdout


def test_bench_regression_reference_and_previous_agree_with_linear_response(regression):
    stdout, report = regression.stdout, regression.report
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


def test_previous_harness_unknown_revision_is_unavailable_not_an_error():
    previous = benchmark_module("_previous.py")
    with pytest.raises(previous.PreviousUnavailable, match="is not a commit"):
        previous.resolve_revision("no-such-revision-0123")


# ── bench_step.py ────────────────────────────────────────────────────────────────────────────────

@pytest.fixture(scope="module")
def step(quick_run):
    return passed(quick_run("bench_step"))


def test_bench_step_writes_the_documented_json(step):
    bench = benchmark_module("bench_step.py")
    stdout, data = step.stdout, step.report
    assert set(data) == set(bench.JSON_KEYS)
    assert data["schema"] == "viscoforce.bench_step/1"
    assert data["quick"] is True
    assert data["machine"]["blas_threads"] == [1]
    assert data["settings"]["env"] == {"OPENBLAS_NUM_THREADS": "1"}
    assert data["settings"]["repeats"] == 1 and data["settings"]["interleaved"] is True
    assert data["target"] == {"speedup": 5.0}
    assert list(data["results"]) == ["fig1_step"]
    case = data["results"]["fig1_step"]
    assert set(case) == set(bench.CASE_KEYS)
    for path in ("old", "new"):
        assert set(case[path]) == set(bench.PATH_KEYS)
        assert case[path]["simulations"] >= 1 and len(case[path]["cpu_s"]) == 1
    assert set(case["params"]) == {"E0", "E_inf", "tau"}
    for entry in case["params"].values():
        assert set(entry) == set(bench.PARAM_KEYS)
    assert data["summary"]["verdict"] in {"PASS", "FAIL"}
    assert data["summary"]["passed"] == (data["summary"]["verdict"] == "PASS")
    assert "OPENBLAS_NUM_THREADS=1" in stdout
    assert f"target >= 5x: {data['summary']['verdict']}" in stdout


def test_bench_step_writes_one_csv_row_per_fit_and_the_plot(step):
    out, data = step.out, step.report
    with (out / "step.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert sorted(r["path"] for r in rows) == ["new", "old"]
    assert {"case", "path", "repeat", "cpu_s", "wall_s", "nfev", "simulations",
            "newton"} <= set(rows[0])
    assert (out / "step.png").stat().st_size > 0
    assert data["files"] == {"json": "step.json", "csv": "step.csv", "png": "step.png"}
