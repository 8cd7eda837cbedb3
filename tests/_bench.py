"""Run a benchmark script as a subprocess (shared by the benchmark smoke tests)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BENCH = REPO / "benchmarks"


def run_benchmark(name: str, *args: str) -> subprocess.CompletedProcess:
    """Run ``benchmarks/<name> *args`` with the Agg backend and this checkout's sources."""
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO / "src"), env.get("PYTHONPATH")]))
    return subprocess.run([sys.executable, str(BENCH / name), *args], capture_output=True,
                          text=True, env=env, timeout=300, check=False)
