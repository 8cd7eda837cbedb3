"""A fit result as a table: one row per curve or pixel, ``name (unit)`` headers (``--out x.csv``).

Every column is read over the rows by dim name (:func:`viscoforce.schema.flat_over`), so each row
sits at its own coordinates.
"""

from __future__ import annotations

from typing import Any

from viscoforce._files import write_text


def table_rows(result) -> tuple[list[str], list[list[Any]]]:
    """A fit result as table rows: ``name (unit)`` headers and one row per curve/pixel.

    Columns: the map's coordinates, then :func:`viscoforce.io.fit_tables.fit_table_columns`
    (each parameter and its stderr, Young's modulus before the paper's and the shear modulus
    after it, the total interval of the error budget, ``redchi``, ``chi2_pvalue``,
    ``quality`` (maps), ``success``, ``modes``); every column read over the rows by dim name
    (:func:`viscoforce.schema.flat_over`).
    """
    from viscoforce.io.fit_tables import fit_table_columns
    from viscoforce.schema import flat_over

    columns = fit_table_columns(result)  # Young's modulus first (issue 38 item 3)
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
