"""Where a map is fitted: the cost model of :func:`viscoforce.fitting.maps.fit_map`.

A map's pixels are independent fits, so the wall time of ``r`` pixels of cost ``c`` each is

- in this process: ``r·c``;
- on a local cluster of ``w`` worker processes: ``S(w) + (r − m)·(c + o)/(min(w, C)·e)``, where
  ``S(w)`` is the cluster's start-up and shut-down (:data:`CLUSTER_STARTUP`, by the start
  method of its processes, plus :data:`FIRST_CLUSTER` for the first local cluster of this
  process), ``m`` the pixels this process fits itself while the cluster starts (``S(w)/(2c)``:
  it shares the cores with the starting workers; only where the workers start as fresh
  interpreters, :data:`OVERLAP_METHODS`), ``o`` the per-pixel transport
  (:data:`PIXEL_OVERHEAD`), ``C`` the parallel capacity of the host (the cores that CPU-bound
  processes get at once now, measured at decision time: ``w`` where it was not measured) and
  ``e`` the parallel efficiency (:data:`PARALLEL_EFFICIENCY`: what the workers turn of that
  capacity into fits; the scheduler and result collection in this process take a share).

:func:`plan_execution` picks the smallest of these over ``w`` = 2 … cores (one worker never
beats this process: it pays ``S`` for the same speed). The per-pixel cost ``c`` is measured on
the map itself, by fitting a few pixels spread over it in this process first
(:func:`probe_indices`; their results are kept); ``S`` and ``o`` are constants measured with
benchmarks/bench_maps.py (2-core Linux machine, Python 3.11, dask.distributed 2026.8).

The host's capacity ``C`` is measured only where it can change the decision: when a cluster is
expected to win with every core free (``C = w``) by more than twice the probe's cost,
:func:`settle_plan` runs :func:`measure_capacity` (a pure-Python loop timed here, then in ``w``
bare interpreters at once: ≈ 0.1 s, :data:`CAPACITY_PROBE_COST`) and makes the plan again with
the measured ``C`` (:func:`replan`); a smaller expected gain keeps this process unmeasured.
On a shared 2-core host ``C`` moved between 0.9 and 2.2 within seconds (issue 41 item 5):
with the capacity left out, the model sent a 16-curve Hertz map to a cluster that was 1.2×
slower than this process whenever ``C`` < 1.3.

Apart from :func:`measure_capacity` (the one clock here), everything is plain arithmetic on
given costs (no dask; whether a local cluster has run in this process already is the caller's
to say): the decisions are deterministic for given inputs and tested so
(tests/fitting/test_maps_cost.py, tests/fitting/test_map_schedule.py).
"""

from __future__ import annotations

import math
import multiprocessing
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

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
#: Fraction of the cores the workers get (``min(w, C)``: ``w`` unless the host's capacity ``C``
#: was measured lower) that they turn into fits: the scheduler, the client and the result
#: collection run in this process beside them. Against the capacity measured by
#: :func:`measure_capacity` just before and after a 2-worker fit (2026-12-06, load 6–7, 12 fits
#: of the 16-curve Hertz map and a 48×48 svda map): 0.39–1.53, median ≈ 1.0, as noisy as the
#: host; on 2026-12-04 a worker's svda pixel took 0.66–0.93 ms against 0.52–0.65 ms here while
#: two processes got ≈ 1.35–1.5 cores (≈ 0.95), and 64×64 maps ran 1.21–1.35× faster on 2
#: workers at capacity 1.41–1.56 (≈ 0.9–1.0 with the start-up and the serial parts). Until
#: the capacity was measured (issue 41 item 5) this was 0.75, the host's typical share folded
#: in; with 0.92 and no capacity, the model had sent a fresh CLI process's 64×64 map to a
#: cluster that took 2.5–3.0 s where this process took 2.0 s.
PARALLEL_EFFICIENCY = 0.9
#: The capacity probe (:func:`measure_capacity`): each run of its loop lasts about this [s].
CAPACITY_PROBE_SECONDS = 0.02
#: The probe's children start their loops together this long [s] after they are launched
#: (a bare interpreter starts in ≈ 20–25 ms; this process waits meanwhile).
CAPACITY_PROBE_START = 0.035
#: Longest wait for the probe's children [s]; beyond it the probe gives NaN.
CAPACITY_PROBE_TIMEOUT = 5.0
#: Most processes the capacity probe starts (a machine with more cores: their share is taken
#: for every worker).
CAPACITY_PROBE_PROCESSES = 8
#: What the capacity probe costs [s] (measured on the 2-core machine, 2026-12-06: 0.11–0.15 s
#: at load 7, where everything ran 2–3× slower than idle). It is run only where a cluster on
#: free cores would save more than twice that: below, measuring cannot pay for itself often
#: enough, and a wrong cluster costs more than a wrong in-process choice.
CAPACITY_PROBE_COST = 0.1
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
    inputs : dict
        The keyword arguments of :func:`plan_execution` that made it (empty for the user's
        choice), so that :func:`replan` can make it again at a measured capacity.
    """

    workers: int
    pixel_cost: float
    expected: dict[str, float]
    reason: str
    inputs: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

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
                     overlap: bool = False, capacity: float | None = None) -> float:
    """Expected wall time [s] of ``pixels`` on a local cluster of ``workers`` (module docstring).

    With ``overlap``, this process fits pixels while the cluster starts (at half speed: the
    starting workers share the cores), the workers the rest. ``capacity`` is the host's
    measured parallel capacity (cores); the workers get ``min(workers, capacity)`` of them
    (``workers`` without a measurement).
    """
    if pixel_cost <= 0:
        return startup
    meanwhile = min(pixels, startup / (2 * pixel_cost)) if overlap else 0.0
    return startup + (pixels - meanwhile) * (pixel_cost + PIXEL_OVERHEAD) / (
        _cores(workers, capacity) * PARALLEL_EFFICIENCY)


def _cores(workers: int, capacity: float | None) -> float:
    """The cores ``workers`` processes get: all of theirs, or the measured capacity if fewer."""
    if capacity is None or not math.isfinite(capacity):
        return float(workers)
    return max(min(float(workers), capacity), 1e-3)


def plan_execution(pixels: int, pixel_cost: float, *, cores: int, method: str | None = None,
                   startup: float | None = None, warm: bool = False,
                   capacity: float | None = None, min_gain: float = 0.0) -> ExecutionPlan:
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
    capacity : float, optional
        The host's parallel capacity [cores] (:func:`measure_capacity`): what CPU-bound
        processes get at once now. None: not measured, every core taken as free.
    min_gain : float
        A cluster is chosen only when it is expected to finish this much sooner [s] (default
        0; :func:`settle_plan` asks for twice :data:`CAPACITY_PROBE_COST` where the capacity
        was not worth measuring).

    Returns
    -------
    ExecutionPlan
        ``workers`` 0 (this process) unless a cluster of 2 … ``cores`` workers is expected to be
        faster; on a tie, this process. ``reason`` states the comparison and its numbers.
    """
    method = start_method() if method is None else method
    if pixels <= 0:
        return ExecutionPlan(0, pixel_cost, {"in-process": 0.0},
                             "cost model: the probe fitted every pixel")
    options = {"in-process": expected_in_process(pixels, pixel_cost)}
    starts: dict[int, float] = {}
    best, best_time = 0, options["in-process"]
    for w in range(2, min(cores, pixels) + 1):
        s = cluster_startup(w, method, warm=warm) if startup is None else startup
        t = expected_cluster(pixels, pixel_cost, w, s, overlap=method in OVERLAP_METHODS,
                             capacity=capacity)
        options[cluster_label(w)], starts[w] = t, s
        if t + min_gain < best_time:
            best, best_time = w, t
    inputs = {"pixels": pixels, "pixel_cost": pixel_cost, "cores": cores, "method": method,
              "startup": startup, "warm": warm, "capacity": capacity, "min_gain": min_gain}
    if not math.isfinite(pixel_cost):
        return ExecutionPlan(best, pixel_cost, options, "cost model: no pixel cost measured",
                             inputs=inputs)
    chosen = "in-process" if best == 0 else cluster_label(best)
    others = ", ".join(f"{k} {v:.3g} s" for k, v in options.items() if k != chosen)
    reason = (f"cost model: {pixels} pixels x {pixel_cost * 1e3:.3g} ms measured; "
              f"{chosen} expected {best_time:.3g} s"
              + (f" (against {others})" if others else ""))
    if starts:  # what the (best) cluster's expectation is made of
        w = best or min(starts, key=lambda k: options[cluster_label(k)])
        cap = (f"the host's measured capacity {capacity:.2f} of {w} cores" if capacity
               is not None and math.isfinite(capacity) else f"{w} free cores (not measured)")
        reason += (f"; {cluster_label(w)}: start-up {starts[w]:.3g} s + "
                   f"{options[cluster_label(w)] - starts[w]:.3g} s on {cap} x efficiency "
                   f"{PARALLEL_EFFICIENCY:g}")
    if min_gain > 0 and best == 0 and len(options) > 1:
        reason += (f"; a cluster must be expected to save more than {min_gain:.3g} s (twice "
                   "the capacity probe's cost) before the host's capacity is measured")
    return ExecutionPlan(best, pixel_cost, options, reason, inputs=inputs)


def replan(plan: ExecutionPlan, capacity: float) -> ExecutionPlan:
    """``plan`` made again at the host's measured ``capacity`` [cores] (:func:`measure_capacity`).

    :func:`plan_execution` keeps its inputs in the plan; a plan without them (the user's
    choice) is returned as it is.
    """
    if not plan.inputs:
        return plan
    return plan_execution(**{**plan.inputs, "capacity": capacity})


def settle_plan(plan: ExecutionPlan, measure: Callable[[int], float]
                ) -> tuple[ExecutionPlan, float]:
    """A plan made with every core free (``capacity`` None), settled against the host.

    A plan that keeps this process stands (a busy host only makes a cluster slower), as does
    one without :func:`plan_execution`'s inputs (the user's choice). Where the cluster would
    save at most twice :data:`CAPACITY_PROBE_COST` even on free cores, measuring cannot pay:
    this process fits the rest. Otherwise ``measure`` (:func:`measure_capacity`) is called with
    the most workers considered (at most :data:`CAPACITY_PROBE_PROCESSES`: beyond, each
    process's measured share is taken for all) and the plan made again at that capacity.

    Returns
    -------
    plan : ExecutionPlan
    capacity : float
        The measured capacity [cores]; NaN where it was not measured.
    """
    if plan.workers == 0 or not plan.inputs:
        return plan, math.nan
    gain = plan.expected["in-process"] - plan.expected[plan.label]
    if gain <= 2 * CAPACITY_PROBE_COST:
        return plan_execution(**{**plan.inputs, "min_gain": 2 * CAPACITY_PROBE_COST}), math.nan
    most = min(plan.inputs["cores"], plan.inputs["pixels"])
    probed = min(most, CAPACITY_PROBE_PROCESSES)
    capacity = float(measure(probed)) * most / probed  # each process's share, for all of them
    return replan(plan, capacity), capacity


def measure_capacity(processes: int, seconds: float = CAPACITY_PROBE_SECONDS) -> float:
    """The cores ``processes`` CPU-bound processes get at once now: ``processes`` × alone / together.

    A pure-Python loop (:data:`_SPIN`, like the interpreter-bound part of a pixel's fit) is
    timed for ``seconds``/2 … ``seconds`` in this process, then in ``processes`` fresh bare
    interpreters at once (``python -I -S``: no site, no imports, ≈ 20 ms to start; each times
    its own loop, started together at an agreed moment while this process waits), then here
    again. The capacity is ``processes`` × the
    shorter time here / the children's mean time, in [0, ``processes``]: ``processes`` on free
    cores, less while other processes hold them. No thread or BLAS setting is changed; the
    children have ended (or been killed) when it returns. Takes ≈ 0.1 s with the defaults
    (:data:`CAPACITY_PROBE_COST`).

    Returns
    -------
    float
        The capacity [cores], or NaN where the probe could not run (no interpreter found, a
        child failed or took over :data:`CAPACITY_PROBE_TIMEOUT`).
    """
    units = 1 << 10
    first = _spin(units)
    while first < seconds / 2 and units < 1 << 30:  # about `seconds` of work, in doublings
        units *= 2
        first = _spin(units)
    if not sys.executable:
        return math.nan
    start = time.time() + CAPACITY_PROBE_START  # wall clock: the one the children share
    children = []
    try:
        for _ in range(processes):
            children.append(subprocess.Popen(
                [sys.executable, "-I", "-S", "-c", _SPIN, str(units), repr(start)],
                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                text=True))
        together = [float(child.communicate(timeout=CAPACITY_PROBE_TIMEOUT)[0])
                    for child in children]
    except (OSError, ValueError, subprocess.SubprocessError):
        return math.nan
    finally:
        for child in children:
            if child.poll() is None:
                child.kill()
                child.wait()
    alone = min(first, _spin(units))  # a hiccup here would overstate the capacity
    mean = sum(together) / len(together)
    return min(float(processes), processes * alone / mean) if mean > 0 else math.nan


#: The capacity probe's loop: ``units`` iterations timed, run in this process by :func:`_spin`
#: and in each child (``argv``: units, the wall-clock moment to start), which prints its time.
_SPIN = """
import sys, time
def spin(units):  # a function, like _spin: its loop variables are locals, not globals
    t0 = time.perf_counter()
    total = 0
    for i in range(units):
        total += i * i
    return time.perf_counter() - t0
units, start = int(sys.argv[1]), float(sys.argv[2])
while time.time() < start:
    time.sleep(max(0.0, min(0.002, start - time.time())))
print(spin(units))
"""


def _spin(units: int) -> float:
    """Wall time [s] of :data:`_SPIN`'s loop of ``units`` iterations in this process."""
    t0 = time.perf_counter()
    total = 0
    for i in range(units):
        total += i * i
    return time.perf_counter() - t0


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
