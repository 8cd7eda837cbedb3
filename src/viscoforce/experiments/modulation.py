r"""Sine-modulation segments of measured force curves → spectrum (:func:`modulation_spectrum`).

Placement: this module needs both :mod:`viscoforce.io` (to read JPK archives into curves) and
:mod:`viscoforce.lockin` (to demodulate). Those two are siblings of one layer and may not import
each other, so it lives in :mod:`viscoforce.experiments`, the layer above both. From a JPK
archive the curves are demodulated segment by segment as decoded (the numbers
:func:`~viscoforce.io.curves.jpk_to_curves` would store, without building that dataset).

Per modulation segment of each curve (``segment_name == "modulation"``, frequency f from
``segment_frequency``, ω = 2πf):

* F(t) = ``force`` [N], minus the file's free-cantilever ``segment_baseline`` when
  ``subtract_baseline`` (only the mean force changes);
* δ(t) = ``tip_position`` (tip displacement toward the sample = −height − deflection) up to an
  offset, i.e. the indentation into the sample. With it a stiff elastic contact gives k* > 0 and
  phase ≈ 0: pushing the tip in (δ up) pushes the cantilever away (deflection, force up) in phase.
* Lock-in (:func:`viscoforce.lockin.harmonics`, orders 0 and 1) of F and δ over the largest
  whole number m of periods that ends at the segment's last sample and starts after ``settle``;
  default ``settle`` = ``settle_periods`` periods minus one sampling interval (so that a
  5-period segment keeps 4 whole periods after skipping the first); ``detrend="linear"``
  removes a linear drift first. Harmonic 0 gives the mean force F̄. F, δ and the height share
  one window: it is selected, resampled and detrended once per segment (one call on a stacked
  array).
* k* = F̂/δ̂ [N/m]; ``stiffness`` = |k*|, ``phase`` = arg k* [degree] (lead of the force over
  the indentation), ``drive_amplitude`` = |δ̂| [m], ``mean_force`` = F̄ [N].
* Corrections, in this order: an instrument ``phase_lag`` λ [degree] (a scalar, or a mapping
  frequency [Hz] → λ) is removed, k* ← k*·e^{−iλ}; then a hydrodynamic ``drag`` B [N·s/m],
  k* ← k* − iωB.

Standard errors (``attrs["stderr_method"]``) come from the spectrum of the lock-in residuals
next to the drive, so that they hold for coloured noise (1/f noise, drift, slow creep) and not
only for white noise. Over the N window samples (m = ``periods`` whole periods; the two window
ends are one point of the cycle, merged with the lock-in's trapezoid weights, so n = N − 1 points
per cycle) the residuals are r_x = x − (x̄ + drift + Re[X̂ e^{iωt}]) for x = F and x = δ (the
drift line is fitted to the residual when detrending). Their Fourier coefficients, normalised
like X̂,

.. math:: R_x(k) = \frac{2}{n}\sum_j r_x(t_j)\,e^{-2\pi i k j/n},

vanish at the drive bin k = m, where the same sum of the noise *is* the error of X̂; at the bins
k ≠ m next to it they are draws of the same (detrended) noise at the frequencies k/T. Assuming
the residual power spectrum is smooth — about linear — over the band B = {m − K, …, m + K},
K = max(2, ⌊m/4⌋) (within ±25 % of f for m ≥ 8), and the noise Gaussian and circular there,
the variance per real component is

.. math:: σ_{\hat X}^2 = \frac{g}{2}\,\mathrm{mean}_{k∈B}\frac{|R_x(k)|^2}{a_k},\qquad
          a_k = 1 − \frac{3}{(πk)^2},\quad g = 1 + \frac{3}{(πm)^2},

a_k the share of white-noise power the fitted drift line leaves in bin k, g the variance the
lock-in's own drift estimate adds at the drive (a_k = g = 1 without detrend). Multiples of m
(harmonics of a nonlinear response: deterministic power) and bins from Nyquist on are left
out. The noise of F and δ may be correlated (deflection noise enters both), with a phase that
may vary with frequency, so the relative error of k* = F̂/δ̂ is taken bin by bin,
ε_k = R_F(k)/F̂ − R_δ(k)/δ̂, and per component

.. math:: ρ^2 = \frac{g}{2}\,\mathrm{mean}_{k∈B}\frac{|ε_k|^2}{a_k},

giving ``stiffness_stderr`` = ρ|k*_raw| and ``phase_stderr`` = ρ|k*_raw|/|k*| rad (in degrees;
the corrections shift k* but not its error), ``drive_amplitude_stderr`` = σ_δ̂ and
``mean_force_stderr`` = σ_F̄ with σ_F̄² = ¼·mean over the K lowest bins k ≥ 1 (not multiples
of m) of |R_F(k)|²/a_k. What this assumes and gives:

* the estimate has ν = 2|B| degrees of freedom (4 at m = 2, 8 for m = 3–11, 12 for 12–15, 16
  for 16–19; 2K for the mean force), so error/stderr is Student-t like (rms √(ν/(ν − 2)) ≈
  1.15 at ν = 8), not Gaussian;
* for a spectrum that is convex over the band (a steep 1/f^α at small m) it errs on the large
  side; a drift of k* itself during the segment (sample creep) enters only through the
  sidebands it leaves next to the drive and is not fully counted;
* the mean-force error assumes the noise flat below K/T: where it still rises below 1/T
  (correlation times longer than the window, random-walk drift) it is a lower bound;
* where B is empty (m = 1 without detrend) the white formula below is used;
  ``lockin_stderr_bins`` = |B| says which (0: white).

On the real JPK map of a cell (16 curves, 1–300 Hz, 4–19 periods) the white formula is 2–6×
too small: the two halves of each window differ by an rms 2.1–6.4 of their stated errors; with
the residual-spectrum errors by 0.9–1.9 (``tests/test_modulation_stderr.py``,
``benchmarks/split_half.py``). The 1.9 is at 300 Hz, where the halves differ systematically
(same sign on every curve: the force response grows by ≈ 10 % through the segment), a drift
of k* the errors count only through its sidebands.

The white-noise formula (stationary white noise; ``*_stderr_white``, ``attrs
["stderr_method_white"]``) uses the residual variances instead, with p = 5 fitted parameters
(3 without detrend):

.. math:: σ_x^2 = Σ r_x^2/(N − p),\quad c = Σ r_F r_δ/(N − p),\quad σ_{\hat X} = σ_x\sqrt{2/N},

.. math:: ρ_w^2 = \frac{2}{N}\Big[\frac{σ_F^2}{|\hat F|^2} + \frac{σ_δ^2}{|\hat δ|^2}
          − \frac{2c\cos χ_{raw}}{|\hat F||\hat δ|}\Big],

and σ_F/√N for the mean force: the residual-spectrum errors for white noise on average
(E|ε_k|² is 4/n times the bracket), too small wherever the noise at ω exceeds its average.

Contact point and mean indentation (:func:`find_contact_point`, on each curve's approach
segment, force F against tip position z = ``tip_position``):

1. Baseline: a straight line F = a + b·z fitted to the first ``baseline_fraction`` (default 30 %)
   of the approach samples (a line, so a tilted free-cantilever baseline — virtual deflection,
   drag — is removed); noise σ = 1.4826·MAD of its residuals (robust to outliers/spikes).
2. Rise: r = F − baseline over the whole approach. The contact must give r(end) > ``k_sigma``·σ
   (default k = 5); the first estimate z₁ is the last sample at or below k·σ (after it the force
   stays above the threshold up to the end of the approach). z₁ must lie after the baseline
   window, and the baseline window must not curve upward significantly (t-statistic of the x²
   term of a quadratic fit > 8: a convex rise); else the baseline is contaminated and no
   contact is reported.
3. Refinement: least squares of r = A·max(z − z_c, 0)^p (p = ``exponent``, default 1.5, Hertz
   sphere; 1 for a linear contact) over all samples after the baseline window, for z_c between
   the baseline window end and z₁ (A > 0 in closed form for each z_c; grid over the sample
   positions, then bounded scalar refinement).

Indentation δ = z − z_c (tip displacement into the sample past contact, > 0 in contact); the
``mean_indentation`` of a modulation point is δ at the mean tip position of its lock-in window.
Limits: the method needs a free (non-contact) baseline in the first ``baseline_fraction`` of the
approach and a monotonic-ish rise ending at least k·σ above it; long-range forces (double-layer,
adhesion snap-in, hydrodynamics that are not linear in z) shift z_c; the power law is a local
model, so for very deep or non-Hertzian indentation the refined z_c is biased by a fraction of
the fitted range; creep of the sample between the approach and the modulation is included in δ
(the mean tip position is measured, not assumed). Where no contact is found the curve's
``mean_indentation`` is NaN and ``attrs["contact_point"]`` says so; when none is found on any
curve the variable is left out.

Which lag is in the phase: δ is built from the height channel, the calibrated sensor
(``measuredHeight``, ``strainGaugeHeight``, ``capacitiveSensorHeight``) where the file has one.
The sensor measures where the scanner is, so the piezo's lag behind its drive signal is not in
the phase and must not be subtracted again: on the real JPK map of a cell the sensor lags the
piezo ``height`` by 1.1, 1.4, 1.2, 2.1, 5.2 and 14.2° at 1, 3, 10, 30, 100 and 300 Hz (the same
on every curve, ``benchmarks/phase_lag_real.py``), and that lag is already absent from the
sensor-based phase. What can remain is named in the ``quality`` comment
(:data:`viscoforce.io.quality.PHASE_REMAINS`): the sensor's own bandwidth, the deflection
detection chain, the cantilever's inertia and hydrodynamics; ``attrs["phase_reference"]`` says
which height signal the phase refers to (:func:`viscoforce.io.quality.phase_basis`).

Phase reference: ``phase_reference`` = a spectrum measured on a hard (elastic) surface, where the
true phase is 0: its median phase per frequency (over all its other dims, non-finite values
ignored; taken circularly, about the circular mean) plus the ``phase_lag`` it already had
subtracted (its ``phase_lag`` variable, when present) is the instrument lag λ(f), subtracted as
``phase_lag``. Every modulation frequency must be in the reference (relative tolerance 1e-6;
extra reference frequencies are ignored), and ``phase_lag`` and ``phase_reference`` are
exclusive. Measured with the same cantilever, liquid, drive and height channel, it removes
everything the ``quality`` comment lists except the sample itself.

Quality (kept, never dropped; :func:`viscoforce.io.quality.spectrum_quality`, the function
the spectrum CSV reader uses too): 1 ``phase_outside_passive_range`` where the phase after the
corrections is outside (0°, 90°), else 2 ``low_signal`` where ``stiffness`` < 3·
``stiffness_stderr``, else 0. The comment says what was corrected (the lag per frequency, the
drag) and what can remain; ``attrs["quality_summary"]`` lists the flagged frequencies, how many
points and their median phase. A flag left after a correction is information, not a defect:
on the real map the 300 Hz points sit at 104.5–109.8° as measured and at 90.5–95.8° after
subtracting 14° (the sensor-vs-piezo lag, which a sensor-based phase does not contain), so they
stay flagged until a hard-surface reference says what the instrument adds there.

:func:`correct_spectrum` applies the same corrections and flags to a spectrum already made (a
spectrum CSV, a netCDF written by ``load``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from scipy.optimize import minimize_scalar

from viscoforce._limits import DRAG_RANGE
from viscoforce._validation import require_plausible
from viscoforce.exceptions import ParameterError
from viscoforce.io.curves import _read_block, check_height_channel, unique_curves
from viscoforce.io.jpk import JPKArchive, read_jpk
from viscoforce.io.quality import SENSOR_CHANNELS, phase_basis, quality_notes, spectrum_quality
from viscoforce.lockin import harmonics
from viscoforce.schema import (
    QUALITY_FLAGS,
    clean_attrs,
    make_spectrum,
    validate_curves,
    validate_spectrum,
)

__all__ = ["correct_spectrum", "demodulate_segment", "find_contact_point", "modulation_spectrum"]

#: ``attrs["stderr_method"]`` of every modulation spectrum: how the standard errors are made.
STDERR_METHOD = (
    "residual spectrum around the drive (coloured noise and drift): per-component variance of "
    "Xhat = half the mean power of the window's residual DFT (Xhat-normalised) over the bins "
    "m-K..m+K, K = max(2, floor(m/4)), m = periods, drive harmonics left out, each bin divided "
    "by 1 - 3/(pi k)^2 (power the drift line removed), times 1 + 3/(pi m)^2 (the lock-in's "
    "drift estimate); k*: the same mean of |eF_k/F - ed_k/d|^2 (F-delta correlation at each "
    "bin kept); mean force: the K lowest bins, a lower bound where noise rises below 1/T; "
    "white formula where no bin is left (lockin_stderr_bins = 0)")
#: ``attrs["stderr_method_white"]``: the white-noise formula of the ``*_stderr_white`` variables.
STDERR_METHOD_WHITE = (
    "white-noise residuals: sigma_Xhat = sigma*sqrt(2/N); relative error of k* rho^2 = "
    "(2/N)(sF^2/|F|^2 + sd^2/|d|^2 - 2 c cos(chi)/(|F||d|))")

_CONVEX_T = 8.0  # t-statistic of the baseline's x² term above which the window holds a contact
_SLACK = 1e-9  # as lockin: fraction of a period the record may fall short of a whole period
_FIT_CHUNK = 1 << 20  # matrix entries per chunk of the vectorised contact-point grid search
_BAND_FRACTION = 0.25  # half-width of the residual band around the drive bin m, fraction of m
_BAND_MIN = 2  # least half-width of that band [bins]


def demodulate_segment(time: np.ndarray, force: np.ndarray, indentation: np.ndarray,
                       frequency: float, *, settle: float, detrend: str | None = "linear",
                       height: np.ndarray | None = None) -> dict[str, Any]:
    """Lock-in of one modulation segment (see the module docstring for the formulas).

    Parameters
    ----------
    time : ndarray
        Sample times [s], strictly increasing.
    force, indentation : ndarray
        F(t) [N] and δ(t) [m] (any offset).
    frequency : float
        Drive frequency f [Hz], > 0.
    settle : float
        Time to skip at the segment start [s], >= 0.
    detrend : {"linear", None}
        Remove a linear drift before demodulating.
    height : ndarray, optional
        The height channel [m]; its complex amplitude is returned as ``h``.

    Returns
    -------
    dict
        ``F`` F̂ [N], ``d`` δ̂ [m] (complex), ``mean_force`` [N], ``sigma_F`` [N], ``sigma_d`` [m]
        (residual std), ``mean_position`` (mean of ``indentation`` over the lock-in window)
        [m], ``cov`` [N·m], ``n`` samples and ``periods`` in the window, and ``rho``,
        the relative standard error of k* = F̂/δ̂ per component (residual spectrum, module
        docstring); ``h`` ĥ [m] when ``height`` is given (else None). Also the standard errors
        per component ``sigma_F_hat`` [N] of F̂, ``sigma_d_hat`` [m] of δ̂, ``sigma_mean`` [N]
        of the mean force, ``stderr_bins`` (bins next to the drive they use; 0: the white
        formula), and their white-noise counterparts ``rho_white``, ``sigma_F_hat_white``,
        ``sigma_d_hat_white``, ``sigma_mean_white``.
    """
    if not (isinstance(frequency, int | float | np.floating) and frequency > 0
            and math.isfinite(frequency)):
        raise ParameterError(f"modulation frequency must be > 0 and finite, got {frequency!r}")
    t = np.asarray(time, dtype=float)
    signals = [force, indentation] + ([] if height is None else [height])
    stacked = np.vstack([np.asarray(x, dtype=float) for x in signals])
    return _demodulate_stacked(t, stacked, float(frequency), settle=settle, detrend=detrend,
                               dt=float(np.median(np.diff(t))))


def _demodulate_stacked(t: np.ndarray, stacked: np.ndarray, frequency: float, *, settle: float,
                        detrend: str | None, dt: float) -> dict[str, Any]:
    """:func:`demodulate_segment` of rows F, δ[, height] of ``stacked``; ``dt`` the median step."""
    omega = 2.0 * math.pi * frequency
    # one lock-in window (selection, resampling, detrend) for every signal and both harmonics
    coef = harmonics(stacked, t, omega, 1, settle=settle, detrend=detrend)
    amp, mean = coef[:2, 1], coef[:2, 0].real
    period = 1.0 / frequency
    periods = math.floor((t[-1] - t[0] - settle) / period + _SLACK)
    start = t[-1] - periods * period
    first = int(np.searchsorted(t, start - 1e-6 * dt, side="left"))  # t increasing: a suffix
    tw, both = t[first:], stacked[:2, first:]
    phase = omega * tw
    model = mean[:, None] + (amp.real[:, None] * np.cos(phase) - amp.imag[:, None] * np.sin(phase))
    resid = both - model
    n = int(tw.size)
    p = 3
    if detrend == "linear":
        tc = tw - tw.mean()
        slope = resid @ tc / (tc @ tc)
        resid = resid - resid.mean(axis=1, keepdims=True) - slope[:, None] * tc
        p = 5
    dof = max(n - p, 1)
    var_f, var_d = (resid ** 2).sum(axis=1) / dof
    cov = float(resid[0] @ resid[1]) / dof
    f_hat, d_hat = complex(amp[0]), complex(amp[1])
    af, ad = abs(f_hat), abs(d_hat)
    if af == 0 or ad == 0:
        rho_white = math.nan  # k* undefined or zero: no relative error
    else:
        chi = np.angle(f_hat / d_hat)
        rho2 = (2.0 / n) * (var_f / af**2 + var_d / ad**2 - 2.0 * cov * math.cos(chi) / (af * ad))
        rho_white = math.sqrt(max(rho2, 0.0))
    out = {"F": f_hat, "d": d_hat, "mean_force": float(mean[0]),
           "mean_position": float(np.mean(both[1])), "sigma_F": math.sqrt(var_f),
           "sigma_d": math.sqrt(var_d), "cov": cov, "n": n, "periods": periods,
           "rho_white": rho_white, "sigma_F_hat_white": math.sqrt(2.0 * var_f / n),
           "sigma_d_hat_white": math.sqrt(2.0 * var_d / n),
           "sigma_mean_white": math.sqrt(var_f / n),
           "h": None if stacked.shape[0] < 3 else complex(coef[2, 1])}
    out.update(_band_errors(resid, periods, f_hat, d_hat, detrended=detrend == "linear"))
    if out["stderr_bins"] == 0:  # no residual bin between the drive harmonics: white formula
        out.update(rho=rho_white, sigma_F_hat=out["sigma_F_hat_white"],
                   sigma_d_hat=out["sigma_d_hat_white"], sigma_mean=out["sigma_mean_white"])
    return out


def _demodulate_halves(t: np.ndarray, stacked: np.ndarray, frequency: float, *, settle: float,
                       detrend: str | None = "linear", dt: float | None = None
                       ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Split-half check: :func:`demodulate_segment` of each half of the lock-in window apart.

    The window of m whole periods (as :func:`demodulate_segment` with these ``settle`` and
    ``detrend``) gives two halves of ⌊m/2⌋ whole periods: its first and its last ⌊m/2⌋ periods
    (the middle period is left out when m is odd), each demodulated with its own standard errors.
    Where those errors hold, (k*_A − k*_B)/√(σ_A² + σ_B²) per real component has rms 1 over
    many segments (``tests/test_modulation_stderr.py``, ``benchmarks/split_half.py``).

    Parameters
    ----------
    t : ndarray
        Sample times [s], strictly increasing.
    stacked : ndarray
        Rows F [N], δ [m] (and optionally the height [m]) over ``t``.
    frequency : float
        Drive frequency f [Hz], > 0.
    settle : float
        Time skipped at the segment start [s], >= 0.
    detrend : {"linear", None}
        As :func:`demodulate_segment`, applied to each half.
    dt : float, optional
        Median sampling interval [s] (default: from ``t``).

    Returns
    -------
    tuple of dict
        The :func:`demodulate_segment` results of the first and the second half.

    Raises
    ------
    ParameterError
        If the halves would hold fewer whole periods than the lock-in needs (2 with a
        detrend, 1 without).
    """
    dt = float(np.median(np.diff(t))) if dt is None else dt
    period = 1.0 / frequency
    periods = math.floor((t[-1] - t[0] - settle) / period + _SLACK)
    half = periods // 2
    need = 2 if detrend == "linear" else 1
    if half < need:
        raise ParameterError(f"split-half needs {2 * need} whole periods in the lock-in window, "
                             f"got {periods} at {frequency:g} Hz")
    i0 = int(np.searchsorted(t, t[-1] - periods * period - 1e-6 * dt))
    i1 = int(np.searchsorted(t, t[i0] + half * period - 1e-6 * dt))    # at least half periods
    i2 = int(np.searchsorted(t, t[-1] - half * period - 1e-6 * dt))
    first, second = slice(i0, i1 + 1), slice(i2, None)
    return tuple(_demodulate_stacked(t[s], stacked[:, s], frequency, settle=0.0,
                                     detrend=detrend, dt=dt) for s in (first, second))


@lru_cache(maxsize=256)
def _band(periods: int, n_cycle: int, detrended: bool
          ) -> tuple[np.ndarray, int, np.ndarray, np.ndarray]:
    """Residual-spectrum bins behind the errors, and their weights (module docstring).

    Bin k is the frequency k/T of a window of T = ``periods`` drive periods sampled ``n_cycle``
    times per cycle (the drive is bin m = ``periods``). The bins are those around the drive,
    m − K … m + K with K = max(:data:`_BAND_MIN`, ⌊:data:`_BAND_FRACTION`·m⌋) (for X̂ and k*),
    then the K lowest bins k ≥ 1 (for the mean); harmonics of the drive (multiples of m, where a
    nonlinear response puts deterministic power) and bins from the Nyquist frequency on are
    left out. Returns the bins, how many of them are around the drive, and the weights that
    turn the powers of the raw DFT sums there into variances: g/(2·|B|·a_k)·(2/n)² around the
    drive and 1/(4·K·a_k)·(2/n)² for the mean, a_k = 1 − 3/(πk)² and g = 1 + 3/(πm)² with a
    detrend (else 1). Read-only arrays, cached per window shape.
    """
    m = periods
    half = max(_BAND_MIN, int(_BAND_FRACTION * m))
    near = np.arange(max(m - half, 1), m + half + 1)
    low = np.arange(1, 2 * half + 1)   # room for the K lowest: at most every other is a harmonic
    near = near[(near % m != 0) & (2 * near < n_cycle)]
    low = low[(low % m != 0) & (2 * low < n_cycle)][:half]
    if detrended:
        # the share of white-noise power a fitted line leaves in bin k: 3/(πk)² of a line's
        # normalised power lies there; the lock-in's drift estimate adds 3/(πm)² at the drive
        a_near = 1.0 - 3.0 / (math.pi * near) ** 2
        a_low = 1.0 - 3.0 / (math.pi * low) ** 2
        gain = 1.0 + 3.0 / (math.pi * m) ** 2
    else:
        a_near, a_low, gain = np.ones(near.size), np.ones(low.size), 1.0
    scale2 = (2.0 / n_cycle) ** 2   # X̂-normalised: the sum at bin m, times 2/n, would be X̂
    w_near = scale2 * gain / (2.0 * max(near.size, 1) * a_near)
    w_low = scale2 / (4.0 * max(low.size, 1) * a_low)
    bins = np.concatenate([near, low])
    for arr in (bins, w_near, w_low):
        arr.flags.writeable = False
    return bins, int(near.size) if near.size and low.size else 0, w_near, w_low


def _band_errors(resid: np.ndarray, periods: int, f_hat: complex, d_hat: complex, *,
                 detrended: bool) -> dict[str, Any]:
    """Standard errors of F̂, δ̂, k* and F̄ from the residual spectrum (module docstring).

    ``resid``: rows F and δ of the residuals over the lock-in window of ``periods`` whole
    periods, first and last sample one whole window apart (one point of the periodic cycle).
    Returns ``rho`` (relative error of k* per component), ``sigma_F_hat``, ``sigma_d_hat`` (per
    component of F̂, δ̂), ``sigma_mean`` (of F̄) and ``stderr_bins`` (bins around the drive; 0
    and NaN errors when there is none).
    """
    bins, nn, w_near, w_low = _band(periods, resid.shape[1] - 1, detrended)
    if nn == 0:
        nan = math.nan
        return {"rho": nan, "sigma_F_hat": nan, "sigma_d_hat": nan, "sigma_mean": nan,
                "stderr_bins": 0}
    # the window's two ends are one point of the cycle (the lock-in's trapezoid weights): the
    # first sample counts as the mean of both, which adds (r_last − r_0)/2 to every bin
    r = np.fft.rfft(resid[:, :-1], axis=1)[:, bins]
    r += (0.5 * (resid[:, -1] - resid[:, 0]))[:, None]
    power = r.real**2 + r.imag**2
    var_f, var_d = power[:, :nn] @ w_near   # per real component: half the mean band power
    var_mean = float(power[0, nn:] @ w_low)
    if f_hat == 0 or d_hat == 0:
        rho = math.nan
    else:
        eps = r[0, :nn] / f_hat - r[1, :nn] / d_hat   # bin by bin: the F–δ correlation is kept
        rho = math.sqrt(float((eps.real**2 + eps.imag**2) @ w_near))
    return {"rho": rho, "sigma_F_hat": math.sqrt(var_f), "sigma_d_hat": math.sqrt(var_d),
            "sigma_mean": math.sqrt(var_mean), "stderr_bins": nn}


def find_contact_point(position: np.ndarray, force: np.ndarray, *,
                       baseline_fraction: float = 0.3, k_sigma: float = 5.0,
                       exponent: float = 1.5, min_points: int = 5) -> dict[str, Any] | None:
    """Contact point of an approach curve, force against tip position (method in the module doc).

    Parameters
    ----------
    position : ndarray
        Tip position z [m] (displacement toward the sample, ``tip_position``), in time order.
    force : ndarray
        Force F [N] (repulsion > 0), same length.
    baseline_fraction : float
        Fraction of the samples (from the start) fitted by the baseline line, in (0, 0.8].
    k_sigma : float
        Threshold in baseline-noise units for the rise, > 0.
    exponent : float
        Exponent p of the post-contact model A·(z − z_c)^p, > 0 (1.5 Hertz sphere, 1 linear).
    min_points : int
        Least number of samples in the baseline window and after contact, >= 3.

    Returns
    -------
    dict or None
        ``z_contact`` [m], ``z_threshold`` [m] (the k·σ crossing z₁), ``sigma`` [N] (baseline
        noise), ``baseline`` (a [N], b [N/m]), ``amplitude`` A [N/m^p], ``rise`` (final rise /
        σ); None when no contact is found (too few samples, no rise above k·σ, a rise inside the
        baseline window or a convex baseline, or a non-positive fit).
    """
    if not (isinstance(baseline_fraction, int | float) and 0 < baseline_fraction <= 0.8):
        raise ParameterError(f"baseline_fraction must be in (0, 0.8], got {baseline_fraction!r}")
    if not (isinstance(k_sigma, int | float) and k_sigma > 0 and math.isfinite(k_sigma)):
        raise ParameterError(f"k_sigma must be > 0 and finite, got {k_sigma!r}")
    if not (isinstance(exponent, int | float) and exponent > 0 and math.isfinite(exponent)):
        raise ParameterError(f"exponent must be > 0 and finite, got {exponent!r}")
    if isinstance(min_points, bool) or not isinstance(min_points, int) or min_points < 3:
        raise ParameterError(f"min_points must be an integer >= 3, got {min_points!r}")
    z = np.asarray(position, dtype=float)
    f = np.asarray(force, dtype=float)
    if z.shape != f.shape or z.ndim != 1:
        raise ParameterError(f"position and force must be 1-D of one length, got {z.shape} and "
                             f"{f.shape}")
    ok = np.isfinite(z) & np.isfinite(f)
    z, f = z[ok], f[ok]
    nb = int(baseline_fraction * z.size)
    if nb < min_points or z.size - nb < min_points:
        return None
    zb, fb = z[:nb], f[:nb]
    if np.ptp(zb) <= 0:
        return None
    b, a = np.polyfit(zb, fb, 1)
    xb = (zb - zb.mean()) / np.ptp(zb)
    design = np.column_stack([np.ones(nb), xb, xb**2])
    coef = np.linalg.lstsq(design, fb, rcond=None)[0]
    rq = fb - design @ coef
    cov2 = float(rq @ rq) / max(nb - 3, 1) * np.linalg.inv(design.T @ design)[2, 2]
    if cov2 > 0 and coef[2] / math.sqrt(cov2) > _CONVEX_T:
        return None  # a significantly convex (rising) baseline: contact inside the window
    r = f - (a + b * z)
    rb = r[:nb]
    sigma = 1.4826 * float(np.median(np.abs(rb - np.median(rb))))
    if not sigma > 0:
        sigma = float(np.std(rb))
    if not sigma > 0:
        return None
    thr = k_sigma * sigma
    if not r[-1] > thr:
        return None
    below = np.flatnonzero(r <= thr)
    j = int(below[-1]) if below.size else 0
    if j < nb or z.size - j - 1 < min_points:
        return None
    zs, rs = z[nb:], r[nb:]
    lo, hi = float(np.max(z[:nb])), float(z[j])
    if not hi > lo:
        return None
    p = float(exponent)

    def sse(zc: float) -> float:
        return float(_power_law_fits(zs, rs, np.array([zc]), p)[0][0])

    grid = np.unique(np.clip(zs[(zs >= lo) & (zs <= hi)], lo, hi))
    grid = np.concatenate([[lo], grid, [hi]])
    if grid.size > 400:
        grid = np.linspace(lo, hi, 400)
    costs = _power_law_fits(zs, rs, grid, p)[0]
    i = int(np.argmin(costs))
    a_lo, a_hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    zc = float(grid[i])
    if a_hi > a_lo:
        opt = minimize_scalar(sse, bounds=(a_lo, a_hi), method="bounded",
                              options={"xatol": 1e-6 * (hi - lo) + 1e-15})
        if opt.fun <= costs[i]:
            zc = float(opt.x)
    amp = float(_power_law_fits(zs, rs, np.array([zc]), p)[1][0])
    if not amp > 0:
        return None
    return {"z_contact": zc, "z_threshold": hi, "sigma": sigma, "baseline": (float(a), float(b)),
            "amplitude": amp, "rise": float(r[-1] / sigma)}


def _power_law_fits(z: np.ndarray, r: np.ndarray, z_contact: np.ndarray, exponent: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Least squares of r = A·max(z − z_c, 0)^p for each candidate z_c, all at once.

    Returns the sums of squared residuals and the amplitudes A (closed form; 0 where the model
    vanishes on every sample), one per entry of ``z_contact``. The candidates are processed in
    chunks of about :data:`_FIT_CHUNK` matrix entries, so memory stays bounded for long curves;
    the powers 1, 1.5 and 2 are taken as products and square roots (the power function is the
    cost of the search).
    """
    costs = np.empty(z_contact.size)
    amps = np.empty(z_contact.size)
    step = max(1, _FIT_CHUNK // max(z.size, 1))
    for k in range(0, z_contact.size, step):
        g = z - z_contact[k:k + step, None]
        np.maximum(g, 0.0, out=g)
        if exponent == 1.5:
            g *= np.sqrt(g)
        elif exponent == 2.0:
            g *= g
        elif exponent != 1.0:
            np.power(g, exponent, out=g)
        gg = np.einsum("ij,ij->i", g, g)
        amp = np.divide(g @ r, gg, out=np.zeros_like(gg), where=gg > 0)
        g *= -amp[:, None]
        g += r
        costs[k:k + step] = np.einsum("ij,ij->i", g, g)
        amps[k:k + step] = amp
    return costs, amps

def _segment_samples(seg: np.ndarray) -> dict[int, slice | np.ndarray]:
    """Samples of each segment-table row of one curve, rows in order of first appearance.

    A slice where the row's samples are contiguous (as :func:`~viscoforce.io.curves.
    jpk_to_curves` writes them), else a boolean mask.
    """
    where: dict[int, slice | np.ndarray] = {}
    if seg.size == 0:
        return where
    cut = (np.flatnonzero(seg[1:] != seg[:-1]) + 1).tolist()
    for a, b in zip([0, *cut], [*cut, seg.size], strict=True):
        row = int(seg[a])
        where[row] = slice(a, b) if row not in where else seg == row
    return where


def _reference_lags(reference: Any, fr: np.ndarray) -> np.ndarray:
    """Instrument lag [degree] per frequency from a hard-surface reference spectrum."""
    if not isinstance(reference, xr.Dataset) or "phase" not in reference.variables \
            or "omega" not in reference.dims:
        raise ParameterError("phase_reference must be a spectrum dataset with 'phase' over "
                             "'omega'")
    ref_f = np.asarray(reference["omega"].values, dtype=float) / (2.0 * math.pi)
    phase = reference["phase"].transpose("omega", ...).values.reshape(ref_f.size, -1)
    if "phase_lag" in reference.variables and reference["phase_lag"].dims == ("omega",):
        phase = phase + np.asarray(reference["phase_lag"].values, dtype=float)[:, None]
    lags = np.empty(fr.size)
    for j, f in enumerate(fr):
        hit = np.flatnonzero(np.isclose(ref_f, f, rtol=1e-6, atol=0.0))
        if hit.size != 1:
            raise ParameterError(f"phase_reference has no single frequency matching {f:g} Hz "
                                 f"(it has {sorted(np.round(ref_f, 9).tolist())} Hz)")
        v = phase[hit[0]]
        v = v[np.isfinite(v)]
        if v.size == 0:
            raise ParameterError(f"phase_reference has no finite phase at {f:g} Hz")
        centre = math.degrees(math.atan2(np.sin(np.radians(v)).mean(),
                                         np.cos(np.radians(v)).mean()))
        d = (v - centre + 180.0) % 360.0 - 180.0
        lags[j] = centre + float(np.median(d))
    return lags


#: Largest instrument phase lag accepted [degree] (an angle; beyond it is a unit mistake).
MAX_PHASE_LAG = 180.0


def _check_corrections(phase_lag: Any, drag: Any, phase_reference: Any) -> None:
    """Validate the correction options of :func:`modulation_spectrum` / :func:`correct_spectrum`."""
    if drag is not None and (isinstance(drag, bool) or not isinstance(drag, int | float)
                             or not math.isfinite(drag) or drag < 0):
        raise ParameterError(f"drag must be a finite number >= 0 [N·s/m] (a viscous drag "
                             f"dissipates), got {drag!r}")
    if drag is not None:
        require_plausible("drag", drag, DRAG_RANGE, "N·s/m", why="a hydrodynamic drag B")
    if phase_lag is not None:
        values = list(phase_lag.values()) if isinstance(phase_lag, Mapping) else [phase_lag]
        for lag in values:
            if isinstance(lag, bool) or not (isinstance(lag, int | float | np.floating)
                                             and math.isfinite(lag)):
                raise ParameterError(f"phase_lag must be degrees or a mapping Hz → degrees, "
                                     f"got {phase_lag!r}")
            if abs(lag) > MAX_PHASE_LAG:
                raise ParameterError(f"phase_lag must be within ±{MAX_PHASE_LAG:g} degrees (an "
                                     f"instrument lag is an angle), got {lag!r}")
    if phase_reference is not None and phase_lag is not None:
        raise ParameterError("give phase_lag or phase_reference, not both")


def _lags(fr: np.ndarray, phase_lag: Any, phase_reference: Any) -> np.ndarray:
    """Instrument lag [degree] to subtract at each frequency ``fr`` [Hz] (0 when none given)."""
    if phase_reference is not None:
        return _reference_lags(phase_reference, fr)
    return np.asarray([_lag_for(phase_lag, float(f)) for f in fr], dtype=float)


def _corrected(k: np.ndarray, omega: np.ndarray, lags: np.ndarray, drag: float | None
               ) -> np.ndarray:
    """k* ← k*·e^{−iλ} − iωB, ``omega`` [rad/s] and λ [degree] along the last axis."""
    out = k * np.exp(-1j * np.radians(lags))
    if drag is not None:
        out = out - 1j * omega * float(drag)
    return out


def _corrections_text(fr: np.ndarray, lags: np.ndarray, drag: float, *, reference: bool) -> str:
    """What was corrected, for the ``quality`` comment: the lag per frequency and the drag."""
    what = "instrument lag from a hard-surface reference" if reference else "phase lag"
    if not np.any(lags != 0):
        lag_text = "no phase lag subtracted"
    elif np.all(lags == lags[0]):
        lag_text = f"{what} of {lags[0]:g} degree subtracted at every frequency"
    else:
        shown = [f"{lag:g} degree at {f:g} Hz" for f, lag in zip(fr, lags, strict=True)
                 if lag != 0]
        lag_text = (f"{what} subtracted: " + ", ".join(shown)
                    + (" (0 at the others)" if np.any(lags == 0) else ""))
    drag_text = (f"drag {drag:g} N*s/m subtracted as i*omega*B" if drag
                 else "no drag subtracted")
    return f"{lag_text}; {drag_text}"


def _lag_mode(phase_lag: Any, phase_reference: Any) -> str:
    """``attrs["phase_lag"]``: how the lag was given."""
    if phase_reference is not None:
        return "reference"
    if phase_lag is None:
        return "none"
    return "per-frequency" if isinstance(phase_lag, Mapping) else "scalar"


def _reference_attrs(basis: str, height_channel: Any, phase_lag: Any,
                     phase_reference: Any) -> dict[str, str]:
    """``phase_reference`` (and ``phase_reference_file``) attrs: what the phase refers to."""
    text = basis
    if phase_reference is not None:
        text += ("; instrument lag = median phase per frequency of a hard-surface reference "
                 "spectrum (plus its own phase_lag)")
    elif phase_lag is not None and height_channel in SENSOR_CHANNELS:
        text += "; the phase_lag given is taken as measured against this sensor (hard surface)"
    out = {"phase_reference": text}
    if phase_reference is not None and "file" in phase_reference.attrs:
        out["phase_reference_file"] = str(phase_reference.attrs["file"])
    return out


#: Variables computed from an uncorrected k* that :func:`correct_spectrum` cannot update.
_DERIVED = ("E_storage", "E_loss", "G_storage", "G_loss")


def correct_spectrum(spectrum: xr.Dataset, *,
                     phase_lag: float | Mapping[float, float] | None = None,
                     drag: float | None = None,
                     phase_reference: xr.Dataset | None = None) -> xr.Dataset:
    """The instrument corrections of :func:`modulation_spectrum`, on a spectrum already made.

    For a spectrum CSV (:func:`viscoforce.io.csv_formats.read_spectrum_csv`) or a netCDF that
    ``load`` wrote: k* ← k*·e^{−iλ} − iωB as in the module docstring, then the ``quality``
    flags, their comment and the attrs are made again by the functions the JPK path uses, so a
    spectrum gets the same flags whichever reader made it.

    Parameters
    ----------
    spectrum : xarray.Dataset
        A valid spectrum (``stiffness``, ``phase`` over ``omega``, any extra dims).
    phase_lag : float or mapping of float to float, optional
        Instrument phase lag [degree] to subtract: one value, or frequency [Hz] → lag for every
        frequency of the spectrum.
    drag : float, optional
        Hydrodynamic drag B [N·s/m], subtracted as iωB.
    phase_reference : xarray.Dataset, optional
        A hard-surface spectrum at the same frequencies (as for :func:`modulation_spectrum`).

    Returns
    -------
    xarray.Dataset
        The spectrum with ``stiffness``, ``phase``, ``force_amplitude`` and ``amplitude``
        (where present) corrected; ``phase_stderr`` (and ``phase_stderr_white``) scaled by
        |k*_before|/|k*_after| (the error of k* is unchanged, as in the JPK path); ``phase_lag``
        [degree] over ``omega`` = all the lag subtracted so far; ``quality`` made again; attrs
        ``phase_lag``, ``drag`` (the total), ``phase_reference``, ``quality_summary``.

    Raises
    ------
    ParameterError
        No correction given, bad options (as :func:`modulation_spectrum`), a lag or a drag the
        spectrum already had subtracted, or moduli (``E_storage`` …) already computed from the
        uncorrected k*.
    SchemaError
        ``spectrum`` is not a valid spectrum.
    """
    _check_corrections(phase_lag, drag, phase_reference)
    if phase_lag is None and drag is None and phase_reference is None:
        raise ParameterError("correct_spectrum needs phase_lag, drag or phase_reference")
    ds = validate_spectrum(spectrum)
    before = np.zeros(ds.sizes["omega"])
    if "phase_lag" in ds.variables and ds["phase_lag"].dims == ("omega",):
        before = np.asarray(ds["phase_lag"].values, dtype=float)
    mode = str(ds.attrs.get("phase_lag", "none"))
    lag_given = phase_lag is not None or phase_reference is not None
    if lag_given and (mode != "none" or np.any(before != 0)):
        raise ParameterError(f"this spectrum already had an instrument phase lag subtracted "
                             f"(attrs phase_lag = {mode!r}); correct the uncorrected spectrum")
    drag_before = float(ds.attrs.get("drag", 0.0) or 0.0)
    if drag is not None and drag_before:
        raise ParameterError(f"this spectrum already had a drag of {drag_before:g} N*s/m "
                             "subtracted; do not subtract it again")
    derived = [name for name in _DERIVED if name in ds.variables]
    if derived:
        raise ParameterError(f"the spectrum holds {derived}, computed from the uncorrected k*: "
                             "correct the spectrum first, then compute the moduli")
    omega = np.asarray(ds["omega"].values, dtype=float)
    fr = omega / (2.0 * math.pi)
    lags = _lags(fr, phase_lag, phase_reference)
    stiffness, phase = xr.broadcast(ds["stiffness"], ds["phase"])
    dims = stiffness.dims
    k_old = stiffness.values * np.exp(1j * np.radians(phase.values))
    k_new = _corrected(k_old, omega, lags, drag)
    new_stiffness, new_phase = np.abs(k_new), np.degrees(np.angle(k_new))
    out = ds.copy()
    out["stiffness"] = (dims, new_stiffness, ds["stiffness"].attrs)
    out["phase"] = (dims, new_phase, ds["phase"].attrs)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = xr.DataArray(np.abs(k_old) / new_stiffness, dims=dims)
    for name in ("phase_stderr", "phase_stderr_white"):
        if name in ds.variables:
            out[name] = (ds[name] * ratio).assign_attrs(ds[name].attrs)
    if "force_amplitude" in ds.variables and "drive_amplitude" in ds.variables:
        out["force_amplitude"] = (out["stiffness"] * ds["drive_amplitude"]).transpose(
            *dims).assign_attrs(ds["force_amplitude"].attrs)
    if "amplitude" in ds.variables and "force_amplitude" in out.variables:
        out["amplitude"] = (out["force_amplitude"] / ds["mean_force"]).transpose(
            *dims).assign_attrs(ds["amplitude"].attrs)
    err = ds["stiffness_stderr"].broadcast_like(stiffness).transpose(*dims).values \
        if "stiffness_stderr" in ds.variables else None
    quality = spectrum_quality(new_phase, new_stiffness, err)
    height_channel = ds.attrs.get("height_channel")
    basis = phase_basis(height_channel)
    total_drag = drag_before + float(drag or 0.0)
    total_lags = before + lags
    notes = quality_notes(quality, new_phase, fr, basis=basis, corrections=_corrections_text(
        fr, total_lags, total_drag, reference=phase_reference is not None
        or mode == "reference"))
    q_attrs = dict(ds["quality"].attrs) if "quality" in ds.variables else {}
    q_attrs.update({"long_name": "quality flag", "comment": notes["comment"]})
    if "quality" not in ds.variables:  # the CF flag attrs make_spectrum gives
        q_attrs.update({"flag_values": np.array(list(QUALITY_FLAGS), dtype=np.int8),
                        "flag_meanings": " ".join(QUALITY_FLAGS.values())})
    out["quality"] = (dims, quality, q_attrs)
    out["phase_lag"] = (("omega",), total_lags, {"units": "degree",
                                                 "long_name": "instrument phase lag subtracted"})
    out.attrs.update({"phase_lag": _lag_mode(phase_lag, phase_reference) if lag_given else mode,
                      "drag": total_drag, "quality_summary": notes["summary"]})
    if lag_given:
        out.attrs.update(_reference_attrs(basis, height_channel, phase_lag, phase_reference))
    else:
        out.attrs.setdefault("phase_reference", basis)
    return validate_spectrum(out)


def _lag_for(phase_lag: float | Mapping[float, float] | None, frequency: float) -> float:
    if phase_lag is None:
        return 0.0
    if isinstance(phase_lag, Mapping):
        try:
            table = {float(f): float(lag) for f, lag in phase_lag.items()}
        except (TypeError, ValueError):
            raise ParameterError(f"phase_lag must map frequencies [Hz] to degrees, got "
                                 f"{phase_lag!r}") from None
        for f, lag in table.items():
            if math.isclose(f, frequency, rel_tol=1e-6):
                return lag
        raise ParameterError(f"phase_lag gives no lag for {frequency:g} Hz (it has "
                             f"{sorted(table)} Hz)")
    return float(phase_lag)


@dataclass(frozen=True, eq=False)
class _Input:
    """What the lock-in reads, from a JPK archive or a curves dataset.

    ``curves``: per selected curve, its segments as (segment-table row, time, force,
    tip_position, height), rows in order of first appearance; ``rows`` the curve rows of the
    dataset (for messages); per segment-table row ``names``, ``freq`` [Hz], ``nominal`` [m],
    ``base`` [N]; per curve ``x``, ``y`` [m] and ``index``; ``attrs`` those of the curves dataset.
    """

    curves: list[list[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]]
    rows: list[int]
    names: Any
    freq: np.ndarray
    nominal: np.ndarray
    base: np.ndarray
    x: np.ndarray
    y: np.ndarray
    index: np.ndarray
    attrs: dict[str, Any]


def _input_of_archive(archive: JPKArchive, curves: int | Iterable[int] | None,
                      height_channel: str | None) -> _Input:
    """The segments of the selected curves as decoded: what the curves dataset would hold.

    Same numbers as :func:`~viscoforce.io.curves.jpk_to_curves` followed by the dataset path,
    without flattening the curves into one dataset (tip_position = −height − deflection, per
    segment as ``make_curves`` computes it per sample).
    """
    block = _read_block(archive, curves, height_channel)
    table, cols = block.table, block.cols
    segments: list[list[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]]] = [
        [] for _ in block.picked]
    for row, (t, f, h, d) in enumerate(zip(cols["time"], cols["force"], cols["height"],
                                           cols["deflection"], strict=True)):
        segments[table["curve"][row]].append((row, t, f, -h - d, h))
    attrs = clean_attrs(block.attrs)
    attrs["source"] = "jpk"
    return _Input(curves=segments, rows=list(range(len(block.picked))), names=table["name"],
                  freq=np.asarray(table["frequency"], dtype=float),
                  nominal=np.asarray(table["amplitude"], dtype=float),
                  base=np.asarray(table["baseline"], dtype=float),
                  x=np.asarray([c.x for c in block.decoded], dtype=float),
                  y=np.asarray([c.y for c in block.decoded], dtype=float),
                  index=np.asarray(block.picked, dtype=np.int32), attrs=attrs)


def _input_of_dataset(ds: xr.Dataset, rows: np.ndarray | None) -> _Input:
    """The segments of curve ``rows`` (None: all) of a valid curves dataset."""
    if "segment_frequency" not in ds.variables:
        raise ParameterError("the curves dataset has no 'segment_frequency' [Hz] over "
                             "segment_table: the modulation frequencies are unknown")
    counts = np.asarray(ds["sample_count"].values)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rows = np.arange(counts.size) if rows is None else rows
    freq = np.asarray(ds["segment_frequency"].values, dtype=float)
    nominal = (np.asarray(ds["segment_amplitude"].values, dtype=float)
               if "segment_amplitude" in ds.variables else np.full(freq.size, np.nan))
    base = (np.asarray(ds["segment_baseline"].values, dtype=float)
            if "segment_baseline" in ds.variables else np.full(freq.size, np.nan))
    time = np.asarray(ds["time"].values, dtype=float)
    force = np.asarray(ds["force"].values, dtype=float)
    tip = np.asarray(ds["tip_position"].values, dtype=float)
    height = np.asarray(ds["height"].values, dtype=float)
    seg = np.asarray(ds["segment"].values)
    segments = []
    for r in rows:
        sl = slice(int(starts[r]), int(starts[r] + counts[r]))
        c_time, c_force, c_tip, c_height = time[sl], force[sl], tip[sl], height[sl]
        segments.append([(row, c_time[m], c_force[m], c_tip[m], c_height[m])
                         for row, m in _segment_samples(seg[sl]).items()])
    return _Input(curves=segments, rows=[int(r) for r in rows],
                  names=np.asarray(ds["segment_name"].values).astype(str), freq=freq,
                  nominal=nominal, base=base,
                  x=ds["x"].values[rows] if "x" in ds.variables else np.full(len(rows), np.nan),
                  y=ds["y"].values[rows] if "y" in ds.variables else np.full(len(rows), np.nan),
                  index=ds["curve"].values[rows] if "curve" in ds.coords else rows,
                  attrs=dict(ds.attrs))


def _curves_of(data: Any, curves: int | Iterable[int] | None, height_channel: str | None
               ) -> _Input:
    """The segments to demodulate, from an archive, a path to one or a curves dataset."""
    if isinstance(data, str | Path):
        with read_jpk(data) as archive:  # opened here, so closed here
            return _input_of_archive(archive, curves, height_channel)
    if isinstance(data, JPKArchive):
        return _input_of_archive(data, curves, height_channel)
    if isinstance(data, xr.Dataset):
        ds = validate_curves(data)
        own = ds.attrs.get("height_channel")
        if height_channel is not None and height_channel != own:
            made = ("does not record its height channel" if own is None else
                    f"was made with {own!r} (attrs['height_channel'])")
            raise ParameterError(
                f"height_channel {height_channel!r} chooses the height of a JPK archive; this "
                f"curves dataset {made}: read the archive again with that height_channel, or "
                "leave it None")
        if curves is None:
            return _input_of_dataset(ds, None)
        picked = [curves] if isinstance(curves, int | np.integer) else list(curves)
        n = ds.sizes["curve"]
        if not picked or any(isinstance(c, bool) or not isinstance(c, int | np.integer)
                             or not -n <= c < n for c in picked):
            raise ParameterError(f"curves {picked} must be integers in [{-n}, {n})")
        return _input_of_dataset(ds, np.asarray(unique_curves([int(c) % n for c in picked],
                                                              [int(c) for c in picked])))
    raise ParameterError("modulation_spectrum needs a JPKArchive, a path to one, or a curves "
                         f"dataset, got {type(data).__name__}")


def modulation_spectrum(data: Any, *, curves: int | Iterable[int] | None = None,
                        settle_periods: float = 1.0, settle: float | None = None,
                        detrend: str | None = "linear",
                        phase_lag: float | Mapping[float, float] | None = None,
                        drag: float | None = None, subtract_baseline: bool = True,
                        height_channel: str | None = None,
                        phase_reference: xr.Dataset | None = None,
                        contact_point: bool | Mapping[str, Any] = True) -> xr.Dataset:
    """Spectrum over (``curve``, ``omega``) from every modulation segment of every curve.

    See the module docstring for the signs, the lock-in window, the corrections and the
    standard-error formulas.

    Parameters
    ----------
    data : JPKArchive, str, Path or xarray.Dataset
        A JPK archive (or its path), or a curves dataset with ``segment_frequency`` [Hz] over
        ``segment_table`` (as :func:`viscoforce.io.curves.jpk_to_curves` writes).
    curves : int or iterable of int, optional
        Curves to use (default all).
    settle_periods : float
        Drive periods to skip at the start of each segment (default 1), >= 0.
    settle : float, optional
        Time to skip [s] instead (overrides ``settle_periods``), >= 0.
    detrend : {"linear", None}
        Remove a linear drift of F and δ (default ``"linear"``).
    phase_lag : float or mapping of float to float, optional
        Instrument phase lag [degree] subtracted from the phase: one value, or frequency [Hz]
        → lag for every frequency present.
    drag : float, optional
        Hydrodynamic drag B [N·s/m], subtracted as iωB from k*.
    subtract_baseline : bool
        Subtract the file's free-cantilever baseline from the mean force (default True).
    height_channel : str, optional
        Height channel for a JPK archive (default: the calibrated sensor), one of
        :data:`~viscoforce.io.curves.HEIGHT_CHANNELS` (refused before anything is read). A
        curves dataset has its own: None or that one.
    phase_reference : xarray.Dataset, optional
        Spectrum measured on a hard (elastic) surface at the same frequencies (e.g. this
        function's output on a glass/sapphire map): its median phase per frequency is the
        instrument lag, subtracted as ``phase_lag`` (module docstring). Not with ``phase_lag``.
    contact_point : bool or mapping
        Estimate the contact point on each curve's approach (:func:`find_contact_point`) and
        store ``mean_indentation``; a mapping gives that function's options; False skips it.

    Returns
    -------
    xarray.Dataset
        Valid spectrum (``source="jpk"`` or the curves' source) with ``stiffness``, ``phase``,
        ``drive_amplitude``, ``mean_force``, their ``_stderr``, ``quality``, plus ``frequency``
        [Hz] (coordinate over ``omega``), ``nominal_amplitude`` [m] (the file's drive setting),
        ``phase_lag`` [degree] over ``omega`` (the lag subtracted), ``height_amplitude`` [m]
        (|ĥ| of the height channel: the measured drive; it differs
        from |δ̂| by the cantilever deflection), ``lockin_periods``, ``lockin_settle`` [s] and
        ``lockin_samples``; coords ``curve``, ``x``, ``y``; ``mean_indentation`` [m] (NaN on
        curves without a contact point; absent when no curve has one) with ``contact_position``
        [m] over ``curve`` (the tip position at contact, NaN where none). The ``_stderr`` are
        the residual-spectrum errors (module docstring, ``attrs["stderr_method"]``); the
        white-noise ones are kept as ``stiffness_stderr_white``, ``phase_stderr_white``,
        ``drive_amplitude_stderr_white`` and ``mean_force_stderr_white`` (``attrs
        ["stderr_method_white"]``), and ``lockin_stderr_bins`` counts the residual bins
        behind the errors (0: white formula used).

    Raises
    ------
    ParameterError
        Bad options, no modulation segment, a modulation segment without a frequency, curves
        whose frequency sets differ, a frequency repeated within a curve, both ``phase_lag``
        and ``phase_reference``, or a reference lacking a modulation frequency.
    """
    if not (isinstance(settle_periods, int | float) and settle_periods >= 0
            and math.isfinite(settle_periods)):
        raise ParameterError(f"settle_periods must be >= 0 and finite, got {settle_periods!r}")
    if settle is not None and not (isinstance(settle, int | float) and settle >= 0
                                   and math.isfinite(settle)):
        raise ParameterError(f"settle must be None or >= 0 seconds, got {settle!r}")
    if detrend not in ("linear", None):
        raise ParameterError(f"detrend must be 'linear' or None, got {detrend!r}")
    _check_corrections(phase_lag, drag, phase_reference)
    if not isinstance(subtract_baseline, bool | np.bool_):
        raise ParameterError(f"subtract_baseline must be True or False, got "
                             f"{subtract_baseline!r}")
    if isinstance(contact_point, Mapping):
        contact_options: dict[str, Any] | None = dict(contact_point)
    elif isinstance(contact_point, bool):
        contact_options = {} if contact_point else None
    else:
        raise ParameterError(f"contact_point must be True, False or a mapping of "
                             f"find_contact_point options, got {contact_point!r}")
    inp = _curves_of(data, curves, check_height_channel(height_channel))
    names, freq, nominal, base = inp.names, inp.freq, inp.nominal, inp.base

    results: list[dict[float, tuple[int, dict[str, Any]]]] = []
    contacts: list[dict[str, Any] | None] = []
    for r, segments in zip(inp.rows, inp.curves, strict=True):
        found: dict[float, tuple[int, dict[str, Any]]] = {}
        approach = [s for s in segments if names[s[0]] == "approach"]
        contacts.append(None if contact_options is None or not approach else find_contact_point(
            approach[0][3], approach[0][2], **contact_options))
        for row, t, c_force, c_tip, c_height in sorted(segments, key=lambda s: s[0]):
            if names[row] != "modulation":
                continue
            f = float(freq[row])
            if not (math.isfinite(f) and f > 0):
                raise ParameterError(f"curve {r}: modulation segment (table row {row}) has no "
                                     f"valid frequency ({f!r} Hz)")
            if any(math.isclose(f, g, rel_tol=1e-9) for g in found):
                raise ParameterError(f"curve {r}: frequency {f:g} Hz is modulated twice; select "
                                     "segments first")
            dt = float(np.median(np.diff(t)))
            wait = settle if settle is not None else max(settle_periods / f - dt, 0.0)
            out = _demodulate_stacked(t, np.vstack([c_force, c_tip, c_height]), f,
                                      settle=wait, detrend=detrend, dt=dt)
            out["settle"] = wait
            found[f] = (int(row), out)
        results.append(found)
    if not any(results):
        raise ParameterError("no modulation segment in the selected curves")
    fsets = [tuple(sorted(d)) for d in results]
    if any(len(s) != len(fsets[0]) or not np.allclose(s, fsets[0], rtol=1e-9) for s in fsets):
        raise ParameterError(f"the curves modulate different frequency sets {sorted(set(fsets))}; "
                             "select curves with the same set")
    fr = np.asarray(fsets[0])
    omega = 2.0 * math.pi * fr
    shape = (len(inp.rows), fr.size)
    k_raw = np.empty(shape, complex)
    arrays = {k: np.empty(shape) for k in ("eta", "eta_se", "mean", "mean_se", "rho",
                                           "eta_se_white", "mean_se_white", "rho_white",
                                           "bins", "nominal", "height", "periods", "n",
                                           "settle", "indent")}
    z_contact = np.asarray([np.nan if c is None else c["z_contact"] for c in contacts])
    for i, found in enumerate(results):
        for j, f in enumerate(sorted(found)):
            row, o = found[f]
            arrays["indent"][i, j] = o["mean_position"] - z_contact[i]
            k_raw[i, j] = o["F"] / o["d"]
            b = base[row] if subtract_baseline and math.isfinite(base[row]) else 0.0
            arrays["eta"][i, j] = abs(o["d"])
            arrays["eta_se"][i, j] = o["sigma_d_hat"]
            arrays["eta_se_white"][i, j] = o["sigma_d_hat_white"]
            arrays["mean"][i, j] = o["mean_force"] - b
            arrays["mean_se"][i, j] = o["sigma_mean"]
            arrays["mean_se_white"][i, j] = o["sigma_mean_white"]
            arrays["rho"][i, j] = o["rho"]
            arrays["rho_white"][i, j] = o["rho_white"]
            arrays["bins"][i, j] = o["stderr_bins"]
            arrays["nominal"][i, j] = nominal[row]
            arrays["height"][i, j] = abs(o["h"])
            arrays["periods"][i, j] = o["periods"]
            arrays["n"][i, j] = o["n"]
            arrays["settle"][i, j] = o["settle"]
    lags = _lags(fr, phase_lag, phase_reference)
    k = _corrected(k_raw, omega, lags, drag)
    sigma_c = arrays["rho"] * np.abs(k_raw)
    sigma_c_white = arrays["rho_white"] * np.abs(k_raw)
    with np.errstate(divide="ignore", invalid="ignore"):
        phase_se = np.degrees(sigma_c / np.abs(k))
        phase_se_white = np.degrees(sigma_c_white / np.abs(k))
    phase = np.degrees(np.angle(k))
    quality = spectrum_quality(phase, np.abs(k), sigma_c)
    height_channel = inp.attrs.get("height_channel")
    basis = phase_basis(height_channel)
    notes = quality_notes(quality, phase, fr, basis=basis, corrections=_corrections_text(
        fr, lags, float(drag or 0.0), reference=phase_reference is not None))

    x, y, index = inp.x, inp.y, inp.index
    attrs = {key: v for key, v in inp.attrs.items() if not key.startswith("segment_")}
    attrs.update({
        "analysis": "lock-in of sine-modulation segments (viscoforce.experiments.modulation)",
        "indentation": "delta = tip_position (= -height - deflection) minus its mean: tip "
                       "displacement into the sample",
        "settle_periods": float(settle_periods), "detrend": str(detrend),
        "settle": "per-point lockin_settle" if settle is None else float(settle),
        "mean_force_baseline_subtracted": int(bool(subtract_baseline)),
        "stderr_method": STDERR_METHOD, "stderr_method_white": STDERR_METHOD_WHITE,
    })
    attrs.update({"phase_lag": _lag_mode(phase_lag, phase_reference),
                  "drag": float(drag) if drag is not None else 0.0,
                  "quality_summary": notes["summary"]})
    attrs.update(_reference_attrs(basis, height_channel, phase_lag, phase_reference))
    source = str(inp.attrs.get("source", "jpk"))
    text, keep_indent = contact_point_summary(z_contact, index, source, contact_options)
    attrs["contact_point"] = text
    if contact_options is not None:
        if keep_indent:
            attrs["indentation_definition"] = (
                "mean_indentation = mean tip_position over the lock-in window minus the tip "
                "position at the approach contact point (> 0 in contact)")
    spec = make_spectrum(
        omega, k, arrays["mean"], arrays["eta"], dims=("curve", "omega"), attrs=attrs,
        coords={"curve": ("curve", np.asarray(index)), "x": ("curve", np.asarray(x, float)),
                "y": ("curve", np.asarray(y, float))},
        stderr={"stiffness": sigma_c, "phase": phase_se, "drive_amplitude": arrays["eta_se"],
                "mean_force": arrays["mean_se"]},
        quality=quality, quality_comment=notes["comment"], amplitude=False, source=source,
        mean_indentation=arrays["indent"] if keep_indent else None)
    w = ("curve", "omega")
    white = "white-noise formula (attrs stderr_method_white): too small for coloured noise"
    spec = spec.assign(
        stiffness_stderr_white=(w, sigma_c_white, {
            "units": "N/m", "long_name": "standard error of dynamic stiffness, white noise",
            "comment": white}),
        phase_stderr_white=(w, phase_se_white, {
            "units": "degree", "long_name": "standard error of phase, white noise",
            "comment": white}),
        drive_amplitude_stderr_white=(w, arrays["eta_se_white"], {
            "units": "m", "long_name": "standard error of drive amplitude, white noise",
            "comment": white}),
        mean_force_stderr_white=(w, arrays["mean_se_white"], {
            "units": "N", "long_name": "standard error of mean force, white noise",
            "comment": white}),
        lockin_stderr_bins=(w, arrays["bins"].astype(np.int32), {
            "units": "1", "long_name": "residual-spectrum bins behind the standard errors",
            "comment": "bins next to the drive frequency (0: none, white-noise formula used)"}))
    if keep_indent:
        spec = spec.assign(contact_position=("curve", z_contact, {
            "units": "m", "long_name": "tip position at the approach contact point"}))
    return spec.assign_coords(
        frequency=("omega", fr, {"units": "Hz", "long_name": "modulation frequency"})).assign(
        nominal_amplitude=(w, arrays["nominal"], {"units": "m",
                                                  "long_name": "nominal drive amplitude"}),
        phase_lag=(("omega",), lags, {"units": "degree",
                                      "long_name": "instrument phase lag subtracted"}),
        height_amplitude=(w, arrays["height"], {
            "units": "m", "long_name": "first-harmonic amplitude of the height channel",
            "height_channel": str(inp.attrs.get("height_channel", "height"))}),
        lockin_periods=(w, arrays["periods"].astype(np.int32),
                        {"units": "1", "long_name": "whole periods demodulated"}),
        lockin_samples=(w, arrays["n"].astype(np.int32),
                        {"units": "1", "long_name": "samples in the lock-in window"}),
        lockin_settle=(w, arrays["settle"], {"units": "s",
                                             "long_name": "time skipped at the segment start"}))


def contact_point_summary(z_contact: np.ndarray, curves: Any, source: str,
                          options: Mapping[str, Any] | None) -> tuple[str, bool]:
    """``attrs["contact_point"]`` of a spectrum and whether its ``mean_indentation`` is kept.

    ``z_contact``: the contact position per curve (NaN where none was found), ``curves`` their
    numbers, ``options`` those of :func:`find_contact_point` (None: not estimated). The
    indentation is kept when some curve has a contact point, and every curve of a simulation.
    """
    n_contact = int(np.isfinite(z_contact).sum())
    keep = n_contact > 0 and (n_contact == z_contact.size or source != "simulation")
    if options is None:
        return "not estimated (contact_point=False)", keep
    missing = [int(c) for c, z in zip(np.asarray(curves).tolist(), z_contact, strict=True)
               if not math.isfinite(z)]
    opts = ", ".join(f"{k}={v!r}" for k, v in sorted(options.items())) or "defaults"
    return ("approach baseline line + k*sigma rise + power-law refinement "
            f"(viscoforce.experiments.modulation.find_contact_point, {opts}); found on "
            f"{n_contact} of {z_contact.size} curves"
            + (f"; none on curves {missing} (mean_indentation NaN there)" if missing and keep
               else "")
            + ("; mean_indentation left out" if not keep else "")), keep
