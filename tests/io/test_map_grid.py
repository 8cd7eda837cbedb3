"""Map positions without jitter: grid rows and columns recovered from the positions (issue 38 item 7).

The JPK map reader's x/y jitter by ~1e-12 m along a grid line, so a 4x4 map unstacked to 7x4;
every curve now has an integer ``row``/``column`` and x/y snapped to its grid line (the file's
values in ``x_raw``/``y_raw``), the same whether the file is read whole or in chunks.
"""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
import xarray as xr

import viscoforce as vf
from tests.io.test_jpk import FIXTURES, build_members, write, zip_bytes
from viscoforce.exceptions import ParameterError
from viscoforce.io.curves import jpk_to_curves
from viscoforce.io.jpk import read_jpk
from viscoforce.io.map_grid import POSITION_NOISE, cluster_axis, map_grid
from viscoforce.io.stream import iter_curves, write_curves_netcdf

BUNDLED = vf.example_path("real/modulation-map.jpk-force-map")
PYFMRHEO = (FIXTURES.parents[2].parent / "shared" / "data" / "real" / "PyFMRheo"
            / "map-data-2022.10.29-12.27.34.564.jpk-force-map")
#: back-and-forth (meander) order of JPK's 4x4 maps: row by row, every other row reversed
MEANDER_COLUMNS = [0, 1, 2, 3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0]
MEANDER_ROWS = [0] * 4 + [1] * 4 + [2] * 4 + [3] * 4
REAL_MAPS = [pytest.param(BUNDLED, 1.25e-6, id="bundled-modulation-map"),
             pytest.param(PYFMRHEO, 5e-6, id="PyFMRheo-map",
                          marks=pytest.mark.skipif(not PYFMRHEO.exists(),
                                                   reason="real data folder absent"))]


def jittered_grid(rng, n_columns=4, n_rows=4, step=1.25e-6, noise=2e-12, origin=(-9.7e-6, -1.86e-5)):
    """Meander-ordered positions of a grid with ~1e-12 m noise, as a JPK map gives them."""
    columns = np.array([c if r % 2 == 0 else n_columns - 1 - c
                        for r in range(n_rows) for c in range(n_columns)])
    rows = np.repeat(np.arange(n_rows), n_columns)
    x = origin[0] + columns * step + noise * rng.standard_normal(rows.size)
    y = origin[1] + rows * step + noise * rng.standard_normal(rows.size)
    return x, y, rows, columns


# ── the clustering ──────────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize("steps", [None, (1.25e-6, 1.25e-6)])
def test_jittered_grid_gives_its_rows_columns_and_one_value_per_line(rng, steps):
    x, y, rows, columns = jittered_grid(rng)
    assert len(np.unique(y)) == 16                       # what made the 7x4 (here 16x4) unstack
    grid = map_grid(x, y, steps=steps)
    np.testing.assert_array_equal(grid.row, rows)
    np.testing.assert_array_equal(grid.column, columns)
    assert (grid.n_rows, grid.n_columns) == (4, 4)
    assert len(np.unique(grid.x)) == 4 and len(np.unique(grid.y)) == 4
    np.testing.assert_allclose(grid.x, x, rtol=0, atol=1e-11)
    np.testing.assert_array_equal(grid.x_raw, x)
    assert grid.x_step == pytest.approx(1.25e-6, rel=1e-5)
    ds = xr.Dataset(coords={"curve": np.arange(16), "x": ("curve", grid.x),
                            "y": ("curve", grid.y)})
    assert dict(ds.set_index(curve=["y", "x"]).unstack().sizes) == {"y": 4, "x": 4}


def test_exact_positions_stay_exact_and_a_single_curve_is_row_0_column_0():
    x = [1e-6, 2e-6, 1e-6, 2e-6]
    y = [5e-6, 5e-6, 6e-6, 6e-6]
    grid = map_grid(x, y)
    np.testing.assert_array_equal(grid.x, x)             # the median of equal values is exact
    np.testing.assert_array_equal(grid.y, y)
    one = map_grid([3e-6], [4e-6])
    assert (int(one.row[0]), int(one.column[0]), one.x[0], one.y[0]) == (0, 0, 3e-6, 4e-6)
    assert math.isnan(one.x_step)


def test_curves_without_a_position_are_row_and_column_minus_1():
    grid = map_grid([0.0, math.nan, 1e-6], [0.0, 1e-6, math.nan])
    np.testing.assert_array_equal(grid.row, [0, -1, -1])
    np.testing.assert_array_equal(grid.column, [0, -1, -1])
    assert math.isnan(grid.x[1]) and math.isnan(grid.y[2])
    nothing = map_grid([math.nan], [math.nan])
    assert (nothing.n_rows, nothing.n_columns) == (0, 0)


def test_a_missing_line_and_noise_below_the_floor_are_one_line_each(rng):
    # column 2 never measured: the gap of two steps is still one step between lines
    values = np.array([0.0, 1e-6, 3e-6, 0.0, 1e-6, 3e-6]) + 1e-12 * rng.standard_normal(6)
    index, centre = cluster_axis(values)
    np.testing.assert_array_equal(index, [0, 1, 2, 0, 1, 2])
    assert len(np.unique(centre)) == 3
    # only noise (one line): no gap is a step
    index, _ = cluster_axis(POSITION_NOISE / 10 * rng.standard_normal(5))
    np.testing.assert_array_equal(index, 0)


def test_a_rotated_grid_is_clustered_in_its_own_frame(rng):
    u, v, rows, columns = jittered_grid(rng, origin=(-1.875e-6, -1.875e-6))
    theta = 0.3
    x = math.cos(theta) * u - math.sin(theta) * v + 5e-6
    y = math.sin(theta) * u + math.cos(theta) * v - 2e-6
    grid = map_grid(x, y, steps=(1.25e-6, 1.25e-6), shape=(4, 4), centre=(5e-6, -2e-6),
                    theta=theta)
    np.testing.assert_array_equal(grid.row, rows)
    np.testing.assert_array_equal(grid.column, columns)
    np.testing.assert_allclose(grid.x, x, rtol=0, atol=1e-11)
    assert "turned by 0.3 rad" in grid.method
    # the other sign convention of theta is found too
    other = map_grid(x, y, steps=(1.25e-6, 1.25e-6), shape=(4, 4), centre=(5e-6, -2e-6),
                     theta=-theta)
    np.testing.assert_array_equal(other.row, rows)


def test_bad_arguments_are_refused():
    with pytest.raises(ParameterError, match="tolerance must be in"):
        cluster_axis([0.0, 1.0], tolerance=0.5)
    with pytest.raises(ParameterError, match="one value per curve"):
        map_grid([0.0, 1.0], [0.0])


# ── the JPK readers ─────────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize(("path", "step"), REAL_MAPS)
def test_real_maps_unstack_to_their_4x4_grid(path, step):
    archive = read_jpk(path)
    raw_y = [archive.curve(i).y_raw for i in range(archive.n_curves)]
    assert len(set(raw_y)) > 4                            # the file's own values jitter
    ds = jpk_to_curves(archive)
    assert ds["row"].values.tolist() == MEANDER_ROWS
    assert ds["column"].values.tolist() == MEANDER_COLUMNS
    assert ds["row"].dtype == np.int32 and ds["row"].attrs["units"] == "1"
    np.testing.assert_array_equal(ds["y_raw"].values, raw_y)
    np.testing.assert_allclose(ds["x"].values, ds["x_raw"].values, rtol=0, atol=1e-11)
    np.testing.assert_allclose(ds["y"].values, ds["y_raw"].values, rtol=0, atol=1e-11)
    pixels = ds.drop_dims(["sample", "segment_table"])
    for index in (["y", "x"], ["row", "column"]):
        assert dict(pixels.set_index(curve=index).unstack().sizes) == {index[0]: 4, index[1]: 4}
    np.testing.assert_allclose(np.diff(np.unique(ds["x"].values)), step, rtol=1e-6)
    assert (ds.attrs["grid_rows"], ds.attrs["grid_columns"]) == (4, 4)
    assert ds.attrs["grid_x_step"] == pytest.approx(step, rel=1e-12)
    assert "x_raw" in ds.attrs["grid_method"]


@pytest.mark.parametrize(("path", "step"), REAL_MAPS)
def test_real_maps_streamed_in_chunks_equal_the_whole_read(tmp_path, path, step):
    whole = jpk_to_curves(read_jpk(path))
    chunks = list(iter_curves(read_jpk(path), chunk=3))   # a fresh archive: no grid found yet
    assert len(chunks) == 6
    for name in ("x", "y", "row", "column", "x_raw", "y_raw"):
        np.testing.assert_array_equal(np.concatenate([c[name].values for c in chunks]),
                                      whole[name].values, err_msg=name)
    for chunk in chunks:
        assert {k: v for k, v in chunk.attrs.items() if k.startswith("grid_")} == \
               {k: v for k, v in whole.attrs.items() if k.startswith("grid_")}
    # one chunk alone (a single row of the map) still gets the whole map's rows and positions
    alone = jpk_to_curves(read_jpk(path), curves=[13])
    assert (int(alone["row"][0]), int(alone["column"][0])) == (3, 2)
    assert alone["x"].values[0] == whole["x"].values[13]
    out = tmp_path / "curves.nc"
    write_curves_netcdf(read_jpk(path), out, chunk=5)
    with xr.open_dataset(out, engine="h5netcdf") as back:
        for name in ("x", "y", "row", "column"):
            np.testing.assert_array_equal(back[name].values, whole[name].values)


def test_the_spectrum_of_the_bundled_map_unstacks_to_4x4():
    spectrum = vf.open_data(BUNDLED)
    assert dict(spectrum.set_index(curve=["y", "x"]).unstack().sizes) == {"y": 4, "x": 4,
                                                                          "omega": 6}
    streamed = vf.stream_spectrum(read_jpk(BUNDLED))
    np.testing.assert_array_equal(streamed["x"].values, spectrum["x"].values)
    np.testing.assert_array_equal(streamed["y"].values, spectrum["y"].values)


def test_positions_are_found_once_and_travel_with_a_pickled_archive(monkeypatch):
    archive = read_jpk(BUNDLED)
    grid = archive.positions()
    assert archive.positions() is grid
    clone = pickle.loads(pickle.dumps(archive))
    monkeypatch.setattr(type(archive), "_find_grid", lambda self: pytest.fail("read again"))
    np.testing.assert_array_equal(clone.positions().row, grid.row)
    assert clone.curve(4).row == 1 and clone.curve(4).column == 3


def test_synthetic_2x2_map_and_single_curve():
    archive = read_jpk(FIXTURES / "synthetic-2x2.jpk-force-map")
    curves = list(archive.curves())
    assert [(c.row, c.column) for c in curves] == [(0, 0), (0, 1), (1, 0), (1, 1)]
    assert all(c.x == c.x_raw and c.y == c.y_raw for c in curves)     # no jitter: unchanged
    one = read_jpk(FIXTURES / "synthetic.jpk-force").curve(0)
    assert (one.row, one.column, one.x, one.y) == (0, 0, one.x_raw, one.y_raw)


def test_a_zip_of_single_curves_is_placed_on_its_grid(tmp_path):
    members = {}
    for i, (dx, dy) in enumerate([(0, 0), (1, 0), (0, 1), (1, 1)]):
        curve = build_members("force")
        curve["header.properties"].update({
            "force-scan-series.header.position.x": repr(2e-6 * dx + 1e-12 * i),
            "force-scan-series.header.position.y": repr(3e-6 * dy - 1e-12 * i)})
        members[f"curve-{i}.jpk-force"] = zip_bytes(curve)
    archive = read_jpk(write(tmp_path / "curves.zip", members))
    ds = jpk_to_curves(archive)
    assert ds["row"].values.tolist() == [0, 0, 1, 1]
    assert ds["column"].values.tolist() == [0, 1, 0, 1]
    assert len(np.unique(ds["x"].values)) == 2
    assert "median gap" in ds.attrs["grid_method"]


def test_a_curve_without_position_keys_is_row_minus_1(tmp_path):
    members = build_members("force-map")
    for key in ("x", "y"):
        del members["index/1/header.properties"][f"force-scan-series.header.position.{key}"]
    ds = jpk_to_curves(read_jpk(write(tmp_path / "m.jpk-force-map", members)))
    assert ds["row"].values.tolist() == [0, -1, 1, 1]
    assert math.isnan(float(ds["x"][1])) and math.isnan(float(ds["x_raw"][1]))
