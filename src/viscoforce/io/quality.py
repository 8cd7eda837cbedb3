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
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from viscoforce.schema import QUALITY_FLAGS, phase_quality

__all__ = ["LOW_SIGNAL_RATIO", "PHASE_REMAINS", "PIEZO_CHANNELS", "SENSOR_CHANNELS", "phase_basis",
           "quality_notes", "spectrum_quality"]

#: Least signal-to-noise of the stiffness: ``low_signal`` where stiffness < this × its stderr.
LOW_SIGNAL_RATIO = 3.0
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
        points, how many, and their median phase.
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
    for code, name in QUALITY_FLAGS.items():
        if code == 0:
            continue
        hits = [f"{float(f):g} Hz ({int(m.sum())} of {m.size} points, median phase "
                f"{_median(ph[m, j]):.1f} deg)"
                for j, f in enumerate(np.asarray(frequency)) if (m := q[:, j] == code).any()]
        if hits:
            parts.append(f"{name}: " + ", ".join(hits))
    return {"comment": comment, "summary": "; ".join(parts) or "no point flagged"}


def _median(values: np.ndarray) -> float:
    """Median of the finite values (NaN when there is none, without a warning)."""
    finite = values[np.isfinite(values)]
    return float(np.median(finite)) if finite.size else float("nan")
