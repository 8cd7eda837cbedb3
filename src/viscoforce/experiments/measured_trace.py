"""A measured (arbitrary) position trace h0(t) as a drive: :class:`MeasuredTrace`.

The trace is checked (at least 2 samples, strictly increasing finite times, finite positions of
the same length), shifted to start at t = 0 and interpolated piecewise-linearly or, with
``smooth=True``, by a monotone cubic (PCHIP). It follows the drive conventions described in
:mod:`viscoforce.experiments.drives`, which re-exports it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from viscoforce._typing import FloatArray
from viscoforce._validation import as_float_1d, require_increasing
from viscoforce.exceptions import ParameterError
from viscoforce.experiments._drive_base import _Drive, _endpoints, _si

if TYPE_CHECKING:
    from scipy.interpolate import PchipInterpolator

__all__ = ["MeasuredTrace"]


@dataclass(frozen=True, eq=False)
class MeasuredTrace(_Drive):
    """An arbitrary (e.g. measured) position trace, interpolated between its samples.

    The time axis is shifted to start at 0; the original first time is kept as ``time_offset``.
    By default the trace is piecewise linear: the velocity is piecewise constant (right-sided at
    the samples) and every sample time is a breakpoint. With ``smooth=True`` a monotone cubic
    (PCHIP) interpolant is used instead: C¹, no overshoot beyond the samples, and breakpoints only
    at 0 and the end. The arrays are stored read-only; equality and hashing are by identity.

    Parameters
    ----------
    time : array_like
        Sample times [s], strictly increasing, at least 2 samples.
    h0 : array_like
        Positions h0 at those times [m], finite, same length as ``time``.
    smooth : bool, optional
        Use a C¹ monotone cubic interpolant instead of piecewise-linear (default False).
    """

    time: FloatArray
    h0: FloatArray
    smooth: bool = False
    time_offset: float = field(init=False)
    _interpolant: PchipInterpolator | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        time = as_float_1d("time", self.time, min_size=2)
        time = require_increasing("time", time)
        position = as_float_1d("h0", self.h0, min_size=2)
        if position.size != time.size:
            raise ParameterError(
                f"h0 must have the same length as time ({time.size}), "
                f"got {position.size}")
        if not isinstance(self.smooth, bool | np.bool_):
            raise ParameterError(f"smooth must be True or False, got {self.smooth!r}")
        offset = float(time[0])
        shifted = np.array(time - offset, dtype=float)
        require_increasing("time (after shifting to start at 0)", shifted)
        position = np.array(position, dtype=float)  # own copy: the caller's array stays as is
        shifted.flags.writeable = False
        position.flags.writeable = False
        interpolant = None
        if self.smooth:
            from scipy.interpolate import PchipInterpolator  # only smooth traces need scipy here

            interpolant = PchipInterpolator(shifted, position)
        object.__setattr__(self, "time", shifted)
        object.__setattr__(self, "h0", position)
        object.__setattr__(self, "smooth", bool(self.smooth))
        object.__setattr__(self, "time_offset", offset)
        object.__setattr__(self, "_interpolant", interpolant)

    @property
    def duration(self) -> float:
        """Duration of the trace [s] (last shifted sample time)."""
        return float(self.time[-1])

    @property
    def start_position(self) -> float:
        """First sample [m]."""
        return float(self.h0[0])

    @property
    def end_position(self) -> float:
        """Last sample [m]."""
        return float(self.h0[-1])

    def _position_active(self, t: FloatArray) -> FloatArray:
        if self._interpolant is not None:
            return np.asarray(self._interpolant(t), dtype=float)
        return np.interp(t, self.time, self.h0)

    def _velocity_active(self, t: FloatArray) -> FloatArray:
        if self._interpolant is not None:
            return np.asarray(self._interpolant(t, 1), dtype=float)
        slopes = np.diff(self.h0) / np.diff(self.time)
        idx = np.searchsorted(self.time, t, side="right") - 1
        return slopes[np.clip(idx, 0, slopes.size - 1)]

    def breakpoints(self) -> FloatArray:
        """Return all sample times [s] (piecewise linear), or 0 and duration (``smooth=True``)."""
        if self.smooth:
            return _endpoints(self.duration)
        return np.array(self.time)

    def min_steps(self) -> int:
        """Return the number of samples (one step per sample interval, smooth or not)."""
        return int(self.time.size)

    def extent(self) -> tuple[float, float]:
        """Return the (min, max) position over [0, duration] [m]: the extreme samples."""
        return (float(np.min(self.h0)), float(np.max(self.h0)))

    def describe(self) -> str:
        """Return a one-line summary, e.g. ``"measured trace: 101 samples over 10 ms, …"``."""
        low, high = self.extent()
        kind = "monotone cubic" if self.smooth else "piecewise linear"
        return (f"measured trace: {self.time.size} samples over {_si(self.duration, 's')}, "
                f"{_si(low, 'm')} \u2026 {_si(high, 'm')} ({kind})")
