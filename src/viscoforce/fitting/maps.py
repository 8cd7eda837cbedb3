"""Fits over datasets with extra dims (maps, zips of curves), in parallel on dask.distributed.

Every pixel is fitted from its own data-driven guess (nothing is carried from one pixel to the
next), so the results do not depend on the order or on the partition into tasks. A pixel that
cannot be fitted is flagged (``success`` = 0, the reason in ``message``) and never stops the map.

Where the pixels are fitted (``attrs["execution"]`` of the result says where, and why):

- ``scheduler=None`` and no ``workers``: the cost model of :mod:`~viscoforce.fitting.map_cost`
  decides. A few pixels spread over the map are fitted in this process first (their results
  are kept) to measure the per-pixel cost; the rest is fitted here, or on a local cluster of
  2 … cores workers when that is expected to finish sooner (per-pixel cost × pixels against
  the cluster's start-up).
- ``workers=N``: a local cluster of N worker processes × 1 thread, as asked.
- ``"synchronous"``: this process only.
- an address (``tcp://host:8786``): a running scheduler; nothing is computed locally.

A local cluster's workers are forked from this process where that is safe
(:func:`~viscoforce.fitting.map_cost.start_method`: Linux, Python < 3.12; ready in ~0.1 s,
viscoforce already imported), else started as fresh interpreters (~2–4 s of imports; a script
must then guard its entry point with ``if __name__ == "__main__":``). BLAS inside the workers is
the user's setting. While the cluster starts, this process fits pixels itself.

Every pixel gets a ``quality`` code (:data:`MAP_QUALITY`, the rule in :data:`QUALITY_RULE`), so
that a map warns pixel by pixel where a single fit would warn once: the optimiser failed, the
χ² p-value says the model does not describe the pixel's data (``chi2_pvalue`` <
:data:`~viscoforce.fitting.verdict.PVALUE_WARN`, with known stderr only), a parameter is not
determined by the data, or a parameter ended on a bound. :func:`map_summary` summarises the
good pixels only and counts the others by reason.
"""

from __future__ import annotations

import contextlib
import math
import os
import pickle
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ClusterError, ParameterError, ViscoforceError
from viscoforce.fitting.curves import curve_data
from viscoforce.fitting.data import FitData, pixel_fit_data, spectrum_arrays
from viscoforce.fitting.fit import local_identifiability, select, summary
from viscoforce.fitting.identify import IDENTIFIABILITY
from viscoforce.fitting.map_cost import (
    OVERLAP_METHODS,
    PROBE_MIN_PIXELS,
    PROBE_SECONDS,
    ExecutionPlan,
    plan_execution,
    probe_indices,
    start_method,
)
from viscoforce.fitting.models import SPECTRUM_MODELS
from viscoforce.fitting.moduli import add_derived_moduli
from viscoforce.fitting.report import fit_report
from viscoforce.fitting.verdict import PVALUE_WARN
from viscoforce.schema import validate_fit_result, validate_spectrum
from viscoforce.schema.fit import SUCCESS_FLAGS, parameter_units

#: Seconds to wait for a scheduler before giving up.
CONNECT_TIMEOUT = 10.0
#: Most pixels per cluster task.
MAX_BLOCK = 64
#: Aimed duration of one cluster task [s] (with the measured per-pixel cost): long against
#: dask's ~1 ms per task, short enough that the last tasks leave no worker idle for long.
TASK_SECONDS = 0.1
#: ``identifiability=`` of :func:`fit_map`: the local test (stderr > |value|, none, or at a
#: bound; free) or the profile likelihood of :mod:`viscoforce.fitting.identify` (several refits
#: per parameter and pixel).
IDENTIFIABILITY_METHODS = ("local", "profile")
#: Per-pixel ``quality`` codes of a map (CF ``flag_values`` → ``flag_meanings``).
MAP_QUALITY: dict[int, str] = {0: "good", 1: "optimiser_failed", 2: "bad_fit",
                               3: "not_determined", 4: "at_bound"}
#: How a pixel's ``quality`` is chosen (``attrs["quality_rule"]`` of a map).
QUALITY_RULE = (
    "each pixel gets the first code that applies: optimiser_failed (the fit raised or did not "
    f"converge), bad_fit (chi2_pvalue < {PVALUE_WARN:g}: the model does not describe the "
    "pixel's data), not_determined (a parameter's identifiability is not 'determined', other "
    "than by ending on a bound), at_bound (a parameter ended on a bound of its window), "
    "otherwise good")
#: Where a pixel has no fit, or its model lacks the parameter, ``identifiability`` holds this.
NO_IDENTIFIABILITY = 3


def pixel_data(ds: xr.Dataset, model: str, *, segment: int | None = None
               ) -> tuple[list[FitData | str], tuple[str, ...], dict[str, Any]]:
    """Per-pixel fit data of a map (or the reason it has none), the map dims and layout.

    Parameters
    ----------
    ds : xarray.Dataset
        A spectrum over (*map dims, ``omega``) for a spectrum model, else a curves dataset.
    model : str
        Model name (a spectrum model, or a curve model: ``relaxation``, ``hertz``, ``creep``).
    segment : int, optional
        The curves' segment of a curve-model map (see :func:`~.curves.curve_data`).

    Returns
    -------
    items : list
        Per pixel (C order over the map dims) its :class:`~.fit.FitData`, or the reason (str)
        it has none.
    dims : tuple of str
        The map dims.
    layout : dict
        ``shape`` (dim → size) and ``coords`` (name → (dims, values, attrs)): the coordinates
        of ``ds`` over the map dims, and ``x``, ``y`` [m] wherever they are.
    """
    if model in SPECTRUM_MODELS:
        validate_spectrum(ds, require=("stiffness", "phase"))
        dims = tuple(str(d) for d in ds["stiffness"].dims if d != "omega")
        arrays = spectrum_arrays(ds, dims)
        omega = np.asarray(ds["omega"].values, dtype=float)
        source = {"data_kind": "spectrum"}
        out: list[FitData | str] = [
            _or_reason(lambda i=i: pixel_fit_data(omega, {k: v[i] for k, v in arrays.items()},
                                                  source))
            for i in range(arrays["stiffness"].shape[0])]
    else:
        dims = ("curve",)
        n = int(ds.sizes["curve"])
        out = [_or_reason(lambda i=i: curve_data(ds, model, curve=i, segment=segment))
               for i in range(n)]
    shape = {d: int(ds.sizes[d]) for d in dims}
    return out, dims, {"coords": map_coords(ds, dims), "shape": shape}


def map_coords(ds: xr.Dataset, dims: tuple[str, ...]) -> dict[str, tuple[Any, ...]]:
    """Coordinates of ``ds`` that a map over ``dims`` keeps: name → (dims, values, attrs).

    Every coordinate (dimension or not) whose dims are within ``dims``, and ``x``, ``y`` also
    when they are data variables (a curves dataset may store them so); coordinates over
    ``omega``, ``sample`` or any other dim the map does not have are left out.
    """
    out: dict[str, tuple[Any, ...]] = {}
    names = [*ds.coords, *(n for n in ("x", "y") if n in ds.data_vars)]
    for name in names:
        da = ds[name]
        if set(da.dims) <= set(dims) and str(name) != "omega":
            out[str(name)] = (tuple(str(d) for d in da.dims), da.values, dict(da.attrs))
    return out


def _or_reason(build: Callable[[], FitData]) -> FitData | str:
    try:
        return build()
    except (ViscoforceError, ValueError, ArithmeticError) as exc:
        return str(exc)


def fit_block(items: Sequence[FitData | str], model: str, modes: int | str, criterion: str,
              fixed: dict[str, Any], *, profile: bool = False,
              omega: np.ndarray | None = None, reports: bool = False) -> list[dict[str, Any]]:
    """Fit each pixel of a block; a failure becomes ``{"success": False, "message": …}``.

    Parameters
    ----------
    items : sequence
        Per pixel its :class:`~.fit.FitData` or the reason (str) it has none.
    model : str
        Model name.
    modes : int or "auto"
        Relaxation modes (``"auto"``: chosen per pixel by ``criterion``).
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.
    fixed : dict
        The model's fixed inputs (for ``contact`` without ``indentation``, each pixel's own
        median ``mean_indentation``).
    profile : bool
        Profile-likelihood identifiability per pixel (:func:`~.fit.summary`), else the local
        test.
    omega : numpy.ndarray, optional
        The map's frequencies [rad/s] (spectrum models): each pixel's best-fit k* there, as
        ``fit_k`` (flagged points included, so the curve has no gaps).
    reports : bool
        Each pixel's lmfit report (:func:`viscoforce.fitting.report.fit_report`) as ``report``.

    Returns
    -------
    list of dict
        Per pixel :func:`~.fit.summary` plus ``modes`` and ``names`` (and ``fit_k``); ``message``
        is the data's notes (points left out, stderr fallbacks) followed by the optimiser's
        message.
    """
    out = []
    for data in items:
        if isinstance(data, str):
            out.append({"success": False, "message": data})
            continue
        notes = list(data.notes)
        own = fixed
        if model == "contact" and fixed.get("indentation") is None:  # each pixel's own depth
            own = {**fixed, "indentation": data.source.get("mean_indentation")}
        if model == "ting":  # each curve's own tip-position trace
            own = {**fixed, "position_trace": data.position_trace}
        try:
            best, _ = select(data, model, modes=modes, criterion=criterion, **own)
        except (ViscoforceError, ValueError, ArithmeticError) as exc:
            out.append({"success": False,
                        "message": "; ".join([*notes, str(exc).splitlines()[0]])})
            continue
        try:
            info = summary(best, profile=profile)
        except (ViscoforceError, ValueError, ArithmeticError) as exc:
            info = summary(best)
            notes.append(f"the profile likelihood failed ({str(exc).splitlines()[0]}): the "
                         "identifiability is the local test")
        info["message"] = "; ".join([*notes, info["message"]])
        info["modes"] = best.model.spec.modes
        info["names"] = best.model.names
        if omega is not None:
            try:
                info["fit_k"] = np.asarray(best.evaluate(omega), dtype=complex)
            except (ViscoforceError, ValueError, ArithmeticError):
                pass  # no curve for this pixel (its values and stderr stand)
        if reports:
            try:
                info["report"] = fit_report(best)
            except (ViscoforceError, ValueError, ArithmeticError) as exc:
                info["report"] = f"no lmfit report: {str(exc).splitlines()[0]}"
        out.append(info)
    return out


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


def _start_local(workers: int) -> tuple[Any, Any]:
    """A local cluster of ``workers`` processes × 1 thread and its Client (both to be closed)."""
    import dask
    from distributed import Client, LocalCluster

    # The fits are CPU-bound Python: dask's statistical profiler (a sampling thread in every
    # worker), fast system monitoring and a dashboard would take a share of the cores.
    quiet = {"distributed.worker.profile.enabled": False,
             "distributed.admin.system-monitor.interval": "2s",
             "distributed.worker.multiprocessing-method": start_method()}
    with dask.config.set(quiet):
        # ":0": any free port for the scheduler's HTTP routes (None still tries 8787 and
        # warns when another cluster holds it)
        local = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                             dashboard_address=":0")
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
        Model name (:data:`~viscoforce.fitting.models.MODEL_NAMES`).
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
        lacks the parameter) and ``quality`` (:data:`MAP_QUALITY`); the coordinates of ``ds``
        over the map dims (``x``, ``y``, …). ``attrs``: ``model``, ``n_fits``, ``n_failed``
        (the optimiser failed), ``n_good`` (quality 0), ``quality_rule``,
        ``identifiability_method``, with ``modes="auto"``, ``criterion``, and where the pixels
        were fitted: ``execution`` (``"in-process"``, ``"local cluster (2 workers)"`` or
        ``"dask scheduler ADDRESS"``), ``execution_reason`` (the cost model's comparison, or the
        option given), ``execution_time_s`` [s] (wall time of the fits, cluster start
        included), ``expected_time_s`` [s] (the cost model's expectation; NaN without it),
        ``pixel_cost_estimated_s`` [s] (the probe's per-pixel cost; NaN without a probe),
        ``pixel_cost_measured_s`` [s] (the fits' wall time per pixel, here and in the
        workers), ``pixels_in_process`` (pixels fitted in this process) and
        ``cluster_startup_s`` [s] (a local cluster's start-up plus shut-down; NaN without one).

    Raises
    ------
    ParameterError
        An unknown model or option value (the message names the allowed values), an
        unreachable scheduler, or no pixel that could be fitted.
    """
    from viscoforce.fitting.models import MODEL_NAMES, check_fixed

    if not isinstance(model, str) or model not in MODEL_NAMES:
        raise ParameterError(f"model must be one of {', '.join(MODEL_NAMES)}, got {model!r}")
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
    if model in SPECTRUM_MODELS:  # the best-fit spectra come with the map (viscoforce view)
        run.omega = np.asarray(ds["omega"].values, dtype=float)
    run.reports = reports
    with _progress_bar(n, model, progress) as bar:
        run.bar = bar
        execution = _execute(run, scheduler, workers)
    results = [r if r is not None else {"success": False, "message": "lost"}
               for r in run.results]
    out = add_derived_moduli(
        _assemble(results, dims, layout, model, criterion if modes == "auto" else None, n,
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
    estimate = math.nan
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
            plan = plan_execution(len(run.left()), estimate, cores=max_workers())
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
            "pixels_in_process": run.here, "cluster_startup_s": run.cluster_seconds}


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
            results = pickle.loads(packed)
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
    """:func:`fit_block` in a worker, of ``_packed`` pixels: its packed results, wall time [s]."""
    t0 = time.perf_counter()
    results = fit_block(pickle.loads(items), model, modes, criterion, fixed, profile=profile,
                        omega=omega, reports=reports)
    return _packed(results), time.perf_counter() - t0


def pixel_quality(result: dict[str, Any]) -> int:
    """The :data:`MAP_QUALITY` code of one pixel's result (the rule of :data:`QUALITY_RULE`)."""
    if "names" not in result or not result.get("success", False):
        return 1
    p = float(result.get("chi2_pvalue", math.nan))
    if math.isfinite(p) and p < PVALUE_WARN:
        return 2
    bound = set(result.get("at_bound", ()))
    if any(int(code) != 0 and name not in bound
           for name, code in _identifiability(result).items()):
        return 3
    return 4 if bound else 0


def _identifiability(result: dict[str, Any]) -> dict[str, int]:
    """A fitted pixel's identifiability codes (the local test when the result has none)."""
    if "identifiability" in result:
        return {str(k): int(v) for k, v in result["identifiability"].items()}
    names = result["names"]
    bound = set(result.get("at_bound", ()))
    return local_identifiability({n: result["values"][n] for n in names},
                                 {n: result["stderr"][n] for n in names},
                                 [n for n in names if n in bound])


def _assemble(results: list[dict[str, Any]], dims: tuple[str, ...], layout: dict[str, Any],
              model: str, criterion: str | None, n: int, *,
              profile: bool = False, omega: np.ndarray | None = None) -> xr.Dataset:
    names: list[str] = []
    for r in results:
        for name in r.get("names", ()):
            if name not in names:
                names.append(name)
    if not names:
        reasons = sorted({r["message"] for r in results})
        raise ParameterError(f"no pixel of the {n} could be fitted: " + "; ".join(reasons[:3]))
    shape = tuple(layout["shape"][d] for d in dims) if dims else ()
    m = len(names)
    values = np.full((n, m), np.nan)
    errors = np.full((n, m), np.nan)
    limits = {side: np.full((n, m), np.nan) for side in ("lower", "upper")}
    corr = np.full((n, m, m), np.nan)
    ident = np.full((n, m), NO_IDENTIFIABILITY, dtype=np.int8)
    stats = {k: np.full(n, np.nan) for k in ("redchi", "aic", "bic", "chi2_pvalue")}
    success = np.zeros(n, dtype=np.int8)
    quality = np.zeros(n, dtype=np.int8)
    modes = np.zeros(n, dtype=np.int32)
    messages = []
    for i, r in enumerate(results):
        messages.append(str(r.get("message", "")))
        quality[i] = pixel_quality(r)
        if "names" not in r:
            continue
        idx = [names.index(x) for x in r["names"]]
        values[i, idx] = [r["values"][x] for x in r["names"]]
        errors[i, idx] = [np.nan if r["stderr"][x] is None else r["stderr"][x]
                          for x in r["names"]]
        codes = _identifiability(r)
        ident[i, idx] = [codes[x] for x in r["names"]]
        for side, arr in limits.items():
            arr[i, idx] = [r.get(side, {}).get(x, np.nan) for x in r["names"]]
        corr[i][np.ix_(idx, idx)] = r["correlation"]
        for k in stats:
            stats[k][i] = r.get(k, np.nan)
        success[i] = int(r["success"])
        modes[i] = r["modes"]
    data: dict[str, Any] = {}
    for j, name in enumerate(names):
        attrs = {"units": parameter_units(name), "long_name": f"fitted parameter {name}"}
        data[name] = (dims, values[:, j].reshape(shape), attrs)
        data[f"{name}_stderr"] = (dims, errors[:, j].reshape(shape),
                                  {**attrs, "long_name": f"standard error of {name}"})
        if profile:
            for side, arr in limits.items():
                data[f"{name}_{side}"] = (dims, arr[:, j].reshape(shape), {
                    **attrs, "long_name": f"2-sigma profile-likelihood {side} limit of {name} "
                                          "(NaN: unbounded on that side)"})
    data["correlation"] = ((*dims, "param_i", "param_j"), corr.reshape((*shape, m, m)),
                           {"units": "1", "long_name": "correlation of the fitted parameters"})
    data["success"] = (dims, success.reshape(shape), {
        "long_name": "fit converged", "flag_values": np.array(list(SUCCESS_FLAGS), dtype=np.int8),
        "flag_meanings": " ".join(SUCCESS_FLAGS.values())})
    data["quality"] = (dims, quality.reshape(shape), {
        "long_name": "quality of the pixel's fit", "comment": QUALITY_RULE,
        "flag_values": np.array(list(MAP_QUALITY), dtype=np.int8),
        "flag_meanings": " ".join(MAP_QUALITY.values())})
    data["identifiability"] = ((*dims, "param_i"), ident.reshape((*shape, m)), {
        "long_name": "identifiability of the fitted parameter",
        "flag_values": np.array(list(IDENTIFIABILITY), dtype=np.int8),
        "flag_meanings": " ".join(IDENTIFIABILITY.values())})
    if any("report" in r for r in results):
        data["fit_report"] = (dims, np.array([r.get("report", "no fit") for r in results],
                                             dtype=object).reshape(shape),
                              {"long_name": "lmfit's fit report of the pixel"})
    data["message"] = (dims, np.array(messages, dtype=object).reshape(shape),
                       {"long_name": "data notes and the optimiser's message, or why the fit "
                                     "failed"})
    for k, long_name in (("redchi", "reduced chi-square"), ("aic", "Akaike information criterion"),
                         ("bic", "Bayesian information criterion"),
                         ("chi2_pvalue", "chi-square goodness-of-fit p-value (NaN: stderr "
                                         "unknown)")):
        data[k] = (dims, stats[k].reshape(shape), {"units": "1", "long_name": long_name})
    data["modes"] = (dims, modes.reshape(shape), {"units": "1",
                                                   "long_name": "number of relaxation modes"})
    if omega is not None and any("fit_k" in r for r in results):
        k = np.full((n, omega.size), np.nan, dtype=complex)
        for i, r in enumerate(results):
            if "fit_k" in r:
                k[i] = r["fit_k"]
        order = (*dims, "omega")
        data["fit_stiffness"] = (order, np.abs(k).reshape((*shape, omega.size)), {
            "units": "N/m", "long_name": "best-fit dynamic stiffness at the data's frequencies"})
        data["fit_phase"] = (order, np.degrees(np.angle(k)).reshape((*shape, omega.size)), {
            "units": "degree", "long_name": "best-fit phase at the data's frequencies"})
    coords: dict[str, Any] = {
        name: value if isinstance(value, tuple) else (name, value)
        for name, value in layout["coords"].items() if name not in data}
    if omega is not None and "fit_stiffness" in data:
        coords["omega"] = ("omega", omega, {"units": "rad/s", "long_name": "angular frequency"})
    coords.update({"param_i": ("param_i", names), "param_j": ("param_j", names)})
    attrs = {"model": model, "n_fits": n, "n_failed": int(n - success.sum()),
             "n_good": int((quality == 0).sum()), "quality_rule": QUALITY_RULE,
             "identifiability_method": "profile likelihood (2 sigma)" if profile
             else "local (stderr > value, none, or at a bound)"}
    if criterion:
        attrs["criterion"] = criterion
    return validate_fit_result(xr.Dataset(data, coords=coords, attrs=attrs))


def map_summary(result: xr.Dataset) -> dict[str, Any]:
    """Medians and quartiles of every parameter over the GOOD pixels of a map (JSON-friendly).

    Parameters
    ----------
    result : xarray.Dataset
        What :func:`fit_map` returns (it needs ``quality`` and ``modes``).

    Returns
    -------
    dict
        ``n_fits``, ``n_good`` (pixels of quality 0); ``left_out``: how many pixels were left
        out per reason of :data:`MAP_QUALITY` (``optimiser_failed``, ``bad_fit``,
        ``not_determined``, ``at_bound``); ``by_modes``: per number of modes fitted (key
        ``"1"``, ``"2"``, …) ``n`` (its good pixels) and ``params`` (each of that model's
        parameters → ``median``, ``q25``, ``q75`` over those good pixels, in the parameter's
        units); ``params``: the same for the number of modes most common among the good pixels
        (the fewer on a tie), which ``modes`` names; ``derived`` (with ``poisson``): the same
        quartiles of the Young's and shear moduli ``<name>_young``, ``<name>_shear`` over those
        pixels, where the map has them. Values are None where no good pixel
        gives one (and ``modes`` is None when no pixel is good). Only str, int, float and None
        appear, so the dict serialises with :func:`json.dumps` as it is.

    Raises
    ------
    ParameterError
        ``result`` is not a map result (no ``quality`` or ``modes``).
    """
    if not isinstance(result, xr.Dataset) or any(
            k not in result.variables for k in ("quality", "modes", "param_i")):
        raise ParameterError("map_summary needs what fit_map returns (a dataset with 'quality', "
                             "'modes' and the parameters over 'param_i'), got "
                             f"{type(result).__name__}"
                             + ("" if not isinstance(result, xr.Dataset) else
                                f" with variables {sorted(map(str, result.variables))}"))
    quality = np.asarray(result["quality"].values).reshape(-1)
    modes = np.asarray(result["modes"].values).reshape(-1)
    names = [str(x) for x in result["param_i"].values]
    values = {x: np.asarray(result[x].values, dtype=float).reshape(-1) for x in names}
    good = quality == 0
    by_modes: dict[str, Any] = {}
    for count in sorted({int(c) for c in modes[modes > 0]}):
        of_count = modes == count
        own = [x for x in names if np.isfinite(values[x][of_count]).any()]
        chosen = good & of_count
        by_modes[str(count)] = {"n": int(chosen.sum()),
                                "params": {x: _quartiles(values[x][chosen]) for x in own}}
    counts = {c: row["n"] for c, row in by_modes.items() if row["n"] > 0}
    common = min(counts, key=lambda c: (-counts[c], int(c))) if counts else None
    params = (by_modes[common]["params"] if common is not None else
              {x: _quartiles(np.empty(0)) for x in names})
    left_out = {reason: int((quality == code).sum()) for code, reason in MAP_QUALITY.items()
                if code != 0}
    out = {"model": str(result.attrs.get("model", "")), "n_fits": int(quality.size),
           "n_good": int(good.sum()), "left_out": left_out, "by_modes": by_modes,
           "modes": None if common is None else int(common), "params": params}
    derived = [str(x) for x in result.data_vars if str(x).endswith(("_young", "_shear"))]
    if derived:  # Young's and shear moduli over the same pixels as params
        chosen = good & (modes == int(common)) if common is not None else np.zeros_like(good)
        out["derived"] = {x: _quartiles(np.asarray(result[x].values, dtype=float).reshape(-1)[
            chosen]) for x in derived}
        out["poisson"] = float(result.attrs.get("poisson", 0.5))
    return out


def _quartiles(v: np.ndarray) -> dict[str, float | None]:
    v = v[np.isfinite(v)]
    if not v.size:
        return {"median": None, "q25": None, "q75": None}
    return {"median": float(np.median(v)), "q25": float(np.percentile(v, 25)),
            "q75": float(np.percentile(v, 75))}
