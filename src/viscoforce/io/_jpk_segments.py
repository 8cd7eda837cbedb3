"""Decoding of the segments and channels of a JPK curve (the sample layer of :mod:`viscoforce.io.jpk`).

A segment is decoded from its plan (kept per header text by the archive's reader, see
:mod:`viscoforce.io._jpk_headers`) and its channel members: each member's declared size is checked
against ``num-points`` and the segment's arrays against
:data:`~viscoforce._limits.MAX_MEMORY_BYTES` before anything is allocated; raw samples go through
the encoder and the calibration steps to SI, and a non-finite calibrated sample is refused. See
:mod:`viscoforce.io.jpk` for the behaviour.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from viscoforce import _limits
from viscoforce._limits import check_effort
from viscoforce._typing import FloatArray
from viscoforce.io._jpk_archive import _Layout, _located, _Members, _parse_props, _read_member, _Where
from viscoforce.io._jpk_headers import _SI_SLOTS, JPKModulation, _ChannelPlan, _segment_plan, _SegmentPlan

#: segment plans an archive reader keeps at most (then it forgets them all and starts again)
_PLAN_CACHE = 64


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
