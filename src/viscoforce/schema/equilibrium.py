"""Equilibrium dataset: one static elastic state (``static_equilibrium``), profiles over ``r``."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import xarray as xr
from numpy.typing import ArrayLike

from viscoforce.exceptions import SchemaError
from viscoforce.schema._core import (
    VariableSpec,
    as_float,
    check_attrs,
    check_present,
    check_variables,
    clean_attrs,
    coordinate,
    require_dataset,
    require_values,
    shaped,
    variable,
)

#: Sign convention written into every equilibrium's attrs.
SIGN_CONVENTION = "u < 0 is flattening; gap = h0 + r^2/2R - u; force > 0 repels"

_R = ("r",)

EQUILIBRIUM_VARIABLES: dict[str, VariableSpec] = {
    "r": VariableSpec("m", "radial coordinate", _R),
    "gap": VariableSpec("m", "local surface separation h(r)", _R),
    "deformation": VariableSpec("m", "surface deformation u(r)", _R),
    "pressure": VariableSpec("Pa", "surface pressure p(h(r))", _R),
    "undeformed_gap": VariableSpec("m", "undeformed separation h0 + r^2/2R", _R),
    "position": VariableSpec("m", "apex position h0", ()),
    "force": VariableSpec("N", "load F", ()),
    "force_rigid": VariableSpec("N", "load between rigid bodies", ()),
    "u_center": VariableSpec("m", "central deformation u(0)", ()),
    "h_center": VariableSpec("m", "central gap h(0)", ()),
    "contact_radius": VariableSpec("m", "contact radius", ()),
}


def contact_radius_name(threshold: float) -> str:
    """long_name of a contact radius defined by the gap ``threshold`` [m] (finite, >= 0)."""
    value = require_values("contact_threshold", as_float("contact_threshold", threshold),
                           minimum=0.0)
    if value.ndim:
        raise SchemaError(f"contact_threshold must be a single number [m], got shape "
                          f"{value.shape}")
    threshold = float(value)
    return f"radius where the gap < {threshold:g} m"


def make_equilibrium(r: ArrayLike, *, gap: ArrayLike, deformation: ArrayLike,
                     pressure: ArrayLike, undeformed_gap: ArrayLike, position: float,
                     force: float, force_rigid: float, u_center: float, h_center: float,
                     contact_radius: float, contact_threshold: float,
                     attrs: Mapping[str, Any] | None = None) -> xr.Dataset:
    """Build an equilibrium dataset from plain arrays and floats (SI).

    Parameters
    ----------
    r : array_like
        Radial nodes [m].
    gap, deformation, pressure, undeformed_gap : array_like
        Profiles over ``r``: h(r) [m], u(r) [m], p(h(r)) [Pa], h0 + r²/2R [m].
    position, force, force_rigid, u_center, h_center, contact_radius : float
        h0 [m], F [N], rigid load [N], u(0) [m], h(0) [m], contact radius [m].
    contact_threshold : float
        Gap [m] defining the contact radius (named in its long_name).
    attrs : mapping, optional
        Parameters; ``sign_convention`` is added unless given.

    Returns
    -------
    xarray.Dataset
        Valid under :func:`validate_equilibrium`.
    """
    t = EQUILIBRIUM_VARIABLES
    r = coordinate("r", r)
    data = {}
    for name, values in (("gap", gap), ("deformation", deformation), ("pressure", pressure),
                         ("undeformed_gap", undeformed_gap)):
        data[name] = variable(shaped(name, values, r.shape, _R), _R, t[name])
    for name, value in (("position", position), ("force", force), ("force_rigid", force_rigid),
                        ("u_center", u_center), ("h_center", h_center)):
        data[name] = variable(shaped(name, value, (), ()), (), t[name])
    data["contact_radius"] = variable(shaped("contact_radius", contact_radius, (), ()), (),
                                      t["contact_radius"],
                                      long_name=contact_radius_name(contact_threshold))
    out = clean_attrs(attrs)
    out.setdefault("sign_convention", SIGN_CONVENTION)
    ds = xr.Dataset(data, coords={"r": variable(r, _R, t["r"])}, attrs=out)
    return validate_equilibrium(ds)


def validate_equilibrium(ds: xr.Dataset, *, require: Iterable[str] | None = None) -> xr.Dataset:
    """Return ``ds`` if it is an equilibrium dataset, else raise :class:`SchemaError`.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset to check.
    require : iterable of str, optional
        Variables that must be present (default: all of :data:`EQUILIBRIUM_VARIABLES`); those
        present are always checked for units, dtype and dims.
    """
    require_dataset(ds, "equilibrium")
    check_present(ds, "equilibrium", EQUILIBRIUM_VARIABLES, require)
    check_variables(ds, "equilibrium", EQUILIBRIUM_VARIABLES)
    check_attrs(ds, "equilibrium")
    return ds
