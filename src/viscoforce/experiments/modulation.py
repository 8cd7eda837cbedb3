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
the residual-spectrum errors by 0.9–1.9 (``tests/measured/test_modulation_stderr.py``,
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

Contact point and mean indentation: :func:`find_contact_point` (on each curve's approach segment,
force F against tip position z = ``tip_position``; the method and its limits in
:mod:`viscoforce.experiments.contact_point`) gives the contact position z_c. Indentation
δ = z − z_c (> 0 in contact); the ``mean_indentation`` of a modulation point is δ at the mean tip
position of its lock-in window. Where no contact is found the curve's ``mean_indentation`` is
NaN and ``attrs["contact_point"]`` says so; when none is found on any curve the variable is left
out.

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
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.experiments._demodulation import (  # noqa: F401 (re-exported)
    _BAND_FRACTION,
    _BAND_MIN,
    _SLACK,
    STDERR_METHOD,
    STDERR_METHOD_WHITE,
    _band,
    _band_errors,
    _demodulate_halves,
    _demodulate_stacked,
    demodulate_segment,
)
from viscoforce.experiments.contact_point import (  # noqa: F401 (re-exported)
    _CONVEX_T,
    _FIT_CHUNK,
    _power_law_fits,
    contact_point_summary,
    find_contact_point,
)
from viscoforce.experiments.corrections import (  # noqa: F401 (re-exported)
    _DERIVED,
    MAX_PHASE_LAG,
    _check_corrections,
    _corrected,
    _corrections_text,
    _lag_for,
    _lag_mode,
    _lags,
    _reference_attrs,
    _reference_lags,
    correct_spectrum,
)
from viscoforce.io.curves import _read_block, check_height_channel, unique_curves
from viscoforce.io.jpk import JPKArchive, read_jpk
from viscoforce.io.quality import phase_basis, quality_notes, spectrum_quality
from viscoforce.schema import clean_attrs, make_spectrum, validate_curves

__all__ = ["correct_spectrum", "demodulate_segment", "find_contact_point", "modulation_spectrum"]


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
