"""Bounded access to the members of a JPK archive (the zip layer of :mod:`viscoforce.io.jpk`).

The member index parsed once from a zip's central directory (:class:`_MemberIndex`), the reader
that serves members through it with one seek and read each (:class:`_IndexedZip`, over a file or
over the bytes of a member archive, :class:`_BufferFile`), and the checks that refuse a member or
an archive whose declared size exceeds the limits of :mod:`viscoforce._limits` before anything is
decompressed. Also the reading of properties headers through those checks, and the places
(:class:`_Where`) that error messages name. See :mod:`viscoforce.io.jpk` for the behaviour.
"""

from __future__ import annotations

import io
import struct
import zipfile
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO

import numpy as np
from numpy.typing import NDArray

from viscoforce import _limits
from viscoforce._limits import check_effort
from viscoforce.exceptions import InstrumentFormatError
from viscoforce.io._properties import HeaderError, parse_properties, resolve_references

if TYPE_CHECKING:
    from viscoforce.io._jpk_headers import _SegmentPlan

#: signature, name length and extra-field length of a zip local file header (30 bytes)
_LOCAL_HEADER = struct.Struct("<4s22xHH")
_LOCAL_SIGNATURE = b"PK\x03\x04"
_ZIP_ERRORS = (zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error, EOFError, NotImplementedError)
#: compressed bytes zipfile reads (and decompresses whole) per step for bzip2 / LZMA members: its
#: bzip2 reader has no output limit, and 4 kB of bzip2 can expand to gigabytes (64 bytes: at most
#: two or three bzip2 blocks, < 150 MB)
_FALLBACK_READ = 64
_HINT = ("the size the zip's directory declares; a damaged or hostile archive, or raise "
         "viscoforce._limits.{}")


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


#: Parsed headers by their bytes (a map's reader meets each segment header about three times,
#: and a file read again meets all of them again); at most this many are kept.
_PARSED_LIMIT = 1024
_PARSED: dict[bytes, dict[str, str]] = {}


def _parse_props(data: bytes, where: _Where,
                 blocks: dict[str, dict[str, str]] | None = None) -> dict[str, str]:
    """Parse header text ``data`` (member ``where``), resolving references when ``blocks``.

    The parse of the same bytes is kept (:data:`_PARSED_LIMIT` headers); each call returns a
    dict of its own.
    """
    key = bytes(data)
    props = _PARSED.get(key)
    try:
        if props is None:
            props = parse_properties(key)
            if len(_PARSED) >= _PARSED_LIMIT:
                _PARSED.clear()
            _PARSED[key] = props
        return resolve_references(props, blocks) if blocks is not None else dict(props)
    except HeaderError as exc:
        raise where.error(str(exc)) from None


@contextmanager
def _located(where: _Where) -> Iterator[None]:
    """Turn a HeaderError raised inside the block into an InstrumentFormatError naming ``where``."""
    try:
        yield
    except HeaderError as exc:
        raise where.error(str(exc)) from None
