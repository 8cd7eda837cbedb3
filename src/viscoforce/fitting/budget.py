"""The systematic error budget of a fit: what the choices the data do not settle do to each number.

A fit's stderr covers the noise only. Beside it, every parameter carries the *shift* it takes
when a choice the data do not settle is made the other way, one per source (issue 37 item 1):

- ``spring_constant``, ``sensitivity``: the force scale. Every force is k·s·V, so a relative
  error ε in k (thermal calibration: ±10 % is the field's usual figure) or in the deflection
  sensitivity s (±5 % for a sensitivity from a hard-surface ramp) scales every parameter in
  newtons or pascals by 1 + ε, to first order (the deflection's share of the indentation,
  smaller than the indentation itself on a soft sample, is neglected);
- ``tip``: the tip's size (a radius R or tan of a half-angle, ±10 % by default): a modulus
  scales as R^(−1/2) (sphere, paraboloid), 1/tan θ (cone, pyramid) or 1/a (flat punch),
  the power of the size in the tip's force shape (:mod:`viscoforce.physics.tips`);
- ``poisson``: Poisson's ratio of the sample (0.5 − 0.05 by default) moves the Young's and shear
  moduli, not the paper's E;
- ``height_record``, ``phase_reference``, ``model``: a refit with the other choice (the sensor
  or the piezo height; the sensor's own phase instead of the piezo or a fitted delay; another
  model within ΔBIC 6), given as the other fit's values (:func:`alternative_shifts`);
- ``fit_window``: a refit without the fitted window's last quarter (the top quarter of a
  spectrum's log-frequency span; the last quarter in time of a curve's fitted samples:
  :func:`viscoforce.fitting.budget_choices.narrowed_window`);
- ``contact_point``: a refit with the contact point held where the approach rises above its
  noise instead of fitted (:func:`viscoforce.fitting.budget_choices.other_contact_point`);
- ``sample_height``: a refit with the layer 10 % thicker (the bottom-effect correction's input,
  ±10 % from a topography step by default; mirrored like the calibration sources).

Each shift is the signed change of the parameter (its own unit); the calibration shifts are
those of the + direction (their − direction is the mirror to first order). The total interval
(:func:`add_budget`) is the envelope of the estimates under every choice, each widened by 2
stderr. A parameter that a choice moves by more than 2 stderr gets one sentence naming the
choice; one whose total interval spans more than a factor 2 (or 0.1 in an exponent) is *not
determined by these data*, reported with its range.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError

__all__ = ["CALIBRATION_DEFAULTS", "EXPONENTS", "add_budget", "add_map_budget",
           "alternative_shifts", "calibration_descriptions", "calibration_factors",
           "calibration_shifts", "check_uncertainties"]

#: Relative uncertainties used where the user gives none: (value, where the figure comes from).
CALIBRATION_DEFAULTS: dict[str, tuple[float, str]] = {
    "spring_constant": (0.10, "thermal-noise calibration, the field's usual +-10 %"),
    "sensitivity": (0.05, "deflection sensitivity from a hard-surface ramp, +-5 %"),
    "tip": (0.10, "nominal tip radius or half-angle tangent, +-10 %"),
    "poisson": (0.05, "Poisson's ratio 0.5 of a near-incompressible sample, -0.05"),
    "sample_height": (0.10, "the layer's thickness from a topography step, +-10 %"),
}
#: Parameters that are exponents (their spread is judged in absolute terms, 0.1).
EXPONENTS = ("alpha", "beta", "m")
#: Parameters that describe the instrument, not the sample: budgeted, not told in sentences.
NUISANCE = ("baseline", "baseline_slope", "contact_point", "F_inf", "z_inf", "drag")
#: How a source reads in a sentence ("moves ... with the <label>").
LABELS = {"spring_constant": "spring constant", "sensitivity": "deflection sensitivity",
          "tip": "tip size", "poisson": "Poisson's ratio", "height_record": "height record",
          "phase_reference": "phase reference", "fit_window": "fit window",
          "contact_point": "contact point method", "sample_height": "sample height",
          "model": "model among the near-ties"}
#: Sources given as the + direction of a ± uncertainty: their − direction mirrors them.
_MIRRORED = ("spring_constant", "sensitivity", "tip", "sample_height")
#: A choice that moves a parameter by more than this many stderr is said to.
SAY_Z = 2.0
#: A total interval wider than this factor (positive parameters) is "not determined".
FACTOR = 2.0
#: ... or wider than this for an exponent.
EXPONENT_SPAN = 0.1


def check_uncertainties(given: Mapping[str, Any] | None) -> dict[str, float]:
    """The relative uncertainties: the defaults, replaced by ``given`` (each in [0, 1))."""
    out = {k: v for k, (v, _) in CALIBRATION_DEFAULTS.items()}
    for key, value in (given or {}).items():
        if key not in out:
            raise ParameterError(f"uncertainties: {key!r} is not a calibration source; the "
                                 f"sources: {', '.join(out)}")
        try:
            v = float(value)
        except (TypeError, ValueError):
            v = math.nan
        if not 0.0 <= v < 1.0:
            raise ParameterError(f"uncertainties[{key!r}] must be a relative uncertainty in "
                                 f"[0, 1), got {value!r}")
        out[key] = v
    return out


def _parameters(ds: xr.Dataset) -> list[str]:
    return [str(n) for n in ds["param_i"].values] if "param_i" in ds else []


def _derived(ds: xr.Dataset) -> list[str]:
    return [str(n) for n in ds.data_vars if str(n).endswith(("_young", "_shear"))
            or str(n) in ("ting_E0", "beta")]


def _reading_order(ds: xr.Dataset) -> list[str]:
    """The parameters and derived moduli in the order people read them.

    Each modulus' Young's value first, then the paper's, then the shear modulus (issue 38 item 3).
    """
    derived = _derived(ds)
    out: list[str] = []
    for name in _parameters(ds):
        out += [n for n in (f"{name}_young", name, f"{name}_shear") if n == name or n in derived]
    return out + [n for n in derived if n not in out]


def _unit(ds: xr.Dataset, name: str) -> str:
    return str(ds[name].attrs.get("units", ""))


def _force_like(unit: str) -> bool:
    """A quantity proportional to the force scale: its unit has newtons or pascals."""
    words = unit.replace("*", " ").replace("/", " ").replace(".", " ").split()
    return any(w.split("^")[0] in ("N", "Pa") for w in words)


def _modulus_like(unit: str) -> bool:
    """A modulus or a viscosity (the tip's size enters it): Pa or Pa s."""
    return unit.split(" ")[0] in ("Pa",) or unit.startswith("Pa")


def _tip_exponent(ds: xr.Dataset) -> float | None:
    """The power of the tip's size a modulus scales with (None: no tip recorded)."""
    shape = str(ds.attrs.get("tip_shape", ""))
    return {"sphere": -0.5, "paraboloid": -0.5, "cone": -1.0, "pyramid": -1.0,
            "flat": -1.0}.get(shape)


def calibration_factors(ds: xr.Dataset, uncertainties: Mapping[str, float] | None = None
                        ) -> dict[str, dict[str, float]]:
    """{source: {parameter: relative shift}} of the calibration sources, first order.

    Sources that do not apply are left out: ``tip`` without a recorded tip shape, ``poisson``
    without Young's moduli.
    """
    rel = check_uncertainties(uncertainties)
    names = _parameters(ds) + _derived(ds)
    out: dict[str, dict[str, float]] = {}
    for source in ("spring_constant", "sensitivity"):
        out[source] = {n: rel[source] for n in names if _force_like(_unit(ds, n))}
    power = _tip_exponent(ds)
    if power is not None:
        out["tip"] = {n: (1.0 + rel["tip"]) ** power - 1.0 for n in names
                      if _modulus_like(_unit(ds, n))}
    if any(n.endswith(("_young", "_shear")) for n in names):
        nu = float(ds.attrs.get("poisson", 0.5))
        other = max(nu - rel["poisson"], 0.0)
        young = (1.0 - other ** 2) / (1.0 - nu ** 2) - 1.0
        shear = (1.0 + young) * (1.0 + nu) / (1.0 + other) - 1.0  # G = E_Y / 2(1 + nu)
        out["poisson"] = {n: young if n.endswith("_young") else shear for n in names
                          if n.endswith(("_young", "_shear"))}
    return {k: v for k, v in out.items() if v}


def calibration_shifts(ds: xr.Dataset, uncertainties: Mapping[str, float] | None = None
                       ) -> dict[str, dict[str, float]]:
    """{source: {parameter: shift}} of the calibration sources (module docstring), first order.

    Sources that do not apply are left out: ``tip`` without a recorded tip shape, ``poisson``
    without Young's moduli.
    """
    return {source: {n: float(ds[n]) * f for n, f in row.items() if ds[n].size == 1}
            for source, row in calibration_factors(ds, uncertainties).items()}


def calibration_descriptions(uncertainties: Mapping[str, float] | None = None
                             ) -> dict[str, str]:
    """{source: what was assumed}, with the relative uncertainty used and where it comes from."""
    rel = check_uncertainties(uncertainties)
    given = set(uncertainties or ())
    return {k: f"+-{100 * rel[k]:.3g} %" + (" (given)" if k in given else
                                           f" ({CALIBRATION_DEFAULTS[k][1]})")
            for k in CALIBRATION_DEFAULTS}


def alternative_shifts(ds: xr.Dataset, other: xr.Dataset, *, where: Any = None
                       ) -> dict[str, Any]:
    """{parameter: other's value − this one's} over the parameters both fits report.

    Single fits give floats (a non-finite difference is left out); maps give the difference
    per pixel (NaN where either failed, or where ``where`` — a boolean per pixel — is False).
    """
    out: dict[str, Any] = {}
    for n in _parameters(ds) + _derived(ds):
        if n not in other:
            continue
        if ds[n].size == 1 and other[n].size == 1:
            a, b = float(ds[n]), float(other[n])
            if math.isfinite(a) and math.isfinite(b):
                out[n] = b - a
        elif ds[n].dims == other[n].dims and ds[n].shape == other[n].shape:
            diff = other[n].drop_vars(list(other[n].coords)) - ds[n].drop_vars(
                list(ds[n].coords))
            diff = diff.assign_coords({d: ds[n][d] for d in ds[n].dims if d in ds[n].coords})
            out[n] = diff if where is None else diff.where(where)
    return out


def _undetermined(name: str, value: Any, lo: Any, hi: Any) -> Any:
    """Whether the total interval leaves the parameter not determined by the data.

    An exponent's interval wider than 0.1; a positive quantity's (a modulus, a time, a
    viscosity: not an instrument's offset) wider than a factor 2 or reaching zero. Scalars or
    arrays (a map's pixels) alike.
    """
    if name in EXPONENTS:
        return (hi - lo) > EXPONENT_SPAN
    if name in NUISANCE:
        return np.zeros(np.shape(value), dtype=bool)
    return (value > 0) & ((lo <= 0) | (hi > FACTOR * lo))


def _unidentified(ds: xr.Dataset, name: str, value: xr.DataArray) -> np.ndarray:
    """Where the fit's own identifiability test says ``name`` is not determined (code ≠ 0).

    A one-sided or flat profile (or a local stderr > |value|) is never "determined" by the
    budget, however narrow its calibration shifts (issue 37 item 4). A derived modulus
    (``E0_young``) follows its parameter's code; instrument parameters are judged by their own
    rule (:data:`NUISANCE`) and pass.
    """
    base = name.removesuffix("_young").removesuffix("_shear")
    if base == "ting_E0":
        base = "E0"
    none = np.zeros(value.shape, dtype=bool)
    if "identifiability" not in ds or base in NUISANCE or "param_i" not in ds[
            "identifiability"].dims or base not in [str(n) for n in ds["param_i"].values]:
        return none
    code = ds["identifiability"].sel(param_i=base, drop=True)
    if set(code.dims) != set(value.dims):
        return none
    return (code.transpose(*value.dims).values != 0) & np.isfinite(value.values)


def _merged(ds: xr.Dataset, shifts: Mapping[str, Mapping[str, Any]],
            descriptions: Mapping[str, str] | None
            ) -> tuple[dict[str, dict[str, Any]], dict[str, str]]:
    """The budget ``ds`` already carries, with ``shifts`` added (a source given again replaces)."""
    old: dict[str, dict[str, Any]] = {}
    text: dict[str, str] = {}
    if "budget_source" in ds.coords:
        names = [str(s) for s in ds["budget_source"].values]
        for var in ds.data_vars:
            if str(var).endswith("_systematic"):
                param = str(var)[:-len("_systematic")]
                for s in names:
                    old.setdefault(s, {})[param] = ds[var].sel(budget_source=s, drop=True)
        for part in str(ds.attrs.get("budget_sources", "")).split("; "):
            key, sep, what = part.partition(": ")
            if sep:
                text[key] = what
    merged = {**old, **{k: dict(v) for k, v in shifts.items()}}
    return merged, {**text, **dict(descriptions or {})}


def _label(source: str) -> str:
    return LABELS.get(source, source.replace("_", " "))


def _scalar_notes(name: str, sources: list[str], row: np.ndarray, stderr: float,
                  determined: bool, lo: float, hi: float, unbounded: bool = False
                  ) -> list[str]:
    """One sentence per choice moving a single fit's parameter > 2 stderr, and if undetermined."""
    notes = []
    for s, shift in zip(sources, row, strict=True):
        if math.isfinite(stderr) and stderr > 0 and abs(shift) > SAY_Z * stderr:
            notes.append(f"{name} moves by {shift:+.3g} ({shift / stderr:+.1f} stderr) with "
                         f"the {_label(s)}")
    if unbounded:
        notes.append(f"{name} is not determined by these data: the fit's identifiability test "
                     f"does not bound it (the budget's interval [{lo:.4g}, {hi:.4g}] is the "
                     "curvature's, not a limit)")
    elif not determined:
        notes.append(f"{name} is not determined by these data: the choices they do not "
                     f"settle put it anywhere in [{lo:.4g}, {hi:.4g}]")
    return notes


def _map_notes(name: str, sources: list[str], row: np.ndarray, stderr: np.ndarray,
               bad: np.ndarray, fitted: np.ndarray, what: str) -> list[str]:
    """A map's counts: pixels a choice moves by > 2 stderr, pixels not determined."""
    n = int(fitted.sum())
    notes = []
    with np.errstate(invalid="ignore"):
        for i, s in enumerate(sources):
            moved = (np.abs(row[i]) > SAY_Z * stderr) & (stderr > 0) & fitted
            if int(moved.sum()):
                notes.append(f"{name} moves by more than {SAY_Z:g} stderr with the {_label(s)} "
                             f"on {int(moved.sum())} of {n} pixels")
    n_bad = int((bad & fitted).sum())
    if n_bad:
        notes.append(f"{name} is not determined by these data on {n_bad} of {n} pixels "
                     f"({what})")
    return notes


def _values(x: Any, value: xr.DataArray) -> np.ndarray:
    """``x`` (a float, or a DataArray over ``value``'s dims) as an array of ``value``'s shape."""
    if isinstance(x, xr.DataArray):
        x = x.transpose(*value.dims).values if set(x.dims) == set(value.dims) else x.values
    return np.broadcast_to(np.asarray(x, dtype=float), value.shape)


def _with_budget(ds: xr.Dataset, shifts: Mapping[str, Mapping[str, Any]],
                 descriptions: Mapping[str, str], *, per_pixel: bool, what: str) -> xr.Dataset:
    """The one rule set of :func:`add_budget` (a single fit) and :func:`add_map_budget` (a map).

    Computed on arrays and assigned at once (a fit result is large: one xarray assignment per
    variable cost far more than the budget's arithmetic).
    """
    sources = [s for s in shifts if shifts[s]]
    out = ds.drop_vars([v for v in ds.variables if str(v).endswith(
        ("_systematic", "_budget_lower", "_budget_upper", "_budget_determined"))
        or v == "budget_source"])
    if not sources:
        return out
    notes: list[str] = []
    mirrored = [i for i, s in enumerate(sources) if s in _MIRRORED]  # ± to first order
    new: dict[str, xr.DataArray] = {}
    for name in _reading_order(ds):
        value_da = ds[name]
        if not per_pixel and value_da.size != 1:
            continue
        dims = value_da.dims
        value = value_da.values.astype(float)
        stderr = (_values(ds[f"{name}_stderr"], value_da) if f"{name}_stderr" in ds
                  else np.full(value.shape, np.nan))
        unit = _unit(ds, name)
        row = np.stack([np.nan_to_num(_values(shifts[s].get(name, 0.0), value_da), nan=0.0,
                                      posinf=0.0, neginf=0.0) for s in sources])
        width = 2.0 * np.where(np.isfinite(stderr), stderr, 0.0)
        estimates = np.concatenate([value[None], value + row, value - row[mirrored]])
        lo = estimates.min(axis=0) - width
        hi = estimates.max(axis=0) + width
        unbounded = np.asarray(_unidentified(ds, name, value_da), dtype=bool)
        with np.errstate(invalid="ignore"):
            bad = np.asarray(_undetermined(name, value, lo, hi), dtype=bool) | unbounded
        fitted = np.isfinite(value)
        determined = (~bad).astype(float if per_pixel else int)
        if per_pixel:
            determined = np.where(fitted, determined, np.nan)
        new[f"{name}_systematic"] = xr.DataArray(row, dims=("budget_source", *dims), attrs={
            "units": unit,
            "long_name": f"shift of {name} when each source's choice is made otherwise"})
        new[f"{name}_budget_lower"] = xr.DataArray(lo, dims=dims, attrs={
            "units": unit, "long_name": f"lower end of {name}'s total interval"})
        new[f"{name}_budget_upper"] = xr.DataArray(hi, dims=dims, attrs={
            "units": unit, "long_name": f"upper end of {name}'s total interval"})
        new[f"{name}_budget_determined"] = xr.DataArray(determined, dims=dims, attrs={
            "units": "1", "long_name": f"1: {name} determined by these data within its budget"})
        if name in NUISANCE:  # in the budget, not in the sentences
            continue
        if per_pixel:
            notes += _map_notes(name, sources, row, stderr, bad, fitted, what)
        else:
            notes += _scalar_notes(name, sources, row[:, ...].reshape(len(sources)),
                                   float(stderr), not bool(bad), float(lo), float(hi),
                                   bool(unbounded))
    out = out.assign(new).assign_coords(
        budget_source=("budget_source", np.asarray(sources, dtype=str)))
    out.attrs["budget_sources"] = "; ".join(
        f"{s}: {descriptions.get(s, CALIBRATION_DEFAULTS.get(s, ('', s))[1])}" for s in sources)
    out.attrs["budget_notes"] = " | ".join(notes) if notes else "none"
    return out


def add_budget(ds: xr.Dataset, shifts: Mapping[str, Mapping[str, float]],
               descriptions: Mapping[str, str] | None = None) -> xr.Dataset:
    """The fit result with its systematic budget (module docstring).

    Parameters
    ----------
    ds : xarray.Dataset
        One fit result (scalar parameters).
    shifts : mapping
        {source: {parameter: shift}} (:func:`calibration_shifts`, :func:`alternative_shifts`).
        A source given again replaces the one ``ds`` already carries.
    descriptions : mapping, optional
        {source: what the choice was} (stated in ``attrs["budget_sources"]``).

    Returns
    -------
    xarray.Dataset
        A copy with ``<name>_systematic`` over ``budget_source`` [the parameter's unit],
        ``<name>_budget_lower``/``_upper`` (the total interval), ``<name>_budget_determined``
        (1, or 0: not determined by these data) and attrs ``budget_sources`` and
        ``budget_notes`` (one sentence per choice that moves a parameter by more than 2 stderr
        and per parameter not determined).
    """
    shifts, text = _merged(ds, shifts, descriptions)
    return _with_budget(ds, shifts, text, per_pixel=False, what="")


def add_map_budget(ds: xr.Dataset, uncertainties: Mapping[str, float] | None = None,
                   alternatives: Mapping[str, Mapping[str, xr.DataArray]] | None = None,
                   descriptions: Mapping[str, str] | None = None) -> xr.Dataset:
    """A map's fit result with its budget per pixel (the rules of :func:`add_budget`).

    Parameters
    ----------
    ds : xarray.Dataset
        A map's fit result (parameters over the pixel dims).
    uncertainties : mapping, optional
        Relative calibration uncertainties (:func:`check_uncertainties`).
    alternatives : mapping, optional
        {source: {parameter: shift per pixel}} of choices refitted the other way (the height
        record, the phase reference: :func:`alternative_shifts` of two map results); NaN where
        a pixel's choice is settled or its refit failed (no shift).
    descriptions : mapping, optional
        {source: what the choice was} of the alternatives.

    Returns
    -------
    xarray.Dataset
        ``<name>_systematic`` over (``budget_source``, the pixel dims), ``<name>_budget_lower``
        / ``_upper`` and ``<name>_budget_determined`` per pixel (0: the pixel's value is not
        determined by these data); ``attrs["budget_notes"]`` counts the pixels per rule.
    """
    factors = calibration_factors(ds, uncertainties)
    shifts: dict[str, dict[str, Any]] = {
        s: {n: ds[n] * f for n, f in row.items()} for s, row in factors.items()}
    shifts.update({s: dict(v) for s, v in (alternatives or {}).items() if v})
    text = calibration_descriptions(uncertainties)
    text.update(descriptions or {})
    what = "its budget" if alternatives else "calibration budget"
    return _with_budget(ds, shifts, text, per_pixel=True, what=what)
