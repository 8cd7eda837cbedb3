"""Maps of fitted variables: every pixel at its own x, y, masked by its quality, with units.

:func:`map_plot` draws one variable of a fitted map (:func:`viscoforce.fitting.maps.fit_map`,
``fit MAP --out fits.nc``) or of a spectrum map. Pixels sit on their ``x``/``y`` coordinates
(the instrument's grid positions [m], drawn in µm) as touching cells, so there are no gaps;
by default it is Young's modulus (``E_young``, ``E0_young``: issue 38 item 3), labelled so, with
the paper's modulus one ``variable=`` away;
a map without ``x``/``y`` is drawn on its two dims' indices. Pixels whose fit failed or does not
describe its data (``quality``, :data:`viscoforce.fitting.pixels.MAP_QUALITY`), or where the
drawn parameter is not determined, are left grey and counted in the title, so a colour never
stands for a value the fit does not support. The colour bar is in a unit chosen
for the values (kPa, GPa, ms, …) and logarithmic for positive values spanning more than a
decade.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from viscoforce._validation import describe_value
from viscoforce.exceptions import ParameterError
from viscoforce.plotting._common import (
    PlotHandle,
    _main_variable,
    _new_or_given_axes,
    _require_flag,
    _variable_label,
)
from viscoforce.units import format_quantity, unit_factor

if TYPE_CHECKING:  # pragma: no cover
    from matplotlib.axes import Axes

__all__ = ["map_plot"]

#: CF units → the :func:`viscoforce.units.format_quantity` dimension of the colour bar.
_DIMENSIONS = {"s": "time", "Pa": "pressure", "N/m": "stiffness", "N": "force", "m": "length"}
#: Colour of the pixels left out (quality ≠ 0).
MASKED_COLOUR = "0.8"


def _grid(ds: xr.Dataset, values: np.ndarray, dims: tuple[str, ...]
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, str, str]:
    """(x edges, y edges, values on a (y, x) grid, x label, y label) of a map's pixels."""
    if "x" in ds.variables and "y" in ds.variables and set(ds["x"].dims) == set(dims) and set(
            ds["y"].dims) == set(dims):
        x = np.asarray(ds["x"].transpose(*dims).values, dtype=float).reshape(-1) * 1e6
        y = np.asarray(ds["y"].transpose(*dims).values, dtype=float).reshape(-1) * 1e6
        ok = np.isfinite(x) & np.isfinite(y)
        (xs, ix), (ys, iy) = _rows(x[ok]), _rows(y[ok])
        grid = np.full((ys.size, xs.size), np.nan)
        grid[iy, ix] = values.reshape(-1)[ok]
        return _edges(xs), _edges(ys), grid, "x [µm]", "y [µm]"
    if len(dims) == 2:
        ny, nx = values.shape
        (xe, xl), (ye, yl) = (_axis(ds, dims[1], nx), _axis(ds, dims[0], ny))
        return xe, ye, values, xl, yl
    n = values.size
    return np.arange(n + 1) - 0.5, np.array([-0.5, 0.5]), values.reshape(1, n), \
        f"{dims[0]} [index]", ""


def _bad_pixels(result: xr.Dataset, variable: str, dims: tuple[str, ...]) -> np.ndarray:
    """Pixels a map of ``variable`` should not colour.

    Failed fits and fits that do not describe their data (``quality`` 1, 2) always; for a
    fitted parameter (or its ``_young``/``_shear``/``_stderr`` forms) also the pixels where that
    parameter is not determined or at a bound (its ``identifiability`` code, else ``quality``
    3, 4); another variable (``redchi``…) only the failed fits.
    """
    shape = tuple(result.sizes[d] for d in dims)
    bad = np.zeros(shape, dtype=bool)
    if "quality" in result.variables and set(result["quality"].dims) == set(dims):
        quality = np.asarray(result["quality"].transpose(*dims).values)
        bad |= np.isin(quality, (1, 2))
    else:
        quality = None
    base = variable
    for suffix in ("_stderr", "_lower", "_upper", "_young", "_shear"):
        base = base.removesuffix(suffix)
    names = [str(n) for n in result["param_i"].values] if "param_i" in result.coords else []
    if base in names:
        ident = result.get("identifiability")
        if ident is not None and set(ident.dims) == {*dims, "param_i"}:
            bad |= np.asarray(ident.sel(param_i=base).transpose(*dims).values) != 0
        elif quality is not None:
            bad |= quality != 0
    return bad


def _rows(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The grid lines of scattered positions and each position's line.

    Positions closer than 1e-3 of their range are one line (the instrument records the
    nominal grid with a jitter of a few pm).
    """
    order = np.sort(v)
    tol = 1e-3 * max(float(np.ptp(order)) if order.size else 0.0, 1e-300)
    starts = np.concatenate([[True], np.diff(order) > tol])
    line = np.cumsum(starts) - 1
    centres = np.array([order[line == i].mean() for i in range(int(line[-1]) + 1)])
    index = line[np.searchsorted(order, v)]
    return centres, index


def _axis(ds: xr.Dataset, dim: str, n: int) -> tuple[np.ndarray, str]:
    """Cell edges and label of one map dim: its coordinate (``x``/``y`` in µm) or indices."""
    if dim in ds.coords and ds[dim].dims == (dim,) and ds[dim].dtype.kind in "iuf":
        centres = np.asarray(ds[dim].values, dtype=float)
        if dim in ("x", "y"):
            return _edges(centres * 1e6), f"{dim} [µm]"
        unit = str(ds[dim].attrs.get("units", ""))
        return _edges(centres), f"{dim} [{unit}]" if unit else dim
    return np.arange(n + 1) - 0.5, f"{dim} [index]"


def _edges(centres: np.ndarray) -> np.ndarray:
    """Cell edges around sorted centres (half-way between neighbours; one cell: ±0.5)."""
    if centres.size == 1:
        return np.array([centres[0] - 0.5, centres[0] + 0.5])
    mid = 0.5 * (centres[1:] + centres[:-1])
    return np.concatenate([[2 * centres[0] - mid[0]], mid, [2 * centres[-1] - mid[-1]]])


def map_plot(result: xr.Dataset, variable: str | None = None, *, ax: Axes | None = None,
             good_only: bool = True, log: bool | None = None,
             title: str | None = None) -> PlotHandle:
    """Draw one variable of a map over the pixels' x, y, masked by quality, with a colour bar.

    Parameters
    ----------
    result : xarray.Dataset
        A fitted map (:func:`viscoforce.fitting.maps.fit_map`) or any dataset whose
        ``variable`` spans one or two map dims (``x``/``y`` coordinates over them place the
        pixels; ``quality`` over them masks).
    variable : str, optional
        The variable to draw (default: Young's modulus of the main modulus, ``<name>_young``
        of the first fitted parameter that has one; else the first fitted parameter,
        ``param_i[0]``).
    ax : matplotlib Axes, optional
        Axes to draw on (default: a new figure).
    good_only : bool
        Grey out the pixels whose fit failed or does not describe its data (``quality`` 1, 2)
        and, for a fitted parameter, those where it is not determined or at a bound (its
        ``identifiability``); default True.
    log : bool, optional
        Logarithmic colour scale (default: positive values spanning more than a decade).
    title : str, optional
        Axes title (default: the variable, the model and how many pixels are shown).

    Returns
    -------
    PlotHandle
        ``axes = (ax, colour bar axes)``, ``lines = (the mesh,)``.

    Raises
    ------
    ParameterError
        ``result`` is not a Dataset; ``variable`` is absent or spans other dims than one or two
        map dims; no pixel is left to draw.
    """
    from matplotlib.colors import LogNorm, Normalize

    if not isinstance(result, xr.Dataset):
        raise ParameterError(f"result must be an xarray.Dataset (a fitted map), got "
                             f"{describe_value(result)}")
    if variable is None:
        if "param_i" not in result.coords:
            raise ParameterError("variable is needed: this dataset has no fitted parameters "
                                 "(param_i)")
        variable = _main_variable(result)
    if not isinstance(variable, str) or variable not in result.variables:
        names = [str(n) for n in result.data_vars if 0 < result[n].ndim <= 2
                 and "omega" not in result[n].dims]
        raise ParameterError(f"variable must be one of the map's variables {names}, got "
                             f"{variable!r}")
    good_only = _require_flag("good_only", good_only)
    da = result[variable]
    dims = tuple(str(d) for d in da.dims)
    if not 1 <= len(dims) <= 2 or any(d in ("omega", "param_i", "param_j") for d in dims):
        raise ParameterError(f"{variable!r} spans {dims}: map_plot draws a variable over one or "
                             "two map dims (select the others first, e.g. .isel(omega=0))")
    values = np.asarray(da.values, dtype=float)
    shown = np.isfinite(values)
    n_bad = 0
    if good_only:
        bad = _bad_pixels(result, variable, dims)
        n_bad = int((bad & shown).sum())
        shown &= ~bad
    if not shown.any():
        raise ParameterError(f"no pixel of {variable!r} is left to draw ({values.size} pixels, "
                             f"{n_bad} with quality != 0, the rest NaN)")
    unit = str(da.attrs.get("units", ""))
    dimension = _DIMENSIONS.get(unit)
    factor, label_unit = 1.0, unit
    if dimension is not None:
        typical = float(np.nanmedian(np.abs(values[shown])))
        chosen = format_quantity(typical, dimension).partition(" ")[2]
        if chosen:
            factor, label_unit = unit_factor(dimension, chosen), chosen
    scaled = np.where(shown, values / factor, np.nan)
    positive = scaled[shown] > 0
    if log is None:
        log = bool(positive.all() and np.nanmax(scaled) > 10 * np.nanmin(scaled))
    log = _require_flag("log", log)
    xe, ye, grid, xlabel, ylabel = _grid(result, scaled, dims)
    figure, axes = _new_or_given_axes(ax, (5.4, 4.4))
    axes.set_facecolor(MASKED_COLOUR)
    norm = LogNorm() if log and positive.all() else Normalize()
    mesh = axes.pcolormesh(xe, ye, np.ma.masked_invalid(grid), norm=norm, cmap="viridis",
                           shading="flat")
    bar = figure.colorbar(mesh, ax=axes)
    bar.set_label(_variable_label(result, variable, label_unit))
    axes.set_xlabel(xlabel)
    if ylabel:
        axes.set_ylabel(ylabel)
    else:
        axes.set_yticks([])
    axes.set_aspect("equal" if xlabel == "x [µm]" and ylabel == "y [µm]" else "auto")
    model = result.attrs.get("model")
    left_out = f"\n{n_bad} grey: failed, bad fit or not determined" if n_bad else ""
    axes.set_title(title if title is not None else
                   f"{variable}{f' ({model})' if model else ''}: {int(shown.sum())} of "
                   f"{values.size} pixels{left_out}", fontsize="medium")
    return PlotHandle(figure, (axes, bar.ax), (mesh,))
