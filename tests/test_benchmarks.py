"""Smoke tests of the benchmark scripts in benchmarks/ (their --quick modes).

No wall time is asserted or compared (timings depend on the machine and its load): only the JSON
keys, the deterministic accuracy figures and the exit status.
"""

from __future__ import annotations

import json
import math
import subprocess
from pathlib import Path

import pandas as pd
import pytest

from tests._bench import run_benchmark, run_main

REPO = Path(__file__).resolve().parents[1]
BENCH = REPO / "benchmarks"
#: The FFT peer's loads, copied into the repository (see tests/data/README.md).
PEER_CSV = Path(__file__).parent / "data" / "static_loads_fft_peer.csv"

# documented in benchmarks/README.md, section bench_static.py
STATIC_TOP_KEYS = {"schema", "created", "quick", "machine", "target", "settings", "build",
                   "default_grid", "sweep", "summary", "files"}
STATIC_ROW_KEYS = {"E", "h0", "nodes", "n_panels", "order", "newton_iterations", "force",
                   "force_refined", "rel_error_refined", "force_peer", "rel_error_peer",
                   "time_public_s", "time_public_cpu_s", "time_newton_s"}
STATIC_SWEEP_KEYS = {"case", "E", "h0", "order", "spacing_factor", "nodes", "status",
                     "time_public_s", "time_newton_s", "rel_error", "is_default"}
STATIC_SUMMARY_KEYS = {"worst_time_public_s", "worst_time_newton_s", "worst_rel_error_refined",
                       "worst_rel_error_peer", "passed", "verdict"}


def run_script(name: str, *args: str) -> subprocess.CompletedProcess:
    return run_benchmark(name, *args)


@pytest.fixture(scope="module")
def static_quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench_static")
    proc = run_script("bench_static.py", "--quick", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    return out, proc.stdout


def test_bench_static_quick_writes_documented_json(static_quick):
    out, stdout = static_quick
    report = json.loads((out / "static_benchmark.json").read_text())
    assert set(report) == STATIC_TOP_KEYS
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


def test_bench_static_default_grid_is_accurate(static_quick):
    # deterministic part of the benchmark: the default grid's load agrees with a 4x-refined grid to
    # far better than the 1e-4 target, and with the independent FFT peer (the copy in tests/data,
    # so this always runs) to its stated ~1e-4
    out, _ = static_quick
    report = json.loads((out / "static_benchmark.json").read_text())
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


def test_bench_static_rejects_nonpositive_repeats(tmp_path):
    code, _, stderr = run_main("bench_static.py", "--quick", "--repeats", "0", "--out",
                               str(tmp_path))
    assert code == 2
    assert "--repeats must be >= 1" in stderr
