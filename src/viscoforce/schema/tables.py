"""Tables over a map (a variable read as one value per row) and the kind of a dataset.

Every table viscoforce writes or shows (a fit's CSV, a batch of files, the viewer's pixel table)
reads its columns through :func:`flat_over`, so each row sits at its own coordinates.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from viscoforce.exceptions import SchemaError

__all__ = ["data_kind", "flat_over"]


def data_kind(ds: xr.Dataset) -> str | None:
    """What kind of dataset ``ds`` is: the route of a fit.

    ``"spectrum"`` (stiffness over omega), ``"curves"`` (over sample), ``"trajectory"``
    (position over time), or None.
    """
    if "omega" in ds.dims and "stiffness" in ds.variables:
        return "spectrum"
    if "sample" in ds.dims:
        return "curves"
    if "time" in ds.dims and "position" in ds.variables:
        return "trajectory"
    return None


def flat_over(ds: xr.Dataset, name: str, dims: tuple[str, ...]) -> np.ndarray:
    """Variable ``name`` of ``ds`` as one value per cell of ``dims``, in C order over ``dims``.

    The one way a table (a CSV row per pixel, the viewer's pixel table, a batch row) reads a
    variable over a map: broadcast BY DIM NAME, so a 1-D ``y`` coordinate of a (``y``, ``x``)
    map repeats along ``x`` and a 1-D ``x`` along ``y`` (positional broadcasting would lay ``y``
    along the last axis: ``y = x`` on a square map, an error on any other).

    Parameters
    ----------
    ds : xarray.Dataset
        The dataset (a fit result, a spectrum, a map).
    name : str
        A variable or coordinate of ``ds`` over a subset of ``dims`` (a scalar repeats).
    dims : tuple of str
        The table's dims, outermost first.

    Returns
    -------
    numpy.ndarray
        1-D, ``prod(ds.sizes[d] for d in dims)`` values (a read-only view where no copy was
        needed).

    Raises
    ------
    SchemaError
        If ``name`` has a dim outside ``dims``.
    """
    da = ds[name]
    outside = [str(d) for d in da.dims if d not in dims]
    if outside:
        raise SchemaError(f"{name} has dims {outside} beside the table's {list(dims)}: it is not "
                          "one value per row")
    missing = {d: int(ds.sizes[d]) for d in dims if d not in da.dims}
    if missing:
        da = da.expand_dims(missing)
    return np.asarray(da.transpose(*dims).values).reshape(-1)
