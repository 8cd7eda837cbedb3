"""Checks of the studies' smoke runs (studies/<name>/): speed_accuracy, validity_maps, real_data,
and where split_half, phase_lag_real and ting_real write.

Each study's smoke run is the session's one (``quick_run``, shared with test_smoke.py, which
checks the top-level keys and the files). No wall time is asserted or compared: the JSON keys,
complete rows, the deterministic accuracy figures, no silent garbage, the Markdown tables.
"""

from __future__ import annotations

import csv
import json
import math

import pytest

from tests._bench import REPO, STUDIES, benchmark_module
from tests.benchmarks._smoke import passed

#: the studies are slow studies: `-m slow` runs them (CI skips them; they stay runnable)
pytestmark = pytest.mark.slow

# ── speed_accuracy.py ────────────────────────────────────────────────────────────────────────────
# the rows complete (finite time and error, or a ``fails: ...`` status), one default per method
# and scene, and the files written

# documented in studies/speed_accuracy/README.md
SPEED_ROW_KEYS = {"scene", "method", "knob", "value", "time_s", "error", "status", "is_default",
                  "reference", "detail"}
SPEED_SCENES = {"static 2 nm", "static -5 nm", "static -10 nm", "Fig. 3 spectrum",
                "Fig. 4 spectrum", "Fig. 1 step", "Fig. 5 loop", "30-point fit", "deep spectrum"}
NO_DEFAULT = {"linear vs td"}  # a comparison row, not a method of its own


@pytest.fixture(scope="module")
def speed(quick_run):
    return passed(quick_run("speed_accuracy"))


def test_speed_accuracy_quick_run_writes_documented_files(speed):
    out, stdout, report = speed.out, speed.stdout, speed.report
    assert report["schema"] == "viscoforce.speed_accuracy/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]  # BLAS pinned to one thread
    assert set(report["files"].values()) == {"speed_accuracy.json", "speed_accuracy.csv",
                                             "speed_accuracy.png"}
    assert (out / "speed_accuracy.png").stat().st_size > 10_000
    with (out / "speed_accuracy.csv").open(newline="") as fh:
        csv_rows = list(csv.DictReader(fh))
    assert len(csv_rows) == len(report["rows"])
    assert SPEED_ROW_KEYS <= set(csv_rows[0])
    assert f"{len(report['rows'])} rows" in stdout


def test_speed_accuracy_every_row_is_complete(speed):
    rows = speed.report["rows"]
    assert {r["scene"] for r in rows} == SPEED_SCENES
    for r in rows:
        assert SPEED_ROW_KEYS <= set(r), r
        if r["status"] == "ok":
            assert r["time_s"] is not None and math.isfinite(r["time_s"]) and r["time_s"] > 0, r
            assert r["error"] is not None and math.isfinite(r["error"]) and r["error"] >= 0, r
        else:
            assert r["status"].startswith("fails: "), r
    # the expected failures of the quick run: the rigid load in contact is infinite, and explicit
    # Euler at its larger steps refuses the fast Fig. 1 rise (StabilityError, not a curve)
    failed = {(r["scene"], r["method"]) for r in rows if r["status"] != "ok"}
    assert failed <= {("static -5 nm", "rigid (Derjaguin)"),
                      ("static -10 nm", "rigid (Derjaguin)"), ("Fig. 1 step", "euler"),
                      ("Fig. 5 loop", "euler")}
    for r in rows:
        if r["status"] != "ok" and r["method"] == "euler":
            assert "explicit Euler is unstable" in r["status"], r
    assert speed.report["summary"]["failed"] == len([r for r in rows if r["status"] != "ok"])


def test_speed_accuracy_one_default_per_method_and_scene(speed):
    rows = speed.report["rows"]
    pairs = {(r["scene"], r["method"]) for r in rows if r["method"] not in NO_DEFAULT}
    for scene, method in pairs:
        defaults = [r for r in rows
                    if (r["scene"], r["method"]) == (scene, method) and r["is_default"]]
        assert len(defaults) == 1, (scene, method)


def test_speed_accuracy_deterministic_accuracy(speed):
    # the default static grid is within 1e-4 of the 4x-refined one; the default linear spectrum
    # within 1e-6 of its refined reference (both are far tighter; loose bounds, no timing)
    for r in speed.report["rows"]:
        if r["is_default"] and r["method"] in {"static_equilibrium", "linear"}:
            assert r["error"] < 1e-6, r


# ── validity_maps.py ─────────────────────────────────────────────────────────────────────────────
# The run classifies every point as ok / warns / raises / silent > 1 %; issue 15 asks that no
# point be more than 1 % off without a warning or an exception, so the quick map must have none
# (the full map, 239 points, has none either: studies/validity_maps/README.md).

VALIDITY_ROW_KEYS = {"map", "x_name", "x", "y_name", "y", "error", "estimate", "status",
                     "exception", "warning", "time_s", "detail"}
STATUSES = {"ok", "warns", "raises", "silent > 1 %"}


@pytest.fixture(scope="module")
def validity(quick_run):
    return passed(quick_run("validity_maps"))


def test_validity_maps_quick_map_writes_the_documented_files(validity):
    out, report = validity.out, validity.report
    assert report["schema"] == "viscoforce.validity_maps/1" and report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]
    assert (out / "validity_maps.png").stat().st_size > 10_000
    with (out / "validity_maps.csv").open(newline="") as fh:
        assert len(list(csv.DictReader(fh))) == len(report["rows"])
    for row in report["rows"]:
        assert VALIDITY_ROW_KEYS <= set(row) and row["status"] in STATUSES, row


def test_validity_maps_quick_map_has_no_silent_garbage_and_covers_every_region(validity):
    report = validity.report
    silent = [r for r in report["rows"] if r["status"] == "silent > 1 %"]
    assert not silent, silent
    assert report["summary"]["silent > 1 %"] == 0
    statuses = {r["status"] for r in report["rows"]}
    assert {"ok", "warns", "raises"} <= statuses  # every kind of region is exercised


# ── real_data.py ─────────────────────────────────────────────────────────────────────────────────
# the real modulation map; the force-curve half and the coverage of every real file when the
# data folder is there; keys, finite numbers and the Markdown tables

REAL_MAP = REPO.parent / "shared" / "data" / "real" / "PyFMReader" / (
    "map-data-2021.11.05-17.37.44.432.jpk-force-map")
BUNDLED_MAP = REPO / "data_examples" / "real" / "modulation-map.jpk-force-map"
DATA = REPO.parent / "shared" / "data" / "real"
needs_map = pytest.mark.skipif(not (REAL_MAP.is_file() or BUNDLED_MAP.is_file()),
                               reason="the real JPK modulation map is absent")
needs_data = pytest.mark.skipif(not DATA.is_dir(), reason=f"the real data folder {DATA} is absent")

REAL_MAP_KEYS = {"status", "file", "curves_in_file", "curves_fitted", "frequencies_hz",
                 "radius_m", "radius_note", "load_warnings", "chooser", "maps", "split_half",
                 "seconds"}
CHOOSER_KEYS = {"curves", "kept", "median_redchi", "median_chi2_pvalue",
                "median_bic_above_best", "per_curve", "warnings"}
MATERIAL_KEYS = {"summary", "n_converged", "converged_params", "median_redchi", "warnings"}
WARNING_KEYS = {"total", "by_category", "sentences"}
HERTZ_KEYS = {"status", "file", "label", "format", "curves", "tip", "tip_attrs", "tip_source",
              "command", "per_curve", "summary", "warnings", "seconds"}
HERTZ_CURVE_KEYS = {"curve", "samples", "success", "E", "E_young", "contact_point", "baseline",
                    "baseline_slope", "E_stderr", "E_young_stderr", "contact_point_stderr",
                    "baseline_stderr", "baseline_slope_stderr", "identifiability", "redchi",
                    "residual_lag1", "stderr_correction", "effective_samples", "indentation_m",
                    "contact_force_n", "indentation_over_radius", "baseline_tilt_share",
                    "windows"}
CREEP_KEYS = {"status", "file", "label", "format", "curves", "command", "samples", "pause_s",
              "creep_force_n", "modes", "selection", "selection_note", "params", "redchi",
              "residual_lag1", "stderr_correction", "effective_samples", "window_test",
              "warnings", "seconds"}
COVERAGE_KEYS = {"file", "label", "bytes", "read_as", "load_error", "models", "analysed",
                 "not_run", "outcome", "reason"}
#: the real files (SOURCE.txt of each folder): 2 JPK maps, the .spm and .uff of one Bruker curve,
#: the 15-curve zip, the AFM Workshop csv, the Chiaro zip, 2 Asylum .ibw, 2 JPK creep curves,
#: the JPK stress-relaxation curve and the NT-MDT text export
N_REAL_FILES = 13


def _reject_constant(name: str) -> float:
    raise ValueError(f"non-finite number {name} in real_data.json")


@pytest.fixture(scope="module")
def real(quick_run):
    run = passed(quick_run("real_data"))
    report = json.loads((run.out / "real_data.json").read_text(),
                        parse_constant=_reject_constant)
    return run.out, run.stdout, report


@needs_map
def test_real_data_json_has_the_documented_keys(real):
    _, _, report = real
    assert report["schema"] == "viscoforce.real_data/2"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]
    assert report["radius_m"] == 10e-6
    sets = report["datasets"]
    assert set(sets) == {"jpk_hold", "zip_map", "modulation_map", "hertz", "creep"}
    assert sets["jpk_hold"]["status"] == sets["zip_map"]["status"] == "skipped"
    mod = sets["modulation_map"]
    assert mod["status"] == "ok"
    assert set(mod) == REAL_MAP_KEYS
    assert mod["curves_fitted"] == 4
    assert len(mod["frequencies_hz"]) == 6
    assert set(mod["chooser"]) == CHOOSER_KEYS
    assert set(mod["maps"]) == {"structural", "power-law+mu", "sls"}
    for entry in mod["maps"].values():
        assert set(entry) == MATERIAL_KEYS
        assert set(entry["warnings"]) == WARNING_KEYS
        assert entry["summary"]["n_fits"] == 4
    assert set(mod["chooser"]["warnings"]) == WARNING_KEYS


@needs_map
def test_real_data_numbers_are_finite(real):
    _, _, report = real
    mod = report["datasets"]["modulation_map"]
    chooser = mod["chooser"]
    assert chooser["curves"] == sum(chooser["kept"].values()) == 4
    numbers = [chooser["median_redchi"], chooser["median_chi2_pvalue"], mod["seconds"],
               report["wall_time_s"]]
    numbers += [v for v in chooser["median_bic_above_best"].values() if v is not None]
    for row in chooser["per_curve"]:
        numbers += [row["redchi"], row["chi2_pvalue"]]
        assert min(v for v in row["bic_above_best"].values() if v is not None) == 0.0
    for entry in mod["maps"].values():
        assert entry["n_converged"] > 0
        numbers.append(entry["median_redchi"])
        numbers += [q["median"] for q in entry["converged_params"].values()]
    split = mod["split_half"]
    assert split["frequencies_hz"] == mod["frequencies_hz"]
    numbers += split["rms_z"]["new"] + split["rms_z"]["white"]
    assert all(isinstance(v, int | float) and math.isfinite(v) for v in numbers), numbers
    assert all(v > 0 for v in split["rms_z"]["new"])


@needs_map
def test_real_data_prints_a_markdown_table(real):
    out, stdout, report = real
    lines = stdout.splitlines()
    header = lines.index("| data | command | result |")
    assert lines[header + 1] == "|---|---|---|"
    row = lines[header + 2]
    assert row.startswith("| JPK modulation map") and row.count(" | ") == 2
    assert "viscoforce fit MAP --model auto" in row and "R = 10 µm assumed" in row
    assert (out / "real_data.md").read_text().strip() == report["markdown"]
    with open(out / "real_data_curves.csv", newline="") as handle:
        assert len(list(csv.DictReader(handle))) == 4


def _real_files() -> list[str]:
    return sorted(p.relative_to(DATA).as_posix() for p in DATA.rglob("*") if p.is_file()
                  and p.suffix.lower() != ".md" and not p.name.startswith(("LICENSE", "SOURCE")))


def _finite(values) -> bool:
    return all(isinstance(v, int | float) and math.isfinite(v) for v in values)


@needs_map
@needs_data
def test_real_data_coverage_lists_every_real_file_with_a_model_or_a_reason(real):
    out, stdout, report = real
    cov = report["coverage"]
    assert cov["status"] == "ok"
    names = [e["file"] for e in cov["files"]]
    assert names == _real_files()
    assert cov["n_files"] == len(names) == N_REAL_FILES
    for e in cov["files"]:
        assert COVERAGE_KEYS <= set(e), e["file"]
        assert e["outcome"] in ("analysed", "not run", "refused"), e
        if e["outcome"] == "analysed":
            assert e["analysed"] and set(e["analysed"]) <= set(e["models"]), e
        else:
            assert isinstance(e["reason"], str) and e["reason"].strip(), e
        if e["load_error"] is None:
            assert set(e["models"]) == {"hertz", "creep", "relaxation", "contact"}
            assert all(v == "ok" or v.strip() for v in e["models"].values())
        else:
            assert e["outcome"] == "refused" and e["reason"] == e["load_error"]
            assert str(DATA) not in e["reason"]
    by_name = {e["file"].rsplit("/", 1)[-1]: e for e in cov["files"]}
    # a file without a height channel has no tip position: refused with the library's reason
    csv_entry = by_name["fmt-afm-workshop-fd_single_2021-10-22_14.16.csv"]
    assert csv_entry["outcome"] == "refused" and "tip position" in csv_entry["reason"]
    assert "hertz" in by_name["fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force"]["analysed"]
    lines = stdout.splitlines()
    header = lines.index("| file | read as | analysed with | not analysed: reason |")
    assert len([ln for ln in lines[header + 2:] if ln.startswith("| `")]) == N_REAL_FILES
    assert (out / "real_data_coverage.md").read_text().strip() == cov["markdown"]


@needs_map
@needs_data
def test_real_data_hertz_keys_and_numbers(real):
    _, stdout, report = real
    hertz = report["datasets"]["hertz"]
    assert hertz["status"] == "ok"
    assert hertz["tip_assumed"] == "sphere:5um" and hertz["force_cut"] == 0.5
    fitted = {k: r for k, r in hertz["files"].items() if r["status"] == "ok"}
    assert len(fitted) >= 5  # the single-curve files under --quick
    assert all(r["status"] == "skipped" and r["reason"] == "--quick"
               for r in hertz["files"].values() if r["status"] != "ok")
    for name, r in fitted.items():
        assert HERTZ_KEYS <= set(r), name
        assert r["tip_source"] in ("assumed", "file")
        assert ("--tip sphere:5um" in r["command"]) == (r["tip_source"] == "assumed")
        for c in r["per_curve"]:
            assert set(c) == HERTZ_CURVE_KEYS, name
            assert c["E"] > 0 and c["E_young"] == pytest.approx(0.375 * c["E"])
            assert _finite([c["E_stderr"], c["contact_point_stderr"], c["residual_lag1"],
                            c["stderr_correction"], c["indentation_m"]]), (name, c)
            assert c["stderr_correction"] >= 1
            assert set(c["windows"]) == {"force_to_half", "deep_half"}
            for w in c["windows"].values():
                assert _finite([w["E"], w["shift_in_stderr"], w["relative_shift"]]), (name, w)
                assert w["samples"] < c["samples"]
        assert r["summary"]["n_fitted"] == r["curves"]
    assert "| Hertz, " in stdout and "--model hertz --tip sphere:5um" in stdout


@needs_map
@needs_data
def test_real_data_creep_keys_and_bounds(real):
    _, stdout, report = real
    creep = report["datasets"]["creep"]
    assert creep["status"] == "ok" and creep["window_cut"] == 0.1
    fitted = [r for r in creep["files"].values() if r["status"] == "ok"]
    assert len(fitted) == 1  # --quick: one single-curve pause
    r = fitted[0]
    assert set(r) == CREEP_KEYS
    assert r["modes"] >= 1 and len(r["selection"]) >= r["modes"]
    taus = [k for k in r["params"] if k.startswith("tau_")]
    assert len(taus) == r["modes"]
    for p in r["params"].values():
        assert {"value", "stderr", "identifiability", "bound"} <= set(p)
        # a parameter the profile bounds on one side only is reported as that bound
        if p["identifiability"] in ("lower_bound_only", "upper_bound_only"):
            assert p["bound"] and (" > " in p["bound"] or " < " in p["bound"])
        if p["identifiability"] == "determined":
            assert p["bound"] is None
    assert set(r["window_test"]) == {"first_10_percent_removed", "last_10_percent_removed"}
    for w in r["window_test"].values():
        assert set(w["tau"]) == set(taus)
    assert _finite([r["residual_lag1"], r["stderr_correction"], r["pause_s"], r["creep_force_n"]])
    assert "| creep, " in stdout and "--model creep --modes auto" in stdout


# ── split_half.py, phase_lag_real.py, ting_real.py: the committed JSON stays ─────────────────────

@pytest.mark.parametrize("name", ["split_half", "phase_lag_real", "ting_real"])
def test_a_quick_run_never_replaces_the_committed_json(name, tmp_path):
    study = benchmark_module(f"{name}.py")
    committed = STUDIES / name / f"{name}.json"
    assert committed.is_file()
    assert study.json_path(None, False) == committed  # a full run regenerates it
    assert study.json_path(None, True) == STUDIES / name / "out" / f"{name}.json"
    assert study.json_path(tmp_path, True) == tmp_path / f"{name}.json"  # --out FOLDER
    assert study.json_path(tmp_path / "x.json", False) == tmp_path / "x.json"  # --out FILE


# ── adhesion_pulloff.py ──────────────────────────────────────────────────────────────────────────
# the quick run (μ = 0.01, 0.1, 0.3, 1, 2 and the μ = 1 path): the Bradley limit, the stored
# transition values, Maugis–Dugdale within its documented deviation, where the folds are, the
# files (studies/adhesion_pulloff/README.md)

@pytest.fixture(scope="module")
def adhesion(quick_run):
    return passed(quick_run("adhesion_pulloff"))


def test_adhesion_pulloff_limits_transition_and_folds(adhesion):
    report = adhesion.report
    assert report["schema"] == "viscoforce.adhesion_pulloff/1" and report["quick"] is True
    rows = {r["mu"]: r for r in report["rows"]}
    assert set(rows) == {0.01, 0.1, 0.3, 1.0, 2.0}
    assert rows[0.01]["pull_off_ratio"] == pytest.approx(2.0, rel=0.01)  # Bradley (0.05 %)
    # the committed full run's values (the same grids), guarded at 1e-3
    for mu, stored in ((0.3, 1.87019), (1.0, 1.67039), (2.0, 1.58380)):
        assert rows[mu]["pull_off_ratio"] == pytest.approx(stored, rel=1e-3), mu
    ratios = [r["pull_off_ratio"] for r in report["rows"]]
    assert all(a > b for a, b in zip(ratios, ratios[1:], strict=False))
    for r in report["rows"]:
        assert 0 <= r["deviation_md"] < 0.08, r  # LJ above MD, at most 6 % (README)
        assert (r["jump_in_position_z0"] is None) == (r["mu"] < 0.7), r
        if r["mu"] >= 1:
            assert r["jump_out_position_z0"] > r["jump_in_position_z0"] > 1.0, r
    onset = report["fold_onset"]
    assert onset["status"] == "ok" and 0.69 < onset["mu_low"] < onset["mu_high"] < 0.72
    path = report["path"]
    assert path["n_folds"] == 2 and path["unstable_points"] > 0
    assert path["pull_off_ratio"] == pytest.approx(rows[1.0]["pull_off_ratio"], rel=2e-3)
    assert path["jump_in"]["position_z0"] == pytest.approx(rows[1.0]["jump_in_position_z0"],
                                                          abs=1e-3)


def test_adhesion_pulloff_files_and_where_they_go(adhesion, tmp_path):
    out = adhesion.out
    for name in ("adhesion_pulloff.png", "adhesion_static_path.png"):
        assert (out / name).stat().st_size > 10_000, name
    with (out / "adhesion_pulloff.csv").open(newline="") as fh:
        assert len(list(csv.DictReader(fh))) == len(adhesion.report["rows"])
    study = benchmark_module("adhesion_pulloff.py")
    quick = study.output_paths(None, True)
    assert {p.parent for p in quick.values()} == {STUDIES / "adhesion_pulloff" / "out"}
    full = study.output_paths(None, False)  # a full run: the committed files and docs/
    assert full["json"] == STUDIES / "adhesion_pulloff" / "adhesion_pulloff.json"
    assert full["pull_off_png"] == REPO / "docs" / "adhesion_pulloff.png"
    assert all(p.is_file() for p in full.values())
    assert {p.parent for p in study.output_paths(tmp_path, False).values()} == {tmp_path}
