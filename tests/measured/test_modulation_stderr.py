"""Lock-in standard errors that hold for coloured noise: split-half on the real map, known truths.

What each test proves:

* the real JPK map of a cell (``data_examples/real``): the two halves of every lock-in window,
  demodulated apart with their own errors, differ by an rms z within [0.5, 2] at every
  frequency (the white-noise formula: 2.1–6.4);
* white noise (truth known): the residual-spectrum errors agree on average with the white
  formula, and (estimate − truth)/stderr has the Student-t rms of their degrees of freedom;
* red noise (AR(1)) and random-walk drift: the white formula is too small, the new errors give
  z-rms in [0.7, 1.4] over 200 replicas; the F–δ noise correlation is kept in the error of k*;
* the spectrum carries both sets of errors, the method in its attrs, and round-trips netCDF;
  ``studies/split_half/split_half.py`` runs and reports the same split-half numbers.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from tests._bench import run_main
from tests.measured.test_modulation import synthetic
from viscoforce.exceptions import ParameterError
from viscoforce.experiments import modulation
from viscoforce.experiments.modulation import demodulate_segment, modulation_spectrum
from viscoforce.io.instruments import load_instrument
from viscoforce.schema import validate_spectrum

REAL_MAP = (Path(__file__).resolve().parents[2] / "data_examples" / "real"
            / "modulation-map.jpk-force-map")
KC = 0.1            # cantilever spring constant [N/m]: deflection noise n gives KC·n in F, −n in δ
AMPLITUDE = 10e-9   # drive amplitude |δ̂| [m]
MEAN_FORCE = 2e-9   # mean force [N]
DRIFT = 20e-9       # linear drift of δ [m/s] (KC times that in F), removed by the detrend


def rms(z) -> float:
    return float(np.sqrt(np.mean(np.square(z))))


def split_half_z(path: Path, key: str) -> dict[float, np.ndarray]:
    """z per real component of k*_A − k*_B over the curves, per frequency [Hz]."""
    inp = modulation._curves_of(load_instrument(path), None, None)
    out: dict[float, list[float]] = {}
    for segments in inp.curves:
        for row, t, force, tip, _height in segments:
            if inp.names[row] != "modulation":
                continue
            f = float(inp.freq[row])
            dt = float(np.median(np.diff(t)))
            a, b = modulation._demodulate_halves(t, np.vstack([force, tip]), f,
                                                 settle=max(1.0 / f - dt, 0.0), dt=dt)
            ka, kb = a["F"] / a["d"], b["F"] / b["d"]
            sigma = math.hypot(a[key] * abs(ka), b[key] * abs(kb))   # stiffness_stderr of each
            out.setdefault(f, []).extend([(ka - kb).real / sigma, (ka - kb).imag / sigma])
    return {f: np.asarray(z) for f, z in sorted(out.items())}


def test_split_half_on_the_real_map():
    if not REAL_MAP.is_file():
        pytest.skip(f"real data file not present: {REAL_MAP}")
    new = split_half_z(REAL_MAP, "rho")
    white = split_half_z(REAL_MAP, "rho_white")
    assert sorted(new) == [1.0, 3.0, 10.0, 30.0, 100.0, 300.0]
    assert all(z.size == 32 for z in new.values())        # 16 curves x 2 components
    for f in new:
        assert 0.5 <= rms(new[f]) <= 2.0, (f, rms(new[f]))
        assert rms(white[f]) > 1.8, (f, rms(white[f]))     # the white formula: too small
    # and what the spectrum stores is the same per-segment estimate as the halves use
    spec = modulation_spectrum(load_instrument(REAL_MAP))
    assert spec.attrs["stderr_method"] == modulation.STDERR_METHOD
    ratio = spec["stiffness_stderr"] / spec["stiffness_stderr_white"]
    assert float(ratio.median()) > 1.5


def test_halves_need_enough_periods():
    t = np.arange(3 * 64 + 1) / (10.0 * 64)   # 3 periods at 10 Hz: halves of 1 period
    x = np.vstack([np.sin(2 * np.pi * 10.0 * t), np.cos(2 * np.pi * 10.0 * t)])
    with pytest.raises(ParameterError, match="split-half needs 4 whole periods"):
        modulation._demodulate_halves(t, x, 10.0, settle=0.0)
    a, b = modulation._demodulate_halves(t, x, 10.0, settle=0.0, detrend=None)
    assert a["periods"] == b["periods"] == 1


# ── synthetic segments with a known k* ──────────────────────────────────────────────────────────

def deflection_noise(rng, kind: str, n: int, sigma: float) -> np.ndarray:
    """Noise of the deflection [m]: white, AR(1) (φ = 0.95, ≈ 0.3 periods), or white + walk.

    The random walk has steps of σ per sample: its drift dominates the white part.
    """
    if kind == "white":
        return sigma * rng.standard_normal(n)
    if kind == "ar1":
        phi = 0.95
        e = sigma * math.sqrt(1 - phi**2) * rng.standard_normal(n)
        out = np.empty(n)
        out[0] = sigma * rng.standard_normal()
        for j in range(1, n):
            out[j] = phi * out[j - 1] + e[j]
        return out
    if kind == "walk":
        return sigma * rng.standard_normal(n) + sigma * np.cumsum(rng.standard_normal(n))
    raise AssertionError(kind)


def segment(rng, kind: str, periods: int, *, k: float = 0.03, chi: float = 35.0,
            sigma: float = 2e-10, per_period: int = 64, frequency: float = 10.0):
    """One modulation segment: δ = A sin ωt + drift − n, F = F̄ + |k|A sin(ωt + χ) + drift + KC·n.

    Returns time, force, indentation, frequency and the true k*, mean force at the window centre.
    """
    n = periods * per_period + 1
    t = np.arange(n) / (frequency * per_period)
    w = 2 * np.pi * frequency
    noise = deflection_noise(rng, kind, n, sigma)
    delta = AMPLITUDE * np.sin(w * t) + DRIFT * t - noise
    force = (MEAN_FORCE + k * AMPLITUDE * np.sin(w * t + np.radians(chi)) + KC * DRIFT * t
             + KC * noise)
    return t, force, delta, frequency, k * np.exp(1j * np.radians(chi))


def replicas(kind: str, periods: int, count: int, seed: int, **kw) -> dict[str, np.ndarray]:
    """Errors and stated standard errors of k*, δ̂ and F̄ over ``count`` seeded segments."""
    rng = np.random.default_rng(seed)
    keys = ("zk", "zk_white", "zd", "zd_white", "ek2", "sk2", "sk2_white", "em2", "sm2",
            "zk_uncorrelated")
    out = {key: [] for key in keys}
    for _ in range(count):
        t, force, delta, f, k_true = segment(rng, kind, periods, **kw)
        o = demodulate_segment(t, force, delta, f, settle=1.0 / f - (t[1] - t[0]))
        k = o["F"] / o["d"]
        e = k - k_true
        ed = o["d"] - AMPLITUDE * np.exp(-0.5j * np.pi)      # A sin ωt = Re[A e^{-iπ/2} e^{iωt}]
        t_mid = t[-o["n"]:].mean()
        em = o["mean_force"] - (MEAN_FORCE + KC * DRIFT * t_mid)
        unc = math.hypot(o["sigma_F_hat"] / abs(o["F"]), o["sigma_d_hat"] / abs(o["d"]))
        for name, err, sd in (("zk", e, o["rho"] * abs(k)), ("zk_white", e, o["rho_white"] * abs(k)),
                              ("zd", ed, o["sigma_d_hat"]), ("zd_white", ed, o["sigma_d_hat_white"]),
                              ("zk_uncorrelated", e, unc * abs(k))):
            out[name] += [err.real / sd, err.imag / sd]
        out["ek2"].append(abs(e) ** 2 / 2)                    # per component
        out["sk2"].append((o["rho"] * abs(k)) ** 2)
        out["sk2_white"].append((o["rho_white"] * abs(k)) ** 2)
        out["em2"].append(em**2)
        out["sm2"].append(o["sigma_mean"] ** 2)
        assert o["stderr_bins"] == 2 * max(2, (periods - 1) // 4)
    return {key: np.asarray(v) for key, v in out.items()}


@pytest.mark.parametrize("periods", [5, 12, 20])      # m = 4, 11, 19 whole periods: 8, 8, 16 dof
def test_white_noise_agrees_with_the_white_formula(periods):
    r = replicas("white", periods, 400, seed=100 + periods)
    m = periods - 1
    # E[stderr²]: the white formula's, times 1 + 3/(πm)² (the drift estimate's share, which
    # the white formula leaves out); the mean over 400 replicas of ν = 8 has 2.5 % scatter
    ratio = r["sk2"].mean() / r["sk2_white"].mean()
    assert abs(ratio / (1 + 3 / (math.pi * m) ** 2) - 1) < 0.08, ratio
    # both are unbiased variances of the estimate: mean stderr² / mean error² ≈ 1 (±15 %:
    # the error² of 400 replicas scatters by 7 %)
    assert 0.85 < r["sk2"].mean() / r["ek2"].mean() < 1.15
    assert 0.85 < r["sk2_white"].mean() / r["ek2"].mean() < 1.15
    # z with the white formula (N − 5 dof): Gaussian, rms 1; with the band (ν = 2·bins dof):
    # Student-t, rms √(ν/(ν − 2)) = 1.15 at ν = 8, 1.07 at 16 (±0.12: 3 sd of 800 values)
    nu = 2 * 2 * max(2, m // 4)
    expected = math.sqrt(nu / (nu - 2))
    for key in ("zk", "zd"):
        assert abs(rms(r[key]) - expected) < 0.12, (key, rms(r[key]), expected)
        assert abs(rms(r[key + "_white"]) - 1.0) < 0.1, (key, rms(r[key + "_white"]))
    # the mean force (ν = 4 at these m): mean stderr² / mean error² ≈ 1 (±25 %)
    assert 0.75 < r["sm2"].mean() / r["em2"].mean() < 1.25


@pytest.mark.parametrize(("kind", "periods"), [("ar1", 5), ("ar1", 12), ("ar1", 20),
                                               ("walk", 5), ("walk", 12), ("walk", 20)])
def test_red_noise_and_random_walk_drift(kind, periods):
    r = replicas(kind, periods, 200, seed=200 + periods)
    # the white formula underestimates (least for the walk at m = 19: its 1/f² power is then
    # lowest at the drive relative to the whole residual, white z-rms ≈ 1.4)
    assert rms(r["zk_white"]) > 1.25
    assert rms(r["zd_white"]) > 1.25
    assert 0.7 <= rms(r["zk"]) <= 1.4, rms(r["zk"])
    assert 0.7 <= rms(r["zd"]) <= 1.4, rms(r["zd"])


def test_correlated_force_and_indentation_noise_is_kept():
    # k = KC, χ = 0: the deflection noise gives the same relative error in F̂ and δ̂ with
    # opposite signs, so they add in k* = F̂/δ̂ (twice the variance of independent noise)
    r = replicas("ar1", 12, 200, seed=7, k=KC, chi=0.0)
    assert 0.7 <= rms(r["zk"]) <= 1.3, rms(r["zk"])
    assert rms(r["zk_uncorrelated"]) > 1.25, rms(r["zk_uncorrelated"])   # √2 expected


def test_one_period_without_detrend_falls_back_to_the_white_formula():
    rng = np.random.default_rng(3)
    t, force, delta, f, _ = segment(rng, "white", 2)
    o = demodulate_segment(t, force, delta, f, settle=1.0 / f - (t[1] - t[0]), detrend=None)
    assert o["periods"] == 1 and o["stderr_bins"] == 0      # every bin is a drive harmonic
    assert o["rho"] == o["rho_white"] and o["sigma_d_hat"] == o["sigma_d_hat_white"]
    assert o["sigma_mean"] == o["sigma_mean_white"]


# ── the spectrum ────────────────────────────────────────────────────────────────────────────────

def test_spectrum_carries_both_errors_and_round_trips(tmp_path):
    ds = synthetic([5.0, 50.0], 0.03, 35.0, seed=4, n_curves=3, noise=3e-10, drift=20e-9)
    spec = modulation_spectrum(ds)
    validate_spectrum(spec)
    assert spec.attrs["stderr_method"] == modulation.STDERR_METHOD
    assert spec.attrs["stderr_method_white"] == modulation.STDERR_METHOD_WHITE
    for name, unit in (("stiffness", "N/m"), ("phase", "degree"), ("drive_amplitude", "m"),
                       ("mean_force", "N")):
        white = spec[f"{name}_stderr_white"]
        assert white.dims == spec[f"{name}_stderr"].dims == ("curve", "omega")
        assert white.attrs["units"] == spec[f"{name}_stderr"].attrs["units"] == unit
        assert np.all(np.isfinite(white.values) & (white.values > 0))
    np.testing.assert_array_equal(spec["lockin_stderr_bins"].values, 4)    # m = 11: K = 2
    # the white variables are the white-noise formula, recomputed here from the residuals
    t = ds["time"].values
    seg = ds["segment"].values
    row = int(np.flatnonzero(ds["segment_frequency"].values == 5.0)[0])
    sel = seg == row
    tt, force, tip = t[sel], ds["force"].values[sel], ds["tip_position"].values[sel]
    per = 1 / 5.0
    m = math.floor((tt[-1] - tt[0] - (per - (tt[1] - tt[0]))) / per + 1e-9)
    win = tt >= tt[-1] - m * per - 1e-9 * per
    tw = tt[win]
    basis = np.column_stack([np.ones(tw.size), tw - tw.mean(), np.cos(2 * np.pi * 5 * tw),
                             np.sin(2 * np.pi * 5 * tw)])
    fits = [np.linalg.lstsq(basis, x[win], rcond=None) for x in (force, tip)]
    res = [x[win] - basis @ c[0] for x, c in zip((force, tip), fits, strict=True)]
    amp = [complex(c[0][2], -c[0][3]) for c in fits]
    var_f, var_d = (r @ r / (tw.size - 5) for r in res)
    cov = res[0] @ res[1] / (tw.size - 5)
    chi = np.angle(amp[0] / amp[1])
    rho_w = math.sqrt(2 / tw.size * (var_f / abs(amp[0]) ** 2 + var_d / abs(amp[1]) ** 2
                                     - 2 * cov * math.cos(chi) / abs(amp[0] * amp[1])))
    k0 = spec["stiffness"].values[0, 0]
    np.testing.assert_allclose(spec["stiffness_stderr_white"].values[0, 0], rho_w * k0, rtol=0.02)
    np.testing.assert_allclose(spec["drive_amplitude_stderr_white"].values[0, 0],
                               math.sqrt(2 * var_d / tw.size), rtol=0.02)
    path = tmp_path / "spec.nc"
    spec.to_netcdf(path, engine="scipy")
    with xr.open_dataset(path, engine="scipy") as back:
        back.load()
    assert back.identical(spec)


def test_split_half_benchmark_script_runs(tmp_path):
    if not REAL_MAP.is_file():
        pytest.skip(f"real data file not present: {REAL_MAP}")
    script = Path(__file__).resolve().parents[2] / "studies" / "split_half" / "split_half.py"
    out = tmp_path / "split_half.json"
    run = subprocess.run([sys.executable, str(script), "--out", str(out), "--repeats", "1"],
                         capture_output=True, text=True, check=False)
    assert run.returncode == 0, run.stderr
    assert "BLAS pinned to one thread" in run.stdout
    report = json.loads(out.read_text())
    assert report["frequencies_hz"] == [1.0, 3.0, 10.0, 30.0, 100.0, 300.0]
    assert all(0.5 <= z <= 2.0 for z in report["rms_z"]["new"])
    assert all(z > 1.8 for z in report["rms_z"]["white"])
    code, _, err = run_main("split_half.py", "--path", str(tmp_path / "none"))  # in-process
    assert code == 2 and "no file" in err
