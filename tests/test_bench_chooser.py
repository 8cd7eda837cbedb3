"""benchmarks/bench_chooser.py --quick runs and writes what benchmarks/README.md documents."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_chooser.py"


def test_quick_run_writes_documented_files(tmp_path):
    proc = subprocess.run([sys.executable, str(SCRIPT), "--quick", "--replicas", "1", "--out",
                           str(tmp_path)],
                          capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stderr
    report = json.loads((tmp_path / "chooser.json").read_text())
    assert set(report) >= {"real", "synthetic", "replicas", "blas_threads"}
    assert set(report["synthetic"]) == {"structural", "sls", "prony 2"}
    for row in report["synthetic"].values():
        assert 0.0 <= row["right"] <= 1.0 and len(row["picks"]) == report["replicas"]
    for row in report["real"]:
        assert row["wall_s"] > 0 and row["kept"]
    assert "PASS" in proc.stdout or "FAIL" in proc.stdout
    assert (tmp_path / "chooser.csv").is_file()
