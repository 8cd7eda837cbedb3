"""A fit result as a table: one row per curve or pixel, ``name (unit)`` headers (``--out x.csv``).

Every column is read over the rows by dim name (:func:`viscoforce.schema.flat_over`), so each row
sits at its own coordinates.
"""

from __future__ import annotations

from typing import Any

from viscoforce._files import write_text


def table_rows(result) -> tuple[list[str], list[list[Any]]]:
    """A fit result as table rows: ``name (unit)`` headers and one row per curve/pixel.

    Columns: the map's coordinates, each parameter and its stderr, the derived Young's and shear
    moduli, the total interval of the error budget (``<name>_budget_lower``/``_upper``,
    ``<name>_budget_determined``), ``redchi``, ``chi2_pvalue``, ``quality`` (maps),
    ``success``, ``modes``; every column read over the rows by dim name
    (:func:`viscoforce.schema.flat_over`).
    """
    from viscoforce.schema import flat_over

    names = [str(n) for n in result["param_i"].values]
    columns = [n for name in names for n in (name, f"{name}_stderr")]
    columns += [str(n) for n in result.data_vars if str(n).endswith(
        ("_young", "_shear", "_young_stderr", "_shear_stderr"))]
    columns += [str(n) for n in result.data_vars if str(n).endswith(
        ("_budget_lower", "_budget_upper", "_budget_determined"))]  # the error budget's interval
    columns += [n for n in ("redchi", "chi2_pvalue", "quality", "success", "modes")
                if n in result.variables]
    dims = [str(d) for d in result["success"].dims]
    coords = [str(c) for c in result.coords
              if c not in ("param_i", "param_j", "omega", "time", "tip_position")
              and set(result[c].dims) <= set(dims) and result[c].dims]

    def header(name: str) -> str:
        unit = str(result[name].attrs.get("units", ""))
        return f"{name} ({unit})" if unit else name

    headers = [header(c) for c in (*coords, *columns)]
    rows = [list(row) for row in zip(*(flat_over(result, c, tuple(dims))
                                       for c in (*coords, *columns)), strict=True)]
    return headers, rows


def _write_csv(path: str, headers: list[str], rows: list[list[Any]]) -> None:
    import csv
    import io

    import numpy as np

    handle = io.StringIO(newline="")
    writer = csv.writer(handle)
    writer.writerow(headers)
    for row in rows:
        writer.writerow(["" if v is None else f"{v:.10g}" if isinstance(
            v, float | np.floating) else v for v in row])
    write_text(path, handle.getvalue())


def write_table(result, path: str) -> None:
    """A fit result as CSV: one row per curve/pixel, ``name (unit)`` headers (:func:`table_rows`)."""
    _write_csv(path, *table_rows(result))
