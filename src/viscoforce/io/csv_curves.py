"""Time-series CSV/TSV tables (:func:`read_curves_csv`) and segment labels (:func:`segment_label`).

The columns, the rules and the messages are described in :mod:`viscoforce.io.csv_formats`, which
re-exports everything here.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.io._csv_columns import _curve_coord, _groups, _ignored, _option, _quantity, _sensitivity
from viscoforce.io._csv_table import _read_table, _Table
from viscoforce.io.quality import MIN_TIME_STEP
from viscoforce.schema import make_curves

__all__ = ["CURVES_COLUMNS", "read_curves_csv", "segment_label"]

#: Dimension (for :func:`viscoforce.units.unit_factor`) of each time-series column.
CURVES_COLUMNS: dict[str, str] = {
    "time": "time", "force": "force", "deflection": "length", "height": "length",
    "position": "length", "z": "length", "x": "length", "y": "length",
}
_SEGMENT_WORDS = (
    ("modulation", "modulation"), ("sine", "modulation"), ("oscillat", "modulation"),
    ("retract", "retract"), ("retrace", "retract"), ("withdraw", "retract"),
    ("pause", "pause"), ("hold", "pause"), ("dwell", "pause"), ("wait", "pause"),
    ("approach", "approach"), ("extend", "approach"), ("trace", "approach"),
    ("indent", "approach"),
)
_SEGMENT_SHORT = {"ext": "approach", "app": "approach", "ret": "retract", "mod": "modulation"}


def segment_label(label: str) -> str:
    """Schema segment name of a file's segment label (e.g. ``"Extend"`` → ``"approach"``)."""
    text = str(label).strip().lower()
    if text in _SEGMENT_SHORT:
        return _SEGMENT_SHORT[text]
    for word, name in _SEGMENT_WORDS:
        if word in text:
            return name
    return "other"


def _refuse_repeated_curves(table: _Table, order: list[str], rows: list[np.ndarray],
                            columns: tuple[np.ndarray, ...]) -> None:
    """Refuse a curve that repeats an earlier one sample for sample (a duplicated curve)."""
    if len(order) < 2:
        return
    seen: dict[bytes, str] = {}
    for label, r in zip(order, rows, strict=True):
        digest = hashlib.blake2b(np.int64(r.size).tobytes(), digest_size=16)
        for values in columns:
            digest.update(np.ascontiguousarray(values[r]).tobytes())
        key = digest.digest()
        if key in seen:
            raise ParameterError(
                f"{table.path}: curve {label!r} repeats curve {seen[key]!r} sample for sample "
                f"({r.size} rows from {table.where(int(r[0]))}): a duplicated curve; remove one")
        seen[key] = label


def read_curves_csv(path: str | Path, *, spring_constant: float | str | None = None,
                    sensitivity: float | str | None = None, source: str = "csv-curves"
                    ) -> xr.Dataset:
    """Read a time-series CSV/TSV (see :mod:`viscoforce.io.csv_formats`) into a curves dataset.

    Parameters
    ----------
    path : str or Path
        The file (read-only).
    spring_constant : float or str, optional
        Cantilever spring constant [N/m] (``"0.1N/m"`` accepted): force = k × deflection when
        the file has no force column, deflection = force / k when it has no deflection column.
    sensitivity : float or str, optional
        Deflection sensitivity [m/V] (``"50nm/V"`` accepted), needed for ``deflection (V)``.
    source : str
        ``attrs["source"]``.

    Returns
    -------
    xarray.Dataset
        Valid under :func:`viscoforce.schema.validate_curves`. Where the file gives force only
        and no spring constant, ``deflection`` and ``tip_position`` are NaN (unknown).

    Raises
    ------
    UnitError
        A column without a unit, or with a unit unknown for its quantity.
    ParameterError
        A missing required column, a non-numeric cell, a value beyond its physical range,
        non-monotonic time, a duplicated curve, a line with a wrong number of fields, bad
        options.
    InstrumentFormatError
        The file is missing, empty, not a table or not UTF-8/Latin-1 text.
    EffortError
        A file above ``MAX_CSV_BYTES`` or a table above ``MAX_CSV_ROWS`` rows.
    """
    k = _option("spring_constant", spring_constant, "stiffness")
    s = _sensitivity(sensitivity)
    table = _read_table(path, CURVES_COLUMNS)
    p = table.path
    time = _quantity(table, "time", CURVES_COLUMNS)
    if time is None:
        raise ParameterError(f"{p}: no 'time (<unit>)' column; columns are "
                             f"{', '.join(c.header for c in table.columns)}")
    heights = [n for n in ("height", "position", "z") if table.find(n) is not None]
    if len(heights) != 1:
        raise ParameterError(f"{p}: need exactly one height column 'height (<unit>)' (or "
                             f"'position'/'z'), found {heights or 'none'}")
    height = _quantity(table, heights[0], CURVES_COLUMNS)
    force = _quantity(table, "force", CURVES_COLUMNS)
    dcol = table.find("deflection")
    deflection = None
    if dcol is not None:
        if dcol.unit in ("V", "mV"):
            if s is None:
                raise ParameterError(f"{p}: column '{dcol.header}' is a voltage; give the "
                                     "sensitivity (e.g. sensitivity='50nm/V')")
            deflection = table.numbers(dcol, s * (1e-3 if dcol.unit == "mV" else 1.0))
        else:
            deflection = _quantity(table, "deflection", CURVES_COLUMNS)
    if force is None and deflection is None:
        raise ParameterError(f"{p}: no 'force (<unit>)' or 'deflection (<unit>)' column")
    attrs: dict[str, Any] = {"file": str(p), "delimiter": repr(table.delimiter),
                             "height_column": heights[0]}
    if force is None:
        if k is None:
            raise ParameterError(f"{p}: the file has deflection but no force; give the spring "
                                 "constant (spring_constant='0.1N/m')")
        force = k * deflection
        attrs["force_from"] = "spring_constant x deflection"
    elif deflection is None:
        deflection = force / k if k is not None else np.full_like(force, np.nan)
        attrs["deflection_from"] = ("force / spring_constant" if k is not None
                                    else "unknown (no deflection column, no spring constant)")
    table.check_ranges()
    order, rows = _groups(table)
    index = np.concatenate(rows)
    for label, r in zip(order, rows, strict=True):
        steps = np.diff(time[r])
        if np.any(steps < MIN_TIME_STEP) and not np.any(steps <= 0):
            i = int(np.flatnonzero(steps < MIN_TIME_STEP)[0])
            where = "" if len(order) == 1 else f" of curve {label!r}"
            raise ParameterError(
                f"{p}: time{where} steps by {float(steps[i]):g} s at {table.where(int(r[i + 1]))} "
                f"({float(time[r[i + 1]])!r} s after {float(time[r[i]])!r} s): a sample interval "
                f"must be at least {MIN_TIME_STEP:g} s (no instrument samples faster); check the "
                "time column and its unit")
        if np.any(steps <= 0):
            i = int(np.flatnonzero(steps <= 0)[0])
            bad, before = int(r[i + 1]), int(r[i])
            where = "" if len(order) == 1 else f" of curve {label!r}"
            why = (f"; the same time as {table.where(before)}: a duplicated row?"
                   if time[bad] == time[before] else
                   f"; curve {label!r} starts again after other curves' rows: a duplicated "
                   "curve?" if bad != before + 1 else "")
            raise ParameterError(f"{p}: time{where} is not strictly increasing at "
                                 f"{table.where(bad)} ({float(time[bad])!r} s after "
                                 f"{float(time[before])!r} s){why}")
    _refuse_repeated_curves(table, order, rows, (time, force, height))
    scol = table.find("segment")
    if scol is not None:
        row_codes, labels = table.label_codes(scol)
        codes, uniques = pd.factorize(row_codes[index])
        types = [labels[u] for u in uniques]  # first-appearance order
        segment = codes.astype(np.int32)
        names = [segment_label(t) for t in types]
    else:
        types, names, segment = None, ["other"], np.zeros(index.size, dtype=np.int32)
    per_curve: dict[str, Any] = {}
    for axis in ("x", "y"):
        v = _quantity(table, axis, CURVES_COLUMNS)
        if v is not None:
            first = []
            for label, r in zip(order, rows, strict=True):
                if np.any(v[r] != v[r[0]]):
                    raise ParameterError(f"{p}: column '{axis}' must be constant within curve "
                                         f"{label!r} (a per-curve position)")
                first.append(v[r[0]])
            per_curve[axis] = first
    table.check_ranges()
    n_curves = len(order)
    if k is not None:
        per_curve["spring_constant"] = [k] * n_curves
        attrs["spring_constant"] = k
    if s is not None:
        per_curve["sensitivity"] = [s] * n_curves
        attrs["sensitivity"] = s
    ignored = _ignored(table, CURVES_COLUMNS)
    if ignored:
        attrs["ignored_columns"] = ", ".join(ignored)
    tip = None if np.all(np.isfinite(deflection)) else -height[index] - deflection[index]
    ds = make_curves(time[index], force[index], height[index], deflection[index],
                     tip_position=tip, segment=segment, segment_names=names,
                     segment_types=types, sample_count=[r.size for r in rows],
                     per_curve=per_curve, attrs=attrs, source=source)
    if scol is not None or n_curves > 1:
        ds = ds.assign_coords(curve=("curve", _curve_coord(order),
                                     {"long_name": "curve label in the file"}))
    return ds
