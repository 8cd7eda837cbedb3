"""The text of a fit's parameters on a plot: value ± stderr in a unit chosen for each value.

:func:`_parameter_text` is what :func:`viscoforce.plotting.bode_plot` and
:func:`viscoforce.plotting.fit_curve_plot` show in their parameter box.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from viscoforce.units import format_quantity, unit_factor

if TYPE_CHECKING:
    import xarray as xr

#: CF units of a fit parameter → the :func:`viscoforce.units.format_quantity` dimension.
_PARAMETER_DIMENSIONS = {"s": "time", "Pa": "pressure", "N/m": "stiffness", "N": "force",
                         "m": "length", "1": "dimensionless"}


def _quantity(value: float, err: float, unit: str) -> str:
    """``"1.020 ± 0.041 ms"``: value ± stderr in one display unit chosen for the value.

    The stderr keeps 2 significant digits and the value is rounded to the same decimal place;
    without a stderr the value keeps 3 significant digits. Units viscoforce cannot rescale
    (e.g. those of ``C1``) are shown in SI as stored, with a shared power of ten where the
    value is far from 1 (``"(1.50 ± 0.20)e-8 Pa-1 s-m"``).
    """
    dimension = _PARAMETER_DIMENSIONS.get(unit)
    if dimension is not None and np.isfinite(value):
        chosen = format_quantity(value, dimension).partition(" ")[2]
        factor = unit_factor(dimension, chosen) if chosen else 1.0
    else:
        chosen, factor = ("" if unit == "1" else unit), 1.0
    v, e = value / factor, err / factor
    if np.isfinite(v) and np.isfinite(e) and e > 0:
        exponent = int(np.floor(np.log10(abs(v)))) if v != 0 else 0
        exponent = 0 if -3 <= exponent < 4 else exponent  # else a shared power of ten
        v, e = v / 10.0**exponent, e / 10.0**exponent
        decimals = int(min(max(0, 1 - np.floor(np.log10(e))), 12))
        shown = f"{v:.{decimals}f} ± {e:.{decimals}f}"
        shown = f"({shown})e{exponent}" if exponent else shown
    elif np.isfinite(e):
        shown = f"{v:.3g} ± {e:.2g}"
    else:
        shown = f"{v:.3g}"
    text = f"{shown} {chosen}" if chosen else shown
    return text if np.isfinite(e) else f"{text} (no stderr)"


def _parameter_text(fit: xr.Dataset) -> str:
    """The fit's model, Young's moduli, each parameter, redchi (and non-convergence), the inputs.

    Young's moduli lead (``<name>_young``, issue 38 item 3: what people read first), under
    Poisson's ratio; the fitted parameters follow, their moduli labelled as the paper's
    convention (E = 2 E_young/(1 − ν²), twice Johnson's E*), then the shear moduli. A
    determined parameter reads value ± stderr; one the data bound on one side only reads as
    that bound (``E0 > 2.1 kPa``, Young's form converted alike); one they do not determine
    reads ``not determined`` (never a value with an error larger than itself). Last, what the
    moduli rest on: the tip, Poisson's ratio and the indentation, where the fit records them.
    """
    lines = [f"fit: {' '.join(str(fit.attrs[k]) for k in ('model', 'candidate') if k in fit.attrs)}"]
    names = [str(n) for n in fit["param_i"].values]
    codes = (np.asarray(fit["identifiability"].values).reshape(-1)
             if "identifiability" in fit.variables else np.zeros(len(names), dtype=int))
    code_of = {n: int(c) for n, c in zip(names, codes, strict=True)}
    young = [n for n in names if f"{n}_young" in fit.variables]
    nu = _poisson(fit, young)
    if young:
        lines.append(f"Young's modulus (nu = {nu:g}):")
        lines.extend(_line(fit, f"{n}_young", code_of[n], n, nu) for n in young)
        lines.append("fitted (paper's E = 2 E_young/(1 - nu^2)):")
    lines.extend(_line(fit, n, code_of[n]) for n in names)
    shear = [n for n in names if f"{n}_shear" in fit.variables]
    if shear:
        lines.append("shear modulus:")
        lines.extend(_line(fit, f"{n}_shear", code_of[n], n, nu) for n in shear)
    lines.append(f"redchi = {float(fit['redchi'].values):.3g}")
    if "chi2_pvalue" in fit.variables and np.isfinite(float(fit["chi2_pvalue"].values)):
        lines.append(f"p(chi2) = {float(fit['chi2_pvalue'].values):.2g}")
    if "success" in fit.variables and int(fit["success"].values) == 0:
        lines.append("(did not converge)")
    lines.extend(_caption_lines(fit.attrs))
    return "\n".join(lines)


def _poisson(fit: xr.Dataset, young: list[str]) -> float:
    """Poisson's ratio of the fit's Young's moduli (their attrs, else the fit's; default 0.5)."""
    for n in young:
        if "poisson" in fit[f"{n}_young"].attrs:
            return float(fit[f"{n}_young"].attrs["poisson"])
    return float(fit.attrs.get("poisson", 0.5))


def _line(fit: xr.Dataset, name: str, code: int, base: str | None = None,
          nu: float = 0.5) -> str:
    """One variable's line: ``name = value ± stderr``, its one-sided bound, or not determined.

    ``code`` is the identifiability of the fitted parameter ``base`` (``name`` itself when
    None) that ``name`` derives from; a bound of ``base`` is shown in ``name``'s form (Young's
    or shear modulus at Poisson's ratio ``nu``).
    """
    base = name if base is None else base
    unit = str(fit[name].attrs.get("units", fit[base].attrs.get("units", "")))
    limit = {1: ("lower", ">"), 2: ("upper", "<")}.get(code)
    if limit and f"{base}_{limit[0]}" in fit.variables and np.isfinite(
            float(fit[f"{base}_{limit[0]}"].values)):
        bound = _converted(float(fit[f"{base}_{limit[0]}"].values), name, base, nu)
        if bound is not None:
            shown = _quantity(bound, np.nan, unit).replace(" (no stderr)", "")
            return f"{name} {limit[1]} {shown} (bound only)"
        return f"{name} not determined"
    if code in (1, 2, 3):
        return f"{name} not determined"
    value = float(fit[name].values)
    err = float(fit[f"{name}_stderr"].values) if f"{name}_stderr" in fit.variables else np.nan
    return f"{name} = {_quantity(value, err, unit)}"


def _converted(bound: float, name: str, base: str, nu: float) -> float | None:
    """A bound of the paper's modulus ``base`` in the form of ``name`` (None: not a modulus)."""
    if name == base:
        return bound
    from viscoforce.exceptions import ParameterError
    from viscoforce.physics.moduli import shear_from_young, young_from_paper

    try:
        young = float(young_from_paper(bound, nu))
        return young if name.endswith("_young") else float(shear_from_young(young, nu))
    except ParameterError:
        return None


def _caption_lines(attrs: Mapping[str, Any]) -> list[str]:
    """The tip, Poisson's ratio and the indentation of a fit's attrs, one short line each."""
    out = []
    if "tip" in attrs:
        out.append(f"tip: {attrs['tip']}")
    if "poisson" in attrs:
        out.append(f"nu = {float(attrs['poisson']):g}")
    depth = attrs.get("indentation", attrs.get("mean_indentation"))
    if depth is not None and np.isfinite(float(depth)):
        out.append(f"indentation {format_quantity(float(depth), 'length')}")
    return out
