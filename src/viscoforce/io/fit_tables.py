"""Fitted curves and residuals in bulk: a long CSV table of data, best fit and residual.

(The columns of the other table, one row per fit, ``fit --out x.csv``, are
:func:`fit_table_columns`: Young's modulus before the paper's, issue 38 item 3.)

:func:`export_fits` writes, for every curve (pixel) of a fit result, one row per data point: which
curve (``curve`` and the map's coordinates, as :func:`viscoforce.io.csv_tables.pixel_columns`),
the independent variable, the data, the best fit there and the residual (data − fit), each column
``name (unit)``:

* spectrum fits (``svda``, ``exact``, ``contact``, ``prony``; one spectrum or a map): ``frequency
  (Hz)``, ``omega (rad/s)``, ``stiffness (N/m)`` [+ ``stiffness_stderr``], ``fit_stiffness
  (N/m)``, ``residual_stiffness (N/m)``, ``phase (deg)`` [+ ``phase_stderr``], ``fit_phase
  (deg)``, ``residual_phase (deg)``: the data's frequencies, taken from the result's best-fit
  curve (``fit_stiffness``, ``fit_phase``), which holds them among its denser grid;
* curve fits (one curve each): ``hertz`` ``tip_position (m)``, ``force (N)``, ``fit_force (N)``,
  ``residual_force (N)`` over the approach (``fit_approach_force``); ``relaxation`` ``time (s)``
  from the start of the hold and the ``force (N)`` on it relative to the file's free-cantilever
  baseline where the fit took it (``attrs["force_baseline"]``); ``creep`` ``time (s)`` and
  ``tip_position (m)`` (``fit_tip_position``); ``ting`` ``time (s)`` and ``force (N)`` over the
  approach and retract (``fit_force``).

Only what a fit result stores is used: its best-fit curve, and, for curve fits, where the fitted
samples lie in the data (``attrs`` ``curve``, ``segment_start``, ``segments``, ``force_baseline``,
as :mod:`viscoforce.fitting.segments` records them). The samples found there must be the fitted
ones (the result's best-fit curve holds exactly their x, sorted); otherwise the data are not
those that were fitted, and the table is refused rather than written wrong. A map of curve fits
keeps no best-fit curves (``fit_map`` stores parameters only): give the single results instead
(``[fit_curve(data, "hertz", curve=i) for i in ...]``), a sequence of results is written as one
table.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from viscoforce._files import write_text
from viscoforce.exceptions import ParameterError
from viscoforce.io.csv_tables import frequency_of, header, pixel_columns, table_text
from viscoforce.schema import select_curve, validate_curves, validate_fit_result, validate_spectrum

__all__ = ["CURVE_FITS", "export_fits", "fit_curves_table", "fit_table_columns"]

#: Curve models -> (best-fit variable, its axis, x column, data variable, segments taken).
CURVE_FITS: dict[str, tuple[str, str, str, str]] = {
    "hertz": ("fit_approach_force", "tip_position", "tip_position", "force"),
    "relaxation": ("fit_force", "time", "time", "force"),
    "creep": ("fit_tip_position", "time", "time", "tip_position"),
    "ting": ("fit_force", "time", "time", "force"),
}
_UNITS = {"time": "s", "tip_position": "m", "force": "N"}


#: Per-row statistics of a fit result's table, last, in this order.
_STATISTICS = ("redchi", "chi2_pvalue", "quality", "success", "modes")
#: The error budget's per-row interval of a variable (``<name><tail>``), in this order.
_BUDGET = ("_budget_lower", "_budget_upper", "_budget_determined")


def fit_table_columns(result: xr.Dataset) -> list[str]:
    """The variables of a fit result's table (one row per fit or pixel), Young's modulus first.

    Per fitted parameter ``<name>`` (``param_i`` order): its Young's modulus ``<name>_young``
    and ``_stderr`` where the fit derived them, then ``<name>`` and ``<name>_stderr`` (the
    paper's convention for a modulus, 2/E = Σ(1 − ν²)/E_i), then its shear modulus
    ``<name>_shear`` and ``_stderr``; then the other derived moduli (e.g. Ting's
    ``ting_E0_young``), Young's before shear; then the error budget's interval of each of those
    (``<name>_budget_lower``, ``_budget_upper``, ``_budget_determined``) in the same order;
    last ``redchi``, ``chi2_pvalue``, ``quality`` (maps), ``success``, ``modes``. Every
    variable of those kinds the result holds is a column (issue 38 item 3 changed the order
    only).

    Parameters
    ----------
    result : xarray.Dataset
        A fit result (a single fit or a map) with ``param_i``.

    Returns
    -------
    list of str
        Variable names, in column order.
    """
    if not isinstance(result, xr.Dataset) or "param_i" not in result.coords:
        raise ParameterError("fit_table_columns needs a fit result (a Dataset with param_i), "
                             f"got {type(result).__name__}")
    present = {str(n) for n in result.data_vars}
    names = [str(n) for n in result["param_i"].values]
    forms = [f for n in names for f in (f"{n}_young", n, f"{n}_shear")
             if f == n or f in present]
    other = [str(n) for n in result.data_vars if str(n).endswith(("_young", "_shear"))
             and str(n) not in forms]
    forms += sorted(other, key=lambda n: (n.endswith("_shear"), other.index(n)))
    columns = [c for f in forms for c in (f, f"{f}_stderr") if c == f or c in present]
    columns += [f"{f}{tail}" for f in forms for tail in _BUDGET if f"{f}{tail}" in present]
    # every budget interval is a column, also of a variable named nowhere above
    columns += [str(n) for n in result.data_vars if str(n).endswith(_BUDGET)
                and str(n) not in columns]
    columns += [n for n in _STATISTICS if n in result.variables]
    return columns


def _refuse(what: str) -> ParameterError:
    return ParameterError(f"export_fits: {what}")


def _spectrum_table(result: xr.Dataset, data: xr.Dataset) -> pd.DataFrame:
    """Rows per (pixel, data frequency) of a spectrum fit (one or a map)."""
    validate_spectrum(data)
    dims = tuple(str(d) for d in result["success"].dims)
    data_dims = tuple(str(d) for d in data["stiffness"].dims if d != "omega")
    if not dims and data_dims and all(data.sizes[d] == 1 for d in data_dims):
        data = data.isel({d: 0 for d in data_dims})
        data_dims = ()
    if set(dims) != set(data_dims):
        raise _refuse(f"the fit result is over {list(dims) or 'no dims (one spectrum)'}, the "
                      f"data over {list(data_dims) or 'omega only'}: give the spectrum that was "
                      "fitted (one curve of a map: data.isel(curve=[i]) or the fitted curve "
                      "alone)")
    for d in dims:
        if d in result.coords and d in data.coords and not np.array_equal(
                np.asarray(result[d].values), np.asarray(data[d].values)):
            raise _refuse(f"the fit result's {d!r} coordinate differs from the data's: give "
                          "the spectrum that was fitted")
    omega = np.asarray(data["omega"].values, dtype=float)
    grid = np.asarray(result["omega"].values, dtype=float)
    at = np.searchsorted(grid, omega)
    if np.any(at >= grid.size) or not np.array_equal(grid[np.minimum(at, grid.size - 1)], omega):
        raise _refuse("the fit's best-fit curve does not hold the data's frequencies: give the "
                      "spectrum that was fitted")
    fitted = result[["fit_stiffness", "fit_phase"]].isel(omega=at)
    fitted = fitted.assign_coords(omega=omega)
    table_dims = (*dims, "omega")
    columns = pixel_columns(data, dims, repeat=omega.size)
    n_pixels = int(np.prod([data.sizes[d] for d in dims]))
    columns[header("frequency", "Hz")] = np.tile(frequency_of(data), n_pixels)
    columns[header("omega", "rad/s")] = np.tile(omega, n_pixels)
    for name, unit in (("stiffness", "N/m"), ("phase", "deg")):
        measured = np.asarray(data[name].transpose(*table_dims).values, dtype=float).reshape(-1)
        model = np.asarray(fitted[f"fit_{name}"].transpose(*table_dims).values,
                           dtype=float).reshape(-1)
        columns[header(name, unit)] = measured
        if f"{name}_stderr" in data.variables:
            columns[header(f"{name}_stderr", unit)] = np.asarray(
                data[f"{name}_stderr"].broadcast_like(data[name]).transpose(*table_dims).values,
                dtype=float).reshape(-1)
        columns[header(f"fit_{name}", unit)] = model
        residual = measured - model
        if name == "phase":  # the difference of two angles, in [-180, 180)
            residual = (residual + 180.0) % 360.0 - 180.0
        columns[header(f"residual_{name}", unit)] = residual
    return pd.DataFrame(columns)


def _runs(segment: np.ndarray) -> list[tuple[int, int]]:
    """(start, stop) of the consecutive runs of one segment index."""
    if segment.size == 0:
        return []
    edges = np.flatnonzero(np.diff(segment)) + 1
    starts = np.concatenate(([0], edges))
    stops = np.concatenate((edges, [segment.size]))
    return [(int(a), int(b)) for a, b in zip(starts, stops, strict=True)]


def _fitted_samples(result: xr.Dataset, data: xr.Dataset, model: str
                    ) -> tuple[int, np.ndarray, np.ndarray]:
    """(curve row, x, y) of the samples a single curve fit fitted, as the fit cut them."""
    attrs = result.attrs
    try:
        row, start_time = int(attrs["curve"]), float(attrs["segment_start"])
    except (KeyError, TypeError, ValueError):
        raise _refuse(f"the {model} result does not say which curve and segment it fitted "
                      "(attrs 'curve', 'segment_start'): give the result of fit_curve / "
                      "fit_ting / fit_creep") from None
    n_curves = int(data.sizes["curve"])
    if not 0 <= row < n_curves:
        raise _refuse(f"the result fitted curve {row}; the data hold {n_curves} curve(s)")
    one = select_curve(data, row)
    time = np.asarray(one["time"].values, dtype=float)
    runs = _runs(np.asarray(one["segment"].values))
    first = [k for k, (a, _) in enumerate(runs) if time[a] == start_time]
    if not first:
        raise _refuse(f"curve {row} of the data has no segment starting at {start_time:g} s, "
                      "where the fit's segment started: give the data that were fitted")
    count = len(str(attrs.get("segments", "")).split(", ")) if model == "ting" else 1
    chosen = runs[first[0]:first[0] + count]
    start, stop = chosen[0][0], chosen[-1][1]
    _, axis, x_name, y_name = CURVE_FITS[model]
    x = np.asarray(one[x_name].values[start:stop], dtype=float)
    y = np.asarray(one[y_name].values[start:stop], dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    if model == "ting":
        ok &= np.isfinite(np.asarray(one["tip_position"].values[start:stop], dtype=float))
    x, y = x[ok], y[ok]
    if axis == "time" and x.size:
        x = x - x[0]
    if model == "relaxation" and "force_baseline" in attrs:
        y = y - float(attrs["force_baseline"])
    return row, x, y


def _curve_table(result: xr.Dataset, data: xr.Dataset) -> pd.DataFrame:
    """Rows per fitted sample of one curve fit."""
    model = str(result.attrs.get("model"))
    name, axis, x_name, y_name = CURVE_FITS[model]
    validate_curves(data)
    row, x, y = _fitted_samples(result, data, model)
    grid = np.asarray(result[axis].values, dtype=float)
    if x.size != grid.size or not np.array_equal(np.sort(x), grid):
        raise _refuse(f"the samples of curve {row} where the {model} fit's segment lies are not "
                      f"the fitted ones ({x.size} found, {grid.size} fitted): give the data that "
                      "were fitted, read the same way (height channel, calibration)")
    model_y = np.asarray(result[name].values, dtype=float)[np.searchsorted(grid, x)]
    pixels = data.drop_dims(["sample", "segment_table"], errors="ignore").isel(curve=[row])
    pixels = pixels.drop_vars(list(pixels.data_vars))
    columns = pixel_columns(pixels, ("curve",), repeat=x.size)
    y_unit = _UNITS[y_name]
    columns[header(x_name, _UNITS[x_name])] = x
    columns[header(y_name, y_unit)] = y
    columns[header(f"fit_{y_name}", y_unit)] = model_y
    columns[header(f"residual_{y_name}", y_unit)] = y - model_y
    return pd.DataFrame(columns)


def fit_curves_table(result: xr.Dataset | Sequence[xr.Dataset], data: xr.Dataset
                     ) -> pd.DataFrame:
    """Data, best fit and residual of every fitted point, as a long table (module docstring).

    Parameters
    ----------
    result : xarray.Dataset or sequence of xarray.Dataset
        A fit result (:func:`viscoforce.schema.validate_fit_result`) holding its best-fit curve:
        of a spectrum or a spectrum map, or of one curve; or several single curve fits of one
        file (their tables are concatenated).
    data : xarray.Dataset
        What was fitted: the spectrum (map), or the curves dataset.

    Returns
    -------
    pandas.DataFrame
        Columns named ``name (unit)``.

    Raises
    ------
    ParameterError
        A result without a best-fit curve (a map of curve fits), a model this table does not
        know, or data that are not those fitted (named).
    SchemaError
        ``result`` is not a fit result, or ``data`` not a spectrum / curves dataset.
    """
    if isinstance(result, Sequence) and not isinstance(result, str | bytes):
        if not result:
            raise _refuse("no fit result given")
        tables = [fit_curves_table(r, data) for r in result]
        headers = [list(t.columns) for t in tables]
        if any(h != headers[0] for h in headers):
            raise _refuse("the results give different columns (models); export them apart")
        return pd.concat(tables, ignore_index=True)
    validate_fit_result(result)
    model = str(result.attrs["model"])
    if "fit_stiffness" in result.variables and "fit_phase" in result.variables:
        return _spectrum_table(result, data)
    if model in CURVE_FITS and CURVE_FITS[model][0] in result.variables:
        if result["success"].dims:
            raise _refuse(f"a map of {model} fits with best-fit curves is not supported; give "
                          "the single results")
        return _curve_table(result, data)
    if model in CURVE_FITS:
        raise _refuse(f"this {model} result stores no best-fit curve (a map of curve fits keeps "
                      f"the parameters only): export the single fits, e.g. [fit_curve(data, "
                      f"{model!r}, curve=i) for i in range(n)]")
    raise _refuse(f"no best-fit curve of a known kind in this {model!r} result (fit_stiffness "
                  f"and fit_phase, or one of {sorted({v[0] for v in CURVE_FITS.values()})})")


def export_fits(result: xr.Dataset | Sequence[xr.Dataset], data: xr.Dataset,
                path: str | os.PathLike[str]) -> dict[str, Any]:
    """Write the data, best fit and residual of every fitted point as CSV (module docstring).

    Parameters
    ----------
    result : xarray.Dataset or sequence of xarray.Dataset
        As :func:`fit_curves_table`.
    data : xarray.Dataset
        What was fitted.
    path : path
        The CSV file (written atomically).

    Returns
    -------
    dict
        ``rows``, ``columns`` (the headers), ``curves`` (how many) and ``path``.

    Raises
    ------
    ParameterError, SchemaError
        As :func:`fit_curves_table`; ``path`` not a path.
    OSError
        The file cannot be written (``filename`` is ``path``).
    """
    if not isinstance(path, str | os.PathLike):
        raise _refuse(f"path must be a file path, got {path!r}")
    table = fit_curves_table(result, data)
    first = result if isinstance(result, xr.Dataset) else result[0]
    comments = [f"viscoforce fitted curves: model {first.attrs.get('model')}; one row per data "
                "point: the data, the best fit there and the residual (data - fit)"]
    if "force_reference" in first.attrs:
        comments.append(f"force: {first.attrs['force_reference']}")
    for key in ("data_source", "tip"):
        if key in first.attrs:
            comments.append(f"{key}: {first.attrs[key]}")
    write_text(path, table_text(table, comments))
    curves = int(table["curve"].nunique()) if "curve" in table.columns else 1
    return {"rows": int(len(table)), "columns": [str(c) for c in table.columns],
            "curves": curves, "path": os.fspath(path)}
