"""``viscoforce load``: instrument files to curves or a modulation spectrum (netCDF, --json)."""

from __future__ import annotations

import hashlib
import json

import pytest
import xarray as xr

from tests.conftest import REAL_DATA_DIR, REPO
from viscoforce.cli import main

FIXTURES = REPO / "tests" / "data" / "jpk"
MAP = REAL_DATA_DIR / "PyFMReader" / "map-data-2021.11.05-17.37.44.432.jpk-force-map"


def _sha(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _load_json(capsys, argv):
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_load_fixture_curves_json_keys(capsys, tmp_path):
    src = FIXTURES / "synthetic-2x2.jpk-force-map"
    before = _sha(src)
    out = tmp_path / "curves.nc"
    result = _load_json(capsys, ["load", str(src), "--raw", "--out", str(out), "--json"])
    assert set(result) == {"format", "kind", "n_curves", "dims", "variables"}
    assert result["kind"] == "curves" and result["n_curves"] == 4
    assert "force" in result["variables"]
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.force.attrs["units"] == "N" and ds.sizes["curve"] == 4
    assert _sha(src) == before


def test_load_modulation_map_gives_a_spectrum(capsys, tmp_path):
    if not MAP.exists():
        pytest.skip("real data folder absent")
    out = tmp_path / "spectrum.nc"
    result = _load_json(capsys, ["load", str(MAP), "--out", str(out), "--json",
                                 "--phase-lag", "300Hz=14", "100Hz=4"])
    assert result["kind"] == "spectrum" and result["n_curves"] == 16
    assert result["dims"]["omega"] == 6 and result["dims"]["curve"] == 16
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.stiffness.attrs["units"] == "N/m" and ds.phase.attrs["units"] == "degree"
        assert "stiffness_stderr" in ds and "quality" in ds


@pytest.mark.parametrize(("argv", "message"), [
    (["load", "/nonexistent.jpk-force"], "nonexistent"),
    (["load", "FIX", "--phase-lag", "abc"], "FREQUENCY=DEGREES"),
    (["load", "FIX", "--raw", "--drag", "1e-6N*s/m"], "and --phase-reference correct a spectrum"),
    (["load", "FIX", "--out", "x.txt"], ".nc"),
    (["load", "FIX", "--phase-lag", "14", "300Hz=2"], "not both"),
])
def test_load_user_errors_exit_2(capsys, argv, message):
    argv = [str(FIXTURES / "synthetic-2x2.jpk-force-map") if a == "FIX" else a for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


@pytest.mark.parametrize("raw", [True, False])
def test_load_output_round_trips_unchanged(tmp_path, capsys, raw):
    """What `load` writes (h5netcdf) reads back identical to the dataset it computed."""
    from viscoforce.experiments.modulation import modulation_spectrum
    from viscoforce.io.instruments import load_instrument

    src = FIXTURES / "synthetic.jpk-force" if raw else MAP
    if not src.exists():
        pytest.skip("real data folder absent")
    # the spectrum from the archive: it carries the piezo record, so the default phase
    # reference is the one the data support (load_instrument's curves lack it)
    expected = load_instrument(src) if raw else modulation_spectrum(src)
    out = tmp_path / "ds.nc"
    argv = ["load", str(src), "--out", str(out), "--json"] + (["--raw"] if raw else [])
    assert main(argv) == 0
    capsys.readouterr()
    with xr.open_dataset(out, engine="h5netcdf") as back:
        xr.testing.assert_identical(back.load(), expected)


def test_load_with_the_map_as_its_own_phase_reference_has_zero_median_phase(capsys, tmp_path):
    if not MAP.exists():
        pytest.skip("real data folder absent")
    out = tmp_path / "s.nc"
    assert main(["load", str(MAP), "--phase-reference", str(MAP), "--out", str(out)]) == 0
    capsys.readouterr()
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        median = ds.phase.median("curve").values
    assert abs(median).max() < 1.0  # degrees; the median curve of the map itself is the lag
