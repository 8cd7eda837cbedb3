"""How ``fit`` reports a result: the ``--json`` object and the printed summary of a fit or a map."""

from __future__ import annotations

from typing import Any

from viscoforce.cli._output import DIGITS, format_estimate, format_value


def show_value(value: float | None, unit: str, digits: int = DIGITS) -> str:
    """A parameter value for humans (:func:`~viscoforce.cli._output.format_value`)."""
    return format_value(value, unit, digits)


def _single_json(result) -> dict[str, Any]:
    import numpy as np

    from viscoforce.fitting.identify import IDENTIFIABILITY
    from viscoforce.fitting.verdict import bound_text

    names = [str(n) for n in result["param_i"].values]
    codes = (np.asarray(result["identifiability"].values).reshape(-1).tolist()
             if "identifiability" in result else [0] * len(names))
    params = {}
    for n, code in zip(names, codes, strict=True):
        entry = {"value": float(result[n]), "stderr": float(result[f"{n}_stderr"]),
                 "identified": IDENTIFIABILITY[int(code)]}
        for side in ("lower", "upper"):
            if f"{n}_{side}" in result:
                entry[side] = float(result[f"{n}_{side}"])
        text = bound_text(result, n)
        if text:
            entry["report_as"] = text
        params[n] = entry
    corr = result["correlation"].values
    out: dict[str, Any] = {
        "model": result.attrs["model"], "modes": int(result["modes"]), "params": params,
        "correlations": {a: {b: float(corr[i, j]) for j, b in enumerate(names) if j != i}
                         for i, a in enumerate(names)},
        "redchi": float(result["redchi"]), "aic": float(result["aic"]),
        "bic": float(result["bic"]), "success": bool(int(result["success"])),
        "chi2_pvalue": float(result["chi2_pvalue"]) if "chi2_pvalue" in result else None,
        "weighting": str(result.attrs.get("weighting", "")),
        "at_bound": [s for s in str(result.attrs.get("at_bound", "")).split(", ")
                     if s and s != "none"]}
    derived = {str(n): {"value": float(result[n]), "stderr": float(result[f"{n}_stderr"])}
               for n in result.data_vars if str(n).endswith(("_young", "_shear"))
               or str(n) in ("ting_E0", "beta")}
    if derived:
        out["derived"] = derived
        out["poisson"] = float(result.attrs.get("poisson", 0.5))
    for key in ("tip", "tip_shape", "tip_radius", "tip_half_angle"):
        if key in result.attrs:
            value = result.attrs[key]
            out[key] = value if isinstance(value, str) else float(value)
    for key in ("material", "candidate", "residual_lag1", "effective_samples", "validity",
                "identifiability_method", "ting_error",
                "depth_check", "depth_check_E", "depth_check_shift", "precontact_rise",
                "creep_force", "segment_type", "split_half_z", "split_half_check",
                "sample_height", "sample_base", "bottom_effect_factor", "depth_check_relative",
                "phase_reference_budget"):
        if key in result.attrs:
            value = result.attrs[key]
            out[key] = value if isinstance(value, str) else float(value)
    if "selection_modes" in result:
        rows = []
        for i in range(result.sizes["candidate"]):
            row = {"modes": int(result["selection_modes"].values[i]),
                   "aic": float(result["selection_aic"].values[i]),
                   "bic": float(result["selection_bic"].values[i])}
            for key in ("label", "redchi", "pvalue", "parameters"):
                if f"selection_{key}" in result:
                    value = result[f"selection_{key}"].values[i]
                    row[key] = str(value) if key == "label" else float(value)
            rows.append(row)
        out["selection"] = rows
        out["criterion"] = result.attrs.get("criterion", "bic")
        if "selection_note" in result.attrs:
            out["selection_note"] = str(result.attrs["selection_note"])
    if "explanation" in result.attrs:  # --model auto
        out["explanation"] = str(result.attrs["explanation"])
        if "estimated_model_error" in result.attrs:
            out["estimated_model_error"] = float(result.attrs["estimated_model_error"])
    return out


def _map_json(result) -> dict[str, Any]:
    import numpy as np

    from viscoforce.fitting.pixels import map_summary

    info = {"model": result.attrs["model"], **map_summary(result),
            "n_failed": int(result.attrs["n_failed"])}
    # where the pixels were fitted and why: the cost model's decision and its numbers
    info["execution"] = {
        "where": str(result.attrs.get("execution", "")),
        "reason": str(result.attrs.get("execution_reason", "")),
        **{key: (value if np.isfinite(value) else None) for key, value in (
            (k, float(result.attrs.get(k, np.nan))) for k in (
                "parallel_capacity", "expected_time_s", "execution_time_s"))}}
    if "budget_source" in result.coords:  # the calibration budget per pixel, summarised
        budget = {}
        for var in result.data_vars:
            name = str(var)
            if name.endswith("_budget_determined"):
                param = name[:-len("_budget_determined")]
                flags = result[name].values
                rows = result[f"{param}_systematic"]
                budget[param] = {
                    "systematic_median": {str(s): float(np.nanmedian(rows.sel(
                        budget_source=s).values)) for s in result["budget_source"].values},
                    "not_determined": int(np.sum(flags == 0))}
        info["budget"] = budget
        info["budget_sources"] = str(result.attrs.get("budget_sources", ""))
        notes = str(result.attrs.get("budget_notes", "none"))
        info["budget_notes"] = [] if notes == "none" else notes.split(" | ")
    return info


def _print_single(info: dict[str, Any]) -> None:
    from viscoforce.schema.fit import parameter_units

    p_value = info.get("chi2_pvalue")
    fit_text = (f"chi-square p-value {p_value:.2g}" if p_value is not None and p_value == p_value
                else f"no p-value (weights {info.get('weighting') or 'unknown'})")
    label = f" ({info['candidate']})" if "candidate" in info else ""
    print(f"model {info['model']}{label}, {info['modes']} mode(s), "
          f"{'converged' if info['success'] else 'DID NOT CONVERGE'}; redchi "
          f"{info['redchi']:.4g}, {fit_text}, AIC {info['aic']:.4g}, BIC {info['bic']:.4g}")
    derived = info.get("derived") or {}
    young = {n: p for n, p in derived.items() if n.endswith("_young")}
    if young:  # what people read first: Young's modulus (issue 38 item 3)
        print(f"  Young's modulus (Poisson's ratio {info['poisson']:g}):")
        for name, p in young.items():
            unit = parameter_units(name.rsplit("_", 1)[0])
            print(f"  {name:<12} = {format_estimate(p['value'], p['stderr'], unit)}")
        print("  fitted (moduli in the paper's convention 2/E = sum (1 - nu^2)/E_i, twice "
              "Johnson's E*):")
    for name, p in info["params"].items():
        unit = parameter_units(name)
        line = f"  {name:<8} = {format_estimate(p['value'], p['stderr'], unit)}"
        if "report_as" in p:
            line += f"   -> report as {p['report_as']} ({info.get('identifiability_method', '')})"
        print(line)
    rest = {n: p for n, p in derived.items() if n not in young}
    if rest:
        print(f"  shear moduli and Ting's forms (Poisson's ratio {info['poisson']:g}):")
        for name, p in rest.items():
            base = name if name in ("ting_E0", "beta") else name.rsplit("_", 1)[0]
            unit = parameter_units(base)
            print(f"  {name:<12} = {format_estimate(p['value'], p['stderr'], unit)}")
    if "tip" in info:
        print(f"  tip: {info['tip']}")
    if info["at_bound"]:
        print(f"  at a bound (not identified by these data): {', '.join(info['at_bound'])}")
    for row in info.get("selection", []):
        name = row.get("label", f"{row['modes']} mode(s)")
        extra = f", redchi {row['redchi']:.3g}" if "redchi" in row else ""
        print(f"  candidate {name}: AIC {row['aic']:.4g}, BIC {row['bic']:.4g}{extra}")
    if "selection_note" in info:
        print(f"  note: {info['selection_note']}")
    if "explanation" in info:
        print(f"  model choice: {info['explanation']}")
    if "depth_check" in info:
        print(f"  depth check: {info['depth_check']}")
    if "validity" in info:
        print(f"  validity: {info['validity']}")
    if "height_record" in info:
        print(f"  {info['height_record']}")
    if info.get("budget_notes"):
        print(f"  error budget ({info['budget_sources']}):")
        for note in info["budget_notes"]:
            print(f"    {note}")


def _print_map(info: dict[str, Any]) -> None:
    """The map summary: Young's modulus first, then the fitted parameters, then shear moduli.

    Young's moduli lead (issue 38 item 3: what people read first), over the good pixels of the
    most common number of modes; the fitted moduli follow per number of modes, labelled as the
    paper's convention (2/E = Σ(1 − ν²)/E_i, twice Johnson's E*). ``info`` is unchanged (the
    ``--json`` object keeps its keys).
    """
    from viscoforce.schema.fit import parameter_units

    def quartiles(name: str, p: dict[str, Any], width: int, unit: str) -> None:
        print(f"    {name:<{width}} median {show_value(p['median'], unit)}, IQR "
              f"{show_value(p['q25'], unit)} .. {show_value(p['q75'], unit)}")

    left = ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in info["left_out"].items() if v)
    print(f"model {info['model']}: {info['n_fits']} fits, {info['n_good']} good"
          + (f"; left out of the summary: {left}" if left else ""))
    derived = info.get("derived") or {}
    young = {n: p for n, p in derived.items() if n.endswith("_young")}
    modes = info.get("modes")
    pixels = (f"the {info['by_modes'][str(modes)]['n']} good pixel(s) of {modes} mode(s)"
              if modes is not None and str(modes) in info["by_modes"] else "no good pixel")
    if young:  # what people read first: Young's modulus (issue 38 item 3)
        print(f"  Young's modulus (Poisson's ratio {info['poisson']:g}), {pixels}:")
        for name, p in young.items():
            quartiles(name, p, 12, parameter_units(name.rsplit("_", 1)[0]))
    paper = (", fitted (moduli in the paper's convention 2/E = sum (1 - nu^2)/E_i, twice "
             "Johnson's E*)") if young else ""
    for count, block in info["by_modes"].items():
        print(f"  {count} mode(s), {block['n']} good pixel(s){paper}:")
        for name, p in block["params"].items():
            quartiles(name, p, 8, parameter_units(name))
    rest = {n: p for n, p in derived.items() if n not in young}
    if rest:
        print(f"  shear moduli (Poisson's ratio {info['poisson']:g}), {pixels}:")
        for name, p in rest.items():
            quartiles(name, p, 12, parameter_units(name.rsplit("_", 1)[0]))


def recorded(run, *args: Any) -> tuple[Any, list[str], list[Any]]:
    """``run(*args)`` with the viscoforce warnings recorded, not shown: (result, texts, caught).

    ``texts`` are the viscoforce warnings' messages (each once), ``caught`` every warning, to be
    shown later (:func:`show`): a single fit's chooser keeps back those of the fits it drops.
    """
    import warnings

    from viscoforce.exceptions import (
        AccuracyWarning,
        DataWarning,
        GoodnessOfFitWarning,
        ModelValidityWarning,
    )

    kinds = (ModelValidityWarning, AccuracyWarning, GoodnessOfFitWarning, DataWarning)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run(*args)
    texts: list[str] = []
    for w in caught:
        if issubclass(w.category, kinds) and str(w.message) not in texts:
            texts.append(str(w.message))
    return result, texts, list(caught)


def show(caught: list[Any]) -> None:
    """Show the warnings :func:`recorded` kept back."""
    import warnings

    for w in caught:
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def _fit_recording(run, *args: Any):
    """``run(*args)`` with the viscoforce warnings recorded, then shown; (result, texts)."""
    result, texts, caught = recorded(run, *args)
    show(caught)
    return result, texts
