"""Bruker Nanoscope force curves: the binary ``.spm`` and its UFF text export, read alike.

Nanoscope binary (``.spm``, read by :func:`read_nanoscope`)
-----------------------------------------------------------
Read by viscoforce's own small reader (a header parser and :func:`numpy.frombuffer`:
:mod:`viscoforce.io._bruker_nanoscope`, :mod:`viscoforce.io._bruker_spm`), after evaluating the
maintained readers (``docs/bruker-spm.md``): AFMReader is LGPL-3.0 and reads images only;
Bruker's ``nanoscope`` is a Windows-only binary (Python <= 3.11.4); SciFiReaders (MIT) returns
unscaled integers and trusts ``Bytes/pixel``, which Nanoscope 9.2 force files misstate; pyfmreader
(MIT) scales correctly but subtracts a baseline and drops points while reading and has had no
release since July 2023. Its scaling chain (the Nanoscope manual's, pyfmreader's) is followed:
see :mod:`viscoforce.io._bruker_spm`. The binary is turned into the same in-memory curve as its
UFF export (segments of rows: Z displacement from the turnaround [m], deflection [V]; spring
constant, sensitivity, velocities), which then goes through the same assembly below, so that a
``.spm`` and its ``.uff`` give the same dataset (variables, segments, units, calibration attrs),
``attrs["source"]`` ``"nanoscope"``, the header's fields that describe the curve as
``meta_nanoscope_<key>`` and the scaling as ``attrs["nanoscope_scaling"]``. The file records no
tip (its ``Tip Radius`` / ``Tip Half Angle`` are PeakForce QNM settings): no tip attrs. Single
ramp curves only; a force volume is refused (the pixel order of its curves is not settled).

UFF text (``.uff``, "Universal Force File", read by :func:`read_uff`)
--------------------------------------------------------------------
A plain-text, self-describing form of one force curve: ``HE key: value`` header lines (units in
the keys, e.g. ``Cantilever_springK_used(N/m)``), and per segment ``Recording_segment_<i>_*``
fields (type, code, number of points, column titles and units, velocity) followed by its data
lines ``<code> <segment number> <column 0> <column 1> …``; ``****`` ends the file. What goes where
(SI; the file is opened read-only):

* ``height`` [m]: the length column (``Displacement``, ``Height`` or ``Z``) as recorded, read as
  growing away from the sample: for a Nanoscope curve it is the Z piezo displacement from the
  turnaround (the most extended piezo, 0) — Nanoscope's force-plot axis, and viscoforce's (and
  JPK's) height convention — so ``tip_position`` = −height − deflection.
* ``deflection`` [m]: the ``Deflection`` column in volts × the inverse optical lever
  sensitivity ``Recording_inv_optical_lever_sens_used(m/V)`` (or a length, as given);
  ``force`` [N] = ``Cantilever_springK_used(N/m)`` × deflection, no baseline subtracted.
  ``spring_constant`` / ``sensitivity`` recalibrate. Other columns are listed in
  ``attrs["ignored_columns"]``.
* Time order: Nanoscope lists each segment's rows from the turnaround outward (its plot order),
  so each segment's rows are put in the order of the motion its type implies — an approach
  moves toward the sample (height decreasing), a retract away from it — and
  ``attrs["time_channel"]`` says which were reversed. The file records no time: ``time`` [s] is
  derived from the ramp, sample interval = mean height step / the segment's ``velocity(m/s)``,
  segment after segment. (``sampling_rate(Hz)`` is not used: in Nanoscope-made files it is the
  ramp rate, velocity / (2 × z_displacement), not a sample rate.) A segment whose times cannot
  be derived so (a pause, a non-monotonic height, no velocity) is refused.
* Segment columns written as ``?`` (no title, no unit) take the columns of the previous segment
  with the same number of columns (``attrs["column_note"]`` says so).
* ``segment``: the file's ``Recording_segment_<i>_type`` (``Approach`` → approach, ``Retract``
  → retract, …), the label kept in ``segment_type``.
* ``attrs``: every header field as ``meta_<key>`` (lower case, non-alphanumerics → ``_``), as
  the file gives it (UFF writes -1 or ``?`` for "not recorded"); the tip as
  :meth:`viscoforce.physics.tips.Tip.as_attrs` writes it (``tip_shape``, ``tip_half_angle``
  [degree] for a cone or pyramid, ``tip_radius`` [m] for a sphere, paraboloid or flat punch) when
  ``Tip_geometry`` names a shape and its size is plausible (a radius in (0, 1 mm)); otherwise
  ``attrs["tip_note"]`` says what was not used and why.

Only single-curve UFF files (``Entry_tot_nb_curve`` = 1) are read.

Plausible values (as the JPK and afmformats readers): a header's spring constant or sensitivity,
or one given by the caller, outside :data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` /
:data:`~viscoforce._limits.SENSITIVITY_RANGE` is refused (the header's as corrupt, naming the
field); so is a height, deflection or force beyond
:data:`~viscoforce.io.quality.PHYSICAL_RANGES` or below its smallest scale
(:data:`~viscoforce.io.quality.SMALLEST_SCALES`: a curve scaled by 1e-300), a velocity that
gives a sample interval below :data:`~viscoforce._limits.MIN_TIME_STEP`, and a position beyond a
metre. A tip is recorded only within :data:`~viscoforce._limits.TIP_RADIUS_RANGE` (and 1 mm) or
:data:`~viscoforce._limits.TIP_HALF_ANGLE_RANGE`.

Bounded reading: the file (at most :data:`MAX_UFF_BYTES`) is read once; the header is found
without visiting the data lines, which are then parsed in file order, each checked as it comes,
and a segment with more lines than its ``nb_point`` is refused at the first one too many.
"""

from __future__ import annotations

import math
from array import array
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from viscoforce._limits import check_effort
from viscoforce._validation import require_path
from viscoforce.exceptions import InstrumentFormatError, ParameterError, UnitError
from viscoforce.io._bruker_nanoscope import _head, detect_nanoscope
from viscoforce.io._bruker_spm import K_FIELD, S_FIELD, nanoscope_curve
from viscoforce.io._bruker_uff_checks import (  # noqa: F401 (re-exported)
    _K_FIELDS,
    _MAX_TIP_RADIUS,
    _RANGES,
    _S_FIELDS,
    _TIP_WORDS,
    _calibration,
    _measured,
    _meta,
    _meta_key,
    _option,
    _tip_attrs,
)
from viscoforce.io._bruker_uff_header import (  # noqa: F401 (re-exported)
    _END,
    _UNKNOWN,
    _Column,
    _field,
    _float_field,
    _int_field,
    _line_number,
    _lines,
    _parse_header,
    _Segment,
    _Uff,
    _whole_lines,
)
from viscoforce.io.csv_formats import segment_label
from viscoforce.io.quality import (
    MIN_TIME_STEP,
    PHYSICAL_RANGES,
    below_scale,
    first_beyond,
    range_text,
    scale_text,
)
from viscoforce.schema import make_curves
from viscoforce.units import unit_factor

__all__ = ["detect_nanoscope", "detect_uff", "read_nanoscope", "read_uff"]

_VOLTS = ("v", "volt", "volts")
_CLI_HINT = "pass {name} (CLI: {flag})"


# ── UFF text ───────────────────────────────────────────────────────────────────────────────────


def detect_uff(path: str | Path) -> bool:
    """True if ``path`` is a UFF text file: ``HE `` header lines naming ``UFF_code`` / ``Entry_UFF_version``.

    Never raises (an unreadable or binary file gives False).
    """
    head = _head(Path(path))
    if not head or b"\x00" in head:
        return False
    text = head.decode("latin-1").removeprefix("\xef\xbb\xbf")
    first = next((ln.strip() for ln in text.splitlines() if ln.strip()), "")
    return first.startswith("HE ") and ("HE UFF_code:" in text or "HE Entry_UFF_version:" in text)


#: Largest UFF text file read [bytes] (a force curve of 1e6 samples is ~ 40 MB).
MAX_UFF_BYTES = 256 * 1024**2


def _read_text(path: Path) -> str:
    try:
        size = path.stat().st_size
        if size > MAX_UFF_BYTES:
            check_effort(f"{path}: reading this UFF text file ({size} bytes)", size,
                         MAX_UFF_BYTES, unit="bytes",
                         hint="a UFF export holds one force curve; split the file")
        data = path.read_bytes()
    except OSError as exc:
        raise InstrumentFormatError(f"{path}: cannot read ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    del data
    if "\n" not in text and "\r" in text:  # classic Mac OS line ends
        text = text.replace("\r", "\n")
    return text


def _parse(path: Path) -> _Uff:
    """The header, then the data lines in file order, each checked as it is read.

    A segment with more data lines than its ``nb_point`` is refused at the first line too many,
    before the rest of the file is parsed (a 200 MB file of a 1024-point curve took 30 s and
    3 GB to be refused when every line was parsed first).
    """
    fields, text = _parse_header(path, _read_text(path))
    n_curves = _int_field(path, fields, "Entry_tot_nb_curve", 1)
    if n_curves != 1:
        raise InstrumentFormatError(f"{path}: the UFF file holds {n_curves} curves "
                                    "(Entry_tot_nb_curve); this reader reads single-curve files")
    segments: list[_Segment] = []
    for i in range(_int_field(path, fields, "Recording_number_segment", 1)):
        pre = f"Recording_segment_{i}_"
        n_cols = _int_field(path, fields, pre + "nb_col", 1)
        columns = [_Column(_field(path, fields, f"{pre}col_{j}_title"),
                           _field(path, fields, f"{pre}col_{j}_unit")) for j in range(n_cols)]
        segments.append(_Segment(index=i, code=_field(path, fields, pre + "code"),
                                 kind=_field(path, fields, pre + "type"),
                                 number=fields.get(pre + "nb", str(i)),
                                 n_points=_int_field(path, fields, pre + "nb_point", 1),
                                 columns=columns))
    by_code = {s.code: s for s in segments}
    if len(by_code) != len(segments):
        raise InstrumentFormatError(f"{path}: segment codes {[s.code for s in segments]} are not "
                                    "unique")
    values: dict[str, array] = {s.code: array("d") for s in segments}
    counts = dict.fromkeys(by_code, 0)
    for lineno, line in _lines(text):
        if line.startswith("HE "):
            continue
        tokens = line.split()
        seg = by_code.get(tokens[0])
        if seg is None:
            raise InstrumentFormatError(
                f"{path}: line {lineno}: {tokens[0][:20]!r} is neither a header ('HE ') nor a "
                f"data line of a declared segment (codes {', '.join(by_code)})")
        if len(tokens) != len(seg.columns) + 2 or tokens[1] != seg.number:
            raise InstrumentFormatError(
                f"{path}: line {lineno}: a data line of segment {seg.index} ({seg.code}) needs "
                f"'{seg.code} {seg.number}' and {len(seg.columns)} numbers, got "
                f"{' '.join(tokens)[:80]!r}")
        try:
            row = [float(t) for t in tokens[2:]]
        except ValueError:
            row = [math.nan]
        if not all(math.isfinite(v) for v in row):
            raise InstrumentFormatError(f"{path}: line {lineno}: not finite numbers "
                                        f"({' '.join(tokens[2:])[:80]!r})")
        counts[seg.code] += 1
        if counts[seg.code] > seg.n_points:
            raise InstrumentFormatError(
                f"{path}: segment {seg.index} ({seg.code}) declares {seg.n_points} points "
                f"(Recording_segment_{seg.index}_nb_point), the file has more: line {lineno} is "
                f"its data line {counts[seg.code]}; refused there, before reading the rest")
        values[seg.code].extend(row)
    for seg in segments:
        if counts[seg.code] != seg.n_points:
            raise InstrumentFormatError(
                f"{path}: segment {seg.index} ({seg.code}) declares {seg.n_points} points "
                f"(Recording_segment_{seg.index}_nb_point), the file has {counts[seg.code]}")
        seg.rows = np.frombuffer(values.pop(seg.code), dtype=float).reshape(
            seg.n_points, len(seg.columns))
    return _Uff(path=path, fields=fields, segments=segments)


def _described_columns(uff: _Uff) -> None:
    """Give ``?`` columns the previous segment's columns (noted), else refuse."""
    notes = []
    for k, seg in enumerate(uff.segments):
        unknown = [c.title.strip() in _UNKNOWN and c.unit.strip() in _UNKNOWN
                   for c in seg.columns]
        if not any(unknown):
            continue
        previous = next((p for p in reversed(uff.segments[:k])
                         if len(p.columns) == len(seg.columns)), None)
        if not all(unknown) or previous is None:
            raise InstrumentFormatError(
                f"{uff.path}: segment {seg.index} ({seg.code}) does not describe its columns "
                f"(titles/units {[(c.title, c.unit) for c in seg.columns]}), and no earlier "
                "segment has as many columns to take them from")
        seg.columns = list(previous.columns)
        notes.append(f"segment {seg.index} ({seg.code}) columns are '?' in the file: taken as "
                     f"segment {previous.index}'s ("
                     + ", ".join(f"{c.title} [{c.unit}]" for c in previous.columns) + ")")
    if notes:
        uff.notes["column_note"] = "; ".join(notes)


def _role(title: str) -> str | None:
    text = title.strip().lower()
    if "deflection" in text:
        return "deflection"
    if "displacement" in text or "height" in text or text in ("z", "zpiezo", "z piezo"):
        return "height"
    return None


@dataclass
class _Channel:
    values: np.ndarray  # SI, or volts for a deflection in V
    unit: str  # as written ("V" for volts)
    title: str  # as written


def _columns(uff: _Uff, seg: _Segment) -> dict[str, _Channel]:
    """Role (height, deflection) → channel of one segment; other columns are noted, unused."""
    table = seg.rows
    out: dict[str, _Channel] = {}
    for j, col in enumerate(seg.columns):
        role, unit, title = _role(col.title), col.unit.strip(), col.title.strip()
        if role is None:
            ignored = uff.notes.get("ignored_columns", "")
            uff.notes["ignored_columns"] = (ignored + ", " if ignored else "") + (
                f"segment {seg.index} {title} [{unit}]")
            continue
        if role in out:
            raise InstrumentFormatError(f"{uff.path}: segment {seg.index} ({seg.code}) has two "
                                        f"{role} columns; keep one")
        if role == "deflection" and unit.lower() in _VOLTS:
            out[role] = _Channel(table[:, j], "V", title)
            continue
        try:
            factor = unit_factor("length", unit)
        except (UnitError, ParameterError):
            allowed = "a length or volts" if role == "deflection" else "a length"
            raise InstrumentFormatError(
                f"{uff.path}: segment {seg.index} ({seg.code}) column {title!r}: unit {unit!r} "
                f"is not {allowed}") from None
        out[role] = _Channel(_measured(uff, seg, title, role, table[:, j] * factor), unit,
                             title)
    missing = [name for role, name in (("height", "height (Displacement, Height or Z)"),
                                       ("deflection", "Deflection")) if role not in out]
    if missing:
        raise InstrumentFormatError(
            f"{uff.path}: segment {seg.index} ({seg.code}) lacks a {' and a '.join(missing)} "
            f"column (it has {', '.join(c.title.strip() for c in seg.columns)})")
    return out


def _order_and_time(uff: _Uff, seg: _Segment, height: np.ndarray, name: str
                    ) -> tuple[np.ndarray, np.ndarray, str]:
    """(row order in time, time from the segment start [s], how) from the ramp."""
    n = len(seg.rows)
    where = f"{uff.path}: segment {seg.index} ({seg.code}, {seg.kind})"
    steps = np.diff(height)
    if name not in ("approach", "retract") or n < 2 or not (
            np.all(steps > 0) or np.all(steps < 0)):
        raise InstrumentFormatError(
            f"{where}: the file records no time, and this segment's sample times cannot be "
            "derived from the ramp (only an approach or retract whose height changes "
            "monotonically, with a velocity); this reader does not guess them")
    key = f"Recording_segment_{seg.index}_velocity(m/s)"
    velocity = _float_field(uff.fields, key)
    if not velocity > 0:
        raise InstrumentFormatError(f"{where}: no positive {key} ({uff.fields.get(key)!r}): the "
                                    "sample times are unknown (the file records no time)")
    dt = abs(float(height[-1] - height[0])) / (n - 1) / velocity
    if not MIN_TIME_STEP <= dt <= PHYSICAL_RANGES["time"][1] / n:
        raise InstrumentFormatError(
            f"{where}: {key} = {uff.fields[key]} gives a sample interval of {dt:g} s (mean "
            f"height step / velocity), outside [{MIN_TIME_STEP:g} s, "
            f"{PHYSICAL_RANGES['time'][1] / n:.3g} s] (from {MIN_TIME_STEP:g} s to a curve of "
            f"{PHYSICAL_RANGES['time'][1]:g} s): a corrupt velocity")
    reverse = bool(steps[0] < 0) != (name == "approach")  # approach: height decreasing in time
    order = np.arange(n)[::-1] if reverse else np.arange(n)
    how = f"dt = mean height step / velocity = {dt:.6g} s" + (", rows reversed" if reverse
                                                             else "")
    return order, np.arange(n) * dt, how


def _deflection(uff: _Uff, channel: _Channel, s: tuple[float, str], notes: dict[str, str]
                ) -> np.ndarray:
    """Deflection [m] of one segment (volts × sensitivity, or a length as recorded)."""
    if channel.unit != "V":
        notes["deflection_channel"] = f"{channel.title} [{channel.unit}] as recorded"
        return channel.values
    value, source = s
    if not value > 0:
        raise InstrumentFormatError(
            f"{uff.path}: the deflection is in volts and the header gives no inverse optical "
            "lever sensitivity (Recording_inv_optical_lever_sens_used(m/V)); "
            + _CLI_HINT.format(name="sensitivity", flag="--sensitivity 50nm/V"))
    notes["deflection_channel"] = f"{channel.title} [V] x sensitivity {value:g} m/V ({source})"
    return channel.values * value  # checked with the force by _assemble


def read_uff(path: str | Path, *, spring_constant: float | str | None = None,
             sensitivity: float | str | None = None) -> xr.Dataset:
    """Read a single-curve UFF text file (``.uff``) into a curves dataset (SI).

    Parameters
    ----------
    path : str or Path
        The file (opened read-only, never modified).
    spring_constant : float or str, optional
        Cantilever spring constant [N/m] (or a quantity, ``"0.1N/m"``); default the header's
        ``Cantilever_springK_used(N/m)``. Given, it recalibrates: force = k × deflection.
    sensitivity : float or str, optional
        Inverse optical lever sensitivity [m/V] (or ``"27nm/V"``) for a deflection in volts;
        default the header's ``Recording_inv_optical_lever_sens_used(m/V)``.

    Returns
    -------
    xarray.Dataset
        Curves dataset (:func:`viscoforce.schema.make_curves`), one curve; ``attrs["source"]``
        ``"uff"``; see the module docstring for what goes where.

    Raises
    ------
    InstrumentFormatError
        If the file is missing, not UFF, malformed (a count, a column, a line that does not fit
        the header; the message gives the line), holds several curves, lacks the calibration a
        deflection in volts needs, or a segment's sample times cannot be known.
    ParameterError, UnitError
        If ``spring_constant`` / ``sensitivity`` is not a positive quantity within
        :data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` /
        :data:`~viscoforce._limits.SENSITIVITY_RANGE`.
    """
    path = require_path("path", path)
    k_user = _option("spring_constant", spring_constant, "stiffness")
    s_user = _option("sensitivity", sensitivity, "sensitivity")
    if not path.is_file():
        raise InstrumentFormatError(f"{path}: no such file")
    if not detect_uff(path):
        raise InstrumentFormatError(f"{path}: not a UFF text file (the first line must be an "
                                    "'HE ' header line, with 'HE UFF_code:' or "
                                    "'HE Entry_UFF_version:')")
    uff = _parse(path)
    _described_columns(uff)
    return _curves(uff, k_user, s_user, fields=(_K_FIELDS, _S_FIELDS), source="uff",
                   meta=_meta(uff.fields))


def read_nanoscope(path: str | Path, *, spring_constant: float | str | None = None,
                   sensitivity: float | str | None = None) -> xr.Dataset:
    """Read a Bruker Nanoscope force-curve file (``.spm``) into a curves dataset (SI).

    Parameters
    ----------
    path : str or Path
        The file (opened read-only, never modified): one ramp force curve (approach,
        retract), as the MultiMode/Dimension/Icon "Force" mode writes it.
    spring_constant : float or str, optional
        Cantilever spring constant [N/m] (or ``"0.1N/m"``); default the header's
        ``Spring Constant``. Given, it recalibrates: force = k × deflection.
    sensitivity : float or str, optional
        Inverse optical lever sensitivity [m/V] (or ``"27nm/V"``); default the header's
        ``@Sens. DeflSens``.

    Returns
    -------
    xarray.Dataset
        Curves dataset (:func:`viscoforce.schema.make_curves`), one curve, the same as
        :func:`read_uff` gives for the UFF export of the curve; ``attrs["source"]``
        ``"nanoscope"``. See :mod:`viscoforce.io._bruker_spm` for the scaling chain.

    Raises
    ------
    InstrumentFormatError
        If the file is missing, not a Nanoscope force curve (an image, a force volume, a
        PeakForce capture, a curve with a surface hold), truncated (the data block beyond the
        end of the file), or its header lacks or garbles a field of the scaling chain (the
        message names the file and the field).
    ParameterError, UnitError
        If ``spring_constant`` / ``sensitivity`` is not a positive quantity within
        :data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` /
        :data:`~viscoforce._limits.SENSITIVITY_RANGE`.
    """
    path = require_path("path", path)
    k_user = _option("spring_constant", spring_constant, "stiffness")
    s_user = _option("sensitivity", sensitivity, "sensitivity")
    if not path.is_file():
        raise InstrumentFormatError(f"{path}: no such file")
    if not detect_nanoscope(path):
        raise InstrumentFormatError(f"{path}: not a Bruker Nanoscope file (it must start with "
                                    "'\\*Force file list' or '\\*File list')")
    uff, meta = nanoscope_curve(path)
    return _curves(uff, k_user, s_user, fields=((K_FIELD,), (S_FIELD,)), source="nanoscope",
                   meta=meta)


def _curves(uff: _Uff, k_user: float | None, s_user: float | None, *,
            fields: tuple[tuple[str, ...], tuple[str, ...]], source: str,
            meta: dict[str, Any]) -> xr.Dataset:
    """The curves dataset of a parsed curve (UFF text or Nanoscope binary): one assembly."""
    path = uff.path
    k_fields, s_fields = fields
    k, k_from = _calibration(uff, k_fields, k_user, "spring_constant")
    if not k > 0:
        raise InstrumentFormatError(
            f"{path}: the header gives no spring constant ({k_fields[0]}); "
            + _CLI_HINT.format(name="spring_constant", flag="--spring-constant 0.1N/m"))
    s = _calibration(uff, s_fields, s_user, "sensitivity")
    parts: dict[str, list[np.ndarray]] = {key: [] for key in (
        "time", "height", "deflection", "segment")}
    table: list[tuple[str, str]] = []
    hows: list[str] = []
    notes = {"force_channel": f"spring constant {k:g} N/m ({k_from}) x deflection"}
    for seg in uff.segments:
        cols = _columns(uff, seg)
        name = segment_label(seg.kind)
        order, t, how = _order_and_time(uff, seg, cols["height"].values, name)
        if parts["time"]:  # a segment starts one sample interval after the previous one ended
            t = t + parts["time"][-1][-1] + t[1]
        if (name, seg.kind) not in table:
            table.append((name, seg.kind))
        parts["time"].append(t)
        parts["height"].append(cols["height"].values[order])
        parts["deflection"].append(_deflection(uff, cols["deflection"], s, notes)[order])
        parts["segment"].append(np.full(len(order), table.index((name, seg.kind)), np.int32))
        hows.append(f"segment {seg.index} ({seg.kind}): {how}")
        notes["height_channel"] = (f"{cols['height'].title} [{cols['height'].unit}] as recorded, "
                                   "read as growing away from the sample (Nanoscope: Z piezo "
                                   "displacement from the turnaround)")
    return _assemble(uff, parts, table, hows, notes, k, s[0], source=source, meta=meta)


def _assemble(uff: _Uff, parts: dict[str, list[np.ndarray]], table: list[tuple[str, str]],
              hows: list[str], notes: dict[str, str], k: float, s: float, *, source: str,
              meta: dict[str, Any]) -> xr.Dataset:
    tip, tip_note = _tip_attrs(uff.fields)
    attrs: dict[str, Any] = {
        "file": str(uff.path), "n_curves": 1, "force_baseline_subtracted": 0,
        "time_channel": "derived from the ramp (the file records no time): " + "; ".join(hows),
        "sample_order": "rows in time order per segment: an approach moves toward the sample "
                        "(height decreasing), a retract away from it; segments in file order",
        **notes, **uff.notes, **tip}
    if tip_note:
        attrs["tip_note"] = tip_note
    attrs.update(meta)
    per_curve: dict[str, Any] = {"spring_constant": [k], "sensitivity": [s]}
    x = _float_field(uff.fields, "Recording_xposition(m)")
    y = _float_field(uff.fields, "Recording_yposition(m)")
    for axis, value in (("x", x), ("y", y)):
        if first_beyond(axis, value) is not None:
            raise InstrumentFormatError(
                f"{uff.path}: the header's Recording_{axis}position(m) = {value:g} m is beyond "
                f"the physical range {range_text(axis)}: a corrupt header")
    if math.isfinite(x) and math.isfinite(y):
        per_curve["x"], per_curve["y"] = [x], [y]
    deflection = np.concatenate(parts["deflection"])
    with np.errstate(over="ignore"):  # an overflow is refused below
        force = k * deflection
    for role, values, what in (("deflection", deflection, "deflection"),
                               ("force", force, "force (spring constant x deflection)")):
        i = first_beyond(role, values)
        tiny = None if i is not None else below_scale(role, values)
        if i is not None or tiny is not None:
            unit = PHYSICAL_RANGES[role][2]
            problem = (f"sample {i} is {float(values[i]):g} {unit}, beyond the physical range "
                       f"{range_text(role)}" if i is not None else
                       f"it is at most {abs(tiny[1]):g} {unit} in magnitude (sample {tiny[0]}), "
                       f"below {scale_text(role)}")
            raise InstrumentFormatError(
                f"{uff.path}: the {what}: {problem}; the calibration (spring constant {k:g} N/m, "
                f"sensitivity {s:g} m/V) or the data are damaged")
    ds = make_curves(np.concatenate(parts["time"]), force,
                     np.concatenate(parts["height"]), deflection,
                     segment=np.concatenate(parts["segment"]),
                     segment_names=[r[0] for r in table], segment_types=[r[1] for r in table],
                     per_curve=per_curve, attrs=attrs, source=source)
    return ds.assign_coords(curve=np.arange(1, dtype=np.int32))
