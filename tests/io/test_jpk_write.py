"""write_jpk_force → read_jpk / load_instrument: SI values, calibration, segment metadata, errors."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

from viscoforce.exceptions import ParameterError
from viscoforce.io._properties import parse_properties
from viscoforce.io.instruments import load_instrument
from viscoforce.io.jpk import read_jpk
from viscoforce.io.jpk_write import ForceSegment, java_double, write_jpk_force

K, SENS, BASELINE = 0.25, 4e-8, 3e-9  # spring constant [N/m], sensitivity [m/V], free deflection [m]
#: (style, duration [s], points, frequency [Hz], amplitude [m])
LAYOUT = (("extend", 0.4, 40, None, None), ("pause", 0.1, 10, None, None),
          ("modulation", 0.5, 100, 20.0, 1.5e-8), ("modulation", 0.2, 60, 100.0, 1e-8),
          ("retract", 0.4, 30, None, None))


def make_segments(rng) -> list[ForceSegment]:
    segments = []
    for style, duration, n, frequency, amplitude in LAYOUT:
        channels = {"vDeflection": rng.normal(2e-8, 5e-9, n),
                    "height": 3e-6 + rng.normal(0.0, 2e-7, n),
                    "measuredHeight": 2.5e-6 + rng.normal(0.0, 2e-7, n)}
        modulation = {} if frequency is None else {"frequency": frequency, "amplitude": amplitude}
        segments.append(ForceSegment(style, duration, channels, **modulation))
    return segments


@pytest.fixture
def written(tmp_path, rng):
    segments = make_segments(rng)
    path = write_jpk_force(tmp_path / "curve.jpk-force", segments, spring_constant=K,
                           sensitivity=SENS, position=(1e-6, -2e-6), baseline=BASELINE)
    return path, segments


def _resolution(segments, channel):
    """Largest read-back error allowed: half an int32 encoder step over the channel's range,
    i.e. range·2⁻³², plus float rounding of the values."""
    values = np.concatenate([s.channels[channel] for s in segments])
    return np.ptp(values) * 2.0**-32 + 8 * np.finfo(float).eps * np.abs(values).max()


def test_round_trip_values_calibration_and_segments(written):
    path, segments = written
    with read_jpk(path) as archive:
        assert (archive.kind, archive.n_curves) == ("force", 1)
        curve = archive.curve(0)
    assert (curve.spring_constant, curve.sensitivity) == (K, SENS)     # exact: repr round trip
    assert (curve.x, curve.y) == (1e-6, -2e-6)
    assert [s.style for s in curve.segments] == [row[0] for row in LAYOUT]
    assert [s.type for s in curve.segments] == ["z-extend-height", "constant-height-pause",
                                                "sine-z-modulation-segment-settings",
                                                "sine-z-modulation-segment-settings",
                                                "z-retract-height"]
    assert [s.num_points for s in curve.segments] == [row[2] for row in LAYOUT]
    assert [s.duration for s in curve.segments] == [row[1] for row in LAYOUT]
    np.testing.assert_allclose([s.start_time for s in curve.segments],
                               np.cumsum([0.0] + [row[1] for row in LAYOUT[:-1]]), rtol=1e-15)
    for read, wrote, (_, _, _, frequency, amplitude) in zip(curve.segments, segments, LAYOUT,
                                                            strict=True):
        assert read.units == {"vDeflection": "m", "force": "N", "height": "m", "measuredHeight": "m"}
        for name, values in wrote.channels.items():
            np.testing.assert_allclose(read.channels[name], values, rtol=0,
                                       atol=_resolution(segments, name), err_msg=name)
        np.testing.assert_allclose(read.channels["force"], K * read.channels["vDeflection"],
                                   rtol=1e-15)
        assert read.baseline == pytest.approx(K * BASELINE, rel=1e-15)
        if frequency is None:
            assert read.modulation is None
        else:
            assert (read.modulation.frequency, read.modulation.amplitude,
                    read.modulation.start_phase) == (frequency, amplitude, 0.0)


def test_load_instrument_gives_the_curves_dataset(written):
    path, segments = written
    ds = load_instrument(path)
    assert ds.attrs["source"] == "jpk" and ds.attrs["height_channel"] == "measuredHeight"
    assert ds.attrs["spring_constant"] == K and ds.attrs["sensitivity"] == SENS
    assert list(ds["segment_name"].values) == ["approach", "pause", "modulation", "modulation",
                                               "retract"]
    np.testing.assert_array_equal(ds["segment_frequency"].values, [np.nan, np.nan, 20, 100, np.nan])
    np.testing.assert_array_equal(ds["segment_amplitude"].values,
                                  [np.nan, np.nan, 1.5e-8, 1e-8, np.nan])
    height = np.concatenate([s.channels["measuredHeight"] for s in segments])
    np.testing.assert_allclose(ds["height"].values, height, rtol=0,
                               atol=_resolution(segments, "measuredHeight"))
    deflection = np.concatenate([s.channels["vDeflection"] for s in segments])
    np.testing.assert_allclose(ds["force"].values, K * deflection, rtol=0,
                               atol=K * _resolution(segments, "vDeflection"))
    dt = [row[1] / row[2] for row in LAYOUT]
    np.testing.assert_allclose(np.diff(ds["time"].values[:40]), dt[0], rtol=1e-9)


def test_layout_is_jpk_like_int32_and_deterministic(written, tmp_path):
    path, segments = written
    with zipfile.ZipFile(path) as zf:
        names = zf.namelist()
        shared = parse_properties(zf.read("shared-data/header.properties"))
        seg2 = parse_properties(zf.read("segments/2/segment-header.properties"))
        raw = zf.read("segments/2/channels/vDeflection.dat")
    assert names[:2] == ["header.properties", "shared-data/header.properties"]
    assert "segments/4/channels/measuredHeight.dat" in names
    assert len(raw) == 4 * 100                                           # int32 samples
    assert shared["lcd-info.0.channel.name"] == "vDeflection"
    assert shared["lcd-info.0.encoder.type"] == "signedinteger"
    assert shared["lcd-info.0.conversion-set.conversion.force.scaling.multiplier"] == "0.25"
    assert shared["force-segment-header-info.2.settings.segment-settings.frequency"] == "20.0"
    assert seg2["force-segment-header.force-segment-header-info.*"] == "2"
    assert seg2["channel.measuredHeight.lcd-info.*"] == "2"
    again = write_jpk_force(tmp_path / "again.jpk-force", segments, spring_constant=K,
                            sensitivity=SENS, position=(1e-6, -2e-6), baseline=BASELINE)
    assert again.read_bytes() == path.read_bytes()


def test_constant_channel_and_no_baseline(tmp_path):
    segment = ForceSegment("pause", 1.0, {"vDeflection": np.full(5, 1e-9), "height": np.full(5, 2e-6)})
    path = write_jpk_force(tmp_path / "flat.jpk-force", [segment], spring_constant=1.0,
                           sensitivity=1e-8)
    read = read_jpk(path).curve(0).segments[0]
    np.testing.assert_allclose(read.channels["vDeflection"], 1e-9, rtol=1e-9)
    np.testing.assert_allclose(read.channels["height"], 2e-6, rtol=1e-9)
    assert read.baseline is None and set(read.channels) == {"vDeflection", "force", "height"}


@pytest.mark.parametrize("value, text", [(1.5e-8, "1.5E-8"), (0.8, "0.8"), (2e7, "2.0E7"),
                                         (1e-3, "0.001"), (9.99e-4, "9.99E-4"), (-0.0, "-0.0"),
                                         (123.0, "123.0"), (np.nan, "NaN"), (-np.inf, "-Infinity"),
                                         (3.8481407868505814e-8, "3.8481407868505814E-8")])
def test_java_double(value, text):
    assert java_double(value) == text
    if np.isfinite(value):
        assert float(text) == value


def _channels(n=4, **extra):
    return {"vDeflection": np.zeros(n), "height": np.ones(n) * 1e-6, **extra}


SEGMENT_ERRORS = {
    "style": (lambda: ForceSegment("approach", 1.0, _channels()), r"ForceSegment\.style must be one of"),
    "duration": (lambda: ForceSegment("extend", 0.0, _channels()),
                 r"ForceSegment\.duration \[s\] must be > 0"),
    "type": (lambda: ForceSegment("extend", 1.0, _channels(), type=""), r"ForceSegment\.type must be"),
    "no channels": (lambda: ForceSegment("extend", 1.0, {}), r"ForceSegment\.channels must be a non-empty"),
    "unknown channel": (lambda: ForceSegment("extend", 1.0, _channels(lateral=np.zeros(4))),
                        r"unknown channel\(s\) lateral"),
    "no deflection": (lambda: ForceSegment("extend", 1.0, {"height": np.zeros(4)}),
                      r"must hold 'vDeflection'"),
    "no height": (lambda: ForceSegment("extend", 1.0, {"vDeflection": np.zeros(4)}),
                  r"must hold a height channel"),
    "2-D": (lambda: ForceSegment("extend", 1.0, _channels(measuredHeight=np.zeros((2, 2)))),
            r"channels\['measuredHeight'\] must be a non-empty 1-D array"),
    "nan": (lambda: ForceSegment("extend", 1.0, {"vDeflection": [0, np.nan], "height": [0, 0]}),
            r"channels\['vDeflection'\] must be .* finite"),
    "lengths": (lambda: ForceSegment("extend", 1.0, {"vDeflection": np.zeros(3), "height": np.zeros(4)}),
                r"must all have one length, got \{'vDeflection': 3, 'height': 4\}"),
    "no frequency": (lambda: ForceSegment("modulation", 1.0, _channels(), amplitude=1e-9),
                     r"ForceSegment\.frequency is required for a modulation segment"),
    "frequency elsewhere": (lambda: ForceSegment("pause", 1.0, _channels(), frequency=1.0),
                            r"ForceSegment\.frequency is only for a modulation segment"),
    "bad frequency": (lambda: ForceSegment("modulation", 1.0, _channels(), frequency=-1.0, amplitude=0.0),
                      r"ForceSegment\.frequency must be > 0"),
    "bad amplitude": (lambda: ForceSegment("modulation", 1.0, _channels(), frequency=1.0, amplitude=-1.0),
                      r"ForceSegment\.amplitude must be >= 0"),
    "start phase": (lambda: ForceSegment("modulation", 1.0, _channels(), frequency=1.0, amplitude=0.0,
                                         start_phase=np.inf), r"ForceSegment\.start_phase must be finite"),
}


@pytest.mark.parametrize("case", list(SEGMENT_ERRORS))
def test_segment_errors_name_the_field(case):
    build, pattern = SEGMENT_ERRORS[case]
    with pytest.raises(ParameterError, match=pattern):
        build()


def _good():
    return [ForceSegment("extend", 1.0, _channels())]


WRITE_ERRORS = {
    "path": ({"path": 3}, r"path must be a file path"),
    "directory": ({"path": "/nonexistent-dir/x.jpk-force"}, r"path: directory '/nonexistent-dir' does not"),
    "segments empty": ({"segments": []}, r"segments must be a non-empty sequence of ForceSegment"),
    "segments single": ({"segments": _good()[0]}, r"segments must be a non-empty sequence"),
    "segment type": ({"segments": [*_good(), {"style": "extend"}]}, r"segments\[1\] must be a ForceSegment"),
    "spring constant": ({"spring_constant": 0.0}, r"spring_constant \[N/m\] must be > 0"),
    "sensitivity": ({"sensitivity": np.nan}, r"sensitivity \[m/V\] must be finite"),
    "position": ({"position": (0.0,)}, r"position must be \(x, y\) \[m\]"),
    "position value": ({"position": (0.0, "a")}, r"position\[1\] \[m\] must be a real number"),
    "baseline": ({"baseline": np.inf}, r"baseline \[m\] must be finite"),
    "instrument": ({"instrument": "a\nb"}, r"instrument must be a one-line str"),
    "time stamp": ({"time_stamp": 5}, r"time_stamp must be a one-line str"),
}


@pytest.mark.parametrize("case", list(WRITE_ERRORS))
def test_write_errors_name_the_parameter(tmp_path, case):
    change, pattern = WRITE_ERRORS[case]
    kwargs = {"path": tmp_path / "x.jpk-force", "segments": _good(), "spring_constant": 1.0,
              "sensitivity": 1e-8, **change}
    with pytest.raises(ParameterError, match=pattern):
        write_jpk_force(kwargs.pop("path"), kwargs.pop("segments"), **kwargs)
    assert not (tmp_path / "x.jpk-force").exists()
