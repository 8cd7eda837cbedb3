"""Instrument formats as recipes in a registry: detect by content, read to SI, validate.

:data:`FORMATS` holds one :class:`InstrumentFormat` per format, in detection order (specific
binary formats first, generic text tables last):

================  ========  =============================================================
name              kind      what
================  ========  =============================================================
``jpk``           curves    JPK ``.jpk-force`` / ``.jpk-force-map`` archives and zips of
                            them (:func:`viscoforce.io.jpk.read_jpk` +
                            :func:`viscoforce.io.curves.jpk_to_curves`); options
                            ``curves``, ``height_channel``
``csv-curves``    curves    time-series CSV/TSV with ``name (unit)`` headers
                            (:func:`viscoforce.io.csv_formats.read_curves_csv`); options
                            ``spring_constant``, ``sensitivity``
``csv-spectrum``  spectrum  spectrum CSV/TSV
                            (:func:`viscoforce.io.csv_formats.read_spectrum_csv`); option
                            ``drive_amplitude``
``afmformats``    curves    Asylum ``.ibw``, AFM Workshop, Chiaro, NT-MDT
                            (:func:`viscoforce.io.afm.read_afmformats`)
``uff``           curves    UFF text force curve ``.uff``, e.g. a Bruker Nanoscope curve
                            (:func:`viscoforce.io.bruker.read_uff`); options
                            ``spring_constant``, ``sensitivity``
``nanoscope``     curves    Bruker Nanoscope binary force curve ``.spm``
                            (:func:`viscoforce.io.bruker.read_nanoscope`); options
                            ``spring_constant``, ``sensitivity``
================  ========  =============================================================

:func:`load_instrument` detects the format by CONTENT (zip members, header line), never by the
extension alone, reads the file read-only, validates the result against the schema and records
``attrs["source"]`` (the format name) and ``attrs["file"]``. Every error names the file. A file
no format recognises is refused with the closest format and its first failure, e.g. "a JPK
archive (first member 'header.properties') that is truncated or damaged", "a JPK archive without
header.properties", "UTF-16 text (a table with the header ...): save it as UTF-8", "looks like a
CSV spectrum (header ...) but it has no phase column 'phase (deg)'"; the list of format names
follows only when the guess is weak (prose, binary content, a zip of other files).

Adding a format (e.g. an ``afmformats``-based entry for Asylum ``.ibw``, AFM Workshop, Optics11
Chiaro, NT-MDT text):

1. Write ``_detect_<name>(path) -> bool``: look at the content (magic bytes, zip members, the
   header line); it must never raise for a file of another format (return False) and must read
   only what it needs.
2. Write ``_read_<name>(path, **options) -> xr.Dataset`` returning a schema dataset in SI
   (``make_curves(..., source=<name>)`` or ``make_spectrum(..., source=<name>)``), the
   instrument's metadata in ``attrs``. Import optional third-party readers (afmformats) inside
   the function, so that viscoforce works without them, and raise
   :class:`~viscoforce.exceptions.InstrumentFormatError` naming the file when they are missing.
3. Add ``InstrumentFormat(name=..., description=..., extensions=(...), detect=..., read=...,
   kind="curves" | "spectrum" | "either", options=(...))`` to :data:`FORMATS`, before the generic
   CSV entries if its files could also look like a CSV table (AFM Workshop ``.csv`` is one: its
   header is not ``name (unit)``, so the CSV entries do not claim it).
"""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import xarray as xr

from viscoforce.exceptions import (
    InstrumentFormatError,
    ParameterError,
    SchemaError,
    UnitError,
    ViscoforceError,
)
from viscoforce.io.afm import AFMFORMATS_EXTENSIONS, detect_afmformats, read_afmformats
from viscoforce.io.bruker import detect_nanoscope, detect_uff, read_nanoscope, read_uff
from viscoforce.io.csv_formats import (
    encoding_problem,
    header_names,
    header_problem,
    read_curves_csv,
    read_spectrum_csv,
)
from viscoforce.io.curves import jpk_to_curves
from viscoforce.io.jpk import read_jpk
from viscoforce.io.quality import check_measured
from viscoforce.schema import validate_curves, validate_spectrum

__all__ = ["FORMATS", "InstrumentFormat", "detect_format", "get_format", "load_instrument"]

FormatKind = Literal["curves", "spectrum", "either"]
_SNIFF_BYTES = 65536
_JPK_SUFFIXES = (".jpk-force", ".jpk-force-map")


@dataclass(frozen=True)
class InstrumentFormat:
    """One instrument file format: how to recognise it and how to read it.

    Parameters
    ----------
    name : str
        Short name (``--format NAME``), also ``attrs["source"]`` of what it reads.
    description : str
        One line for humans.
    extensions : tuple of str
        Usual file name endings (lower case, with the dot); informative only, detection is by
        content.
    detect : callable
        ``detect(path) -> bool``: True if the file's content is of this format (never raises).
    read : callable
        ``read(path, **options) -> xarray.Dataset`` in SI, valid under the schema of ``kind``.
    kind : {"curves", "spectrum", "either"}
        What ``read`` returns ("either": depends on the file).
    options : tuple of str
        Keyword options ``read`` accepts (others raise TypeError in :func:`load_instrument`).
    """

    name: str
    description: str
    extensions: tuple[str, ...]
    detect: Callable[[Path], bool] = field(repr=False)
    read: Callable[..., xr.Dataset] = field(repr=False)
    kind: FormatKind
    options: tuple[str, ...] = ()


# ── detection helpers ───────────────────────────────────────────────────────────────────────


def _head(path: Path) -> bytes:
    try:
        with path.open("rb") as fh:
            return fh.read(_SNIFF_BYTES)
    except OSError:
        return b""


def _text_head(path: Path) -> str | None:
    data = _head(path)
    if not data or b"\x00" in data or data[:2] == b"PK":
        return None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        if exc.start >= len(data) - 4:  # a multi-byte character cut by the sniff window
            return data[:exc.start].decode("utf-8-sig")
        try:
            return data.decode("latin-1")
        except UnicodeDecodeError:  # pragma: no cover
            return None


def _detect_jpk(path: Path) -> bool:
    if _head(path)[:4] != b"PK\x03\x04":
        return False
    try:
        with zipfile.ZipFile(path, mode="r") as zf:
            names = zf.namelist()
    except (zipfile.BadZipFile, OSError, ValueError, EOFError):
        return False
    return "header.properties" in names or any(
        n.lower().endswith(_JPK_SUFFIXES) and not n.startswith("__MACOSX/") for n in names)


def _detect_csv_curves(path: Path) -> bool:
    text = _text_head(path)
    names = header_names(text) if text else set()
    return ("time" in names and bool(names & {"force", "deflection"})
            and bool(names & {"height", "position", "z"}))


def _detect_csv_spectrum(path: Path) -> bool:
    text = _text_head(path)
    names = header_names(text) if text else set()
    return bool(names & {"frequency", "omega"}) and "phase" in names


def _read_jpk(path: Path, *, curves: Any = None, height_channel: str | None = None
              ) -> xr.Dataset:
    return jpk_to_curves(read_jpk(path), curves=curves, height_channel=height_channel)


def _read_csv_curves(path: Path, **options: Any) -> xr.Dataset:
    return read_curves_csv(path, source="csv-curves", **options)


def _read_csv_spectrum(path: Path, **options: Any) -> xr.Dataset:
    return read_spectrum_csv(path, source="csv-spectrum", **options)


#: The registry, in detection order (see the module docstring to add an entry).
FORMATS: tuple[InstrumentFormat, ...] = (
    InstrumentFormat(
        name="jpk", description="JPK force curve / force map archive, or a zip of them",
        extensions=(".jpk-force", ".jpk-force-map", ".zip"), detect=_detect_jpk, read=_read_jpk,
        kind="curves", options=("curves", "height_channel")),
    InstrumentFormat(
        name="csv-curves",
        description="time-series CSV/TSV with 'name (unit)' headers (time, force or deflection, "
                    "height)",
        extensions=(".csv", ".tsv", ".txt"), detect=_detect_csv_curves, read=_read_csv_curves,
        kind="curves", options=("spring_constant", "sensitivity")),
    InstrumentFormat(
        name="csv-spectrum",
        description="spectrum CSV/TSV with 'name (unit)' headers (frequency or omega, a "
                    "magnitude, phase)",
        extensions=(".csv", ".tsv", ".txt"), detect=_detect_csv_spectrum,
        read=_read_csv_spectrum, kind="spectrum", options=("drive_amplitude",)),
    InstrumentFormat(
        name="afmformats",
        description="the vendor formats afmformats reads: Asylum .ibw, AFM Workshop .csv, "
                    "Optics11 Chiaro .txt (also zipped), NT-MDT .txt (give spring_constant and "
                    "sensitivity)",
        extensions=AFMFORMATS_EXTENSIONS, detect=detect_afmformats, read=read_afmformats,
        kind="curves", options=("spring_constant", "sensitivity")),
    InstrumentFormat(
        name="uff", description="UFF text force curve (e.g. a Bruker Nanoscope curve as text)",
        extensions=(".uff",), detect=detect_uff, read=read_uff, kind="curves",
        options=("spring_constant", "sensitivity")),
    InstrumentFormat(
        name="nanoscope",
        description="Bruker Nanoscope binary force curve (one ramp; force volumes refused)",
        extensions=(".spm",), detect=detect_nanoscope, read=read_nanoscope, kind="curves",
        options=("spring_constant", "sensitivity")),
)


def _known() -> str:
    """The short last line of a detection failure (the full list is in the module docstring)."""
    names = [f"{f.name} ({f.extensions[0]})" if f.name == "jpk" else f.name for f in FORMATS]
    return f"known formats: {', '.join(names)}"


#: Diagnoses sure of the format (the list of known formats would add nothing to them).
_SURE = ("looks like ", "a JPK archive", "UTF-16 text (a table", "a header '")


_HDF5_MAGIC = (b"\x89HDF\r\n\x1a\n", b"CDF\x01", b"CDF\x02")
#: Members only a JPK archive has (its curves, its shared headers, a map's index).
_JPK_PARTS = ("segments/", "shared-data/", "index/")


def _jpk_member(name: str) -> bool:
    return name.startswith(_JPK_PARTS) or "/segments/" in name or name.endswith(
        "segment-header.properties")


def _first_member(head: bytes) -> str | None:
    """Name of the first member from a zip's first local header (readable in a truncated zip)."""
    if head[:4] != b"PK\x03\x04" or len(head) < 30:
        return None
    size = int.from_bytes(head[26:28], "little")
    name = head[30:30 + size]
    return name.decode("utf-8", errors="replace") if name and len(name) == size else None


def _short(name: str, width: int = 40) -> str:
    return name if len(name) <= width else "…" + name[-(width - 1):]


def _zip_problem(path: Path, head: bytes) -> str:
    try:
        with zipfile.ZipFile(path, mode="r") as zf:
            names = zf.namelist()
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as exc:
        first = _first_member(head)
        what = "a JPK archive" if first and (_jpk_member(first) or first.endswith(
            ("header.properties", *_JPK_SUFFIXES))) else "a zip archive"
        seen = f" (first member '{_short(first)}')" if first else ""
        return f"{what}{seen} that is truncated or damaged ({exc}); copy it again"
    real = [n for n in names if not n.startswith("__MACOSX/") and not n.endswith("/")]
    if not real:
        return "an empty zip archive"
    jpk = sorted((n for n in real if _jpk_member(n)), key=lambda n: "segments/" not in n)
    if jpk and "header.properties" not in names:
        return (f"a JPK archive without header.properties ({len(real)} members, e.g. "
                f"'{_short(jpk[0])}'): incomplete; export it again")
    listing = ", ".join(f"'{_short(n, 30)}'" for n in real[:3])
    more = f" and {len(real) - 3} more" if len(real) > 3 else ""
    return (f"a zip archive without .jpk-force members or files afmformats reads (members: "
            f"{listing}{more})")


def _closest(path: Path) -> str:
    """The closest format of a file no format recognises, and its first failure (short)."""
    head = _head(path)
    if head[:2] == b"PK":
        return _zip_problem(path, head)
    if head.startswith(_HDF5_MAGIC):
        return "a netCDF/HDF5 file (fit and bode read the netCDF files viscoforce writes as *.nc)"
    problem = encoding_problem(head)
    if problem and problem.startswith("binary"):
        return (f"binary content (first bytes {head[:8].hex(' ')}), neither a text table nor a "
                "zip archive")
    if problem:
        return problem
    text = _text_head(path)
    return header_problem(text) if text is not None else "unreadable text"


def get_format(name: str | InstrumentFormat) -> InstrumentFormat:
    """The registered format called ``name`` (an :class:`InstrumentFormat` is returned as is).

    Raises
    ------
    ParameterError
        If no format has that name (the message lists the names).
    """
    if isinstance(name, InstrumentFormat):
        return name
    for fmt in FORMATS:
        if fmt.name == name:
            return fmt
    raise ParameterError(f"unknown format {name!r}; known formats: "
                         f"{', '.join(f.name for f in FORMATS)}")


def _require_file(path: str | Path) -> Path:
    if not isinstance(path, str | Path):
        raise ParameterError(f"path must be a str or Path, got {type(path).__name__}")
    path = Path(path)
    if path.is_dir():
        raise InstrumentFormatError(f"{path} is a directory, not an instrument file")
    if not path.is_file():
        raise InstrumentFormatError(f"{path}: no such file")
    if path.stat().st_size == 0:
        raise InstrumentFormatError(f"{path}: the file is empty")
    return path


def detect_format(path: str | Path) -> InstrumentFormat:
    """The first format of :data:`FORMATS` whose ``detect`` recognises the file's content.

    Raises
    ------
    InstrumentFormatError
        If the file is missing or empty, or no format recognises it: the message names the
        closest format and its first failure (a truncated zip, a JPK archive without
        header.properties, UTF-16 text, a header cell without a unit, a missing column...), then
        the known format names, in under 300 characters besides the path.
    """
    path = _require_file(path)
    for fmt in FORMATS:
        if fmt.detect(path):
            return fmt
    closest = _closest(path)
    tail = "" if closest.startswith(_SURE) else f"; {_known()}"
    raise InstrumentFormatError(f"{path}: not a known instrument format: {closest}{tail}")


def _named(exc: ViscoforceError, path: Path) -> ViscoforceError:
    if str(path) in str(exc):
        return exc
    return type(exc)(f"{path}: {exc}")


def load_instrument(path: str | Path, *, format: str | InstrumentFormat | None = None,
                    **options: Any) -> xr.Dataset:
    """Read an instrument file into a schema dataset (curves or spectrum), SI units.

    Parameters
    ----------
    path : str or Path
        The file; opened read-only, never modified.
    format : str or InstrumentFormat, optional
        One of the names in :data:`FORMATS`; default: detected from the content.
    **options
        The format's options (``InstrumentFormat.options``), e.g. ``spring_constant="0.1N/m"``
        for ``csv-curves``, ``drive_amplitude="1nm"`` for ``csv-spectrum``, ``curves=[0, 2]``
        for ``jpk``.

    Returns
    -------
    xarray.Dataset
        Valid under :func:`~viscoforce.schema.validate_curves` or
        :func:`~viscoforce.schema.validate_spectrum`; ``attrs["source"]`` is the format name,
        ``attrs["file"]`` the path.

    Raises
    ------
    TypeError
        An option the format does not take.
    InstrumentFormatError, ParameterError, UnitError, SchemaError
        Unreadable or malformed file, bad option values, a measured value beyond its physical
        range or scale (:func:`viscoforce.io.quality.check_measured`); the message names the
        file.
    """
    path = _require_file(path)
    try:
        fmt = detect_format(path) if format is None else get_format(format)
    except ParameterError as exc:
        raise _named(exc, path) from exc
    unknown = sorted(set(options) - set(fmt.options))
    if unknown:
        raise TypeError(f"{path}: format {fmt.name!r} takes no option(s) {', '.join(unknown)}; "
                        f"it takes {', '.join(fmt.options) or 'none'}")
    try:
        ds = fmt.read(path, **options)
        if fmt.kind == "curves" or (fmt.kind == "either" and "sample" in ds.dims):
            ds = validate_curves(ds)
        else:
            ds = validate_spectrum(ds)
        check_measured(ds, str(path))  # the same physical ranges whichever reader made it
    except (InstrumentFormatError, ParameterError, UnitError, SchemaError) as exc:
        raise _named(exc, path) from exc
    ds.attrs["source"] = fmt.name
    ds.attrs["file"] = str(path)
    return ds
