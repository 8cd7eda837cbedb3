"""A spectrum CSV gets the quality flags and notes of the JPK path; degrees in a rad column refused.

Also the real map's phase-lag workflow: the sensor height already keeps the piezo's lag out of
the phase, so the README's `--phase-lag 300Hz=14` leaves the 300 Hz points outside (0°, 90°)
and they stay flagged, with the reason in the quality comment.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from tests.conftest import REAL_DATA_DIR, REPO
from tests.measured.test_modulation import synthetic
from viscoforce.cli import main
from viscoforce.exceptions import ParameterError, UnitError
from viscoforce.experiments.modulation import correct_spectrum, modulation_spectrum
from viscoforce.io.csv_formats import read_spectrum_csv
from viscoforce.io.instruments import load_instrument
from viscoforce.io.quality import PHASE_REMAINS, phase_basis, spectrum_quality
from viscoforce.schema import make_spectrum

MAP_CANDIDATES = (REPO / "data_examples" / "real" / "modulation-map.jpk-force-map",
                  REAL_DATA_DIR / "PyFMReader"
                  / "map-data-2021.11.05-17.37.44.432.jpk-force-map")
NOTES = ("phase_lag", "drag", "phase_reference", "quality_summary")
COLUMNS = {"stiffness": "N/m", "stiffness_stderr": "N/m", "phase": "deg",
           "phase_stderr": "deg", "mean_force": "N", "drive_amplitude": "m"}


def _real_map() -> Path:
    for path in MAP_CANDIDATES:
        if path.exists():
            return path
    pytest.skip("the real modulation map is absent")


@pytest.fixture(scope="module")
def real_spectrum():
    return modulation_spectrum(_real_map(), contact_point=False, phase_reference="sensor")


def write_csv(spectrum: xr.Dataset, path: Path) -> Path:
    """The spectrum as a spectrum CSV, one row per (curve, frequency), full float precision."""
    rows = ["curve,frequency (Hz)," + ",".join(f"{n} ({u})" for n, u in COLUMNS.items())]
    freq = spectrum["omega"].values / (2 * math.pi)
    for i, curve in enumerate(spectrum["curve"].values):
        for j, f in enumerate(freq):
            cells = [repr(float(spectrum[n].broadcast_like(spectrum["stiffness"]).values[i, j]))
                     for n in COLUMNS]
            rows.append(",".join([str(curve), repr(float(f)), *cells]))
    path.write_text("\n".join(rows) + "\n")
    return path


def assert_same_flags(csv: xr.Dataset, jpk: xr.Dataset) -> None:
    np.testing.assert_array_equal(csv["quality"].values, jpk["quality"].values)
    assert csv["quality"].attrs["flag_meanings"] == jpk["quality"].attrs["flag_meanings"]
    np.testing.assert_array_equal(csv["quality"].attrs["flag_values"],
                                  jpk["quality"].attrs["flag_values"])
    assert csv.attrs["quality_summary"] == jpk.attrs["quality_summary"]
    assert all(key in csv.attrs and key in jpk.attrs for key in NOTES)
    for ds in (csv, jpk):
        assert PHASE_REMAINS in ds["quality"].attrs["comment"]


def test_real_map_csv_flags_equal_the_jpk_paths(real_spectrum, tmp_path):
    csv = read_spectrum_csv(write_csv(real_spectrum, tmp_path / "map.csv"))
    assert_same_flags(csv, real_spectrum)
    assert (csv["quality"].values[:, -1] == 1).all() and (csv["quality"].values[:, :-1] == 0).all()
    assert csv.attrs["phase_lag"] == "none" and csv.attrs["drag"] == 0.0
    assert csv.attrs["phase_reference"] == phase_basis(None)      # the file does not say
    assert "calibrated height sensor" in real_spectrum.attrs["phase_reference"]
    # the same correction on either path gives the same phases, errors and flags
    lag = {float(f): 14.0 if f == 300.0 else 0.0 for f in real_spectrum["frequency"].values}
    jpk = modulation_spectrum(_real_map(), contact_point=False, phase_lag=lag, drag=1e-7,
                              phase_reference="sensor")
    fixed = correct_spectrum(csv, phase_lag=lag, drag=1e-7)
    for name in ("stiffness", "phase", "stiffness_stderr", "phase_stderr", "phase_lag"):
        np.testing.assert_allclose(fixed[name].values, jpk[name].values, rtol=1e-12,
                                   atol=1e-12 * float(np.abs(jpk[name]).max()))
    assert_same_flags(fixed, jpk)
    assert fixed.attrs["drag"] == 1e-7 and fixed.attrs["phase_lag"] == "per-frequency"


def test_noisy_csv_flags_equal_the_jpk_paths_for_every_code(tmp_path):
    curves = synthetic([3.0, 30.0, 300.0], 5e-4, 40.0, n_curves=6, noise=4e-10, seed=4,
                       lag_deg={300.0: 60.0})
    jpk = modulation_spectrum(curves, contact_point=False)
    assert set(np.unique(jpk["quality"].values)) == {0, 1, 2}    # ok, phase and low signal
    csv = read_spectrum_csv(write_csv(jpk, tmp_path / "noisy.csv"))
    assert_same_flags(csv, jpk)
    np.testing.assert_array_equal(
        jpk["quality"].values,
        spectrum_quality(jpk["phase"], jpk["stiffness"], jpk["stiffness_stderr"]))


def test_spectrum_quality_codes():
    phase = np.array([-5.0, 0.0, 30.0, 30.0, 89.9, 90.0, np.nan, 45.0])
    stiffness = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, np.nan])
    stderr = np.array([0.0, 0.0, 0.5, 0.2, 0.4, 0.0, 0.0, 0.1])
    np.testing.assert_array_equal(spectrum_quality(phase, stiffness, stderr),
                                  [1, 1, 2, 0, 2, 1, 0, 0])
    np.testing.assert_array_equal(spectrum_quality(phase), [1, 1, 0, 0, 0, 1, 0, 0])
    # a per-curve error broadcasts over the frequencies
    np.testing.assert_array_equal(
        spectrum_quality(np.full((2, 3), 30.0), np.ones((2, 3)), np.array([[0.1], [0.5]])),
        [[0, 0, 0], [2, 2, 2]])


def _spectrum_csv(path: Path, phases, unit="rad", stderr=None) -> Path:
    header = f"frequency (Hz),stiffness (N/m),phase ({unit})"
    if stderr is not None:
        header += f",phase_stderr ({unit})"
    rows = [header]
    for i, p in enumerate(phases):
        row = f"{10.0 * (i + 1)},0.01,{p}"
        if stderr is not None:
            row += f",{stderr[i]}"
        rows.append(row)
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize(("phases", "stderr", "match"), [
    ([10.0, 25.0, 40.0], None,
     r"column 'phase \(rad\)' holds \|values\| up to 40, outside .* \[-2\*pi, 2\*pi\] = "
     r"\[-6.2832, 6.2832\]: these are degrees; write the header 'phase \(deg\)'"),
    ([0.3, -7.0, 0.5], None, r"up to 7, outside"),
    ([2.0, 3.5, 5.0], None,
     r"column 'phase \(rad\)': every value lies in \(pi/2, 2\*pi\] = \(1.5708, 6.2832\]"),
    ([0.3, 0.4, 0.5], [0.01, 12.0, 0.01], r"column 'phase_stderr \(rad\)' holds \|values\| up "
                                          r"to 12"),
])
def test_degrees_in_a_rad_column_are_refused(tmp_path, phases, stderr, match):
    with pytest.raises(UnitError, match=match):
        read_spectrum_csv(_spectrum_csv(tmp_path / "s.csv", phases, stderr=stderr))


def test_radians_are_read_and_flagged_like_degrees(tmp_path):
    rad = read_spectrum_csv(_spectrum_csv(tmp_path / "r.csv", [0.3, 1.8, 0.6]))
    deg = read_spectrum_csv(_spectrum_csv(tmp_path / "d.csv",
                                          [math.degrees(v) for v in (0.3, 1.8, 0.6)], "deg"))
    np.testing.assert_allclose(rad["phase"].values, deg["phase"].values, rtol=1e-12)
    np.testing.assert_array_equal(rad["quality"].values, [0, 1, 0])   # 1.8 rad = 103°
    np.testing.assert_array_equal(deg["quality"].values, [0, 1, 0])
    assert "103.1 deg" in rad.attrs["quality_summary"]
    # two values are too few to call degrees; a degree column may hold anything
    small = read_spectrum_csv(_spectrum_csv(tmp_path / "two.csv", [2.0, 3.0]))
    assert (small["quality"].values == 1).all()
    read_spectrum_csv(_spectrum_csv(tmp_path / "big.csv", [120.0, 250.0, 300.0], "deg"))


def test_correct_spectrum_refuses_what_it_cannot_do(tmp_path):
    csv = read_spectrum_csv(_spectrum_csv(tmp_path / "s.csv", [0.3, 1.8, 0.6]))
    with pytest.raises(ParameterError, match="needs phase_lag, drag or phase_reference"):
        correct_spectrum(csv)
    lagged = correct_spectrum(csv, phase_lag=20.0)
    np.testing.assert_allclose(lagged["phase"].values,
                               np.degrees([0.3, 1.8, 0.6]) - 20.0, rtol=1e-12)
    np.testing.assert_array_equal(lagged["quality"].values, [1, 0, 0])   # 17.2° − 20° < 0
    assert "20 degree subtracted at every frequency" in lagged["quality"].attrs["comment"]
    with pytest.raises(ParameterError, match="already had an instrument phase lag"):
        correct_spectrum(lagged, phase_lag=1.0)
    dragged = correct_spectrum(lagged, drag=1e-8)        # a drag after a lag is fine
    assert dragged.attrs["phase_lag"] == "scalar" and dragged.attrs["drag"] == 1e-8
    assert "20 degree" in dragged["quality"].attrs["comment"]
    with pytest.raises(ParameterError, match="already had a drag"):
        correct_spectrum(dragged, drag=1e-8)
    with pytest.raises(ParameterError, match="not both"):
        correct_spectrum(csv, phase_lag=1.0, phase_reference=csv)
    with pytest.raises(ParameterError, match="phase_lag must be degrees"):
        correct_spectrum(csv, phase_lag="14")
    with pytest.raises(ParameterError, match="no lag for 20 Hz"):
        correct_spectrum(csv, phase_lag={10.0: 1.0})
    moduli = csv.assign(E_storage=csv["stiffness"] * 0)
    with pytest.raises(ParameterError, match="correct the spectrum first"):
        correct_spectrum(moduli, drag=1e-8)
    bare = make_spectrum([1.0, 2.0], [1.0, 1.0j], 0.0, 1e-9, source="test")
    assert "quality" not in bare
    flagged = correct_spectrum(bare, phase_lag=-5.0)
    assert flagged["quality"].attrs["flag_meanings"].startswith("ok phase_outside")
    np.testing.assert_array_equal(flagged["quality"].values, [0, 1])


def test_real_map_300hz_stays_flagged_after_the_readme_phase_lag(real_spectrum, tmp_path,
                                                                 capsys):
    """`load --phase-lag 300Hz=14` subtracts 14° from the sensor-based phase (104.5–109.8°).

    The 14° is the lag of the height sensor behind the piezo, which a phase measured against the
    sensor does not contain; what is left (90.5–95.8°) is outside (0°, 90°), so the points stay
    flagged: the flag is evaluated on the corrected phase, and the comment says what was
    corrected and what can remain.
    """
    out = tmp_path / "m.nc"
    assert main(["load", str(_real_map()), "--out", str(out), "--phase-lag", "300Hz=14",
                 "--phase-reference", "sensor"]) == 0
    capsys.readouterr()
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        ds.load()
    hz = ds["frequency"].values
    assert hz[-1] == 300.0
    raw = real_spectrum["phase"].values
    assert raw[:, -1].min() > 104.0 and raw[:, -1].max() < 110.0
    np.testing.assert_allclose(ds["phase"].values[:, -1], raw[:, -1] - 14.0, atol=1e-9)
    np.testing.assert_allclose(ds["phase"].values[:, :-1], raw[:, :-1], atol=1e-9)
    np.testing.assert_array_equal(ds["phase_lag"].values, [0, 0, 0, 0, 0, 14.0])
    assert ds["phase"].values[:, -1].min() > 90.0                  # still not passive
    np.testing.assert_array_equal(ds["quality"].values[:, -1], 1)
    np.testing.assert_array_equal(ds["quality"].values[:, :-1], 0)
    np.testing.assert_array_equal(
        ds["quality"].values,
        spectrum_quality(ds["phase"], ds["stiffness"], ds["stiffness_stderr"]))
    comment = ds["quality"].attrs["comment"]
    assert "14 degree at 300 Hz (0 at the others)" in comment
    assert "measuredHeight is the calibrated height sensor" in comment
    assert "piezo's lag behind its drive signal is not in the phase" in comment
    assert PHASE_REMAINS in comment
    assert ds.attrs["quality_summary"].startswith(
        "phase_outside_passive_range: 300 Hz (16 of 16 points, median phase 92.")


def test_the_sensor_already_carries_the_piezo_lag():
    """Against the piezo drive signal the 300 Hz phase is 14–21° lower than against the sensor.

    The sensor lags the piezo (JPK-NOTES: about 14° at 300 Hz, the same on every curve); the
    basis attr of each spectrum says which lag its phase contains.
    """
    curves = load_instrument(_real_map(), curves=[0, 5, 10])
    sensor = modulation_spectrum(curves, contact_point=False)
    piezo = modulation_spectrum(load_instrument(_real_map(), curves=[0, 5, 10],
                                                height_channel="height"), contact_point=False)
    diff = sensor["phase"].values - piezo["phase"].values
    assert np.all(diff[:, -1] > 14.0) and np.all(diff[:, -1] < 25.0)   # 300 Hz
    assert np.all(np.abs(diff[:, :3]) < 3.0)                          # 1–10 Hz: ~1–2°
    assert "not in the phase" in sensor.attrs["phase_reference"]
    assert "piezo's own lag behind it is in the phase" in piezo.attrs["phase_reference"]
