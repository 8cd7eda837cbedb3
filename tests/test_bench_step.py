"""Smoke test of benchmarks/bench_step.py (--quick: the step case, one repeat; no time asserted)."""

from __future__ import annotations

import csv
import json
import warnings

import pytest

from tests._bench import benchmark_module, run_main

TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "results", "summary",
            "files", "wall_time_s", "loadavg_end"}


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_step")
    # main() in this process (tests._bench.run_main), not a child: no interpreter start and
    # imports. Its own warnings are recorded by the script where they matter; the rest are
    # not errors here, as in a child process.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        code, stdout, stderr = run_main("bench_step.py", "--quick", "--out", str(out))
    assert code == 0, stderr
    return out, stdout, json.loads((out / "step.json").read_text())


def test_writes_the_documented_json(report):
    bench = benchmark_module("bench_step.py")
    _, stdout, data = report
    assert set(data) == TOP_KEYS == set(bench.JSON_KEYS)
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


def test_writes_one_csv_row_per_fit_and_the_plot(report):
    out, _, data = report
    with (out / "step.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert sorted(r["path"] for r in rows) == ["new", "old"]
    assert {"case", "path", "repeat", "cpu_s", "wall_s", "nfev", "simulations",
            "newton"} <= set(rows[0])
    assert (out / "step.png").stat().st_size > 0
    assert data["files"] == {"json": "step.json", "csv": "step.csv", "png": "step.png"}
