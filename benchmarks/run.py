#!/usr/bin/env python
"""The one runner of the timing suites (benchmarks/) and the studies (studies/).

``SUITES`` below is the single list of them: name, kind, script, the JSON it writes and the
other files, the arguments of its smoke run, what it needs. Each suite runs as a child process
with BLAS pinned to one thread (``OPENBLAS_NUM_THREADS=1`` etc. in the child's environment),
this checkout's ``src/`` first on ``PYTHONPATH`` and the Agg backend; the runner prints each
suite's status and wall time and exits with status 1 if any failed.

Run ``python benchmarks/run.py --list``, ``python benchmarks/run.py NAME [NAME...] [--quick]
[--out DIR]`` or ``python benchmarks/run.py --all --quick``. Without ``--out`` each suite
writes where it writes by itself (benchmarks/out, studies/<name>/out, or a study's committed
JSON on a full run: see its README); with ``--out DIR`` each writes into ``DIR/<name>/``.
tests/benchmarks/test_smoke.py runs every suite's smoke run (``quick`` below) once.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: The child's environment on top of this process's: every BLAS/OpenMP pool pinned to one thread
#: (before NumPy loads in the child) and a non-interactive matplotlib backend.
PINNED_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
              "VECLIB_MAXIMUM_THREADS": "1", "NUMEXPR_NUM_THREADS": "1", "MPLBACKEND": "Agg"}


@dataclass(frozen=True)
class Suite:
    """One timing suite or study: what the runner runs and the smoke test checks."""

    name: str
    #: ``timing`` (a ``bench_*.py`` in benchmarks/) or ``study`` (studies/<name>/).
    kind: str
    #: The script, relative to the repository root.
    script: str
    #: The JSON report it writes into ``--out``.
    output: str
    #: The other files it writes into ``--out`` (the smoke test checks they exist).
    files: tuple[str, ...] = ()
    #: The arguments of its smoke run (``run.py --quick`` and tests/benchmarks/test_smoke.py).
    quick: tuple[str, ...] = ("--quick",)
    #: Modules it imports beyond the dependencies (skipped without them).
    requires: tuple[str, ...] = ()
    #: A data file it needs, relative to the repository root (skipped without it).
    data: str | None = None

    @property
    def path(self) -> Path:
        """The script's absolute path."""
        return REPO / self.script


_T, _S = "timing", "study"
_PYFMRHEO = "../shared/data/real/PyFMRheo/map-data-2022.10.29-12.27.34.564.jpk-force-map"

#: Every suite, timing suites first, then the studies.
SUITES: dict[str, Suite] = {s.name: s for s in (
    Suite("bench_static", _T, "benchmarks/bench_static.py", "static_benchmark.json",
          ("static_speed_accuracy.png", "static_speed_accuracy.csv")),
    Suite("bench_dynamics", _T, "benchmarks/bench_dynamics.py", "dynamics_benchmark.json",
          ("dynamics_speed_accuracy.png", "dynamics_speed_accuracy.csv")),
    Suite("bench_spectrum", _T, "benchmarks/bench_spectrum.py", "spectrum_benchmark.json",
          ("spectrum_speed_accuracy.png", "spectrum_linear.csv", "spectrum_time_domain.csv",
           "spectrum_periods.csv")),
    Suite("bench_linear", _T, "benchmarks/bench_linear.py", "linear_benchmark.json",
          ("linear_timings.png", "linear_timings.csv")),
    Suite("bench_regression", _T, "benchmarks/bench_regression.py",
          "regression_benchmark.json", ("regression_timings.png", "regression_timings.csv")),
    Suite("bench_step", _T, "benchmarks/bench_step.py", "step.json", ("step.csv", "step.png")),
    Suite("bench_fit", _T, "benchmarks/bench_fit.py", "fit_benchmark.json",
          ("fit_timings.png", "fit_single.csv", "fit_maps.csv"),
          requires=("dask.distributed",)),
    Suite("bench_overhead", _T, "benchmarks/bench_overhead.py", "overhead.json",
          ("overhead.png", "overhead.csv")),
    Suite("bench_chooser", _T, "benchmarks/bench_chooser.py", "chooser.json", ("chooser.csv",),
          quick=("--quick", "--replicas", "1")),
    Suite("bench_maps", _T, "benchmarks/bench_maps.py", "maps.json", ("maps.csv", "maps.png")),
    Suite("bench_load", _T, "benchmarks/bench_load.py", "load.json", ("load.csv", "load.png"),
          requires=("dask.distributed",)),
    Suite("bench_stream", _T, "benchmarks/bench_stream.py", "stream.json",
          ("stream.csv", "stream.png"), requires=("dask.distributed",)),
    Suite("bench_startup", _T, "benchmarks/bench_startup.py", "startup.json", ("startup.csv",),
          quick=("--quick", "--repeats", "1")),
    Suite("bench_budget", _T, "benchmarks/bench_budget.py", "budget.json", ("budget.csv",)),
    Suite("bench_modes_auto", _T, "benchmarks/bench_modes_auto.py", "modes_auto.json",
          ("modes_auto.csv",)),
    Suite("bench_ting_nonuniform", _T, "benchmarks/bench_ting_nonuniform.py",
          "ting_nonuniform.json", ("ting_nonuniform.csv",),
          data="../shared/data/real/PyFMReader/map-data-2021.11.05-17.37.44.432.jpk-force-map"),
    Suite("bench_hertz_speed", _T, "benchmarks/bench_hertz_speed.py", "hertz_speed.json",
          ("hertz_speed.csv",), data=_PYFMRHEO),
    Suite("speed_accuracy", _S, "studies/speed_accuracy/speed_accuracy.py",
          "speed_accuracy.json", ("speed_accuracy.csv", "speed_accuracy.png")),
    Suite("validity_maps", _S, "studies/validity_maps/validity_maps.py", "validity_maps.json",
          ("validity_maps.csv", "validity_maps.png")),
    Suite("real_data", _S, "studies/real_data/real_data.py", "real_data.json",
          ("real_data.md", "real_data_coverage.md", "real_data_curves.csv")),
    Suite("split_half", _S, "studies/split_half/split_half.py", "split_half.json"),
    Suite("phase_lag_real", _S, "studies/phase_lag_real/phase_lag_real.py",
          "phase_lag_real.json"),
    Suite("ting_real", _S, "studies/ting_real/ting_real.py", "ting_real.json", data=_PYFMRHEO),
    Suite("adhesion_pulloff", _S, "studies/adhesion_pulloff/adhesion_pulloff.py",
          "adhesion_pulloff.json", ("adhesion_pulloff.csv", "adhesion_static_path.csv",
                                    "adhesion_pulloff.png", "adhesion_static_path.png")),
    Suite("adhesion_loops", _S, "studies/adhesion_loops/adhesion_loops.py",
          "adhesion_loops.json"),
)}


def missing(suite: Suite) -> str | None:
    """Why ``suite`` cannot run here (a module or its data file is absent), else None."""
    for module in suite.requires:
        try:
            found = importlib.util.find_spec(module) is not None
        except ModuleNotFoundError:
            found = False
        if not found:
            return f"needs {module}"
    if suite.data is not None and not (REPO / suite.data).exists():
        return f"needs {suite.data}"
    return None


def child_env() -> dict[str, str]:
    """This process's environment, BLAS pinned and this checkout's ``src/`` first on the path."""
    env = dict(os.environ, **PINNED_ENV)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO / "src"),
                                                      env.get("PYTHONPATH")]))
    return env


def command(suite: Suite, *, quick: bool = False, out: Path | None = None) -> list[str]:
    """The child's command line: the script, its smoke arguments if ``quick``, ``--out out``."""
    args = [sys.executable, str(suite.path), *(suite.quick if quick else ())]
    return args + (["--out", str(out)] if out is not None else [])


def run(suite: Suite, *, quick: bool = False, out: Path | None = None,
        capture: bool = False) -> subprocess.CompletedProcess:
    """Run one suite as a child process (``out``: its output folder); never raises on failure."""
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
    return subprocess.run(command(suite, quick=quick, out=out), env=child_env(), check=False,
                          capture_output=capture, text=True)


def parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", metavar="NAME", help="suites to run (see --list)")
    parser.add_argument("--list", action="store_true", help="list the suites and exit")
    parser.add_argument("--all", action="store_true", help="run every suite")
    parser.add_argument("--quick", action="store_true",
                        help="each suite's smoke run (its --quick; see --list)")
    parser.add_argument("--out", type=Path, default=None,
                        help="write each suite's outputs to OUT/NAME/ (default: the suite's own)")
    args = parser.parse_args(argv)
    unknown = [n for n in args.names if n not in SUITES]
    if unknown:
        parser.error(f"unknown suite(s) {', '.join(unknown)}; --list shows them")
    if not args.list and not args.all and not args.names:
        parser.error("name one or more suites, or --all (--list shows them)")
    if args.all and args.names:
        parser.error("--all runs every suite: give names or --all, not both")
    return args


def print_list() -> None:
    print(f"{'name':16} {'kind':6} {'script':44} {'writes':26} smoke run")
    for s in SUITES.values():
        why = missing(s)
        print(f"{s.name:16} {s.kind:6} {s.script:44} {s.output:26} {' '.join(s.quick)}"
              + (f"  [not here: {why}]" if why else ""))


def main(argv: list[str] | None = None) -> int:
    """Run the suites asked for; 0 if none failed, else 1."""
    args = parse(argv)
    if args.list:
        print_list()
        return 0
    suites = list(SUITES.values()) if args.all else [SUITES[n] for n in args.names]
    pinned = " ".join(f"{k}={v}" for k, v in PINNED_ENV.items() if k != "MPLBACKEND")
    print(f"{len(suites)} suite(s){' (smoke runs)' if args.quick else ''}, each a child process "
          f"with BLAS pinned to one thread: {pinned}")
    status: dict[str, tuple[str, float]] = {}
    for suite in suites:
        why = missing(suite)
        if why:
            status[suite.name] = (f"skipped ({why})", 0.0)
            print(f"\n== {suite.name}: skipped, {why}", flush=True)
            continue
        out = args.out / suite.name if args.out is not None else None
        print(f"\n== {suite.name}: {' '.join(command(suite, quick=args.quick, out=out)[1:])}",
              flush=True)
        t0 = time.perf_counter()
        proc = run(suite, quick=args.quick, out=out)
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            state = f"FAILED (exit status {proc.returncode})"
        elif out is not None and not (out / suite.output).is_file():
            state = f"FAILED (no {suite.output} written)"
        else:
            state = "ok"
        status[suite.name] = (state, wall)
        print(f"-- {suite.name}: {state} in {wall:.1f} s", flush=True)
    print("\nsummary (wall time per suite):")
    for name, (state, wall) in status.items():
        print(f"  {name:16} {state:40} {wall:7.1f} s")
    failed = [n for n, (state, _) in status.items() if state.startswith("FAILED")]
    print(f"{len(status) - len(failed)} of {len(status)} ok or skipped"
          + (f"; failed: {', '.join(failed)}" if failed else ""))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
