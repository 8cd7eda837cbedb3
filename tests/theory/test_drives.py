"""Tests of viscoforce.experiments.drives: positions, exact velocities, breakpoints, validation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from viscoforce import experiments
from viscoforce._typing import SeparationHistory
from viscoforce.exceptions import ParameterError
from viscoforce.experiments.drives import (
    STEPS_PER_PERIOD,
    Hold,
    MeasuredTrace,
    Ramp,
    Sequence,
    Sinusoid,
    Step,
    Triangle,
)

NM = 1e-9


def _all_drives():
    return [
        Hold(-5 * NM, 1e-3),
        Ramp(-5 * NM, -7 * NM, 1e-3),
        Step(-5 * NM, -3 * NM),
        Triangle(10 * NM, -10 * NM, 5e-6),
        Sinusoid(-5 * NM, 0.1 * NM, 2 * math.pi * 1e3, periods=2.5),
        Sequence((Hold(-5 * NM, 1e-3), Step(-5 * NM, -7 * NM), Triangle(-7 * NM, -9 * NM, 1e-6))),
        MeasuredTrace([2.0, 2.001, 2.003, 2.004], [0.0, 1 * NM, -1 * NM, 0.5 * NM]),
        MeasuredTrace([0.0, 1e-3, 3e-3, 4e-3], [0.0, 1 * NM, -1 * NM, 0.5 * NM], smooth=True),
    ]


ALL_DRIVES = _all_drives()
IDS = [type(d).__name__ + ("_smooth" if getattr(d, "smooth", False) else "") for d in ALL_DRIVES]


# ── package surface ──────────────────────────────────────────────────────────────────────────


def test_experiments_exports_every_drive():
    assert set(experiments.__all__) >= {"Hold", "Ramp", "Step", "Triangle", "Sinusoid",
                                        "Sequence", "MeasuredTrace"}
    assert experiments.Triangle is Triangle


@pytest.mark.parametrize("drive", ALL_DRIVES, ids=IDS)
def test_drive_satisfies_protocol_and_shapes(drive):
    assert isinstance(drive, SeparationHistory)
    # scalar in -> 0-d out, convertible with float()
    p0 = drive.position(0.3 * drive.duration)
    assert p0.shape == ()
    assert isinstance(float(p0), float)
    assert drive.velocity(0.3 * drive.duration).shape == ()
    # array shape kept, float dtype even for integer input
    t = np.linspace(-0.1, 1.1, 12).reshape(3, 4) * drive.duration
    assert drive.position(t).shape == (3, 4)
    assert drive.velocity(t).dtype == np.float64
    assert drive.position(np.array([0, 0])).dtype == np.float64


@pytest.mark.parametrize("drive", ALL_DRIVES, ids=IDS)
def test_holds_before_and_after(drive):
    d = drive.duration
    np.testing.assert_array_equal(drive.position([-1.0, -1e-12, 0.0]), drive.start_position)
    np.testing.assert_array_equal(drive.position([d, d * (1 + 1e-9), d + 10.0]),
                                  drive.end_position)
    np.testing.assert_array_equal(drive.velocity([-1.0, -1e-12, d, d + 10.0]), 0.0)


@pytest.mark.parametrize("drive", ALL_DRIVES, ids=IDS)
def test_velocity_matches_finite_difference_between_breakpoints(drive):
    bps = drive.breakpoints()
    assert bps[0] == 0.0
    assert bps[-1] == drive.duration
    assert np.all(np.diff(bps) > 0)
    # a smooth (C¹, piecewise cubic) trace has jumps of the 2nd derivative at its samples, where
    # central differences are only 1st order: split the comparison there as well
    splits = np.union1d(bps, drive.time) if isinstance(drive, MeasuredTrace) else bps
    for a, b in zip(splits[:-1], splits[1:], strict=True):
        margin = 1e-3 * (b - a)
        t = np.linspace(a + margin, b - margin, 20001)
        dt = t[1] - t[0]
        p = drive.position(t)
        fd = np.gradient(p, t)
        v = drive.velocity(t)
        # 2nd-order central differences: exact for linear pieces up to roundoff ~ eps·|p|/dt;
        # for the sinusoid the truncation error is (ω dt)²/6 · Aω ≈ 1e-7·Aω on this grid
        atol = 1e-6 * np.max(np.abs(v)) + 1e-13 * np.max(np.abs(p)) / dt
        np.testing.assert_allclose(fd[1:-1], v[1:-1], rtol=0, atol=atol)


@pytest.mark.parametrize("drive", ALL_DRIVES, ids=IDS)
def test_extent_bounds_a_dense_sampling(drive):
    low, high = drive.extent()
    t = np.linspace(0, drive.duration, 20001)
    p = drive.position(t)
    assert low <= p.min() + 1e-24
    assert high >= p.max() - 1e-24
    # and it is tight: the grid misses an extremum by at most max|v|·dt
    tol = np.max(np.abs(drive.velocity(t))) * (t[1] - t[0]) + 1e-24
    assert p.min() - low <= tol
    assert high - p.max() <= tol


def test_time_input_is_validated():
    ramp = Ramp(0.0, 1 * NM, 1e-3)
    with pytest.raises(ParameterError, match="t must be finite"):
        ramp.position([0.0, np.nan])
    with pytest.raises(ParameterError, match="t must be finite"):
        ramp.velocity(np.inf)
    with pytest.raises(ParameterError, match="t must be real times"):
        ramp.position("soon")


# ── Hold ─────────────────────────────────────────────────────────────────────────────────────


def test_hold_values():
    hold = Hold(-5 * NM, 2e-3)
    np.testing.assert_array_equal(hold.position([-1.0, 0.0, 1e-3, 5.0]), -5 * NM)
    np.testing.assert_array_equal(hold.velocity([0.0, 1e-3]), 0.0)
    np.testing.assert_array_equal(hold.breakpoints(), [0.0, 2e-3])
    assert hold.extent() == (-5 * NM, -5 * NM)
    assert hold.describe() == "hold \u22125 nm for 2 ms"


def test_hold_raises():
    with pytest.raises(ParameterError, match="h0 must be finite"):
        Hold(np.nan, 1e-3)
    with pytest.raises(ParameterError, match=r"duration must be > 0, got 0"):
        Hold(0.0, 0)
    with pytest.raises(ParameterError, match="duration must be a real number"):
        Hold(0.0, "long")


# ── Ramp and Step ────────────────────────────────────────────────────────────────────────────


def test_ramp_values_and_velocity():
    ramp = Ramp(-5 * NM, -7 * NM, 1e-3)
    np.testing.assert_allclose(ramp.position([0.25e-3, 0.5e-3]), [-5.5 * NM, -6 * NM],
                               rtol=1e-14, atol=0)
    np.testing.assert_allclose(ramp.velocity([0.0, 0.999e-3]), -2e-6, rtol=1e-14)
    assert ramp.speed == pytest.approx(-2e-6, rel=1e-14)
    assert float(ramp.position(1e-3)) == -7 * NM
    assert ramp.extent() == (-7 * NM, -5 * NM)
    assert ramp.describe() == "ramp \u22125 nm \u2192 \u22127 nm in 1 ms (\u22122 \u00b5m/s)"


def test_ramp_from_speed():
    ramp = Ramp.from_speed(-5 * NM, -3 * NM, 1e-6)
    assert ramp.duration == pytest.approx(2e-3, rel=1e-14)
    np.testing.assert_allclose(ramp.velocity(1e-3), 1e-6, rtol=1e-14)
    down = Ramp.from_speed(10 * NM, -10 * NM, 5e-6)
    assert down.duration == pytest.approx(4e-3, rel=1e-14)
    np.testing.assert_allclose(down.velocity(0.0), -5e-6, rtol=1e-14)


def test_ramp_raises():
    with pytest.raises(ParameterError, match="start must be finite"):
        Ramp(np.inf, 0.0, 1e-3)
    with pytest.raises(ParameterError, match="end must be finite"):
        Ramp(0.0, np.nan, 1e-3)
    with pytest.raises(ParameterError, match="duration must be > 0"):
        Ramp(0.0, 1 * NM, -1e-3)
    with pytest.raises(ParameterError, match=r"speed must be > 0, got -5e-06"):
        Ramp.from_speed(0.0, 1 * NM, -5e-6)
    with pytest.raises(ParameterError, match="start must be finite"):
        Ramp.from_speed(np.nan, 1 * NM, 1e-6)
    with pytest.raises(ParameterError, match="end must be finite"):
        Ramp.from_speed(0.0, np.inf, 1e-6)
    with pytest.raises(ParameterError, match="end must differ from start"):
        Ramp.from_speed(1 * NM, 1 * NM, 1e-6)
    with pytest.raises(ParameterError, match="finite duration"):
        Ramp.from_speed(0.0, 1 * NM, 5e-324)


def test_step_is_a_short_ramp():
    step = Step(-5 * NM, -7 * NM)
    assert step.rise_time == 1e-4
    assert step.duration == 1e-4
    np.testing.assert_allclose(step.position(0.5e-4), -6 * NM, rtol=1e-14)
    np.testing.assert_allclose(step.velocity(0.0), -2e-5, rtol=1e-14)
    np.testing.assert_array_equal(step.breakpoints(), [0.0, 1e-4])
    assert step.extent() == (-7 * NM, -5 * NM)
    assert step.describe() == "step \u22125 nm \u2192 \u22127 nm (rise time 100 \u00b5s)"


def test_step_raises():
    with pytest.raises(ParameterError, match="rise_time must be > 0"):
        Step(0.0, 1 * NM, rise_time=0.0)
    with pytest.raises(ParameterError, match="start must be finite"):
        Step(np.nan, 1 * NM)
    with pytest.raises(ParameterError, match="end must be finite"):
        Step(0.0, -np.inf)


# ── Triangle ─────────────────────────────────────────────────────────────────────────────────


def test_triangle_turning_point_and_kinks():
    tri = Triangle(10 * NM, -10 * NM, 5e-6)
    assert tri.turning_time == pytest.approx(4e-3, rel=1e-14)
    assert tri.duration == pytest.approx(8e-3, rel=1e-14)
    np.testing.assert_allclose(tri.breakpoints(), [0.0, 4e-3, 8e-3], rtol=1e-14)
    np.testing.assert_allclose(tri.position([0.0, 2e-3, 4e-3, 6e-3, 8e-3]),
                               [10 * NM, 0.0, -10 * NM, 0.0, 10 * NM], rtol=1e-12, atol=1e-22)
    # right-sided velocity: at the turning time, the unloading leg's velocity
    t_turn = tri.turning_time
    np.testing.assert_array_equal(tri.velocity([0.0, np.nextafter(t_turn, 0), t_turn]),
                                  [-5e-6, -5e-6, 5e-6])
    assert tri.extent() == (-10 * NM, 10 * NM)
    assert tri.describe() == ("triangle 10 nm \u2192 \u221210 nm \u2192 10 nm at 5 \u00b5m/s")


def test_triangle_upward():
    tri = Triangle(-10 * NM, 0.0, 1e-6)
    np.testing.assert_array_equal(tri.velocity([0.0, 1.5e-2]), [1e-6, -1e-6])
    assert float(tri.position(1e-2)) == pytest.approx(0.0, abs=1e-22)


def test_triangle_raises():
    with pytest.raises(ParameterError, match="top must be finite"):
        Triangle(np.nan, 0.0, 1e-6)
    with pytest.raises(ParameterError, match="turn must be finite"):
        Triangle(0.0, np.inf, 1e-6)
    with pytest.raises(ParameterError, match=r"speed must be > 0, got -5e-06"):
        Triangle(10 * NM, -10 * NM, -5e-6)
    with pytest.raises(ParameterError, match="turn must differ from top"):
        Triangle(1 * NM, 1 * NM, 1e-6)
    with pytest.raises(ParameterError, match="finite duration"):
        Triangle(10 * NM, -10 * NM, 5e-324)


# ── Sinusoid ─────────────────────────────────────────────────────────────────────────────────


def test_sinusoid_periods_and_values():
    omega = 2 * math.pi * 100.0  # 100 Hz → period 10 ms
    sine = Sinusoid(-5 * NM, 0.1 * NM, omega, periods=3)
    assert sine.duration == pytest.approx(30e-3, rel=1e-14)
    assert sine.periods == 3.0
    np.testing.assert_allclose(sine.position([2.5e-3, 7.5e-3, 10e-3]),
                               [-4.9 * NM, -5.1 * NM, -5 * NM], rtol=1e-12)
    # starts at the mean moving up at A·ω: a kink relative to a hold before it
    assert float(sine.position(0.0)) == -5 * NM
    np.testing.assert_allclose(sine.velocity(0.0), 0.1 * NM * omega, rtol=1e-14)
    assert float(sine.velocity(-1e-9)) == 0.0
    np.testing.assert_allclose(sine.velocity(5e-3), -0.1 * NM * omega, rtol=1e-12)
    np.testing.assert_array_equal(sine.breakpoints(), [0.0, sine.duration])
    assert sine.end_position == pytest.approx(-5 * NM, abs=1e-22)
    np.testing.assert_allclose(sine.extent(), (-5.1 * NM, -4.9 * NM), rtol=1e-14)
    assert sine.describe() == ("sinusoid \u22125 nm + 100 pm\u00b7sin(\u03c9t), "
                               "\u03c9 = 628.3 rad/s, 3 periods (30 ms)")


def test_sinusoid_fractional_periods_and_duration():
    omega = 1000.0
    frac = Sinusoid(0.0, 1 * NM, omega, periods=1.25)
    assert frac.end_position == pytest.approx(1 * NM, rel=1e-12)  # ends at the crest
    by_duration = Sinusoid(0.0, 1 * NM, omega, duration=frac.duration)
    assert by_duration.periods == pytest.approx(1.25, rel=1e-14)
    assert by_duration.duration == frac.duration


def test_sinusoid_raises():
    with pytest.raises(ParameterError, match="exactly one of periods and duration"):
        Sinusoid(0.0, 1 * NM, 1e3)
    with pytest.raises(ParameterError, match="exactly one of periods and duration"):
        Sinusoid(0.0, 1 * NM, 1e3, periods=2, duration=1.0)
    with pytest.raises(ParameterError, match="periods must be >= 1, got 0.5"):
        Sinusoid(0.0, 1 * NM, 1e3, periods=0.5)
    with pytest.raises(ParameterError, match="periods must be finite"):
        Sinusoid(0.0, 1 * NM, 1e3, periods=np.inf)
    with pytest.raises(ParameterError, match="duration must be >= one period"):
        Sinusoid(0.0, 1 * NM, 1e3, duration=1e-3)
    with pytest.raises(ParameterError, match="duration must be > 0"):
        Sinusoid(0.0, 1 * NM, 1e3, duration=-1.0)
    with pytest.raises(ParameterError, match="eta must be > 0"):
        Sinusoid(0.0, 0.0, 1e3, periods=1)
    with pytest.raises(ParameterError, match=r"omega must be > 0, got -1"):
        Sinusoid(0.0, 1 * NM, -1.0, periods=1)
    with pytest.raises(ParameterError, match="h0 must be finite"):
        Sinusoid(np.nan, 1 * NM, 1e3, periods=1)
    with pytest.raises(ParameterError, match="finite duration"):
        Sinusoid(0.0, 1 * NM, 1e-308, periods=1)


# ── Sequence ─────────────────────────────────────────────────────────────────────────────────


def test_sequence_plays_segments_in_order():
    seq = Sequence([Hold(-5 * NM, 1e-3), Step(-5 * NM, -7 * NM), Ramp(-7 * NM, -3 * NM, 2e-3)])
    assert isinstance(seq.segments, tuple)
    assert seq.duration == pytest.approx(3.1e-3, rel=1e-14)
    np.testing.assert_allclose(seq.start_times, [0.0, 1e-3, 1.1e-3], rtol=1e-14)
    np.testing.assert_allclose(seq.breakpoints(), [0.0, 1e-3, 1.1e-3, 3.1e-3], rtol=1e-14)
    np.testing.assert_allclose(seq.position([0.5e-3, 1.05e-3, 1.1e-3, 2.1e-3, 10.0]),
                               [-5 * NM, -6 * NM, -7 * NM, -5 * NM, -3 * NM], rtol=1e-12)
    # right-sided at segment boundaries: the velocity of the segment that starts there
    t1, t2 = seq.start_times[1], seq.start_times[2]
    np.testing.assert_allclose(seq.velocity([np.nextafter(t1, 0), t1, np.nextafter(t2, 0), t2]),
                               [0.0, -2e-5, -2e-5, 2e-6], rtol=1e-12)
    assert seq.start_position == -5 * NM
    assert seq.end_position == -3 * NM
    assert seq.extent() == (-7 * NM, -3 * NM)
    assert seq.describe() == ("hold \u22125 nm for 1 ms; then step \u22125 nm \u2192 \u22127 nm "
                              "(rise time 100 \u00b5s); then ramp \u22127 nm \u2192 \u22123 nm in "
                              "2 ms (2 \u00b5m/s)")


def test_sequence_shifts_inner_breakpoints_and_nests():
    tri = Triangle(-5 * NM, -9 * NM, 2e-6)  # turning time 2 ms
    inner = Sequence((Hold(-5 * NM, 1e-3), tri))
    outer = Sequence((Ramp(0.0, -5 * NM, 0.5e-3), inner))
    np.testing.assert_allclose(outer.breakpoints(), [0.0, 0.5e-3, 1.5e-3, 3.5e-3, 5.5e-3],
                               rtol=1e-13)
    np.testing.assert_allclose(float(outer.position(3.5e-3)), -9 * NM, rtol=1e-12)
    assert outer.extent() == (-9 * NM, 0.0)
    assert hash(outer) == hash(Sequence((Ramp(0.0, -5 * NM, 0.5e-3), inner)))
    assert outer == Sequence((Ramp(0.0, -5 * NM, 0.5e-3), inner))


def test_sequence_accepts_rounding_level_mismatch():
    a = Ramp(0.0, 0.1 * NM + 0.2 * NM, 1e-3)
    b = Hold(0.3 * NM, 1e-3)  # 0.1 nm + 0.2 nm != 0.3 nm in floating point
    assert a.end_position != b.start_position
    assert Sequence((a, b)).duration == pytest.approx(2e-3, rel=1e-14)


def test_sequence_raises():
    with pytest.raises(ParameterError, match=r"segments\[2\] must start where segments\[1\] ends"):
        Sequence((Hold(0.0, 1e-3), Ramp(0.0, 1 * NM, 1e-3), Hold(1.001 * NM, 1e-3)))
    with pytest.raises(ParameterError, match="at least one drive"):
        Sequence(())
    with pytest.raises(ParameterError, match=r"segments\[1\] must be a drive"):
        Sequence((Hold(0.0, 1e-3), lambda t: t))
    with pytest.raises(ParameterError, match="segments must be a sequence of drives"):
        Sequence(5)


# ── min_steps ────────────────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize("drive", ALL_DRIVES, ids=IDS)
def test_min_steps_is_a_positive_int_at_least_the_breakpoint_intervals(drive):
    n = drive.min_steps()
    assert type(n) is int
    assert n >= drive.breakpoints().size - 1 >= 1


@pytest.mark.parametrize(("drive", "expected"), [
    (Hold(-5 * NM, 1e-3), 2),
    (Ramp(-5 * NM, -7 * NM, 1e-3), 2),
    (Step(-5 * NM, -3 * NM), 2),
    (Triangle(10 * NM, -10 * NM, 5e-6), 3),
    (MeasuredTrace([0.0, 1e-3, 3e-3, 4e-3, 5e-3], [0.0, NM, -NM, 0.5 * NM, 0.0]), 5),
    (MeasuredTrace([0.0, 1e-3, 3e-3, 4e-3, 5e-3], [0.0, NM, -NM, 0.5 * NM, 0.0], smooth=True), 5),
    (Sinusoid(-5 * NM, 0.1 * NM, 1e3, periods=1), 2 + 8),
    (Sinusoid(-5 * NM, 0.1 * NM, 1e3, periods=2.5), 2 + 20),
    (Sinusoid(-5 * NM, 0.1 * NM, 1e3, periods=1.01), 2 + 9),  # 8.08 rounds up
], ids=["hold", "ramp", "step", "triangle", "trace", "trace_smooth", "sine_1", "sine_2.5",
        "sine_1.01"])
def test_min_steps_values(drive, expected):
    assert drive.min_steps() == expected


def test_min_steps_of_a_sequence_is_the_sum_over_segments():
    segments = (Hold(-5 * NM, 1e-3), Step(-5 * NM, -7 * NM), Triangle(-7 * NM, -9 * NM, 1e-6),
                Sinusoid(-7 * NM, 0.1 * NM, 1e3, periods=3))
    seq = Sequence(segments)
    assert seq.min_steps() == 2 + 2 + 3 + (2 + 3 * STEPS_PER_PERIOD)
    assert Sequence((seq, Hold(seq.end_position, 1.0))).min_steps() == seq.min_steps() + 2


def test_min_steps_of_a_very_long_sine_is_cheap_and_huge():
    # the number the effort limit refuses "--drive sine --periods 1e7" with, computed instantly
    drive = Sinusoid(-5 * NM, 0.1 * NM, 2 * math.pi * 1e3, periods=1e7)
    assert drive.min_steps() == 2 + 8 * 10**7


# ── MeasuredTrace ────────────────────────────────────────────────────────────────────────────


def test_measured_trace_interpolates_and_shifts_time():
    time = np.array([10.0, 10.002, 10.003, 10.007])
    sep = np.array([0.0, -2 * NM, -1 * NM, -5 * NM])
    trace = MeasuredTrace(time, sep)
    assert trace.time_offset == 10.0
    np.testing.assert_allclose(trace.time, [0.0, 0.002, 0.003, 0.007], rtol=0, atol=1e-15)
    assert trace.duration == pytest.approx(0.007, abs=1e-15)
    np.testing.assert_allclose(trace.position([0.001, 0.0025, 0.005]),
                               [-1 * NM, -1.5 * NM, -3 * NM], rtol=1e-9)
    # piecewise-constant velocity, right-sided at the samples
    t1 = trace.time[1]
    np.testing.assert_allclose(trace.velocity([0.0, np.nextafter(t1, 0), t1, 0.004]),
                               [-1e-6, -1e-6, 1e-6, -1e-6], rtol=1e-9)
    np.testing.assert_array_equal(trace.breakpoints(), trace.time)
    assert trace.extent() == (-5 * NM, 0.0)
    assert trace.describe() == ("measured trace: 4 samples over 7 ms, \u22125 nm \u2026 0 m "
                                "(piecewise linear)")


def test_measured_trace_is_frozen_and_keeps_caller_data():
    time = np.array([0.0, 1.0, 2.0])
    sep = np.array([0.0, 1 * NM, 0.0])
    trace = MeasuredTrace(time, sep)
    assert not trace.time.flags.writeable
    assert not trace.h0.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        trace.h0[0] = 1.0
    sep[1] = 5 * NM  # caller's array is independent of the stored copy
    assert float(trace.position(1.0)) == 1 * NM
    assert time.flags.writeable
    assert hash(trace) == hash(trace)  # identity hash (eq=False)


def test_measured_trace_smooth_is_c1_and_does_not_overshoot():
    time = np.linspace(0.0, 4e-3, 5)
    sep = np.array([0.0, 1.0, 1.0, -1.0, 0.0]) * NM
    trace = MeasuredTrace(time, sep, smooth=True)
    np.testing.assert_allclose(trace.position(time), sep, rtol=0, atol=1e-24)
    np.testing.assert_array_equal(trace.breakpoints(), [0.0, 4e-3])
    t = np.linspace(0, 4e-3, 4001)
    p = trace.position(t)
    assert p.max() <= 1 * NM + 1e-24 and p.min() >= -1 * NM - 1e-24
    # C¹: velocity continuous across an interior sample
    v = trace.velocity([np.nextafter(1e-3, 0), 1e-3])
    assert v[0] == pytest.approx(v[1], abs=1e-12 * 1e-6)
    assert "monotone cubic" in trace.describe()


def test_measured_trace_raises():
    with pytest.raises(ParameterError, match="time needs at least 2 values"):
        MeasuredTrace([0.0], [0.0])
    with pytest.raises(ParameterError, match="time must be finite"):
        MeasuredTrace([0.0, np.nan], [0.0, 0.0])
    with pytest.raises(ParameterError, match="h0 must be finite"):
        MeasuredTrace([0.0, 1.0], [0.0, np.inf])
    with pytest.raises(ParameterError, match="time must be strictly increasing"):
        MeasuredTrace([0.0, 1.0, 1.0], [0.0, 0.0, 0.0])
    with pytest.raises(ParameterError, match=r"h0 must have the same length as time \(3\)"):
        MeasuredTrace([0.0, 1.0, 2.0], [0.0, 0.0])
    with pytest.raises(ParameterError, match="smooth must be True or False"):
        MeasuredTrace([0.0, 1.0], [0.0, 0.0], smooth="yes")
    # distinct times that collapse when shifted to start at 0 (rounding across a binade)
    time = [-(2.0**-54), 1.0 - 2.0**-53, 1.0]
    with pytest.raises(ParameterError, match="after shifting to start at 0"):
        MeasuredTrace(time, [0.0, 0.0, 0.0])


# ── properties ───────────────────────────────────────────────────────────────────────────────

positions = st.floats(min_value=-50e-9, max_value=50e-9, allow_nan=False)
speeds = st.floats(min_value=1e-8, max_value=1e-3)
durations = st.floats(min_value=1e-6, max_value=1.0)


def _check_end_and_continuity(drive):
    assert float(drive.position(drive.duration)) == drive.end_position
    assert float(drive.position(0.0)) == drive.start_position
    vmax = float(np.max(np.abs(drive.velocity(drive.breakpoints()))))
    for b in drive.breakpoints():
        eps = 1e-9 * drive.duration
        jump = abs(float(drive.position(b + eps)) - float(drive.position(b - eps)))
        span = max(abs(drive.start_position), abs(drive.end_position), 1e-9)
        assert jump <= 2.5 * vmax * eps + 1e-12 * span


@settings(max_examples=60, deadline=None)
@given(start=positions, end=positions, duration=durations)
def test_property_ramp_ends_exactly_and_is_continuous(start, end, duration):
    _check_end_and_continuity(Ramp(start, end, duration))


@settings(max_examples=60, deadline=None)
@given(top=positions, turn=positions, speed=speeds)
def test_property_triangle_ends_exactly_and_is_continuous(top, turn, speed):
    if abs(top - turn) < 1e-12:
        turn = top - 1e-9
    tri = Triangle(top, turn, speed)
    _check_end_and_continuity(tri)
    assert float(tri.position(tri.turning_time)) == pytest.approx(turn, rel=1e-12, abs=1e-21)


@settings(max_examples=40, deadline=None)
@given(start=positions, mid=positions, turn=positions, speed=speeds)
def test_property_sequence_of_ramp_and_triangle(start, mid, turn, speed):
    if abs(mid - turn) < 1e-12:
        turn = mid - 1e-9
    seq = Sequence((Ramp.from_speed(start, mid, speed) if start != mid else Hold(mid, 1e-3),
                    Triangle(mid, turn, speed)))
    _check_end_and_continuity(seq)
