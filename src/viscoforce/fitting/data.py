"""What a fit sees: x, y and weights (:class:`FitData`) of one spectrum or pixel.

A spectrum's points flagged in ``quality`` and those with a NaN stiffness or phase are left out
(with a note); the complex weights 1/σ_re + i/σ_im come from ``stiffness_stderr`` and
``phase_stderr`` (or 1/|k*|, relative): :mod:`viscoforce.fitting.fit` says what each weighting
means for the statistics.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import DataWarning, ModelValidityError, ParameterError
from viscoforce.schema import index_values, validate_spectrum

#: Spectrum weightings (``weights=``): the data's stderr or relative 1/|k*| (None: stderr when
#: the data have them, else relative with a DataWarning).
WEIGHTINGS = ("stderr", "relative")


@dataclass(frozen=True)
class FitData:
    """What a fit sees: x (ω [rad/s] or t [s]), y (k* [N/m] or F [N]) and weights.

    ``weighting`` is ``"stderr"`` (weights = 1/σ of the data: χ² is absolute), ``"relative"``
    or ``"unweighted"`` (χ² up to an unknown scale); ``notes`` say what was done to the data
    (points left out, fallbacks), each a sentence a DataWarning or a map's message can carry.
    """

    x: np.ndarray
    y: np.ndarray
    weights: np.ndarray | None
    source: Mapping[str, Any]
    weighting: str = "unweighted"
    notes: tuple[str, ...] = ()
    #: Degrees of freedom of each point's stderr where they were estimated from few values
    #: (lock-in: 2 × the residual-spectrum bins); None: taken as exact.
    sigma_dof: np.ndarray | None = None

    @property
    def sigma_known(self) -> bool:
        """Whether the weights are the data's own 1/σ (χ² absolute)."""
        return self.weighting == "stderr"

    @property
    def n_values(self) -> int:
        """Real numbers fitted (2 per complex point)."""
        return self.y.size * (2 if np.iscomplexobj(self.y) else 1)


def spectrum_data(ds: xr.Dataset, *, weights: str | None = None) -> FitData:
    """ω, k* and weights of one spectrum (1-D over ``omega``), flagged and NaN points left out.

    Parameters
    ----------
    ds : xarray.Dataset
        One spectrum (:mod:`viscoforce.schema.spectrum`) over ``omega`` only.
    weights : {"stderr", "relative"}, optional
        The residual weights (module docstring); None: the data's stderr where present, else
        relative. The notes of :func:`pixel_fit_data` (points left out, fallbacks) are issued
        as DataWarnings.

    Returns
    -------
    FitData
        ω [rad/s], k* [N/m], complex weights 1/σ_re + i/σ_im, provenance, weighting, notes.

    Raises
    ------
    ParameterError
        Extra dims, negative stiffness on a point not flagged, no point left, ``weights="stderr"``
        on data without stderr.
    """
    validate_spectrum(ds, require=("stiffness", "phase"))
    extra = [d for d in ds.variables["stiffness"].dims if d != "omega"]
    if extra:
        raise ParameterError(f"one spectrum is over 'omega' only; this one also has {extra} "
                             "(fit it as a map, or select one)")
    arrays = spectrum_arrays(ds, ())
    source = {"data_kind": "spectrum"}
    if "source" in ds.attrs:
        source["data_source"] = str(ds.attrs["source"])
    data = pixel_fit_data(np.asarray(index_values(ds, "omega"), dtype=float),
                          {k: v[0] for k, v in arrays.items()}, source, weights=weights)
    for note in data.notes:
        warnings.warn(note, DataWarning, stacklevel=3)
    return data


def spectrum_arrays(ds: xr.Dataset, dims: tuple[str, ...]) -> dict[str, np.ndarray]:
    """The spectrum's variables as (pixel, omega) arrays (pixels in C order over ``dims``).

    Keys: ``stiffness``, ``phase`` [rad], ``stiffness_stderr``, ``phase_stderr`` [rad] (NaN when
    absent), ``quality`` (0 when absent), ``mean_indentation`` (NaN when absent),
    ``stderr_bins`` (the lock-in's ``lockin_stderr_bins``; 0 when absent: exact stderr).
    """
    order = (*dims, "omega")
    n_omega = ds.sizes["omega"]
    n_pixels = math.prod(ds.sizes[d] for d in dims)
    shape = tuple(ds.sizes[d] for d in order)

    def grab(name: str, fill: float) -> np.ndarray:
        if name not in ds.variables:
            return np.full((n_pixels, n_omega), fill)
        da = ds.variables[name]  # scalar, per pixel, per frequency or per point: broadcast
        if da.dims == order:
            values = np.asarray(da.values, dtype=float).reshape(n_pixels, n_omega)
            values.flags.writeable = False  # a view of the dataset's data, like broadcast_to's
            return values
        wanted = tuple(d for d in order if d in da.dims)
        values = np.asarray((da if da.dims == wanted else da.transpose(*wanted)).values,
                            dtype=float)
        index = tuple(slice(None) if d in da.dims else None for d in order)
        return np.broadcast_to(values[index], shape).reshape(n_pixels, n_omega)

    out = {"stiffness": grab("stiffness", np.nan), "phase": np.radians(grab("phase", np.nan)),
           "stiffness_stderr": grab("stiffness_stderr", np.nan),
           "phase_stderr": np.radians(grab("phase_stderr", np.nan)),
           "quality": grab("quality", 0.0), "mean_indentation": grab("mean_indentation", np.nan),
           "stderr_bins": grab("lockin_stderr_bins", 0.0)}
    return out


def pixel_fit_data(omega: np.ndarray, a: Mapping[str, np.ndarray],
                   source: Mapping[str, Any], *, weights: str | None = None) -> FitData:
    """FitData of one pixel's arrays (see :func:`spectrum_arrays`), with the checks of one spectrum.

    Points flagged in ``quality`` and points whose stiffness or phase is NaN/inf are left out
    (the latter with a note). ``weights`` as in :func:`spectrum_data`; what was done is in the
    result's ``notes`` (no warning here: maps carry the notes per pixel).
    """
    if weights is not None and weights not in WEIGHTINGS:
        raise ParameterError(f"weights must be one of {', '.join(WEIGHTINGS)} or None, got "
                             f"{weights!r}")
    stiffness, phase = a["stiffness"], a["phase"]
    keep = a["quality"] == 0
    if not keep.any():
        raise ParameterError(f"every one of the {omega.size} spectrum points is flagged in "
                             "'quality' (see its comment): nothing to fit; correct the phase "
                             "lag (load --phase-lag) or inspect the data")
    notes: list[str] = []
    bad = keep & ~(np.isfinite(stiffness) & np.isfinite(phase))
    if bad.any():
        shown = ", ".join(f"{w:.4g}" for w in omega[bad])
        notes.append(f"stiffness or phase is NaN/inf at omega = {shown} rad/s: "
                     f"{int(bad.sum())} point(s) left out of the fit")
        keep = keep & ~bad
        if not keep.any():
            raise ParameterError("no spectrum point is left to fit: every unflagged point has "
                                 "a NaN/inf stiffness or phase")
    negative = keep & (stiffness <= 0)
    if negative.any():
        i = int(np.flatnonzero(negative)[0])
        raise ParameterError(f"stiffness must be > 0 N/m, got {stiffness[i]!r} at omega = "
                             f"{omega[i]:.4g} rad/s (point {i})")
    # left-out points may be NaN, inf or huge: their k* and weights are dropped
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        k = stiffness * np.exp(1j * phase)
        w, weighting, note = _spectrum_weights(omega, k, stiffness, phase, a, keep, weights)
    notes.extend(note)
    info = _data_info(source, keep, a["mean_indentation"])
    bins = a.get("stderr_bins")
    sigma_dof = (_stderr_dof(np.asarray(bins, dtype=float)[keep])
                 if weighting == "stderr" and bins is not None else None)
    return FitData(omega[keep], k[keep], w[keep], info, weighting, tuple(notes), sigma_dof)


def _data_info(source: Mapping[str, Any], keep: np.ndarray, depth: np.ndarray
               ) -> dict[str, Any]:
    """A pixel's FitData.source: provenance, points kept and flagged, median depth if any."""
    n = int(keep.sum())
    info = {**source, "data_points": n, "data_flagged": keep.size - n}
    kept = depth[keep]
    if np.isfinite(kept).any():
        info["mean_indentation"] = float(np.nanmedian(kept))
    return info


def _stderr_dof(bins: np.ndarray) -> np.ndarray | None:
    """Degrees of freedom of the kept points' stderr: 2 × the lock-in's bins (None: exact)."""
    return np.where(bins > 0, 2.0 * bins, np.inf) if np.any(bins > 0) else None


def clean_pixels_fit_data(omega: np.ndarray, arrays: Mapping[str, np.ndarray],
                          source: Mapping[str, Any]) -> list[FitData | None]:
    """FitData of every pixel of a map that needs no note, computed over all pixels at once.

    The pixels of :func:`pixel_fit_data` (``weights=None``) whose spectrum is as expected: some
    point unflagged, no NaN/inf stiffness or phase and no stiffness ≤ 0 among the unflagged, a
    usable stderr at each of them. Their FitData hold the same values, from the same elementwise
    operations on the (pixel, ω) arrays (``tests/fitting/test_fitting.py`` compares them bit for bit);
    every other pixel is None, for :func:`pixel_fit_data` to describe or refuse. One NumPy call
    per operation for the map instead of one per pixel: a 4096-pixel map's preparation took
    0.17 s, serial beside the fits (issue 22 item 3).

    Parameters
    ----------
    omega : numpy.ndarray
        The map's ω [rad/s].
    arrays : mapping
        The map's (pixel, ω) arrays (:func:`spectrum_arrays`).
    source : mapping
        Provenance each FitData carries.

    Returns
    -------
    list
        Per pixel its FitData, or None.
    """
    stiffness, phase = arrays["stiffness"], arrays["phase"]
    keep = arrays["quality"] == 0
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        # as pixel_fit_data and _spectrum_weights, elementwise
        k = stiffness * np.exp(1j * phase)
        sig_re, sig_im, usable = _stderr_parts(stiffness, phase, arrays["stiffness_stderr"],
                                               arrays["phase_stderr"])
        w = 1.0 / sig_re + 1j / sig_im
        fine = np.isfinite(stiffness) & np.isfinite(phase) & (stiffness > 0) & usable
    clean = keep.any(axis=1) & ~(keep & ~fine).any(axis=1)
    depth, bins = arrays["mean_indentation"], arrays.get("stderr_bins")
    out: list[FitData | None] = []
    for i in range(keep.shape[0]):
        if not clean[i]:
            out.append(None)
            continue
        row = keep[i]
        sigma_dof = None if bins is None else _stderr_dof(bins[i][row])
        out.append(FitData(omega[row], k[i][row], w[i][row], _data_info(source, row, depth[i]),
                           "stderr", (), sigma_dof))
    return out


def _stderr_parts(stiffness: np.ndarray, phase: np.ndarray, s_err: np.ndarray,
                  p_err: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """σ of Re k* and Im k* from the stderr of |k*| and χ, and where both are usable (> 0, finite).

    A missing stderr of one (NaN) is taken from the other's relative size. Elementwise: one
    point, one pixel or a whole map alike.
    """
    p_err = np.where(np.isfinite(p_err), p_err, s_err / stiffness)
    s_err = np.where(np.isfinite(s_err), s_err, p_err * stiffness)
    c, s = np.cos(phase), np.sin(phase)
    sig_re = np.sqrt((c * s_err) ** 2 + (stiffness * s * p_err) ** 2)
    sig_im = np.sqrt((s * s_err) ** 2 + (stiffness * c * p_err) ** 2)
    usable = np.isfinite(sig_re) & np.isfinite(sig_im) & (sig_re > 0) & (sig_im > 0)
    return sig_re, sig_im, usable


def _spectrum_weights(omega: np.ndarray, k: np.ndarray, stiffness: np.ndarray,
                      phase: np.ndarray, a: Mapping[str, np.ndarray], keep: np.ndarray,
                      weights: str | None) -> tuple[np.ndarray, str, list[str]]:
    """Complex weights 1/σ_re + i/σ_im, the weighting and the notes (module docstring)."""
    relative = (1.0 + 1j) / np.abs(k)
    if weights == "relative":
        return relative, "relative", []
    s_err, p_err = a["stiffness_stderr"], a["phase_stderr"]
    given = np.isfinite(s_err) | np.isfinite(p_err)
    if not given[keep].any():
        if weights == "stderr":
            raise ParameterError("weights='stderr' needs stiffness_stderr or phase_stderr in "
                                 "the data; these have none (use weights='relative')")
        return relative, "relative", [
            "the spectrum has no stiffness_stderr/phase_stderr: the fit weights every point by "
            "1/|k*| (relative), scales the covariance by the reduced chi-square and gives no "
            "p-value (pass weights='relative', --weights relative, to choose this)"]
    with np.errstate(invalid="ignore"):
        sig_re, sig_im, usable = _stderr_parts(stiffness, phase, s_err, p_err)
    notes = []
    missing = keep & ~usable
    if not (keep & usable).any():
        if weights == "stderr":
            raise ParameterError("weights='stderr': every stderr of the points fitted is "
                                 "missing or zero")
        return relative, "relative", [
            "every stderr of the points fitted is missing or zero: the fit weights every point "
            "by 1/|k*| (relative), scales the covariance by the reduced chi-square and gives "
            "no p-value"]
    if missing.any():
        ok = keep & usable
        rel_re = float(np.median(sig_re[ok] / np.abs(k[ok])))
        rel_im = float(np.median(sig_im[ok] / np.abs(k[ok])))
        sig_re = np.where(missing, rel_re * np.abs(k), sig_re)
        sig_im = np.where(missing, rel_im * np.abs(k), sig_im)
        shown = ", ".join(f"{w:.4g}" for w in omega[missing])
        notes.append(f"stderr missing or zero at omega = {shown} rad/s: those points are "
                     f"weighted by the median relative error of the others ({rel_re:.3g}, "
                     f"{rel_im:.3g} of |k*| in the real and imaginary parts)")
    with np.errstate(divide="ignore"):
        return 1.0 / sig_re + 1j / sig_im, "stderr", notes


def _data_indentation(spectrum: xr.Dataset, data: FitData | None = None) -> float:
    """The operating indentation δ0: the median ``mean_indentation`` of the points fitted.

    The same rule as a map's pixels (:func:`pixel_fit_data`), so a spectrum fitted alone and as
    a one-pixel map uses the same δ0.
    """
    if "mean_indentation" not in spectrum.variables:
        raise ModelValidityError(
            "the contact model needs the operating indentation: this spectrum has no "
            "mean_indentation (no contact point found, or pre-contact); give --indentation D0")
    value = (float(data.source["mean_indentation"]) if data is not None
             and "mean_indentation" in data.source else math.nan)
    if not math.isfinite(value):
        value = float(np.nanmedian(spectrum["mean_indentation"].values))
    if not value > 0:
        raise ModelValidityError(
            f"the contact model refuses a pre-contact spectrum: median mean_indentation "
            f"{value!r} m is not > 0 (use --model svda or exact, or give --indentation D0)")
    return value
