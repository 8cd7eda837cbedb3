"""Generic CSV/TSV readers with ``name (unit)`` headers: curves, spectra, drive traces, Prony tables.

Table rules (every reader):

* The first line that is neither blank nor a ``#`` comment is the header; every cell reads
  ``name (unit)`` (the header grammar shared by every table reader here), except the label
  columns ``curve`` and ``segment``, which take no unit. A column without a unit is an error
  (:class:`~viscoforce.exceptions.UnitError`), so is a unit unknown for the column's quantity
  (the message names the column). Columns whose name is not known here are ignored and listed in
  ``attrs["ignored_columns"]``.
* The delimiter is sniffed from the header line: tab, then semicolon, then comma (the one that
  splits it into the most cells). With a semicolon or tab delimiter, decimal commas (``1,5``) are
  accepted as well as points.
* Units are converted to SI with :func:`viscoforce.units.unit_factor`; a phase takes ``deg``,
  ``degree``, ``°`` or ``rad`` and is stored in degrees.
* An empty or non-numeric cell is an error naming the column, the data row and the file line (the
  only exception: empty ``mean_force`` cells of a spectrum, NaN = unknown); so is a line with
  more fields than the header, or too few for a column read. One trailing delimiter (on the
  header, the data rows or both) is an unnamed empty column; a value in it is an error.
* A value beyond the physical range of its quantity (:data:`viscoforce.io.quality.
  PHYSICAL_RANGES`, in SI after the unit conversion, which may not overflow) is an error naming
  the column, the row, the cell and the range: e.g. a stiffness must be finite, > 0 and <= 1e10
  N/m, a phase within ±360°, a frequency > 0 and <= 1 GHz. Such values are no measurement (a
  wrong unit, a damaged file) and would overflow downstream. So is a column whose largest
  magnitude is below the smallest scale of its quantity (:data:`viscoforce.io.quality.
  SMALLEST_SCALES`, e.g. a force column of 1e-309 N: it underflows downstream), and a time series
  that steps by less than :data:`~viscoforce._limits.MIN_TIME_STEP`. A spring constant or
  sensitivity given to the reader lies in :data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` /
  :data:`~viscoforce._limits.SENSITIVITY_RANGE`.
* Bounded reading: a file above :data:`~viscoforce._limits.MAX_CSV_BYTES` (1 GB) is refused
  before it is read, a table of more than :data:`~viscoforce._limits.MAX_CSV_ROWS` (1e7) rows
  (a drive trace: :data:`~viscoforce._limits.MAX_TRACE_ROWS`) before it is parsed (estimated
  from the size and the first lines) or after that many rows; the numeric columns are parsed
  straight to float64 by pandas' C parser and unknown columns are skipped, so reading takes a
  small multiple of the data it returns (about 3x for curves and traces, 6x for a spectrum with
  its derived variables). A 1e6-row table (~30 MB) reads in about 0.3 s. The first
  :data:`_PROBE_ROWS` rows are parsed first, so a file of text is refused at once; text further
  down is found chunk by chunk (:data:`_CHUNK_ROWS` rows), not by turning whole columns into
  Python strings.
* Text encodings: UTF-8 (with or without a BOM), else Latin-1; UTF-16/32 text is refused with
  "save it as UTF-8".
* The file is only read (opened read-only, never written).

Time series (:func:`read_curves_csv`): ``time`` [time], ``force`` [force] and/or ``deflection``
[length, or V with ``sensitivity``], ``height`` (or ``position`` / ``z``) [length], optional
``segment`` labels (mapped to approach / pause / modulation / retract / other; the label itself
is kept in ``segment_type``), optional ``curve`` labels (several curves in one file, each curve's
rows in file order), optional per-curve ``x``, ``y`` [length]. Time must increase strictly within
each curve (a repeated time is named as a duplicated row, a curve label that starts again after
other curves as a duplicated curve); it is kept as recorded. A curve that repeats an earlier one
sample for sample is refused.

Spectra (:func:`read_spectrum_csv`, the SPEC's "Spectrum CSV"): ``frequency (Hz)`` or ``omega
(rad/s)``; a magnitude ``stiffness (N/m)``, or ``amplitude (1)`` (relative a = |F1|/F̄, needs
``mean_force`` and a drive amplitude), or ``force_amplitude (N)`` with ``drive_amplitude (m)``;
``phase (deg)`` or ``phase (rad)``; optional ``<column>_stderr (<unit>)`` (converted like the
column, stored as ``<name>_stderr``; a derived stiffness gets its stderr by error propagation
when the inputs' stderrs are given), ``mean_force (N)`` (else NaN), ``drive_amplitude (m)``,
``mean_indentation (m)``, and a ``curve`` label column that adds a ``curve`` dim (every curve must
have the same frequencies). A ``phase (rad)`` column whose values are evidently degrees is refused
(:data:`RAD_PHASE_LIMIT`). The spectrum gets the ``quality`` flags, their comment and the
``phase_lag``, ``drag``, ``phase_reference`` and ``quality_summary`` attrs that a JPK modulation
spectrum gets (:mod:`viscoforce.io.quality`; one function for both readers):
no correction is applied here (``viscoforce.experiments.modulation.correct_spectrum`` does it),
and the height signal the file's phase was measured against is unknown.

Quality of a measured spectrum (:func:`viscoforce.io.quality.spectrum_quality`, shared with
:mod:`viscoforce.experiments.modulation`): 1 ``phase_outside_passive_range`` where the phase as
stored (after whatever correction was applied) is outside (0°, 90°), which a passive viscoelastic
sample cannot give; else 2 ``low_signal`` where ``stiffness`` < 3·``stiffness_stderr``; else 0.
Points are flagged, never dropped.
"""

from __future__ import annotations

import csv
import hashlib
import math
import mmap
import re
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr
from pandas.api.types import is_bool_dtype, is_numeric_dtype

from viscoforce._limits import (
    MAX_CSV_BYTES,
    MAX_CSV_ROWS,
    MAX_TRACE_ROWS,
    SENSITIVITY_RANGE,
    SPRING_CONSTANT_RANGE,
)
from viscoforce._validation import require_path, require_plausible
from viscoforce.exceptions import EffortError, InstrumentFormatError, ParameterError, UnitError
from viscoforce.io.quality import (
    MIN_TIME_STEP,
    PHYSICAL_RANGES,
    below_scale,
    first_beyond,
    phase_basis,
    quality_notes,
    range_text,
    scale_text,
    spectrum_quality,
)
from viscoforce.schema import make_curves, make_spectrum, validate_spectrum
from viscoforce.units import parse_quantity, unit_factor

__all__ = ["CURVES_COLUMNS", "RAD_PHASE_LIMIT", "SPECTRUM_COLUMNS", "read_curves_csv",
           "read_spectrum_csv", "segment_label", "sniff_header"]

#: Dimension (for :func:`viscoforce.units.unit_factor`) of each time-series column.
CURVES_COLUMNS: dict[str, str] = {
    "time": "time", "force": "force", "deflection": "length", "height": "length",
    "position": "length", "z": "length", "x": "length", "y": "length",
}
#: Dimension of each spectrum column (``angle``: deg/rad, handled here).
SPECTRUM_COLUMNS: dict[str, str] = {
    "frequency": "frequency", "omega": "angular_frequency", "stiffness": "stiffness",
    "amplitude": "dimensionless", "force_amplitude": "force", "drive_amplitude": "length",
    "phase": "angle", "mean_force": "force", "mean_indentation": "length",
}
_LABELS = ("curve", "segment")
_ANGLE = {"deg": 1.0, "degree": 1.0, "degrees": 1.0, "°": 1.0, "rad": 180.0 / math.pi,
          "radian": 180.0 / math.pi, "radians": 180.0 / math.pi}
_DELIMITERS = ("\t", ";", ",")
_SEGMENT_WORDS = (
    ("modulation", "modulation"), ("sine", "modulation"), ("oscillat", "modulation"),
    ("retract", "retract"), ("retrace", "retract"), ("withdraw", "retract"),
    ("pause", "pause"), ("hold", "pause"), ("dwell", "pause"), ("wait", "pause"),
    ("approach", "approach"), ("extend", "approach"), ("trace", "approach"),
    ("indent", "approach"),
)
_SEGMENT_SHORT = {"ext": "approach", "app": "approach", "ret": "retract", "mod": "modulation"}
#: A header cell ``name (unit)``.
_HEADER = re.compile(r"^\s*([A-Za-z_][\w ]*?)\s*\(\s*([^)]*)\s*\)\s*$")
_MAX_HEADER_SCAN = 200  # lines looked at for the header when sniffing
_HEAD_BYTES = 65536  # bytes looked at for the header (and the encoding, the row estimate)


def segment_label(label: str) -> str:
    """Schema segment name of a file's segment label (e.g. ``"Extend"`` → ``"approach"``)."""
    text = str(label).strip().lower()
    if text in _SEGMENT_SHORT:
        return _SEGMENT_SHORT[text]
    for word, name in _SEGMENT_WORDS:
        if word in text:
            return name
    return "other"


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


def _split(line: str, delimiter: str) -> list[str]:
    return next(csv.reader([line], delimiter=delimiter, skipinitialspace=True), [])


def _size(n: float) -> str:
    return f"{n / 1e9:.1f} GB" if n >= 1e9 else f"{n / 1e6:.0f} MB" if n >= 1e6 else f"{n:.0f} bytes"


def _excerpt(text: str, width: int = 60) -> str:
    text = text.strip()
    return text if len(text) <= width else text[:width - 1] + "…"


def encoding_problem(head: bytes) -> str | None:
    """Why the first bytes of a file are no text this module reads (UTF-16, NUL bytes), or None."""
    if head.startswith((b"\xff\xfe\x00\x00", b"\x00\x00\xfe\xff")):
        return "UTF-32 text: save it as UTF-8"
    sample = head[:1024]
    if len(sample) >= 4 and sample[:2] not in (b"\xff\xfe", b"\xfe\xff"):
        odd, even = sample[1::2].count(0) / (len(sample) // 2), sample[0::2].count(0) / (
            (len(sample) + 1) // 2)
        bom = "utf-16-le" if odd > 0.3 and even < 0.05 else (
            "utf-16-be" if even > 0.3 and odd < 0.05 else None)
    else:
        bom = "utf-16" if sample[:2] in (b"\xff\xfe", b"\xfe\xff") else None
    if bom is not None:
        text = head[:len(head) - len(head) % 2].decode(bom, errors="replace")
        found = sniff_header(text)
        what = f" (a table with the header '{_excerpt(found[0])}')" if found and header_names(
            text) else ""
        return f"UTF-16 text{what}: save it as UTF-8"
    if b"\x00" in head:
        nul = head.index(b"\x00")
        text = head[:nul]
        if nul >= 16 and b"\n" in text and sum(c < 9 or 13 < c < 32 for c in text) == 0:
            return (f"text up to byte {nul}, then NUL bytes: a damaged or zero-padded file "
                    "(copy it again)")
        return "binary content (NUL bytes), not a text table"
    if b"\r" in head and b"\n" not in head and len(head.strip()) > 0 and head.count(b"\r") > 1:
        return ("lines end with CR only (classic Mac OS): save it with LF or CRLF line ends")
    return None


def _encoding(head: bytes, complete: bool) -> str:
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if complete or exc.start < len(head) - 4:  # else a character cut by the sniff window
            return "latin-1"
    return "utf-8-sig"


def _find_header(head: bytes, encoding: str, complete: bool) -> tuple[str, int, int] | None:
    """``(header line, 0-based line, byte offset after it)`` among the first lines of ``head``."""
    offset = 0
    pieces = head.split(b"\n")
    for i, raw in enumerate(pieces[:_MAX_HEADER_SCAN]):
        if i == len(pieces) - 1 and not complete:
            return None  # cut by the sniff window
        text = raw.decode(encoding, errors="replace").rstrip("\r").lstrip("\ufeff")
        stripped = text.strip()
        if stripped and not stripped.startswith("#"):
            return text, i, offset + len(raw) + 1
        offset += len(raw) + 1
    return None


def _first_data_line(head: bytes, offset: int, encoding: str) -> str | None:
    for raw in head[offset:].split(b"\n")[:-1]:
        text = raw.decode(encoding, errors="replace").rstrip("\r")
        if text.strip() and not text.strip().startswith("#"):
            return text
    return None


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


def _delimiter(header: str) -> str:
    counts = {d: header.count(d) for d in _DELIMITERS}
    best = max(_DELIMITERS, key=lambda d: counts[d])
    return best if counts[best] else ","


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


def sniff_header(text: str) -> tuple[str, str, int] | None:
    """``(header line, delimiter, 0-based line index)`` of a table's text, or None if empty."""
    for i, line in enumerate(text.splitlines()[:_MAX_HEADER_SCAN]):
        stripped = line.strip()
        if stripped and not stripped.startswith("#"):
            return line, _delimiter(line), i
    return None


def _header_cells(line: str, delimiter: str) -> list[str]:
    """The header's cells, without one empty trailing cell (a trailing delimiter)."""
    cells = [c.strip() for c in _split(line, delimiter)]
    if len(cells) > 1 and not cells[-1]:
        cells.pop()
    return cells


def header_names(text: str) -> set[str]:
    """Lower-case column names of a ``name (unit)`` header (empty if the header is not one)."""
    found = sniff_header(text)
    if found is None:
        return set()
    line, delimiter, _ = found
    names = set()
    for cell in _header_cells(line, delimiter):
        m = _HEADER.match(cell)
        if m:
            names.add(m.group(1).strip().lower())
        elif cell.lower() in _LABELS:
            names.add(cell.lower())
        else:
            return set()
    return names


_SPECTRUM_MAGNITUDES = ("stiffness", "amplitude", "force_amplitude")
#: A usual unit of each column, for the examples in messages.
_EXAMPLE_UNITS = {"frequency": "Hz", "omega": "rad/s", "stiffness": "N/m", "amplitude": "1",
                  "force_amplitude": "N", "drive_amplitude": "m", "phase": "deg",
                  "mean_force": "N", "mean_indentation": "m", "time": "s", "force": "nN",
                  "deflection": "nm", "height": "nm", "position": "nm", "z": "nm", "x": "um",
                  "y": "um"}


def header_problem(text: str) -> str:
    """What keeps a text from being a CSV table this module reads: the closest kind, and why.

    For format detection's message when no format recognises a file: e.g. ``"looks like a CSV
    spectrum (header 'frequency (Hz),stiffness (N/m)') but it has no phase column 'phase
    (deg)'"``. Short (under 200 characters).
    """
    found = sniff_header(text)
    if found is None:
        return "text without a header line (only blank or '#' lines)"
    line, delimiter, _ = found
    cells = _header_cells(line, delimiter)
    shown = f"header '{_excerpt(line, 50)}'"
    names, no_unit, empty = set(), None, None
    for i, cell in enumerate(cells):
        m = _HEADER.match(cell)
        if m:
            names.add(m.group(1).strip().lower())
        elif cell.lower() in _LABELS:
            names.add(cell.lower())
        elif not cell:
            empty = i if empty is None else empty
        else:
            names.add(cell.lower().removesuffix("_stderr"))
            no_unit = cell if no_unit is None else no_unit
    spectrum = (bool(names & {"frequency", "omega"}) + ("phase" in names)
                + bool(names & set(_SPECTRUM_MAGNITUDES)))
    curves = ("time" in names) + bool(names & {"force", "deflection"}) + bool(
        names & {"height", "position", "z"})
    if len(cells) == 1 and line.count("(") > 1:
        return (f"a {shown} of one cell: separate the columns by commas, semicolons or tabs "
                "(not spaces)")
    if not max(spectrum, curves):
        return (f"text whose first line ('{_excerpt(line, 50)}') is no 'name (unit)' header "
                "like 'frequency (Hz),stiffness (N/m),phase (deg)'")
    kind = "a CSV spectrum" if spectrum >= curves else "a CSV time series"
    if no_unit is not None:
        unit = _EXAMPLE_UNITS.get(no_unit.lower().removesuffix("_stderr"), "SI unit")
        failure = (f"column '{_excerpt(no_unit, 30)}' has no unit: a CSV needs a 'name (unit)' "
                   f"header, e.g. '{_excerpt(no_unit, 30)} ({unit})'")
    elif empty is not None:
        failure = f"the header's cell {empty + 1} is empty (every column needs 'name (unit)')"
    elif spectrum >= curves:
        failure = ("it has no frequency column 'frequency (Hz)' or 'omega (rad/s)'"
                   if not names & {"frequency", "omega"} else
                   "it has no phase column 'phase (deg)'" if "phase" not in names else
                   "it has no magnitude column 'stiffness (N/m)'")
    else:
        failure = ("it has no 'time (s)' column" if "time" not in names else
                   "it has no 'force (N)' or 'deflection (m)' column"
                   if not names & {"force", "deflection"} else
                   "it has no height column 'height (m)' (or 'position', 'z')")
    return f"looks like {kind} ({shown}) but {failure}"


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


def _curve_coord(order: list[str]) -> np.ndarray:
    try:
        return np.asarray([int(k) for k in order], dtype=np.int32)
    except ValueError:
        return np.asarray(order, dtype=str)


def read_curves_csv(path: str | Path, *, spring_constant: float | str | None = None,
                    sensitivity: float | str | None = None, source: str = "csv-curves"
                    ) -> xr.Dataset:
    """Read a time-series CSV/TSV (see the module docstring) into a curves dataset.

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


def _stderr_map(table: _Table) -> dict[str, np.ndarray]:
    out = {}
    for col in table.columns:
        if col.name.endswith("_stderr") and col.name.removesuffix("_stderr") in SPECTRUM_COLUMNS:
            base = col.name.removesuffix("_stderr")
            if base in ("frequency", "omega"):
                raise ParameterError(f"{table.path}: column '{col.header}': a frequency has no "
                                     "standard error here (frequencies are exact)")
            out[base] = _quantity(table, col.name, SPECTRUM_COLUMNS, allow_missing=True)
            if np.any(out[base] < 0):
                raise ParameterError(f"{table.path}: column '{col.header}' has a negative "
                                     "standard error")
    return out


def _refuse_repeated_frequency(table: _Table, omega: np.ndarray, rows: np.ndarray,
                               label: str | None) -> None:
    """Refuse a frequency given twice within one curve, naming both rows."""
    o = np.argsort(omega[rows], kind="stable")
    same = np.flatnonzero(np.diff(omega[rows][o]) <= 0)
    if same.size:
        first, second = sorted((int(rows[o[same[0]]]), int(rows[o[same[0] + 1]])))
        where = f" in curve {label!r}" if label is not None else ""
        raise ParameterError(
            f"{table.path}: a frequency appears twice{where}: "
            f"{float(omega[first]) / (2 * math.pi):g} Hz at {table.where(first)} and "
            f"{table.where(second)} (a duplicated row or curve?); keep one row per frequency "
            "(give repeated measurements distinct curve labels)")


def _relative(pairs: list[tuple[np.ndarray, np.ndarray | None]]) -> np.ndarray | None:
    """Relative error of a product/quotient from (value, stderr) pairs (None if none known)."""
    known = [(v, e) for v, e in pairs if e is not None]
    if not known:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt(sum((e / np.abs(v)) ** 2 for v, e in known))


# ── phase columns in radians ─────────────────────────────────────────────────────────────────────

#: Largest |phase| a ``phase (rad)`` column may hold: 2π. Beyond it the values are degrees.
RAD_PHASE_LIMIT = 2.0 * math.pi


def _check_rad_phase(table: _Table, name: str) -> None:
    """Refuse a ``<name> (rad)`` column whose values are evidently degrees."""
    col = table.find(name)
    if col is None or col.unit is None or _ANGLE.get(col.unit) == 1.0:
        return
    raw = table.numbers(col, 1.0, allow_missing=True)
    finite = raw[np.isfinite(raw)]
    if finite.size == 0:
        return
    worst = float(np.max(np.abs(finite)))
    if worst > RAD_PHASE_LIMIT:
        raise UnitError(
            f"{table.path}: column '{col.header}' holds |values| up to {worst:g}, outside the "
            f"range a phase in radians can take, [-2*pi, 2*pi] = [-{RAD_PHASE_LIMIT:.4f}, "
            f"{RAD_PHASE_LIMIT:.4f}]: these are degrees; write the header '{name} (deg)'")
    if name == "phase" and finite.size >= 3 and np.all(finite > math.pi / 2):
        raise UnitError(
            f"{table.path}: column '{col.header}': every value lies in (pi/2, 2*pi] = "
            f"({math.pi / 2:.4f}, {RAD_PHASE_LIMIT:.4f}], which as radians puts every point "
            "outside the passive range (0, pi/2) and as degrees inside (0, 90): these are "
            f"degrees; write the header '{name} (deg)' (convert them first if they really are "
            "radians)")


def read_spectrum_csv(path: str | Path, *, drive_amplitude: float | str | None = None,
                      source: str = "csv-spectrum") -> xr.Dataset:
    """Read a spectrum CSV/TSV (see the module docstring) into a spectrum dataset.

    Parameters
    ----------
    path : str or Path
        The file (read-only).
    drive_amplitude : float or str, optional
        Drive amplitude |δ̂| [m] (``"1nm"`` accepted) for files without a ``drive_amplitude``
        column; needed to turn ``amplitude (1)`` into a stiffness.
    source : str
        ``attrs["source"]`` (makes it a measured spectrum: NaN mean force allowed).

    Returns
    -------
    xarray.Dataset
        Valid under :func:`viscoforce.schema.validate_spectrum`, over ``omega`` (sorted) or
        (``curve``, ``omega``). Without any drive amplitude, ``drive_amplitude`` and
        ``force_amplitude`` are absent (unknown). ``quality``
        (:func:`viscoforce.io.quality.spectrum_quality`) with the comment of
        :func:`~viscoforce.io.quality.quality_notes`, and attrs ``phase_lag`` = "none", ``drag``
        = 0 (nothing corrected here), ``phase_reference``
        (:func:`~viscoforce.io.quality.phase_basis`: unknown) and
        ``quality_summary``, as a JPK modulation spectrum has them.

    Raises
    ------
    UnitError
        A column without a unit, or with a unit unknown for its quantity; a ``phase (rad)`` or
        ``phase_stderr (rad)`` column holding degrees (a |value| above 2π, or, for the phase,
        three or more values all in (π/2, 2π]).
    ParameterError
        A missing or ambiguous column, a non-numeric cell, a value beyond its physical range (a
        stiffness that is 0 or above 1e10 N/m, derived ones included), a frequency repeated
        within a curve (both rows named), a line with a wrong number of fields, bad options.
    InstrumentFormatError
        The file is missing, empty, not a table or not UTF-8/Latin-1 text.
    EffortError
        A file above ``MAX_CSV_BYTES`` or a table above ``MAX_CSV_ROWS`` rows.
    """
    eta_option = _option("drive_amplitude", drive_amplitude, "length")
    table = _read_table(path, SPECTRUM_COLUMNS)
    p = table.path
    for name in ("phase", "phase_stderr"):
        _check_rad_phase(table, name)
    q = {name: _quantity(table, name, SPECTRUM_COLUMNS, allow_missing=name == "mean_force")
         for name in SPECTRUM_COLUMNS}
    if (q["frequency"] is None) == (q["omega"] is None):
        raise ParameterError(f"{p}: need exactly one frequency column, 'frequency (Hz)' or "
                             "'omega (rad/s)'")
    omega = 2 * math.pi * q["frequency"] if q["omega"] is None else q["omega"]
    if np.any(omega <= 0):
        row = int(np.flatnonzero(omega <= 0)[0])
        name = "frequency" if q["omega"] is None else "omega"
        raise ParameterError(f"{p}: {name} at {table.where(row)} must be > 0 "
                             f"({range_text(name)}), got {float(q[name][row]):g}")
    if q["phase"] is None:
        raise ParameterError(f"{p}: no phase column 'phase (deg)' or 'phase (rad)'")
    err = _stderr_map(table)
    table.check_ranges()
    mean = q["mean_force"] if q["mean_force"] is not None else np.full(omega.shape, np.nan)
    eta = q["drive_amplitude"]
    if eta is None and eta_option is not None:
        eta = np.full(omega.shape, eta_option)
    if eta is not None and np.any(eta <= 0):
        row = int(np.flatnonzero(eta <= 0)[0])
        raise ParameterError(f"{p}: drive_amplitude at {table.where(row)} must be > 0 "
                             f"({range_text('drive_amplitude')}), got {float(eta[row]):g} m")
    stiff_err = err.get("stiffness")
    if q["stiffness"] is not None:
        stiffness, magnitude = q["stiffness"], "stiffness"
    elif q["force_amplitude"] is not None:
        if q["drive_amplitude"] is None:
            raise ParameterError(f"{p}: 'force_amplitude' needs a 'drive_amplitude (m)' column")
        stiffness, magnitude = q["force_amplitude"] / eta, "force_amplitude"
        rel = _relative([(q["force_amplitude"], err.get("force_amplitude")),
                         (eta, err.get("drive_amplitude"))])
        if stiff_err is None and rel is not None:
            stiff_err = rel * stiffness
    elif q["amplitude"] is not None:
        if q["mean_force"] is None:
            raise ParameterError(f"{p}: 'amplitude (1)' is relative (|F1|/mean force); it needs "
                                 "a 'mean_force (N)' column")
        if eta is None:
            raise ParameterError(f"{p}: 'amplitude (1)' needs a drive amplitude: a "
                                 "'drive_amplitude (m)' column or drive_amplitude='1nm'")
        if not np.all(np.isfinite(mean)):
            row = int(np.flatnonzero(~np.isfinite(mean))[0])
            raise ParameterError(f"{p}: 'amplitude (1)' needs the mean force at every row; "
                                 f"{table.where(row)} has none")
        stiffness, magnitude = q["amplitude"] * np.abs(mean) / eta, "amplitude"
        rel = _relative([(q["amplitude"], err.get("amplitude")), (mean, err.get("mean_force")),
                         (eta, err.get("drive_amplitude"))])
        if stiff_err is None and rel is not None:
            stiff_err = rel * stiffness
    else:
        raise ParameterError(f"{p}: no magnitude column: 'stiffness (N/m)', 'amplitude (1)' (with "
                             "'mean_force (N)') or 'force_amplitude (N)' with 'drive_amplitude (m)'")
    if np.any(stiffness < 0):
        row = int(np.flatnonzero(stiffness < 0)[0])
        raise ParameterError(f"{p}: the magnitude at {table.where(row)} is negative; give the "
                             "modulus and put the sign in the phase")
    if np.any(stiffness == 0):
        row = int(np.flatnonzero(stiffness == 0)[0])
        raise ParameterError(f"{p}: the magnitude at {table.where(row)} is 0 (allowed: "
                             f"{range_text('stiffness')}): a point without a force response "
                             "has no phase; drop the row")
    row = first_beyond("stiffness", stiffness)
    if row is not None:
        how = {"force_amplitude": "force_amplitude / drive_amplitude",
               "amplitude": "amplitude x |mean_force| / drive_amplitude"}.get(magnitude)
        raise ParameterError(f"{p}: the stiffness at {table.where(row)}"
                             + (f" ({how})" if how else "")
                             + f" is {float(stiffness[row]):g} N/m, beyond the physical range "
                             f"{range_text('stiffness')}; check the values and the header's units")
    per_row: dict[str, np.ndarray] = {"stiffness": stiffness, "phase": q["phase"],
                                      "mean_force": mean}
    if eta is not None:
        per_row["drive_amplitude"] = eta
    if q["mean_indentation"] is not None:
        per_row["mean_indentation"] = q["mean_indentation"]
    stderr_rows: dict[str, np.ndarray] = {}
    if stiff_err is not None:
        stderr_rows["stiffness"] = stiff_err
    for name in ("phase", "mean_force", "drive_amplitude", "mean_indentation",
                 "force_amplitude", "amplitude"):
        if name in err:
            stderr_rows[name] = err[name]
    unused = [n for n in stderr_rows if n not in per_row and n not in ("force_amplitude",
                                                                       "amplitude")]
    if unused:
        raise ParameterError(f"{p}: stderr columns for {unused} without their value columns")
    if eta is None:
        stderr_rows.pop("force_amplitude", None)
    if magnitude != "amplitude":
        stderr_rows.pop("amplitude", None)

    order, rows = _groups(table)
    for label, r in zip(order, rows, strict=True):
        _refuse_repeated_frequency(table, omega, r, label if len(order) > 1 else None)
    w_sorted = np.sort(omega[rows[0]])
    grids = []
    for label, r in zip(order, rows, strict=True):
        o = np.argsort(omega[r], kind="stable")
        if r.size != w_sorted.size or not np.array_equal(omega[r][o], w_sorted):
            raise ParameterError(f"{p}: curve {label!r} does not have the same frequencies as "
                                 f"curve {order[0]!r} (every curve needs the same set)")
        grids.append(r[o])
    take = np.stack(grids)  # (curve, omega) row indices

    def shape(values: np.ndarray) -> np.ndarray:
        return values[take] if len(order) > 1 else values[take[0]]

    k = shape(stiffness) * np.exp(1j * np.radians(shape(q["phase"])))
    dims = ("curve", "omega") if len(order) > 1 else ("omega",)
    coords = {"curve": ("curve", _curve_coord(order), {"long_name": "curve label in the file"})
              } if len(order) > 1 else None
    attrs: dict[str, Any] = {"file": str(p), "delimiter": repr(table.delimiter),
                             "magnitude_column": magnitude,
                             "frequency_column": "omega" if q["omega"] is not None
                             else "frequency"}
    ignored = _ignored(table, SPECTRUM_COLUMNS)
    if ignored:
        attrs["ignored_columns"] = ", ".join(ignored)
    stderr = {n: shape(v) for n, v in stderr_rows.items()}
    if eta is None:
        stderr.pop("force_amplitude", None)
    # the flags and notes of a JPK modulation spectrum, by the same functions; nothing corrected
    phase = np.degrees(np.angle(k))
    quality = spectrum_quality(phase, np.abs(k), stderr.get("stiffness"))
    basis = phase_basis(None)
    notes = quality_notes(quality, phase, w_sorted / (2 * math.pi), corrections="none",
                          basis=basis)
    attrs.update({"phase_lag": "none", "drag": 0.0, "phase_reference": basis,
                  "quality_summary": notes["summary"]})
    ds = make_spectrum(w_sorted, k, shape(mean), shape(eta) if eta is not None else 1.0,
                       attrs=attrs, dims=dims, coords=coords, stderr=stderr,
                       quality=quality, quality_comment=notes["comment"],
                       mean_indentation=(shape(q["mean_indentation"])
                                         if q["mean_indentation"] is not None else None),
                       amplitude=magnitude == "amplitude", source=source)
    if eta is None:  # the placeholder drive amplitude is not data: drop what depends on it
        ds = ds.drop_vars([v for v in ("drive_amplitude", "force_amplitude",
                                       "force_amplitude_stderr") if v in ds.variables])
        ds.attrs["drive_amplitude_known"] = 0
    return validate_spectrum(ds)


# ── small tables: a measured drive trace, a Prony spectrum ──────────────────────────────────────

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
