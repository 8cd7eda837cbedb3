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
``studies/split_half/split_half.py``). The 1.9 is at 300 Hz, where the halves differ systematically
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
(``measuredHeight``, ``strainGaugeHeight``, ``capacitiveSensorHeight``) where the file has one,
and the phase of its first harmonic is referred to the sensor as recorded, to the piezo record,
or to the sensor advanced by its delay behind the piezo (``phase_reference``:
:mod:`viscoforce.experiments.phase_reference`, which tells the default and why). On the real JPK
map of a cell the sensor lags the piezo ``height`` by 1.1, 1.5, 1.2, 2.1, 5.2 and 14.1° at 1, 3,
10, 30, 100 and 300 Hz (the same on every curve): the fast part is the sensor's own delay
(τ_d ≈ 0.14 ms, removed by the default), the slow part mostly the open-loop piezo's creep, which
a sensor-based phase rightly leaves out. What can remain is named in the ``quality`` comment
(:data:`viscoforce.io.quality.PHASE_REMAINS`): the deflection detection chain, the cantilever's
inertia and hydrodynamics, a sensor lag that is not a delay; ``attrs["phase_reference"]`` says
which height signal the phase refers to, ``attrs["phase_reference_choice"]`` why.

Hard-surface reference: ``phase_reference`` = a spectrum measured on a hard (elastic) surface
against the sensor (its ``phase_reference_mode`` "sensor"; the data are then referred to the
sensor too), where the true phase is 0: its median phase per frequency (over all its other
dims, non-finite values ignored; taken circularly, about the circular mean) plus the
``phase_lag`` it already had subtracted (its ``phase_lag`` variable, when present) is the
instrument lag λ(f), subtracted as ``phase_lag``. Every modulation frequency must be in the
reference (relative tolerance 1e-6; extra reference frequencies are ignored), and ``phase_lag``
and ``phase_reference`` are exclusive. Measured with the same cantilever, liquid, drive and
height channel, it removes everything the ``quality`` comment lists except the sample itself.

Quality (kept, never dropped; :func:`viscoforce.io.quality.spectrum_quality`, the function
the spectrum CSV reader uses too): 1 ``phase_outside_passive_range`` where the phase after the
corrections is outside (0°, 90°), else 2 ``low_signal`` where ``stiffness`` < 3·
``stiffness_stderr``, else 0. The comment says what was corrected (the lag per frequency, the
drag) and what can remain; ``attrs["quality_summary"]`` lists the flagged frequencies, how many
points and their median phase. A flag left after a correction is information, not a defect:
on the real map the 300 Hz points sit at 104.5–109.8° against the sensor as recorded and at
91.8–98.0° against the sensor advanced by its delay (the default; 92.6–98.7° against the piezo),
so they stay flagged until a hard-surface reference says what the instrument adds there.

:func:`correct_spectrum` applies the same corrections and flags to a spectrum already made (a
spectrum CSV, a netCDF written by ``load``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
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
    _curves_of,
    _demodulate_halves,
    _demodulate_stacked,
    _Input,
    _input_of_archive,
    _input_of_dataset,
    _segment_samples,
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
from viscoforce.experiments.phase_reference import (
    check_phase_reference,
    choose_reference,
    fit_sensor_delay,
    phase_difference,
    reference_basis,
    referred,
)
from viscoforce.io.curves import check_height_channel
from viscoforce.io.quality import SENSOR_CHANNELS, quality_notes, spectrum_quality
from viscoforce.schema import make_spectrum

__all__ = ["correct_spectrum", "demodulate_segment", "find_contact_point", "modulation_spectrum"]

#: Real (curve, frequency) arrays of :class:`_Demodulated`.
_REAL = ("eta", "eta_se", "mean", "mean_se", "rho", "eta_se_white", "mean_se_white",
         "rho_white", "bins", "nominal", "height", "periods", "n", "settle", "indent")
#: What the piezo record adds: its harmonic and the error covariances of (F̂, δ̂, ĥ, ĥ_p).
_PIEZO = ("hp", "cov_band", "cov_white")


def modulation_spectrum(data: Any, *, curves: int | Iterable[int] | None = None,
                        settle_periods: float = 1.0, settle: float | None = None,
                        detrend: str | None = "linear",
                        phase_lag: float | Mapping[float, float] | None = None,
                        drag: float | None = None, subtract_baseline: bool = True,
                        height_channel: str | None = None,
                        phase_reference: str | xr.Dataset | None = None,
                        contact_point: bool | Mapping[str, Any] = True) -> xr.Dataset:
    """Spectrum over (``curve``, ``omega``) from every modulation segment of every curve.

    See the module docstring for the signs, the lock-in window, the corrections and the
    standard-error formulas, and :mod:`viscoforce.experiments.phase_reference` for the phase
    reference.

    Parameters
    ----------
    data : JPKArchive, str, Path or xarray.Dataset
        A JPK archive (or its path), or a curves dataset with ``segment_frequency`` [Hz] over
        ``segment_table`` (as :func:`viscoforce.io.curves.jpk_to_curves` writes; with the
        piezo record as ``piezo_height`` [m] beside a sensor ``height`` where it has one).
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
    phase_reference : {"auto", "sensor", "piezo", "delay"} or xarray.Dataset, optional
        What the phase of δ refers to (:mod:`viscoforce.experiments.phase_reference`): the
        sensor as recorded, the piezo's phase with the sensor's amplitude, or the sensor
        advanced by its delay fitted over the selected curves; None or ``"auto"``: the one the
        data support (``attrs["phase_reference_choice"]`` says which and why). Or a spectrum
        measured on a hard (elastic) surface at the same frequencies with the sensor as its
        reference (e.g. this function's output on a glass/sapphire map with
        ``phase_reference="sensor"``): its median phase per frequency is the instrument lag,
        subtracted as ``phase_lag`` (module docstring); not with ``phase_lag``.
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
        behind the errors (0: white formula used). Where the piezo record was read:
        ``height_phase_difference`` (and its ``_stderr``) [degree], the sensor − piezo phase
        per point. Attrs ``phase_reference`` (its name — ``sensor``, ``piezo``, ``delay: τ ±
        σ``, or the hard-surface reference — and what the phase is measured against),
        ``phase_reference_mode`` (``sensor``, ``piezo`` or ``delay``),
        ``phase_reference_choice`` (which and why) and, where the delay was fitted,
        ``sensor_delay``, ``sensor_delay_stderr`` [s] and ``sensor_delay_fit``.

    Raises
    ------
    ParameterError
        Bad options, no modulation segment, a modulation segment without a frequency, curves
        whose frequency sets differ, a frequency repeated within a curve, both ``phase_lag``
        and a reference spectrum, a reference lacking a modulation frequency or referred to
        anything but the sensor, ``"piezo"`` or ``"delay"`` without a sensor and a piezo record.
    """
    options = _checked(settle_periods=settle_periods, settle=settle, detrend=detrend,
                       phase_lag=phase_lag, drag=drag, subtract_baseline=subtract_baseline,
                       phase_reference=phase_reference, contact_point=contact_point)
    demodulated = _demodulate(data, curves, check_height_channel(height_channel), options)
    return _spectrum(demodulated, options)


def _checked(*, settle_periods, settle, detrend, phase_lag, drag, subtract_baseline,
             phase_reference, contact_point) -> dict[str, Any]:
    """The options of :func:`modulation_spectrum`, checked; ``contact`` the contact options."""
    if not (isinstance(settle_periods, int | float) and settle_periods >= 0
            and math.isfinite(settle_periods)):
        raise ParameterError(f"settle_periods must be >= 0 and finite, got {settle_periods!r}")
    if settle is not None and not (isinstance(settle, int | float) and settle >= 0
                                   and math.isfinite(settle)):
        raise ParameterError(f"settle must be None or >= 0 seconds, got {settle!r}")
    if detrend not in ("linear", None):
        raise ParameterError(f"detrend must be 'linear' or None, got {detrend!r}")
    reference = check_phase_reference(phase_reference)
    hard = reference if isinstance(reference, xr.Dataset) else None
    _check_corrections(phase_lag, drag, hard)
    if hard is not None and hard.attrs.get("phase_reference_mode", "sensor") != "sensor":
        raise ParameterError(
            f"phase_reference: this hard-surface spectrum's phase refers to the "
            f"{hard.attrs['phase_reference_mode']!r} reference (attrs phase_reference_mode); a "
            "hard-surface reference measures the instrument lag against the sensor itself: make "
            "it with phase_reference='sensor'")
    if not isinstance(subtract_baseline, bool | np.bool_):
        raise ParameterError(f"subtract_baseline must be True or False, got "
                             f"{subtract_baseline!r}")
    if isinstance(contact_point, Mapping):
        contact: dict[str, Any] | None = dict(contact_point)
    elif isinstance(contact_point, bool):
        contact = {} if contact_point else None
    else:
        raise ParameterError(f"contact_point must be True, False or a mapping of "
                             f"find_contact_point options, got {contact_point!r}")
    return {"settle_periods": settle_periods, "settle": settle, "detrend": detrend,
            "phase_lag": phase_lag, "drag": drag, "subtract_baseline": subtract_baseline,
            "reference": reference, "contact": contact}


@dataclass(frozen=True, eq=False)
class _Demodulated:
    """The lock-in of a selection of curves per (curve, frequency), before any correction.

    ``arrays``: the real (curve, frequency) arrays of :data:`_REAL`, the complex harmonics
    ``F`` [N], ``d`` (δ̂), ``h`` (the height channel's) [m] and, where every modulation segment
    has a piezo record beside a sensor, those of :data:`_PIEZO` (``cov_*`` over (curve,
    frequency, 4, 4)); ``fr`` the frequencies [Hz]; per curve ``z_contact`` [m], ``x``, ``y``
    [m], ``index`` and the map's integer ``row``, ``column`` (None where unknown); ``attrs``
    those of the curves.
    """

    fr: np.ndarray
    arrays: dict[str, np.ndarray]
    z_contact: np.ndarray
    x: np.ndarray
    y: np.ndarray
    index: np.ndarray
    attrs: dict[str, Any]
    row: np.ndarray | None = None
    column: np.ndarray | None = None


def _demodulate(data: Any, curves: Any, height_channel: str | None,
                options: dict[str, Any]) -> _Demodulated:
    """Every modulation segment of the selected curves through the lock-in (no correction)."""
    settle, settle_periods = options["settle"], options["settle_periods"]
    piezo = options["reference"] in ("auto", "piezo", "delay")
    inp = _curves_of(data, curves, height_channel, piezo)
    names, freq, nominal, base = inp.names, inp.freq, inp.nominal, inp.base
    results: list[dict[float, tuple[int, dict[str, Any]]]] = []
    contacts: list[dict[str, Any] | None] = []
    for i, (r, segments) in enumerate(zip(inp.rows, inp.curves, strict=True)):
        found: dict[float, tuple[int, dict[str, Any]]] = {}
        approach = [s for s in segments if names[s[0]] == "approach"]
        contacts.append(None if options["contact"] is None or not approach else
                        find_contact_point(approach[0][3], approach[0][2], **options["contact"]))
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
            out = _demodulate_stacked(t, np.vstack([c_force, c_tip, c_height]), f, settle=wait,
                                      detrend=options["detrend"], dt=dt,
                                      piezo=None if inp.piezo is None else inp.piezo[i][row])
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
    shape = (len(inp.rows), fr.size)
    arrays = {k: np.empty(shape) for k in _REAL}
    arrays.update({k: np.empty(shape, complex) for k in ("F", "d", "h")})
    if inp.piezo is not None:
        arrays.update(hp=np.empty(shape, complex), cov_band=np.empty((*shape, 4, 4), complex),
                      cov_white=np.empty((*shape, 4, 4)))
    z_contact = np.asarray([np.nan if c is None else c["z_contact"] for c in contacts])
    for i, found in enumerate(results):
        for j, f in enumerate(sorted(found)):
            row, o = found[f]
            b = base[row] if options["subtract_baseline"] and math.isfinite(base[row]) else 0.0
            values = {"indent": o["mean_position"] - z_contact[i], "F": o["F"], "d": o["d"],
                      "h": o["h"], "eta": abs(o["d"]), "eta_se": o["sigma_d_hat"],
                      "eta_se_white": o["sigma_d_hat_white"], "mean": o["mean_force"] - b,
                      "mean_se": o["sigma_mean"], "mean_se_white": o["sigma_mean_white"],
                      "rho": o["rho"], "rho_white": o["rho_white"], "bins": o["stderr_bins"],
                      "nominal": nominal[row], "height": abs(o["h"]), "periods": o["periods"],
                      "n": o["n"], "settle": o["settle"]}
            for key in _PIEZO if inp.piezo is not None else ():
                values[key] = o[key]
            for key, value in values.items():
                arrays[key][i, j] = value
    return _Demodulated(fr=fr, arrays=arrays, z_contact=z_contact, x=inp.x, y=inp.y,
                        index=inp.index, attrs=inp.attrs, row=inp.row, column=inp.column)


def _joined(parts: list[_Demodulated]) -> _Demodulated:
    """Chunks of curves as one selection (the same frequencies; the piezo where all have it)."""
    first = parts[0]
    for part in parts[1:]:
        a, b = first.fr, part.fr
        if a.shape != b.shape or not np.allclose(a, b, rtol=1e-9, atol=0.0):
            sets = sorted({tuple(a.tolist()), tuple(b.tolist())})
            raise ParameterError(f"the curves modulate different frequency sets {sets}; select "
                                 "curves with the same set")
    keys = [k for k in first.arrays if all(k in p.arrays for p in parts)]
    placed = all(p.row is not None and p.column is not None for p in parts)
    return _Demodulated(
        fr=first.fr, arrays={k: np.concatenate([p.arrays[k] for p in parts]) for k in keys},
        **{k: np.concatenate([getattr(p, k) for p in parts])
           for k in ("z_contact", "x", "y", "index")}, attrs=first.attrs,
        **{k: np.concatenate([getattr(p, k) for p in parts]) if placed else None
           for k in ("row", "column")})


def _grid_coords(dem: _Demodulated) -> dict[str, tuple]:
    """The map's integer ``row`` and ``column`` coordinates over ``curve`` (none if unknown)."""
    if dem.row is None or dem.column is None:
        return {}
    return {name: ("curve", np.asarray(values, dtype=np.int32), {
        "units": "1", "long_name": f"grid {name} of the curve (along {axis}, from 0; -1: no "
                                  "position)"})
            for name, values, axis in (("row", dem.row, "y"), ("column", dem.column, "x"))}


def _spectrum(dem: _Demodulated, options: dict[str, Any]) -> xr.Dataset:
    """The spectrum of :func:`modulation_spectrum` from the lock-in of its curves."""
    a, fr = dem.arrays, dem.fr
    omega = 2.0 * math.pi * fr
    reference, drag, phase_lag = options["reference"], options["drag"], options["phase_lag"]
    hard = reference if isinstance(reference, xr.Dataset) else None
    height_channel = dem.attrs.get("height_channel")
    fit = None
    if "hp" in a and height_channel in SENSOR_CHANNELS and hard is None:
        try:
            fit = fit_sensor_delay(fr, a["h"], a["hp"], a["cov_band"])
        except ParameterError:
            if reference == "delay":
                raise
    mode, why = choose_reference(reference, channel=height_channel, has_piezo="hp" in a,
                                 fit=fit)
    k_raw, eta, eta_se, eta_se_white = a["F"] / a["d"], a["eta"], a["eta_se"], a["eta_se_white"]
    rho, rho_white = a["rho"], a["rho_white"]
    k_sensor, rho_sensor = k_raw, rho  # kept: the sensor's own phase, the budget's alternative
    if mode != "sensor":
        band, white = (referred(mode, a["F"], a["d"], a["h"], a["hp"], a[cov], omega, fit)
                       for cov in ("cov_band", "cov_white"))
        k_raw, eta, eta_se, rho = band["k"], band["eta"], band["eta_se"], band["rho"]
        eta_se_white, rho_white = white["eta_se"], white["rho"]
    lags = _lags(fr, phase_lag, hard)
    k = _corrected(k_raw, omega, lags, drag)
    sigma_c = rho * np.abs(k_raw)
    sigma_c_white = rho_white * np.abs(k_raw)
    with np.errstate(divide="ignore", invalid="ignore"):
        phase_se = np.degrees(sigma_c / np.abs(k))
        phase_se_white = np.degrees(sigma_c_white / np.abs(k))
    phase = np.degrees(np.angle(k))
    quality = spectrum_quality(phase, np.abs(k), sigma_c)
    basis = reference_basis(mode, height_channel, fit, hard)
    notes = quality_notes(quality, phase, fr, basis=basis, corrections=_corrections_text(
        fr, lags, float(drag or 0.0), reference=hard is not None))

    attrs = {key: v for key, v in dem.attrs.items() if not key.startswith("segment_")}
    attrs.update({
        "analysis": "lock-in of sine-modulation segments (viscoforce.experiments.modulation)",
        "indentation": "delta = tip_position (= -height - deflection) minus its mean: tip "
                       "displacement into the sample",
        "settle_periods": float(options["settle_periods"]), "detrend": str(options["detrend"]),
        "settle": ("per-point lockin_settle" if options["settle"] is None
                   else float(options["settle"])),
        "mean_force_baseline_subtracted": int(bool(options["subtract_baseline"])),
        "stderr_method": STDERR_METHOD, "stderr_method_white": STDERR_METHOD_WHITE,
    })
    attrs.update({"phase_lag": _lag_mode(phase_lag, hard),
                  "drag": float(drag) if drag is not None else 0.0,
                  "quality_summary": notes["summary"]})
    attrs.update(_reference_attrs(basis, height_channel, phase_lag, hard))
    attrs.update({"phase_reference_mode": mode, "phase_reference_choice": why})
    if fit is not None:
        attrs.update(fit.as_attrs())
    source = str(dem.attrs.get("source", "jpk"))
    contact_options = options["contact"]
    text, keep_indent = contact_point_summary(dem.z_contact, dem.index, source, contact_options)
    attrs["contact_point"] = text
    if contact_options is not None and keep_indent:
        attrs["indentation_definition"] = (
            "mean_indentation = mean tip_position over the lock-in window minus the tip "
            "position at the approach contact point (> 0 in contact)")
    spec = make_spectrum(
        omega, k, a["mean"], eta, dims=("curve", "omega"), attrs=attrs,
        coords={"curve": ("curve", np.asarray(dem.index)),
                "x": ("curve", np.asarray(dem.x, float)),
                "y": ("curve", np.asarray(dem.y, float)), **_grid_coords(dem)},
        stderr={"stiffness": sigma_c, "phase": phase_se, "drive_amplitude": eta_se,
                "mean_force": a["mean_se"]},
        quality=quality, quality_comment=notes["comment"], amplitude=False, source=source,
        mean_indentation=a["indent"] if keep_indent else None)
    w = ("curve", "omega")
    white = "white-noise formula (attrs stderr_method_white): too small for coloured noise"
    spec = spec.assign(
        stiffness_stderr_white=(w, sigma_c_white, {
            "units": "N/m", "long_name": "standard error of dynamic stiffness, white noise",
            "comment": white}),
        phase_stderr_white=(w, phase_se_white, {
            "units": "degree", "long_name": "standard error of phase, white noise",
            "comment": white}),
        drive_amplitude_stderr_white=(w, eta_se_white, {
            "units": "m", "long_name": "standard error of drive amplitude, white noise",
            "comment": white}),
        mean_force_stderr_white=(w, a["mean_se_white"], {
            "units": "N", "long_name": "standard error of mean force, white noise",
            "comment": white}),
        lockin_stderr_bins=(w, a["bins"].astype(np.int32), {
            "units": "1", "long_name": "residual-spectrum bins behind the standard errors",
            "comment": "bins next to the drive frequency (0: none, white-noise formula used)"}))
    if keep_indent:
        spec = spec.assign(contact_position=("curve", dem.z_contact, {
            "units": "m", "long_name": "tip position at the approach contact point"}))
    if mode != "sensor":  # the same points against the sensor's own phase (same corrections)
        k_s = _corrected(k_sensor, omega, lags, drag)
        with np.errstate(divide="ignore", invalid="ignore"):
            phase_s_se = np.degrees(rho_sensor * np.abs(k_sensor) / np.abs(k_s))
        what = ("against the height sensor's own phase (phase_reference 'sensor'): the "
                "alternative the error budget refits")
        spec = spec.assign(
            stiffness_sensor=(w, np.abs(k_s), {"units": "N/m",
                                               "long_name": "dynamic stiffness " + what}),
            stiffness_sensor_stderr=(w, rho_sensor * np.abs(k_sensor), {
                "units": "N/m", "long_name": "standard error of stiffness_sensor"}),
            phase_sensor=(w, np.degrees(np.angle(k_s)), {"units": "degree",
                                                         "long_name": "phase " + what}),
            phase_sensor_stderr=(w, phase_s_se, {
                "units": "degree", "long_name": "standard error of phase_sensor"}),
            drive_amplitude_sensor=(w, a["eta"], {
                "units": "m", "long_name": "drive amplitude |delta| " + what}))
    if "hp" in a:
        difference, difference_se = phase_difference(a["h"], a["hp"], a["cov_band"])
        long_name = "phase of the height sensor minus that of the piezo height record"
        spec = spec.assign(
            height_phase_difference=(w, difference, {"units": "degree", "long_name": long_name}),
            height_phase_difference_stderr=(w, difference_se, {
                "units": "degree", "long_name": "standard error of " + long_name}))
    return spec.assign_coords(
        frequency=("omega", fr, {"units": "Hz", "long_name": "modulation frequency"})).assign(
        nominal_amplitude=(w, a["nominal"], {"units": "m",
                                             "long_name": "nominal drive amplitude"}),
        phase_lag=(("omega",), lags, {"units": "degree",
                                      "long_name": "instrument phase lag subtracted"}),
        height_amplitude=(w, a["height"], {
            "units": "m", "long_name": "first-harmonic amplitude of the height channel",
            "height_channel": str(dem.attrs.get("height_channel", "height"))}),
        lockin_periods=(w, a["periods"].astype(np.int32),
                        {"units": "1", "long_name": "whole periods demodulated"}),
        lockin_samples=(w, a["n"].astype(np.int32),
                        {"units": "1", "long_name": "samples in the lock-in window"}),
        lockin_settle=(w, a["settle"], {"units": "s",
                                        "long_name": "time skipped at the segment start"}))
