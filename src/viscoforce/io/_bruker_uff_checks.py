"""UFF calibrations, plausibility checks, tip and metadata (the checks of :mod:`viscoforce.io.bruker`).

The spring constant and inverse optical lever sensitivity, given by the caller (:func:`_option`)
or read from the header (:func:`_calibration`), are refused outside
:data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` / :data:`~viscoforce._limits.SENSITIVITY_RANGE`;
a measured column beyond :data:`~viscoforce.io.quality.PHYSICAL_RANGES` or below its smallest
scale is refused (:func:`_measured`). The header's tip becomes tip attrs when plausible
(:func:`_tip_attrs`), and every header field a ``meta_<key>`` attr (:func:`_meta`).
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np

from viscoforce._limits import (
    SENSITIVITY_RANGE,
    SPRING_CONSTANT_RANGE,
    TIP_HALF_ANGLE_RANGE,
    TIP_RADIUS_RANGE,
)
from viscoforce._validation import require_plausible
from viscoforce.exceptions import InstrumentFormatError, ParameterError
from viscoforce.io._bruker_uff_header import _UNKNOWN, _float_field, _Segment, _Uff
from viscoforce.io.quality import (
    PHYSICAL_RANGES,
    below_scale,
    first_beyond,
    range_text,
    scale_text,
)
from viscoforce.units import parse_quantity

#: largest plausible tip radius [m] (colloid probes reach tens of µm)
_MAX_TIP_RADIUS = 1e-3
_TIP_WORDS = (("pyramid", "pyramid"), ("cone", "cone"), ("conical", "cone"),
              ("sphere", "sphere"), ("spheric", "sphere"), ("colloid", "sphere"),
              ("bead", "sphere"), ("parabol", "paraboloid"), ("flat", "flat"),
              ("cylind", "flat"), ("punch", "flat"))
_K_FIELDS = ("Cantilever_springK_used(N/m)", "Cantilever_springK_read(N/m)")
_S_FIELDS = ("Recording_inv_optical_lever_sens_used(m/V)",
             "Recording_inv_optical_lever_sens_read(m/V)")


def _measured(uff: _Uff, seg: _Segment, title: str, role: str, values: np.ndarray
              ) -> np.ndarray:
    """``values`` [SI] of channel ``role``, refused beyond its physical range or scale."""
    with np.errstate(over="ignore"):  # an overflow is refused here
        values = np.asarray(values, dtype=float)
    where = f"{uff.path}: segment {seg.index} ({seg.code}) column {title!r}"
    i = first_beyond(role, values)
    if i is not None:
        raise InstrumentFormatError(
            f"{where}: sample {i} is {float(values[i]):g} {PHYSICAL_RANGES[role][2]}, beyond the "
            f"physical range {range_text(role)}: the header's unit or calibration, or the data, "
            "are damaged")
    tiny = below_scale(role, values)
    if tiny is not None:
        raise InstrumentFormatError(
            f"{where} is at most {abs(tiny[1]):g} {PHYSICAL_RANGES[role][2]} in magnitude (sample "
            f"{tiny[0]}), below {scale_text(role)}: the header's unit or calibration, or the "
            "data, are damaged")
    return values


def _tip_attrs(fields: dict[str, str]) -> tuple[dict[str, Any], str]:
    """Tip attrs (Tip.as_attrs keys) from the header, and a note on what was not used."""
    geometry = fields.get("Tip_geometry", "").strip().lower()
    shape = next((s for word, s in _TIP_WORDS if word in geometry), None)
    angle = _float_field(fields, "Tip_half_angle(deg)")
    radius = _float_field(fields, "Tip_radius(m)")
    notes = []
    radius_ok = TIP_RADIUS_RANGE[0] <= radius <= _MAX_TIP_RADIUS
    if not math.isnan(radius) and radius != -1 and not radius_ok:
        notes.append(f"Tip_radius(m) = {fields.get('Tip_radius(m)')} is not a plausible tip "
                     f"radius in metres ({TIP_RADIUS_RANGE[0]:g} to {_MAX_TIP_RADIUS:g} m); not "
                     "used")
    if shape is None:
        if geometry not in _UNKNOWN:
            notes.append(f"Tip_geometry {fields.get('Tip_geometry')!r} names no known tip shape")
        return {}, "; ".join(notes)
    if shape in ("cone", "pyramid"):
        low, high = TIP_HALF_ANGLE_RANGE
        if low <= angle <= high:
            return {"tip_shape": shape, "tip_half_angle": angle}, "; ".join(notes)
        notes.append(f"{geometry} tip without a half angle in [{low:g}, {high:g}] degrees "
                     f"(Tip_half_angle(deg) = {fields.get('Tip_half_angle(deg)')!r}); not used")
        return {}, "; ".join(notes)
    if radius_ok:
        return {"tip_shape": shape, "tip_radius": radius}, "; ".join(notes)
    notes.append(f"{geometry} tip without a plausible radius; not used")
    return {}, "; ".join(notes)


def _meta_key(key: str) -> str:
    return "meta_" + re.sub(r"[^0-9A-Za-z]+", "_", key).strip("_").lower()


def _meta(fields: dict[str, str]) -> dict[str, Any]:
    """Every header field as ``meta_<key>``: a finite number as a float, else the text."""
    out: dict[str, Any] = {}
    for key, text in fields.items():
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        out[_meta_key(key)] = value if math.isfinite(value) else text
    return out


#: name → (plausible range, unit, what it is) of the calibrations (:mod:`viscoforce._limits`).
_RANGES = {"spring_constant": (SPRING_CONSTANT_RANGE, "N/m", "spring constant"),
           "sensitivity": (SENSITIVITY_RANGE, "m/V", "inverse optical lever sensitivity")}


def _option(name: str, value: Any, dimension: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise ParameterError(f"{name} must be a number [SI] or a quantity string, got {value!r}")
    out = parse_quantity(value, dimension, name=name) if isinstance(value, str) else float(value)
    if not (math.isfinite(out) and out > 0):
        raise ParameterError(f"{name} must be finite and > 0, got {value!r}")
    bounds, unit, _ = _RANGES[name]
    return require_plausible(name, out, bounds, unit,
                             why=f"given as {value!r}" if isinstance(value, str) else "")


def _calibration(uff: _Uff, keys: tuple[str, ...], user: float | None, name: str
                 ) -> tuple[float, str]:
    """(value, where it came from): the caller's, else the first positive header field.

    A header value outside the plausible range (:data:`_RANGES`) is refused as a corrupt
    header (UFF writes -1 or ``?`` for "not recorded": those are skipped).
    """
    if user is not None:
        return user, name
    (low, high), unit, what = _RANGES[name]
    for key in keys:
        value = _float_field(uff.fields, key)
        if value > 0:
            if not low <= value <= high:
                flag = "--" + name.replace("_", "-")
                raise InstrumentFormatError(
                    f"{uff.path}: the header's {what} {key} = {uff.fields[key]} is outside the "
                    f"plausible range [{low:g}, {high:g}] {unit} ({name}): a corrupt header; "
                    f"pass the right value as {name} (CLI: {flag})")
            return value, key
    return math.nan, ""
