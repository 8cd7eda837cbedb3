"""Fits over datasets with extra dims (maps, zips of curves), in parallel on dask.distributed.

Every pixel is fitted from its own data-driven guess (nothing is carried from one pixel to the
next), so the results do not depend on the order or on the partition into tasks. A pixel that
cannot be fitted is flagged (``success`` = 0, the reason in ``message``) and never stops the map.

``scheduler=None`` starts a local cluster (``workers`` processes × 1 thread; BLAS inside the
workers is the user's setting) — except for maps of at most :data:`SMALL_MAP` pixels without
``workers``, fitted in this process (a cluster would cost more than it saves); an address
(``tcp://host:8786``) uses a running scheduler and computes nothing locally; ``"synchronous"``
fits in this process. A script that starts a local cluster must guard its entry point with
``if __name__ == "__main__":`` (dask starts the workers as fresh processes that import it).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError, ViscoforceError
from viscoforce.fitting.curves import hold_data
from viscoforce.fitting.fit import FitData, pixel_fit_data, select, spectrum_arrays, summary
from viscoforce.fitting.models import SPECTRUM_MODELS
from viscoforce.schema import validate_fit_result, validate_spectrum
from viscoforce.schema.fit import SUCCESS_FLAGS, parameter_units

#: Seconds to wait for a scheduler before giving up.
CONNECT_TIMEOUT = 10.0
#: Pixels per task: enough to amortise the task overhead, small enough to balance the load.
MAX_BLOCK = 64
#: Maps up to this many pixels are fitted in this process when neither ``scheduler`` nor
#: ``workers`` is given: starting a local cluster (3–4 s) costs more than fitting them.
SMALL_MAP = 64


def pixel_data(ds: xr.Dataset, model: str, *, segment: int | None = None
               ) -> tuple[list[FitData | str], tuple[str, ...], dict[str, Any]]:
    """Per-pixel fit data of a map (or the reason it has none), the map dims and coords."""
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
        coords = {d: ds[d].values for d in dims if d in ds.coords}
        shape = {d: ds.sizes[d] for d in dims}
        return out, dims, {"coords": coords, "shape": shape}
    n = int(ds.sizes["curve"])
    out = [_or_reason(lambda i=i: hold_data(ds, curve=i, segment=segment)) for i in range(n)]
    coords = {"curve": ds["curve"].values} if "curve" in ds.coords else {}
    return out, ("curve",), {"coords": coords, "shape": {"curve": n}}


def _or_reason(build: Callable[[], FitData]) -> FitData | str:
    try:
        return build()
    except (ViscoforceError, ValueError, ArithmeticError) as exc:
        return str(exc)


def fit_block(items: Sequence[FitData | str], model: str, modes: int | str, criterion: str,
              fixed: dict[str, Any]) -> list[dict[str, Any]]:
    """Fit each pixel of a block; a failure becomes ``{"success": False, "message": …}``."""
    out = []
    for data in items:
        if isinstance(data, str):
            out.append({"success": False, "message": data})
            continue
        own = fixed
        if model == "contact" and fixed.get("indentation") is None:  # each pixel's own depth
            own = {**fixed, "indentation": data.source.get("mean_indentation")}
        try:
            best, _ = select(data, model, modes=modes, criterion=criterion, **own)
        except (ViscoforceError, ValueError, ArithmeticError) as exc:
            out.append({"success": False, "message": str(exc).splitlines()[0]})
            continue
        info = summary(best)
        info["modes"] = best.model.spec.modes
        info["names"] = best.model.names
        out.append(info)
    return out


@contextlib.contextmanager
def cluster(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A dask.distributed Client: a local cluster, or the running scheduler at ``scheduler``."""
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int)
                                or workers < 1):
        raise ParameterError(f"workers must be an integer >= 1, got {workers!r}")
    from distributed import Client, LocalCluster

    if scheduler is None:
        import dask

        # The fits are CPU-bound Python: dask's statistical profiler (a sampling thread in every
        # worker) and fast system monitoring would take a share of the two cores.
        quiet = {"distributed.worker.profile.enabled": False,
                 "distributed.admin.system-monitor.interval": "2s"}
        with dask.config.set(quiet), LocalCluster(
                n_workers=workers or 2, threads_per_worker=1, processes=True,
                dashboard_address=":0") as local, Client(local) as client:
            yield client
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
            segment: int | None = None, **fixed: Any) -> xr.Dataset:
    """Fit every pixel and return the results over the data's extra dims.

    Pixels are the spectra over the extra dims (spectrum models) or the curves (``relaxation``).

    Returns
    -------
    xarray.Dataset
        ``<name>``, ``<name>_stderr``, ``correlation``, ``success``, ``message``, ``redchi``,
        ``aic``, ``bic``, ``modes`` over the map dims; ``attrs`` ``n_fits``, ``n_failed``.
    """
    from viscoforce.fitting.models import MODEL_NAMES, check_fixed

    if not isinstance(model, str) or model not in MODEL_NAMES:
        raise ParameterError(f"model must be one of {', '.join(MODEL_NAMES)}, got {model!r}")
    if scheduler is not None and not isinstance(scheduler, str):
        raise ParameterError(f"scheduler must be a scheduler address (str, e.g. "
                             f"'tcp://host:8786'), 'synchronous' or None, got {scheduler!r}")
    if not isinstance(progress, bool):
        raise ParameterError(f"progress must be True or False, got {progress!r}")
    fixed = check_fixed(model, fixed)
    items, dims, layout = pixel_data(ds, model, segment=segment)
    n = len(items)
    if scheduler is None and workers is None and n <= SMALL_MAP:
        scheduler = "synchronous"
    if scheduler == "synchronous":
        results = fit_block(items, model, modes, criterion, fixed)
    else:
        results = _distributed(items, model, modes, criterion, fixed, scheduler, workers,
                               progress)
    return _assemble(results, dims, layout, model, criterion if modes == "auto" else None, n)


def _distributed(items: list[FitData | str], model: str, modes: int | str, criterion: str,
                 fixed: dict[str, Any], scheduler: str | None, workers: int | None,
                 progress: bool) -> list[dict[str, Any]]:
    from distributed import as_completed
    from tqdm.auto import tqdm

    n = len(items)
    with cluster(scheduler, workers) as client:
        n_workers = max(1, len(client.scheduler_info().get("workers", {})) or (workers or 2))
        size = max(1, min(MAX_BLOCK, math.ceil(n / (n_workers * 8))))
        blocks = [(start, items[start:start + size]) for start in range(0, n, size)]
        shared = client.scatter(fixed, broadcast=True) if fixed else fixed
        futures = {client.submit(_fit_block_shared, block, model, modes, criterion, shared,
                                 pure=False): start for start, block in blocks}
        results: list[dict[str, Any] | None] = [None] * n
        with tqdm(total=n, unit="fit", disable=not progress, desc=f"fit {model}") as bar:
            for future in as_completed(futures):
                start = futures[future]
                block = future.result()
                results[start:start + len(block)] = block
                bar.update(len(block))
    return [r if r is not None else {"success": False, "message": "lost"} for r in results]


def _fit_block_shared(items: Sequence[FitData | str], model: str, modes: int | str,
                      criterion: str, fixed: dict[str, Any]) -> list[dict[str, Any]]:
    return fit_block(items, model, modes, criterion, fixed)


def _assemble(results: list[dict[str, Any]], dims: tuple[str, ...], layout: dict[str, Any],
              model: str, criterion: str | None, n: int) -> xr.Dataset:
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
    corr = np.full((n, m, m), np.nan)
    stats = {k: np.full(n, np.nan) for k in ("redchi", "aic", "bic")}
    success = np.zeros(n, dtype=np.int8)
    modes = np.zeros(n, dtype=np.int32)
    messages = []
    for i, r in enumerate(results):
        messages.append(str(r.get("message", "")))
        if "names" not in r:
            continue
        idx = [names.index(x) for x in r["names"]]
        values[i, idx] = [r["values"][x] for x in r["names"]]
        errors[i, idx] = [np.nan if r["stderr"][x] is None else r["stderr"][x]
                          for x in r["names"]]
        corr[i][np.ix_(idx, idx)] = r["correlation"]
        for k in stats:
            stats[k][i] = r[k]
        success[i] = int(r["success"])
        modes[i] = r["modes"]
    data: dict[str, Any] = {}
    for j, name in enumerate(names):
        attrs = {"units": parameter_units(name), "long_name": f"fitted parameter {name}"}
        data[name] = (dims, values[:, j].reshape(shape), attrs)
        data[f"{name}_stderr"] = (dims, errors[:, j].reshape(shape),
                                  {**attrs, "long_name": f"standard error of {name}"})
    data["correlation"] = ((*dims, "param_i", "param_j"), corr.reshape((*shape, m, m)),
                           {"units": "1", "long_name": "correlation of the fitted parameters"})
    data["success"] = (dims, success.reshape(shape), {
        "long_name": "fit converged", "flag_values": np.array(list(SUCCESS_FLAGS), dtype=np.int8),
        "flag_meanings": " ".join(SUCCESS_FLAGS.values())})
    data["message"] = (dims, np.array(messages, dtype=object).reshape(shape),
                       {"long_name": "why a fit failed (or the optimiser's message)"})
    for k, long_name in (("redchi", "reduced chi-square"), ("aic", "Akaike information criterion"),
                         ("bic", "Bayesian information criterion")):
        data[k] = (dims, stats[k].reshape(shape), {"units": "1", "long_name": long_name})
    data["modes"] = (dims, modes.reshape(shape), {"units": "1",
                                                   "long_name": "number of relaxation modes"})
    coords: dict[str, Any] = {d: (d, v) for d, v in layout["coords"].items()}
    coords.update({"param_i": ("param_i", names), "param_j": ("param_j", names)})
    n_failed = int(n - success.sum())
    attrs = {"model": model, "n_fits": n, "n_failed": n_failed}
    if criterion:
        attrs["criterion"] = criterion
    return validate_fit_result(xr.Dataset(data, coords=coords, attrs=attrs))
