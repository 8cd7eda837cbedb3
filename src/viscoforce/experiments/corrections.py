"""Instrument corrections of a modulation spectrum: phase lag, phase reference and drag.

k* ← k*·e^{−iλ} − iωB with λ [degree] the instrument lag (given as ``phase_lag``, or the median
phase per frequency of a hard-surface ``phase_reference``) and B [N·s/m] a hydrodynamic
``drag``; the ``quality`` flags and their comment are made again after a correction.

:func:`correct_spectrum` applies them to a spectrum already made;
:func:`viscoforce.experiments.modulation.modulation_spectrum` uses the same helpers. What is in the
phase, the phase reference and the quality flags are told in
:mod:`viscoforce.experiments.modulation`, which re-exports :func:`correct_spectrum`.

The error of k* is that of the measurement: the lag turns it with k*, the drag leaves it where it
is, so after the drag the radial and tangential errors (``stiffness_stderr``, |k*|·
``phase_stderr``) are those of the old error ellipse seen along the new k*, turned by
Δ = arg(k*·e^{−iλ}) − arg(k*_new): σ_r'² = c²σ_r² + s²σ_t² − 2cs·C, σ_t'² = s²σ_r² + c²σ_t² + 2cs·C
and C' = cs(σ_r² − σ_t²) + (c² − s²)·C (c = cos Δ, s = sin Δ, C = ρσ_rσ_t the covariance,
0 unless the spectrum carries ``stiffness_phase_correlation`` ρ). The new ρ' is written as
``stiffness_phase_correlation``, which :func:`viscoforce.experiments.moduli.add_complex_modulus`
uses for E′ and E″. For equal radial and tangential errors (the lock-in's circular noise of the
JPK path) nothing turns: ρ' = 0 and the tangential error is kept, as there.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from viscoforce._limits import DRAG_RANGE
from viscoforce._validation import require_plausible
from viscoforce.exceptions import DataWarning, ParameterError
from viscoforce.io.quality import SENSOR_CHANNELS, phase_basis, quality_notes, spectrum_quality
from viscoforce.schema import QUALITY_FLAGS, validate_spectrum

__all__ = ["CORRELATION", "MAX_PHASE_LAG", "correct_spectrum"]

#: The variable holding the correlation of the radial and tangential errors of k*.
CORRELATION = "stiffness_phase_correlation"


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


def _turned_errors(ds: xr.Dataset, out: xr.Dataset, k_turned: np.ndarray, k_new: np.ndarray,
                   dims: tuple) -> xr.Dataset:
    """``out`` with the radial and tangential errors of k* seen along ``k_new`` (module text).

    ``k_turned`` is k*·e^{−iλ} (the lag turns the error with k*), ``k_new`` after the drag. A
    pair ``stiffness_stderr``/``phase_stderr`` is turned with its correlation, the ``_white``
    pair as uncorrelated (it has none of its own); a lone ``phase_stderr`` keeps its tangential
    error (a DataWarning says the radial one is missing).
    """
    turned = not np.array_equal(k_turned, k_new, equal_nan=True)  # a drag was subtracted
    delta = np.angle(k_turned / k_new) if turned else np.zeros(k_new.shape)
    c, s = np.cos(delta), np.sin(delta)
    size = np.abs(k_new)
    for suffix in ("", "_white"):
        radial, tangential = f"stiffness_stderr{suffix}", f"phase_stderr{suffix}"
        if tangential not in ds.variables:
            continue
        t_err = np.radians(ds[tangential].broadcast_like(ds["stiffness"]).transpose(
            *dims).values) * np.abs(k_turned)
        if radial not in ds.variables:
            if turned:
                warnings.warn(f"{tangential} is turned by the drag without {radial}: its "
                              "tangential error is kept, which holds only for errors equal "
                              "in all directions", DataWarning, stacklevel=3)
            out[tangential] = (dims, np.degrees(t_err / size), ds[tangential].attrs)
            continue
        r_err = ds[radial].broadcast_like(ds["stiffness"]).transpose(*dims).values
        rho = (ds[CORRELATION].broadcast_like(ds["stiffness"]).transpose(*dims).values
               if suffix == "" and CORRELATION in ds.variables else 0.0)
        cov = rho * r_err * t_err
        var_r = c**2 * r_err**2 + s**2 * t_err**2 - 2 * c * s * cov
        var_t = s**2 * r_err**2 + c**2 * t_err**2 + 2 * c * s * cov
        out[radial] = (dims, np.sqrt(var_r), ds[radial].attrs)
        out[tangential] = (dims, np.degrees(np.sqrt(var_t) / size), ds[tangential].attrs)
        if suffix == "" and (turned or CORRELATION in ds.variables):
            with np.errstate(divide="ignore", invalid="ignore"):
                corr = (c * s * (r_err**2 - t_err**2) + (c**2 - s**2) * cov) / np.sqrt(
                    var_r * var_t)
            out[CORRELATION] = (dims, np.where(np.isfinite(corr), corr, 0.0), {
                "units": "1", "long_name": "correlation of the stiffness and phase errors",
                "comment": "of the radial and tangential errors of k*, turned by the drag "
                           "subtracted (viscoforce.experiments.corrections)"})
    return out


#: Variables computed from an uncorrected k* that :func:`correct_spectrum` cannot update.
_DERIVED = ("E_storage", "E_loss", "G_storage", "G_loss")


def correct_spectrum(spectrum: xr.Dataset, *,
                     phase_lag: float | Mapping[float, float] | None = None,
                     drag: float | None = None,
                     phase_reference: xr.Dataset | None = None) -> xr.Dataset:
    """The instrument corrections of :func:`modulation_spectrum`, on a spectrum already made.

    For a spectrum CSV (:func:`viscoforce.io.csv_formats.read_spectrum_csv`) or a netCDF that
    ``load`` wrote: k* ← k*·e^{−iλ} − iωB as in :mod:`viscoforce.experiments.modulation`, then
    the ``quality`` flags, their comment and the attrs are made again by the functions the JPK
    path uses, so a spectrum gets the same flags whichever reader made it.

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
        (where present) corrected; ``stiffness_stderr`` and ``phase_stderr`` (and their
        ``_white`` pair) the radial and tangential errors along the new k* with their
        correlation ``stiffness_phase_correlation`` (module docstring); ``phase_lag``
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
    out = _turned_errors(ds, out, k_old * np.exp(-1j * np.radians(lags)), k_new, dims)
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
