"""Small CSV/TSV tables: a measured drive trace (:func:`read_trace`), a Prony spectrum.

Both are ``name (unit)`` tables read by the bounded reader of :mod:`viscoforce.io.csv_formats`
(whose rules apply), each with its own row limit: :data:`~viscoforce._limits.MAX_TRACE_ROWS`
for a trace, :data:`MAX_PRONY_ROWS` for a Prony table (:func:`read_prony_moduli`). A missing or
unreadable file is a :class:`~viscoforce.exceptions.ParameterError` here.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from viscoforce._limits import MAX_TRACE_ROWS
from viscoforce._validation import require_path
from viscoforce.exceptions import InstrumentFormatError, ParameterError
from viscoforce.io._csv_columns import _quantity
from viscoforce.io._csv_table import _read_table, _Table

__all__ = ["MAX_PRONY_ROWS", "PRONY_COLUMNS", "TRACE_COLUMNS", "read_prony_moduli", "read_trace"]

TRACE_COLUMNS = {"time": "time", "position": "length"}
PRONY_COLUMNS = {"modulus": "pressure", "tau": "time"}
#: Most rows of a Prony table (a thousand creep modes is far beyond any material model).
MAX_PRONY_ROWS = 1000


def _table_for(path: str | Path, known: Mapping[str, str], max_rows: int,
               limit_name: str) -> _Table:
    path = require_path("path", path)
    try:
        return _read_table(path, known, max_rows=max_rows, limit_name=limit_name)
    except InstrumentFormatError as exc:
        raise ParameterError(str(exc)) from None


def _required(table: _Table, name: str, known: Mapping[str, str], *,
              allow_missing: bool = False) -> np.ndarray:
    values = _quantity(table, name, known, allow_missing=allow_missing)
    if values is None:
        raise ParameterError(f"{table.path}: no column '{name} (<unit>)'; columns are "
                             f"{', '.join(c.header for c in table.columns)}")
    return values


def read_trace(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """A measured position trace: columns ``time (<unit>)`` and ``position (<unit>)``.

    At most :data:`~viscoforce._limits.MAX_TRACE_ROWS` rows (each sample is at least one time
    step of ``simulate``, which takes at most ``MAX_STEPS``); a 1e6-row trace reads in about a
    second.

    Returns
    -------
    time, position : numpy.ndarray
        Times [s], strictly increasing, and positions h0 [m].

    Raises
    ------
    ParameterError
        Not a path, missing or empty file, a missing column, a cell that is not a finite number
        or beyond the physical range of its quantity, time not strictly increasing (the row
        named).
    UnitError
        A column without a unit, or with a unit unknown for its quantity.
    EffortError
        A file above ``MAX_CSV_BYTES`` or a table above ``MAX_TRACE_ROWS`` rows.
    """
    table = _table_for(path, TRACE_COLUMNS, MAX_TRACE_ROWS, "MAX_TRACE_ROWS")
    time = _required(table, "time", TRACE_COLUMNS)
    position = _required(table, "position", TRACE_COLUMNS)
    table.check_ranges()
    steps = np.diff(time)
    if np.any(steps <= 0):
        i = int(np.flatnonzero(steps <= 0)[0]) + 1
        why = " (the same time twice: a duplicated row?)" if steps[i - 1] == 0 else ""
        raise ParameterError(
            f"{table.path}: time must be strictly increasing; entry {i}, {table.where(i)}, is "
            f"{float(time[i]):g} s, after {float(time[i - 1]):g} s{why}")
    return time, position


def read_prony_moduli(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """A Prony spectrum in the paper's Eq. 8 form.

    Columns ``modulus (<pressure unit>)`` and ``tau (<time unit>)``: rows E_0 … E_n (decreasing,
    E_n = E_inf) with creep times τ_0 … τ_{n−1}; the last row's tau is empty.

    Returns
    -------
    moduli, taus : numpy.ndarray
        [Pa] (n + 1 values) and [s] (n values).
    """
    table = _table_for(path, PRONY_COLUMNS, MAX_PRONY_ROWS, "MAX_PRONY_ROWS")
    moduli = _required(table, "modulus", PRONY_COLUMNS)
    taus = _required(table, "tau", PRONY_COLUMNS, allow_missing=True)
    table.check_ranges()
    if not np.isnan(taus[-1]) or np.any(np.isnan(taus[:-1])):
        raise ParameterError(
            f"{table.path}: every row but the last (E_inf) needs a tau; the last row's tau is "
            "empty")
    return moduli, taus[:-1]
