"""Shared machinery of the drives in :mod:`viscoforce.experiments.drives`.

The abstract base class ``_Drive`` (holds outside [0, duration], right-sided velocity, shape and
finiteness checks of the times) and the small helpers every drive uses: ``_si`` formats a value
with an SI prefix for ``describe()``, ``_as_time`` checks the times [s], and ``_endpoints`` gives
the breakpoints 0 and duration.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._typing import FloatArray
from viscoforce.exceptions import ParameterError

_PREFIXES = ((1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"), (1e-12, "p"),
             (1e-15, "f"))


def _si(value: float, unit: str) -> str:
    """Format ``value`` [unit] with an SI prefix, 4 significant digits and a true minus sign."""
    if value == 0:
        return f"0 {unit}"
    magnitude = abs(value)
    scale, prefix = _PREFIXES[-1]
    for s, p in _PREFIXES:
        if magnitude >= s * (1 - 1e-9):
            scale, prefix = s, p
            break
    text = f"{value / scale:.4g}".replace("-", "\u2212")
    return f"{text} {prefix}{unit}"


def _as_time(t: ArrayLike) -> FloatArray:
    """Return ``t`` [s] as a float array (0-d for a scalar); raise unless all entries are finite."""
    bad = t is None or isinstance(t, dict | str | bytes)
    try:
        bad = bad or np.iscomplexobj(t)  # a complex time would lose its imaginary part
        arr = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        bad = True
    if bad:
        raise ParameterError(f"t must be real times [s], got {t!r}")
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f"t must be finite, got {t!r}")
    return arr


class _Drive(ABC):
    """Shared machinery of the drives: holds outside [0, duration] and the right-sided velocity.

    Subclasses are frozen dataclasses that provide ``duration`` [s] (a field or a property),
    ``start_position`` and ``end_position`` [m], the position and velocity on the active interval,
    ``breakpoints``, ``extent`` and ``describe``.
    """

    __slots__ = ()

    @property
    @abstractmethod
    def start_position(self) -> float:
        """Position h0(0) [m]; held for t < 0."""

    @property
    @abstractmethod
    def end_position(self) -> float:
        """Position h0(duration) [m]; held for t > duration."""

    @abstractmethod
    def _position_active(self, t: FloatArray) -> FloatArray:
        """Position [m] at 1-D times ``t`` strictly inside (0, duration) [s]."""

    @abstractmethod
    def _velocity_active(self, t: FloatArray) -> FloatArray:
        """Right-sided velocity [m/s] at 1-D times ``t`` in [0, duration) [s]."""

    @abstractmethod
    def breakpoints(self) -> FloatArray:
        """Return the sorted times [s] in [0, duration] where the velocity may jump (incl. ends)."""

    @abstractmethod
    def extent(self) -> tuple[float, float]:
        """Return the smallest and largest position (min, max) [m] over [0, duration]."""

    def min_steps(self) -> int:
        """Return a lower bound on the time steps any accurate stepper needs over [0, duration].

        Piecewise-linear drives: the number of breakpoints (a stepper lands on every one).
        """
        return int(np.asarray(self.breakpoints()).size)

    @abstractmethod
    def describe(self) -> str:
        """Return a one-line summary of the drive with units."""

    def position(self, t: ArrayLike) -> FloatArray:
        """Position h0(t) [m].

        Parameters
        ----------
        t : float or array_like
            Times [s]; the drive holds ``start_position`` for t <= 0 and ``end_position`` for
            t >= ``duration``.

        Returns
        -------
        numpy.ndarray
            Positions [m], same shape as ``t`` (0-d for a scalar).
        """
        tt = _as_time(t)
        duration = self.duration  # type: ignore[attr-defined]
        before = tt <= 0.0
        after = tt >= duration
        inside = ~(before | after)
        out = np.empty(tt.shape, dtype=float)
        out[before] = self.start_position
        out[after] = self.end_position
        if np.any(inside):
            out[inside] = self._position_active(np.atleast_1d(tt[inside]))
        return out

    def velocity(self, t: ArrayLike) -> FloatArray:
        """Drive velocity dh0/dt [m/s], right-sided at kinks and 0 outside [0, duration).

        Parameters
        ----------
        t : float or array_like
            Times [s].

        Returns
        -------
        numpy.ndarray
            Velocities [m/s], same shape as ``t`` (0-d for a scalar).
        """
        tt = _as_time(t)
        active = (tt >= 0.0) & (tt < self.duration)  # type: ignore[attr-defined]
        out = np.zeros(tt.shape, dtype=float)
        if np.any(active):
            out[active] = self._velocity_active(np.atleast_1d(tt[active]))
        return out


def _endpoints(duration: float) -> FloatArray:
    return np.array([0.0, duration])
