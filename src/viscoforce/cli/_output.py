"""What the commands print: strict JSON (SI units) and aligned human-readable tables."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

from viscoforce.units import format_quantity

__all__ = ["json_safe", "print_json", "print_table", "print_written"]


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
