"""Where a map is fitted: the cost model of :func:`viscoforce.fitting.maps.fit_map`.

A map's pixels are independent fits, so the wall time of ``r`` pixels of cost ``c`` each is

- in this process: ``r·c``;
- on a local cluster of ``w`` worker processes: ``S(w) + (r − m)·(c + o)/(w·e)``, where
  ``S(w)`` is the cluster's start-up and shut-down (:data:`CLUSTER_STARTUP`, by the start
  method of its processes, plus :data:`FIRST_CLUSTER` for the first local cluster of this
  process), ``m`` the pixels this process fits itself while the cluster starts (``S(w)/(2c)``:
  it shares the cores with the starting workers; only where the workers start as fresh
  interpreters, :data:`OVERLAP_METHODS`), ``o`` the per-pixel transport
  (:data:`PIXEL_OVERHEAD`) and ``e`` the parallel efficiency (:data:`PARALLEL_EFFICIENCY`: the
  scheduler and result collection in this process take a share of the cores).

:func:`plan_execution` picks the smallest of these over ``w`` = 2 … cores (one worker never
beats this process: it pays ``S`` for the same speed). The per-pixel cost ``c`` is measured on
the map itself, by fitting a few pixels spread over it in this process first
(:func:`probe_indices`; their results are kept); ``S`` and ``o`` are constants measured with
benchmarks/bench_maps.py (2-core Linux machine, Python 3.11, dask.distributed 2026.8).

Everything here is plain arithmetic on given costs (no clock, no dask; whether a local cluster
has run in this process already is the caller's to say): the decisions are deterministic for
given inputs and tested so (tests/fitting/test_maps_cost.py).
"""

from __future__ import annotations

import math
import multiprocessing
import sys
from dataclasses import dataclass

#: Start-up plus shut-down of a local cluster [s] by the start method of its worker processes:
#: ``(base, per worker)``, once a local cluster has run in this process (:data:`FIRST_CLUSTER`
#: on top for the first). "fork" copies this process (viscoforce already imported): 0.13–0.17 s
#: start-up plus shut-down measured for 2 workers on 2026-12-04 (0.32–0.47 s on 2026-12-02, when
#: the first cluster's extra was not told apart); "spawn"/"forkserver" start fresh interpreters
#: that import distributed, NumPy, SciPy, lmfit and viscoforce (1.8 s each, side by side on
#: the cores): 2.3–3.7 s for 2 workers on 2 cores, plus 0.5–1.3 s to shut down.
CLUSTER_STARTUP: dict[str, tuple[float, float]] = {"fork": (0.05, 0.05),
                                                   "spawn": (2.0, 1.0),
                                                   "forkserver": (2.0, 1.0)}
#: The first local cluster of a process costs this much more [s]: importing dask.distributed
#: (0.03–0.4 s measured in child processes, up to 1.2 s under load) and the first set-up of its
#: scheduler and comms here. Measured 2026-12-04 (64×64 svda map, 2 forked workers): start-up
#: 0.64–0.73 s for the first cluster, whether distributed was imported before or not, against
#: 0.13–0.17 s for later ones; the whole map 2.23–2.82 s against 1.67–2.18 s after one
#: (0.42–0.65 s more, this process also spending ≈ 0.5 s more CPU beside the workers).
FIRST_CLUSTER = 0.5
#: Start methods whose cluster start-up this process spends fitting pixels. Not "fork": its
#: 0.1 s start-up is the scheduler's and the nannies' event loop in this process, which a
#: CPU-bound fit here slows (it waits for the GIL at every step): 0.1 s became > 0.5 s.
OVERLAP_METHODS = ("spawn", "forkserver")
#: Per-pixel transport of a cluster fit [s]: pickling the pixel's data to a worker and its
#: result back, and the result's bookkeeping here (~1.3 kB out, ~0.4 kB back per pixel).
PIXEL_OVERHEAD = 5e-5
#: Fraction of ``w`` cores the workers get when the cluster fits ``w`` at a time: the
#: scheduler, the client and the result collection run in this process beside them, and the
#: machine's cores may not be free. Measured 2026-12-04 on this project's 2-core machine: a
#: worker's svda pixel 0.66–0.93 ms against 0.52–0.65 ms in this process (0.92 was measured
#: on 2026-12-02, when the host gave two processes more of its cores); with 0.92 the model
#: sent a fresh CLI process's 64×64 map to a cluster that took 2.5–3.0 s where this process
#: took 2.0 s.
PARALLEL_EFFICIENCY = 0.75
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


def cluster_startup(workers: int, method: str, *, warm: bool = True) -> float:
    """Start-up plus shut-down [s] of a local cluster of ``workers`` (:data:`CLUSTER_STARTUP`).

    Without ``warm`` (no local cluster has run in this process yet), :data:`FIRST_CLUSTER`
    more.
    """
    base, each = CLUSTER_STARTUP.get(method, CLUSTER_STARTUP["spawn"])
    return base + each * workers + (0.0 if warm else FIRST_CLUSTER)


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
                   startup: float | None = None, warm: bool = False) -> ExecutionPlan:
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
    warm : bool
        Whether a local cluster has run in this process already (default False: the first
        costs :data:`FIRST_CLUSTER` more).

    Returns
    -------
    ExecutionPlan
        ``workers`` 0 (this process) unless a cluster of 2 … ``cores`` workers is expected to be
        faster; on a tie, this process.
    """
    method = start_method() if method is None else method
    if pixels <= 0:
        return ExecutionPlan(0, pixel_cost, {"in-process": 0.0},
                             "cost model: the probe fitted every pixel")
    options = {"in-process": expected_in_process(pixels, pixel_cost)}
    best, best_time = 0, options["in-process"]
    for w in range(2, min(cores, pixels) + 1):
        s = cluster_startup(w, method, warm=warm) if startup is None else startup
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
