"""The pixels of a map: their data, their fits in blocks, the assembled result and its summary.

:func:`pixel_data` turns a map (a spectrum with extra dims, or a curves dataset) into one
:class:`~viscoforce.fitting.data.FitData` per pixel, or the reason it has none;
:func:`fit_block` fits a block of them (in this process or in a worker); :func:`assemble_map`
makes the map's dataset of their results, each pixel with its ``quality`` code
(:data:`MAP_QUALITY`, the rule in :data:`QUALITY_RULE`); :func:`map_summary` summarises the good
pixels. Where the blocks are fitted is :mod:`viscoforce.fitting.maps`' business.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError, ViscoforceError
from viscoforce.fitting.curves import curve_data
from viscoforce.fitting.data import FitData, clean_pixels_fit_data, pixel_fit_data, spectrum_arrays
from viscoforce.fitting.fit import local_identifiability, select, summary
from viscoforce.fitting.hertz_checks import (
    DEPTH_CHECK_FRACTION,
    DEPTH_CHECK_SIGMA,
    depth_check,
    hertz_verdict,
)
from viscoforce.fitting.identify import IDENTIFIABILITY
from viscoforce.fitting.registry import entry
from viscoforce.fitting.report import fit_report
from viscoforce.fitting.verdict import NUISANCE_RULE, PVALUE_WARN, settle_nuisance
from viscoforce.schema import flag_attrs, index_values, validate_fit_result, validate_spectrum
from viscoforce.schema.fit import SUCCESS_FLAGS, parameter_units

#: Per-pixel ``quality`` codes of a map (CF ``flag_values`` → ``flag_meanings``); what each
#: means, and which one a pixel gets, is :data:`QUALITY_RULE`.
MAP_QUALITY: dict[int, str] = {0: "good", 1: "optimiser_failed", 2: "bad_fit",
                               3: "not_determined", 4: "at_bound", 5: "depth_dependent"}
#: How a pixel's ``quality`` is chosen (``attrs["quality_rule"]`` of a map).
QUALITY_RULE = (
    "each pixel gets the first code that applies: optimiser_failed (the fit raised or did not "
    f"converge), bad_fit (chi2_pvalue < {PVALUE_WARN:g}: the model does not describe the "
    "pixel's data), depth_dependent (hertz: E refitted up to "
    f"{100 * DEPTH_CHECK_FRACTION:.0f} % of the maximum contact force differs from the full "
    f"fit's by more than {DEPTH_CHECK_SIGMA:g} standard errors of the difference, the single "
    "fit's depth-check warning: the tip's elastic law does not describe the approach; "
    "depth_check_shift and depth_check_relative give the shift), not_determined (a "
    "parameter's identifiability is not 'determined', other than by ending on a bound; "
    f"{NUISANCE_RULE}), at_bound (a parameter ended on a bound of its window), otherwise good")
#: Where a pixel has no fit, or its model lacks the parameter, ``identifiability`` holds this.
NO_IDENTIFIABILITY = 3


def pixel_data(ds: xr.Dataset, model: str, *, segment: int | None = None
               ) -> tuple[list[FitData | str], tuple[str, ...], dict[str, Any]]:
    """Per-pixel fit data of a map (or the reason it has none), the map dims and layout.

    Parameters
    ----------
    ds : xarray.Dataset
        A spectrum over (*map dims, ``omega``) for a spectrum model, else a curves dataset.
    model : str
        Model name (a spectrum model, or a curve model: ``relaxation``, ``hertz``, ``creep``).
    segment : int, optional
        The curves' segment of a curve-model map (see :func:`~.curves.curve_data`).

    Returns
    -------
    items : list
        Per pixel (C order over the map dims) its :class:`~.fit.FitData`, or the reason (str)
        it has none.
    dims : tuple of str
        The map dims.
    layout : dict
        ``shape`` (dim → size) and ``coords`` (name → (dims, values, attrs)): the coordinates
        of ``ds`` over the map dims, and ``x``, ``y`` [m] wherever they are.
    """
    if entry(model).data == "spectrum":
        validate_spectrum(ds, require=("stiffness", "phase"))
        dims = tuple(str(d) for d in ds["stiffness"].dims if d != "omega")
        arrays = spectrum_arrays(ds, dims)
        omega = np.asarray(index_values(ds, "omega"), dtype=float)
        source = {"data_kind": "spectrum"}
        # the pixels that need a note or a refusal, one by one
        out: list[FitData | str] = [
            data if data is not None else _or_reason(lambda i=i: pixel_fit_data(
                omega, {k: v[i] for k, v in arrays.items()}, source))
            for i, data in enumerate(clean_pixels_fit_data(omega, arrays, source))]
    else:
        dims = ("curve",)
        n = int(ds.sizes["curve"])
        out = [_or_reason(lambda i=i: curve_data(ds, model, curve=i, segment=segment))
               for i in range(n)]
    shape = {d: int(ds.sizes[d]) for d in dims}
    return out, dims, {"coords": map_coords(ds, dims), "shape": shape}


def map_coords(ds: xr.Dataset, dims: tuple[str, ...]) -> dict[str, tuple[Any, ...]]:
    """Coordinates of ``ds`` that a map over ``dims`` keeps: name → (dims, values, attrs).

    Every coordinate (dimension or not) whose dims are within ``dims``, and ``x``, ``y`` also
    when they are data variables (a curves dataset may store them so); coordinates over
    ``omega``, ``sample`` or any other dim the map does not have are left out.
    """
    out: dict[str, tuple[Any, ...]] = {}
    names = [*ds.coords, *(n for n in ("x", "y") if n in ds.data_vars)]
    for name in names:
        da = ds[name]
        if set(da.dims) <= set(dims) and str(name) != "omega":
            out[str(name)] = (tuple(str(d) for d in da.dims), da.values, dict(da.attrs))
    return out


def _or_reason(build: Callable[[], FitData]) -> FitData | str:
    try:
        return build()
    except (ViscoforceError, ValueError, ArithmeticError) as exc:
        return str(exc)


def fit_block(items: Sequence[FitData | str], model: str, modes: int | str, criterion: str,
              fixed: dict[str, Any], *, profile: bool = False,
              omega: np.ndarray | None = None, reports: bool = False) -> list[dict[str, Any]]:
    """Fit each pixel of a block; a failure becomes ``{"success": False, "message": …}``.

    Parameters
    ----------
    items : sequence
        Per pixel its :class:`~.fit.FitData` or the reason (str) it has none.
    model : str
        Model name.
    modes : int or "auto"
        Relaxation modes (``"auto"``: chosen per pixel by ``criterion``).
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.
    fixed : dict
        The model's fixed inputs (for ``contact`` without ``indentation``, each pixel's own
        median ``mean_indentation``).
    profile : bool
        Profile-likelihood identifiability per pixel (:func:`~.fit.summary`), else the local
        test.
    omega : numpy.ndarray, optional
        The map's frequencies [rad/s] (spectrum models): each pixel's best-fit k* there, as
        ``fit_k`` (flagged points included, so the curve has no gaps).
    reports : bool
        Each pixel's lmfit report (:func:`viscoforce.fitting.report.fit_report`) as ``report``.

    Returns
    -------
    list of dict
        Per pixel :func:`~.fit.summary` plus ``modes`` and ``names`` (and ``fit_k``); ``message``
        is the data's notes (points left out, stderr fallbacks, the hertz checks) followed by
        the optimiser's message. The identifiability of the nuisance parameters is
        :func:`~.verdict.settle_nuisance`'s (the single fit's, :func:`~.verdict.warn_fit`);
        hertz adds its checks (:func:`_hertz_notes`).
    """
    out = []
    for data in items:
        if isinstance(data, str):
            out.append({"success": False, "message": data})
            continue
        notes = list(data.notes)
        own = fixed
        if model == "contact" and fixed.get("indentation") is None:  # each pixel's own depth
            own = {**fixed, "indentation": data.source.get("mean_indentation")}
        if model == "ting":  # each curve's own tip-position trace
            own = {**fixed, "position_trace": data.position_trace}
        try:
            best, _ = select(data, model, modes=modes, criterion=criterion, **own)
        except (ViscoforceError, ValueError, ArithmeticError) as exc:
            out.append({"success": False,
                        "message": "; ".join([*notes, str(exc).splitlines()[0]])})
            continue
        try:
            info = summary(best, profile=profile)
        except (ViscoforceError, ValueError, ArithmeticError) as exc:
            info = summary(best)
            notes.append(f"the profile likelihood failed ({str(exc).splitlines()[0]}): the "
                         "identifiability is the local test")
        info["identifiability"] = settle_nuisance(info["identifiability"], info["stderr"],
                                                  info["at_bound"], keep=info["profiled"])
        if model == "hertz":  # the single fit's checks (hertz_checks.hertz_checks), without warnings
            notes += _hertz_notes(data, info, own["tip"])
        info["message"] = "; ".join([*notes, info["message"]])
        info["modes"] = best.model.spec.modes
        info["names"] = best.model.names
        if omega is not None:
            try:
                info["fit_k"] = np.asarray(best.evaluate(omega), dtype=complex)
            except (ViscoforceError, ValueError, ArithmeticError):
                pass  # no curve for this pixel (its values and stderr stand)
        if reports:
            try:
                info["report"] = fit_report(best)
            except (ViscoforceError, ValueError, ArithmeticError) as exc:
                info["report"] = f"no lmfit report: {str(exc).splitlines()[0]}"
        out.append(info)
    return out


def _hertz_notes(data: FitData, info: dict[str, Any], tip: Any) -> list[str]:
    """A Hertz pixel's verdicts (:func:`~.hertz_checks.hertz_verdict`, the depth check), as notes.

    E and the contact point become not determined (code 3) where no indentation was measured or
    the tip position's sign looks flipped (the pixel's quality is then 3, on a bound or not:
    ``checked_not_determined`` names them). Otherwise E is refitted on the shallow half of the
    contact force (:func:`~.hertz_checks.depth_check`, the single fit's check):
    ``depth_check_shift`` and ``depth_check_relative`` join ``info``, and a shift beyond
    :data:`~.hertz_checks.DEPTH_CHECK_SIGMA` sets ``depth_dependent`` (the pixel's quality is
    then 5, unless an earlier code of :data:`QUALITY_RULE` applies).
    """
    from viscoforce.physics.tips import tip_from

    z, f, shape = np.asarray(data.x), np.asarray(data.y), tip_from(tip)
    verdict = hertz_verdict(z, f, info["values"], shape)
    reason = (f"the tip position's sign looks flipped ({verdict['flipped']})"
              if verdict["flipped"] is not None else
              f"no detectable indentation ({verdict['indentation_signal']:.2g} sigma over the "
              "baseline alone)" if verdict["no_signal"] else None)
    if reason is None:
        err = info["stderr"].get("E")
        found = depth_check(z, f, info["values"], math.nan if err is None else float(err), shape)
        if not found["made"]:
            return [f"depth check {found['text']}"]
        info.update(depth_check_shift=found["shift"], depth_check_relative=found["relative"],
                    depth_dependent=found["warn"])
        return [f"E depends on the indentation depth: {found['text']}" if found["warn"] else
                f"depth check: {found['text']}"]
    marked = [n for n in ("E", "contact_point") if n in info["identifiability"]]
    for name in marked:
        info["identifiability"][name] = 3  # IDENTIFIABILITY[3]: "not_determined"
    info["checked_not_determined"] = marked  # on a bound or not (pixel_quality)
    return [f"{reason}: E and the contact point are not determined"]


def pixel_quality(result: dict[str, Any]) -> int:
    """The :data:`MAP_QUALITY` code of one pixel's result (the rule of :data:`QUALITY_RULE`)."""
    if "names" not in result or not result.get("success", False):
        return 1
    p = float(result.get("chi2_pvalue", math.nan))
    if math.isfinite(p) and p < PVALUE_WARN:
        return 2
    if result.get("depth_dependent", False):
        return 5
    bound = set(result.get("at_bound", ())) - set(result.get("checked_not_determined", ()))
    if any(int(code) != 0 and name not in bound
           for name, code in _identifiability(result).items()):
        return 3
    return 4 if bound else 0


def _identifiability(result: dict[str, Any]) -> dict[str, int]:
    """A fitted pixel's identifiability codes (the local test when the result has none)."""
    if "identifiability" in result:
        return {str(k): int(v) for k, v in result["identifiability"].items()}
    names = result["names"]
    bound = [n for n in names if n in set(result.get("at_bound", ()))]
    stderr = {n: result["stderr"][n] for n in names}
    return settle_nuisance(local_identifiability({n: result["values"][n] for n in names},
                                                 stderr, bound), stderr, bound)


def assemble_map(results: list[dict[str, Any]], dims: tuple[str, ...], layout: dict[str, Any],
                 model: str, criterion: str | None, n: int, *,
                 profile: bool = False, omega: np.ndarray | None = None) -> xr.Dataset:
    """The map's dataset of the pixels' ``results`` (:func:`fit_block`) over ``dims``.

    Raises :class:`~viscoforce.exceptions.ParameterError` when no pixel could be fitted.
    """
    names: list[str] = []
    for r in results:
        for name in r.get("names", ()):
            if name not in names:
                names.append(name)
    if not names:
        reasons = sorted({r["message"] for r in results})
        raise ParameterError(f"no pixel of the {n} could be fitted: " + "; ".join(reasons[:3]))
    shape = tuple(layout["shape"][d] for d in dims) if dims else ()
    m = len(names)
    values = np.full((n, m), np.nan)
    errors = np.full((n, m), np.nan)
    limits = {side: np.full((n, m), np.nan) for side in ("lower", "upper")}
    corr = np.full((n, m, m), np.nan)
    ident = np.full((n, m), NO_IDENTIFIABILITY, dtype=np.int8)
    stats = {k: np.full(n, np.nan) for k in ("redchi", "aic", "bic", "chi2_pvalue")}
    success = np.zeros(n, dtype=np.int8)
    quality = np.zeros(n, dtype=np.int8)
    modes = np.zeros(n, dtype=np.int32)
    messages = []
    for i, r in enumerate(results):
        messages.append(str(r.get("message", "")))
        quality[i] = pixel_quality(r)
        if "names" not in r:
            continue
        own = r["names"]
        idx: list[int] | slice = slice(None) if own == names else [names.index(x) for x in own]
        values[i, idx] = [r["values"][x] for x in own]
        errors[i, idx] = [np.nan if r["stderr"][x] is None else r["stderr"][x] for x in own]
        codes = _identifiability(r)
        ident[i, idx] = [codes[x] for x in own]
        for side, arr in limits.items():
            arr[i, idx] = [r.get(side, {}).get(x, np.nan) for x in own]
        if isinstance(idx, slice):  # every parameter of the map (one model, one layout)
            corr[i] = r["correlation"]
        else:
            corr[i][np.ix_(idx, idx)] = r["correlation"]
        for k in stats:
            stats[k][i] = r.get(k, np.nan)
        success[i] = int(r["success"])
        modes[i] = r["modes"]
    data: dict[str, Any] = {}
    for j, name in enumerate(names):
        attrs = {"units": parameter_units(name), "long_name": f"fitted parameter {name}"}
        data[name] = (dims, values[:, j].reshape(shape), attrs)
        data[f"{name}_stderr"] = (dims, errors[:, j].reshape(shape),
                                  {**attrs, "long_name": f"standard error of {name}"})
        if profile:
            for side, arr in limits.items():
                data[f"{name}_{side}"] = (dims, arr[:, j].reshape(shape), {
                    **attrs, "long_name": f"2-sigma profile-likelihood {side} limit of {name} "
                                          "(NaN: unbounded on that side)"})
    data["correlation"] = ((*dims, "param_i", "param_j"), corr.reshape((*shape, m, m)),
                           {"units": "1", "long_name": "correlation of the fitted parameters"})
    data["success"] = (dims, success.reshape(shape), {
        "long_name": "fit converged", **flag_attrs(SUCCESS_FLAGS)})
    data["quality"] = (dims, quality.reshape(shape), {
        "long_name": "quality of the pixel's fit", "comment": QUALITY_RULE,
        **flag_attrs(MAP_QUALITY)})
    data["identifiability"] = ((*dims, "param_i"), ident.reshape((*shape, m)), {
        "long_name": "identifiability of the fitted parameter", **flag_attrs(IDENTIFIABILITY)})
    if any("report" in r for r in results):
        data["fit_report"] = (dims, np.array([r.get("report", "no fit") for r in results],
                                             dtype=object).reshape(shape),
                              {"long_name": "lmfit's fit report of the pixel"})
    data["message"] = (dims, np.array(messages, dtype=object).reshape(shape),
                       {"long_name": "data notes and the optimiser's message, or why the fit "
                                     "failed"})
    for k, long_name in (("redchi", "reduced chi-square"), ("aic", "Akaike information criterion"),
                         ("bic", "Bayesian information criterion"),
                         ("chi2_pvalue", "chi-square goodness-of-fit p-value (NaN: stderr "
                                         "unknown)")):
        data[k] = (dims, stats[k].reshape(shape), {"units": "1", "long_name": long_name})
    data["modes"] = (dims, modes.reshape(shape), {"units": "1",
                                                   "long_name": "number of relaxation modes"})
    data.update(_depth_variables(results, dims, shape))
    if omega is not None and any("fit_k" in r for r in results):
        k = np.full((n, omega.size), np.nan, dtype=complex)
        for i, r in enumerate(results):
            if "fit_k" in r:
                k[i] = r["fit_k"]
        order = (*dims, "omega")
        data["fit_stiffness"] = (order, np.abs(k).reshape((*shape, omega.size)), {
            "units": "N/m", "long_name": "best-fit dynamic stiffness at the data's frequencies"})
        data["fit_phase"] = (order, np.degrees(np.angle(k)).reshape((*shape, omega.size)), {
            "units": "degree", "long_name": "best-fit phase at the data's frequencies"})
    coords: dict[str, Any] = {
        name: value if isinstance(value, tuple) else (name, value)
        for name, value in layout["coords"].items() if name not in data}
    if omega is not None and "fit_stiffness" in data:
        coords["omega"] = ("omega", omega, {"units": "rad/s", "long_name": "angular frequency"})
    coords.update({"param_i": ("param_i", names), "param_j": ("param_j", names)})
    attrs = {"model": model, "n_fits": n, "n_failed": int(n - success.sum()),
             "n_good": int((quality == 0).sum()), "quality_rule": QUALITY_RULE,
             "identifiability_method": "profile likelihood (2 sigma)" if profile
             else "local (stderr > value, none, or at a bound)"}
    if criterion:
        attrs["criterion"] = criterion
    return validate_fit_result(xr.Dataset(data, coords=coords, attrs=attrs))


#: A hertz map's per-pixel depth check (:func:`_hertz_notes`): result key → long name.
DEPTH_VARIABLES = {
    "depth_check_shift": "shift of E refitted up to half the maximum contact force, in standard "
                         "errors of the difference (NaN: no check made)",
    "depth_check_relative": "relative change of E refitted up to half the maximum contact force "
                            "(E_shallow / E - 1; NaN: no check made)"}


def _depth_variables(results: list[dict[str, Any]], dims: tuple[str, ...],
                     shape: tuple[int, ...]) -> dict[str, Any]:
    """The map's :data:`DEPTH_VARIABLES` (none where no pixel made the depth check)."""
    if not any("depth_check_shift" in r for r in results):
        return {}
    return {key: (dims, np.array([float(r.get(key, math.nan)) for r in results]).reshape(shape),
                  {"units": "1", "long_name": long_name})
            for key, long_name in DEPTH_VARIABLES.items()}


def map_summary(result: xr.Dataset) -> dict[str, Any]:
    """Medians and quartiles of every parameter over the GOOD pixels of a map (JSON-friendly).

    Parameters
    ----------
    result : xarray.Dataset
        What :func:`~viscoforce.fitting.maps.fit_map` returns (it needs ``quality`` and ``modes``).

    Returns
    -------
    dict
        ``n_fits``, ``n_good`` (pixels of quality 0); ``left_out``: how many pixels were left
        out per reason of :data:`MAP_QUALITY` (``optimiser_failed``, ``bad_fit``,
        ``not_determined``, ``at_bound``, ``depth_dependent``); ``by_modes``: per number of
        modes fitted (key ``"1"``, ``"2"``, …) ``n`` (its good pixels) and ``params`` (each of that model's
        parameters → ``median``, ``q25``, ``q75`` over those good pixels, in the parameter's
        units); ``params``: the same for the number of modes most common among the good pixels
        (the fewer on a tie), which ``modes`` names; ``derived`` (with ``poisson``): the same
        quartiles of the Young's and shear moduli ``<name>_young``, ``<name>_shear`` over those
        pixels, where the map has them. Values are None where no good pixel
        gives one (and ``modes`` is None when no pixel is good). Only str, int, float and None
        appear, so the dict serialises with :func:`json.dumps` as it is.

    Raises
    ------
    ParameterError
        ``result`` is not a map result (no ``quality`` or ``modes``).
    """
    if not isinstance(result, xr.Dataset) or any(
            k not in result.variables for k in ("quality", "modes", "param_i")):
        raise ParameterError("map_summary needs what fit_map returns (a dataset with 'quality', "
                             "'modes' and the parameters over 'param_i'), got "
                             f"{type(result).__name__}"
                             + ("" if not isinstance(result, xr.Dataset) else
                                f" with variables {sorted(map(str, result.variables))}"))
    quality = np.asarray(result["quality"].values).reshape(-1)
    modes = np.asarray(result["modes"].values).reshape(-1)
    names = [str(x) for x in result["param_i"].values]
    values = {x: np.asarray(result[x].values, dtype=float).reshape(-1) for x in names}
    good = quality == 0
    by_modes: dict[str, Any] = {}
    for count in sorted({int(c) for c in modes[modes > 0]}):
        of_count = modes == count
        own = [x for x in names if np.isfinite(values[x][of_count]).any()]
        chosen = good & of_count
        by_modes[str(count)] = {"n": int(chosen.sum()),
                                "params": {x: _quartiles(values[x][chosen]) for x in own}}
    counts = {c: row["n"] for c, row in by_modes.items() if row["n"] > 0}
    common = min(counts, key=lambda c: (-counts[c], int(c))) if counts else None
    params = (by_modes[common]["params"] if common is not None else
              {x: _quartiles(np.empty(0)) for x in names})
    left_out = {reason: int((quality == code).sum()) for code, reason in MAP_QUALITY.items()
                if code != 0}
    out = {"model": str(result.attrs.get("model", "")), "n_fits": int(quality.size),
           "n_good": int(good.sum()), "left_out": left_out, "by_modes": by_modes,
           "modes": None if common is None else int(common), "params": params}
    derived = [str(x) for x in result.data_vars if str(x).endswith(("_young", "_shear"))]
    if derived:  # Young's and shear moduli over the same pixels as params
        chosen = good & (modes == int(common)) if common is not None else np.zeros_like(good)
        out["derived"] = {x: _quartiles(np.asarray(result[x].values, dtype=float).reshape(-1)[
            chosen]) for x in derived}
        out["poisson"] = float(result.attrs.get("poisson", 0.5))
    return out


def _quartiles(v: np.ndarray) -> dict[str, float | None]:
    v = v[np.isfinite(v)]
    if not v.size:
        return {"median": None, "q25": None, "q75": None}
    return {"median": float(np.median(v)), "q25": float(np.percentile(v, 25)),
            "q75": float(np.percentile(v, 75))}
