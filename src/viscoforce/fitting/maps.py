"""Fits over datasets with extra dims (maps, zips of curves), in parallel on dask.distributed.

Every pixel is fitted from its own data-driven guess (nothing is carried from one pixel to the
next), so the results do not depend on the order or on the partition into tasks. A pixel that
cannot be fitted is flagged (``success`` = 0, the reason in ``message``) and never stops the map.

Where the pixels are fitted (``attrs["execution"]`` of the result says where, and why):

- ``scheduler=None`` and no ``workers``: the cost model of :mod:`~viscoforce.fitting.map_cost`
  decides. A few pixels spread over the map are fitted in this process first (their results
  are kept) to measure the per-pixel cost; the rest is fitted here, or on a local cluster of
  2 … cores workers when that is expected to finish sooner (per-pixel cost × pixels against
  the cluster's start-up, at the host's parallel capacity: measured by a ≈ 0.1 s probe
  where a cluster on free cores would save more than twice that, and the plan made again
  with it; :func:`~viscoforce.fitting.map_cost.settle_plan`). The first local cluster of a
  process costs more than later ones
  (:data:`~viscoforce.fitting.map_cost.FIRST_CLUSTER`), so the same map may be fitted here
  in a fresh process and on a cluster once one has run (this module counts them).
- ``workers=N``: a local cluster of N worker processes × 1 thread, as asked.
- ``"synchronous"``: this process only.
- an address (``tcp://host:8786``): a running scheduler; nothing is computed locally.

A local cluster's workers are forked from this process where that is safe
(:func:`~viscoforce.fitting.map_cost.start_method`: Linux, Python < 3.12; ready in ~0.1 s,
viscoforce already imported), else started as fresh interpreters (~2–4 s of imports; a script
must then guard its entry point with ``if __name__ == "__main__":``). BLAS inside the workers is
the user's setting. While the cluster starts, this process fits pixels itself.

Every pixel gets a ``quality`` code (:data:`~viscoforce.fitting.pixels.MAP_QUALITY`, the rule
in :data:`~viscoforce.fitting.pixels.QUALITY_RULE`), so that a map warns pixel by pixel where a
single fit would warn once: the optimiser failed, the χ² p-value says the model does not
describe the pixel's data (``chi2_pvalue`` < :data:`~viscoforce.fitting.verdict.PVALUE_WARN`,
with known stderr only), a hertz pixel's E depends on the indentation depth (the single fit's
depth check, :func:`~viscoforce.fitting.hertz_checks.depth_check`; its shift per pixel in
``depth_check_shift`` and ``depth_check_relative``), a parameter is not determined by the data
(nuisance parameters by :data:`~viscoforce.fitting.verdict.NUISANCE_RULE`), or a parameter
ended on a bound. :func:`~viscoforce.fitting.pixels.map_summary` summarises the good pixels
only and counts the others by reason. The pixels' data, their fits in blocks and the assembled result are
:mod:`viscoforce.fitting.pixels`; this module decides where the blocks are fitted.
"""

from __future__ import annotations

import contextlib
import math
import os
import pickle
import time
from collections import deque
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ClusterError, ParameterError, ViscoforceError
from viscoforce.fitting.data import FitData
from viscoforce.fitting.map_cost import (
    OVERLAP_METHODS,
    PROBE_MIN_PIXELS,
    PROBE_SECONDS,
    ExecutionPlan,
    measure_capacity,
    plan_execution,
    probe_indices,
    settle_plan,
    start_method,
)
from viscoforce.fitting.moduli import add_derived_moduli
from viscoforce.fitting.pixels import assemble_map, fit_block, pixel_data
from viscoforce.fitting.registry import entry

#: Seconds to wait for a scheduler before giving up.
CONNECT_TIMEOUT = 10.0
#: Most pixels per cluster task (at 0.5 ms per svda pixel, 0.1 s of fitting takes 200: a cap of
#: 64 left tasks of 30 ms, and dask's handling of 64 tasks cost this process 0.6–0.8 s of CPU
#: beside the two workers on a 64×64 map; 0.4–0.6 s with 256).
MAX_BLOCK = 256
#: Aimed duration of one cluster task [s] (with the measured per-pixel cost): long against
#: dask's ~1 ms per task, short enough that the last tasks leave no worker idle for long.
TASK_SECONDS = 0.1
#: ``identifiability=`` of :func:`fit_map`: the local test (stderr > |value|, none, or at a
#: bound; free) or the profile likelihood of :mod:`viscoforce.fitting.identify` (several refits
#: per parameter and pixel).
IDENTIFIABILITY_METHODS = ("local", "profile")


def max_workers() -> int:
    """Most worker processes of a local cluster: the machine's cores (at least 1)."""
    return max(1, os.cpu_count() or 1)


def check_workers(workers: Any) -> None:
    """Raise :class:`ParameterError` unless ``workers`` is None or an integer in [1, cores]."""
    limit = max_workers()
    if workers is not None and (isinstance(workers, bool) or not isinstance(
            workers, int | np.integer) or not 1 <= workers <= limit):
        raise ParameterError(f"workers must be an integer in [1, {limit}] (the machine's "
                             f"{os.cpu_count() or 1} cores: one fit process per core; more "
                             f"only compete for them), got {workers!r}")


#: Local clusters started by this process (the cost model's ``warm``: the first costs more).
_local_clusters = 0


def _start_local(workers: int) -> tuple[Any, Any]:
    """A local cluster of ``workers`` processes × 1 thread and its Client (both to be closed)."""
    global _local_clusters
    import dask
    from distributed import Client, LocalCluster

    # The fits are CPU-bound Python: dask's statistical profiler (a sampling thread in every
    # worker), fast system monitoring and a dashboard would take a share of the cores.
    quiet = {"distributed.worker.profile.enabled": False,
             "distributed.admin.system-monitor.interval": "2s",
             "distributed.worker.multiprocessing-method": start_method()}
    with dask.config.set(quiet):
        # "127.0.0.1:0": any free port for the scheduler's HTTP routes, on loopback only (":0"
        # listened on every interface; None still tries 8787 and warns when another cluster
        # holds it)
        local = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                             host="127.0.0.1", dashboard_address="127.0.0.1:0")
    _local_clusters += 1
    try:
        return local, Client(local)
    except BaseException:
        local.close()
        raise


def _close_local(started: tuple[Any, Any]) -> None:
    local, client = started
    try:
        client.close()
    finally:
        local.close()


@contextlib.contextmanager
def cluster(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A dask.distributed Client: a local cluster, or the running scheduler at ``scheduler``.

    The local cluster has ``workers`` (default 2) processes × 1 thread, started as in the
    module docstring.
    """
    check_workers(workers)
    from distributed import Client

    if scheduler is None:
        started = _start_local(workers or 2)
        try:
            yield started[1]
        finally:
            _close_local(started)
        return
    try:
        client = Client(scheduler, timeout=f"{CONNECT_TIMEOUT}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise ParameterError(f"cannot reach the dask scheduler {scheduler!r} within "
                             f"{CONNECT_TIMEOUT:g} s: {exc}") from None
    with client:
        yield client


def fit_map(ds: xr.Dataset, model: str, *, modes: int | str = 1, criterion: str = "bic",
            scheduler: str | None = None, workers: int | None = None, progress: bool = True,
            segment: int | None = None, identifiability: str = "local",
            poisson: float | None = None, reports: bool = False, **fixed: Any) -> xr.Dataset:
    """Fit every pixel and return the results over the data's extra dims.

    Pixels are the spectra over the extra dims (spectrum models) or the curves (``relaxation``,
    ``hertz``, ``creep``).

    Parameters
    ----------
    ds : xarray.Dataset
        A spectrum with extra dims (any variable but ``stiffness`` and ``phase`` may span a
        subset of them: scalar, per pixel or per frequency), or a curves dataset.
    model : str
        Model name (:data:`~viscoforce.fitting.registry.MODELS`).
    modes : int or "auto"
        Relaxation modes; ``"auto"`` chooses per pixel by ``criterion``.
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.
    scheduler : str, optional
        Where to fit (module docstring): None (this process or a local cluster, whichever the
        cost model expects to finish sooner), ``"synchronous"`` or a scheduler address.
    workers : int, optional
        Worker processes of a local cluster, in [1, the machine's cores] (default: the cost
        model's choice; never more than the pixels).
    progress : bool
        Show a progress bar.
    segment : int, optional
        Curve segment of a curve-model map (default: the model's own segment).
    poisson : float, optional
        Poisson's ratio in [0, 0.5] (default 0.5) of the derived ``<name>_young`` and
        ``<name>_shear`` (:func:`viscoforce.fitting.moduli.add_derived_moduli`).
    identifiability : {"local", "profile"}
        How each parameter's identifiability is judged: ``"local"`` (stderr > |value|, none,
        or at a bound) costs nothing; ``"profile"`` walks the profile likelihood (several refits
        per parameter and pixel) and adds the 2σ limits ``<name>_lower``, ``<name>_upper``.
    reports : bool
        Keep each pixel's lmfit report (:func:`lmfit.fit_report`, with the SPEC names) as the
        text variable ``fit_report`` (one more ``leastsq`` per pixel; default False).
    **fixed
        The model's fixed inputs (:func:`~viscoforce.fitting.models.make_model`).

    Returns
    -------
    xarray.Dataset
        Over the map dims: ``<name>``, ``<name>_stderr`` [the parameter's units],
        ``correlation`` (with ``param_i``, ``param_j``), ``success`` (the optimiser converged),
        ``message`` (data notes and the optimiser's message, or why the pixel failed),
        ``redchi``, ``aic``, ``bic``, ``chi2_pvalue`` (NaN without stderr), ``modes``,
        ``identifiability`` (with ``param_i``; codes of
        :data:`~viscoforce.fitting.identify.IDENTIFIABILITY`, 3 where the pixel has no fit or
        lacks the parameter) and ``quality``
        (:data:`~viscoforce.fitting.pixels.MAP_QUALITY`); the coordinates of ``ds`` over the
        map dims (``x``, ``y``, …). ``attrs``: ``model``, ``n_fits``, ``n_failed``
        (the optimiser failed), ``n_good`` (quality 0), ``quality_rule``,
        ``identifiability_method``, with ``modes="auto"``, ``criterion``, and where the pixels
        were fitted: ``execution`` (``"in-process"``, ``"local cluster (2 workers)"`` or
        ``"dask scheduler ADDRESS"``), ``execution_reason`` (the cost model's comparison, or the
        option given), ``execution_time_s`` [s] (wall time of the fits, cluster start
        included), ``expected_time_s`` [s] (the cost model's expectation; NaN without it),
        ``pixel_cost_estimated_s`` [s] (the probe's per-pixel cost; NaN without a probe),
        ``pixel_cost_measured_s`` [s] (the fits' wall time per pixel, here and in the
        workers), ``pixels_in_process`` (pixels fitted in this process) and
        ``cluster_startup_s`` [s] (a local cluster's start-up plus shut-down; NaN without one)
        and ``parallel_capacity`` [cores] (the host's capacity the cost model measured, NaN
        where it did not need it). The fitted values do not depend on where the pixels were
        fitted.

    Raises
    ------
    ParameterError
        An unknown model or option value (the message names the allowed values), an
        unreachable scheduler, or no pixel that could be fitted.
    """
    from viscoforce.fitting.models import check_fixed

    entry(model)  # a registered model, or ParameterError listing them
    if scheduler is not None and not isinstance(scheduler, str):
        raise ParameterError(f"scheduler must be a scheduler address (str, e.g. "
                             f"'tcp://host:8786'), 'synchronous' or None, got {scheduler!r}")
    if not isinstance(progress, bool):
        raise ParameterError(f"progress must be True or False, got {progress!r}")
    if not isinstance(identifiability, str) or identifiability not in IDENTIFIABILITY_METHODS:
        raise ParameterError(f"identifiability must be one of "
                             f"{', '.join(map(repr, IDENTIFIABILITY_METHODS))}, got "
                             f"{identifiability!r}")
    profile = identifiability == "profile"
    if not isinstance(reports, bool):
        raise ParameterError(f"reports must be True or False, got {reports!r}")
    check_workers(workers)
    fixed = check_fixed(model, fixed)
    items, dims, layout = pixel_data(ds, model, segment=segment)
    n = len(items)
    run = _Run(items, model, modes, criterion, fixed, profile)
    if entry(model).data == "spectrum":  # the best-fit spectra come with the map (viscoforce view)
        run.omega = np.asarray(ds["omega"].values, dtype=float)
    run.reports = reports
    with _progress_bar(n, model, progress) as bar:
        run.bar = bar
        execution = _execute(run, scheduler, workers)
    results = [r if r is not None else {"success": False, "message": "lost"}
               for r in run.results]
    out = add_derived_moduli(
        assemble_map(results, dims, layout, model, criterion if modes == "auto" else None, n,
                  profile=profile, omega=run.omega), poisson)
    out.attrs.update(execution)
    if model == "ting" and fixed.get("material") == "structural":
        from viscoforce.fitting.ting import add_ting_forms

        out.attrs.setdefault("reference_frequency", fixed.get("reference_frequency") or 1.0)
        out = add_ting_forms(out)
    return out


class _Run:
    """One map fit in progress: what to fit, the results so far, and the time spent fitting."""

    def __init__(self, items: list[FitData | str], model: str, modes: int | str,
                 criterion: str, fixed: dict[str, Any], profile: bool) -> None:
        self.items, self.model, self.modes = items, model, modes
        self.criterion, self.fixed, self.profile = criterion, fixed, profile
        self.omega: np.ndarray | None = None  # where the best-fit spectra are evaluated
        self.reports = False  # each pixel's lmfit report
        self.results: list[dict[str, Any] | None] = [None] * len(items)
        self.bar: Any = None
        self.fit_seconds = 0.0  # wall time of the pixel fits, here and in the workers
        self.here = 0  # pixels fitted in this process
        self.cluster_seconds = math.nan  # a local cluster's start-up + shut-down (wall)

    def fit_here(self, indices: Sequence[int]) -> float:
        """Fit ``indices`` in this process; their wall time [s]."""
        t0 = time.perf_counter()
        block = fit_block([self.items[i] for i in indices], self.model, self.modes,
                          self.criterion, self.fixed, profile=self.profile, omega=self.omega,
                          reports=self.reports)
        seconds = time.perf_counter() - t0
        self.store(indices, block, seconds)
        self.here += len(indices)
        return seconds

    def store(self, indices: Sequence[int], block: list[dict[str, Any]], seconds: float) -> None:
        for i, r in zip(indices, block, strict=True):
            self.results[i] = r
        self.fit_seconds += seconds
        self.bar.update(len(indices))

    def left(self) -> list[int]:
        return [i for i, r in enumerate(self.results) if r is None]


class _NoBar:
    def update(self, count: int) -> None:
        pass


@contextlib.contextmanager
def _progress_bar(n: int, model: str, show: bool) -> Iterator[Any]:
    if not show:  # tqdm is not imported at all
        yield _NoBar()
        return
    from tqdm.auto import tqdm

    with tqdm(total=n, unit="fit", desc=f"fit {model}") as bar:
        yield bar


def _execute(run: _Run, scheduler: str | None, workers: int | None) -> dict[str, Any]:
    """Fit every pixel of ``run`` where the module docstring says; the ``execution`` attrs."""
    n = len(run.items)
    t0 = time.perf_counter()
    estimate = capacity = math.nan
    if scheduler == "synchronous":
        run.fit_here(range(n))
        label, plan = "in-process", ExecutionPlan(0, math.nan, {}, "scheduler='synchronous'")
    elif scheduler is not None:
        with cluster(scheduler) as client:
            _on_cluster(run, client, run.left(), math.nan, "the scheduler")
        label, plan = (f"dask scheduler {scheduler}",
                       ExecutionPlan(0, math.nan, {}, f"scheduler={scheduler!r}"))
    else:
        if workers is None:
            estimate = _probe(run)
            plan = plan_execution(len(run.left()), estimate, cores=max_workers(),
                                  warm=_local_clusters > 0)
            plan, capacity = settle_plan(plan, measure_capacity)  # on this host, now
        else:  # a worker per pixel at most: the rest would idle
            plan = ExecutionPlan(min(workers, max(1, n)), math.nan, {}, f"workers={workers}")
        left = run.left()
        if plan.workers == 0 or not left:
            run.fit_here(left)
        else:
            _on_local_cluster(run, min(plan.workers, len(left)), estimate)
        label = plan.label
    return {"execution": label, "execution_reason": plan.reason,
            "execution_time_s": time.perf_counter() - t0,
            "expected_time_s": plan.expected.get(plan.label, math.nan),
            "pixel_cost_estimated_s": estimate,
            "pixel_cost_measured_s": run.fit_seconds / n if n else math.nan,
            "pixels_in_process": run.here, "cluster_startup_s": run.cluster_seconds,
            "parallel_capacity": capacity}


def _probe(run: _Run) -> float:
    """Fit a few pixels spread over the map here (kept); their mean wall time per pixel [s].

    The first pixel (lmfit's model set-up, cold caches) counts only when it is all there is.
    """
    times = []
    started = time.perf_counter()
    for i in probe_indices(len(run.items)):
        times.append(run.fit_here([i]))
        if len(times) >= PROBE_MIN_PIXELS and time.perf_counter() - started >= PROBE_SECONDS:
            break
    if not times:
        return math.nan
    warm = times[1:] or times
    return sum(warm) / len(warm)


def _on_local_cluster(run: _Run, workers: int, estimate: float) -> None:
    """Fit what is left on a local cluster (:func:`cluster`); this process fits while it starts.

    Only while fresh interpreters start (:data:`~.map_cost.OVERLAP_METHODS`): a forked cluster
    is up in ~0.1 s unless a fit here keeps its event loop waiting for the GIL. The start-up
    and shut-down wall time goes to ``run.cluster_seconds``.
    """
    from concurrent.futures import ThreadPoolExecutor

    t0 = time.perf_counter()
    manager = cluster(None, workers)
    queue = deque(run.left())
    if start_method() in OVERLAP_METHODS:
        with ThreadPoolExecutor(1, thread_name_prefix="viscoforce-cluster-start") as starter:
            pending = starter.submit(manager.__enter__)
            try:
                while queue and not pending.done():
                    run.fit_here([queue.popleft()])
                client = pending.result()
            except BaseException:  # close the cluster once it is up, then raise
                pending.add_done_callback(lambda f: f.exception() is None and manager.__exit__(
                    None, None, None))
                raise
    else:
        client = manager.__enter__()
    run.cluster_seconds = time.perf_counter() - t0
    try:
        if queue:
            per_pixel = run.fit_seconds / run.here if run.here else estimate
            _on_cluster(run, client, list(queue), per_pixel, "the local cluster")
    finally:
        t0 = time.perf_counter()
        manager.__exit__(None, None, None)
        run.cluster_seconds += time.perf_counter() - t0


def _block_size(pixels: int, workers: int, per_pixel: float) -> int:
    """Pixels per task: about :data:`TASK_SECONDS` of fitting, at least 4 tasks per worker."""
    size = math.ceil(pixels / (4 * workers))
    if math.isfinite(per_pixel) and per_pixel > 0:
        size = min(size, math.ceil(TASK_SECONDS / per_pixel))
    return max(1, min(MAX_BLOCK, size))


def _on_cluster(run: _Run, client: Any, left: list[int], per_pixel: float, where: str) -> None:
    """Fit the pixels ``left`` on the cluster of ``client``, blocks of :func:`_block_size`."""
    from distributed import as_completed

    n_workers = max(1, len(client.scheduler_info().get("workers", {})))
    size = _block_size(len(left), n_workers, per_pixel)
    blocks = [left[start:start + size] for start in range(0, len(left), size)]
    shared = client.scatter(run.fixed, broadcast=True) if run.fixed else run.fixed
    futures = {client.submit(_fit_block_shared, _packed([run.items[i] for i in block]),
                             run.model, run.modes, run.criterion, shared, run.profile,
                             run.omega, run.reports, pure=False): block
               for block in blocks}
    for future in as_completed(futures):
        block = futures[future]
        try:
            packed, seconds = future.result()
            results = _unpacked_results(packed)
        except ViscoforceError:
            raise
        except Exception as exc:  # the cluster, not a fit (fit_block catches those)
            for other in futures:
                other.cancel()
            raise ClusterError(
                f"the map fit lost pixels {block[0]} to {block[-1]} of {len(run.items)}: "
                f"{where} failed ({type(exc).__name__}: {_first_line(exc)}); "
                "no partial result is returned — check the workers (memory, a killed "
                "process) and run again, or fit in this process with "
                "scheduler='synchronous'") from None
        run.store(block, results, seconds)


def _first_line(exc: BaseException) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else "no message"


def _packed(value: Any) -> bytes:
    """``value`` pickled with its arrays in-band: one message part for dask, not one per array.

    A block's pixels and their results hold a few small arrays each (ω, k*, weights; the
    correlations, the best-fit curve): as separate parts, dask's transport spent more time on
    them in this process than the workers spent fitting (issue 22 item 3).
    """
    return pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)


def _fit_block_shared(items: bytes, model: str, modes: int | str, criterion: str,
                      fixed: dict[str, Any], profile: bool = False,
                      omega: np.ndarray | None = None, reports: bool = False
                      ) -> tuple[bytes, float]:
    """:func:`~viscoforce.fitting.pixels.fit_block` in a worker, of ``_packed`` pixels.

    Returns its packed results and wall time [s].
    """
    t0 = time.perf_counter()
    results = fit_block(pickle.loads(items), model, modes, criterion, fixed, profile=profile,
                        omega=omega, reports=reports)
    return _packed_results(results), time.perf_counter() - t0


def _packed_results(results: list[dict[str, Any]]) -> bytes:
    """A block's results pickled with the arrays of all its pixels in one buffer per dtype.

    Each pixel's result holds two small arrays (the correlations, the best-fit k*): unpickled
    one by one, their 2 × 4096 buffers of a 64×64 map cost this process ≈ 0.3 s beside the
    workers (issue 22 item 3). :func:`_unpacked_results` restores the same dicts (keys in their
    order), each array a view of its own range of the shared buffer.
    """
    light: list[dict[str, Any]] = []
    where: list[tuple[int, str, np.dtype, tuple[int, ...], int]] = []
    parts: dict[np.dtype, list[np.ndarray]] = {}
    sizes: dict[np.dtype, int] = {}
    for i, result in enumerate(results):
        plain = dict(result)
        for key, value in result.items():
            if type(value) is np.ndarray:
                code = value.dtype  # the dtype itself: structured ones may share a .str
                where.append((i, key, code, value.shape, sizes.get(code, 0)))
                parts.setdefault(code, []).append(value.ravel())
                sizes[code] = sizes.get(code, 0) + value.size
                plain[key] = None  # its place, so the keys keep their order
        light.append(plain)
    buffers = {code: np.concatenate(arrays) for code, arrays in parts.items()}
    return _packed((light, where, buffers))


def _unpacked_results(packed: bytes) -> list[dict[str, Any]]:
    """The results of :func:`_packed_results`."""
    light, where, buffers = pickle.loads(packed)
    for i, key, code, shape, start in where:
        light[i][key] = buffers[code][start:start + math.prod(shape)].reshape(shape)
    return light
