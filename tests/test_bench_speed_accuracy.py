"""Smoke test of benchmarks/speed_accuracy.py (its --quick mode).

No wall time is asserted or compared (timings depend on the machine and its load): only the JSON
keys, the rows being complete (finite time and error, or a ``fails: ...`` status), one default
per method and scene, and the files written.
"""

from __future__ import annotations

import csv
import json
import math
import warnings

import pytest

from tests._bench import run_main

# documented in benchmarks/README.md, section speed_accuracy.py
TOP_KEYS = {"schema", "created", "quick", "machine", "settings", "rows", "summary", "files"}
ROW_KEYS = {"scene", "method", "knob", "value", "time_s", "error", "status", "is_default",
            "reference", "detail"}
SCENES = {"static 2 nm", "static -5 nm", "static -10 nm", "Fig. 3 spectrum", "Fig. 4 spectrum",
          "Fig. 1 step", "Fig. 5 loop", "30-point fit", "deep spectrum"}
NO_DEFAULT = {"linear vs td"}  # a comparison row, not a method of its own


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("speed_accuracy")
    # main() in this process (tests._bench.run_main), not a child: no interpreter start and
    # imports. Its own warnings are recorded by the script where they matter; the rest are
    # not errors here, as in a child process.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code, stdout, stderr = run_main("speed_accuracy.py", "--quick", "--out", str(out))
    assert code == 0, stderr
    return out, stdout, json.loads((out / "speed_accuracy.json").read_text())


def test_quick_run_writes_documented_files(quick):
    out, stdout, report = quick
    assert set(report) == TOP_KEYS
    assert report["schema"] == "viscoforce.speed_accuracy/1"
    assert report["quick"] is True
    assert report["machine"]["blas_threads"] == [1]  # BLAS pinned to one thread
    assert set(report["files"].values()) == {"speed_accuracy.json", "speed_accuracy.csv",
                                             "speed_accuracy.png"}
    assert (out / "speed_accuracy.png").stat().st_size > 10_000
    with (out / "speed_accuracy.csv").open(newline="") as fh:
        csv_rows = list(csv.DictReader(fh))
    assert len(csv_rows) == len(report["rows"])
    assert ROW_KEYS <= set(csv_rows[0])
    assert f"{len(report['rows'])} rows" in stdout


def test_every_row_is_complete(quick):
    _, _, report = quick
    rows = report["rows"]
    assert {r["scene"] for r in rows} == SCENES
    for r in rows:
        assert ROW_KEYS <= set(r), r
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
    assert report["summary"]["failed"] == len([r for r in rows if r["status"] != "ok"])


def test_one_default_per_method_and_scene(quick):
    _, _, report = quick
    pairs = {(r["scene"], r["method"]) for r in report["rows"] if r["method"] not in NO_DEFAULT}
    for scene, method in pairs:
        defaults = [r for r in report["rows"]
                    if (r["scene"], r["method"]) == (scene, method) and r["is_default"]]
        assert len(defaults) == 1, (scene, method)


def test_deterministic_accuracy(quick):
    # the default static grid is within 1e-4 of the 4x-refined one; the default linear spectrum
    # within 1e-6 of its refined reference (both are far tighter; loose bounds, no timing)
    _, _, report = quick
    for r in report["rows"]:
        if r["is_default"] and r["method"] in {"static_equilibrium", "linear"}:
            assert r["error"] < 1e-6, r
