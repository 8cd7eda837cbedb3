r"""The Bruker Nanoscope header: detection, sections, values, scales (for :mod:`viscoforce.io.bruker`).

A Nanoscope file (``.spm``, ``.000`` …) starts with a text header of ``\key: value`` lines,
separated by CR LF, grouped in sections opened by ``\*<name>`` lines (``\*Force file list``,
``\*Scanner list``, ``\*Ciao scan list``, ``\*Ciao force list``, one ``\*Ciao force image list``
per recorded channel, ``\*Ciao image list`` for an image) and closed by ``\*File list end``; the
binary data follow at the offsets the header gives. Keys repeat across sections (``Samps/line``),
so the header is kept as a list of sections (:class:`NanoscopeHeader`).

A scaled ("V") value reads ``V [<soft scale>] (<hard scale> <unit>/LSB) <hard value> <unit>``
(the Nanoscope manual's scaling chain, also followed by pyfmreader and SciFiReaders):

* the *hard scale* (V/LSB) turns a raw integer into volts;
* the *hard value* is the parameter itself in volts (``@4:Ramp Size … 227.2211 V``);
* the *soft scale* names a sensitivity defined elsewhere in the header (``\@Sens. Zsens: V
  13.203 nm/V``) that turns volts into the physical unit.

:func:`scaled` parses such a value (:class:`Scaled`); :meth:`NanoscopeHeader.sensitivity`
resolves a soft scale to metres per volt. Nothing here reads the binary data: see
:mod:`viscoforce.io._bruker_spm`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from viscoforce.exceptions import InstrumentFormatError

_HEAD = 4096
_NANOSCOPE_MAGIC = (b"\\*Force file list", b"\\*File list", b"\\*EC File list")
#: Largest header searched for ``\*File list end`` [bytes] (real headers: 30-80 kB).
MAX_HEADER_BYTES = 4 * 1024**2
_END = "\\*File list end"
_LINE = re.compile(r"^\\(?P<key>@?(?:\d+:)?[^:]*?)\s*:\s?(?P<value>.*)$")
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_SCALED = re.compile(rf"^V\s*(?:\[(?P<soft>[^\]]*)\])?\s*(?:\((?P<hard>{_NUMBER})\s*"
                     rf"(?P<hard_unit>[^)]*)\))?\s*(?P<value>{_NUMBER})?\s*(?P<unit>.*)$")
#: soft-scale units → their unit per metre ("~m" is Nanoscope's µm): value / this = m/V
_PER_METRE = {"": 1e9, "nm/V": 1e9, "~m/V": 1e6, "um/V": 1e6, "µm/V": 1e6, "m/V": 1.0}


def _head(path: Path, size: int = _HEAD) -> bytes:
    try:
        with path.open("rb") as fh:
            return fh.read(size)
    except OSError:
        return b""


def detect_nanoscope(path: str | Path) -> bool:
    r"""True if ``path`` starts like a Bruker Nanoscope file (``\*Force file list``, ``\*File list``).

    Never raises (an unreadable file gives False).
    """
    head = _head(Path(path), 64).removeprefix(b"\xef\xbb\xbf")
    return head.startswith(_NANOSCOPE_MAGIC)


def _number(text: str) -> float | None:
    """The first number in ``text``, or None."""
    match = re.search(_NUMBER, text)
    return float(match.group(0)) if match else None


@dataclass(frozen=True)
class Scaled:
    """One ``V [soft] (hard unit) value unit`` header value, parsed (NaN where absent)."""

    soft: str  # the soft scale's name ("Sens. Zsens"), "" if none
    hard: float  # hard scale [hard_unit], e.g. V/LSB
    hard_unit: str
    value: float  # the hard value
    unit: str


def scaled(path: Path, key: str, text: str) -> Scaled:
    """Parse a scaled header value; refuse one that is not of that form."""
    match = _SCALED.match(text.strip())
    if match is None:
        raise InstrumentFormatError(f"{path}: header value {key!r} = {text.strip()[:80]!r} is not "
                                    "a scaled value 'V [soft scale] (hard scale) value unit'")
    hard = float(match["hard"]) if match["hard"] else math.nan
    value = float(match["value"]) if match["value"] else math.nan
    return Scaled(soft=(match["soft"] or "").strip(), hard=hard,
                  hard_unit=(match["hard_unit"] or "").strip(), value=value,
                  unit=match["unit"].strip())


def _bare(key: str) -> str:
    """``@4:Z scale`` → ``Z scale``; ``@Sens. Zsens`` → ``Sens. Zsens``."""
    return re.sub(r"^@(\d+:)?", "", key)


@dataclass
class NanoscopeHeader:
    """The header as (section name, {key as written: value text}) pairs, in file order."""

    path: Path
    sections: list[tuple[str, dict[str, str]]]
    size: int  # bytes up to and including the end marker

    def all(self, name: str) -> list[dict[str, str]]:
        """Every section called ``name`` (``Ciao force image list`` …), in file order."""
        return [fields for section, fields in self.sections if section == name]

    def get(self, fields: dict[str, str], name: str) -> str | None:
        """The value of key ``name`` in ``fields``, matched without its ``@n:`` prefix."""
        for key, value in fields.items():
            if key == name or _bare(key) == name:
                return value
        return None

    def anywhere(self, name: str) -> str | None:
        """The first value of key ``name`` in any section."""
        for _, fields in self.sections:
            value = self.get(fields, name)
            if value is not None:
                return value
        return None

    def sensitivity(self, soft: str, what: str) -> tuple[float, str]:
        r"""Soft scale ``soft`` (``Sens. Zsens``) in metres per volt, and its text.

        A soft scale written without a unit (``\@Sens. DeflSens: V 27.39``) is in nm/V, as
        Nanoscope writes it and as pyfmreader reads it.
        """
        text = self.anywhere("@" + soft)
        if text is None:
            raise InstrumentFormatError(f"{self.path}: the {what} refers to the soft scale "
                                        f"'{soft}', which the header does not define")
        value = scaled(self.path, "@" + soft, text)
        per_metre = _PER_METRE.get(value.unit)
        if per_metre is None or not (math.isfinite(value.value) and value.value > 0):
            raise InstrumentFormatError(
                f"{self.path}: soft scale '{soft}' = {text.strip()!r} is not a positive length "
                f"per volt (units {', '.join(repr(u) for u in _PER_METRE if u)})")
        return value.value / per_metre, text.strip()


def read_header(path: Path, file_size: int) -> NanoscopeHeader:
    r"""Parse the text header, up to ``\*File list end`` (at most :data:`MAX_HEADER_BYTES`)."""
    try:
        with path.open("rb") as fh:
            head = fh.read(min(file_size, MAX_HEADER_BYTES))
    except OSError as exc:
        raise InstrumentFormatError(f"{path}: cannot read ({exc.strerror or exc})") from None
    end = head.find(_END.encode())
    if end < 0:
        raise InstrumentFormatError(
            f"{path}: the Nanoscope header has no '{_END}' line within its first "
            f"{len(head)} bytes: the file is truncated or not a Nanoscope file")
    stop = head.find(b"\n", end)
    size = len(head) if stop < 0 else stop + 1
    sections: list[tuple[str, dict[str, str]]] = []
    for raw in head[:end].decode("latin-1").replace("\r", "\n").split("\n"):
        line = raw.strip().removeprefix("\ufeff").removeprefix("ï»¿")
        if not line:
            continue
        if line.startswith("\\*"):
            sections.append((line[2:].strip(), {}))
            continue
        match = _LINE.match(line)
        if match is None or not sections:
            continue  # free text (a note's continuation line): not a field
        sections[-1][1].setdefault(match["key"].strip(), match["value"].strip())
    return NanoscopeHeader(path=path, sections=sections, size=size)
