"""Modulation segments → spectrum: synthetic segments with known k*, drift and noise; the real map."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.experiments.modulation import modulation_spectrum
from viscoforce.io.jpk import read_jpk
from viscoforce.schema import make_curves, validate_spectrum

FIXTURES = Path(__file__).resolve().parents[1] / "data" / "jpk"
REAL = Path(__file__).resolve().parents[3] / "shared" / "data" / "real"
KC = 0.1  # cantilever spring constant [N/m]


def synthetic(freqs, stiffness, phase_deg, *, seed=0, n_curves=2, amplitude=10e-9, periods=12,
              per_period=64, noise=0.0, drift=0.0, transient=0.0, lag_deg=None):
    """Curves dataset: approach, then one modulation segment per frequency, per curve.

    δ(t) = A sin ωt + drift·t, F = F0 + |k|A sin(ωt + χ) + KC·drift·t; the deflection noise
    enters both F (× KC) and δ (with the opposite sign), as on an instrument.
    """
    rng = np.random.default_rng(seed)
    lag_deg = lag_deg or {}
    cols = {k: [] for k in ("time", "force", "height", "deflection", "segment")}
    names, types, freq_col, amp_col, counts = [], [], [], [], []
    for _ in range(n_curves):
        t0, n_curve = 0.0, 0
        rows = [("approach", None)] + [("modulation", f) for f in freqs]
        for name, f in rows:
            if f is None:
                t = t0 + np.arange(20) * 1e-3
                delta = np.linspace(-50e-9, 0, t.size)
                force = np.where(delta > 0, delta, 0.0) + 1e-10
            else:
                w = 2 * np.pi * f
                n = periods * per_period + 1  # exactly `periods` periods long
                t = t0 + np.arange(n) / (f * per_period)
                chi = np.radians(phase_deg + lag_deg.get(f, 0.0))
                delta = amplitude * np.sin(w * t) + drift * (t - t0)
                force = (2e-9 + stiffness * amplitude * np.sin(w * t + chi)
                         + KC * drift * (t - t0))
                early = t < t0 + 0.9 / f
                force = force + transient * early * np.cos(3 * w * t)
            clean = force / KC
            defl = clean + noise * rng.standard_normal(t.size)
            height = -delta - clean          # so that -height - defl = delta - noise
            cols["time"].append(t)
            cols["force"].append(KC * defl)
            cols["height"].append(height)
            cols["deflection"].append(defl)
            cols["segment"].append(np.full(t.size, len(names), dtype=np.int32))
            names.append(name)
            types.append("sine-z-modulation-segment-settings" if f else "z-extend-height")
            freq_col.append(f if f else np.nan)
            amp_col.append(15e-9 if f else np.nan)
            t0 = t[-1] + (t[-1] - t[-2])
            n_curve += t.size
        counts.append(n_curve)
    flat = {k: np.concatenate(v) for k, v in cols.items()}
    ds = make_curves(flat["time"], flat["force"], flat["height"], flat["deflection"],
                     segment=flat["segment"], segment_names=names, segment_types=types,
                     sample_count=counts, per_curve={"x": np.arange(n_curves) * 1e-6,
                                                     "y": np.zeros(n_curves)},
                     attrs={"height_channel": "height"}, source="synthetic-test")
    return ds.assign(segment_frequency=("segment_table", np.asarray(freq_col), {"units": "Hz"}),
                     segment_amplitude=("segment_table", np.asarray(amp_col), {"units": "m"}))


def test_elastic_contact_gives_zero_phase_and_positive_stiffness():
    ds = synthetic([10.0, 1.0, 100.0], 0.05, 0.0)
    spec = modulation_spectrum(ds)
    validate_spectrum(spec)
    assert spec.sizes == {"curve": 2, "omega": 3}
    np.testing.assert_allclose(spec["frequency"].values, [1.0, 10.0, 100.0])
    np.testing.assert_allclose(spec["omega"].values, 2 * np.pi * np.array([1.0, 10.0, 100.0]))
    np.testing.assert_allclose(spec["stiffness"].values, 0.05, rtol=1e-9)
    np.testing.assert_allclose(spec["phase"].values, 0.0, atol=1e-7)
    np.testing.assert_allclose(spec["drive_amplitude"].values, 10e-9, rtol=1e-9)
    np.testing.assert_allclose(spec["mean_force"].values, 2e-9, rtol=1e-9)
    np.testing.assert_array_equal(spec["lockin_periods"].values, 11)  # first period skipped
    # a phase of (numerically) 0 sits on the edge of the passive range (0, 90): 0 or 1, kept
    assert set(np.unique(spec["quality"].values)) <= {0, 1}
    np.testing.assert_allclose(spec["x"].values, [0.0, 1e-6])


def test_viscoelastic_phase_recovered_with_drift_and_transient():
    ds = synthetic([3.0, 30.0], 0.02, 25.0, drift=40e-9, transient=5e-10)
    spec = modulation_spectrum(ds)
    np.testing.assert_allclose(spec["stiffness"].values, 0.02, rtol=1e-6)
    np.testing.assert_allclose(spec["phase"].values, 25.0, atol=1e-4)
    assert (spec["quality"].values == 0).all()
    # without skipping the transient or without detrending the answer is off
    raw = modulation_spectrum(ds, settle=0.0)
    assert np.abs(raw["phase"].values - 25.0).max() > 1e-2
    flat = modulation_spectrum(ds, detrend=None)
    assert np.abs(flat["stiffness"].values / 0.02 - 1).max() > 1e-2


@pytest.mark.parametrize("seed", range(6))
def test_noisy_estimates_lie_within_their_stated_stderr(seed):
    k, chi = 0.03, 35.0
    ds = synthetic([2.0, 20.0, 200.0], k, chi, seed=seed, n_curves=8, noise=2e-10, drift=20e-9)
    spec = modulation_spectrum(ds)
    # white noise: the white-noise formula (N - 5 dof) has Gaussian z; the residual-spectrum
    # errors (the *_stderr, 4 bins = 8 dof at these 11 periods) Student-t z with 8 dof, whose
    # tail beyond 10.3 is as rare as a Gaussian's beyond 4.5 (6.8e-6)
    for suffix, bound in (("_stderr_white", 4.5), ("_stderr", 10.3)):
        z_k = (spec["stiffness"].values - k) / spec["stiffness" + suffix].values
        z_p = (spec["phase"].values - chi) / spec["phase" + suffix].values
        z_a = (spec["drive_amplitude"].values - 10e-9) / spec["drive_amplitude" + suffix].values
        for z in (z_k, z_p, z_a):
            assert np.all(np.abs(z) < bound), z
            assert 0.4 < np.sqrt(np.mean(z**2)) < 1.8, z   # calibrated, not merely conservative
    assert np.all(spec["phase_stderr"].values > 0)


def test_stderr_calibration_pooled_over_seeds():
    k, chi = 0.03, 35.0
    zs = []
    for seed in range(10, 20):
        ds = synthetic([5.0, 50.0], k, chi, seed=seed, n_curves=10, noise=3e-10)
        spec = modulation_spectrum(ds)
        zs.append(((spec["stiffness"] - k) / spec["stiffness_stderr"]).values.ravel())
        zs.append(((spec["phase"] - chi) / spec["phase_stderr"]).values.ravel())
    z = np.concatenate(zs)
    assert 0.8 < np.std(z) < 1.2 and abs(np.mean(z)) < 0.2


def test_phase_lag_and_drag_corrections():
    f = [10.0, 100.0]
    lags = {10.0: 5.0, 100.0: 40.0}
    ds = synthetic(f, 0.04, 20.0, lag_deg=lags)
    plain = modulation_spectrum(ds)
    np.testing.assert_allclose(plain["phase"].values, [[25.0, 60.0]] * 2, atol=1e-6)
    fixed = modulation_spectrum(ds, phase_lag=lags)
    np.testing.assert_allclose(fixed["phase"].values, 20.0, atol=1e-6)
    np.testing.assert_allclose(fixed["phase_lag"].values, [5.0, 40.0])
    assert fixed.attrs["phase_lag"] == "per-frequency"
    shifted = modulation_spectrum(ds, phase_lag=5.0)
    np.testing.assert_allclose(shifted["phase"].values, [[20.0, 55.0]] * 2, atol=1e-6)
    b = 1e-5
    dragged = modulation_spectrum(ds, phase_lag=lags, drag=b)
    k_expect = 0.04 * np.exp(1j * np.radians(20.0)) - 1j * 2 * np.pi * np.asarray(f) * b
    np.testing.assert_allclose(dragged["stiffness"].values[0], np.abs(k_expect), rtol=1e-6)
    np.testing.assert_allclose(dragged["phase"].values[0], np.degrees(np.angle(k_expect)),
                               atol=1e-5)
    with pytest.raises(ParameterError, match="no lag for 100"):
        modulation_spectrum(ds, phase_lag={10.0: 1.0})


def test_outside_passive_range_is_flagged_not_dropped():
    spec = modulation_spectrum(synthetic([10.0, 100.0], 0.02, 100.0))
    np.testing.assert_allclose(spec["phase"].values, 100.0, atol=1e-6)
    assert (spec["quality"].values == 1).all()
    assert "phase_outside_passive_range" in spec["quality"].attrs["flag_meanings"]


def test_curve_selection_and_netcdf_round_trip(tmp_path):
    ds = synthetic([10.0], 0.02, 30.0, n_curves=3)
    spec = modulation_spectrum(ds, curves=[2, 0])
    np.testing.assert_allclose(spec["x"].values, [2e-6, 0.0])
    path = tmp_path / "spec.nc"
    spec.to_netcdf(path, engine="scipy")
    with xr.open_dataset(path, engine="scipy") as back:
        back.load()
    assert back.identical(spec)


def test_bad_input_raises_clear_errors():
    ds = synthetic([10.0], 0.02, 30.0)
    with pytest.raises(ParameterError, match="segment_frequency"):
        modulation_spectrum(ds.drop_vars("segment_frequency"))
    with pytest.raises(ParameterError, match="detrend"):
        modulation_spectrum(ds, detrend="quadratic")
    with pytest.raises(ParameterError, match="settle_periods"):
        modulation_spectrum(ds, settle_periods=-1)
    with pytest.raises(ParameterError, match="curves"):
        modulation_spectrum(ds, curves=[5])
    with pytest.raises(ParameterError, match="JPKArchive"):
        modulation_spectrum(42)
    only_approach = ds.assign(segment_name=("segment_table", ["approach", "pause"] * 2))
    with pytest.raises(ParameterError, match="no modulation segment"):
        modulation_spectrum(only_approach)


def test_fixture_archive_is_too_coarse_for_a_lockin():
    # the self-made archive samples its 100 Hz modulation once per period
    with pytest.raises(ParameterError, match="period|coarse"):
        modulation_spectrum(read_jpk(FIXTURES / "synthetic.jpk-force"))


def test_real_modulation_map():
    path = REAL / "PyFMReader" / "map-data-2021.11.05-17.37.44.432.jpk-force-map"
    if not path.is_file():
        pytest.skip(f"real data file not present: {path}")
    spec = modulation_spectrum(path, phase_reference="sensor")   # against the sensor as recorded
    assert spec.sizes == {"curve": 16, "omega": 6}
    np.testing.assert_allclose(spec["frequency"].values, [1, 3, 10, 30, 100, 300])
    assert spec.attrs["height_channel"] == "measuredHeight"
    phase = spec["phase"].values
    assert np.all((phase[:, -1] > 100) & (phase[:, -1] < 115))   # the 300 Hz instrument lag
    # the default refers the phase to the sensor advanced by its delay behind the piezo: the
    # 300 Hz points drop by 10-14 degrees and stay above 90 (flagged)
    default = modulation_spectrum(path)
    assert default.attrs["phase_reference_mode"] == "delay"
    assert np.all((default["phase"].values[:, -1] > 90) & (default["phase"].values[:, -1] < 100))
    assert np.all(default["quality"].values[:, -1] == 1)
    assert np.all(spec["quality"].values[:, -1] == 1)
    assert np.all((phase[:, :-1] > 0) & (phase[:, :-1] < 90))
    assert np.all(spec["stiffness"].values > 0)
    # the sensor's measured drive ≈ 10.3 nm, not the nominal 15 nm
    np.testing.assert_allclose(np.median(spec["height_amplitude"].values), 10.3e-9, rtol=0.05)
    assert np.all(spec["nominal_amplitude"].values == pytest.approx(15e-9))
    # stiffness rises with frequency
    assert np.all(np.diff(np.median(spec["stiffness"].values, axis=0)) > 0)


# --- contact point on the approach, mean indentation, hard-surface phase reference -------------

from viscoforce.experiments.modulation import find_contact_point  # noqa: E402

Z_C = -8.7e-6   # contact tip position [m]


def hertz_approach(rng, *, n=1200, z_start=-2e-6, z_end=300e-9, force_end=0.5e-9, noise=5e-12,
                   tilt=0.0, exponent=1.5, z_c=Z_C):
    """Approach: z from z_c + z_start to z_c + z_end, F = tilted baseline + A (z − z_c)^p + noise."""
    z = z_c + np.linspace(z_start, z_end, n)
    amp = force_end / z_end**exponent
    force = (-1e-10 + tilt * (z - z_c) + amp * np.clip(z - z_c, 0, None) ** exponent
             + noise * rng.standard_normal(n))
    return z, force


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("exponent", [1.5, 1.0])
def test_contact_point_recovered_on_noisy_hertz_curves(seed, exponent):
    rng = np.random.default_rng(seed)
    z, f = hertz_approach(rng, tilt=2e-5, exponent=exponent)   # 2e-5 N/m: 40 pN over 2 µm
    c = find_contact_point(z, f, exponent=exponent)
    assert c is not None
    assert abs(c["z_contact"] - Z_C) < 15e-9, (c["z_contact"] - Z_C)   # stated tolerance 15 nm
    assert c["z_threshold"] > c["z_contact"]
    np.testing.assert_allclose(c["sigma"], 5e-12, rtol=0.2)
    assert c["rise"] > 50


def test_contact_point_absent_without_a_rise_or_with_contact_in_the_baseline():
    rng = np.random.default_rng(1)
    z, f = hertz_approach(rng, force_end=0.0)         # no rise: noise only
    assert find_contact_point(z, f) is None
    z, f = hertz_approach(rng, force_end=1e-13)       # rise far below 5 sigma
    assert find_contact_point(z, f) is None
    z, f = hertz_approach(rng, z_start=-100e-9, z_end=2e-6)   # contact inside the baseline window
    assert find_contact_point(z, f) is None
    assert find_contact_point(z[:8], f[:8]) is None   # too short
    with pytest.raises(ParameterError, match="baseline_fraction"):
        find_contact_point(z, f, baseline_fraction=0.95)
    with pytest.raises(ParameterError, match="k_sigma"):
        find_contact_point(z, f, k_sigma=0)
    with pytest.raises(ParameterError, match="exponent"):
        find_contact_point(z, f, exponent=-1)
    with pytest.raises(ParameterError, match="one length"):
        find_contact_point(z, f[:-1])


def contact_curves(freqs, *, depths, k=0.02, chi=20.0, noise=5e-12, seed=0, lag_deg=None,
                   per_period=64, periods=8, amplitude=10e-9):
    """Curves: Hertz approach (contact at Z_C), then modulation about Z_C + depth per curve.

    A depth of None gives an approach without a rise (no contact point).
    """
    rng = np.random.default_rng(seed)
    lag_deg = lag_deg or {}
    cols = {k_: [] for k_ in ("time", "force", "tip", "segment")}
    names, freq_col, counts = [], [], []
    for depth in depths:
        t0, n_curve = 0.0, 0
        z, f = hertz_approach(rng, noise=noise, force_end=0.0 if depth is None else 0.5e-9)
        t = np.arange(z.size) * 5e-4
        segs = [("approach", None, t, z, f)]
        t0 = t[-1] + 5e-4
        z0 = Z_C + (300e-9 if depth is None else depth)
        for fr in freqs:
            n = periods * per_period + 1
            t = t0 + np.arange(n) / (fr * per_period)
            w = 2 * np.pi * fr
            zz = z0 + amplitude * np.sin(w * (t - t0))
            ff = 3e-10 + k * amplitude * np.sin(w * (t - t0) + np.radians(chi + lag_deg.get(fr, 0)))
            segs.append(("modulation", fr, t, zz, ff))
            t0 = t[-1] + (t[-1] - t[-2])
        for name, fr, t, zz, ff in segs:
            cols["time"].append(t - segs[0][2][0])
            cols["tip"].append(zz)
            cols["force"].append(ff)
            cols["segment"].append(np.full(t.size, len(names), dtype=np.int32))
            names.append(name)
            freq_col.append(fr if fr else np.nan)
            n_curve += t.size
        counts.append(n_curve)
    flat = {k_: np.concatenate(v) for k_, v in cols.items()}
    defl = flat["force"] / KC
    ds = make_curves(flat["time"], flat["force"], -flat["tip"] - defl, defl,
                     tip_position=flat["tip"], segment=flat["segment"], segment_names=names,
                     sample_count=counts, per_curve={"x": np.arange(len(depths)) * 1e-6,
                                                     "y": np.zeros(len(depths))},
                     source="synthetic-test")
    return ds.assign(segment_frequency=("segment_table", np.asarray(freq_col), {"units": "Hz"}))


def test_mean_indentation_from_the_approach_contact_point():
    depths = [250e-9, 120e-9, None]
    spec = modulation_spectrum(contact_curves([5.0, 50.0], depths=depths))
    validate_spectrum(spec)
    ind = spec["mean_indentation"].values
    assert spec["mean_indentation"].attrs["units"] == "m"
    np.testing.assert_allclose(ind[0], 250e-9, atol=15e-9)
    np.testing.assert_allclose(ind[1], 120e-9, atol=15e-9)
    assert np.isnan(ind[2]).all()                       # no rise on curve 2: NaN, said in attrs
    assert "found on 2 of 3 curves" in spec.attrs["contact_point"]
    assert "none on curves [2]" in spec.attrs["contact_point"]
    np.testing.assert_allclose(spec["contact_position"].values[:2], Z_C, atol=15e-9)
    # the spectrum itself is unchanged by the contact estimate
    np.testing.assert_allclose(spec["stiffness"].values, 0.02, rtol=1e-6)
    np.testing.assert_allclose(spec["phase"].values, 20.0, atol=1e-4)
    # contact_point=False or no contact anywhere: the variable is left out, attrs say why
    off = modulation_spectrum(contact_curves([5.0], depths=[250e-9]), contact_point=False)
    assert "mean_indentation" not in off and "not estimated" in off.attrs["contact_point"]
    none = modulation_spectrum(contact_curves([5.0], depths=[None, None]))
    assert "mean_indentation" not in none and "left out" in none.attrs["contact_point"]
    # options reach find_contact_point; bad ones raise
    linear = modulation_spectrum(contact_curves([5.0], depths=[250e-9]),
                                 contact_point={"exponent": 1.0, "k_sigma": 4.0})
    assert "exponent=1.0" in linear.attrs["contact_point"]
    with pytest.raises(ParameterError, match="k_sigma"):
        modulation_spectrum(contact_curves([5.0], depths=[250e-9]), contact_point={"k_sigma": -1})
    with pytest.raises(ParameterError, match="contact_point"):
        modulation_spectrum(contact_curves([5.0], depths=[250e-9]), contact_point="yes")


def test_phase_reference_from_a_hard_surface_spectrum():
    freqs = [3.0, 30.0, 300.0]
    lags = {3.0: 2.0, 30.0: 9.0, 300.0: 104.0}
    hard = modulation_spectrum(synthetic(freqs, 1.0, 0.0, lag_deg=lags, n_curves=5, noise=2e-11,
                                         seed=3))
    soft = synthetic(freqs, 0.03, 25.0, lag_deg=lags)
    fixed = modulation_spectrum(soft, phase_reference=hard)
    np.testing.assert_allclose(fixed["phase"].values, 25.0, atol=0.05)
    np.testing.assert_allclose(fixed["phase_lag"].values, [2.0, 9.0, 104.0], atol=0.05)
    assert fixed.attrs["phase_lag"] == "reference"
    assert (fixed["quality"].values == 0).all()         # 300 Hz back inside (0°, 90°)
    np.testing.assert_allclose(fixed["stiffness"].values, 0.03, rtol=1e-6)
    # an already-corrected reference: its own phase_lag is added back
    hard_fixed = modulation_spectrum(synthetic(freqs, 1.0, 0.0, lag_deg=lags), phase_lag=lags)
    again = modulation_spectrum(soft, phase_reference=hard_fixed)
    np.testing.assert_allclose(again["phase"].values, 25.0, atol=1e-5)
    # median over curves: one outlier curve does not move the lag
    bad = hard.copy(deep=True)
    bad["phase"][0, :] = 170.0
    np.testing.assert_allclose(modulation_spectrum(soft, phase_reference=bad)["phase"].values,
                               25.0, atol=0.1)
    with pytest.raises(ParameterError, match="not both"):
        modulation_spectrum(soft, phase_reference=hard, phase_lag=3.0)
    with pytest.raises(ParameterError, match="matching 300 Hz"):
        modulation_spectrum(soft, phase_reference=hard.isel(omega=[0, 1]))
    with pytest.raises(ParameterError, match="spectrum dataset"):
        modulation_spectrum(soft, phase_reference={"phase": 1})


def test_real_map_mean_indentation():
    path = REAL / "PyFMReader" / "map-data-2021.11.05-17.37.44.432.jpk-force-map"
    if not path.is_file():
        pytest.skip(f"real data file not present: {path}")
    spec = modulation_spectrum(path)
    ind = spec["mean_indentation"].values
    assert "found on 16 of 16 curves" in spec.attrs["contact_point"]
    # a soft sample (probably a cell, E ~ 0.3-0.5 kPa): 0.5-1.7 µm under a ~0.4 nN setpoint
    assert np.all((ind > 300e-9) & (ind < 2.5e-6)), ind
    # the same operating point at every frequency of a curve (creep < 60 nm over the segments)
    assert np.all(np.ptp(ind, axis=1) < 60e-9)
    # self-reference: the map's own 300 Hz median phase taken as the lag gives zero median there
    # (a hard-surface reference is measured against the sensor: the default's delay refused)
    with pytest.raises(ParameterError, match="make it with phase_reference='sensor'"):
        modulation_spectrum(path, phase_reference=spec)
    sensor = modulation_spectrum(path, phase_reference="sensor")
    ref = modulation_spectrum(path, phase_reference=sensor)
    np.testing.assert_allclose(np.median(ref["phase"].values, axis=0), 0.0, atol=1e-6)
