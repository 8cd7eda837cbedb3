"""map_plot: a fitted variable over the pixels' x, y, masked by quality, with units."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402

from viscoforce.exceptions import ParameterError  # noqa: E402
from viscoforce.plotting import map_plot  # noqa: E402


def _map(nx=4, ny=3, *, curve=True, quality=None):
    """A fitted-map-like dataset: E0 over pixels at x, y [m] on a 2 µm grid."""
    xs, ys = np.meshgrid(np.arange(nx) * 2e-6, np.arange(ny) * 2e-6)
    e0 = 1e3 * (1 + np.arange(nx * ny)).reshape(ny, nx)
    q = np.zeros((ny, nx), dtype=np.int8) if quality is None else quality
    if curve:  # a JPK map: one dim "curve" with x, y coordinates
        dims, shape = ("curve",), (nx * ny,)
        coords = {"x": ("curve", xs.reshape(-1)), "y": ("curve", ys.reshape(-1))}
    else:
        dims, shape, coords = ("y", "x"), (ny, nx), {}
    return xr.Dataset({"E0": (dims, e0.reshape(shape), {"units": "Pa"}),
                       "quality": (dims, q.reshape(shape))},
                      coords={"param_i": ["E0"], **coords}, attrs={"model": "contact"})


def test_pixels_sit_on_their_grid_and_the_bar_has_units():
    handle = map_plot(_map())
    mesh = handle.lines[0]
    grid = np.ma.getdata(mesh.get_array()).reshape(3, 4)
    np.testing.assert_allclose(grid, (1 + np.arange(12)).reshape(3, 4))  # in kPa
    assert handle.axes[1].get_ylabel() == "E0 [kPa]"
    assert handle.axes[0].get_xlabel() == "x [µm]"
    x_edges = mesh.get_coordinates()[0, :, 0]
    np.testing.assert_allclose(x_edges, [-1, 1, 3, 5, 7])  # touching cells, no gaps
    assert "12 of 12 pixels" in handle.axes[0].get_title()


def test_bad_pixels_are_grey_and_counted():
    quality = np.zeros((3, 4), dtype=np.int8)
    quality[0, 0] = 2
    quality[2, 3] = 3
    handle = map_plot(_map(quality=quality))
    grid = handle.lines[0].get_array().reshape(3, 4)
    assert grid.mask[0, 0] and grid.mask[2, 3] and grid.mask.sum() == 2
    assert "10 of 12 pixels\n2 grey: failed, bad fit or not determined" in handle.axes[0].get_title()
    all_shown = map_plot(_map(quality=quality), good_only=False).lines[0].get_array()
    assert not np.ma.getmaskarray(all_shown).any()


def test_a_two_dim_map_without_coordinates_uses_indices_and_log_scale_for_decades():
    ds = _map(curve=False).drop_vars("param_i")
    ds["E0"] = ds["E0"] ** 2 / 1e3  # 1 kPa .. 144 kPa: two decades
    handle = map_plot(ds, "E0")
    from matplotlib.colors import LogNorm

    assert isinstance(handle.lines[0].norm, LogNorm)
    assert handle.axes[0].get_xlabel() == "x [index]"  # no coordinate: indices


def test_bad_requests_name_the_choices():
    with pytest.raises(ParameterError, match=r"variable must be one of the map's variables"):
        map_plot(_map(), "E_inf")
    with pytest.raises(ParameterError, match="result must be an xarray.Dataset"):
        map_plot({"E0": 1})
    all_bad = _map(quality=np.ones((3, 4), dtype=np.int8))
    with pytest.raises(ParameterError, match="no pixel of 'E0' is left to draw"):
        map_plot(all_bad)


def test_the_cli_draws_a_fitted_map(tmp_path, capsys):
    """``fit MAP --plot map.png``: the map of a variable (default the first parameter)."""
    from viscoforce.cli import main
    from viscoforce.schema import make_spectrum

    omega = np.geomspace(10.0, 1e4, 8)
    tau = np.array([[1e-3, 2e-3], [3e-3, 4e-3]])  # four pixels on a 2 x 2 grid
    k = 1.0 + 2.0 * 1j * omega * tau[..., None] / (1 + 1j * omega * tau[..., None])
    ds = make_spectrum(omega, k, 1e-9, 1e-10, dims=("y", "x", "omega"),
                       coords={"x": ("x", [0.0, 2e-6]), "y": ("y", [0.0, 2e-6])},
                       stderr={"stiffness": 0.01 * np.abs(k), "phase": np.full(k.shape, 0.5)})
    path, png = tmp_path / "map.nc", tmp_path / "map.png"
    ds.to_netcdf(path)
    assert main(["fit", str(path), "--model", "prony", "--scheduler", "synchronous",
                 "--plot", str(png), "--plot-variable", "tau_1"]) == 0
    assert png.stat().st_size > 10_000
    assert main(["fit", str(path), "--model", "prony", "--scheduler", "synchronous",
                 "--plot", str(png), "--plot-variable", "nope"]) == 2
    assert "--plot-variable: variable must be one of" in capsys.readouterr().err


def test_jittered_instrument_positions_fall_on_one_grid():
    """The instrument records the nominal grid with pm jitter: 4 x 3 cells, not more."""
    ds = _map()
    jitter = 1e-15 * np.random.default_rng(1).standard_normal(12)
    ds = ds.assign_coords(x=ds.x + jitter, y=ds.y - jitter)
    grid = map_plot(ds).lines[0].get_array()
    assert grid.shape == (12,) or grid.shape == (3, 4)
    np.testing.assert_allclose(np.ma.getdata(grid).reshape(3, 4), (1 + np.arange(12)).reshape(3, 4))
