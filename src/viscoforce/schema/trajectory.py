"""Trajectory dataset: a simulated run over ``time``; profiles over (``profile_time``, ``r``)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from viscoforce.exceptions import SchemaError
from viscoforce.schema._core import (
    VariableSpec,
    as_names,
    check_attrs,
    check_present,
    check_variables,
    clean_attrs,
    coordinate,
    require_dataset,
    shaped,
    variable,
)
from viscoforce.schema.equilibrium import contact_radius_name

_T = ("time",)
_P = ("profile_time", "r")

TRAJECTORY_VARIABLES: dict[str, VariableSpec] = {
    "time": VariableSpec("s", "time", _T),
    "position": VariableSpec("m", "apex position h0", _T),
    "force": VariableSpec("N", "load F", _T),
    "u_center": VariableSpec("m", "central deformation u(0)", _T),
    "h_center": VariableSpec("m", "central gap h(0)", _T),
    "contact_radius": VariableSpec("m", "contact radius", _T),
    "profile_time": VariableSpec("s", "profile time", ("profile_time",), required=False),
    "r": VariableSpec("m", "radial coordinate", ("r",), required=False),
    "gap": VariableSpec("m", "local gap h(r, t)", _P, required=False),
    "deformation": VariableSpec("m", "deformation u(r, t)", _P, required=False),
    "pressure": VariableSpec("Pa", "pressure p(r, t)", _P, required=False),
}
#: The optional profile variables (the builder writes all or none of them).
PROFILE_VARIABLES = ("profile_time", "r", "gap", "deformation", "pressure")
_PROFILE_HINT = "(profiles are stored by simulate(..., profiles=N))"


def make_trajectory(time: ArrayLike, *, position: ArrayLike, force: ArrayLike,
                    u_center: ArrayLike, h_center: ArrayLike, contact_radius: ArrayLike,
                    contact_threshold: float, profile_time: ArrayLike | None = None,
                    r: ArrayLike | None = None, gap: ArrayLike | None = None,
                    deformation: ArrayLike | None = None, pressure: ArrayLike | None = None,
                    attrs: Mapping[str, Any] | None = None) -> xr.Dataset:
    """Build a trajectory dataset from plain arrays (SI).

    Parameters
    ----------
    time : array_like
        Output times [s], increasing.
    position, force, u_center, h_center, contact_radius : array_like
        Over ``time``: h0 [m], F [N], u(0) [m], h(0) [m], contact radius [m].
    contact_threshold : float
        Gap [m] defining the contact radius (named in its long_name).
    profile_time, r : array_like, optional
        Times [s] and radial nodes [m] of the stored profiles.
    gap, deformation, pressure : array_like, optional
        Profiles over (``profile_time``, ``r``): h [m], u [m], p [Pa]. Give all five profile
        arguments or none.
    attrs : mapping, optional
        Parameters, stepper settings and counters.

    Returns
    -------
    xarray.Dataset
        Valid under :func:`validate_trajectory`.
    """
    t = TRAJECTORY_VARIABLES
    time = coordinate("time", time)
    data = {name: variable(shaped(name, values, time.shape, _T), _T, t[name])
            for name, values in (("position", position), ("force", force),
                                 ("u_center", u_center), ("h_center", h_center))}
    data["contact_radius"] = variable(shaped("contact_radius", contact_radius, time.shape, _T), _T,
                                      t["contact_radius"],
                                      long_name=contact_radius_name(contact_threshold))
    coords = {"time": variable(time, _T, t["time"])}
    given = {"profile_time": profile_time, "r": r, "gap": gap, "deformation": deformation,
             "pressure": pressure}
    if any(v is not None for v in given.values()):
        absent = [n for n, v in given.items() if v is None]
        if absent:
            raise SchemaError(f"trajectory profiles need all of {list(PROFILE_VARIABLES)}; "
                              f"missing {absent}")
        pt, radius = coordinate("profile_time", profile_time), coordinate("r", r)
        coords["profile_time"] = variable(pt, ("profile_time",), t["profile_time"])
        coords["r"] = variable(radius, ("r",), t["r"])
        for name in ("gap", "deformation", "pressure"):
            data[name] = variable(shaped(name, given[name], pt.shape + radius.shape, _P), _P,
                                  t[name])
    ds = xr.Dataset(data, coords=coords, attrs=clean_attrs(attrs))
    return validate_trajectory(ds)


def validate_trajectory(ds: xr.Dataset, *, require: Iterable[str] | None = None) -> xr.Dataset:
    """Return ``ds`` if it is a trajectory dataset, else raise :class:`SchemaError`.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset to check.
    require : iterable of str, optional
        Variables that must be present; default the time series (``time``, ``position``,
        ``force``, ``u_center``, ``h_center``, ``contact_radius``). Add
        :data:`PROFILE_VARIABLES` to require profiles. Whatever is present is checked for units,
        dtype and dims; a profile needs its ``profile_time`` and ``r`` coordinates; times must
        increase.
    """
    require_dataset(ds, "trajectory")
    names = as_names("require", require)
    hint = _PROFILE_HINT if names is not None and set(names) & set(PROFILE_VARIABLES) else ""
    check_present(ds, "trajectory", TRAJECTORY_VARIABLES, names, hint)
    if any(n in ds.variables for n in ("gap", "deformation", "pressure")):
        check_present(ds, "trajectory", TRAJECTORY_VARIABLES, ("profile_time", "r"))
    check_variables(ds, "trajectory", TRAJECTORY_VARIABLES)
    for name in ("time", "profile_time"):
        values = np.asarray(ds[name].values) if name in ds.variables else np.zeros(0)
        if not np.all(np.isfinite(values)) or np.any(np.diff(values) <= 0):
            raise SchemaError(f"trajectory: '{name}' must be finite and strictly increasing")
    check_attrs(ds, "trajectory")
    return ds
