"""JPK properties headers read into checked values (the header layer of :mod:`viscoforce.io.jpk`).

A resolved segment header becomes a :class:`_SegmentPlan`: its sample count and duration, and per
channel the raw dtype, the encoder and the calibration steps to each SI slot, the drive of a
modulation segment (:class:`JPKModulation`) and the baseline; a top-level map header gives its
position grid (:class:`JPKGrid`). Calibrations are refused when not finite or outside the
plausible ranges (:class:`~viscoforce.io._properties.HeaderError` naming the key). Nothing here
touches the archive: see :mod:`viscoforce.io.jpk` for the behaviour.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from viscoforce import _limits
from viscoforce._limits import MIN_TIME_STEP
from viscoforce.io._properties import (
    HeaderError,
    conversion_steps,
    convert,
    encoder_prefix,
    get,
    number,
    require_linear,
    slot_unit,
)

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
_SEG = "force-segment-header."
_SETTINGS = "force-segment-header.settings.segment-settings."
_GRID = "force-scan-map.position-pattern.grid."


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
    theta : float
        Rotation of the grid's fast axis from x (``grid.theta``) [rad]; 0 when not given.
    """

    ilength: int
    jlength: int
    ulength: float
    vlength: float
    xcenter: float
    ycenter: float
    theta: float = 0.0


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
    lengths["theta"] = number(header, _GRID + "theta", default="0")
    for key, value in lengths.items():
        if not math.isfinite(value):
            raise HeaderError(f"'{_GRID}{key}' = {value!r} {'rad' if key == 'theta' else 'm'} is "
                              "not finite")
    return JPKGrid(ilength=number(header, _GRID + "ilength", int),
                   jlength=number(header, _GRID + "jlength", int), **lengths)
