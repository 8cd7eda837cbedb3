"""Smoke test of benchmarks/real_data.py --quick (the real modulation map; keys, finite numbers and
the Markdown table, no timing asserted)."""

from __future__ import annotations

import csv
import json
import math

import pytest

from tests._bench import REPO, run_benchmark

REAL_MAP = REPO.parent / "shared" / "data" / "real" / "PyFMReader" / (
    "map-data-2021.11.05-17.37.44.432.jpk-force-map")
BUNDLED_MAP = REPO / "data_examples" / "real" / "modulation-map.jpk-force-map"

pytestmark = pytest.mark.skipif(not (REAL_MAP.is_file() or BUNDLED_MAP.is_file()),
                                reason="the real JPK modulation map is absent")

TOP_KEYS = {"schema", "created", "quick", "machine", "data_dir", "radius_m", "datasets",
            "markdown", "wall_time_s"}
MAP_KEYS = {"status", "file", "curves_in_file", "curves_fitted", "frequencies_hz", "radius_m",
            "radius_note", "load_warnings", "chooser", "maps", "split_half", "seconds"}
CHOOSER_KEYS = {"curves", "kept", "median_redchi", "median_chi2_pvalue", "median_bic_above_best",
                "per_curve", "warnings"}
MATERIAL_KEYS = {"summary", "n_converged", "converged_params", "median_redchi", "warnings"}
WARNING_KEYS = {"total", "by_category", "sentences"}


def _reject_constant(name: str) -> float:
    raise ValueError(f"non-finite number {name} in real_data.json")


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("real_data")
    proc = run_benchmark("real_data.py", "--quick", "--out", str(out))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    report = json.loads((out / "real_data.json").read_text(), parse_constant=_reject_constant)
    return out, proc.stdout, report


def test_json_has_the_documented_keys(quick):
    _, _, report = quick
    assert set(report) == TOP_KEYS
    assert report["schema"] == "viscoforce.real_data/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]
    assert report["radius_m"] == 10e-6
    sets = report["datasets"]
    assert set(sets) == {"jpk_hold", "zip_map", "modulation_map"}
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
