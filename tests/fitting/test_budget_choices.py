"""The choices of the error budget made the other way (issue 37 item 1): fit window, contact point
method, sample height, a map's height record and depth range, and the identifiability rule.

The narrower window and the rise's contact point are checked on synthetic data whose answer is
known by construction (which samples are left out; the contact point the curve was made with);
the shifts through the budget's own rules on hand-made results; the commands on the real map.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from viscoforce.fitting.budget import add_budget, add_map_budget
from viscoforce.fitting.budget_choices import (
    WINDOW_KEEP,
    depth_range_alternative,
    narrowed_window,
    other_contact_point,
)
from viscoforce.schema import make_curves

REAL_MAP = (Path(__file__).resolve().parents[3] / "shared" / "data" / "real" / "PyFMRheo"
            / "map-data-2022.10.29-12.27.34.564.jpk-force-map")
CONTACT = 1e-6  # the synthetic curve's contact point [m]


def _hertz_curve(noise: float = 2e-12, seed: int = 0) -> xr.Dataset:
    """An approach 0 -> 2 um over 0.1 s onto a 1 kPa paraboloid contact at z = 1 um."""
    rng = np.random.default_rng(seed)
    t = np.arange(4000) * (0.1 / 2000)
    z = np.where(t < 0.1, 20e-6 * t, 20e-6 * (0.2 - t))
    delta = np.clip(z - CONTACT, 0.0, None)
    force = 4.0 / 3.0 * 1e3 * math.sqrt(5e-6) * delta ** 1.5 + noise * rng.standard_normal(t.size)
    return make_curves(t, force, -z, np.zeros_like(z), tip_position=z,
                       segment=(t >= 0.1).astype(int), segment_names=("approach", "retract"),
                       source="synthetic")


def _fitted(params: dict[str, float], **attrs) -> xr.Dataset:
    ds = xr.Dataset({n: xr.DataArray(v, attrs={"units": "m" if n == "contact_point" else "Pa"})
                     for n, v in params.items()})
    ds = ds.assign_coords(param_i=("param_i", list(params)))
    ds.attrs.update(attrs)
    return ds


def test_a_spectrums_window_loses_the_top_quarter_of_its_log_frequency_span():
    omega = 2 * np.pi * np.logspace(0, 3, 25)
    data = xr.Dataset({"stiffness": ("omega", np.ones(25))}, coords={"omega": omega})
    out, text = narrowed_window(data, _fitted({"E0": 1.0, "E_inf": 1.0, "tau": 1.0}),
                                "spectrum")
    top = 2 * np.pi * 10 ** (3 * WINDOW_KEEP)
    np.testing.assert_array_equal(out["omega"].values, omega[omega <= top * (1 + 1e-9)])
    assert out.sizes["omega"] == 19 and "178 Hz" in text
    few = data.isel(omega=slice(0, 7))  # 5 of 7 left: fewer than twice 3 parameters
    assert narrowed_window(few, _fitted({"E0": 1.0, "E_inf": 1.0, "tau": 1.0}),
                           "spectrum") is None


def test_a_curves_window_loses_the_last_quarter_in_time_of_its_samples_in_contact():
    data = _hertz_curve()
    n = int(data.sizes["sample"])
    result = _fitted({"E0": 1e3, "contact_point": CONTACT}, segment_start=0.0, data_points=n)
    out, text = narrowed_window(data, result, "curves")
    t = data["time"].values
    z = data["tip_position"].values
    first = int(np.flatnonzero(z >= CONTACT)[0])  # contact: from the approach to the end
    cut = t[first] + WINDOW_KEEP * (t[-1] - t[first])
    dropped = np.isnan(out["force"].values)
    np.testing.assert_array_equal(dropped, t > cut)
    np.testing.assert_array_equal(np.isnan(out["tip_position"].values), dropped)
    assert np.isfinite(data["force"].values).all()  # the data given are not touched
    assert "in contact" in text


def test_the_rise_finds_the_contact_point_the_curve_was_made_with():
    data = _hertz_curve()
    result = _fitted({"E0": 1e3, "contact_point": CONTACT + 3e-8}, tip_shape="paraboloid")
    zc, text = other_contact_point(data, result)
    assert abs(zc - CONTACT) < 2e-8  # the 5-sigma rise of a 2 pN-noise curve, refined
    assert "instead of fitted" in text
    assert other_contact_point(data, _fitted({"E0": 1e3})) is None  # no free contact point


def test_the_hertz_depth_range_is_its_depth_checks_shallow_modulus():
    result = _fitted({"E": 3000.0, "contact_point": CONTACT}, depth_check_E=2000.0)
    result["E_young"] = result["E"] * 0.375
    other, text = depth_range_alternative(result)
    assert float(other["E"]) == 2000.0 and float(other["E_young"]) == pytest.approx(750.0)
    assert float(other["contact_point"]) == CONTACT
    assert "50 %" in text
    assert depth_range_alternative(_fitted({"E": 3000.0})) is None


def test_a_parameter_the_profile_does_not_bound_is_never_determined():
    """Issue 37 item 4: a one-sided profile, however small its calibration shifts."""
    ds = _fitted({"E0": 1e4, "tau": 0.1})
    ds["E0_stderr"] = xr.DataArray(10.0, attrs={"units": "Pa"})
    ds["tau_stderr"] = xr.DataArray(1e-3, attrs={"units": "s"})
    ds["identifiability"] = ("param_i", np.array([1, 0], dtype=np.int8))
    out = add_budget(ds, {"spring_constant": {"E0": 1.0}})
    assert int(out["E0_budget_determined"]) == 0
    assert int(out["tau_budget_determined"]) == 1
    assert "E0 is not determined by these data: the fit's identifiability test does not " \
           "bound it" in out.attrs["budget_notes"]
    pixels = xr.Dataset({"E0": ("curve", [1e4, 1e4]), "E0_stderr": ("curve", [10.0, 10.0]),
                         "identifiability": (("curve", "param_i"), [[0], [2]])},
                        coords={"param_i": ["E0"]})
    pixels["E0"].attrs["units"] = "Pa"
    mapped = add_map_budget(pixels, {"spring_constant": 0.0, "sensitivity": 0.0})
    np.testing.assert_array_equal(mapped["E0_budget_determined"].values, [1, 0])


def test_a_maps_alternative_shifts_count_where_the_choice_is_open_only():
    e = xr.DataArray([1e4, 1e4, 1e4], dims="curve", attrs={"units": "Pa"})
    ds = xr.Dataset({"E": e, "E_stderr": ("curve", [10.0, 10.0, 10.0])}).assign_coords(
        param_i=("param_i", ["E"]))
    shifts = {"height_record": {"E": xr.DataArray([5e3, np.nan, 10.0], dims="curve")}}
    out = add_map_budget(ds, {"spring_constant": 0.0, "sensitivity": 0.0}, shifts,
                         {"height_record": "the other record"})
    np.testing.assert_allclose(out["E_systematic"].sel(budget_source="height_record"),
                               [5e3, 0.0, 10.0])
    np.testing.assert_array_equal(out["E_budget_determined"].values, [1, 1, 1])
    assert "E moves by more than 2 stderr with the height record on 1 of 3 pixels" in out.attrs[
        "budget_notes"]
    assert "height_record: the other record" in out.attrs["budget_sources"]


@pytest.mark.skipif(not REAL_MAP.is_file(), reason=f"{REAL_MAP} absent")
def test_hertz_on_the_real_map_carries_its_depth_range_and_says_calibration_only(capsys):
    from viscoforce.cli import main

    args = ["fit", str(REAL_MAP), "--model", "hertz", "--tip", "sphere:5um", "--curve", "0",
            "--json"]
    assert main(args) == 0
    info = json.loads(capsys.readouterr().out)
    e = info["params"]["E"]
    shift = e["systematic"]["fit_window"]
    assert shift == pytest.approx(info["depth_check_E"] - e["value"], rel=1e-9)
    assert abs(shift) > 2 * e["stderr"] and not e["determined"]
    assert any("with the fit window" in n for n in info["budget_notes"])
    # the contact point held where the approach rises 5 sigma above its noise, refitted
    c = info["params"]["contact_point"]
    assert 0 < abs(c["systematic"]["contact_point"]) < 1e-7  # within 100 nm of the fitted one
    assert "contact_point: held at" in info["budget_sources"]
    assert info["budget_refits"] == 2  # the height record and the contact point
    young = info["derived"]["E_young"]
    assert young["value"] > 0
    assert main([*args[:-1], "--budget", "calibration", "--json"]) == 0
    quiet = json.loads(capsys.readouterr().out)
    assert set(quiet["params"]["E"]["systematic"]) == {"spring_constant", "sensitivity", "tip",
                                                       "poisson"}
    assert "height_record" not in quiet


def test_the_sensor_phase_alternative_is_the_spectrum_made_against_the_sensor():
    """The budget's phase reference alternative without a second read: the points a delay- or
    piezo-referred spectrum keeps against the sensor equal the spectrum made with
    phase_reference="sensor" (the same lock-in, referred otherwise)."""
    import warnings

    import viscoforce as vf
    from viscoforce.cli._fit_budget import sensor_phase_data

    path = vf.example_path("real/modulation-map.jpk-force-map")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        referred, sensor = vf.open_data(path), vf.open_data(path, phase_reference="sensor")
    assert referred.attrs["phase_reference_mode"] == "delay"
    alt = sensor_phase_data(referred)
    for name in ("stiffness", "phase", "drive_amplitude", "stiffness_stderr", "phase_stderr"):
        np.testing.assert_allclose(alt[name].values, sensor[name].values, rtol=1e-12)
    assert alt.attrs["phase_reference_mode"] == "sensor"
    assert sensor_phase_data(sensor) is None  # referred to the sensor already: no alternative
