"""Every table (fit --out CSV, a batch's rows) puts each row at its own coordinates (issue 40 item 2).

The CSV rows are compared with the netCDF the same fit writes: each row's (y, x) must be the
coordinates of the pixel whose parameters the row holds.
"""

from __future__ import annotations

import csv

import numpy as np
import pytest
import xarray as xr

from viscoforce.cli import main
from viscoforce.data import example_path
from viscoforce.schema import flat_over
from viscoforce.schema.curves import SchemaError


def _rows(path):
    with open(path, newline="") as handle:
        return list(csv.DictReader(handle))


def _fit(tmp_path, data, stem, *extra):
    csv_path, nc_path = tmp_path / f"{stem}.csv", tmp_path / f"{stem}.nc"
    for out in (csv_path, nc_path):
        assert main(["fit", str(data), "--model", "prony", "--out", str(out), *extra]) == 0
    with xr.open_dataset(nc_path) as ds:
        return _rows(csv_path), ds.load()


def _check_rows_against_netcdf(rows, fits):
    """Each row's coordinates and k_inf are those of one pixel of the netCDF, all pixels once."""
    assert len(rows) == int(np.prod([fits.sizes[d] for d in fits["success"].dims]))
    seen = set()
    for row in rows:
        where = {d: float(row[f"{d} (m)"]) for d in fits["success"].dims}
        pixel = fits.sel(where)
        assert float(row["k_inf (N/m)"]) == pytest.approx(float(pixel["k_inf"]), rel=1e-9)
        seen.add(tuple(where.values()))
    assert len(seen) == len(rows)


@pytest.fixture(scope="module")
def spectrum_map():
    with xr.open_dataset(example_path("sls_spectrum_map.nc")) as ds:
        return ds.load()


def test_the_shipped_map_csv_has_the_netcdf_y_x_on_every_row(capsys, tmp_path):
    rows, fits = _fit(tmp_path, example_path("sls_spectrum_map.nc"), "fits")
    assert fits["success"].dims == ("y", "x")
    _check_rows_against_netcdf(rows, fits)
    # C order over (y, x): y outermost
    assert [(float(r["y (m)"]), float(r["x (m)"])) for r in rows[:5]] == [
        (0.0, 0.0), (0.0, 1e-6), (0.0, 2e-6), (0.0, 3e-6), (1e-6, 0.0)]


def test_a_non_square_map_csv(capsys, tmp_path, spectrum_map):
    path = tmp_path / "narrow.nc"
    spectrum_map.isel(x=slice(0, 3)).to_netcdf(path)
    rows, fits = _fit(tmp_path, path, "narrow_fits")
    assert fits.sizes["y"] == 4 and fits.sizes["x"] == 3
    _check_rows_against_netcdf(rows, fits)


def test_a_one_dimensional_map_csv(capsys, tmp_path, spectrum_map):
    path = tmp_path / "line.nc"
    spectrum_map.isel(y=2).drop_vars("y").to_netcdf(path)
    rows, fits = _fit(tmp_path, path, "line_fits")
    assert fits["success"].dims == ("x",)
    _check_rows_against_netcdf(rows, fits)


def test_a_non_square_map_keeps_its_rows_in_a_batch(capsys, tmp_path, spectrum_map):
    folder = tmp_path / "batch"
    folder.mkdir()
    spectrum_map.isel(x=slice(0, 3)).to_netcdf(folder / "a_narrow.nc")
    spectrum_map.isel(y=slice(0, 2)).to_netcdf(folder / "b_wide.nc")
    out = tmp_path / "batch.csv"
    assert main(["fit", str(folder), "--model", "prony", "--out", str(out)]) == 0
    rows = _rows(out)
    by_file = {}
    for row in rows:
        by_file.setdefault(row["file"].rsplit("/", 1)[-1], []).append(row)
    assert len(by_file["a_narrow.nc"]) == 12 and len(by_file["b_wide.nc"]) == 8
    assert all(row["success"] == "1" for row in rows)
    narrow = spectrum_map.isel(x=slice(0, 3))
    assert {(float(r["y (m)"]), float(r["x (m)"])) for r in by_file["a_narrow.nc"]} == {
        (float(y), float(x)) for y in narrow["y"].values for x in narrow["x"].values}


def test_flat_over_broadcasts_by_dim_name():
    ds = xr.Dataset({"v": (("y", "x"), np.arange(6.0).reshape(2, 3))},
                    coords={"y": [10.0, 20.0], "x": [1.0, 2.0, 3.0]})
    assert flat_over(ds, "y", ("y", "x")).tolist() == [10, 10, 10, 20, 20, 20]
    assert flat_over(ds, "x", ("y", "x")).tolist() == [1, 2, 3, 1, 2, 3]
    assert flat_over(ds, "v", ("x", "y")).tolist() == [0, 3, 1, 4, 2, 5]
    with pytest.raises(SchemaError, match="not one value per row"):
        flat_over(ds, "v", ("y",))


def test_an_output_onto_a_file_of_an_input_folder_is_refused(capsys, tmp_path, spectrum_map):
    folder = tmp_path / "inputs"
    folder.mkdir()
    spectrum_map.isel(y=slice(0, 1)).to_netcdf(folder / "m.nc")
    victim = folder / "a.csv"
    victim.write_text("frequency (Hz),stiffness (N/m),phase (deg)\n1,100,10\n2,110,12\n3,120,14\n")
    before = victim.read_bytes()
    assert main(["fit", str(folder), "--model", "prony", "--out", str(victim)]) == 2
    assert "is an input of this command" in capsys.readouterr().err
    assert victim.read_bytes() == before


def test_the_viewer_table_of_a_non_square_map(capsys, tmp_path, spectrum_map):
    from viscoforce.plotting.viewer import pixel_table

    path = tmp_path / "narrow.nc"
    spectrum_map.isel(x=slice(0, 3)).to_netcdf(path)
    _, fits = _fit(tmp_path, path, "narrow_fits")
    rows = pixel_table(fits)
    assert len(rows) == 12
    for row in rows:
        pixel = fits.sel(y=row["y"], x=row["x"])
        assert row["k_inf"] == pytest.approx(float(pixel["k_inf"]), rel=1e-12)
    assert {(r["y"], r["x"]) for r in rows} == {
        (float(y), float(x)) for y in fits["y"].values for x in fits["x"].values}
