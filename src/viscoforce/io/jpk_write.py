"""Write a single force curve as a JPK ``.jpk-force`` archive (:func:`write_jpk_force`).

The inverse of :func:`viscoforce.io.jpk.read_jpk` for one curve, laid out as JPK instruments
write it (see ``JPK-NOTES.md``): a zip with ``header.properties`` (the curve: position, segment
count, the force settings of every segment), ``shared-data/header.properties`` (one calibration
block ``lcd-info.<L>.*`` per channel and one settings block ``force-segment-header-info.<s>.*``
per segment) and per segment ``segments/<s>/segment-header.properties`` (actual duration and
number of points, the free-cantilever baseline, references into the shared data) with its
channels ``segments/<s>/channels/<channel>.dat``.

Channels, given in SI as the reader returns them:

=========================  =====  ===========================================================
channel                    unit   stored as (big-endian ``signedinteger`` raw → base → slots)
=========================  =====  ===========================================================
``vDeflection``            m      V → ``distance`` (× ``sensitivity``) → ``force``
                                  (× ``spring_constant``, N)
``height`` (piezo)         m      V → ``nominal`` (× :data:`PIEZO_NOMINAL`) → ``calibrated``
                                  (× :data:`PIEZO_CALIBRATION`)
``measuredHeight``,        m      ``absolute`` m → ``nominal`` (+ :data:`SENSOR_OFFSET`)
``strainGaugeHeight``,
``capacitiveSensorHeight``
=========================  =====  ===========================================================

Every channel is quantised to int32 with one linear encoder over all its segments (offset = the
centre of its base-unit range, multiplier = half the range / (2³¹ − 2)), so the reader gets back
each value to within half an encoder step: |error| ≤ range·2⁻³² (relative 2e-10 of the range),
plus float rounding. Signs are the reader's: height grows away from the sample, deflection is
positive for repulsion. The reader's time axis is ``start + i·duration/num_points``: sample
channel arrays at those times.

The archive is deterministic: fixed zip timestamps, member order and number formatting (Java's
``Double.toString`` style, exact round trip), so the same input gives the same bytes.
"""

from __future__ import annotations

import io
import math
import os
import zipfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._files import write_bytes
from viscoforce._typing import FloatArray
from viscoforce._validation import (
    describe_value,
    require_finite,
    require_nonnegative,
    require_path,
    require_positive,
)
from viscoforce.exceptions import ParameterError

__all__ = ["CHANNELS", "PIEZO_CALIBRATION", "PIEZO_NOMINAL", "SEGMENT_TYPES", "SENSOR_OFFSET",
           "ForceSegment", "java_double", "write_jpk_force"]

#: Channels the writer stores (every one in metres, see the module docstring).
CHANNELS = ("vDeflection", "height", "measuredHeight", "strainGaugeHeight",
            "capacitiveSensorHeight")
#: Default ``settings.segment-settings.type`` of each ``settings.style``.
SEGMENT_TYPES = {"extend": "z-extend-height", "retract": "z-retract-height",
                 "pause": "constant-height-pause",
                 "modulation": "sine-z-modulation-segment-settings"}
#: Piezo ``nominal`` slot: multiplier [m/V] and offset [m] (height grows as the voltage falls).
PIEZO_NOMINAL = (-1.5e-7, 1.5e-5)
#: Piezo ``calibrated`` slot multiplier (calibrated = factor × nominal).
PIEZO_CALIBRATION = 0.8
#: Height-sensor ``nominal`` slot offset [m] (nominal = absolute + offset).
SENSOR_OFFSET = 1.5e-5

_INT32_HALF = 2**31 - 2            # largest |raw| the encoder uses
_ZIP_TIME = (2026, 1, 1, 0, 0, 0)  # timestamp of every zip member (deterministic archives)
_SETTINGS = "settings.segment-settings."


@dataclass(frozen=True, eq=False)
class ForceSegment:
    """One segment of a force curve to write, in SI.

    Parameters
    ----------
    style : {"extend", "retract", "pause", "modulation"}
        ``settings.style``.
    duration : float
        Duration [s], > 0; sample i is at ``start + i * duration / num_points``.
    channels : mapping of str to array_like
        Samples [m] of the channels in :data:`CHANNELS`: ``vDeflection`` (required) and at
        least one height channel, all 1-D, finite and of one length (``num_points`` ≥ 1).
    type : str, optional
        ``settings.segment-settings.type``; default :data:`SEGMENT_TYPES` of ``style``.
    frequency : float, optional
        Drive frequency [Hz], > 0: required for a modulation segment, refused otherwise.
    amplitude : float, optional
        Nominal drive amplitude [m], >= 0: required for a modulation segment, refused otherwise.
    start_phase : float
        ``start-phase`` of a modulation segment (no unit stated by JPK; default 0).

    Raises
    ------
    ParameterError
        A value outside the ranges above; the message names the field.
    """

    style: str
    duration: float
    channels: Mapping[str, ArrayLike] = field(repr=False)
    type: str | None = None
    frequency: float | None = None
    amplitude: float | None = None
    start_phase: float = 0.0

    def __post_init__(self) -> None:
        if self.style not in SEGMENT_TYPES:
            raise ParameterError(f"ForceSegment.style must be one of {', '.join(SEGMENT_TYPES)}, "
                                 f"got {describe_value(self.style)}")
        set_ = object.__setattr__
        set_(self, "duration", require_positive("ForceSegment.duration [s]", self.duration))
        if self.type is None:
            set_(self, "type", SEGMENT_TYPES[self.style])
        elif not isinstance(self.type, str) or not self.type.strip() or "\n" in self.type:
            raise ParameterError(f"ForceSegment.type must be a non-empty one-line str, got "
                                 f"{describe_value(self.type)}")
        set_(self, "channels", _channels(self.channels))
        modulation = self.style == "modulation"
        for name, check in (("frequency", require_positive), ("amplitude", require_nonnegative)):
            value = getattr(self, name)
            if modulation and value is None:
                raise ParameterError(f"ForceSegment.{name} is required for a modulation segment")
            if not modulation and value is not None:
                raise ParameterError(f"ForceSegment.{name} is only for a modulation segment "
                                     f"(style {self.style!r}), got {value!r}")
            if value is not None:
                set_(self, name, check(f"ForceSegment.{name}", value))
        set_(self, "start_phase", require_finite("ForceSegment.start_phase", self.start_phase))

    @property
    def num_points(self) -> int:
        """Number of samples of every channel."""
        return len(next(iter(self.channels.values())))


def _channels(channels: Any) -> dict[str, FloatArray]:
    if not isinstance(channels, Mapping) or not channels:
        raise ParameterError(f"ForceSegment.channels must be a non-empty mapping channel name -> "
                             f"samples [m], got {describe_value(channels)}")
    unknown = sorted(set(map(str, channels)) - set(CHANNELS))
    if unknown:
        raise ParameterError(f"ForceSegment.channels: unknown channel(s) {', '.join(unknown)}; "
                             f"known: {', '.join(CHANNELS)}")
    if "vDeflection" not in channels:
        raise ParameterError("ForceSegment.channels must hold 'vDeflection' (the cantilever "
                             "deflection [m])")
    if not set(channels) & set(CHANNELS[1:]):
        raise ParameterError(f"ForceSegment.channels must hold a height channel (one of "
                             f"{', '.join(CHANNELS[1:])})")
    out: dict[str, FloatArray] = {}
    for name in CHANNELS:  # a fixed order: the channels.list of the file
        if name not in channels:
            continue
        values = np.array(channels[name], dtype=float)  # a copy: the segment is immutable
        if values.ndim != 1 or values.size == 0 or not np.all(np.isfinite(values)):
            raise ParameterError(f"ForceSegment.channels[{name!r}] must be a non-empty 1-D array "
                                 f"of finite numbers [m], got shape {values.shape}")
        values.flags.writeable = False
        out[name] = values
    sizes = {name: v.size for name, v in out.items()}
    if len(set(sizes.values())) != 1:
        raise ParameterError(f"ForceSegment.channels must all have one length, got {sizes}")
    return out


# ── properties text ─────────────────────────────────────────────────────────────────────────


def java_double(value: float) -> str:
    """``value`` as Java's ``Double.toString`` writes it (``1.5E-8``, ``0.8``, ``2.0E7``).

    Shortest digits that round-trip exactly; scientific notation outside [1e-3, 1e7).
    """
    x = float(value)
    if math.isnan(x):
        return "NaN"
    if math.isinf(x):
        return "Infinity" if x > 0 else "-Infinity"
    if x == 0:
        return "-0.0" if math.copysign(1.0, x) < 0 else "0.0"
    if 1e-3 <= abs(x) < 1e7:
        text = repr(x)
        return text if "e" not in text else np.format_float_positional(x, unique=True,
                                                                       min_digits=1)
    mantissa, exponent = np.format_float_scientific(x, unique=True, min_digits=1).split("e")
    return f"{mantissa}E{int(exponent)}"


def _escape(text: str, *, key: bool) -> str:
    out = []
    for i, char in enumerate(text):
        if char in "\\:=#!":
            out.append("\\" + char)
        elif char == " " and (key or i == 0):
            out.append("\\ ")
        elif char in "\t\n\r\f":
            out.append("\\" + {"\t": "t", "\n": "n", "\r": "r", "\f": "f"}[char])
        elif ord(char) > 126 or ord(char) < 32:
            out.append(f"\\u{ord(char):04X}")
        else:
            out.append(char)
    return "".join(out)


def _properties(props: Mapping[str, str], stamp: str) -> bytes:
    lines = [f"#{stamp}"] + [f"{_escape(k, key=True)}={_escape(v, key=False)}"
                             for k, v in props.items()]
    return ("\n".join(lines) + "\n").encode("latin-1")


# ── calibration blocks ──────────────────────────────────────────────────────────────────────


@dataclass(frozen=True)
class _Encoder:
    """Linear int32 encoder of one channel: raw = round((base − offset) / multiplier)."""

    multiplier: float
    offset: float

    @classmethod
    def spanning(cls, values: FloatArray) -> _Encoder:
        lo, hi = float(values.min()), float(values.max())
        offset = 0.5 * (lo + hi)
        half = 0.5 * (hi - lo)
        multiplier = half / _INT32_HALF if half > 0 else max(abs(offset), 1e-300) * 2.0**-31
        return cls(multiplier=multiplier, offset=offset)

    def encode(self, values: FloatArray) -> bytes:
        raw = np.rint((values - self.offset) / self.multiplier)
        return np.clip(raw, -_INT32_HALF - 1, _INT32_HALF + 1).astype(">i4").tobytes()


def _slot(name: str, title: str, base: str, multiplier: float, offset: float,
          unit: str) -> dict[str, str]:
    pre = f"conversion-set.conversion.{name}."
    return {pre + "name": title, pre + "defined": "true", pre + "type": "simple",
            pre + "comment": "viscoforce", pre + "base-calibration-slot": base,
            pre + "calibration-slot": name, pre + "scaling.type": "linear",
            pre + "scaling.style": "offsetmultiplier", pre + "scaling.offset": java_double(offset),
            pre + "scaling.multiplier": java_double(multiplier),
            pre + "scaling.unit.type": "metric-unit", pre + "scaling.unit.unit": unit}


def _chain(channel: str, spring_constant: float, sensitivity: float
           ) -> tuple[str, str, list[tuple[str, str, str, float, float, str]]]:
    """Base slot, its unit and the slots (name, title, base, multiplier, offset, unit)."""
    if channel == "vDeflection":
        return "volts", "V", [("distance", "Distance", "volts", sensitivity, 0.0, "m"),
                              ("force", "Force", "distance", spring_constant, 0.0, "N")]
    if channel == "height":
        mult, off = PIEZO_NOMINAL
        return "volts", "V", [("nominal", "Nominal height", "volts", mult, off, "m"),
                              ("calibrated", "Calibrated height", "nominal", PIEZO_CALIBRATION,
                               0.0, "m")]
    return "absolute", "m", [("nominal", "Nominal", "absolute", 1.0, SENSOR_OFFSET, "m")]


def _to_base(channel: str, values: FloatArray, sensitivity: float) -> FloatArray:
    """SI samples → the channel's base slot (inverse of the conversion chain)."""
    if channel == "vDeflection":
        return values / sensitivity
    if channel == "height":
        mult, off = PIEZO_NOMINAL
        return (values / PIEZO_CALIBRATION - off) / mult
    return values - SENSOR_OFFSET


def _lcd_info(channel: str, encoder: _Encoder, spring_constant: float,
              sensitivity: float) -> dict[str, str]:
    base, unit, slots = _chain(channel, spring_constant, sensitivity)
    block = {"type": "integer-data", "channel.type": "channel", "channel.name": channel,
             "unit.type": "metric-unit", "unit.unit": unit,
             "conversion-set.conversions.list": " ".join(s[0] for s in slots),
             "conversion-set.conversions.default": slots[-1][0],
             "conversion-set.conversions.base": base,
             f"conversion-set.conversion.{base}.name": base.title(),
             f"conversion-set.conversion.{base}.defined": "false"}
    for slot in slots:
        block.update(_slot(*slot))
    block.update({"encoder.type": "signedinteger", "encoder.scaling.type": "linear",
                  "encoder.scaling.style": "offsetmultiplier",
                  "encoder.scaling.offset": java_double(encoder.offset),
                  "encoder.scaling.multiplier": java_double(encoder.multiplier),
                  "encoder.scaling.unit.type": "metric-unit", "encoder.scaling.unit.unit": unit})
    return block


def _settings(segment: ForceSegment) -> dict[str, str]:
    """The ``settings.*`` block of a segment (planned duration and points = the actual ones)."""
    settings = {"settings.type": "combined", "settings.style": segment.style,
                _SETTINGS + "type": str(segment.type),
                _SETTINGS + "identifier.type": "standard",
                _SETTINGS + "identifier.name": f"{segment.style}-spm",
                _SETTINGS + "style": segment.style,
                _SETTINGS + "duration": java_double(segment.duration),
                _SETTINGS + "num-points": str(segment.num_points)}
    if segment.style == "modulation":
        settings.update({_SETTINGS + "frequency": java_double(segment.frequency),
                         _SETTINGS + "amplitude": java_double(segment.amplitude),
                         _SETTINGS + "start-phase": java_double(segment.start_phase),
                         _SETTINGS + "axis-direction": "ZPOS"})
    return settings


# ── the archive ─────────────────────────────────────────────────────────────────────────────


def _require_segments(segments: Any) -> tuple[ForceSegment, ...]:
    if isinstance(segments, ForceSegment) or not isinstance(segments, Sequence) or not segments:
        raise ParameterError(f"segments must be a non-empty sequence of ForceSegment, got "
                             f"{describe_value(segments)}")
    for i, segment in enumerate(segments):
        if not isinstance(segment, ForceSegment):
            raise ParameterError(f"segments[{i}] must be a ForceSegment, got "
                                 f"{describe_value(segment)}")
    return tuple(segments)


def _require_text(name: str, value: Any) -> str:
    if not isinstance(value, str) or "\n" in value or "\r" in value:
        raise ParameterError(f"{name} must be a one-line str, got {describe_value(value)}")
    return value


def write_jpk_force(path: str | os.PathLike[str], segments: Sequence[ForceSegment], *,
                    spring_constant: float, sensitivity: float,
                    position: tuple[float, float] = (0.0, 0.0), baseline: float | None = None,
                    instrument: str = "viscoforce synthetic",
                    time_stamp: str = "2026-01-01 00:00:00.000 +0000") -> Path:
    """Write one force curve as a ``.jpk-force`` archive that :func:`~viscoforce.io.jpk.read_jpk` reads.

    See the module docstring for the layout, the calibration chains and the precision.

    Parameters
    ----------
    path : str or Path
        The file to write (overwritten if it exists; its directory must exist).
    segments : sequence of ForceSegment
        The segments in time order (at least one).
    spring_constant : float
        Cantilever spring constant [N/m], > 0: force = spring_constant × vDeflection.
    sensitivity : float
        Deflection sensitivity [m/V], > 0: vDeflection [m] = sensitivity × volts.
    position : (float, float)
        Position x, y of the curve [m] (``force-scan-series.header.position``).
    baseline : float, optional
        Free-cantilever deflection [m], written as every segment's measured
        ``baseline.baseline`` (in V); None: no measured baseline.
    instrument : str
        ``force-scan-series.description.instrument``.
    time_stamp : str
        Time stamp of the headers and segments (fixed by default: deterministic files).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    ParameterError
        A bad argument (the message names it), or a directory that does not exist.
    """
    path = require_path("path", path)
    segments = _require_segments(segments)
    spring_constant = require_positive("spring_constant [N/m]", spring_constant)
    sensitivity = require_positive("sensitivity [m/V]", sensitivity)
    if not isinstance(position, Sequence) or isinstance(position, str) or len(position) != 2:
        raise ParameterError(f"position must be (x, y) [m], got {describe_value(position)}")
    x, y = (require_finite(f"position[{i}] [m]", v) for i, v in enumerate(position))
    baseline = None if baseline is None else require_finite("baseline [m]", baseline)
    instrument = _require_text("instrument", instrument)
    time_stamp = _require_text("time_stamp", time_stamp)
    if not path.parent.is_dir():
        raise ParameterError(f"path: directory {str(path.parent)!r} does not exist")

    names = [c for c in CHANNELS if any(c in s.channels for s in segments)]
    lcd = {name: number for number, name in enumerate(names)}
    base = {name: [_to_base(name, s.channels[name], sensitivity) for s in segments
                   if name in s.channels] for name in names}
    encoders = {name: _Encoder.spanning(np.concatenate(base[name])) for name in names}

    shared: dict[str, str] = {"force-segment-header-infos.count": str(len(segments)),
                              "lcd-infos.count": str(len(names))}
    for s, segment in enumerate(segments):
        shared.update({f"force-segment-header-info.{s}.type": "spm-force-segment-header",
                       f"force-segment-header-info.{s}.name.type": "standard",
                       f"force-segment-header-info.{s}.name.name": f"{segment.style}-spm"})
        shared.update({f"force-segment-header-info.{s}.{k}": v for k, v in _settings(segment).items()})
    for name, number in lcd.items():
        shared.update({f"lcd-info.{number}.{k}": v for k, v in
                       _lcd_info(name, encoders[name], spring_constant, sensitivity).items()})

    header = {"jpk-data-file": "spm-forcefile", "file-format-version": "2.0",
              "type": "force-scan-series", "force-scan-series.force-segments.count": str(len(segments)),
              "force-scan-series.header.type": "xy-position-force-scan-series-header",
              "force-scan-series.header.position.x": java_double(x),
              "force-scan-series.header.position.y": java_double(y),
              "force-scan-series.description.instrument": instrument,
              "force-scan-series.description.source-software": "viscoforce",
              "force-scan-series.start-time": time_stamp,
              "force-scan-series.header.force-settings.type": "segmented-force-settings",
              "force-scan-series.header.force-settings.segments.size": str(len(segments))}
    for s, segment in enumerate(segments):
        pre = f"force-scan-series.header.force-settings.segment.{s}."
        header.update({pre + k.removeprefix(_SETTINGS): v for k, v in _settings(segment).items()
                       if k.startswith(_SETTINGS)})

    members: list[tuple[str, bytes]] = [("header.properties", _properties(header, time_stamp)),
                                        ("shared-data/header.properties",
                                         _properties(shared, time_stamp))]
    for s, segment in enumerate(segments):
        n = segment.num_points
        head = {"force-segment-header.force-segment-header-info.*": str(s),
                "force-segment-header.type": "spm-force-segment-header",
                "force-segment-header.num-points": str(n),
                "force-segment-header.duration": java_double(segment.duration),
                "force-segment-header.time-stamp": time_stamp}
        if baseline is not None:
            head.update({"force-segment-header.baseline.baseline": java_double(baseline / sensitivity),
                         "force-segment-header.baseline.measured": "true"})
        head["channels.list"] = " ".join(segment.channels)
        data = []
        for name, values in segment.channels.items():
            pre = f"channel.{name}."
            head.update({pre + "lcd-info.*": str(lcd[name]),
                         pre + "data.file.name": f"channels/{name}.dat",
                         pre + "data.file.format": "raw", pre + "data.num-points": str(n)})
            data.append((f"segments/{s}/channels/{name}.dat",
                         encoders[name].encode(_to_base(name, values, sensitivity))))
        members.append((f"segments/{s}/segment-header.properties", _properties(head, time_stamp)))
        members.extend(data)

    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as zf:
        for name, content in members:
            info = zipfile.ZipInfo(name, date_time=_ZIP_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            zf.writestr(info, content, compresslevel=9)
    write_bytes(path, buffer.getvalue())
    return path
