"""What the map viewer shows, as plain arrays: pixels, their table, spectra, fits and histograms.

Nothing here imports Bokeh: :func:`map_view` turns a fitted map (and optionally its spectra and
best-fit curves) into a :class:`MapView`, which :mod:`viscoforce.plotting.viewer._page` lays out.
The masking rules are :func:`viscoforce.plotting.maps.map_plot`'s: a pixel is grey for a
parameter where its fit failed or does not describe its data (``quality`` 1, 2), or where that
parameter is not determined (its ``identifiability`` ≠ 0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr

from viscoforce._validation import describe_value
from viscoforce.exceptions import ParameterError, SchemaError
from viscoforce.plotting._common import _mapped_variables, _variable_label, _what
from viscoforce.plotting.maps import _DIMENSIONS, _bad_pixels, _rows
from viscoforce.plotting.viewer._curves import CURVE_MODELS, force_curves, is_curves
from viscoforce.schema import flag_meanings, flat_over
from viscoforce.units import format_quantity, unit_factor

__all__ = ["MapView", "best_fit_curves", "map_view", "pixel_table"]

#: Bins of each parameter's histogram.
HISTOGRAM_BINS = 20
#: Points of a best-fit curve computed by :func:`best_fit_curves` (log-spaced over the data).
FIT_POINTS = 60


@dataclass(frozen=True)
class MapView:
    """A fitted map ready to draw: flat pixel arrays in C order over the map dims.

    Attributes
    ----------
    title : str
        What the page is titled.
    dims : tuple of str
        The map dims of the fit result.
    params : tuple of str
        The fitted parameters (``param_i``), in order.
    variables : tuple of str
        What the page maps and tabulates, Young's modulus first (issue 38 item 3): per fitted
        parameter ``<name>_young`` (where the fit derived it), ``<name>`` (the paper's
        convention for a modulus), ``<name>_shear``; the first is the default map.
    units : dict
        Variable → (SI unit, display unit, factor: display value = SI value / factor).
    x, y, width, height : numpy.ndarray
        Cell centres and sizes in the display units of ``axis_labels``.
    axis_labels : tuple of str
        (x label, y label) of the map.
    colour : dict
        Variable → per-pixel display values, NaN where the pixel is masked for it.
    log : dict
        Variable → whether its colour scale is logarithmic.
    quality : numpy.ndarray
        Per-pixel quality code (0 good).
    table : list of dict
        Per pixel: ``y``, ``x`` (the map's coordinates, SI, or indices), each variable and its
        ``_stderr``, ``redchi``, ``chi2_pvalue``, ``quality`` (code) and ``quality_name``.
    histograms : dict
        Variable → (bin left edges, right edges, counts) over its unmasked pixels (display
        units).
    frequency : numpy.ndarray or None
        The spectra's frequency axis (display unit ``frequency_label``), None without spectra.
    spectra : dict
        Flat per-pixel arrays (pixel-major, ``len(frequency)`` per pixel): ``stiffness``,
        ``stiffness_lower``, ``stiffness_upper`` [N/m], ``phase``, ``phase_lower``,
        ``phase_upper`` [degree], ``residual_re``, ``residual_im`` (÷ stderr or ÷ |k*_fit|);
        points flagged in the data's ``quality`` are NaN. Empty without spectra.
    fit_frequency : numpy.ndarray or None
        Frequency axis of the best-fit curves (display unit), None without them.
    fits : dict
        Flat per-pixel ``stiffness`` and ``phase`` of the best fit (pixel-major). Empty without.
    frequency_label : str
        The Bode plots' x label.
    residual_label : str
        The residual plot's y label.
    notes : tuple of str
        What the page cannot show and why (no spectra, no best-fit curves).
    what : dict
        Variable → what it is for a person (``"Young's modulus"``, ``"paper's E = 2
        E_young/(1 − ν²)"``, ``""`` for a parameter that is not a modulus).
    labels : dict
        Variable → its axis and colour-bar label (``"Young's modulus E_young [kPa]"``).
    curves : dict
        A curve map's force curves (hertz, with ``data=`` a curves dataset): flat per-pixel
        ``position`` [µm from the pixel's contact point], ``force``, ``fit_force`` [nN] and
        ``offsets`` (pixel i's samples are ``offsets[i]:offsets[i + 1]``). Empty otherwise.
    """

    title: str
    dims: tuple[str, ...]
    params: tuple[str, ...]
    units: dict[str, tuple[str, str, float]]
    x: np.ndarray
    y: np.ndarray
    width: np.ndarray
    height: np.ndarray
    axis_labels: tuple[str, str]
    colour: dict[str, np.ndarray]
    log: dict[str, bool]
    quality: np.ndarray
    table: list[dict[str, Any]]
    histograms: dict[str, tuple[np.ndarray, np.ndarray, np.ndarray]]
    frequency: np.ndarray | None = None
    spectra: dict[str, np.ndarray] = field(default_factory=dict)
    fit_frequency: np.ndarray | None = None
    fits: dict[str, np.ndarray] = field(default_factory=dict)
    frequency_label: str = "frequency [Hz]"
    residual_label: str = "residual / stderr"
    notes: tuple[str, ...] = ()
    variables: tuple[str, ...] = ()
    what: dict[str, str] = field(default_factory=dict)
    labels: dict[str, str] = field(default_factory=dict)
    curves: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_pixels(self) -> int:
        """Number of pixels."""
        return int(self.quality.size)


def check_map(fits: Any) -> tuple[str, ...]:
    """The map dims of a fitted map, or :class:`SchemaError` saying why ``fits`` is not one."""
    if not isinstance(fits, xr.Dataset):
        raise ParameterError(f"fits must be an xarray.Dataset (a fitted map), got "
                             f"{describe_value(fits)}")
    missing = [n for n in ("quality", "success", "redchi") if n not in fits.variables]
    if "param_i" not in fits.coords:
        missing.insert(0, "param_i")
    if missing:
        raise SchemaError(f"not a fitted map: no {', '.join(missing)} (make one with "
                          "'viscoforce fit MAP --out fits.nc')")
    dims = tuple(str(d) for d in fits["quality"].dims)
    if not dims:
        raise SchemaError("not a fitted map: a single fit (no map dims); the viewer shows maps "
                          "(fit a map file, 'viscoforce fit MAP --out fits.nc')")
    if len(dims) > 2:
        raise SchemaError(f"a fitted map has one or two map dims, this one has {dims}")
    return dims


def _display_unit(values: np.ndarray, unit: str) -> tuple[str, float]:
    """(display unit, factor) for ``values`` in ``unit`` (map_plot's choice)."""
    dimension = _DIMENSIONS.get(unit)
    finite = values[np.isfinite(values)]
    if dimension is None or not finite.size:
        return ("" if unit == "1" else unit), 1.0
    chosen = format_quantity(float(np.median(np.abs(finite))), dimension).partition(" ")[2]
    if not chosen:
        return unit, 1.0
    return chosen, unit_factor(dimension, chosen)


def _layout(fits: xr.Dataset, dims: tuple[str, ...]
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, tuple[str, str],
                       np.ndarray, np.ndarray]:
    """Cell centres, sizes and labels (display), and the table's x, y (SI or indices)."""
    shape = tuple(fits.sizes[d] for d in dims)
    n = math.prod(shape)
    if all(c in fits.variables and set(fits[c].dims) == set(dims) for c in ("x", "y")):
        xs = np.asarray(fits["x"].transpose(*dims).values, dtype=float).reshape(-1)
        ys = np.asarray(fits["y"].transpose(*dims).values, dtype=float).reshape(-1)
        if np.isfinite(xs).all() and np.isfinite(ys).all():
            x_um, y_um = xs * 1e6, ys * 1e6
            return (x_um, y_um, np.full(n, _spacing(x_um)), np.full(n, _spacing(y_um)),
                    ("x [µm]", "y [µm]"), xs, ys)
    if len(dims) == 2 and all(d in fits.coords and fits[d].dims == (d,) for d in dims):
        yc = np.asarray(fits[dims[0]].values, dtype=float)
        xc = np.asarray(fits[dims[1]].values, dtype=float)
        yy, xx = np.meshgrid(yc, xc, indexing="ij")
        xs, ys = xx.reshape(-1), yy.reshape(-1)
        scale = 1e6 if dims == ("y", "x") else 1.0
        labels = (("x [µm]", "y [µm]") if scale != 1.0 else (dims[1], dims[0]))
        return (xs * scale, ys * scale, np.full(n, _spacing(xs * scale)),
                np.full(n, _spacing(ys * scale)), labels, xs, ys)
    if len(dims) == 2:
        yy, xx = np.meshgrid(np.arange(shape[0]), np.arange(shape[1]), indexing="ij")
        xs, ys = xx.reshape(-1).astype(float), yy.reshape(-1).astype(float)
        labels = (f"{dims[1]} [index]", f"{dims[0]} [index]")
    else:
        xs, ys = np.arange(n, dtype=float), np.zeros(n)
        labels = (f"{dims[0]} [index]", "")
    return xs, ys, np.ones(n), np.ones(n), labels, xs, ys


def _spacing(v: np.ndarray) -> float:
    """The grid spacing of scattered positions (1 for a single line)."""
    centres, _ = _rows(v)
    return float(np.median(np.diff(centres))) if centres.size > 1 else 1.0


def _number(v: Any) -> float | None:
    v = float(v)
    return v if math.isfinite(v) else None


def pixel_table(fits: xr.Dataset) -> list[dict[str, Any]]:
    """The per-pixel table of a fitted map (the page's JSON data island), in C order.

    Parameters
    ----------
    fits : xarray.Dataset
        A fitted map (:func:`viscoforce.fitting.maps.fit_map`).

    Returns
    -------
    list of dict
        Per pixel: ``index`` (C order over the map dims), the map dims' indices, ``y``, ``x``
        (the pixel's coordinates [m], or its indices without coordinates), each fitted
        parameter and ``<name>_stderr`` [SI] with, before a modulus, its Young's modulus
        ``<name>_young`` and after it the shear modulus ``<name>_shear`` (each with
        ``_stderr``) where the fit derived them, ``redchi``, ``chi2_pvalue``, ``quality`` (the
        code) and ``quality_name``. Non-finite values are None (JSON ``null``).
    """
    dims = check_map(fits)
    *_, xs, ys = _layout(fits, dims)
    columns = {n: flat_over(fits, n, dims) for name in _mapped_variables(fits)
               for n in (name, f"{name}_stderr") if n in fits.variables}
    columns.update({n: flat_over(fits, n, dims) for n in ("redchi", "chi2_pvalue")
                    if n in fits.variables})
    quality = flat_over(fits, "quality", dims).astype(int)
    quality_names = flag_meanings(fits.variables["quality"])
    shape = tuple(fits.sizes[d] for d in dims)
    rows = []
    for i, index in enumerate(np.ndindex(*shape)):
        row: dict[str, Any] = {"index": i, **{d: int(j) for d, j in zip(dims, index, strict=True)
                                              if d not in ("x", "y")},
                               "y": _number(ys[i]), "x": _number(xs[i])}
        row.update({n: _number(v[i]) for n, v in columns.items()})
        row["quality"] = int(quality[i])
        row["quality_name"] = quality_names.get(int(quality[i]), str(int(quality[i])))
        rows.append(row)
    return rows


def _histogram(values: np.ndarray, log: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    finite = values[np.isfinite(values)]
    if log:
        finite = finite[finite > 0]
    if not finite.size:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    lo, hi = float(finite.min()), float(finite.max())
    if log:
        edges = np.geomspace(lo, hi if hi > lo else lo * 1.01, HISTOGRAM_BINS + 1)
    else:
        edges = np.linspace(lo, hi if hi > lo else lo + max(abs(lo), 1.0) * 0.01,
                            HISTOGRAM_BINS + 1)
    counts, _ = np.histogram(finite, bins=edges)
    return edges[:-1], edges[1:], counts.astype(float)


def _match(fits: xr.Dataset, data: xr.Dataset, dims: tuple[str, ...], what: str) -> None:
    """Raise if ``data`` (spectra or fit curves) is not over the map's pixels."""
    for d in dims:
        if d not in data.dims or data.sizes[d] != fits.sizes[d]:
            raise ParameterError(f"{what} is not over this map's pixels: the map has "
                                 f"{dict(fits.sizes)} over {dims}, {what} "
                                 f"{dict(data.sizes)}")
    for c in ("x", "y"):
        if c in fits.variables and c in data.variables and set(data[c].dims) == set(dims):
            a, b = flat_over(fits, c, dims).astype(float), flat_over(data, c, dims).astype(float)
            if not np.allclose(a, b, rtol=1e-9, atol=1e-12, equal_nan=True):
                raise ParameterError(f"{what} is from another map: its pixel positions {c!r} "
                                     "differ from the fit's")


def _spectra(fits: xr.Dataset, spectra: xr.Dataset, dims: tuple[str, ...],
             fit_curves: xr.Dataset | None) -> tuple[np.ndarray, dict[str, np.ndarray], str,
                                                     str, float]:
    """Frequency axis, flat per-pixel data arrays, x label, residual label and the x scale."""
    if "stiffness" not in spectra.variables or "phase" not in spectra.variables or (
            "omega" not in spectra.dims):
        raise SchemaError("the spectra need 'stiffness' and 'phase' over 'omega' (a spectrum "
                          "map, 'viscoforce load MAP --out spectra.nc')")
    _match(fits, spectra, dims, "the spectra (--data)")
    order = (*dims, "omega")
    omega = np.asarray(spectra["omega"].values, dtype=float)
    measured = "frequency" in spectra.coords
    scale, label = ((1 / (2 * np.pi), "frequency [Hz]") if measured
                    else (1.0, "angular frequency [rad/s]"))

    def grid(name: str) -> np.ndarray:
        shape = tuple(spectra.sizes[d] for d in order)
        if name not in spectra.variables:
            return np.full(shape, np.nan)
        return flat_over(spectra, name, order).astype(float, copy=False).reshape(shape)

    stiff, phase = grid("stiffness"), grid("phase")
    s_err, p_err = grid("stiffness_stderr"), grid("phase_stderr")
    keep = np.isfinite(stiff) & np.isfinite(phase)
    if "quality" in spectra.variables:
        keep &= grid("quality") == 0
    out = {"stiffness": stiff, "phase": phase,
           "stiffness_lower": stiff - s_err, "stiffness_upper": stiff + s_err,
           "phase_lower": phase - p_err, "phase_upper": phase + p_err}
    residual_label = "residual / stderr" if np.isfinite(s_err).any() else "residual / |k*_fit|"
    if fit_curves is not None:
        r_re, r_im = _residuals(omega, stiff, phase, s_err, p_err, fit_curves, dims)
    else:
        r_re = r_im = np.full(stiff.shape, np.nan)
    out.update({"residual_re": r_re, "residual_im": r_im})
    flat = {k: np.where(keep, v, np.nan).reshape(-1) for k, v in out.items()}
    return omega * scale, flat, label, residual_label, scale


def _residuals(omega: np.ndarray, stiff: np.ndarray, phase: np.ndarray, s_err: np.ndarray,
               p_err: np.ndarray, fit_curves: xr.Dataset, dims: tuple[str, ...]
               ) -> tuple[np.ndarray, np.ndarray]:
    """Re and Im k* residuals per pixel (bode_plot's rule: ÷ stderr, else ÷ |k*_fit|)."""
    w_fit = np.asarray(fit_curves["omega"].values, dtype=float)
    order = (*dims, "omega")
    fs = np.asarray(fit_curves["fit_stiffness"].transpose(*order).values, dtype=float)
    fp = np.radians(np.asarray(fit_curves["fit_phase"].transpose(*order).values, dtype=float))
    log_w, log_fit = np.log(omega), np.log(w_fit)
    k_fit = np.empty(stiff.shape, dtype=complex)
    for index in np.ndindex(*stiff.shape[:-1]):
        with np.errstate(divide="ignore", invalid="ignore"):
            mag = np.exp(np.interp(log_w, log_fit, np.log(fs[index])))
        k_fit[index] = mag * np.exp(1j * np.interp(log_w, log_fit, np.unwrap(fp[index])))
    chi = np.radians(phase)
    diff = stiff * np.exp(1j * chi) - k_fit
    with np.errstate(divide="ignore", invalid="ignore"):
        if np.isfinite(s_err).any():
            p_rad = np.radians(p_err)
            sig_re = np.hypot(np.cos(chi) * s_err, stiff * np.sin(chi) * p_rad)
            sig_im = np.hypot(np.sin(chi) * s_err, stiff * np.cos(chi) * p_rad)
            return diff.real / sig_re, diff.imag / sig_im
        return diff.real / np.abs(k_fit), diff.imag / np.abs(k_fit)


def best_fit_curves(fits: xr.Dataset, spectra: xr.Dataset, *, points: int = FIT_POINTS,
                    **fixed: Any) -> xr.Dataset:
    """Best-fit ``fit_stiffness`` and ``fit_phase`` of every pixel, from its fitted parameters.

    A map result holds each pixel's parameters, not its best-fit curve; this evaluates the
    model (:func:`viscoforce.fitting.models.make_model`, its ``raw`` function) with the fixed
    inputs the map was fitted with. For the ``contact`` model each pixel's operating
    indentation is the median ``mean_indentation`` of its unflagged points (what the map fit
    used), unless ``indentation`` is given.

    Parameters
    ----------
    fits : xarray.Dataset
        A fitted map (:func:`viscoforce.fitting.maps.fit_map`).
    spectra : xarray.Dataset
        The spectra it was fitted to (over the same pixels and ``omega``).
    points : int
        Points of each curve, log-spaced over the spectra's ``omega`` range.
    **fixed
        The model's fixed inputs as given to ``fit_map`` (``radius=``, ``material=``, …).

    Returns
    -------
    xarray.Dataset
        ``fit_stiffness`` [N/m] and ``fit_phase`` [degree] over (map dims, ``omega``); NaN
        where the pixel's fit failed or the model cannot be evaluated there.
    """
    from viscoforce.fitting.models import make_model

    dims = check_map(fits)
    _match(fits, spectra, dims, "the spectra")
    omega_data = np.asarray(spectra["omega"].values, dtype=float)
    omega = np.geomspace(omega_data.min(), omega_data.max(), int(points))
    model, names = str(fits.attrs["model"]), [str(n) for n in fits["param_i"].values]
    success = flat_over(fits, "success", dims).astype(bool)
    modes = flat_over(fits, "modes", dims) if "modes" in fits.variables else np.ones(success.size)
    values = {n: flat_over(fits, n, dims).astype(float) for n in names}
    depth = None
    if model == "contact" and fixed.get("indentation") is None and (
            "mean_indentation" in spectra.variables):
        d = spectra["mean_indentation"]
        if "quality" in spectra.variables:
            d = d.where(spectra["quality"] == 0)
        depth = flat_over(d.median("omega", skipna=True).to_dataset(name="d"), "d", dims)
    k = np.full((success.size, omega.size), np.nan, dtype=complex)
    for i in np.flatnonzero(success):
        inputs = dict(fixed)
        if depth is not None:
            inputs["indentation"] = float(depth[i])
        pixel = {n: float(values[n][i]) for n in names if math.isfinite(values[n][i])}
        try:
            fit_model = make_model(model, int(modes[i]), **inputs)
            k[i] = fit_model.raw(omega, pixel)
        except (ArithmeticError, ValueError, KeyError):
            continue  # the pixel keeps NaN: its curve cannot be evaluated
    shape = (*(fits.sizes[d] for d in dims), omega.size)
    coords = {"omega": ("omega", omega, {"units": "rad/s"})}
    return xr.Dataset({
        "fit_stiffness": ((*dims, "omega"), np.abs(k).reshape(shape), {"units": "N/m"}),
        "fit_phase": ((*dims, "omega"), np.degrees(np.angle(k)).reshape(shape),
                      {"units": "degree"})}, coords=coords)


def map_view(fits: xr.Dataset, spectra: xr.Dataset | None = None,
             fit_curves: xr.Dataset | None = None, *, title: str | None = None,
             tip: Any = None) -> MapView:
    """Everything the viewer draws, from a fitted map and (optionally) its spectra.

    Parameters
    ----------
    fits : xarray.Dataset
        A fitted map (:func:`viscoforce.fitting.maps.fit_map`).
    spectra : xarray.Dataset, optional
        The map's spectra (``stiffness``, ``phase``, their ``_stderr`` over the map dims and
        ``omega``): the Bode plots' data. For a map of ``hertz`` fits, the force curves it
        was fitted to: each pixel's approach and best fit (``curves``,
        :func:`~viscoforce.plotting.viewer._curves.force_curves`) instead of Bode plots.
    fit_curves : xarray.Dataset, optional
        Best-fit ``fit_stiffness`` and ``fit_phase`` over (map dims, ``omega``)
        (:func:`best_fit_curves`); default: those of ``fits`` if it has them.
    title : str, optional
        The page title (default: the model and the pixel count).
    tip : Tip or str, optional
        The tip of a ``hertz`` map's fits (default: the one its attrs record), for its
        best-fit force curves.

    Returns
    -------
    MapView

    Raises
    ------
    SchemaError
        ``fits`` is not a fitted map; force curves given for a map of spectrum fits.
    ParameterError
        The spectra or curves are not over this map's pixels.
    """
    dims = check_map(fits)
    names = tuple(str(n) for n in fits["param_i"].values)
    variables = tuple(_mapped_variables(fits))
    x, y, width, height, labels, _, _ = _layout(fits, dims)
    quality = flat_over(fits, "quality", dims).astype(int)
    units, colour, log, hists = {}, {}, {}, {}
    for name in variables:
        values = flat_over(fits, name, dims).astype(float)
        bad = _bad_pixels(fits, name, dims).reshape(-1)
        shown = np.isfinite(values) & ~bad
        unit = str(fits[name].attrs.get("units", ""))
        display, factor = _display_unit(values[shown], unit)
        units[name] = (unit, display, factor)
        scaled = np.where(shown, values / factor, np.nan)
        good = scaled[shown]
        log[name] = bool(good.size and (good > 0).all() and good.max() > 10 * good.min())
        colour[name] = scaled
        hists[name] = _histogram(scaled, log[name])
    if fit_curves is None and "fit_stiffness" in fits.variables and set(
            fits["fit_stiffness"].dims) == {*dims, "omega"}:
        fit_curves = fits
    notes: list[str] = []
    model = str(fits.attrs.get("model", ""))
    curves: dict[str, np.ndarray] = {}
    if model in CURVE_MODELS:
        if spectra is not None and not is_curves(spectra):
            raise SchemaError(f"a {model} map was fitted to force curves: give them as --data "
                              "(the map file), not spectra")
        if spectra is None:
            notes.append(f"no force curves given (--data MAP, the file the {model} map was "
                         "fitted to): the force-curve plot stays empty")
            empty = np.zeros(0)
            curves = {"position": empty, "force": empty, "fit_force": empty,
                      "offsets": np.zeros(quality.size + 1, dtype=np.int64)}
        else:
            curves, more = force_curves(fits, spectra, dims, tip=tip)
            notes.extend(more)
        spectra = None
    elif spectra is not None and is_curves(spectra):
        raise SchemaError(f"--data holds force curves; the viewer draws them for maps of "
                          f"{', '.join(CURVE_MODELS)} fits, this is a {model} map: give its "
                          "spectra ('viscoforce load MAP --out spectra.nc')")
    frequency, data, f_label, r_label, scale = None, {}, "frequency [Hz]", "residual", 1.0
    if spectra is not None:
        frequency, data, f_label, r_label, scale = _spectra(fits, spectra, dims, fit_curves)
    fit_frequency, fit_arrays = None, {}
    if fit_curves is not None:
        _match(fits, fit_curves, dims, "the best-fit curves")
        order = (*dims, "omega")
        fit_frequency = np.asarray(fit_curves["omega"].values, dtype=float) * (
            scale if spectra is not None else 1 / (2 * np.pi))
        if spectra is None:
            f_label = "frequency [Hz]"
        fit_arrays = {k: np.asarray(fit_curves[f"fit_{k}"].transpose(*order).values,
                                    dtype=float).reshape(-1) for k in ("stiffness", "phase")}
    if curves or model in CURVE_MODELS:
        pass  # a curve map: no Bode plots (the force-curve notes are above)
    elif spectra is None and fit_curves is None:
        notes.append("no spectra (--data SPECTRA.nc) and no best-fit curves in the fit result: "
                     "the Bode plots stay empty")
    elif spectra is None:
        notes.append("no spectra given (--data SPECTRA.nc): the Bode plots show the fit only")
    elif fit_curves is None:
        notes.append("the fit result holds no best-fit curves (fit_stiffness, fit_phase): the "
                     "Bode plots show the data only")
    n_good = int((quality == 0).sum())
    return MapView(
        title=title or f"viscoforce map viewer: {fits.attrs.get('model', 'fit')} model, "
                       f"{quality.size} pixels, {n_good} good",
        dims=dims, params=names, variables=variables, units=units, x=x, y=y, width=width, height=height,
        axis_labels=labels, colour=colour, log=log, quality=quality,
        table=pixel_table(fits), histograms=hists, frequency=frequency, spectra=data,
        fit_frequency=fit_frequency, fits=fit_arrays, frequency_label=f_label,
        residual_label=r_label, notes=tuple(notes),
        what={n: _what(fits, n) for n in variables},
        labels={n: _variable_label(fits, n, units[n][1]) for n in variables}, curves=curves)
