"""Calibration and sample checks of the afmformats readers (for :mod:`viscoforce.io.afm`).

A calibration in the file, or given by the caller, is refused outside
:data:`~viscoforce._limits.SPRING_CONSTANT_RANGE` / :data:`~viscoforce._limits.SENSITIVITY_RANGE`;
a non-finite sample, a sample beyond :data:`~viscoforce.io.quality.PHYSICAL_RANGES` or a channel
whose every sample is below its smallest scale is refused, the message naming the file (and
member), the curve, the segment and the channel.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from viscoforce import _limits
from viscoforce._validation import require_plausible, require_positive
from viscoforce.exceptions import InstrumentFormatError
from viscoforce.io.quality import (
    PHYSICAL_RANGES,
    below_scale,
    first_beyond,
    range_text,
    scale_text,
)


def _finite_or_nan(value: Any) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        return math.nan
    return x if math.isfinite(x) else math.nan


_CALIBRATIONS = {"spring constant": ("spring_constant", "N/m", "SPRING_CONSTANT_RANGE"),
                 "sensitivity": ("sensitivity", "m/V", "SENSITIVITY_RANGE")}


def _file_calibration(meta: dict[str, Any], key: str, where: str, check: bool) -> float:
    """The file's calibration ``key`` (NaN when absent); refused outside its plausible range."""
    value = meta.get(key)
    if value is None or not check:
        return _finite_or_nan(value)
    name, unit, limits = _CALIBRATIONS[key]
    low, high = getattr(_limits, limits)
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not low <= number <= high:  # also NaN and text
        raise InstrumentFormatError(
            f"{where}: the file's {key} is {value!r} {unit}, outside the plausible range "
            f"[{low:g}, {high:g}] {unit} ({name}): a corrupt header")
    return number


def _require_finite_samples(values: np.ndarray, channel: str, where: str, index: int,
                            table: list[tuple[str, str]], local: np.ndarray) -> None:
    """Refuse NaN / inf samples, naming the file (and member), curve, segment and channel."""
    finite = np.isfinite(values)
    if finite.all():
        return
    bad = np.flatnonzero(~finite)
    segment = table[int(local[bad[0]])][0]
    raise InstrumentFormatError(
        f"{where}: curve {index}, segment {segment!r}, channel '{channel}': {bad.size} of "
        f"{values.size} samples are not finite (first: sample {bad[0]} = {float(values[bad[0]])})")


def _require_physical(values: np.ndarray, channel: str, where: str, index: int) -> None:
    """Refuse samples beyond the channel's physical range, or a channel below its scale."""
    unit = PHYSICAL_RANGES[channel][2]
    i = first_beyond(channel, values)
    if i is not None:
        raise InstrumentFormatError(
            f"{where}: curve {index}, channel '{channel}': sample {i} is {float(values[i]):g} "
            f"{unit}, beyond the physical range {range_text(channel)}: the file's calibration "
            "or its data are damaged")
    tiny = below_scale(channel, values)
    if tiny is not None:
        raise InstrumentFormatError(
            f"{where}: curve {index}, channel '{channel}': every sample is at most "
            f"{abs(tiny[1]):g} {unit} in magnitude (sample {tiny[0]}), below "
            f"{scale_text(channel)}: the file's calibration or its data are damaged")


def _optional_calibration(name: str, value: Any, unit: str, limits: tuple[float, float]
                          ) -> float | None:
    """None, or ``value`` when positive and within ``limits`` (else ParameterError)."""
    if value is None:
        return None
    return require_plausible(name, require_positive(name, value), limits, unit)
