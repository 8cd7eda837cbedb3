"""Tests of viscoforce.lockin: whole-period demodulation, xarray wrapper and RC lock-in."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import iv

from viscoforce.exceptions import ParameterError
from viscoforce.lockin import (
    amplitude_phase_from_complex,
    demodulate,
    demodulate_dataarray,
    harmonics,
    lockin_filter,
    settling_time,
    sin_phase,
)

OMEGA = 3.0
PERIOD = 2 * math.pi / OMEGA


@pytest.fixture
def rng():
    return np.random.default_rng(20240611)


def aligned_time(periods, per_period, t0=0.0, omega=OMEGA):
    """Samples exactly on a whole-period grid (the trapezoid rule is exact there)."""
    period = 2 * math.pi / omega
    return t0 + np.arange(periods * per_period + 1) * (period / per_period)


def unaligned_time(record_periods, per_period, t0=0.3):
    """Uniform samples whose spacing does not divide the period (resampling path)."""
    return t0 + np.arange(0.0, record_periods * PERIOD, PERIOD / per_period * 1.0037)


# ---------------------------------------------------------------- exactness and properties


def test_exactly_periodic_is_exact_to_rounding():
    t = aligned_time(4, 64, t0=1.1)
    x = 0.2 + 1.3 * np.cos(OMEGA * t + 0.7) + 0.1 * np.cos(2 * OMEGA * t - 0.3)
    # machine precision: 50 eps of the signal scale
    assert abs(demodulate(x, t, OMEGA) - 1.3 * np.exp(0.7j)) < 50 * np.finfo(float).eps
    assert abs(demodulate(x, t, OMEGA, harmonic=2) - 0.1 * np.exp(-0.3j)) < 1e-14
    assert abs(demodulate(x, t, OMEGA, harmonic=0) - 0.2) < 1e-14  # mean, not 2×mean


@settings(max_examples=60, deadline=None)
@given(amplitude=st.floats(1e-3, 1e3), phase=st.floats(-math.pi, math.pi),
       log_omega=st.floats(-2, 5), periods=st.integers(1, 12), per_period=st.integers(8, 120),
       offset=st.floats(-3, 3), mean=st.floats(-10, 10))
def test_property_cosine_gives_a_exp_i_phi(amplitude, phase, log_omega, periods, per_period,
                                           offset, mean):
    omega = 10.0**log_omega
    t = aligned_time(periods, per_period, t0=offset * 2 * math.pi / omega, omega=omega)
    x = mean * amplitude + amplitude * np.cos(omega * t + phase)
    got = demodulate(x, t, omega)
    assert abs(got - amplitude * np.exp(1j * phase)) <= 1e-9 * amplitude * (1 + abs(mean))


@settings(max_examples=40, deadline=None)
@given(phase=st.floats(-math.pi, math.pi), record=st.floats(1.05, 12.0),
       per_period=st.integers(50, 120), stretch=st.floats(0.9, 1.1))
def test_property_unaligned_sampling_within_1e6(phase, record, per_period, stretch):
    # off-grid samples are resampled with a cubic spline: error ≲ (ωΔt)⁴/500 ≤ 5e-7 here
    t = 0.4 + np.arange(0.0, record * PERIOD, PERIOD / per_period * stretch)
    x = 2.5 * np.cos(OMEGA * t + phase)
    assert abs(demodulate(x, t, OMEGA) - 2.5 * np.exp(1j * phase)) < 1e-6 * 2.5


@settings(max_examples=40, deadline=None)
@given(a=st.floats(-5, 5), b=st.floats(-5, 5), seed=st.integers(0, 2**32 - 1),
       aligned=st.booleans(), harmonic=st.integers(0, 3))
def test_property_linearity(a, b, seed, aligned, harmonic):
    rng = np.random.default_rng(seed)
    t = aligned_time(3, 40) if aligned else unaligned_time(3.6, 40)
    x = rng.normal(size=t.size)
    y = rng.normal(size=t.size) + np.cos(OMEGA * t)
    lhs = demodulate(a * x + b * y, t, OMEGA, harmonic=harmonic)
    rhs = a * demodulate(x, t, OMEGA, harmonic=harmonic) + b * demodulate(
        y, t, OMEGA, harmonic=harmonic)
    assert abs(lhs - rhs) <= 1e-12 * (1 + abs(a) + abs(b))


# ---------------------------------------------------------------- window selection


def test_window_is_whole_periods_after_settle_ending_at_last_sample():
    t = unaligned_time(7.37, 50)
    settle = 1.2 * PERIOD  # 6.17 periods remain → 6 whole periods
    # the mean of x = t over the window is its centre, te − 3 periods
    assert demodulate(t, t, OMEGA, harmonic=0, settle=settle) == pytest.approx(
        t[-1] - 3 * PERIOD, rel=1e-12)
    assert demodulate(t, t, OMEGA, harmonic=0) == pytest.approx(t[-1] - 3.5 * PERIOD, rel=1e-12)


def test_settle_discards_transient(rng):
    t = unaligned_time(7.37, 50)
    settle = 1.2 * PERIOD
    clean = 1.5 * np.cos(OMEGA * t - 2.0) + 0.3 * np.cos(3 * OMEGA * t)
    dirty = clean + np.where(t < t[-1] - 6 * PERIOD - 2 * PERIOD / 50,
                             1e3 * rng.normal(size=t.size), 0.0)
    got = demodulate(dirty, t, OMEGA, settle=settle)
    assert got == demodulate(clean, t, OMEGA, settle=settle)
    assert abs(got - 1.5 * np.exp(-2.0j)) < 1e-6 * 1.5  # 50 samples/period, off-grid


def test_non_uniform_sampling(rng):
    # jittered samples (±30 % of Δt) at 100 per period: spline error ~ (ωΔt)⁴/500 ≈ 3e-8
    t = np.sort(0.1 + np.arange(0, 5.5 * PERIOD, PERIOD / 100)
                + rng.uniform(-0.3, 0.3, 550) * PERIOD / 100)
    x = 0.8 * np.cos(OMEGA * t + 1.0) - 4.0
    assert abs(demodulate(x, t, OMEGA) - 0.8 * np.exp(1j)) < 1e-6


def test_nd_signal_along_axis():
    t = aligned_time(2, 30)
    amps = np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]])
    sig = amps[:, :, None] * np.cos(OMEGA * t + 0.25)  # (2, 3, time)
    expected = amps * np.exp(0.25j)
    np.testing.assert_allclose(demodulate(sig, t, OMEGA), expected, rtol=1e-13)
    np.testing.assert_allclose(demodulate(np.moveaxis(sig, -1, 0), t, OMEGA, axis=0), expected,
                               rtol=1e-13)
    np.testing.assert_allclose(harmonics(sig, t, OMEGA, 2)[..., 1], expected, rtol=1e-13)


# ---------------------------------------------------------------- noise, drift, distortion


def test_gaussian_noise_standard_error(rng):
    # X̂ = (2/T)Σ w x e^{−iωt}: white noise σ gives Re and Im each a standard error
    # σ·sqrt(2/N) (N samples in the window). Check a single record within 3 standard errors,
    # and the spread over 400 records (vectorised along axis 0) within 15 % of the theory
    # (the estimate's own relative scatter is 1/sqrt(2·400) ≈ 3.5 %).
    t = aligned_time(10, 100)
    n = t.size - 1
    sigma = 0.5
    truth = 2.0 * np.exp(0.3j)
    clean = 2.0 * np.cos(OMEGA * t + 0.3)
    noisy = clean + sigma * rng.normal(size=(400, t.size))
    err = demodulate(noisy, t, OMEGA) - truth
    se = sigma * math.sqrt(2 / n)
    assert abs(err[0].real) < 3 * se
    assert abs(err[0].imag) < 3 * se
    assert np.std(err.real) == pytest.approx(se, rel=0.15)
    assert np.std(err.imag) == pytest.approx(se, rel=0.15)
    assert abs(np.mean(err)) < 4 * se / math.sqrt(400)


@pytest.mark.parametrize("harmonic", [1, 2])
def test_linear_drift_bias_matches_analytic(harmonic):
    # (2/T)∫ c t e^{−inωt} dt over whole periods [ts, ts+T] = 2ic e^{−inωts}/(nω).
    # The trapezoid sum differs from the integral by the factor (θ/2)cot(θ/2), θ = nωΔt
    # (exact discrete sum), i.e. by ≈ θ²/12.
    per_period = 50
    t = aligned_time(6, per_period, t0=0.7)
    c = 0.05
    x = 1.2 * np.cos(harmonic * OMEGA * t + 0.4) + c * t
    bias = demodulate(x, t, OMEGA, harmonic=harmonic) - 1.2 * np.exp(0.4j)
    analytic = 2j * c * np.exp(-1j * harmonic * OMEGA * t[0]) / (harmonic * OMEGA)
    theta = harmonic * OMEGA * (t[1] - t[0])
    discrete = analytic * (theta / 2) / math.tan(theta / 2)
    assert abs(bias - discrete) < 1e-12
    assert abs(bias - analytic) <= theta**2 / 10 * abs(analytic)
    assert abs(bias) == pytest.approx(2 * c / (harmonic * OMEGA), rel=theta**2 / 10)


@pytest.mark.parametrize("aligned", [True, False])
def test_detrend_linear_removes_drift(aligned):
    t = aligned_time(6, 50, t0=0.7) if aligned else unaligned_time(6.4, 50, t0=0.7)
    tol = 1e-12 if aligned else 2e-6  # spline resampling error at 50 samples/period
    x = 3.0 + 1.2 * np.cos(OMEGA * t + 0.4) + 0.2 * np.cos(2 * OMEGA * t - 1.0) + 0.05 * t
    got = harmonics(x, t, OMEGA, 2, detrend="linear")
    t_start = t[-1] - 6 * PERIOD
    # the mean is unchanged: the line's value at the window centre
    assert abs(got[0] - (3.0 + 0.05 * (t_start + 3 * PERIOD))) < tol
    assert abs(got[1] - 1.2 * np.exp(0.4j)) < tol
    assert abs(got[2] - 0.2 * np.exp(-1.0j)) < tol
    assert abs(demodulate(x, t, OMEGA, detrend="linear") - got[1]) < 1e-14


@pytest.mark.parametrize("aligned", [True, False])
def test_distorted_signal_harmonics_are_bessel_coefficients(aligned):
    # e^{a cos θ} = I0(a) + 2 Σ I_n(a) cos nθ, θ = ωt + φ ⇒ X̂_n = 2 I_n(a) e^{inφ}
    a, phi = 1.5, 0.6
    t = aligned_time(3, 64) if aligned else unaligned_time(3.3, 64)
    x = np.exp(a * np.cos(OMEGA * t + phi))
    n = np.arange(6)
    expected = np.where(n == 0, 1.0, 2.0) * iv(n, a) * np.exp(1j * n * phi)
    tol = 1e-12 if aligned else 5e-6  # (nωΔt)⁴/500 grows with n
    np.testing.assert_allclose(harmonics(x, t, OMEGA, 5), expected, rtol=0, atol=tol)
    assert abs(demodulate(x, t, OMEGA, harmonic=3) - expected[3]) < tol


def test_sin_phase_convention():
    # x = mean + B sin(ωt + ψ)  ⇔  X̂ = B e^{i(ψ − π/2)}
    t = aligned_time(2, 40)
    for psi in (0.3, -2.0, 3.1):
        x = 7.0 + 0.5 * np.sin(OMEGA * t + psi)
        big_x = demodulate(x, t, OMEGA)
        assert abs(big_x - 0.5 * np.exp(1j * (psi - math.pi / 2))) < 1e-14
        assert sin_phase(big_x) == pytest.approx(psi, abs=1e-13)
        modulus, phase = amplitude_phase_from_complex(big_x)
        assert modulus == pytest.approx(0.5, rel=1e-13)
        assert phase == pytest.approx(psi, abs=1e-13)
    np.testing.assert_allclose(sin_phase(np.array([1.0, -1j, -1.0])),
                               [math.pi / 2, 0.0, -math.pi / 2], atol=1e-15)


# ---------------------------------------------------------------- lock-in amplifier mode


def test_settling_time_analytic():
    assert settling_time(2.0, 1, 1e-3) == pytest.approx(2.0 * math.log(1e3), rel=1e-12)
    # order 2: (1 + x) e^{−x} = accuracy
    x = settling_time(1.0, 2, 1e-4)
    assert (1 + x) * math.exp(-x) == pytest.approx(1e-4, rel=1e-10)
    assert settling_time(1.0, 4) == pytest.approx(13.0622, rel=1e-5)


def test_settling_time_matches_filter_step_response():
    tau, order, accuracy = 0.1, 4, 1e-3
    t = np.arange(0, 3.0, tau / 1000)
    y = lockin_filter(np.ones_like(t), t, 1.0, time_constant=tau, order=order, harmonic=0)
    ts = settling_time(tau, order, accuracy)
    assert 1 - y[np.searchsorted(t, ts)].real <= accuracy
    assert 1 - y[np.searchsorted(t, 0.95 * ts)].real > accuracy  # not overly conservative


def test_filter_converges_to_complex_amplitude():
    omega = 2 * math.pi
    tau, order = 2.0, 4  # ripple at 2ω: (1 + (2ωτ)²)^(−2) ≈ 4e-6
    t = np.arange(0, 40.0, 0.01)
    x = 0.5 + 1.7 * np.cos(omega * t - 1.1)
    y = lockin_filter(x, t, omega, time_constant=tau, order=order)
    late = t >= settling_time(tau, order, accuracy=1e-4)
    assert late.sum() > 500
    assert np.max(np.abs(y[late] - 1.7 * np.exp(-1.1j))) < 1e-3 * 1.7
    assert abs(y[-1] - demodulate(x, t, omega)) < 1e-3 * 1.7
    mean = lockin_filter(x, t, omega, time_constant=tau, order=order, harmonic=0)
    assert abs(mean[-1] - 0.5) < 1e-3


def test_filter_reduces_noise_as_predicted(rng):
    # Complex white noise 2σ e^{−iωt}ε through an n-stage RC cascade: output variance
    # 4σ²Δt ∫h² = 4σ²Δt (2n−2)!/((n−1)!² 2^(2n−1) τ)  (0.15625/τ for n = 4).
    omega, tau, order, sigma, dt = 2 * math.pi, 0.5, 4, 0.3, 0.01
    t = np.arange(0, 1000.0, dt)
    x = np.cos(omega * t) + sigma * rng.normal(size=t.size)
    y = lockin_filter(x, t, omega, time_constant=tau, order=order)
    late = t > settling_time(tau, order, 1e-6)
    var = np.mean(np.abs(y[late] - 1.0) ** 2)
    n = order
    theory = 4 * sigma**2 * dt * math.factorial(2 * n - 2) / (
        math.factorial(n - 1) ** 2 * 2 ** (2 * n - 1) * tau)
    assert var == pytest.approx(theory, rel=0.2)  # ~500 correlation times → ~5 % scatter
    assert var < 0.01 * (2 * sigma) ** 2  # raw mixed noise variance is (2σ)²


def test_filter_nd_axis():
    t = np.arange(0, 20.0, 0.01)
    x = np.stack([np.cos(2 * math.pi * t), 2 * np.cos(2 * math.pi * t)])
    y = lockin_filter(x.T, t, 2 * math.pi, time_constant=1.0, axis=0)
    assert y.shape == (t.size, 2)
    np.testing.assert_allclose(y[:, 1], 2 * y[:, 0], rtol=1e-13)


# ---------------------------------------------------------------- xarray wrapper


def _cube(rng, dims=("x", "y", "time")):
    t = unaligned_time(4.3, 40)
    amp = rng.uniform(0.5, 2.0, size=(3, 2))
    phase = rng.uniform(-3, 3, size=(3, 2))
    data = amp[..., None] * np.cos(OMEGA * t + phase[..., None]) + rng.normal(
        scale=0.1, size=(3, 2, t.size))
    da = xr.DataArray(data, dims=("x", "y", "time"),
                      coords={"time": t, "x": [0.0, 1.0, 2.0], "y": [5.0, 6.0]},
                      name="force", attrs={"units": "N"})
    return da.transpose(*dims), data, t


def test_dataarray_matches_numpy_core(rng):
    da, data, t = _cube(rng)
    expected = demodulate(data, t, OMEGA, settle=PERIOD / 3)
    got = demodulate_dataarray(da, OMEGA, settle=PERIOD / 3)
    assert got.dims == ("x", "y")
    assert got.name == "force"
    assert got.attrs["units"] == "N"
    assert got.attrs["harmonic"] == 1
    np.testing.assert_allclose(got.values, expected, rtol=1e-13)
    transposed, _, _ = _cube(np.random.default_rng(20240611), dims=("time", "y", "x"))
    got_t = demodulate_dataarray(transposed, OMEGA, settle=PERIOD / 3).transpose("x", "y")
    np.testing.assert_allclose(got_t.values, expected, rtol=1e-13)


def test_dataarray_omega_per_point(rng):
    da, data, t = _cube(rng)
    omegas = xr.DataArray([OMEGA, 2 * OMEGA, 0.5 * OMEGA], dims="x", coords={"x": da.x})
    got = demodulate_dataarray(da, omegas, harmonic=2)
    for i, w in enumerate(omegas.values):
        np.testing.assert_allclose(got.values[i], demodulate(data[i], t, w, harmonic=2),
                                   rtol=1e-13)


def test_dataarray_dask(rng):
    pytest.importorskip("dask")
    da, data, t = _cube(rng)
    lazy = demodulate_dataarray(da.chunk({"x": 1, "time": 50}), OMEGA, detrend="linear")
    assert lazy.chunks is not None
    np.testing.assert_allclose(lazy.compute().values,
                               demodulate(data, t, OMEGA, detrend="linear"), rtol=1e-13)
    omegas = xr.DataArray([OMEGA, 2 * OMEGA, 0.5 * OMEGA], dims="x").chunk({"x": 1})
    per_point = demodulate_dataarray(da.chunk({"x": 1}), omegas).compute()
    np.testing.assert_allclose(per_point.values[2], demodulate(data[2], t, 0.5 * OMEGA),
                               rtol=1e-13)


# ---------------------------------------------------------------- every raise branch

T_OK = aligned_time(3, 20)
X_OK = np.cos(OMEGA * T_OK)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"omega": 0.0}, "omega must be > 0"),
    ({"omega": float("nan")}, "omega must be finite"),
    ({"harmonic": -1}, "harmonic must be an integer >= 0"),
    ({"harmonic": 1.5}, "harmonic must be an integer >= 0"),
    ({"settle": -1.0}, "settle must be >= 0"),
    ({"detrend": "quadratic"}, "detrend must be None or 'linear'"),
    ({"axis": 1}, r"axis must be in \[-1, 0\]"),
    ({"axis": 0.0}, "axis must be an integer"),
    ({"time": T_OK[::-1]}, "time must be strictly increasing"),
    ({"time": np.r_[T_OK[:-1], np.nan]}, "time must be finite"),
    ({"time": [0.0], "signal": [1.0]}, "time needs at least 2 samples"),
    ({"signal": X_OK + 0j}, "signal must be real"),
    ({"signal": np.array(["a"] * T_OK.size)}, "signal must be an array of real numbers"),
    ({"signal": 1.0}, "signal must have a time axis"),
    ({"signal": X_OK[:-1]}, "signal has 60 samples along axis -1 but time has 61"),
    ({"signal": np.r_[X_OK[:-1], np.nan]}, r"signal must be finite .* sample 60"),
    ({"settle": 2.5 * PERIOD},
     r"record is 6\.28319 s long; after settle = 5\.23599 s only 1\.0472 s remain, "
     r"less than one period 2π/omega = 2\.0944 s"),
    ({"settle": 1.5 * PERIOD, "detrend": "linear"}, "detrend='linear' needs at least 2 whole"),
    ({"harmonic": 10}, "sampling too coarse for harmonic 10: about 20 samples per period"),
])
def test_demodulate_raises(kwargs, match):
    args = {"signal": X_OK, "time": T_OK, "omega": OMEGA, **kwargs}
    with pytest.raises(ParameterError, match=match):
        demodulate(args.pop("signal"), args.pop("time"), args.pop("omega"), **args)


def test_harmonics_raises():
    with pytest.raises(ParameterError, match="n_max must be an integer >= 0"):
        harmonics(X_OK, T_OK, OMEGA, -1)
    with pytest.raises(ParameterError, match="sampling too coarse for harmonic 10"):
        harmonics(X_OK, T_OK, OMEGA, 10)


def test_dataarray_raises(rng):
    da, _, _ = _cube(rng)
    with pytest.raises(ParameterError, match="da must be an xarray.DataArray"):
        demodulate_dataarray(da.values, OMEGA)
    with pytest.raises(ParameterError, match="dim must be one of the dimensions"):
        demodulate_dataarray(da, OMEGA, dim="t")
    with pytest.raises(ParameterError, match="needs a coordinate 'time'"):
        demodulate_dataarray(da.drop_vars("time"), OMEGA)
    with pytest.raises(ParameterError, match="omega must not vary along 'time'"):
        demodulate_dataarray(da, xr.full_like(da.time, OMEGA))
    with pytest.raises(ParameterError, match="omega must be > 0 and finite everywhere"):
        demodulate_dataarray(da, xr.DataArray([OMEGA, -1.0, OMEGA], dims="x"))
    with pytest.raises(ParameterError, match="omega must be > 0"):
        demodulate_dataarray(da, -OMEGA)
    with pytest.raises(ParameterError, match="harmonic must be an integer >= 0"):
        demodulate_dataarray(da, OMEGA, harmonic=-2)
    with pytest.raises(ParameterError, match="settle must be >= 0"):
        demodulate_dataarray(da, OMEGA, settle=-1.0)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"omega": -1.0}, "omega must be > 0"),
    ({"time_constant": 0.0}, "time_constant must be > 0"),
    ({"order": 0}, "order must be an integer >= 1"),
    ({"harmonic": -1}, "harmonic must be an integer >= 0"),
    ({"time": [0.0], "signal": [1.0]}, "time needs at least 2 samples"),
    ({"time": np.r_[T_OK[:-1], T_OK[-1] + 0.01]}, "time must be uniformly spaced"),
    ({"time": T_OK[::-1]}, "time must be strictly increasing"),
    ({"signal": X_OK[:5]}, "signal has 5 samples"),
])
def test_lockin_filter_raises(kwargs, match):
    args = {"signal": X_OK, "time": T_OK, "omega": OMEGA, "time_constant": 1.0, **kwargs}
    with pytest.raises(ParameterError, match=match):
        lockin_filter(args.pop("signal"), args.pop("time"), args.pop("omega"), **args)


@pytest.mark.parametrize(("args", "match"), [
    ((0.0, 4), "time_constant must be > 0"),
    ((1.0, 0), "order must be an integer >= 1"),
    ((1.0, 4, 0.0), r"accuracy must be in \(0, 1\)"),
    ((1.0, 4, 1.0), r"accuracy must be in \(0, 1\)"),
])
def test_settling_time_raises(args, match):
    with pytest.raises(ParameterError, match=match):
        settling_time(*args)


# ---------------------------------------------------------------- bad input (robustness probe)

_DA_OK = xr.DataArray(X_OK, dims="time", coords={"time": T_OK})


@pytest.mark.parametrize(("call", "match"), [
    (lambda: demodulate(X_OK, T_OK, OMEGA, detrend=np.array([])),
     r"detrend must be None or 'linear', got ndarray array\(\[\]"),
    (lambda: demodulate(X_OK, T_OK, OMEGA, detrend=True),
     "detrend must be None or 'linear', got bool True"),
    (lambda: demodulate(X_OK, T_OK, OMEGA, detrend=["linear"]),
     r"detrend must be None or 'linear', got list \['linear'\]"),
    (lambda: harmonics(X_OK, T_OK, OMEGA, 2, detrend=np.array([])),
     "detrend must be None or 'linear'"),
    (lambda: demodulate_dataarray(_DA_OK, OMEGA, detrend=np.array([])),
     "detrend must be None or 'linear'"),
    (lambda: demodulate_dataarray(_DA_OK, OMEGA, detrend={}),
     "detrend must be None or 'linear', got dict"),
    (lambda: demodulate_dataarray(_DA_OK, OMEGA, dim=np.array([])),
     r"dim must be one of the dimensions \('time',\), got ndarray"),
    (lambda: demodulate_dataarray(_DA_OK, OMEGA, dim=["time"]),
     r"dim must be one of the dimensions \('time',\), got list"),
], ids=["detrend-empty", "detrend-bool", "detrend-list", "harmonics-detrend-empty",
        "dataarray-detrend-empty", "dataarray-detrend-dict", "dataarray-dim-empty",
        "dataarray-dim-list"])
def test_flags_must_be_what_they_say(call, match):
    with pytest.raises(ParameterError, match=match):
        call()


@pytest.mark.parametrize("function", [sin_phase, amplitude_phase_from_complex])
@pytest.mark.parametrize(("value", "match"), [
    (None, "amplitude must be a complex number or an array of complex numbers, got None"),
    ("1+1j", "amplitude must be a complex number .* got str '1\\+1j'"),
    (["a", "b"], "amplitude must be a complex number .* got list"),
    ({}, "amplitude must be a complex number .* got dict"),
    (object(), "amplitude must be a complex number .* got object"),
    (True, "amplitude must be a complex number .* got bool"),
    (float("nan"), r"amplitude must be finite \(no NaN/inf\); entry 0 is \(nan\+0j\)"),
    ([1j, float("nan")], r"amplitude must be finite \(no NaN/inf\); entry 1 is \(nan\+0j\)"),
    (np.array([1 + 1j, complex(np.inf, 0)]), r"amplitude must be finite .* entry 1 is \(inf\+0j\)"),
], ids=["None", "str", "strlist", "dict", "object", "bool", "nan", "with-nan", "with-inf"])
def test_complex_amplitude_conversions_reject_bad_input(function, value, match):
    with pytest.raises(ParameterError, match=match):
        function(value)


def test_complex_amplitude_conversions_accept_real_and_integer_input():
    assert sin_phase(1.0) == pytest.approx(math.pi / 2)
    modulus, phase = amplitude_phase_from_complex(np.array([2, -2]))
    np.testing.assert_allclose(modulus, [2.0, 2.0])
    np.testing.assert_allclose(phase, [math.pi / 2, -math.pi / 2])
    assert sin_phase(np.array([])).shape == (0,)
