"""Where a map is fitted: the cost model of :func:`viscoforce.fitting.maps.fit_map`.

A map's pixels are independent fits, so the wall time of ``r`` pixels of cost ``c`` each is

- in this process: ``r·c``;
- on a local cluster of ``w`` worker processes: ``S(w) + (r − m)·(c + o)/(w·e)``, where
  ``S(w)`` is the cluster's start-up and shut-down (:data:`CLUSTER_STARTUP`, by the start
  method of its processes, plus :data:`DISTRIBUTED_IMPORT` while dask.distributed is not
  imported), ``m`` the pixels this process fits itself while the cluster starts (``S(w)/(2c)``:
  it shares the cores with the starting workers; only where the workers start as fresh
  interpreters, :data:`OVERLAP_METHODS`), ``o`` the per-pixel transport
  (:data:`PIXEL_OVERHEAD`) and ``e`` the parallel efficiency (:data:`PARALLEL_EFFICIENCY`: the
  scheduler and result collection in this process take a share of the cores).

:func:`plan_execution` picks the smallest of these over ``w`` = 2 … cores (one worker never
beats this process: it pays ``S`` for the same speed). The per-pixel cost ``c`` is measured on
the map itself, by fitting a few pixels spread over it in this process first
(:func:`probe_indices`; their results are kept); ``S`` and ``o`` are constants measured with
benchmarks/bench_maps.py (2-core Linux machine, Python 3.11, dask.distributed 2026.8).

Everything here is plain arithmetic on given costs (no clock, no dask; the only fact looked up
is whether dask.distributed is imported already, unless given): the decisions are
deterministic for given inputs and tested so (tests/test_maps_cost.py).
"""

from __future__ import annotations

import math
import multiprocessing
import sys
from dataclasses import dataclass

#: Start-up plus shut-down of a local cluster [s] by the start method of its worker processes:
#: ``(base, per worker)``, with distributed already imported (:data:`DISTRIBUTED_IMPORT` on top
#: otherwise). "fork" copies this process (viscoforce already imported): 0.24–0.35 s start and
#: 0.08–0.12 s shut-down measured for 2 workers (0.12–0.16 s and 0.04–0.10 s for one);
#: "spawn"/"forkserver" start fresh interpreters that import distributed, NumPy, SciPy, lmfit
#: and viscoforce (1.8 s each, side by side on the cores): 2.3–3.7 s for 2 workers on 2
#: cores, plus 0.5–1.3 s to shut down.
CLUSTER_STARTUP: dict[str, tuple[float, float]] = {"fork": (0.2, 0.1),
                                                   "spawn": (2.0, 1.0),
                                                   "forkserver": (2.0, 1.0)}
#: Importing dask.distributed into this process, the first time [s]: 0.48–0.63 s measured
#: (1.0 s under a load of 4 on 2 cores).
DISTRIBUTED_IMPORT = 0.5
#: Start methods whose cluster start-up this process spends fitting pixels. Not "fork": its
#: 0.1 s start-up is the scheduler's and the nannies' event loop in this process, which a
#: CPU-bound fit here slows (it waits for the GIL at every step): 0.1 s became > 0.5 s.
OVERLAP_METHODS = ("spawn", "forkserver")
#: Per-pixel transport of a cluster fit [s]: pickling the pixel's data to a worker and its
#: result back, and the result's bookkeeping here (~1.3 kB out, ~0.4 kB back per pixel).
PIXEL_OVERHEAD = 5e-5
#: Fraction of ``w`` cores the workers get when the cluster fits ``w`` at a time: the
#: scheduler, the client and the result collection run in this process beside them.
PARALLEL_EFFICIENCY = 0.92
#: The probe: pixels fitted in this process to measure the per-pixel cost, at most
#: :data:`PROBE_PIXELS`, and no more once :data:`PROBE_SECONDS` have passed and at least
#: :data:`PROBE_MIN_PIXELS` are fitted.
PROBE_PIXELS = 32
#: See :data:`PROBE_PIXELS`.
PROBE_MIN_PIXELS = 3
#: See :data:`PROBE_PIXELS` [s].
PROBE_SECONDS = 0.15


@dataclass(frozen=True)
class ExecutionPlan:
    """Where the rest of a map is fitted, and what the cost model expected.

    Attributes
    ----------
    workers : int
        Worker processes of a local cluster; 0 fits in this process.
    pixel_cost : float
        The per-pixel cost the plan is based on [s] (NaN when none was measured).
    expected : dict
        Expected wall time [s] of the pixels left, per option considered: ``"in-process"``
        and ``"local cluster (w workers)"``.
    reason : str
        Why: the cost model's comparison, or the user's explicit choice.
    """

    workers: int
    pixel_cost: float
    expected: dict[str, float]
    reason: str

    @property
    def label(self) -> str:
        """``"in-process"`` or ``"local cluster (w workers)"`` (the map's ``execution``)."""
        return "in-process" if self.workers == 0 else cluster_label(self.workers)


def cluster_label(workers: int) -> str:
    """``"local cluster (w workers)"`` (``worker`` for one)."""
    return f"local cluster ({workers} worker{'s' if workers != 1 else ''})"


def start_method() -> str:
    """Start method of local-cluster workers: "fork" on Linux before Python 3.12, else "spawn".

    Forking copies this process with viscoforce already imported: a worker is ready in
    ~0.05 s where a fresh interpreter needs ~2 s of imports. It is used only where it is safe
    and quiet: Linux (macOS frameworks are not fork-safe) and Python < 3.12 (3.12 warns on a
    fork from a process with threads, and the cluster's event loop is a thread).
    """
    if (sys.platform.startswith("linux") and sys.version_info < (3, 12)
            and "fork" in multiprocessing.get_all_start_methods()):
        return "fork"
    return "spawn"


def cluster_startup(workers: int, method: str, *, imported: bool = True) -> float:
    """Start-up plus shut-down [s] of a local cluster of ``workers`` (:data:`CLUSTER_STARTUP`).

    Without ``imported`` (distributed not yet imported here), :data:`DISTRIBUTED_IMPORT` more.
    """
    base, each = CLUSTER_STARTUP.get(method, CLUSTER_STARTUP["spawn"])
    return base + each * workers + (0.0 if imported else DISTRIBUTED_IMPORT)


def expected_in_process(pixels: int, pixel_cost: float) -> float:
    """Expected wall time [s] of ``pixels`` fitted in this process."""
    return pixels * pixel_cost


def expected_cluster(pixels: int, pixel_cost: float, workers: int, startup: float, *,
                     overlap: bool = False) -> float:
    """Expected wall time [s] of ``pixels`` on a local cluster of ``workers`` (module docstring).

    With ``overlap``, this process fits pixels while the cluster starts (at half speed: the
    starting workers share the cores), the workers the rest.
    """
    if pixel_cost <= 0:
        return startup
    meanwhile = min(pixels, startup / (2 * pixel_cost)) if overlap else 0.0
    return startup + (pixels - meanwhile) * (pixel_cost + PIXEL_OVERHEAD) / (
        workers * PARALLEL_EFFICIENCY)


def plan_execution(pixels: int, pixel_cost: float, *, cores: int, method: str | None = None,
                   startup: float | None = None, imported: bool | None = None
                   ) -> ExecutionPlan:
    """The fastest way to fit ``pixels`` more of cost ``pixel_cost`` each: here or a cluster.

    Parameters
    ----------
    pixels : int
        Pixels left to fit.
    pixel_cost : float
        Measured wall time of one pixel's fit in this process [s].
    cores : int
        Most worker processes (the machine's cores).
    method : str, optional
        Start method of the workers (default :func:`start_method`); sets the start-up.
    startup : float, optional
        Start-up plus shut-down of a cluster [s], instead of :func:`cluster_startup` (the same
        for every worker count).
    imported : bool, optional
        Whether dask.distributed is imported in this process already (default: whether it
        is, in ``sys.modules``).

    Returns
    -------
    ExecutionPlan
        ``workers`` 0 (this process) unless a cluster of 2 … ``cores`` workers is expected to be
        faster; on a tie, this process.
    """
    method = start_method() if method is None else method
    imported = "distributed" in sys.modules if imported is None else imported
    if pixels <= 0:
        return ExecutionPlan(0, pixel_cost, {"in-process": 0.0},
                             "cost model: the probe fitted every pixel")
    options = {"in-process": expected_in_process(pixels, pixel_cost)}
    best, best_time = 0, options["in-process"]
    for w in range(2, min(cores, pixels) + 1):
        s = cluster_startup(w, method, imported=imported) if startup is None else startup
        t = expected_cluster(pixels, pixel_cost, w, s, overlap=method in OVERLAP_METHODS)
        options[cluster_label(w)] = t
        if t < best_time:
            best, best_time = w, t
    if math.isfinite(pixel_cost):
        chosen = "in-process" if best == 0 else cluster_label(best)
        others = ", ".join(f"{k} {v:.3g} s" for k, v in options.items() if k != chosen)
        reason = (f"cost model: {pixels} pixels x {pixel_cost * 1e3:.3g} ms measured; "
                  f"{chosen} expected {best_time:.3g} s"
                  + (f" (against {others})" if others else ""))
    else:
        reason = "cost model: no pixel cost measured"
    return ExecutionPlan(best, pixel_cost, options, reason)


def probe_indices(n: int, count: int = PROBE_PIXELS) -> list[int]:
    """Up to ``count`` distinct pixel indices of ``0 … n-1``, every prefix spread over the map.

    The order is the base-2 van der Corput sequence scaled to the map (first, middle,
    quarters, eighths, …), so that a probe stopped early by :data:`PROBE_SECONDS` still samples
    the whole map rather than its first rows.
    """
    out: list[int] = []
    k = 0
    while len(out) < min(n, count):
        x, f, i = 0.0, 0.5, k
        while i:
            x, f, i = x + f * (i & 1), f / 2, i >> 1
        index = round(x * (n - 1))
        if index not in out:
            out.append(index)
        k += 1
    return out
