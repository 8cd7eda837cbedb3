"""Tables people expect (issue 38 item 7): a spectrum as CSV that reads back, fitted curves in bulk."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
import xarray as xr

import viscoforce as vf
from tests.io.test_map_grid import BUNDLED, PYFMRHEO
from viscoforce.exceptions import ParameterError, SchemaError
from viscoforce.fitting.curves import fit_curve
from viscoforce.io.csv_spectrum import read_spectrum_csv
from viscoforce.io.csv_tables import spectrum_table, write_spectrum_csv
from viscoforce.io.fit_tables import export_fits, fit_curves_table

#: Relative agreement of what goes through k* = stiffness e^{i phase} on reading (1 ulp or so)
THROUGH_K = 1e-14
#: The fits of real and example curves warn about their goodness of fit (not what is tested here)
def QUIET_FITS(test):  # noqa: N802 (a marker)
    for category in ("GoodnessOfFitWarning", "DataWarning"):
        test = pytest.mark.filterwarnings(f"ignore::viscoforce.exceptions.{category}")(test)
    return test


@pytest.fixture(scope="module")
def map_spectrum():
    """The bundled real map's spectrum with E', E'', G', G'' (load --tip sphere:5um)."""
    return vf.open_data(BUNDLED, tip="sphere:5um")


def read_table(path):
    return pd.read_csv(path, comment="#")


def assert_same_spectrum(back, ds, dims):
    """Every variable the table holds reads back to the spectrum's values (NaN where NaN)."""
    for name in ("stiffness", "phase", "force_amplitude"):
        np.testing.assert_allclose(back[name].values, ds[name].transpose(*dims).values,
                                   rtol=THROUGH_K, atol=0, err_msg=name)
    exact = [v for v in back.data_vars if v not in ("stiffness", "phase", "force_amplitude")
             and v in ds.variables]
    assert exact
    for name in exact:
        expected = ds[name].broadcast_like(ds["stiffness"]).transpose(*dims).values
        np.testing.assert_array_equal(back[name].values, expected, err_msg=name)
        if "units" in ds[name].attrs:
            assert back[name].attrs["units"] == ds[name].attrs["units"], name
    np.testing.assert_array_equal(back["omega"].values, ds["omega"].values)


# ── the spectrum table ──────────────────────────────────────────────────────────────────────


def test_map_spectrum_with_moduli_round_trips(tmp_path, map_spectrum):
    ds = map_spectrum
    out = tmp_path / "spectrum.csv"
    written = write_spectrum_csv(ds, out)
    assert written["rows"] == 16 * 6
    columns = written["columns"]
    assert columns[0] == "curve" and {"x (m)", "y (m)"} <= set(columns)
    assert columns.index("frequency (Hz)") + 1 == columns.index("omega (rad/s)") < \
        columns.index("stiffness (N/m)")
    for name in ("stiffness (N/m)", "stiffness_stderr (N/m)", "phase (deg)",
                 "phase_stderr (deg)", "mean_force (N)", "mean_indentation (m)",
                 "E_storage (Pa)", "E_loss_stderr (Pa)", "G_storage (Pa)", "G_loss (Pa)",
                 "quality (1)"):
        assert name in columns, name
    text = out.read_text(encoding="utf-8")
    assert text.startswith("# viscoforce spectrum table") and "# tip: sphere R = 5" in text
    table = read_table(out)
    first = table[table["curve"] == 3]
    np.testing.assert_array_equal(first["frequency (Hz)"], ds["frequency"].values)
    np.testing.assert_array_equal(first["E_storage (Pa)"], ds["E_storage"].sel(curve=3).values)
    back = read_spectrum_csv(out)
    assert back.sizes == {"curve": 16, "omega": 6}
    assert_same_spectrum(back, ds, ("curve", "omega"))
    for name in ("E_storage", "E_loss", "G_storage", "G_loss", "quality", "mean_indentation"):
        assert name in back.data_vars, name
    for name in ("curve", "x", "y", "row", "column"):   # row, column: where the spectrum has them
        if name in ds.coords:
            np.testing.assert_array_equal(back[name].values, ds[name].values)
    assert dict(back.set_index(curve=["y", "x"]).unstack().sizes) == {"y": 4, "x": 4, "omega": 6}
    assert vf.open_data(out).sizes == back.sizes          # the format is detected


def test_yx_map_round_trips_through_its_coordinates(tmp_path):
    ds = vf.open_data(vf.example_path("sls_spectrum_map.nc"))
    out = tmp_path / "map.csv"
    write_spectrum_csv(ds, out)
    table = read_table(out)
    assert list(table.columns[:3]) == ["curve", "y (m)", "x (m)"]
    assert table["curve"].nunique() == 16
    back = read_spectrum_csv(out).set_index(curve=["y", "x"]).unstack()
    np.testing.assert_allclose(back["stiffness"].transpose("y", "x", "omega").values,
                               ds["stiffness"].values, rtol=THROUGH_K)
    np.testing.assert_array_equal(back["stiffness_stderr"].transpose("y", "x", "omega").values,
                                  ds["stiffness_stderr"].broadcast_like(ds["stiffness"]).values)


def test_single_spectrum_round_trips_and_nan_cells_stay_nan(tmp_path):
    ds = vf.open_data(vf.example_path("sls_spectrum.csv"))
    ds = ds.assign(mean_indentation=("omega", np.where(np.arange(ds.sizes["omega"]) % 3 == 0,
                                                       np.nan, 2e-9), {"units": "m"}))
    out = tmp_path / "one.csv"
    write_spectrum_csv(ds, out)
    assert "curve" not in read_table(out).columns
    first_row = [t for t in out.read_text().splitlines() if not t.startswith("#")][1]
    assert ",," in first_row                              # NaN is an empty cell
    back = read_spectrum_csv(out)
    assert back.sizes == {"omega": 25}
    assert_same_spectrum(back, ds, ("omega",))
    assert np.isnan(back["mean_indentation"].values[::3]).all()


def test_spectrum_table_is_a_dataframe_and_bad_input_is_refused(map_spectrum):
    table = spectrum_table(map_spectrum.isel(curve=[0]))
    assert isinstance(table, pd.DataFrame) and len(table) == 6
    with pytest.raises(SchemaError):
        spectrum_table(xr.Dataset())
    with pytest.raises(ParameterError, match="path must be a file path"):
        write_spectrum_csv(map_spectrum, 3)


def test_a_failed_write_leaves_the_previous_file(tmp_path, map_spectrum, monkeypatch):
    out = tmp_path / "s.csv"
    out.write_text("before")
    import viscoforce.io.csv_tables as tables

    monkeypatch.setattr(tables, "table_text", lambda *a: (_ for _ in ()).throw(OSError("full")))
    with pytest.raises(OSError, match="full"):
        write_spectrum_csv(map_spectrum, out)
    assert out.read_text() == "before"


@pytest.mark.parametrize(("text", "match"), [
    ("frequency (Hz),omega (rad/s),stiffness (N/m),phase (deg)\n1,6.2831853,1,1\n"
     "2,13,1,1\n", "disagree at .*exactly one frequency column"),
    ("curve,x (m),frequency (Hz),stiffness (N/m),phase (deg)\na,1e-6,1,1,1\na,2e-6,2,1,1\n",
     "'x' must hold one value per curve"),
    ("curve,row (1),frequency (Hz),stiffness (N/m),phase (deg)\na,0.5,1,1,1\na,0.5,2,1,1\n",
     "'row' must hold integers"),
    ("frequency (Hz),stiffness (N/m),phase (deg),quality (1)\n1,1,1,7\n",
     "'quality' at .* not one of the codes"),
])
def test_reader_refuses_inconsistent_tables(tmp_path, text, match):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ParameterError, match=match):
        read_spectrum_csv(path)


def test_reader_takes_omega_when_both_frequency_columns_agree(tmp_path):
    w = 2 * math.pi * np.array([1.0, 3.0])
    path = tmp_path / "both.csv"
    path.write_text("frequency (Hz),omega (rad/s),stiffness (N/m),phase (deg)\n"
                    f"1,{float(w[0])!r},1,10\n3,{float(w[1])!r},2,20\n")
    back = read_spectrum_csv(path)
    np.testing.assert_array_equal(back["omega"].values, w)
    assert back.attrs["frequency_column"] == "omega"


# ── fitted curves and residuals ─────────────────────────────────────────────────────────────


def test_spectrum_fit_table_holds_data_fit_and_residual(tmp_path):
    data = vf.open_data(vf.example_path("sls_spectrum.csv"))
    result = vf.fit_spectrum(data, "prony")
    out = tmp_path / "fit.csv"
    written = export_fits(result, data, out)
    assert (written["rows"], written["curves"]) == (25, 1)
    table = read_table(out)
    np.testing.assert_array_equal(table["stiffness (N/m)"], data["stiffness"].values)
    fit = result["fit_stiffness"].sel(omega=data["omega"].values).values
    np.testing.assert_array_equal(table["fit_stiffness (N/m)"], fit)
    np.testing.assert_allclose(table["residual_stiffness (N/m)"],
                               data["stiffness"].values - fit, rtol=1e-15)
    np.testing.assert_allclose(table["residual_phase (deg)"],
                               data["phase"].values - result["fit_phase"].sel(
                                   omega=data["omega"].values).values, atol=1e-12)
    assert "model prony" in out.read_text().splitlines()[0]


def test_spectrum_map_fit_table_has_one_block_per_pixel(tmp_path):
    data = vf.open_data(vf.example_path("sls_spectrum_map.nc"))
    result = vf.fit_map(data, "prony", scheduler="synchronous", progress=False)
    table = fit_curves_table(result, data)
    assert len(table) == 16 * 12 and table["curve"].nunique() == 16
    pixel = table[table["curve"] == 5]                    # C order over (y, x): y[1], x[1]
    assert pixel["y (m)"].unique().tolist() == [float(data["y"][1])]
    assert pixel["x (m)"].unique().tolist() == [float(data["x"][1])]
    expected = result["fit_stiffness"].isel(y=1, x=1).sel(omega=data["omega"].values).values
    np.testing.assert_array_equal(pixel["fit_stiffness (N/m)"], expected)
    with pytest.raises(ParameterError, match="the fit result is over"):
        fit_curves_table(result, data.isel(y=0, x=0))


@QUIET_FITS
def test_relaxation_fit_table_recovers_the_fitted_samples(tmp_path):
    data = vf.open_data(vf.example_path("sls_step_relaxation.csv"))
    result = fit_curve(data, "relaxation")
    written = export_fits(result, data, tmp_path / "relax.csv")
    table = read_table(tmp_path / "relax.csv")
    assert written["columns"][-4:] == ["time (s)", "force (N)", "fit_force (N)",
                                       "residual_force (N)"]
    np.testing.assert_array_equal(np.sort(table["time (s)"]), result["time"].values)
    residual = table["residual_force (N)"].to_numpy()
    np.testing.assert_allclose(table["force (N)"] - table["fit_force (N)"], residual, rtol=1e-12,
                               atol=1e-18)
    span = np.ptp(table["force (N)"])                      # 2.98 -> 1.59 uN, 2 nN noise
    assert np.sqrt(np.mean(residual**2)) < 0.01 * span


@pytest.mark.skipif(not PYFMRHEO.exists(), reason="real data folder absent")
@QUIET_FITS
def test_hertz_fits_of_several_pixels_are_one_table(tmp_path):
    data = vf.open_data(PYFMRHEO, raw=True)
    results = [fit_curve(data, "hertz", curve=i, tip="sphere:5um") for i in (2, 7)]
    written = export_fits(results, data, tmp_path / "hertz.csv")
    table = read_table(tmp_path / "hertz.csv")
    assert written["curves"] == 2 and sorted(table["curve"].unique()) == [2, 7]
    assert {"row (1)", "column (1)", "x (m)", "y (m)"} <= set(table.columns)
    for result, (curve, rows) in zip(results, table.groupby("curve"), strict=True):
        assert rows["row (1)"].unique().tolist() == [int(data["row"][curve])]
        np.testing.assert_array_equal(np.sort(rows["tip_position (m)"]),
                                      result["tip_position"].values)
    moved = data.assign(tip_position=data["tip_position"] + 1e-9)   # not the fitted samples
    with pytest.raises(ParameterError, match="not the fitted ones"):
        fit_curves_table(results[0], moved)


@QUIET_FITS
def test_results_without_best_fit_curves_are_refused_with_the_way_out():
    data = vf.open_data(vf.example_path("sls_step_relaxation.csv"))
    result = fit_curve(data, "relaxation").drop_vars(["fit_force", "time"])
    with pytest.raises(ParameterError, match=r"stores no best-fit curve.*fit_curve\(data"):
        fit_curves_table(result, data)
    with pytest.raises(ParameterError, match="no fit result given"):
        fit_curves_table([], data)
    with pytest.raises(ParameterError, match="path must be a file path"):
        export_fits(fit_curve(data, "relaxation"), data, None)


def test_bode_and_load_write_a_spectrum_csv_that_reads_back(tmp_path, capsys):
    """Issue 38 item 7: `bode ... --out c0.csv` and `load ... --out s.csv` (was refused)."""
    from viscoforce.cli import main
    from viscoforce.io.csv_spectrum import read_spectrum_csv

    out = tmp_path / "s.csv"
    assert main(["load", "example:sls_modulation.jpk-force", "--out", str(out)]) == 0
    back = read_spectrum_csv(out)
    assert back.sizes["omega"] > 1 and "stiffness" in back
    c0 = tmp_path / "c0.csv"
    assert main(["bode", "example:sls_modulation.jpk-force", "--tip", "sphere:5um",
                 "--out", str(c0)]) == 0
    capsys.readouterr()
    header = next(line for line in c0.read_text().splitlines() if not line.startswith("#"))
    assert "E_storage (Pa)" in header and "G_loss (Pa)" in header
