"""A Hertz map's force curves for the viewer: each pixel's approach and its best fit, flat arrays.

A map of ``hertz`` fits holds each pixel's parameters (``E``, ``contact_point``, ``baseline``,
``baseline_slope``), not its curve; with the curves it was fitted to (``view FITS --data
MAP.jpk-force-map``) :func:`force_curves` cuts each pixel's approach the way the fit did
(:func:`viscoforce.fitting.curves.curve_data`) and evaluates the Hertz law there
(:func:`viscoforce.fitting.models.make_model`, its ``raw`` function) with the tip the fit
recorded (``tip_shape`` and ``tip_radius``/``tip_half_angle`` attrs, :meth:`Tip.from_attrs
<viscoforce.physics.tips.Tip.from_attrs>`) or the one given. Positions are shown from each
pixel's fitted contact point in µm, forces in nN, as :func:`viscoforce.plotting.fit_curve_plot`
draws a single fit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError, ViscoforceError
from viscoforce.schema import flat_over

__all__ = ["CURVE_MODELS", "force_curves", "is_curves"]

#: Map models whose pixels the viewer draws as force curves (the approach and its fit).
CURVE_MODELS = ("hertz",)
#: Display scales: µm of tip position, nN of force.
_UM, _NN = 1e6, 1e9


def is_curves(data: Any) -> bool:
    """Whether ``data`` is a curves dataset (force over ``sample``), not spectra."""
    return isinstance(data, xr.Dataset) and "force" in data.variables and (
        "sample" in data.dims) and "omega" not in data.dims


def _tip(fits: xr.Dataset, tip: Any) -> Any:
    from viscoforce.physics.tips import Tip, tip_from

    if tip is not None:
        return tip_from(tip)
    if "tip_shape" in fits.attrs:
        return Tip.from_attrs(fits.attrs)
    return None


def force_curves(fits: xr.Dataset, curves: xr.Dataset, dims: tuple[str, ...], *,
                 tip: Any = None) -> tuple[dict[str, np.ndarray], list[str]]:
    """Each pixel's approach and best-fit force, flat (pixel-major), and what could not be shown.

    Parameters
    ----------
    fits : xarray.Dataset
        A fitted map of a model in :data:`CURVE_MODELS` over one dim, ``curve``.
    curves : xarray.Dataset
        The curves it was fitted to (:mod:`viscoforce.schema.curves`).
    dims : tuple of str
        The map dims of ``fits`` (``("curve",)``).
    tip : Tip or str, optional
        The tip of the fit (default: the one its attrs record).

    Returns
    -------
    (dict, list of str)
        ``position`` [µm from the pixel's contact point], ``force`` and ``fit_force`` [nN],
        flat over the pixels, and ``offsets`` (pixel i's samples are ``offsets[i]:offsets[i
        + 1]``); the notes (no tip: data only; pixels whose approach could not be cut).

    Raises
    ------
    ParameterError
        ``fits`` is not over the curves of ``curves`` (their count differs), or not a map over
        ``curve``.
    """
    from viscoforce.fitting.curves import curve_data
    from viscoforce.fitting.models import make_model

    model = str(fits.attrs.get("model", ""))
    if dims != ("curve",):
        raise ParameterError(f"the force curves of a {model} map need a map over 'curve', this "
                             f"one is over {dims}")
    n = int(fits.sizes["curve"])
    n_curves = int(curves.sizes.get("curve", 1))
    if n_curves != n:
        raise ParameterError(f"the curves (--data) are not this map's: {n_curves} curve(s), the "
                             f"map {n} pixel(s)")
    notes: list[str] = []
    tip = _tip(fits, tip)
    fixed = {"tip": tip, **{k: fits.attrs[k] for k in ("sample_height", "sample_base")
                            if k in fits.attrs}}
    fitted = None
    if tip is None:
        notes.append(f"the {model} map records no tip (tip_shape): the force curves show the "
                     "data only")
    else:
        fitted = make_model(model, 1, **fixed)
    names = [str(p) for p in fits["param_i"].values]
    values = {p: flat_over(fits, p, dims).astype(float) for p in names}
    success = flat_over(fits, "success", dims).astype(bool)
    label = (np.asarray(fits["curve"].values).astype(int) if "curve" in fits.coords
             else np.arange(n))
    position, force, fit_force, offsets, failed = [], [], [], [0], []
    for i in range(n):
        try:
            data = curve_data(curves, model, curve=int(label[i]))
        except ViscoforceError:
            failed.append(i)
            offsets.append(offsets[-1])
            continue
        order = np.argsort(data.x)
        z, f = np.asarray(data.x, dtype=float)[order], np.asarray(data.y, dtype=float)[order]
        pixel = {p: float(values[p][i]) for p in names}
        contact = pixel.get("contact_point", math.nan)
        shift = contact if math.isfinite(contact) else 0.0
        model_f = np.full(z.size, np.nan)
        if fitted is not None and success[i] and all(map(math.isfinite, pixel.values())):
            model_f = np.asarray(fitted.raw(z, pixel), dtype=float)
        position.append((z - shift) * _UM)
        force.append(f * _NN)
        fit_force.append(model_f * _NN)
        offsets.append(offsets[-1] + z.size)
    if failed:
        notes.append(f"no approach to show for pixel(s) {', '.join(map(str, failed))}")

    def joined(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(parts) if parts else np.zeros(0)

    return ({"position": joined(position), "force": joined(force),
             "fit_force": joined(fit_force), "offsets": np.asarray(offsets, dtype=np.int64)},
            notes)
