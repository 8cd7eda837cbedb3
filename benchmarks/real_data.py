#!/usr/bin/env python
"""The README's "Measured on the real files" table, regenerated from the real files (issue 20, item 7).

What it measures, through the public API (the CLI equivalent is the table's "command" column):

1. JPK stress relaxation, ``afmformats/fmt-jpk-sr_cell1-0008.jpk-force`` (a 30 s hold):
   ``fit_hold(load_instrument(path), modes="auto")`` — the modes kept, every τ_i ± stderr, F_inf,
   the BIC/AIC of each mode count tried, and the residual-autocorrelation correction of the stderr
   (``attrs["residual_lag1"]``, ``["stderr_correction"]``, ``["effective_samples"]``). Window
   test: the hold refitted (``fit_data(..., "relaxation", modes=N)``, same N) with the first 10 %
   and with the last 10 % of its samples removed (t kept from the start of the full hold), and how
   far each τ moves in units of the full fit's stated stderr (the table marks a refitted τ that
   the profile does not determine or whose stderr exceeds its value: cutting the first 3 s
   leaves little of the fastest mode, so the same N modes may then describe other time scales).
2. The 15-curve zip of the same cell, ``afmformats/10.1002_btm2.10294_fig5d-cell1.zip``:
   ``fit_map(curves, "relaxation", modes="auto", scheduler="synchronous")`` and ``map_summary``:
   good and left-out counts, medians and IQR of every parameter per mode count.
3. The JPK modulation map (4×4 curves × 6 frequencies 1–300 Hz; the 300 Hz points flagged):
   (a) ``fit_spectrum(curve, "auto", radius=10e-6)`` on every curve (the measured-data chooser):
   the candidate kept and on how many curves, the median redchi and chi-square p-value, and per
   candidate the median BIC above the best candidate of the curve; (b)–(c) ``fit_map(spec,
   "contact", radius=10e-6, material=...)`` for ``structural``, ``power-law`` with
   ``newtonian=True`` and ``sls``, each through ``map_summary`` (medians/IQR over the GOOD pixels,
   counts left out per reason), plus — since few pixels pass the p ≥ 0.001 test — the same
   quartiles over every pixel whose optimiser converged, and the median redchi; (d) the lock-in
   split-half rms z per frequency, residual-spectrum ("new") against white-noise stderr, by
   ``benchmarks/split_half.py``'s own functions. The tip radius is not in the file: R = 10 µm is
   assumed (the CLI default).

Fits warn (GoodnessOfFitWarning, AccuracyWarning, DataWarning, ModelValidityWarning): every warning
is recorded, not printed — per data set the count per category and the distinct first sentences
(numbers masked as ``#``) with their counts. A data set whose file is absent is skipped and the
output says so.

BLAS is pinned to one thread (``OPENBLAS_NUM_THREADS=1`` etc. before NumPy loads, plus
``threadpoolctl.threadpool_limits(1)``). ``--quick``: the modulation map only, its first 4 curves
for (a)–(c), and the split-half on the whole map. Prints the Markdown table to paste into the
README and writes ``real_data.json`` (every number; keys ``schema``, ``created``, ``quick``,
``machine``, ``data_dir``, ``radius_m``, ``datasets`` (``jpk_hold``, ``zip_map``,
``modulation_map``, each with ``status``: ``"ok"``, ``"skipped"`` or ``"error"``), ``markdown``,
``wall_time_s``), ``real_data.md`` (the table) and ``real_data_curves.csv`` (the chooser per curve)
to ``--out`` (default benchmarks/out). Exit status 1 when an analysis raised, else 0.
Run ``python benchmarks/real_data.py [--quick] [--out DIR] [--data DIR]``.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # before NumPy loads

import argparse  # noqa: E402
import csv  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import re  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
import warnings  # noqa: E402
from collections import Counter  # noqa: E402
from collections.abc import Callable, Iterator  # noqa: E402
from contextlib import contextmanager  # noqa: E402
from datetime import datetime, timezone  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from threadpoolctl import threadpool_info, threadpool_limits  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
DATA_DIR = ROOT.parent / "shared" / "data" / "real"
BUNDLED_MAP = ROOT / "data_examples" / "real" / "modulation-map.jpk-force-map"
HOLD_FILE = "afmformats/fmt-jpk-sr_cell1-0008.jpk-force"
ZIP_FILE = "afmformats/10.1002_btm2.10294_fig5d-cell1.zip"
MAP_FILE = "PyFMReader/map-data-2021.11.05-17.37.44.432.jpk-force-map"
SCHEMA = "viscoforce.real_data/1"
RADIUS = 10e-6          # not in the file: the CLI default is assumed
WINDOW_CUT = 0.10       # fraction of the hold's samples dropped at one end in the window test
QUICK_CURVES = 4
#: contact materials of the map fits: key → fit_map keywords
MATERIALS = {"structural": {"material": "structural"},
             "power-law+mu": {"material": "power-law", "newtonian": True},
             "sls": {"material": "sls"}}
MATERIAL_FLAGS = {"structural": "--material structural",
                  "power-law+mu": "--material power-law --newtonian", "sls": "--material sls"}


# ── warnings ─────────────────────────────────────────────────────────────────────────────────────

@contextmanager
def recording(bucket: list[warnings.WarningMessage]) -> Iterator[None]:
    """Record every warning raised in the block into ``bucket`` (none is printed or raised)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield
        finally:
            bucket.extend(caught)


def first_sentence(message: str) -> str:
    """The message up to its first ``:``, ``;`` or sentence end, numbers masked as ``#``."""
    head = re.split(r"[:;]\s|\.\s|\.$", message.strip(), maxsplit=1)[0]
    return re.sub(r"(?<![A-Za-z_\d])[-+−]?\d+(?:\.\d+)?(?:e[-+]?\d+)?", "#", head)


def warning_summary(bucket: list[warnings.WarningMessage]) -> dict[str, Any]:
    """``total``, ``by_category`` (class name → count) and ``sentences`` (category: first
    sentence → count, most common first)."""
    categories = Counter(w.category.__name__ for w in bucket)
    sentences = Counter(f"{w.category.__name__}: {first_sentence(str(w.message))}" for w in bucket)
    return {"total": len(bucket), "by_category": dict(categories.most_common()),
            "sentences": dict(sentences.most_common())}


# ── helpers ──────────────────────────────────────────────────────────────────────────────────────

def finite(value: Any) -> float | None:
    """A float, or None when it is not finite (so that the JSON holds no NaN)."""
    v = float(value)
    return v if math.isfinite(v) else None


def quartiles(values: np.ndarray) -> dict[str, float | None]:
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if not v.size:
        return {"median": None, "q25": None, "q75": None}
    return {"median": float(np.median(v)), "q25": float(np.percentile(v, 25)),
            "q75": float(np.percentile(v, 75))}


SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def num(v: float | None, digits: int = 3) -> str:
    """``v`` to ``digits`` significant figures (``a×10ⁿ`` outside [1e-3, 1e5)), with a real minus
    sign; "–" for None."""
    if v is None or not math.isfinite(v):
        return "–"
    if v == 0:
        return "0"
    exponent = math.floor(math.log10(abs(v)))
    if -3 <= exponent < 5:
        text = f"{v:.{max(0, digits - 1 - exponent)}f}"
    else:
        mantissa = f"{v / 10.0 ** exponent:.{digits - 1}f}"
        text = f"{mantissa}×10{str(exponent).translate(SUPERSCRIPT)}"
    return text.replace("-", "−")


def pm(v: float, s: float | None) -> str:
    """``v ± s`` rounded at the first significant figure of ``s``."""
    if s is None or not math.isfinite(s) or s <= 0:
        return num(v)
    d = max(0, -math.floor(math.log10(s)))
    return f"{v:.{d}f} ± {s:.{d}f}".replace("-", "−")


#: display scale and unit of the parameters that appear in the table
DISPLAY = {"E_ref": (1e-3, "kPa"), "E0": (1e-3, "kPa"), "E_inf": (1e-3, "kPa"),
           "tau": (1e3, "ms"), "mu": (1.0, "Pa·s"), "alpha": (1.0, ""), "m": (1.0, ""),
           "C1": (1.0, "")}
GREEK = {"alpha": "α", "mu": "μ", "tau": "τ"}


def iqr_text(name: str, q: dict[str, float | None], unit: tuple[float, str] | None = None) -> str:
    """``name = median (q25–q75) unit``."""
    scale, label = unit or DISPLAY.get(name, (1.0, ""))
    if q["median"] is None:
        return f"{GREEK.get(name, name)}: –"
    parts = [num(q[k] * scale, 2 if k != "median" else 3) for k in ("median", "q25", "q75")]
    return f"{GREEK.get(name, name)} = {parts[0]} ({parts[1]}–{parts[2]}){' ' + label if label else ''}"


def left_out_text(left_out: dict[str, int]) -> str:
    shown = [f"{n} {reason.replace('_', ' ')}" for reason, n in left_out.items() if n]
    return ", ".join(shown) if shown else "none"


def cmd(*parts: str) -> str:
    return "`" + " ".join(("viscoforce", "fit", *parts)) + "`"


# ── 1. the stress-relaxation hold ────────────────────────────────────────────────────────────────

def jpk_hold(path: Path) -> dict[str, Any]:
    from viscoforce.fitting.curves import fit_hold, hold_data
    from viscoforce.fitting.fit import FitData, fit_data
    from viscoforce.fitting.identify import IDENTIFIABILITY
    from viscoforce.io.instruments import load_instrument

    caught: list[warnings.WarningMessage] = []
    with recording(caught):
        curves = load_instrument(path)
        ds = fit_hold(curves, modes="auto")
        data = hold_data(curves)
    n = int(ds["modes"])
    taus = [f"tau_{i}" for i in range(1, n + 1)]
    names = [str(p) for p in ds["param_i"].values]
    params = {p: {"value": float(ds[p]), "stderr": finite(ds[f"{p}_stderr"]),
                  "lower": finite(ds[f"{p}_lower"]) if f"{p}_lower" in ds else None,
                  "upper": finite(ds[f"{p}_upper"]) if f"{p}_upper" in ds else None}
              for p in names}
    selection = [{"modes": int(m), "bic": float(b), "aic": float(a)}
                 for m, b, a in zip(ds["selection_modes"].values, ds["selection_bic"].values,
                                    ds["selection_aic"].values, strict=True)]
    size = data.x.size
    cut = int(round(WINDOW_CUT * size))
    windows = {}
    for label, sl in (("first_10_percent_removed", slice(cut, None)),
                      ("last_10_percent_removed", slice(None, size - cut))):
        part = FitData(data.x[sl], data.y[sl], None,
                       {**data.source, "data_points": int(data.x[sl].size)})
        with recording(caught):
            refit = fit_data(part, "relaxation", modes=n)
        codes = dict(zip((str(p) for p in refit["param_i"].values),
                         np.asarray(refit["identifiability"].values).reshape(-1).tolist(),
                         strict=True)) if "identifiability" in refit else {}
        moved = {}
        for t in taus:
            s = params[t]["stderr"]
            new = float(refit[t])
            moved[t] = {"value": new, "stderr": finite(refit[f"{t}_stderr"]),
                        "identifiability": IDENTIFIABILITY.get(int(codes.get(t, 3))),
                        "shift_in_stderr": finite((new - params[t]["value"]) / s) if s else None}
        windows[label] = {"samples": int(data.x[sl].size), "t_start_s": float(data.x[sl][0]),
                          "t_stop_s": float(data.x[sl][-1]), "redchi": finite(refit["redchi"]),
                          "tau": moved}
    return {"status": "ok", "file": str(path), "samples": int(size),
            "force_baseline_subtracted": int("force_baseline" in ds.attrs
                                             or curves.attrs.get("force_baseline_subtracted", 0)),
            "hold_s": float(data.x[-1] - data.x[0]), "modes": n,
            "selection": selection, "selection_note": ds.attrs.get("selection_note"),
            "criterion": ds.attrs.get("criterion"), "params": params,
            "redchi": finite(ds["redchi"]),
            "residual_lag1": float(ds.attrs["residual_lag1"]),
            "stderr_correction": float(ds.attrs["stderr_correction"]),
            "effective_samples": float(ds.attrs["effective_samples"]),
            "stderr_method": ds.attrs.get("stderr_method"),
            "window_test": windows, "warnings": warning_summary(caught)}


def loose(tau: dict[str, Any]) -> str:
    """A marker for a refitted τ that is not determined: by the profile or by the local test."""
    if tau["identifiability"] != "determined":
        return " (not determined)"
    if tau["stderr"] is None or tau["stderr"] > abs(tau["value"]):
        return f" (refit {num(tau['value'], 2)} ± {num(tau['stderr'], 1)} s)"
    return ""


def hold_row(r: dict[str, Any]) -> tuple[str, str, str]:
    n = r["modes"]
    taus = ", ".join(pm(r["params"][f"tau_{i}"]["value"], r["params"][f"tau_{i}"]["stderr"])
                     for i in range(1, n + 1))
    capped = r["selection_note"] is not None
    kept = (f"BIC keeps falling up to the {n}-mode cap" if capped
            else f"BIC keeps {n} mode{'s' if n > 1 else ''}")
    shifts = []
    for label, text in (("first_10_percent_removed", "first"), ("last_10_percent_removed", "last")):
        w = r["window_test"][label]
        cut = r["hold_s"] - (w["t_stop_s"] - w["t_start_s"])
        shifts.append(", ".join(
            num(m["shift_in_stderr"], 2) + loose(m) for m in w["tau"].values())
            + f" without the {text} 10 % ({cut:.0f} s)")
    f_inf = r["params"]["F_inf"]
    baseline = (" (relative to the file's free-cantilever baseline)"
                if r["force_baseline_subtracted"] else " (force not baseline-corrected)")
    result = (f"{kept} ({r['samples']} samples): τ = {taus} s; F_inf = "
              f"{num(f_inf['value'] * 1e9, 2)} nN{baseline}. Stderr × "
              f"{r['stderr_correction']:.2f} for residual lag-1 autocorrelation "
              f"{r['residual_lag1']:.2f} ({r['effective_samples']:.0f} effective samples). "
              f"Window test, {n} modes refitted: τ moves by {'; by '.join(shifts)}, in stated "
              f"stderr")
    return (f"JPK stress relaxation, {r['hold_s']:.0f} s hold",
            cmd(Path(HOLD_FILE).name, "--model relaxation --modes auto"), result)


# ── 2. the 15-curve relaxation zip ───────────────────────────────────────────────────────────────

def zip_map(path: Path) -> dict[str, Any]:
    from viscoforce.fitting.maps import fit_map, map_summary
    from viscoforce.io.instruments import load_instrument

    caught: list[warnings.WarningMessage] = []
    with recording(caught):
        curves = load_instrument(path)
        result = fit_map(curves, "relaxation", modes="auto", scheduler="synchronous")
        summary = map_summary(result)
    modes = Counter(int(m) for m in np.asarray(result["modes"].values).reshape(-1))
    return {"status": "ok", "file": str(path), "summary": summary,
            "modes_fitted": {str(k): v for k, v in sorted(modes.items())},
            "n_failed": int(result.attrs["n_failed"]),
            "messages": dict(Counter(str(m) for m in result["message"].values)),
            "median_redchi": quartiles(result["redchi"].values)["median"],
            "warnings": warning_summary(caught)}


def zip_row(r: dict[str, Any]) -> tuple[str, str, str]:
    s = r["summary"]
    parts = [f"{s['n_good']} of {s['n_fits']} good (left out: {left_out_text(s['left_out'])})"]
    for count, row in s["by_modes"].items():
        if not row["n"]:
            continue
        taus = [k for k in row["params"] if k.startswith("tau_")]
        med = ", ".join(num(row["params"][t]["median"], 3) for t in taus)
        slow = row["params"][taus[-1]]
        parts.append(f"{row['n']} with {count} mode{'s' if count != '1' else ''}: median τ = {med} s "
                     f"(IQR of the slowest {num(slow['q25'], 2)}–{num(slow['q75'], 2)} s)")
    return ("the 15-curve zip of the same cell",
            cmd(Path(ZIP_FILE).name, "--model relaxation --modes auto"), "; ".join(parts))


# ── 3. the modulation map ────────────────────────────────────────────────────────────────────────

def chooser(spec) -> dict[str, Any]:
    from viscoforce.fitting import fit_spectrum

    caught: list[warnings.WarningMessage] = []
    rows = []
    for i in range(spec.sizes["curve"]):
        with recording(caught):
            fit = fit_spectrum(spec.isel(curve=i), "auto", radius=RADIUS)
        labels = [str(x) for x in fit["selection_label"].values]
        bic = np.asarray(fit["selection_bic"].values, dtype=float)
        best = np.nanmin(bic)
        rows.append({"curve": i, "kept": str(fit.attrs["candidate"]),
                     "redchi": float(fit["redchi"]), "chi2_pvalue": float(fit["chi2_pvalue"]),
                     "bic_above_best": {lab: finite(b - best) for lab, b in
                                        zip(labels, bic, strict=True)}})
    labels = list(dict.fromkeys(lab for r in rows for lab in r["bic_above_best"]))
    bic_median = {lab: quartiles(np.array([r["bic_above_best"][lab] for r in rows
                                           if r["bic_above_best"].get(lab) is not None],
                                          dtype=float))["median"] for lab in labels}
    return {"curves": len(rows), "kept": dict(Counter(r["kept"] for r in rows).most_common()),
            "median_redchi": quartiles(np.array([r["redchi"] for r in rows]))["median"],
            "median_chi2_pvalue": quartiles(np.array([r["chi2_pvalue"] for r in rows]))["median"],
            "median_bic_above_best": bic_median, "per_curve": rows,
            "warnings": warning_summary(caught)}


def material_map(spec, key: str) -> dict[str, Any]:
    from viscoforce.fitting.maps import fit_map, map_summary

    caught: list[warnings.WarningMessage] = []
    with recording(caught):
        result = fit_map(spec, "contact", radius=RADIUS, scheduler="synchronous",
                         **MATERIALS[key])
        summary = map_summary(result)
    ok = np.asarray(result["success"].values, dtype=bool).reshape(-1)
    names = [str(p) for p in result["param_i"].values]
    fitted = {p: quartiles(np.asarray(result[p].values, dtype=float).reshape(-1)[ok])
              for p in names}
    redchi = np.asarray(result["redchi"].values, dtype=float).reshape(-1)
    return {"summary": summary, "n_converged": int(ok.sum()), "converged_params": fitted,
            "median_redchi": quartiles(redchi[ok])["median"], "warnings": warning_summary(caught)}


def split_half_check(path: Path) -> dict[str, Any]:
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))
    import split_half

    caught: list[warnings.WarningMessage] = []
    with recording(caught):
        result = split_half.split_half(split_half.segments(path))
    return {**result, "warnings": warning_summary(caught)}


def modulation_map(path: Path, curves: int | None) -> dict[str, Any]:
    from viscoforce.experiments.modulation import modulation_spectrum
    from viscoforce.io.instruments import load_instrument

    caught: list[warnings.WarningMessage] = []
    with recording(caught):
        spec = modulation_spectrum(load_instrument(path))
    total = int(spec.sizes["curve"])
    if curves is not None:
        spec = spec.isel(curve=slice(0, curves))
    freqs = [float(f) for f in np.asarray(spec["frequency"].values)]
    out = {"status": "ok", "file": str(path), "curves_in_file": total,
           "curves_fitted": int(spec.sizes["curve"]), "frequencies_hz": freqs,
           "radius_m": RADIUS, "radius_note": "not in the file: 10 um assumed",
           "load_warnings": warning_summary(caught)}
    out["chooser"] = chooser(spec)
    out["maps"] = {key: material_map(spec, key) for key in MATERIALS}
    out["split_half"] = split_half_check(path)
    return out


def map_text(key: str, r: dict[str, Any]) -> str:
    s = r["summary"]
    good = s["params"] if s["n_good"] else None
    head = {"structural": "structural", "power-law+mu": "power law + μ", "sls": "SLS"}[key]
    text = f"{head}: {s['n_good']} good of {s['n_fits']} (left out: {left_out_text(s['left_out'])})"
    if good:
        text += ", good: " + ", ".join(iqr_text(p, q) for p, q in good.items() if p != "C1")
    text += (f"; all {r['n_converged']} converged: "
             + ", ".join(iqr_text(p, q) for p, q in r["converged_params"].items() if p != "C1")
             + f", median redchi {num(r['median_redchi'], 2)}")
    return text


def modulation_row(r: dict[str, Any]) -> tuple[str, str, str]:
    c = r["chooser"]
    kept = ", ".join(f"{lab} on {n}" for lab, n in c["kept"].items())
    bic = ", ".join(f"{lab} +{num(v, 2 if v < 10 else 3)}"
                    for lab, v in c["median_bic_above_best"].items() if v is not None)
    sh = r["split_half"]
    z = ", ".join(f"{f:g} Hz {sh['rms_z']['new'][i]:.2f}/{sh['rms_z']['white'][i]:.2f}"
                  for i, f in enumerate(sh["frequencies_hz"]))
    maps = [map_text(k, m) for k, m in r["maps"].items()]
    sub = ("" if r["curves_fitted"] == r["curves_in_file"]
           else f"; first {r['curves_fitted']} of {r['curves_in_file']} curves")
    result = (f"R = 10 µm assumed (not in the file){sub}. (a) `--model auto` kept {kept} of "
              f"{c['curves']}; median redchi {num(c['median_redchi'], 2)}, p = "
              f"{num(c['median_chi2_pvalue'], 2)}; median BIC above the best: {bic}. "
              f"(b) {maps[0]}. (c) {'. '.join(maps[1:])}. (d) lock-in split-half rms z, "
              f"new/white stderr: {z} (1 where the stderr hold)")
    command = "; ".join([cmd("MAP --model auto --R 10um --curve I")]
                        + [cmd("MAP --model contact", MATERIAL_FLAGS[k], "--R 10um")
                           for k in MATERIALS]
                        + ["`python benchmarks/split_half.py`"])
    return (f"JPK modulation map, 4×4, {len(r['frequencies_hz'])} frequencies "
            f"(MAP = `{Path(MAP_FILE).name}`)", command, result)


# ── output ───────────────────────────────────────────────────────────────────────────────────────

def markdown(rows: list[tuple[str, str, str]]) -> str:
    lines = ["| data | command | result |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    return "\n".join(lines)


def machine() -> dict[str, Any]:
    import viscoforce

    blas = [{"library": Path(d.get("filepath", "")).name, "internal_api": d.get("internal_api"),
             "num_threads": d.get("num_threads")}
            for d in threadpool_info() if d.get("user_api") == "blas"]
    return {"python": platform.python_version(), "platform": platform.platform(),
            "cpu_count": os.cpu_count(), "numpy": np.__version__,
            "viscoforce": viscoforce.__version__, "blas": blas,
            "blas_threads": sorted({b["num_threads"] for b in blas}),
            "loadavg": list(os.getloadavg()) if hasattr(os, "getloadavg") else None}


def run(name: str, path: Path | None, job: Callable[[Path], dict[str, Any]]) -> dict[str, Any]:
    """Run one data set's analysis; skipped when its file is absent, ``error`` when it raised."""
    if path is None or not path.is_file():
        print(f"{name}: SKIPPED, no file {path}")
        return {"status": "skipped", "file": None if path is None else str(path)}
    start = time.perf_counter()
    try:
        out = job(path)
    except Exception as exc:  # reported, not raised: the other data sets still run
        traceback.print_exc()
        print(f"{name}: ERROR {type(exc).__name__}: {exc}")
        return {"status": "error", "file": str(path), "error": f"{type(exc).__name__}: {exc}"}
    out["seconds"] = time.perf_counter() - start
    print(f"{name}: done in {out['seconds']:.1f} s ({path})")
    return out


def print_warnings(name: str, summary: dict[str, Any]) -> None:
    if not summary["total"]:
        return
    cats = ", ".join(f"{n} {c}" for c, n in summary["by_category"].items())
    print(f"  {name} warnings: {summary['total']} ({cats})")
    for sentence, n in summary["sentences"].items():
        print(f"    {n:3d}× {sentence}")


def clean(obj: Any) -> Any:
    """The report with NaN/inf as None and NumPy scalars as Python ones (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): clean(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [clean(v) for v in obj]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"the modulation map only, its first {QUICK_CURVES} curves")
    parser.add_argument("--out", type=Path, default=HERE / "out",
                        help="output folder (default: benchmarks/out)")
    parser.add_argument("--data", type=Path, default=DATA_DIR,
                        help="folder of the real files (default: ../shared/data/real)")
    args = parser.parse_args(argv)
    wall = time.perf_counter()
    args.out.mkdir(parents=True, exist_ok=True)
    map_path = args.data / MAP_FILE
    if not map_path.is_file() and BUNDLED_MAP.is_file():
        map_path = BUNDLED_MAP
    with threadpool_limits(limits=1):
        facts = machine()
        print("BLAS pinned to one thread (threadpoolctl): "
              + (", ".join(f"{b['library']} ({b['num_threads']} thread)" for b in facts["blas"])
                 or "no BLAS found"))
        datasets: dict[str, dict[str, Any]] = {}
        if args.quick:
            print("--quick: the stress-relaxation hold and the 15-curve zip are not run")
            datasets["jpk_hold"] = {"status": "skipped", "file": str(args.data / HOLD_FILE),
                                    "reason": "--quick"}
            datasets["zip_map"] = {"status": "skipped", "file": str(args.data / ZIP_FILE),
                                   "reason": "--quick"}
        else:
            datasets["jpk_hold"] = run("JPK stress relaxation", args.data / HOLD_FILE, jpk_hold)
            datasets["zip_map"] = run("15-curve zip", args.data / ZIP_FILE, zip_map)
        datasets["modulation_map"] = run(
            "JPK modulation map", map_path,
            lambda p: modulation_map(p, QUICK_CURVES if args.quick else None))

    rows = []
    for key, make in (("jpk_hold", hold_row), ("zip_map", zip_row),
                      ("modulation_map", modulation_row)):
        if datasets[key]["status"] == "ok":
            rows.append(make(datasets[key]))
    table = markdown(rows)

    hold = datasets["jpk_hold"]
    if hold["status"] == "ok":
        print(f"hold: {hold['modes']} modes; lag-1 {hold['residual_lag1']:.3f}, stderr × "
              f"{hold['stderr_correction']:.3f}, effective samples {hold['effective_samples']:.0f}")
        for label, w in hold["window_test"].items():
            print(f"  window, {label.replace('_', ' ')}: τ shift / stderr = "
                  + ", ".join(f"{k} {num(v['shift_in_stderr'], 3)}" for k, v in w["tau"].items()))
        print_warnings("hold", hold["warnings"])
    if datasets["zip_map"]["status"] == "ok":
        print_warnings("zip", datasets["zip_map"]["warnings"])
    mod = datasets["modulation_map"]
    if mod["status"] == "ok":
        print_warnings("modulation map, load", mod["load_warnings"])
        print_warnings("modulation map, chooser", mod["chooser"]["warnings"])
        for key, m in mod["maps"].items():
            print_warnings(f"modulation map, {key} map", m["warnings"])
        sh = mod["split_half"]
        print("split-half rms z (new / white): " + ", ".join(
            f"{f:g} Hz {sh['rms_z']['new'][i]:.2f}/{sh['rms_z']['white'][i]:.2f}"
            for i, f in enumerate(sh["frequencies_hz"])))
        with open(args.out / "real_data_curves.csv", "w", newline="") as handle:
            writer = csv.writer(handle)
            labels = list(mod["chooser"]["median_bic_above_best"])
            writer.writerow(["curve", "kept", "redchi", "chi2_pvalue",
                             *(f"bic_above_best[{lab}]" for lab in labels)])
            for r in mod["chooser"]["per_curve"]:
                writer.writerow([r["curve"], r["kept"], r["redchi"], r["chi2_pvalue"],
                                 *(r["bic_above_best"].get(lab) for lab in labels)])

    print()
    print("Markdown table for the README (\"Measured on the real files\"):")
    print()
    print(table)
    print()
    report = {"schema": SCHEMA, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
              "quick": args.quick, "machine": facts, "data_dir": str(args.data),
              "radius_m": RADIUS, "datasets": datasets, "markdown": table,
              "wall_time_s": time.perf_counter() - wall}
    (args.out / "real_data.json").write_text(json.dumps(clean(report), indent=2, allow_nan=False)
                                             + "\n")
    (args.out / "real_data.md").write_text(table + "\n")
    print(f"wrote {args.out / 'real_data.json'}, {args.out / 'real_data.md'}"
          + (f", {args.out / 'real_data_curves.csv'}" if mod["status"] == "ok" else "")
          + f" in {report['wall_time_s']:.1f} s")
    return 1 if any(d["status"] == "error" for d in datasets.values()) else 0


if __name__ == "__main__":
    raise SystemExit(main())
