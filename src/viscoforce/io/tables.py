"""Small CSV tables with units in the header: measured position traces and Prony spectra.

Header cells read ``name (unit)``, e.g. ``time (s)``, ``position (nm)``, ``modulus (Pa)``; values are
converted to SI here. The file is only read, never modified.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from viscoforce._typing import FloatArray
from viscoforce._validation import require_path
from viscoforce.exceptions import ParameterError, UnitError
from viscoforce.units import unit_factor

_HEADER = re.compile(r"^\s*([A-Za-z_][\w ]*?)\s*\(\s*([^)]*)\s*\)\s*$")
#: Suffix pandas appends to a repeated header ("time (s)" twice → "time (s).1").
_MANGLED = re.compile(r"\.\d+$")


def _read(path: str | Path) -> pd.DataFrame:
    path = require_path("path", path)
    if path.is_dir():
        raise ParameterError(f"{path} is a directory, not a CSV file")
    if not path.is_file():
        raise ParameterError(f"file not found: {path}")
    try:
        df = pd.read_csv(path, comment="#", skipinitialspace=True)
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise ParameterError(f"{path}: not a readable CSV table ({exc})") from None
    if df.empty:
        raise ParameterError(f"{path}: the table has no rows")
    return df


def _column(df: pd.DataFrame, path: Path, name: str, dimension: str, *,
            allow_missing: bool = False) -> FloatArray:
    """SI values of the column ``name (unit)`` (the unit must be present, the values finite)."""
    same = [h for h in df.columns
            if (m := _HEADER.match(_MANGLED.sub("", str(h)))) and m.group(1).strip().lower() == name]
    if len(same) > 1:
        raise ParameterError(
            f"{path}: {len(same)} columns named '{name} (<unit>)' ({', '.join(map(str, same))}); "
            "keep one")
    for header in df.columns:
        m = _HEADER.match(str(header))
        if m and m.group(1).strip().lower() == name:
            unit = m.group(2).strip()
            try:
                factor = unit_factor(dimension, unit)
            except UnitError as exc:
                raise UnitError(f"{path}: column '{header}': {exc}") from None
            values = pd.to_numeric(df[header], errors="coerce").to_numpy(dtype=float)
            bad = np.isnan(values) if not allow_missing else np.zeros(values.shape, bool)
            if np.any(bad):
                row = int(np.flatnonzero(bad)[0])
                raise ParameterError(
                    f"{path}: column '{header}' row {row + 1} is not a number "
                    f"({df[header].iloc[row]!r}); decimal commas are not accepted")
            infinite = np.isinf(values)
            if np.any(infinite):
                row = int(np.flatnonzero(infinite)[0])
                raise ParameterError(
                    f"{path}: column '{header}' row {row + 1} is not a finite number "
                    f"({df[header].iloc[row]!r})")
            return values * factor
        if str(header).strip().lower() == name:
            raise UnitError(f"{path}: column '{header}' has no unit; write e.g. '{name} (SI unit)'")
    raise ParameterError(
        f"{path}: no column '{name} (<unit>)'; columns are {', '.join(map(str, df.columns))}")


def read_trace(path: str | Path) -> tuple[FloatArray, FloatArray]:
    """Read a measured position trace: columns ``time (<unit>)`` and ``position (<unit>)``.

    Returns
    -------
    time, position : ndarray
        Times [s] and positions h0 [m] (validation of monotonic time is the drive's job).
    """
    df = _read(path)
    return _column(df, Path(path), "time", "time"), _column(df, Path(path), "position", "length")


def read_prony_moduli(path: str | Path) -> tuple[FloatArray, FloatArray]:
    """Read a Prony spectrum in the paper's Eq. 8 form.

    Columns ``modulus (<pressure unit>)`` and ``tau (<time unit>)``: rows E_0 … E_n (decreasing,
    E_n = E_inf) with creep times τ_0 … τ_{n−1}; the last row's tau is empty.

    Returns
    -------
    moduli, taus : ndarray
        [Pa] (n + 1 values) and [s] (n values).
    """
    df = _read(path)
    moduli = _column(df, Path(path), "modulus", "pressure")
    taus = _column(df, Path(path), "tau", "time", allow_missing=True)
    if not np.isnan(taus[-1]) or np.any(np.isnan(taus[:-1])):
        raise ParameterError(
            f"{Path(path)}: every row but the last (E_inf) needs a tau; the last row's tau is empty")
    return moduli, taus[:-1]
