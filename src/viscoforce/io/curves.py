"""JPK archive → schema *curves* dataset (:func:`jpk_to_curves`).

What goes where (SI throughout; the file is never modified):

* per sample: ``time`` [s] from the start of the curve (segment ``start_time`` + i·duration /
  num_points), ``force`` [N] as the file gives it (**no baseline subtracted**), ``height`` [m]
  from the preferred height channel, ``deflection`` [m] (``vDeflection``), ``tip_position`` [m]
  = −height − deflection (tip displacement toward the sample, the :func:`~viscoforce.schema.
  make_curves` default), ``segment`` (row of the segment table);
* per curve: ``x``, ``y`` [m] snapped to the map's grid, ``x_raw``, ``y_raw`` [m] as the file
  gives them, the grid ``row`` and ``column`` (int32; :meth:`~viscoforce.io.jpk.JPKArchive.
  positions`, found from every curve of the archive, so a chunk of curves agrees with the whole
  file), ``spring_constant`` [N/m], ``sensitivity`` [m/V], ``baseline`` [N] (the file's
  free-cantilever baseline converted to force; NaN when the file has none) and a ``curve``
  coordinate holding the curve's index in the archive;
* per segment (``segment_table``, one row per segment of every curve): ``segment_name`` (one of
  :data:`~viscoforce.schema.SEGMENT_NAMES`), ``segment_type`` (the file's
  ``settings.segment-settings.type``), ``segment_style``, ``segment_curve`` (row of ``curve``),
  ``segment_index``, ``segment_start_time`` [s], ``segment_duration`` [s], ``segment_num_points``,
  ``segment_frequency`` [Hz] and ``segment_amplitude`` [m] (nominal drive of modulation segments,
  NaN otherwise), ``segment_baseline`` [N];
* ``attrs`` (flat numbers and strings): ``source`` = ``"jpk"``, ``file``, ``archive_kind``,
  ``n_curves``, ``height_channel``, ``force_baseline_subtracted`` = 0, the calibration of the
  first curve (``spring_constant``, ``sensitivity``; per-curve values are the variables), the grid
  (``grid_*``) of a map, how the rows and columns were found (``grid_rows``, ``grid_columns``,
  ``grid_x_step``, ``grid_y_step``, ``grid_method``), and the settings of the first curve's
  segments ``segment_<k>_style``, ``_type``, ``_duration``, ``_num_points``, and for modulation
  ``_frequency``, ``_amplitude``, ``_start_phase``.

Height channel: the calibrated sensor where the file has one, in the order ``strainGaugeHeight``,
``measuredHeight``, ``capacitiveSensorHeight``, then the piezo ``height``. One channel is used for
the whole dataset: the first of that order present in every segment of every selected curve (a
channel that exists in some segments only, e.g. ``capacitiveSensorHeight`` in extend and retract,
would make the height jump between segments).

Refused before anything is decoded: a curve selected twice (``curves=[0, 0]``), an unknown
``height_channel``, and one that the segment headers do not list. A channel whose samples leave
:data:`~viscoforce.io.quality.PHYSICAL_RANGES`, or are all below the smallest scale of a
measurement (:data:`~viscoforce.io.quality.SMALLEST_SCALES`), is refused naming the file, curve,
segment and channel.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import InstrumentFormatError, ParameterError
from viscoforce.io.jpk import JPKArchive, JPKCurve, JPKSegment
from viscoforce.io.quality import (
    PHYSICAL_RANGES,
    below_scale,
    first_beyond,
    range_text,
    scale_text,
)
from viscoforce.schema import make_curves, validate_curves

__all__ = ["HEIGHT_CHANNELS", "check_height_channel", "jpk_to_curves", "segment_name",
           "unique_curves"]

#: Height channels in order of preference (calibrated sensors first, the piezo last).
HEIGHT_CHANNELS = ("strainGaugeHeight", "measuredHeight", "capacitiveSensorHeight", "height")
_STYLES = {"extend": "approach", "approach": "approach", "retract": "retract", "pause": "pause",
           "modulation": "modulation"}
_TYPE_WORDS = (("modulation", "modulation"), ("pause", "pause"), ("extend", "approach"),
               ("retract", "retract"))


def segment_name(style: str, type_: str = "") -> str:
    """Schema segment name of a JPK segment: by ``settings.style``, else by words of its type.

    extend → approach, retract → retract, pause → pause, modulation → modulation, anything
    else → other.
    """
    name = _STYLES.get(style.strip().lower())
    if name is not None:
        return name
    low = type_.lower()
    for word, found in _TYPE_WORDS:
        if word in low:
            return found
    return "other"


def _select(archive: JPKArchive, curves: int | Iterable[int] | None) -> list[int]:
    n = archive.n_curves
    if curves is None:
        return list(range(n))
    if isinstance(curves, int | np.integer) and not isinstance(curves, bool):
        curves = [curves]
    try:
        picked = [operator.index(c) for c in curves]  # type: ignore[union-attr]
    except TypeError:
        raise ParameterError(f"curves must be None, an integer or integers, got {curves!r}"
                             ) from None
    if not picked:
        raise ParameterError("curves selects no curve; give None for all")
    for c in picked:
        if not -n <= c < n:
            raise ParameterError(f"curve index {c} out of range for {n} curves in {archive.path}")
    return unique_curves([c % n for c in picked], picked)


def unique_curves(indices: list[int], given: list[int] | None = None) -> list[int]:
    """``indices`` (curve rows, negative ones already wrapped), refused when one repeats.

    A curve selected twice would be decoded, stored and fitted twice (a map's pixel counted
    twice); ``given`` is the selection as the caller wrote it, for the message.

    Raises
    ------
    ParameterError
        Naming the repeated curve and where it was given.
    """
    given = indices if given is None else given
    first: dict[int, int] = {}
    for k, c in enumerate(indices):
        if c in first:
            j = first[c]
            same = "" if given[j] == given[k] else f" (as {given[j]!r} and {given[k]!r})"
            raise ParameterError(
                f"curves selects curve {c} twice{same}, at positions {j} and {k} of "
                f"{_shown_list(given)}; give each curve once (None: all)")
        first[c] = k
    return indices


def _shown_list(values: list[int]) -> str:
    shown = ", ".join(str(int(v)) for v in values[:10])
    return f"[{shown}]" if len(values) <= 10 else f"[{shown}, ...] ({len(values)} indices)"


def check_height_channel(height_channel: Any) -> str | None:
    """``height_channel`` unchanged when None or one of :data:`HEIGHT_CHANNELS`, else refused.

    Called before anything is decoded (an unknown name was refused only after every selected
    curve had been read).

    Raises
    ------
    ParameterError
        Naming the value and the allowed names.
    """
    if height_channel is None or (isinstance(height_channel, str)
                                  and height_channel in HEIGHT_CHANNELS):
        return height_channel
    raise ParameterError(f"height_channel must be None (the first of {', '.join(HEIGHT_CHANNELS)} "
                         f"present in every segment) or one of them, got {height_channel!r}")


def _default_height(units: list[list[dict[str, str]]]) -> str:
    """The first of :data:`HEIGHT_CHANNELS` in metres in every segment (units per curve)."""
    segments = [u for curve in units for u in curve]
    for name in HEIGHT_CHANNELS:
        if all(u.get(name) == "m" for u in segments):
            return name
    raise InstrumentFormatError(
        "no height channel in metres is present in every segment (looked for "
        f"{', '.join(HEIGHT_CHANNELS)})")


def _require(seg: JPKSegment, curve: JPKCurve, name: str, unit: str, path: Any = None
             ) -> np.ndarray:
    if name not in seg.channels:
        raise InstrumentFormatError(
            f"curve {curve.index} segment {seg.index} has no {name!r} channel "
            f"(channels: {', '.join(sorted(seg.channels))}); is the deflection calibrated?")
    if seg.units.get(name, unit) != unit:
        raise InstrumentFormatError(
            f"curve {curve.index} segment {seg.index}: {name!r} is in {seg.units[name]!r}, not "
            f"{unit!r}: the file lacks its calibration")
    values = np.asarray(seg.channels[name], dtype=float)
    _refuse_bad_samples(values, seg, curve, name, path)
    return values


def _refuse_bad_samples(values: np.ndarray, seg: JPKSegment, curve: JPKCurve, name: str,
                        path: Any) -> None:
    """Refuse NaN, inf or physically impossible samples, naming file, curve, segment, channel."""
    where = (f"{path}: " if path is not None else "") + (
        f"curve {curve.index}" + (f" ({curve.source.rstrip('/')})" if curve.source else "")
        + f" segment {seg.index} ({seg.style or seg.type or 'unnamed'}) channel {name!r}")
    bad = ~np.isfinite(values)
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise InstrumentFormatError(
            f"{where}: sample {i} of {values.size} is {float(values[i])!r} ({int(bad.sum())} "
            "non-finite samples); the file's data are damaged")
    key = "deflection" if name == "vDeflection" else "height" if name in HEIGHT_CHANNELS else name
    i = first_beyond(key, values) if key in PHYSICAL_RANGES else None
    if i is not None:
        raise InstrumentFormatError(
            f"{where}: sample {i} of {values.size} is {float(values[i]):g} "
            f"{PHYSICAL_RANGES[key][2]}, beyond the physical range {range_text(key)}; the file's "
            "calibration (spring constant, sensitivity, scaling) or its data are damaged")
    tiny = below_scale(key, values)
    if tiny is not None:
        raise InstrumentFormatError(
            f"{where}: every sample is at most {abs(tiny[1]):g} {PHYSICAL_RANGES[key][2]} in "
            f"magnitude (sample {tiny[0]} of {values.size}), below {scale_text(key)}; the file's "
            "calibration (spring constant, sensitivity, scaling) or its data are damaged")


def _nan(value: float | None) -> float:
    return math.nan if value is None else float(value)


def _file_attrs(archive: JPKArchive, first: JPKCurve, height: str) -> dict[str, Any]:
    attrs: dict[str, Any] = {
        "file": str(archive.path), "archive_kind": archive.kind, "n_curves": archive.n_curves,
        "height_channel": height, "force_baseline_subtracted": 0,
        "force_convention": "force = spring_constant x vDeflection, positive when the tip is "
                            "pushed away from the sample (repulsion); not baseline-corrected",
        "tip_position_convention": "tip_position = -height - deflection: tip displacement toward "
                                   "the sample, up to an offset",
        "spring_constant": float(first.spring_constant), "sensitivity": float(first.sensitivity),
        "n_segments": len(first.segments),
    }
    if archive.grid is not None:
        g = archive.grid
        attrs.update(grid_ilength=int(g.ilength), grid_jlength=int(g.jlength),
                     grid_ulength=float(g.ulength), grid_vlength=float(g.vlength),
                     grid_xcenter=float(g.xcenter), grid_ycenter=float(g.ycenter))
        if g.theta:
            attrs["grid_theta"] = float(g.theta)
    attrs.update(archive.positions().as_attrs())  # of the whole archive: chunks agree
    for s in first.segments:
        p = f"segment_{s.index}_"
        attrs[p + "style"] = s.style
        attrs[p + "type"] = s.type
        attrs[p + "name"] = segment_name(s.style, s.type)
        attrs[p + "duration"] = float(s.duration)
        attrs[p + "num_points"] = int(s.num_points)
        if s.modulation is not None:
            attrs[p + "frequency"] = float(s.modulation.frequency)
            attrs[p + "amplitude"] = float(s.modulation.amplitude)
            if s.modulation.start_phase is not None:
                attrs[p + "start_phase"] = float(s.modulation.start_phase)
    return attrs


@dataclass(frozen=True, eq=False)
class _Block:
    """Decoded curves before they become a dataset (:func:`jpk_to_curves` flattens them).

    ``cols`` holds one array per segment of every curve, in order (``time``, ``force``,
    ``height``, ``deflection``) and, under ``segment``, the segment-table row of each;
    ``table`` the segment table as lists; ``counts`` and ``baselines`` one entry per curve;
    ``attrs`` the file attributes. Also read by :mod:`viscoforce.experiments.modulation`, which
    demodulates the segments as they are instead of a flattened dataset.
    """

    picked: list[int]
    decoded: list[JPKCurve]
    height: str
    cols: dict[str, list[Any]]
    table: dict[str, list[Any]]
    counts: list[int]
    baselines: list[float]
    attrs: dict[str, Any]


def _read_block(archive: JPKArchive, curves: int | Iterable[int] | None,
                height_channel: str | None) -> _Block:
    """Decode and check the selected curves (see :func:`jpk_to_curves` for the errors)."""
    if not isinstance(archive, JPKArchive):
        raise ParameterError(f"archive must be a JPKArchive (from read_jpk), got "
                             f"{type(archive).__name__}")
    check_height_channel(height_channel)
    picked = _select(archive, curves)
    units = [archive._units(i) for i in picked]  # from the headers, before any decoding
    if height_channel is None:  # the other heights are not decoded
        height = _default_height(units)
    else:
        missing = [f"curve {i} segment {k}" for i, curve in zip(picked, units, strict=True)
                   for k, segment in enumerate(curve) if height_channel not in segment]
        if missing:
            raise ParameterError(f"height_channel {height_channel!r} is missing in "
                                 f"{', '.join(missing[:5])}")
        height = height_channel
    keep = frozenset(("vDeflection", height))
    decoded = [archive._curve_only(i, keep) for i in picked]  # through the archive's one zip

    cols: dict[str, list[Any]] = {"time": [], "force": [], "height": [], "deflection": [],
                                 "segment": []}
    table: dict[str, list[Any]] = {k: [] for k in (
        "name", "type", "style", "curve", "index", "start_time", "duration", "num_points",
        "frequency", "amplitude", "baseline")}
    counts, baselines = [], []
    for row, curve in enumerate(decoded):
        n_curve = 0
        for seg in curve.segments:
            n = int(seg.num_points)
            force = _require(seg, curve, "force", "N", archive.path)
            defl = _require(seg, curve, "vDeflection", "m", archive.path)
            h = _require(seg, curve, height, "m", archive.path)
            if not force.size == defl.size == h.size == n:
                raise InstrumentFormatError(
                    f"curve {curve.index} segment {seg.index}: channel lengths force {force.size}, "
                    f"vDeflection {defl.size}, {height} {h.size} differ from num-points {n}")
            cols["time"].append(seg.time)  # start_time + i * duration / num_points
            cols["force"].append(force)
            cols["deflection"].append(defl)
            cols["height"].append(h)
            cols["segment"].append(len(table["name"]))
            mod = seg.modulation
            table["name"].append(segment_name(seg.style, seg.type))
            table["type"].append(seg.type)
            table["style"].append(seg.style)
            table["curve"].append(row)
            table["index"].append(seg.index)
            table["start_time"].append(float(seg.start_time))
            table["duration"].append(float(seg.duration))
            table["num_points"].append(n)
            table["frequency"].append(math.nan if mod is None else float(mod.frequency))
            table["amplitude"].append(math.nan if mod is None else float(mod.amplitude))
            table["baseline"].append(_nan(seg.baseline))
            n_curve += n
        counts.append(n_curve)
        known = [s.baseline for s in curve.segments if s.baseline is not None]
        baselines.append(float(known[0]) if known else math.nan)

    return _Block(picked=picked, decoded=decoded, height=height, cols=cols, table=table,
                  counts=counts, baselines=baselines,
                  attrs=_file_attrs(archive, decoded[0], height))


def jpk_to_curves(archive: JPKArchive, *, curves: int | Iterable[int] | None = None,
                  height_channel: str | None = None) -> xr.Dataset:
    """The schema curves dataset of all (or the selected) curves of a JPK archive.

    See the module docstring for every variable and attribute.

    Parameters
    ----------
    archive : JPKArchive
        An archive opened by :func:`viscoforce.io.jpk.read_jpk`.
    curves : int or iterable of int, optional
        Indices of the curves to convert (negative count from the end; each curve once);
        default all.
    height_channel : str, optional
        Force one of :data:`HEIGHT_CHANNELS`; default the first of them present in every
        segment of every selected curve.

    Returns
    -------
    xarray.Dataset
        Valid under :func:`viscoforce.schema.validate_curves`; ``attrs["height_channel"]`` names
        the height used.

    Raises
    ------
    ParameterError
        If ``archive`` is not a JPKArchive, ``curves`` is malformed, out of range or repeats
        a curve, or ``height_channel`` is unknown (refused before anything is decoded) or
        missing somewhere.
    InstrumentFormatError
        If a segment lacks a calibrated ``vDeflection``/``force`` or any height channel.
    """
    block = _read_block(archive, curves, height_channel)
    cols, table, decoded = block.cols, block.table, block.decoded
    flat = {k: np.concatenate(v) for k, v in cols.items() if k != "segment"}
    flat["segment"] = np.repeat(np.asarray(cols["segment"], dtype=np.int32),
                                np.asarray(table["num_points"], dtype=np.intp))
    per_curve = {"x": [c.x for c in decoded], "y": [c.y for c in decoded],
                 "spring_constant": [c.spring_constant for c in decoded],
                 "sensitivity": [c.sensitivity for c in decoded],
                 "row": np.asarray([c.row for c in decoded], dtype=np.int32),
                 "column": np.asarray([c.column for c in decoded], dtype=np.int32),
                 "x_raw": [c.x_raw for c in decoded], "y_raw": [c.y_raw for c in decoded]}
    ds = make_curves(flat["time"], flat["force"], flat["height"], flat["deflection"],
                     segment=flat["segment"], segment_names=table["name"],
                     segment_types=table["type"], sample_count=block.counts,
                     per_curve=per_curve,
                     attrs=block.attrs, source="jpk")
    seg_dim = ("segment_table",)
    extra = {
        "baseline": (("curve",), np.asarray(block.baselines, dtype=float),
                     {"units": "N", "long_name": "free-cantilever force baseline from the file "
                                                 "(not subtracted from force)"}),
        "segment_style": (seg_dim, np.asarray(table["style"], dtype=str),
                          {"long_name": "segment style as the file names it"}),
        "segment_curve": (seg_dim, np.asarray(table["curve"], dtype=np.int32),
                          {"units": "1", "long_name": "row of the curve dim the segment belongs to"}),
        "segment_index": (seg_dim, np.asarray(table["index"], dtype=np.int32),
                          {"units": "1", "long_name": "segment number within its curve"}),
        "segment_start_time": (seg_dim, np.asarray(table["start_time"]),
                               {"units": "s", "long_name": "segment start from the curve start"}),
        "segment_duration": (seg_dim, np.asarray(table["duration"]),
                             {"units": "s", "long_name": "segment duration"}),
        "segment_num_points": (seg_dim, np.asarray(table["num_points"], dtype=np.int32),
                               {"units": "1", "long_name": "number of samples of the segment"}),
        "segment_frequency": (seg_dim, np.asarray(table["frequency"]),
                              {"units": "Hz", "long_name": "modulation frequency (nominal)"}),
        "segment_amplitude": (seg_dim, np.asarray(table["amplitude"]),
                              {"units": "m", "long_name": "modulation amplitude (nominal drive)"}),
        "segment_baseline": (seg_dim, np.asarray(table["baseline"]),
                             {"units": "N", "long_name": "free-cantilever force baseline"}),
    }
    ds = ds.assign(extra).assign_coords(
        curve=("curve", np.asarray(block.picked, dtype=np.int32),
               {"units": "1", "long_name": "index of the curve in the archive"}))
    return validate_curves(ds)
