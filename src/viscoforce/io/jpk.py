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

Positions: a map's curves are placed on its grid (:meth:`JPKArchive.positions`, from every curve
header, once): :attr:`JPKCurve.row` / :attr:`JPKCurve.column` and x, y snapped to their grid
line (the file's values, which jitter by ~1e-12 m, in ``x_raw``, ``y_raw``).

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

Code: the zip layer (member index, bounded member reads, header reading) is in
:mod:`viscoforce.io._jpk_archive`, the checked reading of headers into segment plans, drives and
grids in :mod:`viscoforce.io._jpk_headers`, the decoding of segments and channels in
:mod:`viscoforce.io._jpk_segments`; this module scans archives and zips of archives and builds
the curves.
"""

from __future__ import annotations

import bisect
import dataclasses
import math
import operator
import os
import re
import threading
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from viscoforce.exceptions import InstrumentFormatError

# The layers below this module; every name they took from it is re-exported here, so
# ``viscoforce.io.jpk.<name>`` works as before. The callers of ``_open_zip`` and
# ``_read_segment`` that the tests patch through this module live in it.
from viscoforce.io._jpk_archive import (  # noqa: F401 (re-exported)
    _CHUNK,
    _FALLBACK_READ,
    _HINT,
    _LOCAL_HEADER,
    _LOCAL_SIGNATURE,
    _STREAM_ABOVE,
    _ZIP_ERRORS,
    _BufferFile,
    _check_archive,
    _first_member,
    _IndexedZip,
    _Layout,
    _located,
    _MemberIndex,
    _Members,
    _open_zip,
    _parse_props,
    _read_archive_member,
    _read_member,
    _read_props,
    _streamed,
    _Where,
)
from viscoforce.io._jpk_headers import (  # noqa: F401 (re-exported)
    _ENCODERS,
    _GRID,
    _SEG,
    _SETTINGS,
    _SI_SLOTS,
    _UNENCODED,
    JPKGrid,
    JPKModulation,
    _baseline,
    _calibration,
    _calibration_values,
    _ChannelPlan,
    _encoding,
    _grid,
    _modulation,
    _outputs,
    _require_finite_steps,
    _require_scaling,
    _segment_plan,
    _SegmentPlan,
)
from viscoforce.io._jpk_segments import (  # noqa: F401 (re-exported)
    _PLAN_CACHE,
    JPKSegment,
    _check_declared,
    _decode_channel,
    _decode_raw,
    _plan_of,
    _read_segment,
    _require_finite_samples,
    _require_samples,
)
from viscoforce.io._properties import HeaderError, group_blocks, number
from viscoforce.io.map_grid import MapGrid, map_grid

__all__ = ["InstrumentFormatError", "JPKArchive", "JPKCurve", "JPKGrid", "JPKModulation", "JPKSegment",
           "MapGrid", "read_jpk"]


_KINDS = {"force-scan-series": "force", "force-scan-map": "force-map"}
_JPK_SUFFIXES = (".jpk-force", ".jpk-force-map")
_SHARED = "shared-data/header.properties"
_POSITION = "force-scan-series.header.position."
_COUNT = "force-scan-series.force-segments.count"
#: [index/<n>/]header.properties and [index/<n>/]segments/<s>/segment-header.properties
_HEADER = re.compile(r"^((?:index/\d+/)?)(?:segments/(\d+)/segment-)?header\.properties$")


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
        Position [m]: ``force-scan-series.header.position.{x,y}`` snapped to the archive's grid
        (:meth:`JPKArchive.positions`: the median of the curve's grid line, so that every curve
        of a row has the same y); NaN when the file gives none.
    segments : tuple of JPKSegment
        The segments, ``segments[k].index == k``.
    spring_constant : float
        Cantilever spring constant [N/m]: the vDeflection ``force`` slot multiplier.
    sensitivity : float
        Deflection sensitivity [m/V]: the vDeflection ``distance`` slot multiplier.
    metadata : dict of str to str
        The curve header (``index/<n>/header.properties`` in a map).
    x_raw, y_raw : float
        The position as the file gives it [m] (it jitters by ~1e-12 m along a grid line).
    row, column : int
        Grid row (along y, 0 at the smallest y) and column (along x) of the curve among all
        the archive's curves; -1 without a position.
    """

    index: int
    source: str
    x: float
    y: float
    segments: tuple[JPKSegment, ...]
    spring_constant: float
    sensitivity: float
    metadata: dict[str, str] = field(repr=False)
    x_raw: float = math.nan
    y_raw: float = math.nan
    row: int = -1
    column: int = -1


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
        object.__setattr__(self, "_grid_found", None)
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
        self.__dict__.setdefault("_grid_found", None)
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

    def positions(self) -> MapGrid:
        """Grid rows, columns and snapped positions of every curve of the archive.

        Read once from the curve headers (0.35 s for a 64x64 map), then kept (and pickled with
        the archive); the grid is that of all the curves, whichever are decoded, so a chunk of
        curves gets the rows, columns and positions the whole file gives them. The file's grid
        (:attr:`grid`) gives the step; see :func:`viscoforce.io.map_grid.map_grid`. A curve
        whose header cannot be read counts as one without a position here (its decoding says
        what is wrong).

        Returns
        -------
        MapGrid
            Indexed by the curve index.
        """
        found = self._grid_found
        if found is None:
            with self._lock:
                found = self._grid_found
                if found is None:
                    found = self._find_grid()
                    object.__setattr__(self, "_grid_found", found)
        return found

    def _find_grid(self) -> MapGrid:
        """:meth:`positions` (call under the lock)."""
        xs, ys = [], []
        for layout in self._layouts:
            for curve_dir, _ in layout.curves:
                try:
                    header = (_read_props(self._zip_of(layout), f"{curve_dir}header.properties",
                                          layout.where) if curve_dir else layout.header)
                    place = [number(header, _POSITION + axis, default="nan") for axis in "xy"]
                except (InstrumentFormatError, HeaderError):
                    place = [math.nan, math.nan]
                xs.append(place[0])
                ys.append(place[1])
        xs = [v if math.isfinite(v) else math.nan for v in xs]
        ys = [v if math.isfinite(v) else math.nan for v in ys]
        g = self.grid
        if g is None or g.ilength < 1 or g.jlength < 1:
            return map_grid(xs, ys)
        return map_grid(xs, ys, steps=(g.ulength / g.ilength, g.vlength / g.jlength),
                        shape=(g.ilength, g.jlength), centre=(g.xcenter, g.ycenter),
                        theta=g.theta)

    def _decode(self, owner: int, local: int, index: int,
                only: frozenset[str] | None = None) -> JPKCurve:
        """Curve ``local`` of layout ``owner`` (global ``index``), under the lock, placed."""
        layout = self._layouts[owner]
        grid = self.positions()
        with self._lock:
            curve = _read_curve(self._zip_of(layout), layout, local, index, only)
        row, column = int(grid.row[index]), int(grid.column[index])
        placed = row >= 0 and grid.x_raw[index] == curve.x and grid.y_raw[index] == curve.y
        return dataclasses.replace(
            curve, x_raw=curve.x, y_raw=curve.y, row=row if placed else -1,
            column=column if placed else -1, x=float(grid.x[index]) if placed else curve.x,
            y=float(grid.y[index]) if placed else curve.y)

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


# ── scanning archives ─────────────────────────────────────────────────────────────────────────


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
