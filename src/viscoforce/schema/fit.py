"""Fit-result dataset: what ``fit --out`` writes (parameters, stderr, correlations, statistics).

One fit has scalar parameters; fits over a map are the same variables over the data's extra dims
(``xr.concat`` of single results along a new dim gives a valid result). Everything is numeric:
``success`` is int8 0/1 (netCDF3 has no bool), the parameter names are the ``param_i`` and
``param_j`` coordinates of ``correlation``.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from viscoforce.exceptions import SchemaError
from viscoforce.schema._core import (
    EXTRA,
    VariableSpec,
    as_flag,
    as_mapping,
    as_text,
    assemble,
    check_attrs,
    check_flags,
    check_one,
    check_present,
    check_variables,
    clean_attrs,
    coordinate,
    flag_attrs,
    plain_variable,
    require_dataset,
    shaped,
    variable,
)

FIT_VARIABLES: dict[str, VariableSpec] = {
    "correlation": VariableSpec("1", "correlation of the fitted parameters",
                                (EXTRA, "param_i", "param_j")),
    "success": VariableSpec("", "fit converged", (EXTRA,), "i"),
    "redchi": VariableSpec("1", "reduced chi-square", (EXTRA,)),
    "aic": VariableSpec("1", "Akaike information criterion", (EXTRA,)),
    "bic": VariableSpec("1", "Bayesian information criterion", (EXTRA,)),
    "modes": VariableSpec("1", "number of relaxation modes", (EXTRA,), "i"),
    "chi2_pvalue": VariableSpec("1", "chi-square goodness-of-fit p-value (NaN: stderr unknown)",
                                (EXTRA,), required=False),
    "identifiability": VariableSpec("", "identifiability of the fitted parameter",
                                    (EXTRA, "param_i"), "i", required=False),
    "quality": VariableSpec("", "quality of the pixel's fit", (EXTRA,), "i", required=False),
    "omega": VariableSpec("rad/s", "angular frequency", ("omega",), required=False),
    "fit_stiffness": VariableSpec("N/m", "best-fit dynamic stiffness", (EXTRA, "omega"),
                                  required=False),
    "fit_phase": VariableSpec("degree", "best-fit phase", (EXTRA, "omega"), required=False),
    "time": VariableSpec("s", "time", ("time",), required=False),
    "fit_force": VariableSpec("N", "best-fit force", (EXTRA, "time"), required=False),
    "fit_tip_position": VariableSpec("m", "best-fit tip position toward the sample",
                                     (EXTRA, "time"), required=False),
    "tip_position": VariableSpec("m", "tip position toward the sample", ("tip_position",),
                                 required=False),
    "fit_approach_force": VariableSpec("N", "best-fit force over the approach",
                                       (EXTRA, "tip_position"), required=False),
}
#: ``success`` flag codes.
SUCCESS_FLAGS: dict[int, str] = {0: "failed", 1: "succeeded"}

#: Units of the SPEC's parameter names (``E_2``, ``tau_3``, … by pattern); others need ``units=``.
PARAMETER_UNITS: dict[str, str] = {"tau": "s", "E0": "Pa", "E_inf": "Pa", "k_inf": "N/m",
                                   "F_inf": "N", "C1": "Pa-1 s-m", "m": "1",
                                   "E_ref": "Pa", "alpha": "1", "mu": "Pa s", "E": "Pa",
                                   "contact_point": "m", "baseline": "N",
                                   "baseline_slope": "N/m", "z_inf": "m", "drag": "N s/m",
                                   "ting_E0": "Pa", "beta": "1"}
_PATTERNS = ((r"tau_\d+", "s"), (r"E_\d+", "Pa"), (r"dk_\d+", "N/m"), (r"dF_\d+", "N"),
             (r"dz_\d+", "m"))


def parameter_units(name: str, units: Mapping[str, str] | None = None) -> str:
    """Units of fit parameter ``name`` (``units`` overrides :data:`PARAMETER_UNITS`)."""
    units = as_mapping("units", units)
    if name in units:
        if not isinstance(units[name], str):
            raise SchemaError(f"units[{name!r}] must be a unit string, got {units[name]!r}")
        return units[name]
    if name in PARAMETER_UNITS:
        return PARAMETER_UNITS[name]
    for pattern, unit in _PATTERNS:
        if re.fullmatch(pattern, name):
            return unit
    raise SchemaError(f"no units known for fit parameter {name!r}; give units={{{name!r}: ...}}")


def make_fit_result(params: Mapping[str, tuple[float, float | None]], *,
                    correlation: ArrayLike | None = None, success: bool, redchi: float,
                    aic: float, bic: float, modes: int, model: str,
                    omega: ArrayLike | None = None, fit_stiffness: ArrayLike | None = None,
                    fit_phase: ArrayLike | None = None, time: ArrayLike | None = None,
                    fit_force: ArrayLike | None = None, fit_tip_position: ArrayLike | None = None,
                    tip_position: ArrayLike | None = None,
                    fit_approach_force: ArrayLike | None = None,
                    units: Mapping[str, str] | None = None,
                    attrs: Mapping[str, Any] | None = None,
                    extra: Mapping[str, xr.Variable | xr.DataArray] | None = None,
                    fresh_extra: bool = False, check: bool = True) -> xr.Dataset:
    """Build the result of one fit.

    Parameters
    ----------
    params : mapping
        Parameter name → (value, stderr) in SI; stderr None (not estimated) is stored as NaN.
    correlation : array_like, optional
        Correlation matrix in the order of ``params``; default NaN off the diagonal (unknown).
    success : bool
        Whether the fit converged (stored as int8 0/1).
    redchi, aic, bic : float
        Reduced chi-square and information criteria.
    modes : int
        Number of relaxation modes of the model.
    model : str
        Model name (``attrs["model"]``, e.g. ``"svda"``).
    omega, fit_stiffness, fit_phase : array_like, optional
        Best-fit spectrum: ω [rad/s], stiffness [N/m], phase [degree].
    time, fit_force : array_like, optional
        Best-fit force curve (relaxation, step models): t [s], F [N].
    fit_tip_position : array_like, optional
        Best-fit tip position [m] over ``time`` (creep model).
    tip_position, fit_approach_force : array_like, optional
        Best-fit approach (hertz model): tip position toward the sample [m], F [N].
    units : mapping, optional
        Units of parameters not in :data:`PARAMETER_UNITS`.
    attrs : mapping, optional
        Fixed inputs (position or mean force, geometry) and the data's provenance.
    extra : mapping, optional
        More variables (statistics, limits, derived moduli) put into the same dataset, over
        its dims; checked with the rest.
    fresh_extra : bool
        The ``extra`` Variables were made for this result: they are taken over, not copied
        (the fitting code's own; a caller's variables are copied by default, so that the
        result's attributes stay apart from them).
    check : bool
        Validate the dataset (:func:`validate_fit_result`). The fitting code passes False for
        the results it assembles from checked pieces; ``tests/schema/test_schema_assemble.py``
        validates every model's result instead.

    Returns
    -------
    xarray.Dataset
        Valid under :func:`validate_fit_result`.
    """
    names = list(as_mapping("params", params))
    bad = [n for n in names if not isinstance(n, str)]
    if bad:
        raise SchemaError(f"fit parameter names must be strings, got {bad[0]!r}")
    success = as_flag("success", success)
    model = as_text("model", model)
    if not names:
        raise SchemaError("a fit result needs at least one parameter")
    clash = sorted(set(names) & (set(FIT_VARIABLES) | {"param_i", "param_j"}))
    if clash:
        raise SchemaError(f"fit parameter names {clash} clash with fit-result variables")
    data: dict[str, xr.Variable | xr.DataArray] = {}
    for name in names:
        try:
            value, err = params[name]
        except (TypeError, ValueError):
            raise SchemaError(f"params[{name!r}] must be (value, stderr), got {params[name]!r}"
                              ) from None
        spec = VariableSpec(parameter_units(name, units), f"fitted parameter {name}", ())
        data[name] = variable(shaped(name, value, (), ()), (), spec)
        data[f"{name}_stderr"] = variable(shaped(f"{name}_stderr", np.nan if err is None else err,
                                                 (), ()), (), spec,
                                          long_name=f"standard error of {name}")
    n = len(names)
    corr = np.where(np.eye(n, dtype=bool), 1.0, np.nan) if correlation is None else correlation
    t = FIT_VARIABLES
    pair = ("param_i", "param_j")
    data["correlation"] = variable(shaped("correlation", corr, (n, n), pair), pair,
                                   t["correlation"])
    data["success"] = plain_variable((), np.int8(success), {
        "long_name": t["success"].long_name, **flag_attrs(SUCCESS_FLAGS)})
    for name, value in (("redchi", redchi), ("aic", aic), ("bic", bic)):
        data[name] = variable(shaped(name, value, (), ()), (), t[name])
    data["modes"] = variable(modes, (), t["modes"], name="modes")
    coords: dict[str, Any] = {"param_i": ("param_i", names), "param_j": ("param_j", names)}
    axes = {"omega": omega, "time": time, "tip_position": tip_position}
    for axis, curves in (("omega", {"fit_stiffness": fit_stiffness, "fit_phase": fit_phase}),
                         ("time", {"fit_force": fit_force, "fit_tip_position": fit_tip_position}),
                         ("tip_position", {"fit_approach_force": fit_approach_force})):
        x = axes[axis]
        if x is None:
            if any(v is not None for v in curves.values()):
                raise SchemaError(f"a best-fit curve over {axis!r} needs {axis}=")
            continue
        x = coordinate(axis, x)
        coords[axis] = variable(x, (axis,), t[axis])
        for name, v in curves.items():
            if v is not None:
                data[name] = variable(shaped(name, v, x.shape, (axis,)), (axis,), t[name])
    fresh = set(data) | set(coords)  # made here; the caller's extra variables are copied
    if as_flag("fresh_extra", fresh_extra):
        fresh |= set(as_mapping("extra", extra))
    for name, v in as_mapping("extra", extra).items():
        if name in data or name in coords:
            raise SchemaError(f"extra variable {name!r} clashes with a fit-result variable")
        data[name] = v
    meta = clean_attrs(attrs)
    meta["model"] = model
    ds = assemble(data, coords, meta, fresh=fresh)
    return validate_fit_result(ds) if as_flag("check", check) else ds


def validate_fit_result(ds: xr.Dataset, *, require: Iterable[str] | None = None) -> xr.Dataset:
    """Return ``ds`` if it is a fit result, else raise :class:`SchemaError`.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset to check.
    require : iterable of str, optional
        Variables that must be present (default ``correlation``, ``success``, ``redchi``,
        ``aic``, ``bic``, ``modes``). Also checked: ``attrs["model"]``; every name of
        ``param_i`` has ``<name>`` and ``<name>_stderr`` over the extra dims with the same units;
        ``success`` is a 0/1 flag, and the optional ``identifiability`` (over the extra dims and
        ``param_i``) and ``quality`` (a map's per-pixel code) are CF flags; units and dims of
        everything known.
    """
    require_dataset(ds, "fit result")
    if not isinstance(ds.attrs.get("model"), str):
        raise SchemaError("fit result has no attrs['model'] (the model name)")
    check_present(ds, "fit result", FIT_VARIABLES, require)
    variables = ds.variables
    extra = tuple(str(d) for d in variables["success"].dims) if "success" in variables else ()
    check_variables(ds, "fit result", FIT_VARIABLES, extra)
    if "correlation" in ds.variables:
        if "param_i" not in ds.coords or "param_j" not in ds.coords:
            raise SchemaError("fit result: 'correlation' needs the param_i and param_j "
                              "coordinates (the parameter names)")
        names = [str(v) for v in variables["param_i"].values]
        if names != [str(v) for v in variables["param_j"].values]:
            raise SchemaError("fit result: param_i and param_j must list the same parameters")
        for name in names:
            check_present(ds, "fit result", {}, (name, f"{name}_stderr"))
            unit = variables[name].attrs.get("units")
            if not isinstance(unit, str) or not unit:
                raise SchemaError(f"fit result: parameter '{name}' has no units")
            spec = VariableSpec(unit, "", (EXTRA,))
            check_one(ds, "fit result", name, spec, extra)
            check_one(ds, "fit result", f"{name}_stderr", spec, extra)
    for name in ("success", "identifiability", "quality"):
        if name in ds.variables:
            check_flags(ds, "fit result", name)
    check_attrs(ds, "fit result")
    return ds
