"""JPK archive → curves dataset: the self-made fixtures exactly, and the real files."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.io.curves import HEIGHT_CHANNELS, jpk_to_curves, segment_name
from viscoforce.io.jpk import read_jpk
from viscoforce.schema import select_curve, validate_curves

FIXTURES = Path(__file__).resolve().parents[1] / "data" / "jpk"
REAL = Path(__file__).resolve().parents[3] / "shared" / "data" / "real"


def real(name: str) -> Path:
    path = REAL / name
    if not path.is_file():
        pytest.skip(f"real data file not present: {path}")
    return path


def _concat(curve, channel):
    return np.concatenate([s.channels[channel] for s in curve.segments])


def test_single_curve_matches_the_reader_sample_by_sample():
    archive = read_jpk(FIXTURES / "synthetic.jpk-force")
    ds = jpk_to_curves(archive)
    curve = archive.curve(0)
    validate_curves(ds)
    assert ds.sizes["curve"] == 1 and ds.sizes["sample"] == 15 and ds.sizes["segment_table"] == 3
    assert ds.attrs["height_channel"] == "measuredHeight"
    assert ds.attrs["source"] == "jpk"
    np.testing.assert_array_equal(ds["force"].values, _concat(curve, "force"))
    np.testing.assert_array_equal(ds["deflection"].values, _concat(curve, "vDeflection"))
    np.testing.assert_array_equal(ds["height"].values, _concat(curve, "measuredHeight"))
    np.testing.assert_allclose(ds["tip_position"].values,
                               -ds["height"].values - ds["deflection"].values)
    np.testing.assert_allclose(ds["time"].values, np.concatenate([s.time for s in curve.segments]))
    assert list(ds["segment_name"].values) == ["approach", "modulation", "retract"]
    assert list(ds["segment_type"].values) == [s.type for s in curve.segments]
    np.testing.assert_array_equal(ds["segment"].values, np.repeat([0, 1, 2], [4, 8, 3]))
    freq = ds["segment_frequency"].values
    assert math.isnan(freq[0]) and freq[1] == 100.0 and math.isnan(freq[2])
    assert ds["segment_amplitude"].values[1] == pytest.approx(15e-9)
    assert ds["segment_frequency"].attrs["units"] == "Hz"
    assert ds["spring_constant"].values[0] == pytest.approx(0.25)
    assert ds["sensitivity"].values[0] == pytest.approx(2e-8)
    assert ds["baseline"].values[0] == pytest.approx(curve.segments[0].baseline)
    assert ds.attrs["force_baseline_subtracted"] == 0
    assert ds.attrs["segment_1_frequency"] == 100.0
    assert ds.attrs["segment_1_amplitude"] == pytest.approx(15e-9)
    assert ds.attrs["segment_1_type"] == "sine-z-modulation-segment-settings"
    assert ds.attrs["segment_2_num_points"] == 3
    for value in ds.attrs.values():
        assert isinstance(value, str | int | float)


def test_netcdf_round_trip(tmp_path):
    ds = jpk_to_curves(read_jpk(FIXTURES / "synthetic-2x2.jpk-force-map"))
    path = tmp_path / "curves.nc"
    ds.to_netcdf(path, engine="scipy")
    with xr.open_dataset(path, engine="scipy") as back:
        back.load()
    assert back.identical(ds)


def test_map_positions_selection_and_segment_table():
    archive = read_jpk(FIXTURES / "synthetic-2x2.jpk-force-map")
    ds = jpk_to_curves(archive)
    assert ds.sizes["curve"] == 4 and ds.sizes["segment_table"] == 12
    for i, curve in enumerate(archive.curves()):
        assert ds["x"].values[i] == curve.x and ds["y"].values[i] == curve.y
        one = select_curve(ds, i)
        np.testing.assert_array_equal(one["force"].values, _concat(curve, "force"))
    np.testing.assert_array_equal(ds["segment_curve"].values, np.repeat(np.arange(4), 3))
    assert ds.attrs["grid_ilength"] == 2 and ds.attrs["grid_ulength"] == pytest.approx(4e-6)
    sub = jpk_to_curves(archive, curves=[3, -3])
    np.testing.assert_array_equal(sub["curve"].values, [3, 1])
    np.testing.assert_array_equal(sub["force"].values[:15], _concat(archive.curve(3), "force"))
    assert jpk_to_curves(archive, curves=2)["curve"].values.tolist() == [2]


def test_height_channel_override_and_errors():
    archive = read_jpk(FIXTURES / "synthetic.jpk-force")
    ds = jpk_to_curves(archive, height_channel="height")
    assert ds.attrs["height_channel"] == "height"
    np.testing.assert_array_equal(ds["height"].values, _concat(archive.curve(0), "height"))
    with pytest.raises(ParameterError, match="height_channel"):
        jpk_to_curves(archive, height_channel="bogus")
    with pytest.raises(ParameterError, match="missing"):
        jpk_to_curves(archive, height_channel="strainGaugeHeight")
    with pytest.raises(ParameterError, match="out of range"):
        jpk_to_curves(archive, curves=[1])
    with pytest.raises(ParameterError, match="no curve"):
        jpk_to_curves(archive, curves=[])
    with pytest.raises(ParameterError, match="JPKArchive"):
        jpk_to_curves(FIXTURES / "synthetic.jpk-force")
    assert HEIGHT_CHANNELS[-1] == "height"


@pytest.mark.parametrize(("style", "type_", "name"), [
    ("extend", "z-extend-height", "approach"), ("retract", "z-retract-height", "retract"),
    ("pause", "constant-force-pause", "pause"),
    ("modulation", "sine-z-modulation-segment-settings", "modulation"),
    ("", "sine-z-modulation-segment-settings", "modulation"), ("", "something", "other")])
def test_segment_names(style, type_, name):
    assert segment_name(style, type_) == name


# ── the real files ───────────────────────────────────────────────────────────────────────────


def test_real_modulation_map():
    ds = jpk_to_curves(read_jpk(real("PyFMReader/map-data-2021.11.05-17.37.44.432.jpk-force-map")))
    assert ds.sizes["curve"] == 16 and ds.sizes["segment_table"] == 16 * 9
    assert ds.attrs["height_channel"] == "measuredHeight"
    first = ds["segment_curve"].values == 0
    assert list(ds["segment_name"].values[first]) == (
        ["approach", "pause"] + ["modulation"] * 6 + ["retract"])
    np.testing.assert_array_equal(ds["segment_frequency"].values[first][2:8],
                                  [300, 3, 100, 30, 1, 10])
    # a 4 x 4 grid (the file's positions jitter by a few nm)
    assert len(np.unique(np.round(ds["x"].values, 7))) == 4
    assert len(np.unique(np.round(ds["y"].values, 7))) == 4
    assert ds.attrs["segment_2_frequency"] == 300.0


def test_real_stress_relaxation_uses_the_strain_gauge():
    archive = read_jpk(real("afmformats/fmt-jpk-sr_cell1-0008.jpk-force"))
    ds = jpk_to_curves(archive)
    assert ds.sizes["segment_table"] == 4
    assert ds.attrs["height_channel"] == "strainGaugeHeight"
    assert list(ds["segment_name"].values) == ["pause", "approach", "pause", "retract"]
    assert ds["segment_num_points"].values[3] == 1951
    pause = ds["height"].values[ds["segment"].values == 2]
    assert np.ptp(pause) < 50e-9          # the sensor stays put; the piezo drifts ~0.6 µm
    np.testing.assert_array_equal(ds["height"].values,
                                  _concat(archive.curve(0), "strainGaugeHeight"))


@pytest.mark.parametrize("name", ["fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force",
                                  "fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force"])
def test_real_creep_uses_measured_height_everywhere(name):
    ds = jpk_to_curves(read_jpk(real(f"afmformats/{name}")))
    assert ds.attrs["height_channel"] == "measuredHeight"
    assert list(ds["segment_name"].values) == ["approach", "pause", "retract"]
