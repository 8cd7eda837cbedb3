"""Columns and options of the CSV readers of :mod:`viscoforce.io.csv_formats`.

A column's unit to SI (:func:`_factor`, the angle units included), a known column read as numbers
(:func:`_quantity`), the columns a reader ignores, a reader's numeric options (a spring constant, a
sensitivity, a drive amplitude: a number or a quantity string, in its plausible range) and the
``curve`` label column's grouping of the rows.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

from viscoforce._limits import SENSITIVITY_RANGE, SPRING_CONSTANT_RANGE
from viscoforce._validation import require_plausible
from viscoforce.exceptions import ParameterError, UnitError
from viscoforce.io._csv_header import _LABELS
from viscoforce.io._csv_table import _Column, _Table
from viscoforce.io.quality import first_beyond, range_text
from viscoforce.units import parse_quantity, unit_factor

_ANGLE = {"deg": 1.0, "degree": 1.0, "degrees": 1.0, "°": 1.0, "rad": 180.0 / math.pi,
          "radian": 180.0 / math.pi, "radians": 180.0 / math.pi}


def _factor(table: _Table, col: _Column, dimension: str) -> float:
    assert col.unit is not None
    if dimension == "angle":
        if col.unit not in _ANGLE:
            raise UnitError(f"{table.path}: column '{col.header}': unknown unit '{col.unit}' for "
                            f"an angle; accepted: deg, degree, °, rad")
        return _ANGLE[col.unit]
    try:
        return unit_factor(dimension, col.unit)
    except UnitError as exc:
        raise UnitError(f"{table.path}: column '{col.header}': {exc}") from None


def _quantity(table: _Table, name: str, known: Mapping[str, str], *,
              allow_missing: bool = False) -> np.ndarray | None:
    col = table.find(name)
    if col is None:
        return None
    base = name.removesuffix("_stderr")
    return table.numbers(col, _factor(table, col, known[base]), allow_missing=allow_missing)


def _ignored(table: _Table, known: Mapping[str, str]) -> list[str]:
    return [c.header for c in table.columns if c.name not in _LABELS
            and c.name not in known and c.name.removesuffix("_stderr") not in known]


#: Plausible ranges (SI) and units of the calibrations a reader is given.
_CALIBRATION_RANGES = {"spring_constant": (SPRING_CONSTANT_RANGE, "N/m"),
                       "sensitivity": (SENSITIVITY_RANGE, "m/V")}


def _option(name: str, value: Any, dimension: str, shown: Any = None) -> float | None:
    if value is None:
        return None
    if isinstance(value, str):
        out = parse_quantity(value, dimension, name=name)
    elif isinstance(value, bool) or not isinstance(value, int | float):
        raise ParameterError(f"{name} must be a number [SI] or a quantity string, got {value!r}")
    else:
        out = float(value)
    if not (math.isfinite(out) and out > 0):
        raise ParameterError(f"{name} must be finite and > 0, got {value!r}")
    if name in _CALIBRATION_RANGES:  # a cantilever calibration: refused outside its range
        bounds, unit = _CALIBRATION_RANGES[name]
        text = value if shown is None else shown
        return require_plausible(name, out, bounds, unit,
                                 why=f"given as {text!r}" if isinstance(text, str) else "")
    if first_beyond(name, out) is not None:
        raise ParameterError(f"{name} = {value if shown is None else shown!r} is beyond the "
                             f"physical range {range_text(name)}; check the value and its unit")
    return out


def _sensitivity(value: Any) -> float | None:
    """Deflection sensitivity [m/V] from a number or ``"<length>/V"`` (e.g. ``"50nm/V"``)."""
    shown = value
    if isinstance(value, str):
        m = re.fullmatch(r"\s*(.*?)\s*/\s*V\s*", value)
        if not m:
            raise UnitError(f"sensitivity: write a length per volt, e.g. '50nm/V', got {value!r}")
        value = m.group(1)
        if not value:
            raise UnitError("sensitivity: no number before '/V'")
    return _option("sensitivity", value, "length", shown)


def _groups(table: _Table) -> tuple[list[str], list[np.ndarray]]:
    """Curve labels (first-appearance order) and the row indices of each curve (in file order)."""
    col = table.find("curve")
    n = table.n_rows
    if col is None:
        return ["0"], [np.arange(n)]
    codes, labels = table.label_codes(col)
    order = np.argsort(codes, kind="stable")
    return labels, np.split(order, np.cumsum(np.bincount(codes, minlength=len(labels)))[:-1])


def _curve_coord(order: list[str]) -> np.ndarray:
    try:
        return np.asarray([int(k) for k in order], dtype=np.int32)
    except ValueError:
        return np.asarray(order, dtype=str)
