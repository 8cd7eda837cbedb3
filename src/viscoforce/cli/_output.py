"""What the commands print: strict JSON (SI units), and numbers for humans with their units.

Every number a command prints for humans goes through :func:`format_value` (a value with a
prefixed unit, 3 significant digits) or :func:`format_estimate` (``4.97 GPa ± 37.3 MPa``), so the
fit, map, batch and demo summaries read alike.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

from viscoforce.units import format_quantity

__all__ = ["DIGITS", "format_estimate", "format_value", "json_safe", "print_json", "print_table",
           "print_written"]


def json_safe(obj: Any) -> Any:
    """A copy of ``obj`` that :func:`json.dumps` writes as strict JSON.

    Non-finite floats become None (JSON ``null``), NumPy arrays and scalars become lists and
    Python numbers, tuples become lists, mapping keys become strings; anything else that JSON
    cannot hold becomes its ``str``.

    Parameters
    ----------
    obj : object
        Nested dicts, lists, tuples, numbers, strings, NumPy arrays or scalars.

    Returns
    -------
    object
        The JSON-safe copy.
    """
    if isinstance(obj, Mapping):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    if obj is None or isinstance(obj, bool | str):
        return obj
    if hasattr(obj, "tolist"):  # NumPy arrays and scalars (without importing NumPy here)
        return json_safe(obj.tolist())
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return float(obj) if math.isfinite(obj) else None
    return str(obj)


def print_json(obj: Any) -> None:
    """Print ``obj`` as one line of strict JSON (no NaN or Infinity: those are ``null``)."""
    print(json.dumps(json_safe(obj), allow_nan=False))


def print_table(rows: Sequence[tuple[str, float, str]]) -> None:
    """Print ``name  value`` lines, names aligned, values with units (:func:`format_quantity`).

    Parameters
    ----------
    rows : sequence of (name, value, dimension)
        Value in SI; non-finite values are printed as ``inf``/``nan``.
    """
    width = max(len(name) for name, _, _ in rows)
    for name, value, dim in rows:
        text = format_quantity(value, dim) if math.isfinite(value) else str(value)
        print(f"{name:<{width}}  {text}")


def print_written(*paths: str | None) -> None:
    """Print ``wrote PATH`` for each path given (call it only after the files were written)."""
    for path in paths:
        if path:
            print(f"wrote {path}")


#: Significant digits of every number printed for humans.
DIGITS = 3

#: Dataset unit strings (``attrs["units"]``) → the dimension of :mod:`viscoforce.units`.
_UNIT_DIMENSIONS = {"Pa": "pressure", "s": "time", "N": "force", "N/m": "stiffness", "m": "length",
                    "N s/m": "drag", "N*s/m": "drag", "Hz": "frequency",
                    "rad/s": "angular_frequency", "m/s": "speed"}


def format_value(value: float | None, unit: str, digits: int = DIGITS) -> str:
    """A value for humans: ``3.69 TPa`` style where the unit's dimension is known.

    Parameters
    ----------
    value : float or None
        The value in the SI ``unit``; None or NaN prints ``n/a``.
    unit : str
        Its unit as a dataset writes it (``"Pa"``, ``"s"``, ``"1"``, ``"Pa s^beta"`` ...).
    digits : int
        Significant digits (default :data:`DIGITS`).

    Returns
    -------
    str
        A prefixed unit for the dimensions :mod:`viscoforce.units` knows (:func:`format_quantity`),
        else the number and the unit as given (none for ``"1"``).
    """
    if value is None or value != value:
        return "n/a"
    if unit in _UNIT_DIMENSIONS:
        return format_quantity(value, _UNIT_DIMENSIONS[unit], digits=digits)
    return f"{value:.{digits}g} {'' if unit in ('1', '') else unit}".rstrip()


def format_estimate(value: float | None, stderr: float | None, unit: str,
                    digits: int = DIGITS) -> str:
    """``value ± stderr`` with units, both with ``digits`` significant digits.

    Returns
    -------
    str
        ``"4.97 GPa ± 37.3 MPa"``; ``"4.97 GPa (no stderr)"`` when the stderr is missing.
    """
    text = format_value(value, unit, digits)
    if stderr is None or stderr != stderr:
        return f"{text} (no stderr)"
    return f"{text} ± {format_value(stderr, unit, digits)}"
