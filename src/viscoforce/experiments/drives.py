"""Prescribed trajectories h0(t) of the sphere's apex: hold, ramp, step, triangle, sinusoid, ...

Every drive is a frozen dataclass that satisfies :class:`viscoforce._typing.SeparationHistory`:

- ``position(t)`` [m] and ``velocity(t)`` [m/s] accept a scalar or an array of times [s] and return
  a float array of the same shape (a 0-d array for a scalar, so ``float(drive.position(0.1))``
  works);
- every drive starts at t = 0 and ends at ``duration`` [s]; it holds its initial position for
  t < 0 and its final position for t > ``duration``;
- ``velocity(t)`` is the exact derivative of ``position(t)``; at a kink it is right-sided (the
  velocity of the piece that starts there) and it is 0 outside [0, duration);
- ``breakpoints()`` lists the times [s] in [0, duration] where the velocity may jump (always
  including 0 and ``duration``), so that a time stepper can land on them;
- ``min_steps()`` -> int is a cheap lower bound on the number of time steps any accurate stepper
  needs over [0, duration], computed without building anything (solvers refuse runs beyond their
  effort limits up front with it): the number of breakpoints for the piecewise-linear drives
  (``Hold``, ``Ramp``, ``Step``, ``Triangle``; the number of samples for ``MeasuredTrace``, also
  when smooth), plus ``STEPS_PER_PERIOD`` (8) per period for ``Sinusoid``, and the sum over the
  segments for ``Sequence``;
- ``start_position`` / ``end_position`` [m], ``extent()`` -> (min, max) position over
  [0, duration] [m] (solvers size the radial grid on the deepest position), and ``describe()``,
  a one-line summary with units.

Positions follow the package convention: h0 is the undeformed apex separation and may be negative.

The shared base class lives in :mod:`viscoforce.experiments._drive_base` and the measured trace in
:mod:`viscoforce.experiments.measured_trace`; :class:`MeasuredTrace` is re-exported here.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from viscoforce._typing import FloatArray
from viscoforce._validation import require_finite, require_positive
from viscoforce.exceptions import ParameterError
from viscoforce.experiments._drive_base import _Drive, _endpoints, _si
from viscoforce.experiments.measured_trace import MeasuredTrace

__all__ = ["Hold", "Ramp", "Step", "Triangle", "Sinusoid", "Sequence", "MeasuredTrace"]

# Continuity tolerance of Sequence: |start_k - end_{k-1}| <= _ABS_TOL + _REL_TOL * scale [m].
_ABS_TOL = 1e-15
_REL_TOL = 1e-9

#: Fewest time steps per period of a sinusoid any accurate stepper takes (used by min_steps).
STEPS_PER_PERIOD = 8


class _LinearMove(_Drive):
    """Constant-velocity move from ``start`` to ``end`` over ``duration``: Ramp and Step.

    Subclasses are frozen dataclasses with ``start`` and ``end`` [m] fields and a ``duration`` [s]
    (a field or a property).
    """

    __slots__ = ()
    start: float
    end: float
    duration: float

    @property
    def start_position(self) -> float:
        """Position at t = 0 [m]."""
        return self.start

    @property
    def end_position(self) -> float:
        """Position at t = duration [m]."""
        return self.end

    def _position_active(self, t: FloatArray) -> FloatArray:
        return self.start + (self.end - self.start) * (t / self.duration)

    def _velocity_active(self, t: FloatArray) -> FloatArray:
        return np.full(t.shape, (self.end - self.start) / self.duration)

    def breakpoints(self) -> FloatArray:
        """Return the kink times [s]: 0 and duration."""
        return _endpoints(self.duration)

    def extent(self) -> tuple[float, float]:
        """Return the (min, max) position over [0, duration] [m]."""
        return (min(self.start, self.end), max(self.start, self.end))


@dataclass(frozen=True)
class Hold(_Drive):
    """Hold a constant position.

    Parameters
    ----------
    h0 : float
        Position h0 held [m] (may be negative).
    duration : float
        How long it is held [s], > 0.
    """

    h0: float
    duration: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "h0", require_finite("h0", self.h0))
        object.__setattr__(self, "duration", require_positive("duration", self.duration))

    @property
    def start_position(self) -> float:
        """Position at t = 0 [m]."""
        return self.h0

    @property
    def end_position(self) -> float:
        """Position at t = duration [m]."""
        return self.h0

    def _position_active(self, t: FloatArray) -> FloatArray:
        return np.full(t.shape, self.h0)

    def _velocity_active(self, t: FloatArray) -> FloatArray:
        return np.zeros(t.shape)

    def breakpoints(self) -> FloatArray:
        """Return the kink times [s]: 0 and duration."""
        return _endpoints(self.duration)

    def extent(self) -> tuple[float, float]:
        """Return the (min, max) position over [0, duration] [m]: both equal ``h0``."""
        return (self.h0, self.h0)

    def describe(self) -> str:
        """Return a one-line summary, e.g. ``"hold −5 nm for 1 ms"``."""
        return f"hold {_si(self.h0, 'm')} for {_si(self.duration, 's')}"


@dataclass(frozen=True)
class Ramp(_LinearMove):
    """Move linearly from ``start`` to ``end`` in ``duration``.

    Parameters
    ----------
    start : float
        Initial position [m].
    end : float
        Final position [m].
    duration : float
        Duration of the ramp [s], > 0.
    """

    start: float
    end: float
    duration: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", require_finite("start", self.start))
        object.__setattr__(self, "end", require_finite("end", self.end))
        object.__setattr__(self, "duration", require_positive("duration", self.duration))

    @classmethod
    def from_speed(cls, start: float, end: float, speed: float) -> Ramp:
        """Build a ramp that moves at constant speed; duration = |end − start| / speed.

        Parameters
        ----------
        start : float
            Initial position [m].
        end : float
            Final position [m], different from ``start``.
        speed : float
            Speed magnitude [m/s], > 0 (the direction follows from ``start`` and ``end``).

        Returns
        -------
        Ramp
            The ramp.
        """
        start = require_finite("start", start)
        end = require_finite("end", end)
        speed = require_positive("speed", speed)
        if start == end:
            raise ParameterError(
                f"end must differ from start for a ramp at given speed, got start = end = {start!r}"
                " (use Hold for a constant position)")
        duration = abs(end - start) / speed
        if not (math.isfinite(duration) and duration > 0):
            raise ParameterError(
                f"|end - start| / speed must be a finite duration > 0 [s], got {duration!r}")
        return cls(start, end, duration)

    @property
    def speed(self) -> float:
        """Signed velocity (end − start)/duration [m/s]."""
        return (self.end - self.start) / self.duration

    def describe(self) -> str:
        """Return a one-line summary, e.g. ``"ramp −5 nm → −7 nm in 1 ms (−2 µm/s)"``."""
        return (f"ramp {_si(self.start, 'm')} \u2192 {_si(self.end, 'm')} in "
                f"{_si(self.duration, 's')} ({_si(self.speed, 'm/s')})")


@dataclass(frozen=True)
class Step(_LinearMove):
    """A fast linear move from ``start`` to ``end`` taking ``rise_time`` (duration = rise_time).

    The paper's Fig. 1 steps take 0.1 ms (the default). A step is a short ramp: the solvers need
    a finite rise time because the drive velocity enters the rate equation.

    Parameters
    ----------
    start : float
        Initial position [m].
    end : float
        Final position [m].
    rise_time : float
        Duration of the move [s], > 0 (default 1e-4).
    """

    start: float
    end: float
    rise_time: float = 1e-4

    def __post_init__(self) -> None:
        object.__setattr__(self, "start", require_finite("start", self.start))
        object.__setattr__(self, "end", require_finite("end", self.end))
        object.__setattr__(self, "rise_time", require_positive("rise_time", self.rise_time))

    @property
    def duration(self) -> float:
        """Duration of the drive [s] (= rise_time)."""
        return self.rise_time

    def describe(self) -> str:
        """Return a one-line summary, e.g. ``"step −5 nm → −7 nm (rise time 100 µs)"``."""
        return (f"step {_si(self.start, 'm')} \u2192 {_si(self.end, 'm')} "
                f"(rise time {_si(self.rise_time, 's')})")


@dataclass(frozen=True)
class Triangle(_Drive):
    """Go from ``top`` to ``turn`` and back to ``top`` at constant speed magnitude.

    The paper's Figs. 5–8 use ``Triangle(10e-9, -10e-9, speed)`` (load, then unload).

    Parameters
    ----------
    top : float
        Initial and final position [m].
    turn : float
        Turning position [m], different from ``top``.
    speed : float
        Speed magnitude on both legs [m/s], > 0.
    """

    top: float
    turn: float
    speed: float

    def __post_init__(self) -> None:
        top = require_finite("top", self.top)
        turn = require_finite("turn", self.turn)
        speed = require_positive("speed", self.speed)
        if top == turn:
            raise ParameterError(f"turn must differ from top, got top = turn = {top!r}")
        if not math.isfinite(2 * abs(top - turn) / speed):
            raise ParameterError(
                f"speed must give a finite duration 2|top - turn|/speed, got speed = {speed!r}")
        object.__setattr__(self, "top", top)
        object.__setattr__(self, "turn", turn)
        object.__setattr__(self, "speed", speed)

    @property
    def turning_time(self) -> float:
        """Time at which the drive reaches ``turn`` [s] (= |top − turn| / speed)."""
        return abs(self.top - self.turn) / self.speed

    @property
    def duration(self) -> float:
        """Duration of the drive [s] (= 2|top − turn| / speed)."""
        return 2.0 * self.turning_time

    @property
    def start_position(self) -> float:
        """Position at t = 0 [m] (= top)."""
        return self.top

    @property
    def end_position(self) -> float:
        """Position at t = duration [m] (= top)."""
        return self.top

    def _position_active(self, t: FloatArray) -> FloatArray:
        t_turn = self.turning_time
        distance_from_turn = np.abs(t - t_turn) / t_turn  # 1 at the ends, 0 at the turn
        return self.turn + (self.top - self.turn) * distance_from_turn

    def _velocity_active(self, t: FloatArray) -> FloatArray:
        out_velocity = math.copysign(self.speed, self.turn - self.top)
        return np.where(t < self.turning_time, out_velocity, -out_velocity)

    def breakpoints(self) -> FloatArray:
        """Return the kink times [s]: 0, the turning time, and duration."""
        return np.array([0.0, self.turning_time, self.duration])

    def extent(self) -> tuple[float, float]:
        """Return the (min, max) position over [0, duration] [m]."""
        return (min(self.top, self.turn), max(self.top, self.turn))

    def describe(self) -> str:
        """Return a one-line summary, e.g. ``"triangle 10 nm → −10 nm → 10 nm at 5 µm/s"``."""
        top = _si(self.top, "m")
        return (f"triangle {top} \u2192 {_si(self.turn, 'm')} \u2192 {top} at "
                f"{_si(self.speed, 'm/s')}")


@dataclass(frozen=True)
class Sinusoid(_Drive):
    """Oscillate as h0(t) = h0 + eta·sin(ωt) for a whole or fractional number of periods.

    It starts at ``h0`` with velocity eta·ω, so t = 0 is a kink relative to a hold before
    it. Give exactly one of ``periods`` and ``duration``; at least one full period is required.

    Parameters
    ----------
    h0 : float
        Mean position h̄0 [m].
    eta : float
        Drive amplitude η [m], > 0.
    omega : float
        Angular frequency ω [rad/s], > 0.
    periods : float, optional
        Number of periods (>= 1, need not be an integer); duration = periods·2π/ω.
    duration : float, optional
        Duration [s], at least one period 2π/ω; periods = duration·ω/2π.
    """

    h0: float
    eta: float
    omega: float
    periods: float | None = None
    duration: float | None = None

    def __post_init__(self) -> None:
        position = require_finite("h0", self.h0)
        eta = require_positive("eta", self.eta)
        omega = require_positive("omega", self.omega)
        period = 2.0 * math.pi / omega
        if (self.periods is None) == (self.duration is None):
            raise ParameterError(
                "give exactly one of periods and duration, got "
                f"periods={self.periods!r}, duration={self.duration!r}")
        if self.periods is not None:
            periods = require_finite("periods", self.periods)
            if periods < 1:
                raise ParameterError(f"periods must be >= 1, got {self.periods!r}")
            duration = periods * period
        else:
            duration = require_positive("duration", self.duration)
            if duration < period * (1 - 1e-12):
                raise ParameterError(
                    f"duration must be >= one period 2π/omega = {period!r} s, "
                    f"got {self.duration!r}")
            periods = duration / period
        if not math.isfinite(duration):
            raise ParameterError(
                f"periods·2π/omega must be a finite duration [s], got {duration!r}")
        object.__setattr__(self, "h0", position)
        object.__setattr__(self, "eta", eta)
        object.__setattr__(self, "omega", omega)
        object.__setattr__(self, "periods", periods)
        object.__setattr__(self, "duration", duration)

    @property
    def start_position(self) -> float:
        """Position at t = 0 [m] (= the mean position)."""
        return self.h0

    @property
    def end_position(self) -> float:
        """Position at t = duration [m]."""
        return self.h0 + self.eta * math.sin(self.omega * self.duration)

    def _position_active(self, t: FloatArray) -> FloatArray:
        return self.h0 + self.eta * np.sin(self.omega * t)

    def _velocity_active(self, t: FloatArray) -> FloatArray:
        return self.eta * self.omega * np.cos(self.omega * t)

    def breakpoints(self) -> FloatArray:
        """Return the kink times [s]: 0 and duration (jumps from/to the holds around it)."""
        return _endpoints(self.duration)

    def min_steps(self) -> int:
        """Return the breakpoints (2) plus ``STEPS_PER_PERIOD`` (8) steps per period played."""
        return 2 + math.ceil(STEPS_PER_PERIOD * self.periods)

    def extent(self) -> tuple[float, float]:
        """Return the (min, max) position [m]: h0 ∓ eta (>= one full period is played)."""
        return (self.h0 - self.eta, self.h0 + self.eta)

    def describe(self) -> str:
        """Return a one-line summary, e.g. ``"sinusoid −5 nm + 100 pm·sin(ωt), …"``."""
        return (f"sinusoid {_si(self.h0, 'm')} + {_si(self.eta, 'm')}·sin(ωt), "
                f"ω = {self.omega:.4g} rad/s, {self.periods:.4g} periods "
                f"({_si(self.duration, 's')})")


@dataclass(frozen=True)
class Sequence(_Drive):
    """Play drives one after the other; each segment starts where the previous one ended.

    Parameters
    ----------
    segments : tuple of drives
        The drives (``Hold``, ``Ramp``, ``Step``, ``Triangle``, ``Sinusoid``, ``MeasuredTrace``
        or ``Sequence``), at least one. Segment k must start where segment k−1 ends, within
        1e-15 m + 1e-9·|position|.
    """

    segments: tuple[_Drive, ...]
    _offsets: FloatArray = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        try:
            segments = tuple(self.segments)
        except TypeError:
            raise ParameterError(
                f"segments must be a sequence of drives, got {self.segments!r}") from None
        if not segments:
            raise ParameterError("segments must contain at least one drive, got none")
        for k, seg in enumerate(segments):
            if not isinstance(seg, _Drive):
                raise ParameterError(
                    f"segments[{k}] must be a drive (Hold, Ramp, Step, Triangle, Sinusoid, "
                    f"MeasuredTrace or Sequence), got {seg!r}")
        for k in range(1, len(segments)):
            previous_end = segments[k - 1].end_position
            start = segments[k].start_position
            tol = _ABS_TOL + _REL_TOL * max(abs(previous_end), abs(start))
            if abs(start - previous_end) > tol:
                raise ParameterError(
                    f"segments[{k}] must start where segments[{k - 1}] ends "
                    f"({previous_end!r} m, tolerance {tol:.3g} m), got start {start!r} m")
        durations = np.array([seg.duration for seg in segments])  # type: ignore[attr-defined]
        offsets = np.concatenate(([0.0], np.cumsum(durations)))
        offsets.flags.writeable = False
        object.__setattr__(self, "segments", segments)
        object.__setattr__(self, "_offsets", offsets)

    @property
    def duration(self) -> float:
        """Total duration [s] (sum of the segment durations)."""
        return float(self._offsets[-1])

    @property
    def start_times(self) -> FloatArray:
        """Time [s] at which each segment starts (read-only array, one per segment)."""
        return self._offsets[:-1]

    @property
    def start_position(self) -> float:
        """Position at t = 0 [m] (start of the first segment)."""
        return self.segments[0].start_position

    @property
    def end_position(self) -> float:
        """Position at t = duration [m] (end of the last segment)."""
        return self.segments[-1].end_position

    def _segment_index(self, t: FloatArray) -> np.ndarray:
        # side="right": a time equal to a segment's start belongs to that segment (right-sided)
        idx = np.searchsorted(self._offsets[:-1], t, side="right") - 1
        return np.clip(idx, 0, len(self.segments) - 1)

    def _per_segment(self, t: FloatArray,
                     evaluate: Callable[[_Drive, FloatArray], FloatArray]) -> FloatArray:
        """Return ``evaluate(segment, local time [s])`` at each of the 1-D times ``t`` [s]."""
        idx = self._segment_index(t)
        out = np.empty(t.shape)
        for k, seg in enumerate(self.segments):
            mask = idx == k
            if np.any(mask):
                out[mask] = evaluate(seg, t[mask] - self._offsets[k])
        return out

    def _position_active(self, t: FloatArray) -> FloatArray:
        return self._per_segment(t, lambda seg, local: seg.position(local))

    def _velocity_active(self, t: FloatArray) -> FloatArray:
        def velocity(seg: _Drive, local: FloatArray) -> FloatArray:
            # keep rounding of t - offset from landing on the segment's end (velocity 0 there)
            end = np.nextafter(seg.duration, 0.0)  # type: ignore[attr-defined]
            return seg.velocity(np.minimum(local, end))

        return self._per_segment(t, velocity)

    def breakpoints(self) -> FloatArray:
        """Return the union of the segments' breakpoints shifted by their start times [s], sorted.

        Times closer than 1e-12·duration to the previous one are merged, so that rounding of the
        shifted times does not create vanishing steps.
        """
        times = np.concatenate([seg.breakpoints() + offset
                                for seg, offset in zip(self.segments, self._offsets[:-1],
                                                       strict=True)]
                               + [self._offsets])
        times = np.unique(np.clip(times, 0.0, self.duration))
        keep = np.concatenate(([True], np.diff(times) > 1e-12 * self.duration))
        merged = times[keep]
        merged[-1] = self.duration
        return merged

    def min_steps(self) -> int:
        """Return the sum of the segments' :meth:`min_steps`."""
        return sum(seg.min_steps() for seg in self.segments)

    def extent(self) -> tuple[float, float]:
        """Return the (min, max) position over [0, duration] [m], over all segments."""
        lows, highs = zip(*(seg.extent() for seg in self.segments), strict=True)
        return (min(lows), max(highs))

    def describe(self) -> str:
        """Return a one-line summary: the segments' descriptions joined by ``"; then "``."""
        return "; then ".join(seg.describe() for seg in self.segments)
