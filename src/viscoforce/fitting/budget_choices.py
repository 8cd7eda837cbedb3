"""The data of a fit made again with a choice the data may not settle made the other way.

The error budget (:mod:`viscoforce.fitting.budget`) carries, beside the calibration sources, the
shift of each parameter when a choice is made otherwise. This module makes the other choice's
data; the refit and the comparison are the caller's (the CLI's ``fit``):

- the **fit window** (:func:`narrowed_window`): the fitted window's last quarter left out — for a
  spectrum the top quarter of its log-frequency span (where the sensor's lag and the drag
  matter most), for a force curve the last quarter in time of the samples fitted (in contact,
  where the fit has a contact point: the end of a retract; the tail of a hold). The Hertz fit's
  depth range is its own depth check's (E refitted up to 50 % of the maximum contact force:
  :func:`depth_range_alternative`);
- the **contact point method** (:func:`other_contact_point`): the contact point a fit leaves
  free, found instead from the approach's rise above its baseline noise
  (:func:`viscoforce.experiments.contact_point.find_contact_point`, the power law of the tip's
  shape), to be held fixed in the refit.
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from viscoforce.fitting.segments import segment_runs

__all__ = ["WINDOW_KEEP", "depth_range_alternative", "narrowed_window", "other_contact_point"]

#: The share of the fitted window kept by the narrower window (its first three quarters).
WINDOW_KEEP = 0.75
#: The power of the indentation in the force of each tip shape (the contact-rise search).
_RISE_EXPONENT = {"sphere": 1.5, "paraboloid": 1.5, "cone": 2.0, "pyramid": 2.0, "flat": 1.0}


def narrowed_window(data: xr.Dataset, result: xr.Dataset, kind: str
                    ) -> tuple[xr.Dataset, str] | None:
    """The data with the fitted window's last quarter left out, and what that window is.

    Parameters
    ----------
    data : xarray.Dataset
        What was fitted: a spectrum (over ``omega``) or a one-curve curves dataset.
    result : xarray.Dataset
        The fit (its ``data_points``, ``segment_start`` and free parameters).
    kind : {"spectrum", "curves"}
        The data's kind.

    Returns
    -------
    (xarray.Dataset, str) or None
        The narrower data and a sentence; None where it would leave fewer than twice as many
        points as the fit has free parameters (or the window is not found).
    """
    n_free = len(result["param_i"]) if "param_i" in result else 4  # the fit's parameters
    if kind == "spectrum" and "omega" in data.dims:
        omega = np.asarray(data["omega"].values, dtype=float)
        ok = omega > 0
        if ok.sum() < 2:
            return None
        lw = np.log(omega[ok])
        top = math.exp(lw.min() + WINDOW_KEEP * (lw.max() - lw.min()))
        keep = omega <= top * (1 + 1e-9)
        if int(keep.sum()) < max(2 * n_free, 4) or keep.all():
            return None
        return data.isel(omega=np.flatnonzero(keep)), (
            f"fit window: refitted up to {top / (2 * math.pi):.3g} Hz (the top quarter of the "
            "log-frequency span left out)")
    if kind != "curves" or "sample" not in data.dims or data.sizes.get("curve", 1) != 1:
        return None
    region = _fitted_region(data, result)
    if region is None:
        return None
    start, stop = region
    time = np.asarray(data["time"].values, dtype=float)
    if "contact_point" in result and "tip_position" in data:  # the window in contact
        z = np.asarray(data["tip_position"].values[start:stop], dtype=float)
        inside = np.flatnonzero(z >= float(result["contact_point"]))
        if inside.size < 8:
            return None
        start = start + int(inside[0])
    t0, t1 = time[start], time[stop - 1]
    cut = t0 + WINDOW_KEEP * (t1 - t0)
    drop = np.zeros(time.size, dtype=bool)
    drop[start:stop] = time[start:stop] > cut
    if int((~drop[start:stop]).sum()) < max(2 * n_free, 8) or not drop.any():
        return None
    out = data.copy()
    for name in ("force", "tip_position"):
        if name in out:
            values = np.asarray(out[name].values, dtype=float).copy()
            values[drop] = np.nan
            out[name] = out[name].copy(data=values)
    what = "in contact" if "contact_point" in result else "fitted"
    return out, (f"refitted without the last quarter in time of the samples {what} "
                 f"(kept {t0:.4g} s to {cut:.4g} s of {t1:.4g} s)")


def _fitted_region(data: xr.Dataset, result: xr.Dataset) -> tuple[int, int] | None:
    """(start, stop) sample indices of the segment runs a curve fit used."""
    if "segment_start" not in result.attrs or "data_points" not in result.attrs:
        return None
    time = np.asarray(data["time"].values, dtype=float)
    found = np.flatnonzero(np.isclose(time, float(result.attrs["segment_start"]), rtol=0,
                                      atol=1e-12 + 1e-9 * float(np.nanmax(np.abs(time)))))
    if not found.size:
        return None
    start = int(found[0])
    last = min(start + int(result.attrs["data_points"]) - 1, time.size - 1)
    stop = next((b for a, b, _ in segment_runs(data) if a <= last < b), time.size)
    return (start, stop) if stop - start >= 8 else None


def other_contact_point(data: xr.Dataset, result: xr.Dataset) -> tuple[float, str] | None:
    """The contact point [m] of the approach's rise above its noise, and how it was found.

    For a fit that leaves the contact point free (``contact_point`` among its parameters). None
    where the approach has no detectable rise or the fit has no free contact point.
    """
    from viscoforce.experiments.contact_point import find_contact_point

    names = [str(n) for n in result["param_i"].values] if "param_i" in result else []
    if "contact_point" not in names or data.sizes.get("curve", 1) != 1 or "sample" not in (
            data.dims):
        return None
    runs = [r for r in segment_runs(data) if r[2] == "approach"]
    if not runs:
        return None
    a, b, _ = runs[0]
    z = np.asarray(data["tip_position"].values[a:b], dtype=float)
    f = np.asarray(data["force"].values[a:b], dtype=float)
    ok = np.isfinite(z) & np.isfinite(f)
    shape = str(result.attrs.get("tip_shape", "paraboloid"))
    exponent = _RISE_EXPONENT.get(shape, 1.5)
    found = find_contact_point(z[ok], f[ok], exponent=exponent)
    if found is None:
        return None
    zc = float(found["z_contact"])
    return zc, (f"held at {zc:.4g} m, the approach's rise above 5 sigma of "
                f"its baseline noise with a power {exponent:g} law, instead of fitted "
                f"({float(result['contact_point']):.4g} m)")


def depth_range_alternative(result: xr.Dataset) -> tuple[xr.Dataset, str] | None:
    """The Hertz fit as its depth check found it on the shallower half of the force, and why.

    The depth check (:mod:`viscoforce.fitting.hertz_checks`) refits E up to 50 % of the maximum
    contact force; the moduli derived from E scale with it. None without a depth check.
    """
    shallow = result.attrs.get("depth_check_E")
    if shallow is None or "E" not in result or not math.isfinite(float(shallow)):
        return None
    ratio = float(shallow) / float(result["E"]) if float(result["E"]) else math.nan
    if not math.isfinite(ratio):
        return None
    other = result.copy()
    for name in [str(n) for n in result.data_vars]:
        if name == "E" or (name.startswith("E_") and name.endswith(("_young", "_shear"))
                           and name.count("_") == 1):
            other[name] = result[name] * ratio
    return other, ("the depth range: E refitted up to 50 % of the maximum contact "
                   f"force ({float(shallow):.4g} Pa against {float(result['E']):.4g} Pa)")
