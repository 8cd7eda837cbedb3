"""Helpers shared by the timing suites in benchmarks/ and the studies in studies/.

Plain functions only: the common command line, machine facts and the BLAS report, wall/CPU timing
with the garbage collector paused, the one-off kernel build, and JSON/CSV output. Each script
puts ``benchmarks/`` on ``sys.path`` from its own location and imports this module (``benchmarks/``
is not a package); the printed text, JSON keys and CSV columns the scripts produce are documented
in benchmarks/README.md (timing suites) and studies/<name>/README.md (studies).
"""

from __future__ import annotations

import argparse
import csv
import gc
import json
import math
import os
import platform
import statistics
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import scipy
from threadpoolctl import threadpool_info

import viscoforce as vf
from viscoforce.kernel import _node_matrix_unit

#: Default output folder of the timing suites: benchmarks/out next to the scripts (a study passes
#: its own, studies/<name>/out).
OUT_DIR = Path(__file__).resolve().parent / "out"
#: The repository root (benchmarks/ and studies/ are folders of it).
REPO = OUT_DIR.parents[1]


# ── command line ─────────────────────────────────────────────────────────────────────────────────

def parse_args(argv: list[str] | None, *, doc: str, quick_help: str, repeats_help: str,
               min_repeats: int = 1, out_dir: Path = OUT_DIR) -> argparse.Namespace:
    """Parse the options every benchmark takes: ``--quick``, ``--out DIR`` and ``--repeats N``.

    Parameters
    ----------
    argv : list of str or None
        Command-line arguments (None: ``sys.argv[1:]``).
    doc : str
        The script's module docstring; its first line is the description.
    quick_help, repeats_help : str
        Help texts of ``--quick`` and ``--repeats``.
    min_repeats : int
        Smallest accepted ``--repeats``; a smaller value exits with status 2 and the message
        ``--repeats must be >= min_repeats``.
    out_dir : Path
        Default of ``--out`` (benchmarks/out; a study passes its studies/<name>/out).

    Returns
    -------
    argparse.Namespace
        ``quick`` (bool), ``out`` (Path), ``repeats`` (int or None when not given).
    """
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help=quick_help)
    parser.add_argument("--out", type=Path, default=out_dir,
                        help=f"output folder (default: {_shown(out_dir)})")
    parser.add_argument("--repeats", type=int, default=None, help=repeats_help)
    args = parser.parse_args(argv)
    if args.repeats is not None and args.repeats < min_repeats:
        parser.error(f"--repeats must be >= {min_repeats}")
    return args


def _shown(path: Path) -> str:
    """``path`` relative to the repository root where it is inside it (for help texts)."""
    try:
        return path.relative_to(REPO).as_posix()
    except ValueError:
        return str(path)


# ── timing ───────────────────────────────────────────────────────────────────────────────────────

@contextmanager
def gc_paused() -> Iterator[None]:
    """Switch the garbage collector off for the block (timeit-style); restore it afterwards."""
    gc_was_on = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if gc_was_on:
            gc.enable()


def timed(fn: Callable[[], object], repeats: int, *, cheap_below: float | None = None,
          cheap_repeats: int = 3) -> tuple[object, dict]:
    """Run ``fn`` ``repeats`` times with the garbage collector off; more often if it is cheap.

    Parameters
    ----------
    fn : callable
        The deterministic run to time (no arguments).
    repeats : int
        Number of runs.
    cheap_below : float or None
        If given and the first run takes less than this [s], run ``max(repeats, cheap_repeats)``
        times instead.
    cheap_repeats : int
        Number of runs of a cheap ``fn``.

    Returns
    -------
    tuple
        The first result (runs are deterministic) and the statistics ``time_median_s``,
        ``time_min_s``, ``cpu_median_s`` [s] (wall and process CPU time per run) and ``repeats``.
    """
    wall, cpu, result = [], [], None
    with gc_paused():
        n = repeats
        while len(wall) < n:
            c0, t0 = time.process_time(), time.perf_counter()
            out = fn()
            t1, c1 = time.perf_counter(), time.process_time()
            wall.append(t1 - t0)
            cpu.append(c1 - c0)
            if result is None:
                result = out
                if cheap_below is not None and wall[0] < cheap_below:
                    n = max(n, cheap_repeats)
    return result, {"time_median_s": statistics.median(wall), "time_min_s": min(wall),
                    "cpu_median_s": statistics.median(cpu), "repeats": len(wall)}


def cold_build(problem: vf.ContactProblem) -> float:
    """Time [s] to build the influence matrix and centre row from an empty kernel cache."""
    _node_matrix_unit.cache_clear()
    t0 = time.perf_counter()
    _ = problem.influence
    _ = problem.center_row
    return time.perf_counter() - t0


# ── machine facts ────────────────────────────────────────────────────────────────────────────────

def load_average() -> list[float] | None:
    """1, 5 and 15 min load averages (None where the OS has none)."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        return None


def cpu_model() -> str:
    """The CPU model name from /proc/cpuinfo (else what :mod:`platform` knows)."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_facts(*, cpu_model_name: bool = True) -> dict:
    """Interpreter, library versions, BLAS libraries with their thread counts, load average.

    Parameters
    ----------
    cpu_model_name : bool
        True: a ``cpu`` entry with the CPU model name; False: a ``processor`` entry with the
        machine type instead (bench_static.py's documented key).

    Returns
    -------
    dict
        The ``machine`` entry of a benchmark's JSON report (see benchmarks/README.md).
    """
    blas = [{"internal_api": d.get("internal_api"), "version": d.get("version"),
             "num_threads": d.get("num_threads"), "threading_layer": d.get("threading_layer"),
             "architecture": d.get("architecture"), "library": Path(d.get("filepath", "")).name}
            for d in threadpool_info() if d.get("user_api") == "blas"]
    cpu = {"cpu": cpu_model()} if cpu_model_name else {"processor": platform.machine()}
    return {"python": platform.python_version(), "implementation": platform.python_implementation(),
            "platform": platform.platform(), **cpu, "cpu_count": os.cpu_count(),
            "numpy": np.__version__, "scipy": scipy.__version__, "viscoforce": vf.__version__,
            "blas": blas, "blas_threads": sorted({b["num_threads"] for b in blas}),
            "loadavg_start": load_average()}


def print_machine(machine: dict) -> None:
    """Print the interpreter/library line and one line per BLAS library of ``machine``.

    The CPU model and each BLAS library's architecture are printed when ``machine`` has a ``cpu``
    entry (see :func:`machine_facts`).
    """
    detailed = "cpu" in machine
    cpu = f"CPU {machine['cpu']}, " if detailed else ""
    print(f"python {machine['python']} ({machine['implementation']}), numpy "
          f"{machine['numpy']}, scipy {machine['scipy']}, {cpu}os.cpu_count() = "
          f"{machine['cpu_count']}, {machine['platform']}")
    for b in machine["blas"]:
        arch = f", {b['architecture']}" if detailed else ""
        print(f"BLAS: {b['internal_api']} {b['version']} ({b['library']}{arch}), "
              f"num_threads = {b['num_threads']}")


# ── output ───────────────────────────────────────────────────────────────────────────────────────

def report_head(schema: str, quick: bool, machine: dict) -> dict:
    """The first four entries of every JSON report: schema, creation time (UTC), quick, machine."""
    return {"schema": schema, "created": datetime.now(UTC).isoformat(timespec="seconds"),
            "quick": quick, "machine": machine}


def run_end(t_start: float) -> dict:
    """``wall_time_s`` since ``t_start`` (a ``time.perf_counter`` value) and ``loadavg_end``."""
    return {"wall_time_s": time.perf_counter() - t_start, "loadavg_end": load_average()}


def clean(obj):
    """JSON-safe copy: NaN/inf → None, numpy arrays → lists, numpy scalars → Python."""
    if isinstance(obj, dict):
        return {k: clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return clean(obj.tolist())
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def write_json(report: dict, path: Path) -> None:
    """Write ``report`` to ``path`` as strict JSON (NaN/inf as null, see :func:`clean`)."""
    path.write_text(json.dumps(clean(report), indent=2, allow_nan=False) + "\n")


def write_csv(rows: list[dict], path: Path) -> None:
    """Write ``rows`` to ``path`` as CSV; the columns are every key in order of first appearance."""
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)


def fmt(x: float, spec: str = "9.2e") -> str:
    """``format(x, spec)``, or ``n/a`` padded to the width of ``spec`` when ``x`` is not finite."""
    width = spec.split(".")[0]
    if not math.isfinite(x):
        return "n/a".rjust(int(width)) if width else "n/a"
    return format(x, spec)


def pf(flag: bool) -> str:
    """``PASS`` or ``FAIL``."""
    return "PASS" if flag else "FAIL"
