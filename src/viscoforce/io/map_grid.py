"""Grid rows and columns of a map's curves from their lateral positions, and the positions snapped.

An instrument records where each curve of a map was taken, with a little noise: the JPK map
reader finds ``force-scan-series.header.position.{x,y}`` of one grid column differing by ~1e-12
m (the real maps in ``data_examples/real`` and ``data/real/PyFMRheo``), so that
``ds.set_index(curve=["y", "x"]).unstack()`` of a 4 x 4 map gave 7 x 4 pixels, mostly empty.
:func:`map_grid` recovers the grid: along each axis the positions are clustered (sorted, and split
where two neighbours differ by more than :data:`GRID_TOLERANCE` of the grid step), each curve gets
the integer ``row`` (along y, 0 at the smallest y) and ``column`` (along x, 0 at the smallest x)
of its clusters, and the positions are snapped to the median of their cluster (the same value
for every curve of a grid line; exact where the file's values do not jitter). The grid step is
the map's own where the file declares its grid (``ulength / ilength``, ``vlength / jlength``),
else the median of the gaps between neighbouring positions above :data:`POSITION_NOISE`. A grid
rotated by ``theta`` is clustered in its own frame (u along the fast axis), and the snapped
positions are turned back.

Rows and columns count in the sample's frame (row 0 at the smallest y), not as an image does (row
0 at the top): ``ds.set_index(curve=["row", "column"]).unstack()`` or ``["y", "x"]`` give the
same map. A curve without a finite position has row = column = -1 and NaN positions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from viscoforce.exceptions import ParameterError

__all__ = ["GRID_TOLERANCE", "POSITION_NOISE", "MapGrid", "cluster_axis", "map_grid"]

#: Fraction of the grid step within which positions belong to one grid line.
GRID_TOLERANCE = 0.25
#: Gaps between positions below this [m] are noise, never a grid step (the JPK maps' positions
#: jitter by ~1e-12 m; no instrument maps at steps below 0.1 nm).
POSITION_NOISE = 1e-10


@dataclass(frozen=True, eq=False)
class MapGrid:
    """Grid indices and snapped positions of a map's curves (:func:`map_grid`).

    Parameters
    ----------
    row, column : numpy.ndarray of int32
        Per curve: grid row (along y, from 0 at the smallest y) and column (along x, from 0 at
        the smallest x); -1 for a curve without a finite position.
    x, y : numpy.ndarray
        Per curve: the position snapped to its grid line [m] (NaN without a position).
    x_raw, y_raw : numpy.ndarray
        Per curve: the position as given [m].
    n_rows, n_columns : int
        Distinct rows and columns found.
    x_step, y_step : float
        The grid step used for the clustering [m] (NaN along an axis with one line).
    method : str
        How the grid was found (for ``attrs``).
    """

    row: NDArray[np.int32]
    column: NDArray[np.int32]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    x_raw: NDArray[np.float64]
    y_raw: NDArray[np.float64]
    n_rows: int
    n_columns: int
    x_step: float
    y_step: float
    method: str

    def as_attrs(self) -> dict[str, int | float | str]:
        """``grid_rows``, ``grid_columns``, ``grid_x_step``, ``grid_y_step``, ``grid_method``."""
        return {"grid_rows": int(self.n_rows), "grid_columns": int(self.n_columns),
                "grid_x_step": float(self.x_step), "grid_y_step": float(self.y_step),
                "grid_method": self.method}


def _step_of(values: NDArray[np.float64]) -> float:
    """The median gap between neighbouring distinct positions above :data:`POSITION_NOISE`."""
    gaps = np.diff(np.sort(values))
    steps = gaps[gaps > POSITION_NOISE]
    return float(np.median(steps)) if steps.size else math.nan


def cluster_axis(values: ArrayLike, step: float | None = None, *,
                 tolerance: float = GRID_TOLERANCE) -> tuple[NDArray[np.int32], NDArray[np.float64]]:
    """Cluster positions along one axis into grid lines.

    Parameters
    ----------
    values : array_like
        Positions [m]; NaN for unknown ones.
    step : float, optional
        The grid step [m]; default the median gap between neighbouring positions above
        :data:`POSITION_NOISE`.
    tolerance : float
        Fraction of the step in (0, 0.5): neighbours (in sorted order) closer than
        ``tolerance * step`` are one line.

    Returns
    -------
    index : numpy.ndarray of int32
        Per value: its line, 0 at the smallest position (-1 for NaN).
    centre : numpy.ndarray
        Per value: the median of its line [m] (NaN for NaN).
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    if not 0 < tolerance < 0.5:
        raise ParameterError(f"tolerance must be in (0, 0.5) (a fraction of the grid step), got "
                             f"{tolerance!r}")
    index = np.full(v.shape, -1, dtype=np.int32)
    centre = np.full(v.shape, math.nan)
    known = np.flatnonzero(np.isfinite(v))
    if known.size == 0:
        return index, centre
    if step is None or not math.isfinite(step) or step <= 0:
        step = _step_of(v[known])
    order = known[np.argsort(v[known], kind="stable")]
    gaps = np.diff(v[order])
    breaks = gaps > tolerance * step if math.isfinite(step) else np.zeros(gaps.shape, bool)
    lines = np.concatenate(([0], np.cumsum(breaks))).astype(np.int32)
    index[order] = lines
    for line in range(int(lines[-1]) + 1):
        members = order[lines == line]
        centre[members] = np.median(v[members])
    return index, centre


def _rotated(x: NDArray[np.float64], y: NDArray[np.float64], centre: tuple[float, float],
             theta: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(u, v): the positions relative to ``centre`` in the frame turned by ``theta`` [rad]."""
    dx, dy = x - centre[0], y - centre[1]
    c, s = math.cos(theta), math.sin(theta)
    return c * dx + s * dy, -s * dx + c * dy


def map_grid(x: ArrayLike, y: ArrayLike, *, steps: tuple[float, float] | None = None,
             shape: tuple[int, int] | None = None, centre: tuple[float, float] = (0.0, 0.0),
             theta: float = 0.0, tolerance: float = GRID_TOLERANCE) -> MapGrid:
    """Rows, columns and snapped positions of the curves of a map (see the module docstring).

    Parameters
    ----------
    x, y : array_like
        Per curve, the lateral position [m] (NaN where unknown).
    steps : (float, float), optional
        The grid steps along u (x) and v (y) [m], from the file's grid; default from the
        positions.
    shape : (int, int), optional
        The declared (columns, rows) of the grid (``ilength``, ``jlength``): with ``theta``,
        the frame whose clustering fits in it is kept (``theta``, else ``-theta``).
    centre : (float, float)
        Centre of the grid [m] (where a rotated grid turns about).
    theta : float
        Rotation of the grid's fast axis from x [rad].
    tolerance : float
        Fraction of the step within which positions are one grid line (:func:`cluster_axis`).

    Returns
    -------
    MapGrid
    """
    xr_ = np.asarray(x, dtype=float).reshape(-1)
    yr_ = np.asarray(y, dtype=float).reshape(-1)
    if xr_.shape != yr_.shape:
        raise ParameterError(f"x and y must have one value per curve, got {xr_.size} and "
                             f"{yr_.size}")
    du, dv = steps if steps is not None else (None, None)
    known = np.isfinite(xr_) & np.isfinite(yr_)
    xs, ys = np.where(known, xr_, np.nan), np.where(known, yr_, np.nan)
    turn = 0.0
    if theta and math.isfinite(theta):
        candidates = (theta, -theta)
        for turn in candidates:
            u, v = _rotated(xs, ys, centre, turn)
            column, cu = cluster_axis(u, du, tolerance=tolerance)
            row, cv = cluster_axis(v, dv, tolerance=tolerance)
            if shape is None or (column.max(initial=-1) < shape[0]
                                 and row.max(initial=-1) < shape[1]):
                break
        back_u, back_v = _rotated(cu, cv, (0.0, 0.0), -turn)
        sx, sy = back_u + centre[0], back_v + centre[1]
    else:
        column, sx = cluster_axis(xs, du, tolerance=tolerance)
        row, sy = cluster_axis(ys, dv, tolerance=tolerance)
    n_columns, n_rows = int(column.max(initial=-1)) + 1, int(row.max(initial=-1)) + 1
    axes = [("x", du, xs if not turn else None), ("y", dv, ys if not turn else None)]
    used = []
    for _, given, values in axes:
        if given is not None and math.isfinite(given) and given > 0:
            used.append(float(given))
        else:
            used.append(_step_of(values[np.isfinite(values)]) if values is not None
                        else math.nan)
    source = "the file's grid" if steps is not None else "the median gap between positions"
    method = (f"positions clustered per axis{f' in the grid frame turned by {turn:g} rad' if turn else ''}"
              f" (neighbours within {tolerance:g} of the grid step, from {source}, are one grid "
              "line); x, y snapped to the median of their line, the file's values in x_raw, "
              "y_raw; row along y and column along x, from 0 at the smallest (-1: no position)")
    return MapGrid(row=row, column=column, x=sx, y=sy, x_raw=xr_, y_raw=yr_, n_rows=n_rows,
                   n_columns=n_columns, x_step=used[0], y_step=used[1], method=method)
