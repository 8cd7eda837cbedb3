"""Run a timing suite or study script as a subprocess, or its command line in-process (shared by
the smoke tests in tests/benchmarks/ and the tests that reuse a script's functions).

A script is named by its file name: ``bench_load.py`` is ``benchmarks/bench_load.py``,
``split_half.py`` is ``studies/split_half/split_half.py`` (benchmarks/run.py's ``SUITES`` lists
them all). No wall-clock timeout: on a loaded machine a smoke run may take several times its
quiet time, and a timeout would turn that into a failure (issue 22 item 5).
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import subprocess
import sys
from pathlib import Path
from types import ModuleType

REPO = Path(__file__).resolve().parents[1]
BENCH = REPO / "benchmarks"
STUDIES = REPO / "studies"


def script_path(name: str) -> Path:
    """``benchmarks/<name>``, else ``studies/<stem>/<name>`` (a study's script)."""
    path = BENCH / name
    return path if path.is_file() else STUDIES / Path(name).stem / name


def run_benchmark(name: str, *args: str) -> subprocess.CompletedProcess:
    """Run the script ``name`` with ``args``, the Agg backend and this checkout's sources."""
    env = dict(os.environ, MPLBACKEND="Agg")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO / "src"), env.get("PYTHONPATH")]))
    return subprocess.run([sys.executable, str(script_path(name)), *args], capture_output=True,
                          text=True, env=env, check=False)


def benchmark_module(name: str) -> ModuleType:
    """The script ``name`` imported in this process (once; its ``main`` is not run).

    The scripts put ``benchmarks/`` (or a study's folder) on ``sys.path`` for their helpers;
    those entries are taken out again after the import.
    """
    key = f"_benchmark_{Path(name).stem}"
    if key not in sys.modules:
        spec = importlib.util.spec_from_file_location(key, script_path(name))
        module = importlib.util.module_from_spec(spec)
        saved = list(sys.path)
        sys.modules[key] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[key]
            raise
        finally:
            sys.path[:] = saved
    return sys.modules[key]


def run_main(name: str, *args: str) -> tuple[int, str, str]:
    """Exit status, stdout and stderr of ``main(args)`` of the script ``name``, in-process.

    For command-line checks that end before any work (argument errors) and for the ``--quick``
    smoke runs of scripts that measure nothing about fresh processes: it skips the ~1-2 s
    interpreter start and imports of a subprocess. Scripts that time child processes, dask
    workers or start-up (bench_stream, bench_fit, bench_load, bench_startup) run as children.
    """
    # a script's import pins BLAS threads in os.environ and its main() may put benchmarks/ (or a
    # study's folder) on sys.path: both are put back, so later tests in this process see what
    # they saw before
    saved_env, saved_path = dict(os.environ), list(sys.path)
    out, err = io.StringIO(), io.StringIO()
    try:
        main = benchmark_module(name).main
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(list(args))
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else 1
    finally:
        os.environ.clear()
        os.environ.update(saved_env)
        sys.path[:] = saved_path
    return code or 0, out.getvalue(), err.getvalue()
