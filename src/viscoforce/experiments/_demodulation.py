"""Lock-in demodulation of modulation segments, with their standard errors; what it reads.

:func:`demodulate_segment` and its stacked form (one call per segment of
:func:`viscoforce.experiments.modulation.modulation_spectrum`), the split-half check, the
residual-spectrum errors and the error covariances the phase reference needs
(:mod:`viscoforce.experiments.phase_reference`); and the segments to demodulate, from a JPK
archive or a curves dataset (:func:`_curves_of`). The signs, the lock-in window and the
standard-error formulas are told in :mod:`viscoforce.experiments.modulation`, the public module
that re-exports everything here.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.experiments.phase_reference import PIEZO_VARIABLE
from viscoforce.io.curves import _read_block, unique_curves
from viscoforce.io.jpk import JPKArchive, read_jpk
from viscoforce.io.map_grid import map_grid
from viscoforce.io.quality import SENSOR_CHANNELS
from viscoforce.lockin import harmonics
from viscoforce.schema import clean_attrs, validate_curves

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

_SLACK = 1e-9  # as lockin: fraction of a period the record may fall short of a whole period
_BAND_FRACTION = 0.25  # half-width of the residual band around the drive bin m, fraction of m
_BAND_MIN = 2  # least half-width of that band [bins]


def demodulate_segment(time: np.ndarray, force: np.ndarray, indentation: np.ndarray,
                       frequency: float, *, settle: float, detrend: str | None = "linear",
                       height: np.ndarray | None = None) -> dict[str, Any]:
    """Lock-in of one modulation segment (formulas in :mod:`viscoforce.experiments.modulation`).

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
                        detrend: str | None, dt: float,
                        piezo: np.ndarray | None = None) -> dict[str, Any]:
    """:func:`demodulate_segment` of rows F, δ[, height] of ``stacked``; ``dt`` the median step.

    With ``piezo`` (the piezo height record over ``t``, [m]; needs the height row) also ``hp``
    (its first harmonic ĥ_p [m]) and the error covariances of (F̂, δ̂, ĥ, ĥ_p) that
    :mod:`viscoforce.experiments.phase_reference` refers the phase with: :func:`_covariances`.
    The piezo is demodulated by a call of its own, so that F̂, δ̂ and ĥ are those without it.
    """
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
    if piezo is not None:
        hp = harmonics(np.asarray(piezo, dtype=float)[None, :], t, omega, 1, settle=settle,
                       detrend=detrend)[0]
        out["hp"] = complex(hp[1])
        extra = np.vstack([stacked[2, first:], np.asarray(piezo, dtype=float)[first:]])
        model = np.array([coef[2, 0].real, hp[0].real])[:, None] + (
            np.array([coef[2, 1].real, hp[1].real])[:, None] * np.cos(phase)
            - np.array([coef[2, 1].imag, hp[1].imag])[:, None] * np.sin(phase))
        out.update(_covariances(np.vstack([resid, _detrended(extra - model, tw, detrend)]),
                                periods, n, dof, detrended=detrend == "linear"))
    return out


def _detrended(resid: np.ndarray, tw: np.ndarray, detrend: str | None) -> np.ndarray:
    """``resid`` less its mean and least-squares line (rows over ``tw``) with a detrend."""
    if detrend != "linear":
        return resid
    tc = tw - tw.mean()
    return resid - resid.mean(axis=1, keepdims=True) - (resid @ tc / (tc @ tc))[:, None] * tc


def _covariances(resid: np.ndarray, periods: int, n: int, dof: int, *, detrended: bool
                 ) -> dict[str, np.ndarray]:
    """Error covariances of the first harmonics of the rows of ``resid`` (F, δ, ĥ, ĥ_p).

    ``cov_band`` [row units²]: C_ij = Σ_k w_k R_i(k) R_j(k)* over the residual band around the
    drive (the weights of :func:`_band`), so that for any complex combination c of the rows
    c·C·c^H is the variance per real component of c·X̂ (the module's residual-spectrum error,
    correlations kept bin by bin); ``cov_white``: the same from the white-noise formula,
    (2/N)·Σ r_i r_j/(N − p). Where the band is empty (``stderr_bins`` 0) ``cov_band`` is
    ``cov_white``, as for the other errors.
    """
    white = (2.0 / n) * (resid @ resid.T) / dof
    bins, nn, w_near, _ = _band(periods, resid.shape[1] - 1, detrended)
    if nn == 0:
        return {"cov_band": white.astype(complex), "cov_white": white}
    r = np.fft.rfft(resid[:, :-1], axis=1)[:, bins[:nn]]
    r += (0.5 * (resid[:, -1] - resid[:, 0]))[:, None]
    return {"cov_band": (r * w_near) @ r.conj().T, "cov_white": white}


def _demodulate_halves(t: np.ndarray, stacked: np.ndarray, frequency: float, *, settle: float,
                       detrend: str | None = "linear", dt: float | None = None
                       ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Split-half check: :func:`demodulate_segment` of each half of the lock-in window apart.

    The window of m whole periods (as :func:`demodulate_segment` with these ``settle`` and
    ``detrend``) gives two halves of ⌊m/2⌋ whole periods: its first and its last ⌊m/2⌋ periods
    (the middle period is left out when m is odd), each demodulated with its own standard errors.
    Where those errors hold, (k*_A − k*_B)/√(σ_A² + σ_B²) per real component has rms 1 over
    many segments (``tests/measured/test_modulation_stderr.py``, ``studies/split_half/split_half.py``).

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
    """Residual-spectrum bins behind the errors, and their weights (modulation module docstring).

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
    """Standard errors of F̂, δ̂, k* and F̄ from the residual spectrum (modulation docstring).

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


@dataclass(frozen=True, eq=False)
class _Input:
    """What the lock-in reads, from a JPK archive or a curves dataset.

    ``curves``: per selected curve, its segments as (segment-table row, time, force,
    tip_position, height), rows in order of first appearance; ``rows`` the curve rows of the
    dataset (for messages); per segment-table row ``names``, ``freq`` [Hz], ``nominal`` [m],
    ``base`` [N]; per curve ``x``, ``y`` [m], ``index`` and the map's integer ``row``,
    ``column`` (None where nothing places the curves); ``attrs`` those of the curves dataset;
    ``piezo``, when asked for and present in every modulation segment beside a sensor height:
    per curve, segment-table row → the piezo height record [m] of that segment.
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
    piezo: list[dict[int, np.ndarray]] | None = None
    row: np.ndarray | None = None
    column: np.ndarray | None = None


def _input_of_archive(archive: JPKArchive, curves: int | Iterable[int] | None,
                      height_channel: str | None, piezo: bool = False) -> _Input:
    """The segments of the selected curves as decoded: what the curves dataset would hold.

    Same numbers as :func:`~viscoforce.io.curves.jpk_to_curves` followed by the dataset path,
    without flattening the curves into one dataset (tip_position = −height − deflection, per
    segment as ``make_curves`` computes it per sample). With ``piezo``, the piezo ``height``
    of the modulation segments too, where the height is a sensor (:func:`_piezo_of_archive`).
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
                  index=np.asarray(block.picked, dtype=np.int32), attrs=attrs,
                  piezo=_piezo_of_archive(archive, block, segments) if piezo else None,
                  row=np.asarray([c.row for c in block.decoded], dtype=np.int32),
                  column=np.asarray([c.column for c in block.decoded], dtype=np.int32))


def _piezo_of_archive(archive: JPKArchive, block: Any, segments: list
                      ) -> list[dict[int, np.ndarray]] | None:
    """The piezo ``height`` [m] of every modulation segment, or None where any lacks it.

    None too where the block's height is not a sensor (it is then the piezo itself). Decoded
    curve by curve (only that channel), in the segment order of ``segments``.
    """
    if block.height not in SENSOR_CHANNELS:
        return None
    names = block.table["name"]
    out = []
    for i, rows in zip(block.picked, segments, strict=True):
        decoded = archive._curve_only(i, frozenset(("height", "vDeflection")))  # it calibrates
        found = {}
        for (row, t, *_), seg in zip(rows, decoded.segments, strict=True):
            if names[row] != "modulation":
                continue
            values = seg.channels.get("height")
            if (values is None or seg.units.get("height", "m") != "m"
                    or np.shape(values) != t.shape or not np.all(np.isfinite(values))):
                return None
            found[row] = np.asarray(values, dtype=float)
        out.append(found)
    return out


def _input_of_dataset(ds: xr.Dataset, rows: np.ndarray | None, piezo: bool = False) -> _Input:
    """The segments of curve ``rows`` (None: all) of a valid curves dataset.

    With ``piezo``, the piezo record of the modulation segments from the dataset's
    ``piezo_height`` [m] (:data:`~viscoforce.experiments.phase_reference.PIEZO_VARIABLE`), where
    it has one beside a sensor ``height``.
    """
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
    names = np.asarray(ds["segment_name"].values).astype(str)
    record = None
    if piezo and PIEZO_VARIABLE in ds.variables and ds.attrs.get("height_channel") in \
            SENSOR_CHANNELS:
        variable = ds[PIEZO_VARIABLE]
        if variable.dims != ("sample",) or variable.attrs.get("units") != "m":
            raise ParameterError(f"'{PIEZO_VARIABLE}' must be the piezo height [m] over 'sample', "
                                 f"got dims {variable.dims}, units {variable.attrs.get('units')!r}")
        record = np.asarray(variable.values, dtype=float)
    segments, piezos = [], []
    for r in rows:
        sl = slice(int(starts[r]), int(starts[r] + counts[r]))
        c_time, c_force, c_tip, c_height = time[sl], force[sl], tip[sl], height[sl]
        where = _segment_samples(seg[sl])
        segments.append([(row, c_time[m], c_force[m], c_tip[m], c_height[m])
                         for row, m in where.items()])
        if record is not None:
            piezos.append({row: record[sl][m] for row, m in where.items()
                           if names[row] == "modulation"})
    if record is not None and not all(np.all(np.isfinite(v)) for p in piezos
                                      for v in p.values()):
        record = None
    grid = _grid_of_dataset(ds)
    return _Input(curves=segments, rows=[int(r) for r in rows], names=names, freq=freq,
                  nominal=nominal, base=base,
                  x=ds["x"].values[rows] if "x" in ds.variables else np.full(len(rows), np.nan),
                  y=ds["y"].values[rows] if "y" in ds.variables else np.full(len(rows), np.nan),
                  index=ds["curve"].values[rows] if "curve" in ds.coords else rows,
                  attrs=dict(ds.attrs), piezo=piezos if record is not None else None,
                  row=None if grid is None else grid[0][rows],
                  column=None if grid is None else grid[1][rows])


def _grid_of_dataset(ds: xr.Dataset) -> tuple[np.ndarray, np.ndarray] | None:
    """Per curve of ``ds`` its integer map (row, column): the dataset's, else from x and y.

    Positions are placed on the grid of every curve of the dataset
    (:func:`~viscoforce.io.map_grid.map_grid`), so a selection keeps the map's indices; None
    without positions.
    """
    if "row" in ds.variables and "column" in ds.variables:
        return (np.asarray(ds["row"].values, dtype=np.int32),
                np.asarray(ds["column"].values, dtype=np.int32))
    if "x" not in ds.variables or "y" not in ds.variables:
        return None
    grid = map_grid(ds["x"].values, ds["y"].values)
    return grid.row, grid.column


def _curves_of(data: Any, curves: int | Iterable[int] | None, height_channel: str | None,
               piezo: bool = False) -> _Input:
    """The segments to demodulate, from an archive, a path to one or a curves dataset.

    ``piezo``: also the piezo height record where there is one (:class:`_Input`).
    """
    if isinstance(data, str | Path):
        with read_jpk(data) as archive:  # opened here, so closed here
            return _input_of_archive(archive, curves, height_channel, piezo)
    if isinstance(data, JPKArchive):
        return _input_of_archive(data, curves, height_channel, piezo)
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
            return _input_of_dataset(ds, None, piezo)
        picked = [curves] if isinstance(curves, int | np.integer) else list(curves)
        n = ds.sizes["curve"]
        if not picked or any(isinstance(c, bool) or not isinstance(c, int | np.integer)
                             or not -n <= c < n for c in picked):
            raise ParameterError(f"curves {picked} must be integers in [{-n}, {n})")
        return _input_of_dataset(ds, np.asarray(unique_curves([int(c) % n for c in picked],
                                                              [int(c) for c in picked])), piezo)
    raise ParameterError("modulation_spectrum needs a JPKArchive, a path to one, or a curves "
                         f"dataset, got {type(data).__name__}")
