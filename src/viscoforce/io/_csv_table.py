"""The bounded table reader of :mod:`viscoforce.io.csv_formats`: :class:`_Table` and its checks.

:func:`_read_table` reads a ``name (unit)`` table's header, then its known and label columns in
one bounded pass of pandas' C parser (the table rules, the size limits and the messages are those
of :mod:`viscoforce.io.csv_formats`). :class:`_Table` holds the cells read and refuses a cell that
is no finite number or beyond its quantity's physical range, naming the column, the data row and
the file line; :func:`_bad_line` names a line with a wrong number of fields.
"""

from __future__ import annotations

import math
import mmap
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from pandas.api.types import is_bool_dtype, is_numeric_dtype

from viscoforce._limits import MAX_CSV_BYTES, MAX_CSV_ROWS
from viscoforce.exceptions import EffortError, InstrumentFormatError, ParameterError, UnitError
from viscoforce.io._csv_header import (
    _HEAD_BYTES,
    _HEADER,
    _LABELS,
    _MAX_HEADER_SCAN,
    _delimiter,
    _encoding,
    _excerpt,
    _find_header,
    _first_data_line,
    _header_cells,
    _split,
    encoding_problem,
)
from viscoforce.io.quality import (
    PHYSICAL_RANGES,
    below_scale,
    first_beyond,
    range_text,
    scale_text,
)


@dataclass(frozen=True)
class _Column:
    index: int  # position in the row
    header: str  # the cell as written
    name: str  # lower-case quantity name, e.g. "force", "phase_stderr"
    unit: str | None  # None for label columns


@dataclass
class _Table:
    path: Path
    delimiter: str
    decimal_comma: bool
    columns: list[_Column]
    cells: pd.DataFrame  # the columns read (quantities, labels), labelled by their index
    header: str  # the header line as written
    header_index: int  # 0-based file line of the header
    n_fields: int  # fields per line (the header's, with an unnamed trailing one)
    encoding: str
    skipped: np.ndarray  # 0-based file lines after the header that are blank or comments
    #: columns read but not yet checked against PHYSICAL_RANGES (see :meth:`check_ranges`)
    unchecked: list[tuple[_Column, np.ndarray, np.ndarray]] = field(default_factory=list)

    @property
    def n_rows(self) -> int:
        return len(self.cells)

    def find(self, name: str) -> _Column | None:
        hits = [c for c in self.columns if c.name == name]
        if len(hits) > 1:
            raise ParameterError(f"{self.path}: {len(hits)} columns named {name!r} "
                                 f"({', '.join(c.header for c in hits)}); keep one")
        return hits[0] if hits else None

    def line_index(self, row: int) -> int:
        """0-based file line of data row ``row`` (the lines after the header, minus skipped)."""
        base = self.header_index + 1 + row
        k = base
        while True:
            shifted = base + int(np.searchsorted(self.skipped, k, side="right"))
            if shifted == k:
                return k
            k = shifted

    def where(self, row: int) -> str:
        return f"data row {row + 1} (line {self.line_index(row) + 1})"

    def fields(self, row: int) -> list[str]:
        """The cells of data row ``row`` as written (the file is read up to it: messages only)."""
        target = self.line_index(row)
        with self.path.open("rb") as fh:
            for i, raw in enumerate(fh):
                if i == target:
                    return _split(raw.decode(self.encoding, errors="replace").rstrip("\r\n"),
                                  self.delimiter)
        return []  # pragma: no cover - the row was read from the file

    def cell(self, row: int, col: _Column) -> str | None:
        """The cell as written (None when the line is too short to hold it)."""
        found = self.fields(row)
        return found[col.index].strip() if col.index < len(found) else None

    def in_curve(self, row: int) -> str:
        """`` in curve 'a'`` when the table has a curve column, else empty."""
        col = next((c for c in self.columns if c.name == "curve"), None)
        if col is None or col.index not in self.cells:
            return ""
        return f" in curve {str(self.cells[col.index].iloc[row]).strip()!r}"

    def numbers(self, col: _Column, factor: float, *, allow_missing: bool = False) -> np.ndarray:
        series = self.cells[col.index]
        missing = None
        if is_numeric_dtype(series.dtype) and not is_bool_dtype(series.dtype):
            values = series.to_numpy(dtype=float)  # the parser's own numbers (the usual case)
        else:  # text somewhere in the column: empty cells, words, decimal commas among points
            raw = series.astype(str).str.strip()
            text = raw.str.replace(",", ".", regex=False) if self.decimal_comma else raw
            values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
            missing = (raw == "").to_numpy()
        bad = ~np.isfinite(values)
        if allow_missing and missing is not None:
            bad &= ~missing
        if np.any(bad):
            self._not_a_number(col, int(np.flatnonzero(bad)[0]))
        out = _scale(values, factor)
        self.unchecked.append((col, values, out))
        return out

    def check_ranges(self) -> None:
        """Refuse a value beyond its quantity's physical range, in every column read so far.

        Called by each reader once its columns are read, so that a cell that is no number is
        reported before a number that is out of range, whatever the column order.
        """
        while self.unchecked:
            self._check_range(*self.unchecked.pop(0))

    def _not_a_number(self, col: _Column, row: int) -> None:
        cell = self.cell(row, col)
        if cell is None:
            raise ParameterError(
                f"{self.path}: column '{col.header}' {self.where(row)} is missing: the line has "
                f"{len(self.fields(row))} fields, expected {self.n_fields} (a truncated line?)")
        hint = "" if self.decimal_comma or "," not in cell else (
            "; decimal commas need a semicolon or tab delimiter")
        raise ParameterError(f"{self.path}: column '{col.header}' {self.where(row)} is not a "
                             f"finite number ({cell!r}){self.in_curve(row)}{hint}")

    def _check_range(self, col: _Column, raw: np.ndarray, values: np.ndarray) -> None:
        if col.name.removesuffix("_stderr") not in PHYSICAL_RANGES:
            return
        row = first_beyond(col.name, values)
        if row is None:
            tiny = below_scale(col.name, values)
            if tiny is not None:
                unit = PHYSICAL_RANGES[col.name][2]
                raise ParameterError(
                    f"{self.path}: column '{col.header}' is at most {abs(tiny[1]):g} {unit} in "
                    f"magnitude ({self.where(tiny[0])}: {self.cell(tiny[0], col)!r}"
                    f"{self.in_curve(tiny[0])}), below {scale_text(col.name)}; check the "
                    "header's unit and the values (scaled by mistake?)")
            return
        unit = PHYSICAL_RANGES[col.name.removesuffix("_stderr")][2]
        overflow = (" (the conversion to SI overflows)"
                    if math.isfinite(raw[row]) and not math.isfinite(values[row]) else "")
        raise ParameterError(
            f"{self.path}: column '{col.header}' {self.where(row)} holds {self.cell(row, col)!r}"
            f" = {float(values[row]):g} {unit}{overflow}{self.in_curve(row)}, beyond the "
            f"physical range {range_text(col.name)}; check the value and the header's unit")

    def label_codes(self, col: _Column) -> tuple[np.ndarray, list[str]]:
        """Per-row codes and the labels of a label column, in order of first appearance."""
        codes, uniques = pd.factorize(self.cells[col.index], use_na_sentinel=False)
        stripped = np.asarray([str(u).strip() if isinstance(u, str) else "" for u in uniques],
                              dtype=object)
        merged, labels = pd.factorize(stripped)  # "a" and "a " are one label
        codes = merged[codes]
        if "" in labels.tolist():
            row = int(np.flatnonzero(codes == labels.tolist().index(""))[0])
            raise ParameterError(f"{self.path}: column '{col.header}' {self.where(row)} is empty")
        return codes.astype(np.intp), [str(s) for s in labels]


def _scale(values: np.ndarray, factor: float) -> np.ndarray:
    """``values × factor``; a decimal prefix divides by 10**k (``3 nN`` → exactly ``3e-9``)."""
    if 0 < factor < 1:
        inverse = round(1 / factor)
        if 1 < inverse <= 10**22 and str(inverse).rstrip("0") == "1" and 1 / inverse == factor:
            return values / float(inverse)
    with np.errstate(over="ignore"):  # an overflow is refused by the range check, with the cell
        return values * factor


def _size(n: float) -> str:
    return f"{n / 1e9:.1f} GB" if n >= 1e9 else f"{n / 1e6:.0f} MB" if n >= 1e6 else f"{n:.0f} bytes"


#: Byte pairs that start a blank or comment line (then the lines to skip are listed one by one).
_SPECIAL_STARTS = (b"\n\n", b"\n\r\n", b"\n#", b"\n ", b"\n\t", b"\n\x0b", b"\n\x0c")


def _skipped_lines(path: Path, offset: int, first: int) -> np.ndarray:
    """0-based file lines from ``first`` on (starting at byte ``offset``) that are blank or ``#``."""
    with path.open("rb") as fh:
        with mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ) as mm:
            start = max(offset - 1, 0)
            if not any(mm.find(p, start) >= 0 for p in _SPECIAL_STARTS):
                return np.empty(0, dtype=np.int64)  # the usual case: nothing to skip
        fh.seek(offset)
        out = [i for i, raw in enumerate(fh, start=first)
               if not raw.strip() or raw.lstrip().startswith(b"#")]
    return np.asarray(out, dtype=np.int64)


def _head_of(path: Path, size: int) -> bytes:
    if size > MAX_CSV_BYTES:
        raise EffortError(
            f"{path}: the file is {_size(size)}; the CSV reader reads at most "
            f"{_size(MAX_CSV_BYTES)} (MAX_CSV_BYTES), refused before reading (split the table, "
            "or keep the columns and rows the analysis needs)",
            estimate=float(size), limit=float(MAX_CSV_BYTES))
    with path.open("rb") as fh:  # read-only
        return fh.read(_HEAD_BYTES)


def _parse_header(cells: list[str], path: Path, known: Mapping[str, str]) -> list[_Column]:
    columns = []
    for i, cell in enumerate(cells):
        text = cell.strip()
        m = _HEADER.match(text)
        if m:
            name, unit = m.group(1).strip().lower(), m.group(2).strip()
            if name in _LABELS:
                unit = None  # a unit on a label column is harmless
            columns.append(_Column(i, text, name, unit))
        elif text.lower() in _LABELS:
            columns.append(_Column(i, text, text.lower(), None))
        elif not text:
            after = f" after '{cells[i - 1].strip()}'" if i else ""
            raise ParameterError(f"{path}: the header has an empty column name (cell {i + 1}"
                                 f"{after}); every column needs 'name (unit)'")
        else:
            base = text.lower()
            hint = f"; write e.g. '{text} (SI unit)'"
            if base in known or base.removesuffix("_stderr") in known:
                raise UnitError(f"{path}: column '{text}' has no unit{hint}")
            raise UnitError(f"{path}: column '{text}' has no unit (header cells read "
                            f"'name (unit)'){hint}")
    return columns


def _read_table(path: str | Path, known: Mapping[str, str], *, max_rows: int | None = None,
                limit_name: str = "MAX_CSV_ROWS") -> _Table:
    """Read the header, then the known and label columns in one bounded pass of pandas' C parser.

    Refused before parsing: a file above :data:`~viscoforce._limits.MAX_CSV_BYTES`, or one whose
    size and first lines say it holds more than twice ``max_rows`` rows; refused after reading
    ``max_rows + 1`` rows: more rows than ``max_rows``. Memory: the numeric columns are parsed
    straight to float64 (text only where a column holds text), the other columns are skipped.
    """
    path = Path(path)
    max_rows = MAX_CSV_ROWS if max_rows is None else max_rows
    if path.is_dir():
        raise InstrumentFormatError(f"{path} is a directory, not a CSV file")
    if not path.is_file():
        raise InstrumentFormatError(f"{path}: no such file")
    size = path.stat().st_size
    head = _head_of(path, size)
    problem = encoding_problem(head)
    if problem:
        raise InstrumentFormatError(f"{path}: {problem}")
    complete = size <= len(head)
    encoding = _encoding(head, complete)
    found = _find_header(head, encoding, complete)
    if found is None:
        if complete:
            raise InstrumentFormatError(f"{path}: empty table (no header line)")
        raise InstrumentFormatError(f"{path}: no header line in the first {_MAX_HEADER_SCAN} "
                                    f"lines ({_HEAD_BYTES // 1024} KiB); not a table")
    header, start, header_end = found
    header_end = min(header_end, size)
    delimiter = _delimiter(header)
    names = _header_cells(header, delimiter)
    columns = _parse_header(names, path, known)
    n_fields = len(names)
    first = _first_data_line(head, header_end, encoding)
    if first is not None:
        cells = _split(first, delimiter)
        if len(cells) == n_fields + 1 and not cells[-1].strip():
            n_fields += 1  # a trailing delimiter on the data rows: an unnamed, empty column
    if len(_split(header, delimiter)) > len(names):
        n_fields = len(names) + 1  # the header's own trailing delimiter
    tail = n_fields - 1 if n_fields > len(names) else None
    body = head[header_end:].split(b"\n")[:-1] if not complete else head[header_end:].split(b"\n")
    lengths = [len(b) + 1 for b in body[:1000] if b.strip() and not b.lstrip().startswith(b"#")]
    if lengths:
        estimate = (size - header_end) / (sum(lengths) / len(lengths))
        if estimate > 2 * max_rows:
            raise EffortError(
                f"{path}: about {estimate:.2g} data rows (from the file size, {_size(size)}, and "
                f"its first lines); the CSV reader reads at most {max_rows:.3g} rows "
                f"({limit_name}), refused before reading (split the table)",
                estimate=float(estimate), limit=float(max_rows))
    skipped = _skipped_lines(path, header_end, start + 1)
    wanted = [c.index for c in columns if c.name in _LABELS or c.name in known
              or c.name.removesuffix("_stderr") in known]
    text_columns = [c.index for c in columns if c.name in _LABELS]
    if tail is not None:
        wanted.append(tail)
        text_columns.append(tail)
    options: dict[str, Any] = dict(
        sep=delimiter, header=None, names=list(range(n_fields)),
        usecols=None if len(wanted) == n_fields else wanted or [0],
        dtype={i: str for i in text_columns}, skiprows=np.concatenate(
            [np.arange(start + 1), skipped]).tolist(), nrows=max_rows + 1,
        keep_default_na=False, na_values=[], skipinitialspace=True, skip_blank_lines=True,
        index_col=False, engine="c", decimal="," if delimiter in ("\t", ";") else ".")
    table = _Table(path, delimiter, delimiter in ("\t", ";"), columns, pd.DataFrame(), header,
                   start, n_fields, encoding, skipped)
    # the first rows first: a cell that is no number there is refused at once, not after the
    # whole file has been parsed (1e7 rows of text took 10 s and GBs as Python strings)
    table.cells = _parse(table, dict(options, nrows=min(_PROBE_ROWS, max_rows + 1)))
    _refuse_text(table, known, table.cells)
    if options["usecols"] is not None and _more_delimiters(path, header_end, delimiter,
                                                           n_fields - 1):
        # pandas checks the field count only when it reads every column: check it here, before
        # the whole table is parsed
        error = _bad_line(table)
        if error is not None:
            raise error
    numbers = {c.index: np.float64 for c in columns if c.index in wanted and c.index not in
               text_columns}
    try:  # straight to float64: a text cell further down cannot turn a column into strings
        table.cells = _parse(table, dict(options, dtype={**options["dtype"], **numbers}),
                             floats=True)
    except _TextCell:  # find it chunk by chunk (bounded memory), else the text-tolerant parse
        for offset, chunk in _chunks(table, options):
            _refuse_text(table, known, chunk, offset)
        table.cells = _parse(table, options)
    if table.n_rows == 0:
        raise InstrumentFormatError(f"{path}: the table has a header but no data rows")
    if table.n_rows > max_rows:
        raise EffortError(
            f"{path}: more than {max_rows:.3g} data rows; the CSV reader reads at most "
            f"{max_rows:.3g} rows ({limit_name}), refused after reading that many (split the "
            "table)", estimate=float(table.n_rows), limit=float(max_rows))
    if tail is not None:
        values = table.cells.pop(tail).astype(str).str.strip()
        filled = np.flatnonzero((values != "").to_numpy())
        if filled.size:
            row = int(filled[0])
            raise ParameterError(
                f"{path}: {table.where(row)} holds {values.iloc[row]!r} in field {tail + 1}, "
                f"which the header ('{_excerpt(header)}') does not name; every column needs "
                "'name (unit)'")
    return table


#: Data rows parsed before the whole table, to refuse a file of text at once (:func:`_refuse_text`).
_PROBE_ROWS = 1000


#: Data rows per step when a table with text in a quantity column is searched for it.
_CHUNK_ROWS = 200_000


class _TextCell(Exception):
    """pandas met a cell that is no number in a column parsed straight to float64."""


def _chunks(table: _Table, options: dict[str, Any]) -> Iterator[tuple[int, pd.DataFrame]]:
    """(first data row, cells) of the table, :data:`_CHUNK_ROWS` rows at a time."""
    offset = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pd.errors.DtypeWarning)
        reader = pd.read_csv(table.path, encoding=table.encoding, chunksize=_CHUNK_ROWS,
                             **options)
        with reader:
            for chunk in reader:
                yield offset, chunk.reset_index(drop=True)
                offset += len(chunk)


def _refuse_text(table: _Table, known: Mapping[str, str], cells: pd.DataFrame,
                 offset: int = 0) -> None:
    """Refuse the first non-empty cell of a quantity column that is no finite number.

    ``cells`` holds data rows ``offset``, ``offset + 1``, … Empty cells pass (some columns
    allow them, each reader decides); the message is the one the reader gives after parsing.
    """
    for col in table.columns:
        if col.name in _LABELS or (col.name not in known
                                   and col.name.removesuffix("_stderr") not in known):
            continue
        series = cells.get(col.index)
        if series is None or (is_numeric_dtype(series.dtype)
                              and not is_bool_dtype(series.dtype)):
            continue
        raw = series.astype(str).str.strip()
        text = raw.str.replace(",", ".", regex=False) if table.decimal_comma else raw
        values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero((raw != "").to_numpy() & ~np.isfinite(values))
        if bad.size:
            table._not_a_number(col, offset + int(bad[0]))


def _parse(table: _Table, options: dict[str, Any], *, floats: bool = False) -> pd.DataFrame:
    """Run pandas' C parser over the file; its warnings and errors become precise messages.

    With ``floats`` (some columns' dtype float64), a cell that is no number raises
    :class:`_TextCell` for the caller to locate.
    """
    for encoding in dict.fromkeys((table.encoding, "latin-1")):
        table.encoding = encoding
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error", pd.errors.ParserWarning)  # fields would be lost
                warnings.simplefilter("ignore", pd.errors.DtypeWarning)  # text: handled per column
                return pd.read_csv(table.path, encoding=encoding, **options)
        except UnicodeDecodeError:
            continue
        except pd.errors.EmptyDataError:
            return pd.DataFrame()
        except (pd.errors.ParserError, pd.errors.ParserWarning, ValueError, OverflowError) as exc:
            if floats and type(exc) is ValueError:  # a conversion, not the parser's error
                raise _TextCell(str(exc)) from None
            raise _bad_line(table, short=True) or InstrumentFormatError(
                f"{table.path}: not a readable table ({exc})") from None
    raise InstrumentFormatError(f"{table.path}: not a readable text table")  # pragma: no cover


def _more_delimiters(path: Path, offset: int, delimiter: str, most: int) -> bool:
    """Whether a line from byte ``offset`` on holds more than ``most`` delimiters (NumPy, chunked).

    Quoted delimiters count too: a True is confirmed by :func:`_bad_line`, which parses.
    """
    code, carry = ord(delimiter), 0
    with path.open("rb") as fh:
        fh.seek(offset)
        while chunk := fh.read(1 << 20):  # 1 MiB at a time: ~6 MB of work arrays
            block = np.frombuffer(chunk, dtype=np.uint8)
            count = np.cumsum(block == code, dtype=np.int32)
            ends = np.flatnonzero(block == 10)
            if ends.size == 0:
                carry += int(count[-1])
                continue
            per_line = np.diff(count[ends], prepend=0)
            per_line[0] += carry
            if int(per_line.max()) > most:
                return True
            carry = int(count[-1] - count[ends[-1]])
    return carry > most


def _odd_lines(path: Path, delimiter: str, most: int) -> Iterator[tuple[int, int, int]]:
    """(0-based line, first byte, end byte) of each line whose fields may not number ``most + 1``.

    NumPy counts the delimiters of every line, 1 MiB at a time; only the lines with another
    count, or with a quote (a quoted delimiter is no field separator), are given to be parsed
    (a Python loop over every line of a 1e7-row table took 30 s before its bad last line was
    named).
    """
    code, quote = ord(delimiter), ord('"')
    line = line_start = offset = carry = 0
    quoted = False
    with path.open("rb") as fh:
        while chunk := fh.read(1 << 20):
            block = np.frombuffer(chunk, dtype=np.uint8)
            ends = np.flatnonzero(block == 10)
            count = np.cumsum(block == code, dtype=np.int32)
            quotes = np.cumsum(block == quote, dtype=np.int32)
            if ends.size:
                per_line = np.diff(count[ends], prepend=0)
                per_line[0] += carry
                has_quote = np.diff(quotes[ends], prepend=0) > 0
                has_quote[0] |= quoted
                starts = np.concatenate(([line_start], offset + ends[:-1] + 1))
                for k in np.flatnonzero((per_line != most) | has_quote):
                    yield line + int(k), int(starts[k]), offset + int(ends[k]) + 1
                line += ends.size
                line_start = offset + int(ends[-1]) + 1
                carry = int(count[-1] - count[ends[-1]])
                quoted = bool(quotes[-1] > quotes[ends[-1]])
            else:
                carry += int(count[-1])
                quoted |= bool(quotes[-1] > 0)
            offset += len(chunk)
    if offset > line_start and (carry != most or quoted):  # a last line without a line end
        yield line, line_start, offset


def _bad_line(table: _Table, *, short: bool = False) -> ParameterError | None:
    """The first line with more fields than the header, as an error (None if there is none).

    With ``short``, else the first data line with fewer fields than the header. Only the lines
    :func:`_odd_lines` finds are parsed.
    """
    shorter = None
    with table.path.open("rb") as fh:
        for i, start, stop in _odd_lines(table.path, table.delimiter, table.n_fields - 1):
            if i <= table.header_index:
                continue
            fh.seek(start)
            raw = fh.read(stop - start)
            if not raw.strip() or raw.lstrip().startswith(b"#"):
                continue
            found = _split(raw.decode(table.encoding, errors="replace").rstrip("\r\n"),
                           table.delimiter)
            if len(found) < table.n_fields and shorter is None:
                shorter = (i, len(found))
            if len(found) > table.n_fields:
                extra = [e.strip() for e in found[table.n_fields:]]
                hint = (": a trailing delimiter? remove it" if not any(extra)
                        else "; if ',' is a decimal comma here, use a semicolon or tab delimiter"
                        if table.delimiter == "," and all(e.isdigit() for e in extra) else "")
                return ParameterError(
                    f"{table.path}: line {i + 1} has {len(found)} fields, expected "
                    f"{table.n_fields} (header '{_excerpt(table.header)}'){hint}")
    if short and shorter is not None:
        return ParameterError(
            f"{table.path}: line {shorter[0] + 1} has {shorter[1]} fields, expected "
            f"{table.n_fields} (header '{_excerpt(table.header)}'): a truncated line?")
    return None
