"""Native reader of JPK ``.jpk-force`` / ``.jpk-force-map`` archives and of zips of them.

An archive is a zip of Java properties headers and big-endian raw channels: ``header.properties``,
``shared-data/header.properties`` (calibrations ``lcd-info.<L>.*`` and segment settings
``force-segment-header-info.<N>.*`` that segment headers refer to), and per segment
``[index/<n>/]segments/<s>/segment-header.properties`` plus ``channels/<channel>.dat``. Older
archives keep the calibration in the segment header (``channel.<ch>.data.encoder.*``); both work.

Decoding, in SI at this boundary: raw -> ``encoder.scaling`` -> base slot (V, or m for the height
sensors) -> each ``conversion-set`` slot up to the wanted one, following ``base-calibration-slot``.
Channels: ``vDeflection`` [m] (slot ``distance``), ``force`` [N] (slot ``force``), ``height`` [m]
(piezo, slot ``calibrated``), ``measuredHeight`` / ``strainGaugeHeight`` / ``capacitiveSensorHeight``
[m] (slot ``nominal``); any other channel in its default slot if defined, else its base slot, unit
in :attr:`JPKSegment.units`. Signs are the file's: height grows away from the sample, deflection
and force are positive for repulsion; nothing is baseline-corrected. The file is opened read-only
and never modified; curves are decoded one at a time, on request.

Access: :func:`read_jpk` parses the zip's central directory once (O(members), 1.7 s for a 64x64
map) into a compact member index kept in the :class:`JPKArchive` and pickled with it. The
archive reads members through that index and one read-only file handle, opened on the first
read and kept open for the next ones (one seek and read per member). After
:meth:`JPKArchive.close`, after unpickling (an archive may be sent to dask workers; the handle
is not pickled, the index is) and in a forked child, the next read reopens the file — without
parsing the directory again. Reads of one archive are serialised by a lock, so threads may share
it. The reader keeps, per segment-header text, its parsed and checked plan (the resolved
properties, the dtype, encoder and calibration steps of every channel, the drive, the baseline;
at most 256, then it starts again): a header repeated from curve to curve (a synthetic map's;
real files differ by time stamp and position) is neither parsed nor resolved again, and
:attr:`JPKSegment.settings` is a fresh copy each time.
"""

from __future__ import annotations

import bisect
import io
import operator
import os
import re
import struct
import threading
import zipfile
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import numpy as np
from numpy.typing import NDArray

from viscoforce._typing import FloatArray
from viscoforce.exceptions import InstrumentFormatError
from viscoforce.io._properties import (
    HeaderError,
    conversion_steps,
    convert,
    encoder_prefix,
    get,
    group_blocks,
    number,
    parse_properties,
    require_linear,
    resolve_references,
    slot_unit,
)

__all__ = ["InstrumentFormatError", "JPKArchive", "JPKCurve", "JPKGrid", "JPKModulation", "JPKSegment",
           "read_jpk"]


#: encoder.type -> big-endian numpy dtype of the raw samples
_ENCODERS = {"signedshort": ">i2", "unsignedshort": ">u2", "signedinteger": ">i4",
             "unsignedinteger": ">u4", "signedlong": ">i8", "float": ">f4", "double": ">f8"}
#: lcd-info type of channels stored without an encoder (already in the base unit)
_UNENCODED = {"float-data": ">f4", "double-data": ">f8"}
#: channel in the file -> (name in JPKSegment.channels, calibration slot, SI unit) it yields
_SI_SLOTS = {
    "vDeflection": (("vDeflection", "distance", "m"), ("force", "force", "N")),
    "height": (("height", "calibrated", "m"),),
    "measuredHeight": (("measuredHeight", "nominal", "m"),),
    "strainGaugeHeight": (("strainGaugeHeight", "nominal", "m"),),
    "capacitiveSensorHeight": (("capacitiveSensorHeight", "nominal", "m"),),
}
_KINDS = {"force-scan-series": "force", "force-scan-map": "force-map"}
_JPK_SUFFIXES = (".jpk-force", ".jpk-force-map")
_SHARED = "shared-data/header.properties"
_SEG = "force-segment-header."
_SETTINGS = "force-segment-header.settings.segment-settings."
_POSITION = "force-scan-series.header.position."
_COUNT = "force-scan-series.force-segments.count"
_GRID = "force-scan-map.position-pattern.grid."
#: [index/<n>/]header.properties and [index/<n>/]segments/<s>/segment-header.properties
_HEADER = re.compile(r"^((?:index/\d+/)?)(?:segments/(\d+)/segment-)?header\.properties$")
#: signature, name length and extra-field length of a zip local file header (30 bytes)
_LOCAL_HEADER = struct.Struct("<4s22xHH")
_LOCAL_SIGNATURE = b"PK\x03\x04"
#: segment plans an archive reader keeps at most (then it forgets them all and starts again)
_PLAN_CACHE = 256
_ZIP_ERRORS = (zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error, EOFError, NotImplementedError)


@dataclass(frozen=True)
class JPKGrid:
    """Position grid of a force map (``force-scan-map.position-pattern.grid.*``).

    Parameters
    ----------
    ilength, jlength : int
        Number of points along the fast (u) and slow (v) axes.
    ulength, vlength : float
        Side lengths of the scanned area [m].
    xcenter, ycenter : float
        Centre of the area in the scanner's frame [m].
    """

    ilength: int
    jlength: int
    ulength: float
    vlength: float
    xcenter: float
    ycenter: float


@dataclass(frozen=True)
class JPKModulation:
    """Nominal drive of a modulation segment (``settings.segment-settings.*``).

    Parameters
    ----------
    frequency : float
        Drive frequency [Hz].
    amplitude : float
        Nominal piezo drive amplitude [m]; the calibrated piezo and the height sensor move less.
    start_phase : float or None
        ``start-phase`` as the file gives it; the file states no unit (0.0 in every file seen).
        None when the file does not give it.
    """

    frequency: float
    amplitude: float
    start_phase: float | None


@dataclass(frozen=True, eq=False)
class JPKSegment:
    """One segment of a force curve, in SI.

    Parameters
    ----------
    index : int
        Segment number in the curve (0, 1, ...).
    style : str
        ``settings.style`` as the file says: ``extend``, ``retract``, ``pause``, ``modulation``.
    type : str
        ``settings.segment-settings.type``, e.g. ``z-extend-height``, ``constant-force-pause``,
        ``sine-z-modulation-segment-settings``; classify segments by this, not by position.
    start_time : float
        Sum of the earlier segments' durations [s].
    duration : float
        Actual duration ``force-segment-header.duration`` [s].
    num_points : int
        Actual number of samples ``force-segment-header.num-points``.
    channels : dict of str to ndarray
        SI samples (see the module docstring): ``force`` [N], ``vDeflection`` [m], ``height`` [m], ...
    units : dict of str to str
        Unit of each channel as the file names it (``N``, ``m``, or ``V`` for uncalibrated ones).
    time : ndarray
        ``start_time + i * duration / num_points`` [s].
    modulation : JPKModulation or None
        Drive of a modulation segment, else None.
    baseline : float or None
        ``baseline.baseline`` (free-cantilever deflection [V]) converted to force [N]; None when not
        measured or the segment has no vDeflection. Not subtracted from ``force``.
    settings : dict of str to str
        The segment header with its shared-data references resolved.
    """

    index: int
    style: str
    type: str
    start_time: float
    duration: float
    num_points: int
    channels: dict[str, FloatArray]
    units: dict[str, str]
    time: FloatArray
    modulation: JPKModulation | None
    baseline: float | None
    settings: dict[str, str] = field(repr=False)


@dataclass(frozen=True, eq=False)
class JPKCurve:
    """One force curve: its segments in time order and its cantilever calibration.

    Parameters
    ----------
    index : int
        Position of the curve in the archive (0 ... n_curves - 1).
    source : str
        Where it lives: ``""`` (a single curve), ``"index/<n>/"`` (a map), prefixed by
        ``"<member>!"`` inside a zip of archives.
    x, y : float
        Position ``force-scan-series.header.position.{x,y}`` [m]; NaN when the file gives none.
    segments : tuple of JPKSegment
        The segments, ``segments[k].index == k``.
    spring_constant : float
        Cantilever spring constant [N/m]: the vDeflection ``force`` slot multiplier.
    sensitivity : float
        Deflection sensitivity [m/V]: the vDeflection ``distance`` slot multiplier.
    metadata : dict of str to str
        The curve header (``index/<n>/header.properties`` in a map).
    """

    index: int
    source: str
    x: float
    y: float
    segments: tuple[JPKSegment, ...]
    spring_constant: float
    sensitivity: float
    metadata: dict[str, str] = field(repr=False)


@dataclass(frozen=True)
class _Where:
    """File (``label``) and archive member an error message names."""

    label: str
    member: str | None = None

    def at(self, member: str) -> _Where:
        return _Where(self.label, member)

    def error(self, what: str) -> InstrumentFormatError:
        place = f"{self.label}: {self.member}" if self.member else self.label
        return InstrumentFormatError(f"{place}: {what}")


@dataclass(frozen=True)
class _Layout:
    """The curves of one JPK archive (the file itself, or ``member`` of a zip of archives)."""

    where: _Where
    member: str | None
    kind: str
    header: dict[str, str]
    blocks: dict[str, dict[str, str]]
    curves: tuple[tuple[str, tuple[int, ...]], ...]  # (curve directory, segment numbers)


@dataclass(frozen=True, eq=False)
class _MemberIndex:
    """Where each member of a zip lives: its central directory, parsed once by :func:`read_jpk`.

    A dict name -> row and one array per field, about a quarter of the memory of zipfile's
    ``ZipInfo`` objects; it is pickled with the archive, so another process reads members
    without parsing the central directory again (O(members): 1.7 s for a 64x64 map).
    """

    rows: dict[str, int]
    offset: NDArray[np.int64]       # of the local file header
    compressed: NDArray[np.int64]   # compressed size [bytes]
    size: NDArray[np.int64]         # uncompressed size [bytes]
    crc: NDArray[np.uint32]
    method: NDArray[np.uint16]      # compression method
    flags: NDArray[np.uint16]       # general-purpose flag bits (bit 0: encrypted)

    @classmethod
    def of(cls, zf: zipfile.ZipFile) -> _MemberIndex:
        """The index of an open zip (a repeated name keeps its last entry, as zipfile does)."""
        infos = zf.infolist()

        def column(attr: str, dtype: type) -> np.ndarray:
            return np.fromiter((getattr(i, attr) for i in infos), dtype=dtype, count=len(infos))

        return cls(rows={info.filename: row for row, info in enumerate(infos)},
                   offset=column("header_offset", np.int64),
                   compressed=column("compress_size", np.int64),
                   size=column("file_size", np.int64), crc=column("CRC", np.uint32),
                   method=column("compress_type", np.uint16), flags=column("flag_bits", np.uint16))


class _IndexedZip:
    """The members of one zip (a file, or the bytes of a member archive) through its index.

    One seek and read per member: ``zipfile.ZipFile.read`` costs about twice as much for the
    small members of a JPK map, and opening a ZipFile parses the whole central directory.
    Members that are not plain stored or deflated ones (encrypted, other compressions) are read
    by a ZipFile opened on first need. The file is opened on the first read. Not thread-safe:
    the archive's lock serialises use.
    """

    def __init__(self, source: Path | bytes, index: _MemberIndex, where: _Where) -> None:
        self.source, self.index, self.where = source, index, where
        self._fp: BinaryIO | None = None
        self._zip: zipfile.ZipFile | None = None
        #: segment header bytes -> its plan (headers repeat from curve to curve in a map)
        self.plans: dict[bytes, _SegmentPlan] = {}

    def read(self, name: str) -> bytes:
        """Content of member ``name``; KeyError if absent, zipfile.BadZipFile if damaged."""
        row = self.index.rows[name]
        method, flags = int(self.index.method[row]), int(self.index.flags[row])
        if flags & 0x1 or method not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            return self._zipfile().read(name)
        fp = self._file()
        fp.seek(int(self.index.offset[row]))
        head = fp.read(_LOCAL_HEADER.size)
        if len(head) != _LOCAL_HEADER.size:
            raise zipfile.BadZipFile(f"truncated local header of {name!r}")
        signature, name_length, extra_length = _LOCAL_HEADER.unpack(head)
        if signature != _LOCAL_SIGNATURE:
            raise zipfile.BadZipFile(f"bad magic number for the local header of {name!r}")
        fp.seek(name_length + extra_length, io.SEEK_CUR)
        compressed = int(self.index.compressed[row])
        raw = fp.read(compressed)
        if len(raw) != compressed:
            raise zipfile.BadZipFile(f"truncated data of {name!r}")
        data = zlib.decompress(raw, -zlib.MAX_WBITS) if method == zipfile.ZIP_DEFLATED else raw
        if len(data) != int(self.index.size[row]) or zlib.crc32(data) != int(self.index.crc[row]):
            raise zipfile.BadZipFile(f"bad CRC-32 or size for {name!r}")
        return data

    def _file(self) -> BinaryIO:
        if self._fp is None:
            if isinstance(self.source, bytes):
                self._fp = io.BytesIO(self.source)
            elif not self.source.is_file():
                raise self.where.error("no such file (moved or deleted since read_jpk)")
            else:
                try:
                    self._fp = open(self.source, "rb")  # kept open; closed by close()
                except OSError as exc:
                    raise self.where.error(f"cannot be opened ({exc})") from None
        return self._fp

    def _zipfile(self) -> zipfile.ZipFile:
        if self._zip is None:
            source = io.BytesIO(self.source) if isinstance(self.source, bytes) else self.source
            self._zip = _open_zip(source, self.where)
        return self._zip

    def close(self) -> None:
        for handle in (self._zip, self._fp):
            if handle is not None:
                handle.close()
        self._fp = self._zip = None

    def __del__(self) -> None:  # like zipfile.ZipFile: no file left open for the finaliser
        self.close()


#: What member reads go through: the scan's ZipFile, or an archive's indexed reader.
_Members = zipfile.ZipFile | _IndexedZip


class _Handles:
    """The open member readers of one :class:`JPKArchive` (mutable; never pickled).

    ``outer`` reads the file itself; ``inner`` the last-used member archive of a zip of
    archives (member name, reader over its bytes), one at a time so that memory stays at one
    member. ``pid`` is the process that opened them: a forked child shares the file offset and
    must reopen.
    """

    def __init__(self) -> None:
        self.pid = os.getpid()
        self.outer: _IndexedZip | None = None
        self.inner: tuple[str, _IndexedZip] | None = None

    def close(self) -> None:
        for reader in (self.inner[1] if self.inner else None, self.outer):
            if reader is not None:
                reader.close()
        self.outer = self.inner = None


@dataclass(frozen=True, eq=False)
class JPKArchive:
    """A JPK archive opened by :func:`read_jpk`; curves are decoded on request.

    The archive holds the zip's member index and, from its first read on, one read-only file
    handle (see the module docstring): close it with :meth:`close` or use the archive as a
    context manager (``with read_jpk(path) as archive:``); a closed archive reopens the file on
    its next read. It pickles with the index and without the handle (each process opens its
    own); reads are serialised by a lock, so threads may share one archive.

    Parameters
    ----------
    path : Path
        The file.
    kind : str
        ``"force"`` (one curve), ``"force-map"``, or ``"zip"`` (a zip of such archives).
    n_curves : int
        Number of curves.
    grid : JPKGrid or None
        The map's grid (None for single curves, zips and non-grid maps).
    metadata : dict of str to str
        The top-level ``header.properties`` (empty for a zip of archives).
    """

    path: Path
    kind: str
    n_curves: int
    grid: JPKGrid | None
    metadata: dict[str, str] = field(repr=False)
    _layouts: tuple[_Layout, ...] = field(repr=False, default=())
    _index: _MemberIndex | None = field(repr=False, default=None)

    def __post_init__(self) -> None:
        self._reset()

    def _reset(self) -> None:
        """Fresh (unopened) handles and lock, and the first global index of each layout."""
        firsts, total = [], 0
        for layout in self._layouts:
            firsts.append(total)
            total += len(layout.curves)
        object.__setattr__(self, "_first", tuple(firsts))
        object.__setattr__(self, "_lock", threading.Lock())
        object.__setattr__(self, "_handles", _Handles())

    def __getstate__(self) -> dict[str, object]:
        state = dict(self.__dict__)
        for name in ("_first", "_lock", "_handles"):
            state.pop(name, None)
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._reset()

    def __enter__(self) -> JPKArchive:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        """Close the file handle (idempotent); a later read reopens the file."""
        with self._lock:
            self._handles.close()

    def curve(self, i: int) -> JPKCurve:
        """Decode curve ``i`` (0 <= i < n_curves; negative counts from the end).

        Parameters
        ----------
        i : int
            Curve index.

        Returns
        -------
        JPKCurve
            The decoded curve.

        Raises
        ------
        IndexError
            If ``i`` is out of range.
        InstrumentFormatError
            If the file cannot be reopened, or the curve's members are missing, corrupt or
            inconsistent.
        """
        return self._decode(*self._locate(i))

    def curves(self) -> Iterator[JPKCurve]:
        """Decode the curves one after the other.

        Yields
        ------
        JPKCurve
            Curve 0, 1, ... n_curves - 1.
        """
        for owner, layout in enumerate(self._layouts):
            for local in range(len(layout.curves)):
                yield self._decode(owner, local, self._first[owner] + local)

    def _decode(self, owner: int, local: int, index: int,
                only: frozenset[str] | None = None) -> JPKCurve:
        """Curve ``local`` of layout ``owner`` (global ``index``), under the lock."""
        layout = self._layouts[owner]
        with self._lock:
            return _read_curve(self._zip_of(layout), layout, local, index, only)

    def _locate(self, i: int) -> tuple[int, int, int]:
        """(layout, index in it, global index) of curve ``i``; IndexError when out of range."""
        i = operator.index(i)
        if not -self.n_curves <= i < self.n_curves:
            raise IndexError(f"curve index {i} out of range for {self.n_curves} curves in {self.path}")
        i %= self.n_curves
        owner = bisect.bisect_right(self._first, i) - 1
        return owner, i - self._first[owner], i

    def _curve_only(self, i: int, channels: frozenset[str]) -> JPKCurve:
        """:meth:`curve` decoding only the file channels ``channels`` (for the curves dataset)."""
        return self._decode(*self._locate(i), channels)

    def _units(self, i: int) -> list[dict[str, str]]:
        """Per segment of curve ``i``, the unit of every output channel, from the headers only."""
        owner, local, _ = self._locate(i)
        layout = self._layouts[owner]
        curve_dir, numbers = layout.curves[local]
        with self._lock:
            zf = self._zip_of(layout)
            plans = [_plan_of(zf, layout, f"{curve_dir}segments/{s}/") for s in numbers]
        return [{out: unit for channel in plan.channels for out, _, unit in channel.outputs}
                for plan in plans]

    def _zip_of(self, layout: _Layout) -> _IndexedZip:
        """The reader of ``layout``'s members (opened on demand; call under the lock)."""
        handles = self._handles
        if handles.pid != os.getpid():  # forked: the inherited descriptor shares its offset
            handles.outer = handles.inner = None
            handles.pid = os.getpid()
        where = _Where(str(self.path))
        if handles.outer is None:
            index = self._index
            if index is None:  # built by hand, not by read_jpk: parse the directory here
                with _open_zip(self.path, where) as zf:
                    index = _MemberIndex.of(zf)
            handles.outer = _IndexedZip(self.path, index, where)
        if layout.member is None:
            return handles.outer
        if handles.inner is None or handles.inner[0] != layout.member:
            if handles.inner is not None:
                handles.inner[1].close()
                handles.inner = None
            data = _read_member(handles.outer, layout.member, where)
            with _open_zip(io.BytesIO(data), layout.where) as zf:
                handles.inner = (layout.member, _IndexedZip(data, _MemberIndex.of(zf), layout.where))
        return handles.inner[1]


def read_jpk(path: str | Path) -> JPKArchive:
    """Open a ``.jpk-force`` / ``.jpk-force-map`` archive, or a zip of them, read-only.

    Only the headers and the member list are read here (the central directory becomes the
    archive's member index); :meth:`JPKArchive.curve` decodes a curve. The archive opens the
    file on its first read and keeps it open (``with read_jpk(path) as archive:`` or
    :meth:`JPKArchive.close` closes it).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    JPKArchive
        Kind, number of curves, grid and top-level header.

    Raises
    ------
    InstrumentFormatError
        If the file is missing, empty, truncated or corrupt, is not a JPK force archive, or is a
        zip without a JPK member; the message names the file, the member and what is wrong.
    """
    path = Path(path)
    where = _Where(str(path))
    if not path.is_file():
        raise where.error("no such file")
    with _open_zip(path, where) as zf:
        if "header.properties" in zf.namelist():
            layouts = (_scan(zf, where, None),)
        else:
            layouts = _scan_zip(zf, where)
        index = _MemberIndex.of(zf)
    if len(layouts) == 1 and layouts[0].member is None:
        kind, metadata = layouts[0].kind, layouts[0].header
        with _located(where.at("header.properties")):
            grid = _grid(metadata) if kind == "force-map" else None
    else:
        kind, metadata, grid = "zip", {}, None
    return JPKArchive(path=path, kind=kind, n_curves=sum(len(layout.curves) for layout in layouts),
                      grid=grid, metadata=metadata, _layouts=layouts, _index=index)


# ── archive access ──────────────────────────────────────────────────────────────────────────


def _open_zip(source: Path | io.BytesIO, where: _Where) -> zipfile.ZipFile:
    """Open a zip read-only; a bad one raises InstrumentFormatError. The caller closes it."""
    try:
        return zipfile.ZipFile(source, mode="r")
    except (*_ZIP_ERRORS, ValueError) as exc:
        size = source.stat().st_size if isinstance(source, Path) else len(source.getbuffer())
        what = "is empty (0 bytes)" if size == 0 else f"is not a readable zip archive ({exc})"
        raise where.error(f"{what}; a JPK archive is a zip file — is it truncated or corrupt?") from None


def _read_member(zf: _Members, name: str, where: _Where) -> bytes:
    try:
        return zf.read(name)
    except KeyError:
        raise where.at(name).error("missing from the archive") from None
    except (*_ZIP_ERRORS, OSError) as exc:
        raise where.at(name).error(f"cannot be read ({exc}); the archive is truncated or corrupt") from None


def _read_props(zf: _Members, name: str, where: _Where,
                blocks: dict[str, dict[str, str]] | None = None) -> dict[str, str]:
    """Parse header ``name``, resolving its shared-data references when ``blocks`` is given."""
    return _parse_props(_read_member(zf, name, where), where.at(name), blocks)


def _parse_props(data: bytes, where: _Where,
                 blocks: dict[str, dict[str, str]] | None = None) -> dict[str, str]:
    """Parse header text ``data`` (member ``where``), resolving references when ``blocks``."""
    try:
        props = parse_properties(data)
        return resolve_references(props, blocks) if blocks is not None else props
    except HeaderError as exc:
        raise where.error(str(exc)) from None


def _scan(zf: zipfile.ZipFile, where: _Where, member: str | None) -> _Layout:
    """Kind, headers and curve/segment directories of one archive (nothing is decoded)."""
    header = _read_props(zf, "header.properties", where)
    kind = _KINDS.get(header.get("type", ""))
    if kind is None:
        raise where.at("header.properties").error(
            f"type={header.get('type')!r} is not a JPK force curve or force map "
            f"(expected one of {', '.join(_KINDS)})")
    names = zf.namelist()
    blocks = group_blocks(_read_props(zf, _SHARED, where)) if _SHARED in names else {}
    segments: dict[str, set[int]] = {}
    for found in filter(None, map(_HEADER.match, names)):
        segments.setdefault(found.group(1), set()).update(
            () if found.group(2) is None else (int(found.group(2)),))
    dirs = [""] if kind == "force" else sorted(filter(None, segments), key=lambda d: int(d[6:-1]))
    if not dirs:
        raise where.error("the force map holds no curve (no index/<n>/header.properties)")
    curves = tuple((d, _contiguous(segments.get(d, set()), where.at(d + "segments/"))) for d in dirs)
    return _Layout(where=where, member=member, kind=kind, header=header, blocks=blocks, curves=curves)


def _contiguous(numbers: set[int], where: _Where) -> tuple[int, ...]:
    ordered = tuple(sorted(numbers))
    if ordered != tuple(range(len(ordered))) or not ordered:
        missing = sorted(set(range(max(ordered, default=0) + 1)) - numbers)
        raise where.error(f"segment(s) {missing} missing (found {list(ordered)})")
    return ordered


def _scan_zip(zf: zipfile.ZipFile, where: _Where) -> tuple[_Layout, ...]:
    members = [n for n in zf.namelist()
               if n.lower().endswith(_JPK_SUFFIXES) and not n.startswith("__MACOSX/")]
    if not members:
        raise where.error("neither a JPK archive (no header.properties) nor a zip of "
                          ".jpk-force / .jpk-force-map archives (no such member)")
    layouts = []
    for member in members:
        inner_where = _Where(f"{where.label}!{member}")
        with _open_zip(io.BytesIO(_read_member(zf, member, where)), inner_where) as inner:
            if "header.properties" not in inner.namelist():
                raise inner_where.error("not a JPK archive (no header.properties)")
            layouts.append(_scan(inner, inner_where, member))
    return tuple(layouts)


# ── curves and segments ─────────────────────────────────────────────────────────────────────


@contextmanager
def _located(where: _Where) -> Iterator[None]:
    """Turn a HeaderError raised inside the block into an InstrumentFormatError naming ``where``."""
    try:
        yield
    except HeaderError as exc:
        raise where.error(str(exc)) from None


def _read_curve(zf: _Members, layout: _Layout, local: int, index: int,
                only: frozenset[str] | None = None) -> JPKCurve:
    curve_dir, numbers = layout.curves[local]
    header = (layout.header if not curve_dir
              else _read_props(zf, f"{curve_dir}header.properties", layout.where, layout.blocks))
    with _located(where := layout.where.at(f"{curve_dir}header.properties")):
        count = number(header, _COUNT, int, default=str(len(numbers)))
        x, y = (number(header, _POSITION + axis, default="nan") for axis in "xy")
    if count != len(numbers):
        raise where.error(f"{_COUNT}={count} but the archive holds {len(numbers)} segment(s): "
                          "truncated or incomplete archive")
    segments: list[JPKSegment] = []
    start = 0.0
    for s in numbers:
        segments.append(_read_segment(zf, layout, f"{curve_dir}segments/{s}/", s, start, only))
        start += segments[-1].duration
    with_deflection = [seg for seg in segments if "vDeflection" in seg.channels]
    if not with_deflection:
        raise layout.where.at(curve_dir or "segments/").error(
            "no segment has a vDeflection channel: spring constant and sensitivity unknown")
    first = with_deflection[0]
    with _located(layout.where.at(f"{curve_dir}segments/{first.index}/segment-header.properties")):
        spring_constant, sensitivity = _calibration(first.settings)
    return JPKCurve(index=index, source=f"{layout.member}!{curve_dir}" if layout.member else curve_dir,
                    x=x, y=y, segments=tuple(segments), spring_constant=spring_constant,
                    sensitivity=sensitivity, metadata=header)


@dataclass(frozen=True)
class _ChannelPlan:
    """How to decode one channel of a segment: everything its header fixes."""

    name: str
    dtype: str                                     # big-endian numpy dtype of the raw samples
    file: str                                      # data file relative to the segment directory
    declared: str | None                           # channel num-points as the header gives it
    scaling: tuple[float, float] | None            # encoder (multiplier, offset); None: unencoded
    outputs: tuple[tuple[str, tuple[tuple[float, float], ...], str], ...]  # (out, steps, unit)


@dataclass(frozen=True, eq=False)
class _SegmentPlan:
    """The parsed, resolved and checked header of a segment: all but its samples and start."""

    props: dict[str, str]
    num_points: int
    duration: float
    style: str
    type: str
    channels: tuple[_ChannelPlan, ...]
    modulation: JPKModulation | None
    baseline: float | None
    offsets: FloatArray                            # i * duration / num_points [s]


def _segment_plan(props: dict[str, str]) -> _SegmentPlan:
    """Plan of a resolved segment header; HeaderError naming the key when it is unusable."""
    n = number(props, _SEG + "num-points", int)
    duration = number(props, _SEG + "duration")
    if n < 0 or not duration >= 0:
        raise HeaderError(f"num-points={n}, duration={duration}: must be >= 0")
    channels = []
    for name in get(props, "channels.list").split():
        dtype, scaling = _encoding(props, name)
        pre = f"channel.{name}."
        outputs = []
        for out, slot, unit in _outputs(props, name):
            steps = tuple(conversion_steps(props, name, slot))
            found = slot_unit(props, name, slot)
            if unit is not None and found != unit:
                raise HeaderError(f"channel '{name}' slot '{slot}' is in {found!r}, "
                                  f"expected {unit!r}")
            outputs.append((out, steps, found))
        channels.append(_ChannelPlan(name=name, dtype=dtype, file=get(props, pre + "data.file.name"),
                                     declared=props.get(pre + "data.num-points"), scaling=scaling,
                                     outputs=tuple(outputs)))
    return _SegmentPlan(props=props, num_points=n, duration=duration,
                        style=get(props, _SEG + "settings.style"), type=get(props, _SETTINGS + "type"),
                        channels=tuple(channels), modulation=_modulation(props),
                        baseline=_baseline(props),
                        offsets=np.arange(n) * (duration / max(n, 1)))


def _plan_of(zf: _Members, layout: _Layout, seg_dir: str) -> _SegmentPlan:
    """The plan of segment ``seg_dir``'s header (kept by the reader, see the module docstring)."""
    name = f"{seg_dir}segment-header.properties"
    data = _read_member(zf, name, layout.where)
    plans = zf.plans if isinstance(zf, _IndexedZip) else {}
    plan = plans.get(data)
    if plan is None:
        props = _parse_props(data, layout.where.at(name), layout.blocks)
        with _located(layout.where.at(name)):
            plan = _segment_plan(props)
        if len(plans) >= _PLAN_CACHE:
            plans.clear()
        plans[data] = plan
    return plan


def _read_segment(zf: _Members, layout: _Layout, seg_dir: str, seg_index: int,
                  start_time: float, only: frozenset[str] | None = None) -> JPKSegment:
    """Decode a segment: every channel, or the file channels named in ``only``."""
    plan = _plan_of(zf, layout, seg_dir)
    n = plan.num_points
    channels: dict[str, FloatArray] = {}
    units: dict[str, str] = {}
    for channel in plan.channels:
        if only is not None and channel.name not in only:
            continue
        base = _decode_raw(zf, channel, seg_dir, n, layout.where)
        for out, steps, unit in channel.outputs:
            values = base
            for multiplier, offset in steps:  # as _properties.convert, step by step
                values = values * multiplier + offset
            channels[out] = values
            units[out] = unit
    return JPKSegment(index=seg_index, style=plan.style, type=plan.type, start_time=start_time,
                      duration=plan.duration, num_points=n, channels=channels, units=units,
                      time=start_time + plan.offsets, modulation=plan.modulation,
                      baseline=plan.baseline, settings=dict(plan.props))


def _encoding(props: dict[str, str], name: str) -> tuple[str, tuple[float, float] | None]:
    """Raw dtype and encoder (multiplier, offset) of channel ``name`` (None: unencoded)."""
    pre, enc = f"channel.{name}.", encoder_prefix(props, name)
    fmt = props.get(pre + "data.file.format", "raw")
    if fmt != "raw":
        raise HeaderError(f"channel '{name}': data file format '{fmt}' is not supported (only 'raw')")
    if enc + "type" in props:
        dtype = _ENCODERS.get(props[enc + "type"])
        if dtype is None:
            raise HeaderError(f"{enc}type={props[enc + 'type']!r} is an unknown encoder "
                              f"(known: {', '.join(_ENCODERS)})")
        require_linear(props, enc + "scaling.")
        return dtype, (number(props, enc + "scaling.multiplier"),
                       number(props, enc + "scaling.offset"))
    data_type = props.get(pre + "type", props.get(pre + "data.type", ""))
    dtype = _UNENCODED.get(data_type)
    if dtype is None:
        raise HeaderError(f"channel '{name}': unknown encoder (no {enc}type, and data type "
                          f"{data_type!r} is not one of {', '.join(_UNENCODED)})")
    return dtype, None


def _decode_raw(zf: _Members, channel: _ChannelPlan, seg_dir: str, n: int,
                where: _Where) -> FloatArray:
    """Samples of ``channel`` in its base slot (raw * encoder multiplier + offset)."""
    member = seg_dir + channel.file
    data = _read_member(zf, member, where)
    size = np.dtype(channel.dtype).itemsize
    declared = channel.declared
    if len(data) != n * size or (declared is not None and declared.strip() != str(n)):
        raise where.at(member).error(
            f"holds {len(data)} bytes = {len(data) / size:g} samples of {channel.dtype}, but the "
            f"segment header says num-points={n} (channel num-points={declared}): truncated or "
            "inconsistent")
    values = np.frombuffer(data, dtype=channel.dtype).astype(np.float64)
    if channel.scaling is None:
        return values
    multiplier, offset = channel.scaling
    return values * multiplier + offset


def _outputs(props: dict[str, str], name: str) -> tuple[tuple[str, str, str | None], ...]:
    """(output name, calibration slot, required unit or None) for channel ``name``."""
    if name in _SI_SLOTS:
        return _SI_SLOTS[name]
    conv = f"channel.{name}.conversion-set."
    base = get(props, conv + "conversions.base")
    default = props.get(conv + "conversions.default", base)
    defined = props.get(f"{conv}conversion.{default}.defined") == "true"
    return ((name, default if defined else base, None),)


def _modulation(props: dict[str, str]) -> JPKModulation | None:
    if _SETTINGS + "frequency" not in props:
        seg_type = props.get(_SETTINGS + "type", "")
        if "modulation" in seg_type or props.get(_SEG + "settings.style") == "modulation":
            raise HeaderError(f"modulation segment ({seg_type}) without {_SETTINGS}frequency")
        return None
    phase = None if _SETTINGS + "start-phase" not in props else number(props, _SETTINGS + "start-phase")
    return JPKModulation(frequency=number(props, _SETTINGS + "frequency"),
                         amplitude=number(props, _SETTINGS + "amplitude"), start_phase=phase)


def _baseline(props: dict[str, str]) -> float | None:
    """``baseline.baseline`` [V] through the vDeflection chain to force [N]."""
    key = _SEG + "baseline.baseline"
    if (key not in props or props.get(_SEG + "baseline.measured") == "false"
            or "vDeflection" not in props.get("channels.list", "").split()):
        return None
    return float(convert(props, "vDeflection", "force", np.array([number(props, key)]))[0])


def _calibration(props: dict[str, str]) -> tuple[float, float]:
    """Spring constant [N/m] and sensitivity [m/V] of a segment header with vDeflection."""
    conv = "channel.vDeflection.conversion-set."
    base = get(props, conv + "conversions.base")
    chain = (props.get(conv + "conversion.force.base-calibration-slot"),
             props.get(conv + "conversion.distance.base-calibration-slot"))
    if chain != ("distance", base):
        raise HeaderError(f"vDeflection slots force <- {chain[0]}, distance <- {chain[1]}: "
                          f"expected force <- distance <- {base}")
    return (number(props, conv + "conversion.force.scaling.multiplier"),
            number(props, conv + "conversion.distance.scaling.multiplier"))


def _grid(header: dict[str, str]) -> JPKGrid | None:
    if _GRID + "ilength" not in header:
        return None
    if (unit := header.get(_GRID + "unit.unit", "m")) != "m":
        raise HeaderError(f"{_GRID}unit.unit={unit!r}, expected 'm'")
    lengths = {key: number(header, _GRID + key) for key in ("ulength", "vlength", "xcenter", "ycenter")}
    return JPKGrid(ilength=number(header, _GRID + "ilength", int),
                   jlength=number(header, _GRID + "jlength", int), **lengths)
