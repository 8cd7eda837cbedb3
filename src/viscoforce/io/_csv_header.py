"""Header grammar and text sniffing of the CSV/TSV tables of :mod:`viscoforce.io.csv_formats`.

The ``name (unit)`` header cell, the delimiter (tab, semicolon, comma), the text encoding and the
first lines of a file: what :func:`~viscoforce.io._csv_table._read_table` needs before it parses a
table, and what format detection (:mod:`viscoforce.io.instruments`) asks of a text that may be a
table (:func:`sniff_header`, :func:`header_names`, :func:`encoding_problem`,
:func:`header_problem`).
"""

from __future__ import annotations

import csv
import re

__all__ = ["encoding_problem", "header_names", "header_problem", "sniff_header"]

_LABELS = ("curve", "segment")
_DELIMITERS = ("\t", ";", ",")
#: A header cell ``name (unit)``.
_HEADER = re.compile(r"^\s*([A-Za-z_][\w ]*?)\s*\(\s*([^)]*)\s*\)\s*$")
_MAX_HEADER_SCAN = 200  # lines looked at for the header when sniffing
_HEAD_BYTES = 65536  # bytes looked at for the header (and the encoding, the row estimate)


def _split(line: str, delimiter: str) -> list[str]:
    return next(csv.reader([line], delimiter=delimiter, skipinitialspace=True), [])


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


def _delimiter(header: str) -> str:
    counts = {d: header.count(d) for d in _DELIMITERS}
    best = max(_DELIMITERS, key=lambda d: counts[d])
    return best if counts[best] else ","


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
