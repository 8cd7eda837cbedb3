"""Curves dataset: measured force curves, one or many, as a CF contiguous ragged array.

Layout (chosen so that curves of different lengths need no padding and the file stays netCDF3):

* dim ``sample``: every sample of every curve, curve after curve. ``time`` [s] (a coordinate,
  from the start of its curve, strictly increasing within a curve), ``force`` [N], ``height``
  [m], ``deflection`` [m], ``tip_position`` [m], and ``segment``, an int32 index into the
  segment table.
* dim ``curve`` (always present, size 1 for a single curve): ``sample_count`` (int32, CF
  ``sample_dimension = "sample"``: curve i holds the next ``sample_count[i]`` samples), optional
  ``x``, ``y`` [m] coordinates and per-curve calibration ``spring_constant`` [N/m],
  ``sensitivity`` [m/V]. In a map, optional int32 coordinates ``row`` (along y, 0 at the
  smallest y) and ``column`` (along x, 0 at the smallest x): the curve's place on the grid (-1:
  no position), so that ``ds.set_index(curve=["row", "column"]).unstack()`` (or ``["y", "x"]``)
  gives the map; the readers that set them (JPK, :mod:`viscoforce.io.map_grid`) snap ``x``, ``y``
  to the grid and keep the file's positions, which jitter by ~1e-12 m, in ``x_raw``, ``y_raw``
  [m].
* dim ``segment_table``: one row per distinct segment (curves may share rows): ``segment_name``,
  one of :data:`SEGMENT_NAMES`, and optional ``segment_type``, the file's own label (e.g.
  ``"sine-z-modulation"``). Readers may add more ``segment_*`` variables over it (with units).

:func:`select_curve` cuts one curve out. File metadata goes in ``attrs`` (``source`` = format).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from viscoforce.exceptions import ParameterError, SchemaError
from viscoforce.schema._core import (
    VariableSpec,
    as_mapping,
    as_names,
    as_text,
    check_attrs,
    check_present,
    check_variables,
    clean_attrs,
    coordinate,
    require_dataset,
    shaped,
    variable,
)

_S, _C, _G = ("sample",), ("curve",), ("segment_table",)

CURVES_VARIABLES: dict[str, VariableSpec] = {
    "time": VariableSpec("s", "time from the start of the curve", _S),
    "force": VariableSpec("N", "force (spring constant x deflection)", _S),
    "height": VariableSpec("m", "height as recorded (piezo or sensor)", _S),
    "deflection": VariableSpec("m", "cantilever deflection", _S),
    "tip_position": VariableSpec("m", "tip displacement toward the sample", _S),
    "segment": VariableSpec("1", "segment of the sample (index into segment_table)", _S, "i"),
    "sample_count": VariableSpec("1", "number of samples of the curve", _C, "i"),
    "segment_name": VariableSpec("", "segment kind", _G, "U"),
    "segment_type": VariableSpec("", "segment type as the file names it", _G, "U", False),
    "x": VariableSpec("m", "lateral position x", _C, required=False),
    "y": VariableSpec("m", "lateral position y", _C, required=False),
    "x_raw": VariableSpec("m", "lateral position x as the file gives it", _C, required=False),
    "y_raw": VariableSpec("m", "lateral position y as the file gives it", _C, required=False),
    "row": VariableSpec("1", "grid row of the curve (along y, from 0; -1: no position)", _C, "i",
                        required=False),
    "column": VariableSpec("1", "grid column of the curve (along x, from 0; -1: no position)", _C,
                           "i", required=False),
    "spring_constant": VariableSpec("N/m", "cantilever spring constant", _C, required=False),
    "sensitivity": VariableSpec("m/V", "deflection sensitivity", _C, required=False),
}
#: What ``make_curves(per_curve=...)`` takes (all but the calibration become coordinates).
_PER_CURVE = ("x", "y", "spring_constant", "sensitivity", "row", "column", "x_raw", "y_raw")
#: Allowed values of ``segment_name``.
SEGMENT_NAMES = ("approach", "pause", "modulation", "retract", "other")


def make_curves(time: ArrayLike, force: ArrayLike, height: ArrayLike, deflection: ArrayLike, *,
                tip_position: ArrayLike | None = None, segment: ArrayLike = 0,
                segment_names: Sequence[str] = ("other",),
                segment_types: Sequence[str] | None = None,
                sample_count: ArrayLike | None = None,
                per_curve: Mapping[str, ArrayLike] | None = None,
                attrs: Mapping[str, Any] | None = None, source: str | None = None) -> xr.Dataset:
    """Build a curves dataset from flat per-sample arrays (SI; curves concatenated in order).

    Parameters
    ----------
    time : array_like
        Time [s] of each sample from the start of its curve.
    force, height, deflection : array_like
        Per sample: force [N], height [m] as recorded, deflection [m].
    tip_position : array_like, optional
        Tip displacement toward the sample [m]; default −height − deflection.
    segment : int or array_like of int
        Per-sample row of the segment table (default 0: one segment).
    segment_names : sequence of str
        The segment table: one of :data:`SEGMENT_NAMES` per row.
    segment_types : sequence of str, optional
        The file's own label of each row.
    sample_count : array_like of int, optional
        Samples per curve (default: one curve of all samples).
    per_curve : mapping, optional
        Per-curve variables ``x``, ``y`` [m], ``spring_constant`` [N/m], ``sensitivity`` [m/V],
        and the coordinates of a map's grid ``row``, ``column`` (integers) and ``x_raw``,
        ``y_raw`` [m] (see the module docstring).
    attrs : mapping, optional
        File metadata (calibration, settings, path).
    source : str, optional
        ``attrs["source"]``: the instrument format.

    Returns
    -------
    xarray.Dataset
        Valid under :func:`validate_curves`.
    """
    t = CURVES_VARIABLES
    source = as_text("source", source, allow_none=True)
    per_curve = as_mapping("per_curve", per_curve)
    segment_names = as_names("segment_names", segment_names, unique=False)
    segment_types = as_names("segment_types", segment_types, unique=False)
    time = coordinate("time", time)
    n = time.shape
    values = {"force": force, "height": height, "deflection": deflection}
    data = {name: variable(shaped(name, v, n, _S), _S, t[name]) for name, v in values.items()}
    tip = -data["height"].values - data["deflection"].values if tip_position is None else tip_position
    data["tip_position"] = variable(shaped("tip_position", tip, n, _S), _S, t["tip_position"])
    seg = np.asarray(segment)
    data["segment"] = variable(np.broadcast_to(seg, n) if seg.ndim == 0 else seg, _S, t["segment"],
                               name="segment")
    counts = np.asarray([n[0]] if sample_count is None else sample_count)
    data["sample_count"] = variable(counts, _C, t["sample_count"], name="sample_count",
                                    attrs={"sample_dimension": "sample"})
    coords: dict[str, xr.Variable] = {"time": variable(time, _S, t["time"])}
    if not segment_names:
        raise SchemaError("segment_names must name at least one segment, e.g. ('other',)")
    coords["segment_name"] = variable(list(segment_names), _G, t["segment_name"])
    if segment_types is not None:
        coords["segment_type"] = variable(list(segment_types), _G, t["segment_type"])
    for name, v in per_curve.items():
        if name not in _PER_CURVE:
            raise SchemaError(f"per_curve variable {name!r} is not one of "
                              f"{', '.join(_PER_CURVE)}")
        if t[name].dtype == "i":  # grid indices: integers, not floats
            v = np.asarray(v)
            if v.shape != counts.shape:
                raise SchemaError(f"{name} must have shape {counts.shape} over {_C}, got "
                                  f"{v.shape}")
        else:
            v = shaped(name, v, counts.shape, _C)
        arr = variable(v, _C, t[name], name=name)
        (data if name in ("spring_constant", "sensitivity") else coords)[name] = arr
    meta = clean_attrs(attrs)
    if source is not None:
        meta["source"] = source
    return validate_curves(xr.Dataset(data, coords=coords, attrs=meta))


def validate_curves(ds: xr.Dataset, *, require: Iterable[str] | None = None,
                    curve: int | None = None) -> xr.Dataset:
    """Return ``ds`` if it is a curves dataset, else raise :class:`SchemaError`.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset to check.
    require : iterable of str, optional
        Variables that must be present (default: all per-sample ones, ``sample_count`` and
        ``segment_name``). Also checked: units, dtype, dims; the sample counts add up; segment
        indices lie in the table; names are among :data:`SEGMENT_NAMES`; time increases
        strictly within each curve.
    curve : int, optional
        Check the per-sample values (time, segment indices) of this curve only
        (:func:`curve_samples`), the rest of the structure whole: what a fit of one curve of a
        map reads.
    """
    require_dataset(ds, "curves")
    check_present(ds, "curves", CURVES_VARIABLES, require)
    check_variables(ds, "curves", CURVES_VARIABLES)
    variables = ds.variables  # their values without a DataArray each (a curve fit reads this)
    cut = slice(None)
    if curve is not None and "sample_count" in variables:
        cut = slice(*curve_samples(ds, curve)[:2])
    if "sample_count" in variables:
        counts = np.asarray(variables["sample_count"].values)
        if np.any(counts < 1) or counts.sum() != ds.sizes.get("sample", 0):
            raise SchemaError(f"curves: 'sample_count' {counts.tolist()} must be >= 1 and add up "
                              f"to the {ds.sizes.get('sample', 0)} samples")
        if "time" in variables:
            time = np.asarray(variables["time"].values[cut], dtype=float)
            back = time[1:] <= time[:-1]  # a step that does not increase (NaN: the next test)
            if cut == slice(None):
                back[np.cumsum(counts)[:-1] - 1] = False  # curve boundaries restart the clock
            if not np.isfinite(time).all() or back.any():
                raise SchemaError("curves: 'time' must be finite and strictly increasing within "
                                  "each curve")
    if "segment_name" in variables:
        names = [str(v) for v in np.asarray(variables["segment_name"].values).ravel()]
        unknown = sorted(set(names) - set(SEGMENT_NAMES))
        if unknown:
            raise SchemaError(f"curves: segment names {unknown} are not among {SEGMENT_NAMES} "
                              "(keep the file's own label in 'segment_type')")
        if "segment" in variables:
            seg = np.asarray(variables["segment"].values[cut])
            if seg.size and (seg.min() < 0 or seg.max() >= len(names)):
                raise SchemaError(f"curves: 'segment' indices must lie in [0, {len(names)}) "
                                  f"(the segment_table), got {seg.min()}..{seg.max()}")
    check_attrs(ds, "curves")
    return ds


def select_curve(ds: xr.Dataset, index: int) -> xr.Dataset:
    """The samples of curve ``index`` (negative counts from the end) as a one-curve dataset.

    The segment table is kept whole, so ``segment`` indices stay valid.
    """
    validate_curves(ds)
    start, stop, index = curve_samples(ds, index)
    return ds.isel(sample=slice(start, stop), curve=[index])


def curve_samples(ds: xr.Dataset, index: int) -> tuple[int, int, int]:
    """(start, stop, index ≥ 0): curve ``index``'s samples are ``sample`` start:stop.

    Of a curves dataset already validated (:func:`validate_curves`); what :func:`select_curve`
    cuts, for a reader that slices the arrays it needs itself.

    Raises
    ------
    ParameterError
        ``index`` is not an integer.
    SchemaError
        ``index`` is out of range (negative counts from the end).
    """
    counts = np.asarray(ds.variables["sample_count"].values)
    if isinstance(index, bool) or not isinstance(index, int | np.integer):
        raise ParameterError(f"curve index must be an integer, got {index!r}")
    if not -counts.size <= index < counts.size:
        raise SchemaError(f"curve index {index} out of range for {counts.size} curves")
    index = int(index) % counts.size
    start = int(counts[:index].sum())
    return start, start + int(counts[index]), index
