r"""Sine-modulation segments of measured force curves → spectrum (:func:`modulation_spectrum`).

Placement: this module needs both :mod:`viscoforce.io` (to read JPK archives into curves) and
:mod:`viscoforce.lockin` (to demodulate). Those two are siblings of one layer and may not import
each other, so it lives in :mod:`viscoforce.experiments`, the layer above both.

Per modulation segment of each curve (``segment_name == "modulation"``, frequency f from
``segment_frequency``, ω = 2πf):

* F(t) = ``force`` [N], minus the file's free-cantilever ``segment_baseline`` when
  ``subtract_baseline`` (only the mean force changes);
* δ(t) = ``tip_position`` (tip displacement toward the sample = −height − deflection) up to an
  offset, i.e. the indentation into the sample. With it a stiff elastic contact gives k* > 0 and
  phase ≈ 0: pushing the tip in (δ up) pushes the cantilever away (deflection, force up) in phase.
* Lock-in (:func:`viscoforce.lockin.demodulate`) of F and δ over the largest whole number m of
  periods that ends at the segment's last sample and starts after ``settle``; default ``settle``
  = ``settle_periods`` periods minus one sampling interval (so that a 5-period segment keeps 4
  whole periods after skipping the first); ``detrend="linear"`` removes a linear drift first.
  Harmonic 0 gives the mean force F̄.
* k* = F̂/δ̂ [N/m]; ``stiffness`` = |k*|, ``phase`` = arg k* [degree] (lead of the force over
  the indentation), ``drive_amplitude`` = |δ̂| [m], ``mean_force`` = F̄ [N].
* Corrections, in this order: an instrument ``phase_lag`` λ [degree] (a scalar, or a mapping
  frequency [Hz] → λ) is removed, k* ← k*·e^{−iλ}; then a hydrodynamic ``drag`` B [N·s/m],
  k* ← k* − iωB.

Standard errors from the residuals (white, stationary noise assumed). Over the N window samples,
r_x = x − (x̄ + drift + Re[X̂ e^{iωt}]) for x = F and x = δ (the drift line is fitted to the
residual when detrending), with p = 5 fitted parameters (3 without detrend):

.. math:: σ_x^2 = Σ r_x^2/(N − p),\quad c = Σ r_F r_δ/(N − p),\quad σ_{\hat X} = σ_x\sqrt{2/N}

(σ_X̂ per real component of X̂, hence also of |X̂|, and σ_X̂/|X̂| for its angle). The noise of F
and δ may be correlated (deflection noise enters both), so the relative error of k* = F̂/δ̂ is,
per component,

.. math:: ρ^2 = \frac{2}{N}\Big[\frac{σ_F^2}{|\hat F|^2} + \frac{σ_δ^2}{|\hat δ|^2}
          − \frac{2c\cos χ_{raw}}{|\hat F||\hat δ|}\Big],

giving ``stiffness_stderr`` = ρ|k*_raw| and ``phase_stderr`` = ρ|k*_raw|/|k*| rad (in degrees;
the corrections shift k* but not its error), ``drive_amplitude_stderr`` = σ_δ√(2/N) and
``mean_force_stderr`` = σ_F/√N. Correlated (coloured) noise makes these optimistic.

Quality (kept, never dropped): 1 ``phase_outside_passive_range`` where the corrected phase is
outside (0°, 90°) (:func:`viscoforce.schema.phase_quality`), else 2 ``low_signal`` where
|F̂| < 3·σ_F̂, else 0.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.io.curves import jpk_to_curves
from viscoforce.io.jpk import JPKArchive, read_jpk
from viscoforce.lockin import demodulate
from viscoforce.schema import make_spectrum, phase_quality, validate_curves

__all__ = ["demodulate_segment", "modulation_spectrum"]

_SLACK = 1e-9  # as lockin: fraction of a period the record may fall short of a whole period


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
        (residual std), ``cov`` [N·m], ``n`` samples and ``periods`` in the window, and ``rho``,
        the relative standard error of k* = F̂/δ̂; ``h`` ĥ [m] when ``height`` is given.
    """
    if not (isinstance(frequency, int | float | np.floating) and frequency > 0
            and math.isfinite(frequency)):
        raise ParameterError(f"modulation frequency must be > 0 and finite, got {frequency!r}")
    t = np.asarray(time, dtype=float)
    omega = 2.0 * math.pi * float(frequency)
    both = np.vstack([np.asarray(force, dtype=float), np.asarray(indentation, dtype=float)])
    amp = np.asarray(demodulate(both, t, omega, settle=settle, detrend=detrend))
    mean = np.asarray(demodulate(both, t, omega, harmonic=0, settle=settle, detrend=detrend)).real
    period = 1.0 / float(frequency)
    periods = math.floor((t[-1] - t[0] - settle) / period + _SLACK)
    start = t[-1] - periods * period
    dt = float(np.median(np.diff(t)))
    win = t >= start - 1e-6 * dt
    tw = t[win]
    model = mean[:, None] + (amp[:, None] * np.exp(1j * omega * tw)).real
    resid = both[:, win] - model
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
        rho = math.nan  # k* undefined or zero: no relative error
    else:
        chi = np.angle(f_hat / d_hat)
        rho2 = (2.0 / n) * (var_f / af**2 + var_d / ad**2 - 2.0 * cov * math.cos(chi) / (af * ad))
        rho = math.sqrt(max(rho2, 0.0))
    return {"F": f_hat, "d": d_hat, "mean_force": float(mean[0]), "sigma_F": math.sqrt(var_f),
            "sigma_d": math.sqrt(var_d), "cov": cov, "n": n, "periods": periods, "rho": rho,
            "h": None if height is None else complex(demodulate(
                np.asarray(height, dtype=float), t, omega, settle=settle, detrend=detrend))}


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


def _curves_of(data: Any, curves: int | Iterable[int] | None, height_channel: str | None
               ) -> tuple[xr.Dataset, np.ndarray | None]:
    """The curves dataset and the rows of ``curve`` to use (None: all)."""
    if isinstance(data, str | Path):
        data = read_jpk(data)
    if isinstance(data, JPKArchive):
        return jpk_to_curves(data, curves=curves, height_channel=height_channel), None
    if isinstance(data, xr.Dataset):
        ds = validate_curves(data)
        if curves is None:
            return ds, None
        picked = [curves] if isinstance(curves, int | np.integer) else list(curves)
        n = ds.sizes["curve"]
        if not picked or any(isinstance(c, bool) or not isinstance(c, int | np.integer)
                             or not -n <= c < n for c in picked):
            raise ParameterError(f"curves {picked} must be integers in [{-n}, {n})")
        return ds, np.asarray([c % n for c in picked])
    raise ParameterError("modulation_spectrum needs a JPKArchive, a path to one, or a curves "
                         f"dataset, got {type(data).__name__}")


def modulation_spectrum(data: Any, *, curves: int | Iterable[int] | None = None,
                        settle_periods: float = 1.0, settle: float | None = None,
                        detrend: str | None = "linear",
                        phase_lag: float | Mapping[float, float] | None = None,
                        drag: float | None = None, subtract_baseline: bool = True,
                        height_channel: str | None = None) -> xr.Dataset:
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
        Height channel for a JPK archive (default: the calibrated sensor).

    Returns
    -------
    xarray.Dataset
        Valid spectrum (``source="jpk"`` or the curves' source) with ``stiffness``, ``phase``,
        ``drive_amplitude``, ``mean_force``, their ``_stderr``, ``quality``, plus ``frequency``
        [Hz] (coordinate over ``omega``), ``nominal_amplitude`` [m] (the file's drive setting),
        ``phase_lag`` [degree] over ``omega`` (the lag subtracted), ``height_amplitude`` [m]
        (|ĥ| of the height channel: the measured drive; it differs
        from |δ̂| by the cantilever deflection), ``lockin_periods``, ``lockin_settle`` [s] and
        ``lockin_samples``; coords ``curve``, ``x``, ``y``.

    Raises
    ------
    ParameterError
        Bad options, no modulation segment, a modulation segment without a frequency, curves
        whose frequency sets differ, or a frequency repeated within a curve.
    """
    if not (isinstance(settle_periods, int | float) and settle_periods >= 0
            and math.isfinite(settle_periods)):
        raise ParameterError(f"settle_periods must be >= 0 and finite, got {settle_periods!r}")
    if settle is not None and not (isinstance(settle, int | float) and settle >= 0
                                   and math.isfinite(settle)):
        raise ParameterError(f"settle must be None or >= 0 seconds, got {settle!r}")
    if detrend not in ("linear", None):
        raise ParameterError(f"detrend must be 'linear' or None, got {detrend!r}")
    if drag is not None and not (isinstance(drag, int | float) and math.isfinite(drag)):
        raise ParameterError(f"drag must be a finite number [N·s/m], got {drag!r}")
    if phase_lag is not None and not isinstance(phase_lag, Mapping):
        if not (isinstance(phase_lag, int | float) and math.isfinite(phase_lag)):
            raise ParameterError(f"phase_lag must be degrees or a mapping Hz → degrees, got "
                                 f"{phase_lag!r}")
    ds, rows = _curves_of(data, curves, height_channel)
    if "segment_frequency" not in ds.variables:
        raise ParameterError("the curves dataset has no 'segment_frequency' [Hz] over "
                             "segment_table: the modulation frequencies are unknown")
    counts = np.asarray(ds["sample_count"].values)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    rows = np.arange(counts.size) if rows is None else rows
    names = np.asarray(ds["segment_name"].values).astype(str)
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

    results: list[dict[float, tuple[int, dict[str, Any]]]] = []
    for r in rows:
        sl = slice(int(starts[r]), int(starts[r] + counts[r]))
        found: dict[float, tuple[int, dict[str, Any]]] = {}
        s_seg = seg[sl]
        for row in np.unique(s_seg):
            if names[row] != "modulation":
                continue
            f = float(freq[row])
            if not (math.isfinite(f) and f > 0):
                raise ParameterError(f"curve {r}: modulation segment (table row {row}) has no "
                                     f"valid frequency ({f!r} Hz)")
            if any(math.isclose(f, g, rel_tol=1e-9) for g in found):
                raise ParameterError(f"curve {r}: frequency {f:g} Hz is modulated twice; select "
                                     "segments first")
            m = s_seg == row
            t = time[sl][m]
            dt = float(np.median(np.diff(t)))
            wait = settle if settle is not None else max(settle_periods / f - dt, 0.0)
            out = demodulate_segment(t, force[sl][m], tip[sl][m], f, settle=wait,
                                     detrend=detrend, height=height[sl][m])
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
    shape = (len(rows), fr.size)
    k_raw = np.empty(shape, complex)
    arrays = {k: np.empty(shape) for k in ("eta", "eta_se", "mean", "mean_se", "rho", "snr",
                                           "nominal", "height", "periods", "n", "settle")}
    for i, found in enumerate(results):
        for j, f in enumerate(sorted(found)):
            row, o = found[f]
            k_raw[i, j] = o["F"] / o["d"]
            b = base[row] if subtract_baseline and math.isfinite(base[row]) else 0.0
            arrays["eta"][i, j] = abs(o["d"])
            arrays["eta_se"][i, j] = o["sigma_d"] * math.sqrt(2.0 / o["n"])
            arrays["mean"][i, j] = o["mean_force"] - b
            arrays["mean_se"][i, j] = o["sigma_F"] / math.sqrt(o["n"])
            arrays["rho"][i, j] = o["rho"]
            arrays["snr"][i, j] = abs(o["F"]) / (o["sigma_F"] * math.sqrt(2.0 / o["n"]))
            arrays["nominal"][i, j] = nominal[row]
            arrays["height"][i, j] = abs(o["h"])
            arrays["periods"][i, j] = o["periods"]
            arrays["n"][i, j] = o["n"]
            arrays["settle"][i, j] = o["settle"]
    lags = np.asarray([_lag_for(phase_lag, float(f)) for f in fr])
    k = k_raw * np.exp(-1j * np.radians(lags))
    if drag is not None:
        k = k - 1j * omega * float(drag)
    sigma_c = arrays["rho"] * np.abs(k_raw)
    with np.errstate(divide="ignore", invalid="ignore"):
        phase_se = np.degrees(sigma_c / np.abs(k))
    phase = np.degrees(np.angle(k))
    quality = phase_quality(phase)
    quality = np.where((quality == 0) & (arrays["snr"] < 3.0), 2, quality).astype(np.int8)

    x = ds["x"].values[rows] if "x" in ds.variables else np.full(len(rows), np.nan)
    y = ds["y"].values[rows] if "y" in ds.variables else np.full(len(rows), np.nan)
    index = ds["curve"].values[rows] if "curve" in ds.coords else rows
    attrs = {key: v for key, v in ds.attrs.items() if not key.startswith("segment_")}
    attrs.update({
        "analysis": "lock-in of sine-modulation segments (viscoforce.experiments.modulation)",
        "indentation": "delta = tip_position (= -height - deflection) minus its mean: tip "
                       "displacement into the sample",
        "settle_periods": float(settle_periods), "detrend": str(detrend),
        "settle": "per-point lockin_settle" if settle is None else float(settle),
        "phase_lag": ("none" if phase_lag is None else "per-frequency"
                      if isinstance(phase_lag, Mapping) else "scalar"),
        "drag": float(drag) if drag is not None else 0.0,
        "mean_force_baseline_subtracted": int(bool(subtract_baseline)),
        "stderr_method": "white-noise residuals: sigma_Xhat = sigma*sqrt(2/N); relative error of "
                         "k* rho^2 = (2/N)(sF^2/|F|^2 + sd^2/|d|^2 - 2 c cos(chi)/(|F||d|))",
    })
    source = str(ds.attrs.get("source", "jpk"))
    spec = make_spectrum(
        omega, k, arrays["mean"], arrays["eta"], dims=("curve", "omega"), attrs=attrs,
        coords={"curve": ("curve", np.asarray(index)), "x": ("curve", np.asarray(x, float)),
                "y": ("curve", np.asarray(y, float))},
        stderr={"stiffness": sigma_c, "phase": phase_se, "drive_amplitude": arrays["eta_se"],
                "mean_force": arrays["mean_se"]},
        quality=quality, amplitude=False, source=source)
    w = ("curve", "omega")
    return spec.assign_coords(
        frequency=("omega", fr, {"units": "Hz", "long_name": "modulation frequency"})).assign(
        nominal_amplitude=(w, arrays["nominal"], {"units": "m",
                                                  "long_name": "nominal drive amplitude"}),
        phase_lag=(("omega",), lags, {"units": "degree",
                                      "long_name": "instrument phase lag subtracted"}),
        height_amplitude=(w, arrays["height"], {
            "units": "m", "long_name": "first-harmonic amplitude of the height channel",
            "height_channel": str(ds.attrs.get("height_channel", "height"))}),
        lockin_periods=(w, arrays["periods"].astype(np.int32),
                        {"units": "1", "long_name": "whole periods demodulated"}),
        lockin_samples=(w, arrays["n"].astype(np.int32),
                        {"units": "1", "long_name": "samples in the lock-in window"}),
        lockin_settle=(w, arrays["settle"], {"units": "s",
                                             "long_name": "time skipped at the segment start"}))
