"""The UFF text layout: header lines and field values (the header layer of :mod:`viscoforce.io.bruker`).

The file's segments and columns (:class:`_Uff`, :class:`_Segment`, :class:`_Column`), the lines of
its text found without visiting the data lines (:func:`_whole_lines`) or one at a time
(:func:`_lines`), the ``HE key: value`` header up to the ``****`` end marker
(:func:`_parse_header`) and its fields read as text, integers or floats. Nothing here reads the
file or its data lines: see :mod:`viscoforce.io.bruker`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from viscoforce.exceptions import InstrumentFormatError

_UNKNOWN = ("", "?")
_END = re.compile(r"^\*+$")


@dataclass
class _Column:
    title: str
    unit: str


@dataclass
class _Segment:
    index: int
    code: str
    kind: str  # the file's type label
    number: str  # Recording_segment_<i>_nb as written
    n_points: int
    columns: list[_Column]
    #: the data, one row per sample (filled by :func:`_parse`)
    rows: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))


@dataclass
class _Uff:
    path: Path
    fields: dict[str, str]
    segments: list[_Segment]
    notes: dict[str, str] = field(default_factory=dict)


def _lines(text: str) -> Iterator[tuple[int, str]]:
    """(1-based line number, stripped line) of every non-blank line of ``text``, one at a time.

    The lines are cut out of ``text`` lazily: a list of every line (or of every line's tokens)
    of a 256 MB file would take several times the file in memory before anything is checked.
    """
    start, lineno, size = 0, 0, len(text)
    while start < size:
        end = text.find("\n", start)
        if end < 0:
            end = size
        lineno += 1
        line = text[start:end].strip()
        if line:
            yield lineno, line
        start = end + 1


def _line_number(text: str, offset: int) -> int:
    """1-based line number of character ``offset`` (for messages only: it counts)."""
    return text.count("\n", 0, offset) + 1


def _whole_lines(text: str, token: str, end: int | None = None) -> Iterator[tuple[int, str]]:
    """(offset, stripped line) of the lines of ``text[:end]`` that start with ``token``.

    Found by ``str.find`` (C speed) rather than by visiting every line: a header's few lines
    among millions of data lines.
    """
    end = len(text) if end is None else end
    pos = 0
    while (i := text.find(token, pos, end)) >= 0:
        start = text.rfind("\n", 0, i) + 1
        stop = text.find("\n", i, end)
        stop = end if stop < 0 else stop
        if not text[start:i].strip():
            yield start, text[start:stop].strip()
        pos = stop + 1 if stop > i else i + len(token)


def _parse_header(path: Path, text: str) -> tuple[dict[str, str], str]:
    """Header fields (key → value text), and the text up to the ``****`` end marker.

    The data lines are not visited here; content after the end marker is refused.
    """
    marker = next((offset for offset, line in _whole_lines(text, "*") if _END.match(line)), None)
    body = text if marker is None else text[:marker]
    fields: dict[str, str] = {}
    for offset, line in _whole_lines(body, "HE "):
        key, sep, value = line[3:].partition(":")
        key = key.strip()
        if not sep or not key:
            raise InstrumentFormatError(f"{path}: line {_line_number(text, offset)}: header "
                                        f"line without 'key: value' ({line[:60]!r})")
        if key in fields:
            raise InstrumentFormatError(f"{path}: line {_line_number(text, offset)}: header "
                                        f"field {key!r} given twice")
        fields[key] = value.strip().strip('"').strip()
    if marker is not None:
        stop = text.find("\n", marker)
        after = None if stop < 0 else re.compile(r"\S").search(text, stop)
        if after is not None:
            raise InstrumentFormatError(f"{path}: line {_line_number(text, after.start())}: "
                                        "content after the '****' end marker")
    return fields, body


def _field(uff_path: Path, fields: dict[str, str], key: str) -> str:
    if key not in fields:
        raise InstrumentFormatError(f"{uff_path}: the UFF header lacks {key!r}")
    return fields[key]


def _int_field(uff_path: Path, fields: dict[str, str], key: str, minimum: int) -> int:
    text = _field(uff_path, fields, key)
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value == int(value) and value >= minimum):
        raise InstrumentFormatError(f"{uff_path}: header field {key!r} must be an integer >= "
                                    f"{minimum}, got {text!r}")
    return int(value)


def _float_field(fields: dict[str, str], key: str) -> float:
    """The field as a finite float, NaN if absent, unrecorded (``?``) or not a number."""
    try:
        value = float(fields.get(key, "nan"))
    except ValueError:
        return math.nan
    return value if math.isfinite(value) else math.nan
