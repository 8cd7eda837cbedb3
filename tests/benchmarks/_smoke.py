"""Each suite's smoke run, once per test session (shared by the files of tests/benchmarks/).

``quick_run(name)`` runs the suite ``name`` of benchmarks/run.py's ``SUITES`` with its smoke
arguments (``Suite.quick``) and ``--out`` a folder of its own, and returns a :class:`QuickRun`.
The first request runs it; later ones, in this process or in another xdist worker of the same
session, read the stored result (a file lock per suite, in the session's shared temporary
folder), so the parametrised smoke test and the per-suite checks share one run. Scripts that
time child processes, dask workers or start-up run as children through benchmarks/run.py
(BLAS pinned in the child's environment); the others in this process (tests._bench.run_main:
no interpreter start and imports), their warnings not errors here, as in a child. No wall time
is asserted anywhere, and there is no timeout.
"""

from __future__ import annotations

import contextlib
import json
import traceback
import warnings
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import pytest

from tests._bench import benchmark_module, run_main

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: each xdist worker runs its own
    fcntl = None

RUNNER = benchmark_module("run.py")
SUITES = RUNNER.SUITES
#: Suites whose smoke run is ``main()`` in this process: they measure nothing about fresh
#: processes (the rest time child processes, dask workers or the interpreter's start-up).
#: bench_chooser, bench_linear and bench_modes_auto pin BLAS with threadpoolctl in main();
#: bench_budget pins it in os.environ at import, which does not reach the BLAS already loaded
#: here: its smoke run's timings differ, and no check reads them (nor its BLAS threads).
IN_PROCESS = frozenset({"bench_dynamics", "bench_spectrum", "bench_step", "speed_accuracy",
                        "validity_maps", "real_data", "split_half", "phase_lag_real",
                        "ting_real", "adhesion_pulloff", "bench_chooser", "bench_linear",
                        "bench_modes_auto", "bench_budget"})


#: Suites whose smoke run takes more than about 3 s on a quiet 2-core machine (measured
#: 2026-12-06: bench_stream 18 s, bench_load, bench_spectrum, bench_ting_nonuniform 8 s,
#: bench_fit 7 s, bench_static 5 s, the others 3-5 s): their smoke runs and the checks on
#: them are slow tests (``-m slow``; CI skips them to keep the suite near its 3 minutes, they
#: stay runnable: ``python -m pytest -m slow tests/benchmarks``). The cheaper suites' smoke runs
#: stay in CI.
HEAVY_SMOKE = frozenset({"bench_stream", "bench_load", "bench_spectrum", "bench_ting_nonuniform",
                         "bench_fit", "bench_static", "bench_regression", "bench_startup",
                         "bench_overhead", "bench_dynamics", "bench_hertz_speed", "bench_step"})


def suite_of(item: pytest.Item) -> str | None:
    """The suite a test of tests/benchmarks/ checks: its ``name`` parameter or its name's."""
    callspec = getattr(item, "callspec", None)
    if callspec is not None and callspec.params.get("name") in SUITES:
        return str(callspec.params["name"])
    return next((s for s in sorted(SUITES, key=len, reverse=True)
                 if item.name.startswith(f"test_{s}_")), None)


@dataclass(frozen=True)
class QuickRun:
    """A finished smoke run: its suite, output folder, exit status and printed text."""

    name: str
    out: Path
    code: int
    stdout: str
    stderr: str

    @cached_property
    def report(self) -> dict:
        """The suite's JSON report (``Suite.output`` in ``out``)."""
        return json.loads((self.out / SUITES[self.name].output).read_text())


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """Hold an exclusive lock on ``path`` (a no-op where fcntl is missing)."""
    with path.open("a") as handle:
        if fcntl is not None:
            fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            if fcntl is not None:
                fcntl.flock(handle, fcntl.LOCK_UN)


def _run(name: str, out: Path) -> tuple[int, str, str]:
    """Exit status, stdout and stderr of the smoke run of ``name`` writing into ``out``."""
    suite = SUITES[name]
    args = (*suite.quick, "--out", str(out))
    if name in IN_PROCESS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                return run_main(suite.path.name, *args)
            except Exception:  # stored like a child's crash: every check reports it, once
                return 1, "", traceback.format_exc()
    proc = RUNNER.run(suite, quick=True, out=out, capture=True)
    return proc.returncode, proc.stdout, proc.stderr


def passed(run: QuickRun) -> QuickRun:
    """``run`` after asserting that it exited 0 (its stderr, and stdout, as the message)."""
    assert run.code == 0, run.stdout[-2000:] + run.stderr
    return run


def quick_runs(root: Path) -> Callable[[str], QuickRun]:
    """The ``quick_run`` fixture's function, its results stored under ``root``."""
    root.mkdir(exist_ok=True)
    done: dict[str, QuickRun] = {}

    def get(name: str) -> QuickRun:
        suite = SUITES[name]
        for module in suite.requires:
            pytest.importorskip(module)
        why = RUNNER.missing(suite)
        if why:
            pytest.skip(f"{name}: {why}")
        if name not in done:
            out, result = root / name, root / f"{name}.result.json"
            with _locked(root / f"{name}.lock"):
                if not result.is_file():
                    out.mkdir(exist_ok=True)
                    code, stdout, stderr = _run(name, out)
                    result.write_text(json.dumps({"code": code, "stdout": stdout,
                                                  "stderr": stderr}))
                stored = json.loads(result.read_text())
            done[name] = QuickRun(name, out, stored["code"], stored["stdout"], stored["stderr"])
        return done[name]

    return get
