"""Spectra of a map carry the map's integer ``row`` and ``column`` per curve (issue 38 item 7).

The bundled 4 x 4 map's positions jitter by ~1e-12 m (its raw y takes 7 values), so unstacking a
spectrum by x and y needed the snapped positions; with ``row`` and ``column`` (the curves'
own, or :func:`viscoforce.io.map_grid.map_grid` of the positions where a curves dataset has
none) ``ds.set_index(curve=["row", "column"]).unstack()`` gives the 4 x 4 map on every path:
the whole archive, the archive in chunks (``viscoforce load``'s path), a curves dataset, and one
whose rows were dropped. The lock-in options that do not touch the grid (contact point, sensor
delay fit) are turned off to keep the runs short.
"""

from __future__ import annotations

import numpy as np
import pytest

from viscoforce._files import write_netcdf
from viscoforce.data import example_path
from viscoforce.experiments.modulation import modulation_spectrum
from viscoforce.experiments.stream import stream_spectrum
from viscoforce.io.curves import jpk_to_curves
from viscoforce.io.jpk import read_jpk
from viscoforce.io.netcdf import open_netcdf

MAP = example_path("real/modulation-map.jpk-force-map")
FAST = {"contact_point": False, "phase_reference": "sensor"}


@pytest.fixture(scope="module")
def curves():
    with read_jpk(MAP) as archive:
        return jpk_to_curves(archive)


@pytest.fixture(scope="module")
def whole():
    return modulation_spectrum(MAP, **FAST)


def grid_of(ds):
    """Rows and columns counted independently: the rank of each curve's snapped y and x."""
    return (np.unique(ds.y.values, return_inverse=True)[1],
            np.unique(ds.x.values, return_inverse=True)[1])


def assert_4x4_map(ds):
    assert ds.row.dtype.kind == ds.column.dtype.kind == "i"
    assert ds.row.attrs["units"] == ds.column.attrs["units"] == "1"
    pixels = ds.set_index(curve=["row", "column"]).unstack()
    assert (pixels.sizes["row"], pixels.sizes["column"]) == (4, 4)
    assert not np.isnan(pixels.stiffness.values).any()  # every pixel holds one curve
    row, column = grid_of(ds)
    np.testing.assert_array_equal(ds.row.values, row)
    np.testing.assert_array_equal(ds.column.values, column)


def test_the_raw_positions_jitter_off_the_grid(curves):
    # the file's own values: one grid row's y differ by ~1e-12 m (the defect being guarded)
    assert np.unique(curves.y_raw.values).size == 7
    assert np.unique(curves.y.values).size == np.unique(curves.x.values).size == 4


def test_whole_archive_spectrum_unstacks_to_the_4x4_map(whole, curves):
    assert_4x4_map(whole)
    np.testing.assert_array_equal(whole.row.values, curves.row.values)
    np.testing.assert_array_equal(whole.column.values, curves.column.values)


def test_streamed_spectrum_has_the_same_rows_and_columns(whole, tmp_path):
    streamed = stream_spectrum(MAP, chunk=5, **FAST)  # 4 chunks joined
    assert_4x4_map(streamed)
    np.testing.assert_array_equal(streamed.row.values, whole.row.values)
    np.testing.assert_array_equal(streamed.column.values, whole.column.values)
    write_netcdf(streamed, tmp_path / "map.nc", engine="scipy")  # as viscoforce load writes
    with open_netcdf(tmp_path / "map.nc") as back:
        assert_4x4_map(back.load())


def test_curves_dataset_selection_keeps_the_maps_rows_and_columns(curves):
    picked = [14, 2, 5]
    spec = modulation_spectrum(curves, curves=picked, **FAST)
    np.testing.assert_array_equal(spec.row.values, curves.row.values[picked])  # [3, 0, 1]
    np.testing.assert_array_equal(spec.column.values, curves.column.values[picked])  # [1, 2, 2]


def test_jittered_positions_without_rows_are_placed_on_their_grid(curves):
    raw = curves.drop_vars(["row", "column", "x", "y"]).rename({"x_raw": "x", "y_raw": "y"})
    spec = modulation_spectrum(raw, **FAST)
    pixels = spec.set_index(curve=["row", "column"]).unstack()
    assert (pixels.sizes["row"], pixels.sizes["column"]) == (4, 4)
    np.testing.assert_array_equal(spec.row.values, curves.row.values)
    np.testing.assert_array_equal(spec.column.values, curves.column.values)
