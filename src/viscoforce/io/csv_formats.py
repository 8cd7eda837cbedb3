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
  only exception: empty ``mean_force`` cells of a spectrum, NaN = unknown).
* The file is only read (opened read-only, never written).

Time series (:func:`read_curves_csv`): ``time`` [time], ``force`` [force] and/or ``deflection``
[length, or V with ``sensitivity``], ``height`` (or ``position`` / ``z``) [length], optional
``segment`` labels (mapped to approach / pause / modulation / retract / other; the label itself
is kept in ``segment_type``), optional ``curve`` labels (several curves in one file, each curve's
rows in file order), optional per-curve ``x``, ``y`` [length]. Time must increase strictly within
each curve; it is kept as recorded.

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
import io
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import xarray as xr

from viscoforce._validation import require_path
from viscoforce.exceptions import InstrumentFormatError, ParameterError, UnitError
from viscoforce.io.quality import phase_basis, quality_notes, spectrum_quality
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
    cells: pd.DataFrame  # str cells, one column per header
    lines: np.ndarray  # file line (1-based) of each data row

    def find(self, name: str) -> _Column | None:
        hits = [c for c in self.columns if c.name == name]
        if len(hits) > 1:
            raise ParameterError(f"{self.path}: {len(hits)} columns named {name!r} "
                                 f"({', '.join(c.header for c in hits)}); keep one")
        return hits[0] if hits else None

    def where(self, row: int) -> str:
        return f"data row {row + 1} (line {int(self.lines[row])})"

    def numbers(self, col: _Column, factor: float, *, allow_missing: bool = False) -> np.ndarray:
        raw = self.cells[col.index].fillna("").astype(str).str.strip()
        text = raw.str.replace(",", ".", regex=False) if self.decimal_comma else raw
        values = pd.to_numeric(text, errors="coerce").to_numpy(dtype=float)
        bad = ~np.isfinite(values)
        if allow_missing:
            bad &= (raw != "").to_numpy()
        if np.any(bad):
            row = int(np.flatnonzero(bad)[0])
            hint = "" if self.decimal_comma or "," not in raw.iloc[row] else (
                "; decimal commas need a semicolon or tab delimiter")
            raise ParameterError(f"{self.path}: column '{col.header}' {self.where(row)} is not a "
                                 f"finite number ({raw.iloc[row]!r}){hint}")
        return _scale(values, factor)

    def labels(self, col: _Column) -> list[str]:
        raw = self.cells[col.index].fillna("").astype(str).str.strip()
        empty = (raw == "").to_numpy()
        if np.any(empty):
            row = int(np.flatnonzero(empty)[0])
            raise ParameterError(f"{self.path}: column '{col.header}' {self.where(row)} is empty")
        return raw.tolist()


def _scale(values: np.ndarray, factor: float) -> np.ndarray:
    """``values × factor``; a decimal prefix divides by 10**k (``3 nN`` → exactly ``3e-9``)."""
    if 0 < factor < 1:
        inverse = round(1 / factor)
        if 1 < inverse <= 10**22 and str(inverse).rstrip("0") == "1" and 1 / inverse == factor:
            return values / float(inverse)
    return values * factor


def _read_text(path: Path) -> str:
    if not path.is_file():
        raise InstrumentFormatError(f"{path}: no such file")
    with path.open("rb") as fh:  # read-only
        data = fh.read()
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        try:
            return data.decode("latin-1")
        except UnicodeDecodeError:  # pragma: no cover - latin-1 decodes every byte
            raise InstrumentFormatError(f"{path}: not a text table") from None


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
            raise ParameterError(f"{path}: the header has an empty column name; every column "
                                 "needs 'name (unit)'")
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


def header_names(text: str) -> set[str]:
    """Lower-case column names of a ``name (unit)`` header (empty if the header is not one)."""
    found = sniff_header(text)
    if found is None:
        return set()
    line, delimiter, _ = found
    names = set()
    for cell in line.split(delimiter):
        cell = cell.strip().strip('"')
        m = _HEADER.match(cell)
        if m:
            names.add(m.group(1).strip().lower())
        elif cell.lower() in _LABELS:
            names.add(cell.lower())
        else:
            return set()
    return names


def _read_table(path: str | Path, known: Mapping[str, str]) -> _Table:
    path = Path(path)
    if path.is_dir():
        raise InstrumentFormatError(f"{path} is a directory, not a CSV file")
    text = _read_text(path)
    all_lines = text.splitlines()
    found = sniff_header(text)
    if found is None:
        raise InstrumentFormatError(f"{path}: empty table (no header line)")
    header, delimiter, start = found
    body = [(i + 1, line) for i, line in enumerate(all_lines) if i > start
            and line.strip() and not line.lstrip().startswith("#")]
    if not body:
        raise InstrumentFormatError(f"{path}: the table has a header but no data rows")
    try:
        cells = pd.read_csv(io.StringIO("\n".join([header] + [line for _, line in body])),
                            sep=delimiter, dtype=str, keep_default_na=False,
                            skipinitialspace=True, engine="c")
    except (pd.errors.ParserError, ValueError) as exc:
        raise InstrumentFormatError(f"{path}: not a readable table ({exc})") from None
    names = next(csv.reader([header], delimiter=delimiter, skipinitialspace=True))
    if len(names) != cells.shape[1]:  # pragma: no cover - pandas splits the header the same way
        raise InstrumentFormatError(f"{path}: could not split the header line")
    cells.columns = range(len(names))
    columns = _parse_header(names, path, known)
    if len(cells) != len(body):  # pragma: no cover - pandas keeps every non-blank row
        raise InstrumentFormatError(f"{path}: could not align rows with file lines")
    return _Table(path, delimiter, delimiter in ("\t", ";"), columns, cells,
                  np.asarray([n for n, _ in body]))


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


def _option(name: str, value: Any, dimension: str) -> float | None:
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
    return out


def _sensitivity(value: Any) -> float | None:
    """Deflection sensitivity [m/V] from a number or ``"<length>/V"`` (e.g. ``"50nm/V"``)."""
    if isinstance(value, str):
        m = re.fullmatch(r"\s*(.*?)\s*/\s*V\s*", value)
        if not m:
            raise UnitError(f"sensitivity: write a length per volt, e.g. '50nm/V', got {value!r}")
        value = m.group(1)
        if not value:
            raise UnitError("sensitivity: no number before '/V'")
    return _option("sensitivity", value, "length")


def _groups(table: _Table) -> tuple[list[str], list[np.ndarray]]:
    """Curve labels (first-appearance order) and the row indices of each curve."""
    col = table.find("curve")
    n = len(table.cells)
    if col is None:
        return ["0"], [np.arange(n)]
    labels = np.asarray(table.labels(col))
    order = list(dict.fromkeys(labels.tolist()))
    return order, [np.flatnonzero(labels == k) for k in order]


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
        A missing required column, a non-numeric cell, non-monotonic time, bad options.
    InstrumentFormatError
        The file is missing, empty or not a table.
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
    order, rows = _groups(table)
    index = np.concatenate(rows)
    for label, r in zip(order, rows, strict=True):
        steps = np.diff(time[r])
        if np.any(steps <= 0):
            bad = int(r[int(np.flatnonzero(steps <= 0)[0]) + 1])
            where = "" if len(order) == 1 else f" of curve {label!r}"
            raise ParameterError(f"{p}: time{where} is not strictly increasing at "
                                 f"{table.where(bad)} ({time[bad]!r} s after "
                                 f"{time[r][np.searchsorted(r, bad) - 1]!r} s)")
    scol = table.find("segment")
    if scol is not None:
        codes, uniques = pd.factorize(np.asarray(table.labels(scol))[index])
        types = [str(u) for u in uniques]  # first-appearance order
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
        A missing or ambiguous column, a non-numeric cell, repeated frequencies, bad options.
    InstrumentFormatError
        The file is missing, empty or not a table.
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
        raise ParameterError(f"{p}: frequency at {table.where(row)} must be > 0")
    if q["phase"] is None:
        raise ParameterError(f"{p}: no phase column 'phase (deg)' or 'phase (rad)'")
    err = _stderr_map(table)
    mean = q["mean_force"] if q["mean_force"] is not None else np.full(omega.shape, np.nan)
    eta = q["drive_amplitude"]
    if eta is None and eta_option is not None:
        eta = np.full(omega.shape, eta_option)
    if eta is not None and np.any(eta <= 0):
        row = int(np.flatnonzero(eta <= 0)[0])
        raise ParameterError(f"{p}: drive_amplitude at {table.where(row)} must be > 0")
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
    w = omega[rows[0]]
    w_sorted = np.sort(w)
    if np.any(np.diff(w_sorted) <= 0):
        raise ParameterError(f"{p}: a frequency appears twice"
                             + (f" in curve {order[0]!r}" if len(order) > 1 else ""))
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


def _table_for(path: str | Path, known: Mapping[str, str]) -> _Table:
    path = require_path("path", path)
    try:
        return _read_table(path, known)
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

    Returns
    -------
    time, position : numpy.ndarray
        Times [s] and positions h0 [m] (monotonic time is checked by the drive).

    Raises
    ------
    ParameterError
        Not a path, missing or empty file, a missing column, a cell that is not a finite number.
    UnitError
        A column without a unit, or with a unit unknown for its quantity.
    """
    table = _table_for(path, TRACE_COLUMNS)
    return (_required(table, "time", TRACE_COLUMNS),
            _required(table, "position", TRACE_COLUMNS))


def read_prony_moduli(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """A Prony spectrum in the paper's Eq. 8 form.

    Columns ``modulus (<pressure unit>)`` and ``tau (<time unit>)``: rows E_0 … E_n (decreasing,
    E_n = E_inf) with creep times τ_0 … τ_{n−1}; the last row's tau is empty.

    Returns
    -------
    moduli, taus : numpy.ndarray
        [Pa] (n + 1 values) and [s] (n values).
    """
    table = _table_for(path, PRONY_COLUMNS)
    moduli = _required(table, "modulus", PRONY_COLUMNS)
    taus = _required(table, "tau", PRONY_COLUMNS, allow_missing=True)
    if not np.isnan(taus[-1]) or np.any(np.isnan(taus[:-1])):
        raise ParameterError(
            f"{table.path}: every row but the last (E_inf) needs a tau; the last row's tau is "
            "empty")
    return moduli, taus[:-1]
