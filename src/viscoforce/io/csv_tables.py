"""Tables people expect: a spectrum as CSV, one row per (curve, frequency) (:func:`write_spectrum_csv`).

The table is the SPEC's "Spectrum CSV", so :func:`viscoforce.io.csv_spectrum.read_spectrum_csv`
(and ``fit``, ``bode``, ``load``) reads it back to the same spectrum (to the last bit of the
numbers, up to the rounding of the magnitude and phase through k*). Columns, each ``name
(unit)`` with the SPEC's units (``phase (deg)``):

* which curve: ``curve`` (the label; present when the spectrum has extra dims: its ``curve``
  coordinate, else the pixel's number in C order over the extra dims, whose coordinates get
  columns of their own, e.g. ``y (m)``, ``x (m)``), then every coordinate over the extra dims
  (``x (m)``, ``y (m)``, ``row (1)``, ``column (1)`` of a map);
* ``frequency (Hz)`` and ``omega (rad/s)`` (the reader takes ``omega``, checking that the two
  agree);
* ``stiffness (N/m)``, ``phase (deg)``, ``drive_amplitude (m)``, ``mean_force (N)``,
  ``mean_indentation (m)`` and, when the spectrum has them (``load --tip``), ``E_storage (Pa)``,
  ``E_loss (Pa)``, ``G_storage (Pa)``, ``G_loss (Pa)``; each followed by its ``<name>_stderr``
  where the spectrum has one; then ``quality (1)`` (the flag codes of
  :data:`viscoforce.schema.QUALITY_FLAGS`).

NaN is an empty cell. Numbers are written with the shortest text that reads back to the same
double (Python's ``repr``). ``#`` lines before the header say what the table is and where it came
from (the source file, the phase reference, the corrections, the tip of the moduli); readers skip
them. The file is written atomically (:func:`viscoforce._files.write_text`).

:func:`spectrum_table` gives the same table as a :class:`pandas.DataFrame`. The fitted curves
and residuals of a fit are :mod:`viscoforce.io.fit_tables`.
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from viscoforce._files import write_text
from viscoforce.exceptions import ParameterError
from viscoforce.schema import flat_over, validate_spectrum

__all__ = ["SPECTRUM_TABLE_COLUMNS", "frequency_of", "header", "pixel_columns", "spectrum_table",
           "table_text", "write_spectrum_csv"]

#: The per-point variables of the table, in order (each followed by its ``_stderr``).
SPECTRUM_TABLE_COLUMNS = ("stiffness", "phase", "drive_amplitude", "mean_force",
                          "mean_indentation", "E_storage", "E_loss", "G_storage", "G_loss")
#: Units written as the SPEC spells them.
_SPEC_UNITS = {"degree": "deg"}
#: Attributes named in the ``#`` lines (when the dataset has them).
_PROVENANCE = ("source", "file", "phase_reference", "phase_lag", "drag", "tip", "poisson",
               "quality_summary")


def header(name: str, units: Any) -> str:
    """``name (unit)``; a quantity without units is ``(1)``."""
    unit = str(units) if units not in (None, "") else "1"
    return f"{name} ({_SPEC_UNITS.get(unit, unit)})"


def pixel_columns(ds: xr.Dataset, dims: Sequence[str], repeat: int = 1) -> dict[str, np.ndarray]:
    """The columns that say which curve (pixel) a row is: ``curve`` and the map's coordinates.

    Parameters
    ----------
    ds : xarray.Dataset
        A spectrum or fit result over ``dims`` (and more).
    dims : sequence of str
        Its extra dims (the pixels), outermost first; none for one curve.
    repeat : int
        Rows per pixel (each value is repeated that many times, pixels in C order).

    Returns
    -------
    dict
        Header → values (without ``dims``: the scalar coordinates of the one curve, e.g. of
        ``ds.isel(curve=3)``): ``curve`` (the ``curve`` coordinate when ``dims`` is ``("curve",)``,
        else the pixel's number in C order), the coordinates of ``dims`` other than ``curve``
        and every other coordinate over a subset of ``dims`` (``x (m)``, ``row (1)`` ...; not
        the file's unsnapped ``x_raw``, ``y_raw``).
    """
    dims = tuple(str(d) for d in dims)
    if not dims:  # one curve: its scalar coordinates (one curve of a map: curve, x, y, ...)
        scalar = {str(c): ds[c].values for c in ds.coords if ds[c].ndim == 0
                  and not str(c).endswith("_raw") and ds[c].dtype.kind in "biuf"}
        return {("curve" if name == "curve" else header(name, ds[name].attrs.get("units"))):
                np.repeat(value, repeat) for name, value in scalar.items()}
    n = int(np.prod([ds.sizes[d] for d in dims]))
    out: dict[str, np.ndarray] = {}
    if dims == ("curve",) and "curve" in ds.coords:
        out["curve"] = np.asarray(ds["curve"].values)
    else:
        out["curve"] = np.arange(n)
    names = [d for d in dims if d in ds.coords and d != "curve"]
    names += [str(c) for c in ds.coords if c not in dims and ds[c].dims
              and set(ds[c].dims) <= set(dims) and not str(c).endswith("_raw")]
    for name in names:
        out[header(name, ds[name].attrs.get("units"))] = flat_over(ds, name, dims)
    return {k: np.repeat(v, repeat) for k, v in out.items()}


def frequency_of(ds: xr.Dataset) -> np.ndarray:
    """The frequencies [Hz] of ``ds``'s omega.

    Its ``frequency`` coordinate (the file's nominal values, 30.0 rather than
    29.999999999999996) where it has one in Hz that agrees with omega, else omega / 2π.
    """
    omega = np.asarray(ds["omega"].values, dtype=float)
    given = ds.coords.get("frequency")
    if given is not None and given.dims == ("omega",) and given.attrs.get("units") == "Hz":
        hz = np.asarray(given.values, dtype=float)
        if np.allclose(2 * math.pi * hz, omega, rtol=1e-12, atol=0):
            return hz
    return omega / (2 * math.pi)


def _pixels(ds: xr.Dataset) -> tuple[str, ...]:
    """The spectrum's extra dims, from its stiffness (omega last)."""
    return tuple(str(d) for d in ds["stiffness"].dims if d != "omega")


def spectrum_table(ds: xr.Dataset) -> pd.DataFrame:
    """A spectrum as a table, one row per (curve, frequency) (see the module docstring).

    Parameters
    ----------
    ds : xarray.Dataset
        A spectrum (:func:`viscoforce.schema.validate_spectrum`), over ``omega`` and any extra
        dims.

    Returns
    -------
    pandas.DataFrame
        Columns named ``name (unit)`` (``curve`` unitless); rows in C order over (extra dims,
        omega).
    """
    validate_spectrum(ds)
    dims = _pixels(ds)
    table_dims = (*dims, "omega")
    omega = np.asarray(ds["omega"].values, dtype=float)
    columns = pixel_columns(ds, dims, repeat=omega.size)
    n_pixels = int(np.prod([ds.sizes[d] for d in dims]))
    columns[header("frequency", "Hz")] = np.tile(frequency_of(ds), n_pixels)
    columns[header("omega", "rad/s")] = np.tile(omega, n_pixels)
    for name in SPECTRUM_TABLE_COLUMNS:
        for var in (name, f"{name}_stderr"):
            if var in ds.variables:
                columns[header(var, ds[var].attrs.get("units"))] = flat_over(ds, var, table_dims)
    if "quality" in ds.variables:
        columns[header("quality", "1")] = flat_over(ds, "quality", table_dims).astype(int)
    return pd.DataFrame(columns)


def table_text(table: pd.DataFrame, comments: Sequence[str] = ()) -> str:
    """The CSV text of ``table``: ``#`` comment lines, the header, the rows (NaN: empty cell).

    Floats are written by pandas with the shortest text that reads back to the same double.
    """
    handle = io.StringIO(newline="")
    for line in comments:
        handle.write("# " + " ".join(str(line).split()) + "\n")
    table.to_csv(handle, index=False, na_rep="", lineterminator="\n")
    return handle.getvalue()


def _comments(ds: xr.Dataset, what: str) -> list[str]:
    lines = [what]
    for key in _PROVENANCE:
        if key in ds.attrs:
            lines.append(f"{key}: {ds.attrs[key]}")
    return lines


def write_spectrum_csv(ds: xr.Dataset, path: str | os.PathLike[str]) -> dict[str, Any]:
    """Write a spectrum as CSV, one row per (curve, frequency) (see the module docstring).

    Parameters
    ----------
    ds : xarray.Dataset
        A spectrum (any extra dims: ``curve``, or ``y`` and ``x`` of a map).
    path : path
        The CSV file (written atomically: a previous file stays whole until the new one is).

    Returns
    -------
    dict
        ``rows``, ``columns`` (the headers) and ``path``.

    Raises
    ------
    SchemaError
        ``ds`` is not a spectrum.
    ParameterError
        ``path`` is not a path.
    OSError
        The file cannot be written (``filename`` is ``path``).
    """
    if not isinstance(path, str | os.PathLike):
        raise ParameterError(f"path must be a file path, got {path!r}")
    table = spectrum_table(ds)
    write_text(path, table_text(table, _comments(
        ds, "viscoforce spectrum table: one row per (curve, frequency); phase = lead of the "
            "force over the indentation [deg]; read back by viscoforce.io.csv_spectrum."
            "read_spectrum_csv")))
    return {"rows": int(len(table)), "columns": [str(c) for c in table.columns],
            "path": os.fspath(path)}
