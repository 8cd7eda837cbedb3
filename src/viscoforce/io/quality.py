"""Quality flags and notes of a measured spectrum: one rule for every reader (CSV, JPK lock-in).

:func:`spectrum_quality` flags points a passive viscoelastic sample cannot give (phase outside
(0°, 90°), evaluated on the phase as stored, i.e. after whatever instrument correction was
applied) and points whose stiffness is not above its noise; :func:`quality_notes` writes the
``quality`` comment (what was corrected, what the phase refers to — :func:`phase_basis` — and
what can remain, :data:`PHASE_REMAINS`) and the ``quality_summary`` attr. The spectrum CSV reader
(:mod:`viscoforce.io.csv_formats`) and the lock-in of modulation segments
(:mod:`viscoforce.experiments.modulation`) both call them, so the same values get the same flags.

Placement: pure NumPy on top of :mod:`viscoforce.schema` (no pandas), so that
:mod:`viscoforce.experiments` may import it under the "pandas only in io" contract; it belongs
beside :func:`viscoforce.schema.phase_quality` and can move there.

:data:`PHYSICAL_RANGES` bounds every measured quantity the readers convert to SI (a value beyond
them is no measurement: a wrong unit in a header or a damaged file, and its square overflows
downstream); :func:`first_beyond` finds the first such value and :func:`range_text` states the
range in the readers' refusals. At the other end, :data:`SMALLEST_SCALES` bounds the largest
magnitude of a measured column (a force curve scaled by 1e-300 is no measurement either, and it
underflows downstream; :func:`below_scale`, :func:`scale_text`), and :data:`MIN_TIME_STEP` the
sample interval of a time series.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._limits import MIN_TIME_STEP
from viscoforce.exceptions import ParameterError
from viscoforce.schema import QUALITY_FLAGS, phase_quality

__all__ = ["LOW_SIGNAL_RATIO", "MIN_TIME_STEP", "PHASE_REMAINS", "PHYSICAL_RANGES",
           "PIEZO_CHANNELS", "SENSOR_CHANNELS", "SMALLEST_SCALES", "below_scale", "check_measured",
           "first_beyond",
           "phase_basis", "quality_notes", "range_text", "scale_text", "spectrum_quality"]

_METRE = (-1.0, 1.0, "m")  # no piezo, stage or cantilever moves a metre
#: Physical range ``(lowest, highest, SI unit)`` of each measured quantity, by its column or
#: channel name. Readers refuse a value beyond it naming the column (channel), the row (sample)
#: and this range; a lowest bound of 0 means "> 0" (checked by each reader with its own message).
#: The bounds are far beyond any AFM, colloid-probe or surface-force measurement and far below
#: where the fits' squares overflow (1e308 is refused, not carried to an inf downstream).
PHYSICAL_RANGES: dict[str, tuple[float, float, str]] = {
    "frequency": (0.0, 1e9, "Hz"),  # no mechanical drive of a probe reaches 1 GHz
    "omega": (0.0, 2e9 * math.pi, "rad/s"),
    "stiffness": (0.0, 1e10, "N/m"),  # E*L of a 5 cm steel cube; AFM and SFA contacts < 1e8 N/m
    "phase": (-360.0, 360.0, "deg"),
    "amplitude": (0.0, 1e12, "1"),  # |F1| / mean force; the stiffness it gives is bounded too
    "force_amplitude": (0.0, 1e3, "N"),  # a kilonewton: beyond any AFM or SFA load
    "mean_force": (-1e3, 1e3, "N"),
    "force": (-1e3, 1e3, "N"),
    "drive_amplitude": (0.0, 1.0, "m"),
    "mean_indentation": _METRE, "height": _METRE, "position": _METRE, "z": _METRE,
    "deflection": _METRE, "vDeflection": _METRE, "tip_position": _METRE, "x": _METRE,
    "y": _METRE,
    "time": (-1e10, 1e10, "s"),  # 300 years: absolute (Unix) time stamps fit too
    "modulus": (0.0, 1e13, "Pa"),  # diamond's Young modulus is 1.2e12 Pa
    "tau": (0.0, 1e10, "s"),
    "spring_constant": (0.0, 1e3, "N/m"),  # the stiffest cantilevers are ~1e2 N/m
    "sensitivity": (0.0, 1e-3, "m/V"),  # deflection sensitivities are 1e-8 to 1e-6 m/V
}


#: Smallest magnitude the LARGEST value of a measured column or channel may have, by name (SI,
#: the unit of :data:`PHYSICAL_RANGES`): below it the whole column is no measurement — a wrong
#: unit in a header, or values scaled by 1e-300 — and what is computed from it underflows (a
#: subnormal force curve gives a fit bounds closer than double precision tells apart). Each is
#: far below any instrument's resolution. A column of zeros is left to each reader's own checks.
SMALLEST_SCALES: dict[str, float] = {
    "force": 1e-15,  # a femtonewton: below the thermal noise of optical tweezers
    "force_amplitude": 1e-15,
    "height": 1e-12, "position": 1e-12, "z": 1e-12,  # a picometre: no ramp is that short
    "deflection": 1e-13, "vDeflection": 1e-13, "drive_amplitude": 1e-13,
    "time": 1e-9,  # a curve shorter than a nanosecond
    "stiffness": 1e-12,  # far below the softest optical trap (1e-7 N/m)
    "frequency": 1e-6, "omega": 2e-6 * math.pi,  # a period of 12 days
}


def _largest_magnitude(v: np.ndarray) -> float:
    """The largest |v| ignoring NaN (NaN if none), by two reductions: no temporary array."""
    if v.size == 0:
        return math.nan
    return float(np.fmax(abs(np.fmax.reduce(v)), abs(np.fmin.reduce(v))))


def below_scale(name: str, values: ArrayLike) -> tuple[int, float] | None:
    """(flat index, value) of the largest magnitude when it is nonzero and below ``name``'s scale.

    None when ``name`` has no entry in :data:`SMALLEST_SCALES`, when every value is zero or NaN,
    or when the largest magnitude reaches the scale.
    """
    floor = SMALLEST_SCALES.get(name)
    if floor is None:
        return None
    v = np.asarray(values, dtype=float).ravel()
    if not 0 < _largest_magnitude(v) < floor:  # also NaN: nothing measured to judge
        return None
    i = int(np.nanargmax(np.abs(v)))
    return i, float(v[i])


def scale_text(name: str) -> str:
    """The smallest scale of ``name`` (a key of :data:`SMALLEST_SCALES`) for a refusal.

    E.g. ``"the smallest scale of a measured force, 1e-15 N (far below any instrument's
    resolution)"``.
    """
    return (f"the smallest scale of a measured {name}, {SMALLEST_SCALES[name]:g} "
            f"{PHYSICAL_RANGES[name][2]} (far below any instrument's resolution)")


def check_measured(ds: Any, where: str) -> None:
    """Refuse a dataset whose measured variables leave :data:`PHYSICAL_RANGES` or their scale.

    Every data variable and coordinate named in :data:`PHYSICAL_RANGES` (and ``<name>_stderr``)
    is checked: no value beyond the range, and (:data:`SMALLEST_SCALES`) not every value tinier
    than any measurement. The boundary check of :func:`~viscoforce.io.instruments.
    load_instrument` after each reader's own (which name the column or channel), and the one a
    dataset read from elsewhere (a netCDF file) needs before it is fitted.

    Parameters
    ----------
    ds : xarray.Dataset
        A curves or spectrum dataset (SI).
    where : str
        What to name in the message (the file).

    Raises
    ------
    ParameterError
        Naming the variable, the value and the range.
    """
    for name in list(ds.data_vars) + list(ds.coords):
        base = str(name).removesuffix("_stderr")
        if base not in PHYSICAL_RANGES:
            continue
        values = np.asarray(ds[name].values)
        if values.dtype.kind not in "fiu":
            continue
        unit = PHYSICAL_RANGES[base][2]
        i = first_beyond(str(name), values)
        if i is not None:
            raise ParameterError(
                f"{where}: {name} holds {float(values.ravel()[i]):g} {unit} (entry {i}), beyond "
                f"the physical range {range_text(str(name))}; check its unit and the values")
        tiny = below_scale(str(name), values)
        if tiny is not None:
            raise ParameterError(
                f"{where}: {name} is at most {abs(tiny[1]):g} {unit} in magnitude (entry "
                f"{tiny[0]}), below {scale_text(str(name))}; check its unit and the values")


def _bounds(name: str) -> tuple[float, float, str]:
    base = name.removesuffix("_stderr")
    low, high, unit = PHYSICAL_RANGES[base]
    if base != name:  # a standard error: >= 0, at most the quantity's largest magnitude
        return 0.0, max(abs(low), abs(high)), unit
    return low, high, unit


def range_text(name: str) -> str:
    """The allowed range of ``name`` (a key of :data:`PHYSICAL_RANGES`, or ``<key>_stderr``).

    E.g. ``"0 < stiffness <= 1e+10 N/m"``, ``"-1000 <= force <= 1000 N"``.
    """
    low, high, unit = _bounds(name)
    opening = "<=" if low < 0 or name.endswith("_stderr") else "<"
    return f"{low:g} {opening} {name} <= {high:g} {unit}"


def first_beyond(name: str, values: ArrayLike) -> int | None:
    """Flat index of the first value whose magnitude exceeds the range of ``name``, else None.

    Only the magnitude is checked (``|value| <= max(|lowest|, highest)``; NaN passes, inf does
    not): signs and zeros are each reader's own checks, with their own messages.
    """
    low, high, _ = _bounds(name)
    limit = max(abs(low), abs(high))
    v = np.asarray(values, dtype=float).ravel()
    if not _largest_magnitude(v) > limit:  # the usual case, without a temporary array
        return None
    with np.errstate(invalid="ignore"):
        bad = np.abs(v) > limit
    hits = np.flatnonzero(bad)
    return int(hits[0]) if hits.size else None

#: Least signal-to-noise of the stiffness: ``low_signal`` where stiffness < this × its stderr.
LOW_SIGNAL_RATIO = 3.0
#: Most frequencies listed per flag in ``quality_summary`` (the rest are counted).
SUMMARY_FREQUENCIES = 20
#: Height channels that are calibrated position sensors (JPK names; afmformats' "measured").
SENSOR_CHANNELS = ("strainGaugeHeight", "measuredHeight", "capacitiveSensorHeight",
                   "height (measured)")
#: Height channels that are the piezo's drive signal.
PIEZO_CHANNELS = ("height", "height (piezo)")
#: What no correction here removes (part of the ``quality`` comment).
PHASE_REMAINS = (
    "What can remain after these corrections: the height sensor's own bandwidth (a height that "
    "reads late raises the phase), the deflection detection chain (photodiode amplifier and "
    "anti-alias filters: a force that reads late lowers it) and the cantilever's inertia and "
    "hydrodynamics in the liquid (a base-driven beam adds a term in omega^2 and i*omega*B to "
    "k*). Measure them together on a hard surface with the same cantilever, liquid, drive and "
    "frequencies and give that spectrum as --phase-reference (or its median phases as "
    "--phase-lag FREQUENCY=DEGREES); give the drag at contact as --drag (extrapolated from "
    "spectra at several heights: viscoforce.experiments.drag.drag_from_heights).")


def spectrum_quality(phase: ArrayLike, stiffness: ArrayLike | None = None,
                     stiffness_stderr: ArrayLike | None = None) -> np.ndarray:
    """Quality codes of a measured spectrum, one per point (the same rule for every reader).

    Parameters
    ----------
    phase : array_like
        Phase [degree] as stored, i.e. after whatever instrument correction was applied.
    stiffness, stiffness_stderr : array_like, optional
        |k*| [N/m] and its standard error (broadcast against ``phase``); without both, no point
        is flagged ``low_signal``.

    Returns
    -------
    numpy.ndarray of int8
        1 (``phase_outside_passive_range``) where the phase is outside (0°, 90°)
        (:func:`viscoforce.schema.phase_quality`); else 2 (``low_signal``) where stiffness <
        :data:`LOW_SIGNAL_RATIO` × stiffness_stderr; else 0. NaN values are not flagged.
    """
    codes = phase_quality(phase)
    if stiffness is None or stiffness_stderr is None:
        return codes
    s, e = np.broadcast_arrays(np.asarray(stiffness, dtype=float),
                               np.asarray(stiffness_stderr, dtype=float))
    with np.errstate(invalid="ignore"):
        low = np.broadcast_to(s < LOW_SIGNAL_RATIO * e, codes.shape)
    return np.where((codes == 0) & low, 2, codes).astype(np.int8)


def phase_basis(height_channel: str | None) -> str:
    """``attrs["phase_reference"]``: which height signal the phase was measured against.

    Parameters
    ----------
    height_channel : str or None
        The height channel behind δ (``attrs["height_channel"]``); None when unknown (a
        spectrum CSV).

    Returns
    -------
    str
        For a calibrated sensor: the piezo's lag behind its drive is not in the phase (the sensor
        measures where the scanner is), so a sensor-vs-piezo lag must not be subtracted; for the
        piezo: that lag is in the phase; else: unknown.
    """
    if height_channel in SENSOR_CHANNELS:
        return (f"force against delta = -{height_channel} - deflection; {height_channel} is the "
                "calibrated height sensor, so the piezo's lag behind its drive signal is not in "
                "the phase (the sensor measures where the scanner is): do not subtract the "
                "sensor-vs-piezo lag as --phase-lag")
    if height_channel in PIEZO_CHANNELS:
        return (f"force against delta = -{height_channel} - deflection; {height_channel} is the "
                "piezo's drive signal (no height sensor), so the piezo's own lag behind it is in "
                "the phase")
    return ("the file does not say which height signal (sensor or piezo) the phase was measured "
            "against")


def quality_notes(quality: np.ndarray, phase: np.ndarray, frequency: np.ndarray, *,
                  corrections: str, basis: str) -> dict[str, str]:
    """CF comment of ``quality`` and the ``quality_summary`` attr (one wording for every reader).

    Parameters
    ----------
    quality : ndarray
        Codes of :func:`spectrum_quality`, ``omega`` last.
    phase : ndarray
        Phase [degree] as stored, broadcast to ``quality``.
    frequency : ndarray
        Frequency [Hz] per ``omega``.
    corrections : str
        What was corrected (the lags subtracted per frequency, the drag), or ``"none"``.
    basis : str
        :func:`phase_basis` of the spectrum.

    Returns
    -------
    dict
        ``comment`` (for ``quality``) and ``summary``: per flag, the frequencies with flagged
        points, how many, and their median phase (the first :data:`SUMMARY_FREQUENCIES`
        frequencies, then how many more).
    """
    comment = (
        "phase_outside_passive_range: the phase as stored, after the corrections "
        f"({corrections}), is outside (0, 90) degrees, which a passive viscoelastic sample "
        f"cannot give; the point is kept. Phase reference: {basis}. {PHASE_REMAINS} "
        f"low_signal: stiffness < {LOW_SIGNAL_RATIO:g} stiffness_stderr (the force response is "
        "not above the noise); large_residual: the lock-in residual is large (drift, "
        "nonlinearity or too few periods)")
    q = np.asarray(quality).reshape(-1, np.shape(quality)[-1])
    ph = np.broadcast_to(np.asarray(phase, dtype=float), np.shape(quality)).reshape(q.shape)
    parts = []
    freq = np.asarray(frequency)
    for code, name in QUALITY_FLAGS.items():
        if code == 0:
            continue
        flagged = np.flatnonzero((q == code).any(axis=0))  # frequencies with a flagged point
        hits = [f"{float(freq[j]):g} Hz ({int(m.sum())} of {m.size} points, median phase "
                f"{_median(ph[m, j]):.1f} deg)"
                for j in flagged[:SUMMARY_FREQUENCIES] if (m := q[:, j] == code).any()]
        if flagged.size > SUMMARY_FREQUENCIES:
            hits.append(f"and {flagged.size - SUMMARY_FREQUENCIES} more frequencies")
        if hits:
            parts.append(f"{name}: " + ", ".join(hits))
    return {"comment": comment, "summary": "; ".join(parts) or "no point flagged"}


def _median(values: np.ndarray) -> float:
    """Median of the finite values (NaN when there is none, without a warning)."""
    finite = values[np.isfinite(values)]
    return float(np.median(finite)) if finite.size else float("nan")
