"""Time a previous release of viscoforce side by side with the current tree, in one run.

Two worker subprocesses run the same harness: ``current`` imports viscoforce from this checkout's
``src/`` and ``previous`` from a git revision extracted into a temporary folder
(``git archive REV src``, untarred there; no worktree is left behind). Both start with
``PYTHONPATH=<tree>/src``, one BLAS/OpenMP thread (environment and ``threadpoolctl``), the garbage
collector paused while timing and warnings ignored, and each checks that it imported viscoforce
from its own tree. A benchmark then interleaves rounds (``current``, ``previous``, ``current``,
…) so that a burst of load from another process spoils one round of every case instead of many
samples of one.

Protocol: one JSON object per line on the worker's stdin, one reply per line on its stdout.

- ``{"op": "hello"}`` → ``viscoforce_file``, ``version``, ``blas_threads``, ``pid``, ``python``;
- ``{"op": "setup", "case": NAME, "params": {...}, "warmup": N}`` builds the case (once per
  (name, params)) and runs it ``N`` times untimed;
- ``{"op": "time", "case": NAME, "params": {...}, "calls": N}`` → ``cpu_s`` and ``wall_s``: the
  process CPU and wall time per call [s], the mean over ``N`` calls (each preceded by the case's
  untimed ``reset``, if it has one; without ``reset`` the ``N`` calls are timed as one batch);
- ``{"op": "value", "case": NAME, "params": {...}}`` → ``value``: the case's JSON-able check
  values (to see that both versions compute the same thing);
- ``{"op": "quit"}``.

A failing request replies ``{"error": traceback}``; the parent raises :class:`WorkerError`.

Cases are named functions in a *cases module* of this folder (``benchmarks/``), imported by both
workers, so they must only use API present in both versions. Each takes keyword parameters
(JSON values) and returns a :class:`Case`. Register them in the module's ``CASES`` dict.

Use (see bench_regression.py)::

    with Workers("_regression_cases", previous=PREVIOUS_RELEASE) as workers:
        print(workers.note)            # why the previous release is missing, if it is
        for label, worker in workers.items():   # "current", then "previous" when available
            worker.setup("static_equilibrium", {"position": -5e-9}, warmup=3)
            cpu, wall = worker.time("static_equilibrium", {"position": -5e-9}, calls=5)

``python benchmarks/_previous.py --worker MODULE`` is the worker's entry point (not for users).
"""

from __future__ import annotations

import gc
import importlib
import io
import json
import os
import platform
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
#: The previous release timed by default: the last commit before issue 22's work started
#: (``linear_response`` already ran the direct finite-amplitude check on every call there).
PREVIOUS_RELEASE = "b8f8e44"
#: ``previous`` value of :class:`Workers` for an A/A control (the current sources twice).
SELF = "current"
#: Environment of every worker: one BLAS/OpenMP thread.
THREAD_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


@dataclass(frozen=True)
class Case:
    """One timed call of a cases module.

    Attributes
    ----------
    run : callable
        The call to time (no arguments).
    reset : callable, optional
        Untimed, before every timed call (e.g. clear caches, build a new problem: a cold call).
    value : callable, optional
        JSON-able check values of the call (lists of floats, numbers, strings).
    """

    run: Callable[[], object]
    reset: Callable[[], None] | None = None
    value: Callable[[], object] | None = None


class PreviousUnavailable(RuntimeError):
    """The previous release cannot be extracted or started (no git, unknown revision, ...)."""


class WorkerError(RuntimeError):
    """A worker replied with an error (the message holds the worker's traceback)."""


# ── the parent side ──────────────────────────────────────────────────────────────────────────────

def resolve_revision(rev: str, repo: Path = REPO) -> str:
    """The full commit hash of ``rev`` in ``repo``; PreviousUnavailable if git or ``rev`` is not."""
    try:
        proc = subprocess.run(["git", "-C", str(repo), "rev-parse", "--verify", "--quiet",
                               f"{rev}^{{commit}}"], capture_output=True, text=True, check=False)
    except OSError as exc:
        raise PreviousUnavailable(f"git is not available ({exc})") from None
    if proc.returncode != 0:
        raise PreviousUnavailable(f"revision {rev!r} is not a commit of {repo}")
    return proc.stdout.strip()


def extract_tree(rev: str, dest: Path, repo: Path = REPO) -> Path:
    """Extract ``src/`` of commit ``rev`` into ``dest`` (``git archive``); return ``dest/src``."""
    proc = subprocess.run(["git", "-C", str(repo), "archive", "--format=tar", rev, "src"],
                          capture_output=True, check=False)
    if proc.returncode != 0:
        raise PreviousUnavailable(f"git archive {rev} src failed: "
                                  f"{proc.stderr.decode(errors='replace').strip()}")
    with tarfile.open(fileobj=io.BytesIO(proc.stdout)) as tar:
        tar.extractall(dest, filter="data")
    src = dest / "src"
    if not (src / "viscoforce" / "__init__.py").is_file():
        raise PreviousUnavailable(f"revision {rev} has no src/viscoforce package")
    return src


class Worker:
    """A worker subprocess importing viscoforce from ``src`` and the cases module ``cases``."""

    def __init__(self, label: str, src: Path, cases: str):
        self.label, self.src = label, Path(src).resolve()
        env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
        env.update(THREAD_ENV, PYTHONPATH=str(self.src), MPLBACKEND="Agg")
        self._proc = subprocess.Popen(
            [sys.executable, "-u", str(Path(__file__).resolve()), "--worker", cases],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env, cwd=str(BENCH))
        self.info: dict = {}

    def request(self, **message) -> dict:
        """Send one request; its reply (WorkerError if the worker failed or died)."""
        try:
            self._proc.stdin.write(json.dumps(message) + "\n")
            self._proc.stdin.flush()
            line = self._proc.stdout.readline()
        except (BrokenPipeError, OSError) as exc:
            raise WorkerError(f"{self.label} worker is gone ({exc})") from None
        if not line:
            raise WorkerError(f"{self.label} worker exited (status {self._proc.wait()}) on "
                              f"{message}")
        reply = json.loads(line)
        if "error" in reply:
            raise WorkerError(f"{self.label} worker, request {message}:\n{reply['error']}")
        return reply

    def hello(self) -> dict:
        """The worker's facts; WorkerError unless it imported viscoforce from its own tree."""
        self.info = self.request(op="hello")
        imported = Path(self.info["viscoforce_file"]).resolve()
        if self.src not in imported.parents:
            raise WorkerError(f"{self.label} worker imported viscoforce from {imported}, not "
                              f"from {self.src}")
        return self.info

    def setup(self, case: str, params: dict, *, warmup: int = 2) -> None:
        """Build ``case`` with ``params`` in the worker and run it ``warmup`` times untimed."""
        self.request(op="setup", case=case, params=params, warmup=warmup)

    def time(self, case: str, params: dict, *, calls: int) -> tuple[float, float]:
        """Process CPU and wall time per call [s] of ``calls`` calls of a set-up case."""
        reply = self.request(op="time", case=case, params=params, calls=calls)
        return reply["cpu_s"], reply["wall_s"]

    def value(self, case: str, params: dict):
        """The case's check values (after a setup)."""
        return self.request(op="value", case=case, params=params)["value"]

    def close(self) -> None:
        """Ask the worker to quit; kill it if it does not within 10 s."""
        if self._proc.poll() is None:
            try:
                self._proc.stdin.write(json.dumps({"op": "quit"}) + "\n")
                self._proc.stdin.flush()
                self._proc.wait(timeout=10)
            except (OSError, subprocess.TimeoutExpired):
                self._proc.kill()
                self._proc.wait()
        for stream in (self._proc.stdin, self._proc.stdout):
            stream.close()


class Workers:
    """Context manager: the ``current`` worker and, if available, the ``previous`` one.

    Parameters
    ----------
    cases : str
        Name of the cases module in ``benchmarks/`` (e.g. ``"_regression_cases"``).
    previous : str or None
        Git revision of the previous release (default :data:`PREVIOUS_RELEASE`); None: none;
        :data:`SELF` (``"current"``): the current sources again, in a second worker — an A/A
        control whose ratios show the noise floor of two processes running identical code.
    current_src : Path
        viscoforce sources of the current worker (default this checkout's ``src/``).

    Attributes
    ----------
    workers : dict
        ``{"current": Worker, "previous": Worker}`` (``previous`` missing if unavailable).
    previous_commit : str or None
        Full hash of the previous release, when it runs.
    note : str or None
        Why the previous release is not timed (None when it is).
    """

    def __init__(self, cases: str, *, previous: str | None = PREVIOUS_RELEASE,
                 current_src: Path = REPO / "src"):
        self.cases, self.previous, self.current_src = cases, previous, current_src
        self.workers: dict[str, Worker] = {}
        self.previous_commit: str | None = None
        self.note: str | None = None if previous else "previous release not requested"
        self._tmp: str | None = None

    def __enter__(self) -> Workers:
        try:
            self.workers["current"] = Worker("current", self.current_src, self.cases)
            prev_src = self._previous_tree()
            if prev_src is not None:
                self.workers["previous"] = Worker("previous", prev_src, self.cases)
            self.workers["current"].hello()
            if "previous" in self.workers:
                try:
                    self.workers["previous"].hello()
                except WorkerError as exc:
                    self.workers.pop("previous").close()
                    self.note = f"previous release {self.previous} does not start: {exc}"
        except BaseException:
            self.__exit__(None, None, None)
            raise
        return self

    def _previous_tree(self) -> Path | None:
        if not self.previous:
            return None
        if self.previous == SELF:
            return Path(self.current_src)
        try:
            self.previous_commit = resolve_revision(self.previous)
            self._tmp = tempfile.mkdtemp(prefix="viscoforce-previous-")
            return extract_tree(self.previous_commit, Path(self._tmp))
        except PreviousUnavailable as exc:
            self.previous_commit = None
            self.note = f"previous release skipped: {exc}"
            return None

    def __exit__(self, *exc) -> None:
        for worker in self.workers.values():
            worker.close()
        if self._tmp is not None:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None

    def items(self):
        """(label, worker) pairs: ``current`` first."""
        return self.workers.items()

    def __contains__(self, label: str) -> bool:
        return label in self.workers

    def __getitem__(self, label: str) -> Worker:
        return self.workers[label]


# ── the worker side ──────────────────────────────────────────────────────────────────────────────

def _blas_threads() -> list[int]:
    from threadpoolctl import threadpool_info
    return sorted({d["num_threads"] for d in threadpool_info() if d.get("user_api") == "blas"})


def _time_case(case: Case, calls: int) -> dict:
    """Mean CPU and wall time per call [s] of ``calls`` calls (gc paused)."""
    gc.collect()
    gc.disable()
    try:
        if case.reset is None:
            c0, t0 = time.process_time(), time.perf_counter()
            for _ in range(calls):
                case.run()
            cpu, wall = time.process_time() - c0, time.perf_counter() - t0
        else:
            cpu = wall = 0.0
            for _ in range(calls):
                case.reset()
                c0, t0 = time.process_time(), time.perf_counter()
                case.run()
                wall += time.perf_counter() - t0
                cpu += time.process_time() - c0
    finally:
        gc.enable()
    return {"cpu_s": cpu / calls, "wall_s": wall / calls}


def worker_main(cases_module: str) -> int:
    """Serve requests on stdin until ``quit`` or end of input (see the module docstring)."""
    from threadpoolctl import threadpool_limits

    warnings.simplefilter("ignore")
    threadpool_limits(limits=1)
    sys.path.insert(0, str(BENCH))
    registry = importlib.import_module(cases_module).CASES
    built: dict[tuple[str, str], Case] = {}

    def get(msg: dict) -> Case:
        key = (msg["case"], json.dumps(msg.get("params", {}), sort_keys=True))
        if key not in built:
            built[key] = registry[msg["case"]](**msg.get("params", {}))
        return built[key]

    out, sys.stdout = sys.stdout, sys.stderr  # a stray print must not corrupt the protocol
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            msg = json.loads(line)
            op = msg["op"]
            if op == "quit":
                break
            if op == "hello":
                import viscoforce
                reply = {"viscoforce_file": viscoforce.__file__,
                         "version": getattr(viscoforce, "__version__", None),
                         "blas_threads": _blas_threads(), "pid": os.getpid(),
                         "python": platform.python_version()}
            elif op == "setup":
                case = get(msg)
                for _ in range(int(msg.get("warmup", 0))):
                    if case.reset is not None:
                        case.reset()
                    case.run()
                gc.collect()
                gc.freeze()  # what exists now is never collected again: cheap gc.collect() later
                reply = {"ok": True}
            elif op == "time":
                reply = _time_case(get(msg), int(msg["calls"]))
            elif op == "value":
                case = get(msg)
                reply = {"value": case.value() if case.value is not None else None}
            else:
                raise ValueError(f"unknown op {op!r}")
        except Exception:  # noqa: BLE001 - reported to the parent, which raises WorkerError
            reply = {"error": traceback.format_exc()}
        out.write(json.dumps(reply) + "\n")
        out.flush()
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] != "--worker":
        sys.exit("usage: python benchmarks/_previous.py --worker CASES_MODULE (started by a "
                 "benchmark, not by hand)")
    sys.exit(worker_main(sys.argv[2]))
