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
at most 64, about 3 MB for real headers, then it starts again): a header repeated from curve to
curve (a synthetic map's; real files differ by time stamp and position) is neither parsed nor
resolved again, and :attr:`JPKSegment.settings` is a fresh copy each time.

Bounded reading (hostile or damaged files): every member's decompressed size, as the zip's
central directory declares it, is checked before the member is read — a properties header
against :data:`~viscoforce._limits.MAX_HEADER_BYTES`, anything else against
:data:`~viscoforce._limits.MAX_MEMBER_BYTES`, the sum over the archive against
:data:`~viscoforce._limits.MAX_ARCHIVE_BYTES` (an :class:`~viscoforce.exceptions.EffortError`
with the size and the limit) — and decompression stops one byte past the declared size, so a
header that lies about it is refused (InstrumentFormatError) with at most that much in memory.
A member above 1 MiB is decompressed chunk by chunk into one buffer of its declared size, so it
costs its size once (a deflated JPK archive inside a zip of archives, which is held whole, took
three times its size); such a member archive is also refused up front when holding it would
exceed :data:`~viscoforce._limits.MAX_MEMORY_BYTES` (EffortError with the estimate). A segment
whose duration over num-points is below :data:`~viscoforce._limits.MIN_TIME_STEP` is refused.
A segment's ``num-points`` is checked against the declared size of each channel member before
any array is allocated, and the segment's float arrays against
:data:`~viscoforce._limits.MAX_MEMORY_BYTES`. Calibrations are refused when not finite (every
encoder and slot multiplier and offset, durations, drives, the baseline) or outside the
plausible ranges :data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` and
:data:`~viscoforce._limits.SENSITIVITY_RANGE`; a non-finite sample of a calibrated channel
(overflow, a NaN in float data) is refused naming the file, curve, segment and channel.
Reading all the curves of a file peaks at 1.0-1.5x the arrays it returns (tracemalloc on the
real files and on a synthetic 16x16 map of 410 MB); curve by curve, at the curve plus the plans
kept (1-3 MB on the real maps).
"""

from __future__ import annotations

import bisect
import io
import math
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

from viscoforce import _limits
from viscoforce._limits import MIN_TIME_STEP, check_effort
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
_PLAN_CACHE = 64
_ZIP_ERRORS = (zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error, EOFError, NotImplementedError)
#: compressed bytes zipfile reads (and decompresses whole) per step for bzip2 / LZMA members: its
#: bzip2 reader has no output limit, and 4 kB of bzip2 can expand to gigabytes (64 bytes: at most
#: two or three bzip2 blocks, < 150 MB)
_FALLBACK_READ = 64
_HINT = ("the size the zip's directory declares; a damaged or hostile archive, or raise "
         "viscoforce._limits.{}")


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

    @property
    def place(self) -> str:
        """``file: member`` (or the file)."""
        return f"{self.label}: {self.member}" if self.member else self.label

    def error(self, what: str) -> InstrumentFormatError:
        return InstrumentFormatError(f"{self.place}: {what}")


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


#: Members larger than this [bytes] are decompressed chunk by chunk into one buffer of their size.
_STREAM_ABOVE = 1 << 20
#: Compressed bytes read per step of a streamed member.
_CHUNK = 1 << 20


def _streamed(fp: BinaryIO, name: str, method: int, compressed: int, declared: int
              ) -> tuple[bytearray, bool]:
    """Read a stored or deflated member of ``compressed`` bytes at ``fp``'s position.

    Returns (its content in a bytearray of ``declared`` bytes, whether the deflate stream
    ended). At most one chunk of compressed input is held beside the output, and the output is
    never copied or grown: the member costs its declared size in memory.
    """
    out = bytearray(declared)
    if method == zipfile.ZIP_STORED:
        got = fp.readinto(out)
        if got != compressed:
            raise zipfile.BadZipFile(f"truncated data of {name!r}")
        return out, True
    view = memoryview(out)
    inflater = zlib.decompressobj(-zlib.MAX_WBITS)
    pos, remaining, pending = 0, compressed, b""
    while not inflater.eof:
        if not pending:
            if remaining == 0:
                break
            pending = fp.read(min(_CHUNK, remaining))
            if not pending:
                raise zipfile.BadZipFile(f"truncated data of {name!r}")
            remaining -= len(pending)
        piece = inflater.decompress(pending, declared + 1 - pos)  # one byte past: a lie shows
        pending = inflater.unconsumed_tail
        if pos + len(piece) > declared:
            raise zipfile.BadZipFile(f"{name!r} decompresses to more than the {declared} bytes "
                                     "the zip declares")
        view[pos:pos + len(piece)] = piece
        pos += len(piece)
    view.release()
    if pos != declared:
        del out[pos:]
    return out, inflater.eof


class _BufferFile(io.RawIOBase):
    """A read-only, seekable file over a bytes-like buffer, without copying it.

    ``io.BytesIO(bytearray)`` copies the buffer: for a JPK archive held inside a zip of
    archives that doubles the memory it takes.
    """

    def __init__(self, buffer: bytes | bytearray) -> None:
        super().__init__()
        self._view = memoryview(buffer).cast("B")
        self._pos = 0

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def readinto(self, target: bytearray | memoryview) -> int:  # type: ignore[override]
        n = max(0, min(len(target), len(self._view) - self._pos))
        target[:n] = self._view[self._pos:self._pos + n]
        self._pos += n
        return n

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        base = {io.SEEK_SET: 0, io.SEEK_CUR: self._pos, io.SEEK_END: len(self._view)}[whence]
        if base + offset < 0:
            raise ValueError(f"negative seek position {base + offset}")
        self._pos = base + offset
        return self._pos

    def tell(self) -> int:
        return self._pos

    def getbuffer(self) -> memoryview:
        """The whole buffer (as ``io.BytesIO.getbuffer``)."""
        return self._view


class _IndexedZip:
    """The members of one zip (a file, or the bytes of a member archive) through its index.

    One seek and read per member: ``zipfile.ZipFile.read`` costs about twice as much for the
    small members of a JPK map, and opening a ZipFile parses the whole central directory.
    Members that are not plain stored or deflated ones (encrypted, other compressions) are read
    by a ZipFile opened on first need. The file is opened on the first read. Not thread-safe:
    the archive's lock serialises use.
    """

    def __init__(self, source: Path | bytes | bytearray, index: _MemberIndex,
                 where: _Where) -> None:
        self.source, self.index, self.where = source, index, where
        self._fp: BinaryIO | None = None
        self._zip: zipfile.ZipFile | None = None
        #: segment header bytes -> its plan (headers repeat from curve to curve in a map)
        self.plans: dict[bytes, _SegmentPlan] = {}

    def namelist(self) -> list[str]:
        """The member names (each once)."""
        return list(self.index.rows)

    def size(self, name: str) -> int:
        """Decompressed size of member ``name`` as the central directory declares it; KeyError."""
        return int(self.index.size[self.index.rows[name]])

    def read(self, name: str) -> bytes | bytearray:
        """Content of member ``name``; KeyError if absent, zipfile.BadZipFile if damaged.

        Never more than the declared size (+ 1 byte to see a lie) is decompressed: callers check
        that size against the limits first (:func:`_read_member`). A member above
        :data:`_STREAM_ABOVE` comes as a ``bytearray`` of exactly its size, filled chunk by chunk
        (compressed input and output are never both held whole: a deflated member costs its
        size once, not three times); a smaller one as ``bytes``, in one step.
        """
        row = self.index.rows[name]
        method, flags = int(self.index.method[row]), int(self.index.flags[row])
        declared = int(self.index.size[row])
        if flags & 0x1 or method not in (zipfile.ZIP_STORED, zipfile.ZIP_DEFLATED):
            return self._read_through_zipfile(name, declared)
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
        # deflate expands incompressible data by < 0.1 % (12.5 % with fixed Huffman codes);
        # stored data are exactly the declared size
        bound = declared if method == zipfile.ZIP_STORED else declared + declared // 8 + 1024
        if compressed > bound:
            raise zipfile.BadZipFile(f"{name!r}: {compressed} compressed bytes declared for "
                                     f"{declared} decompressed ones, impossible")
        if declared > _STREAM_ABOVE:
            data, complete = _streamed(fp, name, method, compressed, declared)
        else:
            raw = fp.read(compressed)
            if len(raw) != compressed:
                raise zipfile.BadZipFile(f"truncated data of {name!r}")
            if method == zipfile.ZIP_DEFLATED:
                inflater = zlib.decompressobj(-zlib.MAX_WBITS)
                data = inflater.decompress(raw, declared + 1)   # output stops one byte past it
                del raw
                if len(data) > declared:
                    raise zipfile.BadZipFile(f"{name!r} decompresses to more than the {declared} "
                                             "bytes the zip declares")
                complete = inflater.eof
            else:
                data, complete = raw, True
        if not complete or len(data) != declared or zlib.crc32(data) != int(self.index.crc[row]):
            raise zipfile.BadZipFile(f"bad CRC-32 or size for {name!r} ({len(data)} bytes "
                                     f"decompressed, {declared} declared)")
        return data

    def _read_through_zipfile(self, name: str, declared: int) -> bytearray:
        """An encrypted, bzip2 or LZMA member, through zipfile, in small bounded steps."""
        out = bytearray()
        with self._zipfile().open(name) as handle:
            handle.MIN_READ_SIZE = _FALLBACK_READ  # each step decompresses this much input whole
            while piece := handle.read(_FALLBACK_READ):
                out += piece
                if len(out) > declared:  # zipfile stops at the declared size; in case it did not
                    raise zipfile.BadZipFile(f"{name!r} decompresses to more than the {declared} "
                                             "bytes the zip declares")
        return out

    def _file(self) -> BinaryIO:
        if self._fp is None:
            if not isinstance(self.source, Path):
                self._fp = _BufferFile(self.source)
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
            source = self.source if isinstance(self.source, Path) else _BufferFile(self.source)
            self._zip = _open_zip(source, self.where)
        return self._zip

    def close(self) -> None:
        for handle in (self._zip, self._fp):
            if handle is not None:
                handle.close()
        self._fp = self._zip = None

    def __del__(self) -> None:  # like zipfile.ZipFile: no file left open for the finaliser
        self.close()


#: What member reads go through (the scan's and the archive's readers alike).
_Members = _IndexedZip


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
            data = _read_archive_member(handles.outer, layout.member, where)
            with _open_zip(_BufferFile(data), layout.where) as zf:
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
    EffortError
        If a member or the whole archive would decompress to more than the limits of
        :mod:`viscoforce._limits` (checked on the sizes the zip declares, before reading).
    """
    path = Path(path)
    where = _Where(str(path))
    if not path.is_file():
        raise where.error("no such file")
    with _open_zip(path, where) as zf:
        index = _MemberIndex.of(zf)
    reader = _IndexedZip(path, index, where)
    try:
        if "header.properties" in index.rows:
            _check_archive(where, int(index.size.sum()))
            layouts = (_scan(reader, where, None),)
        else:
            layouts = _scan_zip(reader, where)
    finally:
        reader.close()
    if len(layouts) == 1 and layouts[0].member is None:
        kind, metadata = layouts[0].kind, layouts[0].header
        with _located(where.at("header.properties")):
            grid = _grid(metadata) if kind == "force-map" else None
    else:
        kind, metadata, grid = "zip", {}, None
    return JPKArchive(path=path, kind=kind, n_curves=sum(len(layout.curves) for layout in layouts),
                      grid=grid, metadata=metadata, _layouts=layouts, _index=index)


# ── archive access ──────────────────────────────────────────────────────────────────────────


def _open_zip(source: Path | _BufferFile, where: _Where) -> zipfile.ZipFile:
    """Open a zip read-only; a bad one raises InstrumentFormatError. The caller closes it."""
    try:
        return zipfile.ZipFile(source, mode="r")
    except (*_ZIP_ERRORS, ValueError) as exc:
        size = source.stat().st_size if isinstance(source, Path) else len(source.getbuffer())
        if size == 0:
            raise where.error("is empty (0 bytes); a JPK archive is a zip file — is it truncated "
                              "or corrupt?") from None
        first = _first_member(source)
        if first is None:
            raise where.error(f"is not a readable zip archive ({exc}); a JPK archive is a zip "
                              "file — is it truncated or corrupt?") from None
        raise where.error(
            f"is not a readable zip archive ({exc}): it starts as one (first member {first!r}) but "
            f"its central directory, the member list at the end of a zip, is missing or damaged: "
            f"the {size}-byte file is truncated or corrupt") from None


def _first_member(source: Path | _BufferFile) -> str | None:
    """Name in the first local header of a zip-like file, or None when it does not start as a zip."""
    try:
        if isinstance(source, Path):
            with open(source, "rb") as handle:
                head = handle.read(_LOCAL_HEADER.size + 256)
        else:
            head = bytes(source.getbuffer()[:_LOCAL_HEADER.size + 256])
    except OSError:
        return None
    if len(head) < _LOCAL_HEADER.size or head[:4] != _LOCAL_SIGNATURE:
        return None
    _, name_length, _ = _LOCAL_HEADER.unpack(head[:_LOCAL_HEADER.size])
    return head[_LOCAL_HEADER.size:_LOCAL_HEADER.size + name_length].decode("cp437")


def _read_member(zf: _Members, name: str, where: _Where, limit: str) -> bytes | bytearray:
    """Member ``name``, refused before reading when its declared size exceeds the named limit.

    ``limit`` is ``"MAX_HEADER_BYTES"`` or ``"MAX_MEMBER_BYTES"`` (of :mod:`viscoforce._limits`).
    """
    try:
        declared = zf.size(name)
    except KeyError:
        raise where.at(name).error("missing from the archive") from None
    check_effort(f"{where.at(name).place}: decompressing this member", declared,
                 getattr(_limits, limit), unit="bytes", hint=_HINT.format(limit))
    try:
        return zf.read(name)
    except RuntimeError as exc:  # zipfile: an encrypted member and no password
        raise where.at(name).error(f"cannot be read ({exc}); encrypted archives are not "
                                   "supported") from None
    except (*_ZIP_ERRORS, OSError) as exc:
        raise where.at(name).error(f"cannot be read ({exc}); the archive is truncated or corrupt") from None


def _read_archive_member(zf: _Members, name: str, where: _Where) -> bytes | bytearray:
    """A JPK archive inside a zip of archives, which is read into memory whole.

    Refused before anything is decompressed when its declared size exceeds MAX_MEMBER_BYTES,
    or when holding it (its size and one chunk of compressed input: nothing else is held while
    it is read, the previous member archive is released first) would exceed MAX_MEMORY_BYTES;
    the message gives the estimate.
    """
    try:
        declared = zf.size(name)
    except KeyError:
        raise where.at(name).error("missing from the archive") from None
    check_effort(f"{where.at(name).place}: holding this JPK archive in memory (a member of a zip "
                 "of archives is read whole)", declared + 2 * _CHUNK,
                 _limits.MAX_MEMORY_BYTES, unit="bytes",
                 hint="unzip the outer zip and read the archives one by one, or raise "
                      "viscoforce._limits.MAX_MEMORY_BYTES")
    return _read_member(zf, name, where, "MAX_MEMBER_BYTES")


def _check_archive(where: _Where, total: int) -> None:
    """Refuse an archive whose members decompress to more than MAX_ARCHIVE_BYTES in all."""
    check_effort(f"{where.place}: decompressing the archive's members", total,
                 _limits.MAX_ARCHIVE_BYTES, unit="bytes", hint=_HINT.format("MAX_ARCHIVE_BYTES"))


def _read_props(zf: _Members, name: str, where: _Where,
                blocks: dict[str, dict[str, str]] | None = None) -> dict[str, str]:
    """Parse header ``name``, resolving its shared-data references when ``blocks`` is given."""
    return _parse_props(_read_member(zf, name, where, "MAX_HEADER_BYTES"), where.at(name), blocks)


def _parse_props(data: bytes, where: _Where,
                 blocks: dict[str, dict[str, str]] | None = None) -> dict[str, str]:
    """Parse header text ``data`` (member ``where``), resolving references when ``blocks``."""
    try:
        props = parse_properties(data)
        return resolve_references(props, blocks) if blocks is not None else props
    except HeaderError as exc:
        raise where.error(str(exc)) from None


def _scan(zf: _Members, where: _Where, member: str | None) -> _Layout:
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


#: members of a JPK archive (without its header.properties, the sign of a damaged one)
_JPK_PARTS = re.compile(r"^(?:index/\d+/)?(?:segments/\d+/|shared-data/header\.properties$)")


def _scan_zip(zf: _Members, where: _Where) -> tuple[_Layout, ...]:
    names = zf.namelist()
    members = [n for n in names
               if n.lower().endswith(_JPK_SUFFIXES) and not n.startswith("__MACOSX/")]
    if not members:
        parts = [n for n in names if _JPK_PARTS.match(n)]
        if parts:
            raise where.at("header.properties").error(
                f"missing from the archive: it holds {len(parts)} of a JPK archive's members "
                f"({', '.join(parts[:3])}{', ...' if len(parts) > 3 else ''}) but not the header "
                "that says what it is (type, segment count); the archive is damaged or incomplete")
        raise where.error("neither a JPK archive (no header.properties) nor a zip of "
                          ".jpk-force / .jpk-force-map archives (no such member)")
    total = sum(zf.size(m) for m in members)
    _check_archive(where, total)
    layouts = []
    for member in members:
        inner_where = _Where(f"{where.label}!{member}")
        data = _read_archive_member(zf, member, where)
        with _open_zip(_BufferFile(data), inner_where) as inner_zip:
            index = _MemberIndex.of(inner_zip)
        if "header.properties" not in index.rows:
            raise inner_where.error("not a JPK archive (no header.properties)")
        total += int(index.size.sum())
        _check_archive(where, total)
        inner = _IndexedZip(data, index, inner_where)
        try:
            layouts.append(_scan(inner, inner_where, member))
        finally:
            inner.close()
        del data, inner  # one member archive in memory at a time, not the last one and this one
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
        for axis, value in zip("xy", (x, y), strict=True):
            if math.isinf(value):
                raise HeaderError(f"'{_POSITION}{axis}' = {value} is not finite")
    if count != len(numbers):
        raise where.error(f"{_COUNT}={count} but the archive holds {len(numbers)} segment(s): "
                          "truncated or incomplete archive")
    segments: list[JPKSegment] = []
    start = 0.0
    for s in numbers:
        segments.append(_read_segment(zf, layout, f"{curve_dir}segments/{s}/", s, start, only, index))
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


def _segment_plan(props: dict[str, str]) -> _SegmentPlan:
    """Plan of a resolved segment header; HeaderError naming the key when it is unusable."""
    n = number(props, _SEG + "num-points", int)
    duration = number(props, _SEG + "duration")
    if n < 0 or not duration >= 0:
        raise HeaderError(f"num-points={n}, duration={duration}: must be >= 0")
    if not math.isfinite(duration):
        raise HeaderError(f"'{_SEG}duration' = {duration} s is not finite")
    if n > 1 and 0 < duration / n < MIN_TIME_STEP:
        raise HeaderError(f"'{_SEG}duration' = {duration!r} s over num-points={n} gives a sample "
                          f"interval of {duration / n:g} s, below {MIN_TIME_STEP:g} s (no "
                          "instrument samples faster): a corrupt header")
    names = get(props, "channels.list").split()
    if "vDeflection" in names:
        _calibration_values(props)  # first: a bad spring constant is named as one
    channels = []
    for name in names:
        dtype, scaling = _encoding(props, name)
        pre = f"channel.{name}."
        outputs = []
        for out, slot, unit in _outputs(props, name):
            steps = tuple(conversion_steps(props, name, slot))
            _require_finite_steps(props, name, slot, steps)
            found = slot_unit(props, name, slot)
            if unit is not None and found != unit:
                raise HeaderError(f"channel '{name}' slot '{slot}' is in {found!r}, "
                                  f"expected {unit!r}")
            outputs.append((out, steps, found))
        channels.append(_ChannelPlan(name=name, dtype=dtype, file=get(props, pre + "data.file.name"),
                                     declared=props.get(pre + "data.num-points"), scaling=scaling,
                                     outputs=tuple(outputs)))
    if "vDeflection" in names:
        _calibration(props)  # the chain force <- distance <- base
    return _SegmentPlan(props=props, num_points=n, duration=duration,
                        style=get(props, _SEG + "settings.style"), type=get(props, _SETTINGS + "type"),
                        channels=tuple(channels), modulation=_modulation(props),
                        baseline=_baseline(props))


def _require_finite_steps(props: dict[str, str], name: str, slot: str,
                          steps: tuple[tuple[float, float], ...]) -> None:
    """Refuse a non-finite or zero multiplier, or a non-finite offset, on ``slot``'s chain."""
    if all(math.isfinite(m) and m != 0 and math.isfinite(o) for m, o in steps):
        return
    conv = f"channel.{name}.conversion-set."
    chain, current = [], slot  # the slots in the order conversion_steps returns their steps
    while current != props[conv + "conversions.base"]:
        chain.append(current)
        current = props[f"{conv}conversion.{current}.base-calibration-slot"]
    for current, (multiplier, offset) in zip(reversed(chain), steps, strict=True):
        key = f"{conv}conversion.{current}.scaling."
        _require_scaling(key, multiplier, offset)


def _require_scaling(key: str, multiplier: float, offset: float) -> None:
    """Refuse ``<key>multiplier`` when not finite or zero and ``<key>offset`` when not finite."""
    if not (math.isfinite(multiplier) and multiplier != 0):
        raise HeaderError(f"'{key}multiplier' = {multiplier!r} must be finite and non-zero")
    if not math.isfinite(offset):
        raise HeaderError(f"'{key}offset' = {offset!r} must be finite")


def _plan_of(zf: _Members, layout: _Layout, seg_dir: str) -> _SegmentPlan:
    """The plan of segment ``seg_dir``'s header (kept by the reader, see the module docstring)."""
    name = f"{seg_dir}segment-header.properties"
    data = bytes(_read_member(zf, name, layout.where, "MAX_HEADER_BYTES"))  # a key: hashable
    plans = zf.plans
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
                  start_time: float, only: frozenset[str] | None = None, curve: int = 0
                  ) -> JPKSegment:
    """Decode a segment: every channel, or the file channels named in ``only``.

    ``num-points`` is checked against each channel's declared member size, and the arrays it
    implies against MAX_MEMORY_BYTES, before anything is allocated or decompressed.
    """
    plan = _plan_of(zf, layout, seg_dir)
    n = plan.num_points
    wanted = [c for c in plan.channels if only is None or c.name in only]
    for channel in wanted:
        _check_declared(zf, channel, seg_dir, n, layout.where)
    arrays = 2 + sum(len(channel.outputs) for channel in wanted)  # + time and the raw base
    check_effort(f"{layout.where.at(seg_dir + 'segment-header.properties').place}: decoding "
                 f"segment {seg_index} (num-points={n}, {arrays} arrays of float64)",
                 8.0 * n * arrays, _limits.MAX_MEMORY_BYTES, unit="bytes",
                 hint="the segment is larger than one read may hold; raise "
                      "viscoforce._limits.MAX_MEMORY_BYTES")
    channels: dict[str, FloatArray] = {}
    units: dict[str, str] = {}
    with np.errstate(over="ignore", invalid="ignore"):  # non-finite results are refused below
        for channel in wanted:
            _decode_channel(zf, layout.where, channel, seg_dir, n, curve, seg_index, channels,
                            units)
    time = np.arange(n, dtype=np.float64)  # start + i * duration / n, made after the checks above
    time *= plan.duration / max(n, 1)
    time += start_time
    return JPKSegment(index=seg_index, style=plan.style, type=plan.type, start_time=start_time,
                      duration=plan.duration, num_points=n, channels=channels, units=units,
                      time=time, modulation=plan.modulation,
                      baseline=plan.baseline, settings=dict(plan.props))


def _decode_channel(zf: _Members, where: _Where, channel: _ChannelPlan, seg_dir: str, n: int,
                    curve: int, seg_index: int, channels: dict[str, FloatArray],
                    units: dict[str, str]) -> None:
    """Decode ``channel`` into ``channels`` / ``units``, one entry per output slot."""
    base = _decode_raw(zf, channel, seg_dir, n, where)
    aliased = False  # an output that is the base itself: later outputs must not scale it in place
    for k, (out, steps, unit) in enumerate(channel.outputs):
        if not steps:
            values, aliased = base, True
        else:  # as _properties.convert, step by step; in place where nothing else needs it
            multiplier, offset = steps[0]
            last = k == len(channel.outputs) - 1 and not aliased
            values = base if last else base * multiplier
            if last:
                values *= multiplier
            values += offset
            for multiplier, offset in steps[1:]:
                values *= multiplier
                values += offset
        if channel.name in _SI_SLOTS:
            _require_finite_samples(values, where.at(seg_dir + channel.file), curve,
                                    seg_index, out)
        channels[out] = values
        units[out] = unit


def _require_finite_samples(values: FloatArray, where: _Where, curve: int, segment: int,
                            channel: str) -> None:
    """Refuse NaN / inf samples of a calibrated channel, naming curve, segment and channel."""
    if np.isfinite(values).all():
        return
    bad = np.flatnonzero(~np.isfinite(values))
    raise where.error(
        f"curve {curve}, segment {segment}, channel '{channel}': {bad.size} of {values.size} "
        f"samples are not finite (first: sample {bad[0]} = {float(values[bad[0]])}); the raw data or "
        "the header's calibration (encoder and slot multipliers) is corrupt")


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
        scaling = (number(props, enc + "scaling.multiplier"), number(props, enc + "scaling.offset"))
        _require_scaling(enc + "scaling.", *scaling)
        return dtype, scaling
    data_type = props.get(pre + "type", props.get(pre + "data.type", ""))
    dtype = _UNENCODED.get(data_type)
    if dtype is None:
        raise HeaderError(f"channel '{name}': unknown encoder (no {enc}type, and data type "
                          f"{data_type!r} is not one of {', '.join(_UNENCODED)})")
    return dtype, None


def _check_declared(zf: _Members, channel: _ChannelPlan, seg_dir: str, n: int,
                    where: _Where) -> None:
    """Refuse a channel member whose declared size is not ``n`` samples, before reading it."""
    member = seg_dir + channel.file
    try:
        size = zf.size(member)
    except KeyError:
        raise where.at(member).error("missing from the archive") from None
    _require_samples(size, channel, n, where.at(member))


def _require_samples(size: int, channel: _ChannelPlan, n: int, where: _Where) -> None:
    """Refuse ``size`` bytes of ``channel`` when they are not ``n`` samples (or disagree)."""
    itemsize = np.dtype(channel.dtype).itemsize
    declared = channel.declared
    if size != n * itemsize or (declared is not None and declared.strip() != str(n)):
        raise where.error(
            f"holds {size} bytes = {size / itemsize:g} samples of {channel.dtype}, but the "
            f"segment header says num-points={n} (channel num-points={declared}), i.e. "
            f"{n * itemsize} bytes: truncated or inconsistent")


def _decode_raw(zf: _Members, channel: _ChannelPlan, seg_dir: str, n: int,
                where: _Where) -> FloatArray:
    """Samples of ``channel`` in its base slot (raw * encoder multiplier + offset)."""
    member = seg_dir + channel.file
    data = _read_member(zf, member, where, "MAX_MEMBER_BYTES")
    _require_samples(len(data), channel, n, where.at(member))
    values = np.frombuffer(data, dtype=channel.dtype).astype(np.float64)
    del data
    if channel.scaling is not None:
        multiplier, offset = channel.scaling
        values *= multiplier
        values += offset
    return values


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
    frequency = number(props, _SETTINGS + "frequency")
    amplitude = number(props, _SETTINGS + "amplitude")
    if not (math.isfinite(frequency) and frequency > 0):
        raise HeaderError(f"'{_SETTINGS}frequency' = {frequency!r} Hz must be finite and > 0")
    if not (math.isfinite(amplitude) and amplitude >= 0):
        raise HeaderError(f"'{_SETTINGS}amplitude' = {amplitude!r} m must be finite and >= 0")
    if phase is not None and not math.isfinite(phase):
        raise HeaderError(f"'{_SETTINGS}start-phase' = {phase!r} is not finite")
    return JPKModulation(frequency=frequency, amplitude=amplitude, start_phase=phase)


def _baseline(props: dict[str, str]) -> float | None:
    """``baseline.baseline`` [V] through the vDeflection chain to force [N]."""
    key = _SEG + "baseline.baseline"
    if (key not in props or props.get(_SEG + "baseline.measured") == "false"
            or "vDeflection" not in props.get("channels.list", "").split()):
        return None
    volts = number(props, key)
    force = float(convert(props, "vDeflection", "force", np.array([volts]))[0])
    if not math.isfinite(force):
        raise HeaderError(f"'{key}' = {volts!r} V gives a non-finite force ({force!r} N)")
    return force


def _calibration(props: dict[str, str]) -> tuple[float, float]:
    """Spring constant [N/m] and sensitivity [m/V] of a segment header with vDeflection.

    Each is refused (HeaderError naming the key, the value and the range) outside
    :data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` / :data:`~viscoforce._limits.SENSITIVITY_RANGE`.
    """
    conv = "channel.vDeflection.conversion-set."
    base = get(props, conv + "conversions.base")
    chain = (props.get(conv + "conversion.force.base-calibration-slot"),
             props.get(conv + "conversion.distance.base-calibration-slot"))
    if chain != ("distance", base):
        raise HeaderError(f"vDeflection slots force <- {chain[0]}, distance <- {chain[1]}: "
                          f"expected force <- distance <- {base}")
    values = _calibration_values(props)
    return values["force"], values["distance"]


def _calibration_values(props: dict[str, str]) -> dict[str, float]:
    """The vDeflection ``force`` and ``distance`` multipliers the header gives, each checked.

    HeaderError naming the key, the value and the plausible range when one is outside it.
    """
    values = {}
    for what, slot, unit, (low, high) in (
            ("spring constant", "force", "N/m", _limits.SPRING_CONSTANT_RANGE),
            ("deflection sensitivity", "distance", "m/V", _limits.SENSITIVITY_RANGE)):
        key = f"channel.vDeflection.conversion-set.conversion.{slot}.scaling.multiplier"
        if key not in props:
            continue  # the calibration chain says what is missing
        value = number(props, key)
        if not low <= value <= high:  # also refuses NaN
            raise HeaderError(f"{what} '{key}' = {value!r} {unit} is outside the plausible range "
                              f"[{low:g}, {high:g}] {unit}: a corrupt header")
        values[slot] = value
    return values


def _grid(header: dict[str, str]) -> JPKGrid | None:
    if _GRID + "ilength" not in header:
        return None
    if (unit := header.get(_GRID + "unit.unit", "m")) != "m":
        raise HeaderError(f"{_GRID}unit.unit={unit!r}, expected 'm'")
    lengths = {key: number(header, _GRID + key) for key in ("ulength", "vlength", "xcenter", "ycenter")}
    for key, value in lengths.items():
        if not math.isfinite(value):
            raise HeaderError(f"'{_GRID}{key}' = {value!r} m is not finite")
    return JPKGrid(ilength=number(header, _GRID + "ilength", int),
                   jlength=number(header, _GRID + "jlength", int), **lengths)
