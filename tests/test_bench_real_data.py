"""Smoke test of benchmarks/real_data.py --quick (the real modulation map; the force-curve half
and the coverage of every real file when the data folder is there; keys, finite numbers and the
Markdown tables, no timing asserted)."""

from __future__ import annotations

import csv
import json
import math
import warnings

import pytest

from tests._bench import REPO, run_main

REAL_MAP = REPO.parent / "shared" / "data" / "real" / "PyFMReader" / (
    "map-data-2021.11.05-17.37.44.432.jpk-force-map")
BUNDLED_MAP = REPO / "data_examples" / "real" / "modulation-map.jpk-force-map"
DATA = REPO.parent / "shared" / "data" / "real"
needs_data = pytest.mark.skipif(not DATA.is_dir(), reason=f"the real data folder {DATA} is absent")

pytestmark = pytest.mark.skipif(not (REAL_MAP.is_file() or BUNDLED_MAP.is_file()),
                                reason="the real JPK modulation map is absent")

TOP_KEYS = {"schema", "created", "quick", "machine", "data_dir", "radius_m", "datasets",
            "coverage", "markdown", "wall_time_s"}
MAP_KEYS = {"status", "file", "curves_in_file", "curves_fitted", "frequencies_hz", "radius_m",
            "radius_note", "load_warnings", "chooser", "maps", "split_half", "seconds"}
CHOOSER_KEYS = {"curves", "kept", "median_redchi", "median_chi2_pvalue", "median_bic_above_best",
                "per_curve", "warnings"}
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
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("real_data")
    # main() in this process (tests._bench.run_main, which puts os.environ and sys.path back),
    # not a child: no interpreter start and imports. The script records its fits' warnings
    # itself; the rest are not errors here, as in a child process.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code, stdout, stderr = run_main("real_data.py", "--quick", "--out", str(out))
    assert code == 0, stdout + stderr
    report = json.loads((out / "real_data.json").read_text(), parse_constant=_reject_constant)
    return out, stdout, report


def test_json_has_the_documented_keys(quick):
    _, _, report = quick
    assert set(report) == TOP_KEYS
    assert report["schema"] == "viscoforce.real_data/2"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]
    assert report["radius_m"] == 10e-6
    sets = report["datasets"]
    assert set(sets) == {"jpk_hold", "zip_map", "modulation_map", "hertz", "creep"}
    assert sets["jpk_hold"]["status"] == sets["zip_map"]["status"] == "skipped"
    mod = sets["modulation_map"]
    assert mod["status"] == "ok"
    assert set(mod) == MAP_KEYS
    assert mod["curves_fitted"] == 4
    assert len(mod["frequencies_hz"]) == 6
    assert set(mod["chooser"]) == CHOOSER_KEYS
    assert set(mod["maps"]) == {"structural", "power-law+mu", "sls"}
    for entry in mod["maps"].values():
        assert set(entry) == MATERIAL_KEYS
        assert set(entry["warnings"]) == WARNING_KEYS
        assert entry["summary"]["n_fits"] == 4
    assert set(mod["chooser"]["warnings"]) == WARNING_KEYS


def test_numbers_are_finite(quick):
    _, _, report = quick
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


def test_prints_a_markdown_table(quick):
    out, stdout, report = quick
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


@needs_data
def test_coverage_lists_every_real_file_with_a_model_or_a_reason(quick):
    out, stdout, report = quick
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


@needs_data
def test_hertz_keys_and_numbers(quick):
    _, stdout, report = quick
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


@needs_data
def test_creep_keys_and_bounds(quick):
    _, stdout, report = quick
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
