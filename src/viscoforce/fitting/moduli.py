"""The field's moduli: Young's and shear moduli derived from the paper's E, fits and maps alike.

``<name>_young`` and ``<name>_shear`` (with their stderr) of every paper-convention modulus.

The paper's E is 2/E = Σ(1 − ν_i²)/E_i, twice Johnson's E*; the conversions are
:func:`viscoforce.physics.tips.young_from_paper` and :func:`~viscoforce.physics.tips.shear_from_young`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.fitting.report import carry
from viscoforce.schema import parameter_names, plain_variable

#: Fitted quantities in the paper's modulus convention (2/E = Σ(1 − ν²)/E_i), by name pattern:
#: moduli [Pa] and the structural viscosity μ [Pa s] (an E-like coefficient of iω).
PAPER_CONVENTION = re.compile(r"E0|E_inf|E_\d+|E_ref|E|mu")


def add_derived_moduli(ds: xr.Dataset, poisson: float | None = None) -> xr.Dataset:
    """``<name>_young`` and ``<name>_shear`` (with ``_stderr``) of every paper-convention modulus.

    Young's modulus Y = E(1 − ν²)/2 (a rigid tip; the paper's E is twice Johnson's E*) and the
    shear modulus G = Y/(2(1 + ν)); both linear in E, so the stderr convert the same way. At
    ν = 0.5, E = 8/3 Y = 8 G. Works on a single fit or a map (elementwise).

    Parameters
    ----------
    ds : xarray.Dataset
        A fit result.
    poisson : float, optional
        The sample's Poisson's ratio ν in [0, 0.5] (default 0.5, incompressible; recorded in
        ``attrs["poisson"]``).

    Returns
    -------
    xarray.Dataset
        ``ds`` with the derived variables.
    """
    from viscoforce.physics.tips import DEFAULT_POISSON

    nu = DEFAULT_POISSON if poisson is None else poisson
    names = parameter_names(ds)
    if ds.attrs.get("poisson") == nu and all(
            f"{n}_young" in ds.variables for n in names if PAPER_CONVENTION.fullmatch(n)):
        return ds  # already derived at this ν (result_dataset derives at the default)
    variables = ds.variables
    result = carry(ds, ds.assign(derived_variables(
        {n: (variables[n], variables[f"{n}_stderr"]) for n in names}, nu)))
    result.attrs.update(derived_attrs(nu))
    return result


def derived_variables(params: Mapping[str, tuple[Any, Any]], nu: float
                      ) -> dict[str, xr.Variable]:
    """``<name>_young``, ``<name>_shear`` and their ``_stderr`` of each paper-convention modulus.

    ``params``: name → (value, stderr) as :class:`xarray.Variable` (a map) or floats (one fit,
    units from :func:`viscoforce.schema.fit.parameter_units`). ν is validated here (the message
    names its range).
    """
    from viscoforce.physics.tips import shear_from_young, young_from_paper
    from viscoforce.schema.fit import parameter_units

    young_from_paper(1.0, nu)  # validates ν (the message names the range)
    nu = float(nu)
    out = {}
    for name, pair in params.items():
        if not PAPER_CONVENTION.fullmatch(name):
            continue
        first = pair[0]
        unit = (str(first.attrs.get("units", "Pa")) if isinstance(first, xr.Variable)
                else parameter_units(name))
        kind = "viscosity" if name == "mu" else "modulus"
        converted = {}
        for tail, source in zip(("", "_stderr"), pair, strict=True):
            if source is None or isinstance(source, float):  # one fit: arithmetic
                value = math.nan if source is None else source
                if math.isinf(value) or value < 0:
                    young_from_paper(value, nu)  # raises (the message says how)
                young = value * (1.0 - nu * nu) / 2.0  # the same operations, in that order
                converted[tail] = (), {"young": young, "shear": young / (2.0 * (1.0 + nu))}
                continue
            dims = source.dims if isinstance(source, xr.Variable) else ()
            values = np.asarray(source.values if isinstance(source, xr.Variable) else source,
                                dtype=float)
            young = young_from_paper(values, nu)  # checks the values (the message says how)
            converted[tail] = dims, {"young": young, "shear": shear_from_young(young, nu)}
        for suffix, what in (("young", "Young's"), ("shear", "shear")):
            for tail, (dims, moduli) in converted.items():
                value = moduli[suffix]
                out[f"{name}_{suffix}{tail}"] = plain_variable(
                    dims, value if dims else float(value), {
                        "units": unit, "poisson": float(nu),
                        "long_name": f"{'standard error of ' if tail else ''}{what} {kind} "
                                     f"from {name} (nu = {nu:g})"})
    return out


def derived_attrs(nu: float) -> dict[str, Any]:
    """The dataset attributes that go with :func:`derived_variables`."""
    return {"poisson": float(nu), "modulus_convention": (
        "E (and E0, E_inf, E_i, E_ref, mu) is the paper's: 2/E = sum (1 - nu_i^2)/E_i, twice "
        "Johnson's E*; <name>_young = E (1 - nu^2)/2, <name>_shear = <name>_young/(2 (1 + nu))")}
