#!/usr/bin/env python
"""The README's "Measured on the real files" table, regenerated from the real files (issues 20, 21).

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
   ``studies/split_half/split_half.py``'s own functions. The tip radius is not in the file: R = 10 µm is
   assumed (the CLI default).

4. Force curves, on every real file whose curves have the segment (found at run time, not listed
   here): (a) ``hertz`` on the approach — per curve ``fit_data(curve_data(curves, "hertz",
   curve=i), "hertz", tip=...)`` (a single curve through ``fit_curve``, profiled, exactly what
   ``viscoforce fit FILE --model hertz`` does; a map's curves unprofiled, as ``fit_map`` fits
   them, plus ``fit_map`` + ``map_summary`` for the good counts). The tip: the file's own where
   its reader finds one (the UFF header's pyramid), else ``TIP_ASSUMED`` = sphere:5um for every
   file — an assumption, not a measurement (the JPK, Asylum and Chiaro readers pass no tip on).
   Reported: E (the paper's convention) and E_young (ν = 0.5) ± stderr (quartiles over a map's
   curves), the contact point's stderr, the indentation depth (also over R), the residual lag-1
   and the stderr correction; the tilted baseline's rise before the contact point relative to
   the contact force (above ``TILT_FLAG`` the table says the baseline is not a free cantilever);
   and a window test: the approach refitted up to where the contact force first reaches
   ``FORCE_CUT`` (50 %) of its maximum, and without the contact samples of the first half of
   the indentation depth, E's shift in units of the full fit's stated stderr (and relative).
   For a zip holding a vendor text export whose header gives ``Tip radius (um)`` and
   ``E[v=0.500] (Pa)`` (the Chiaro export), one more fit with that radius against the
   instrument's own Hertz result (``header_tip_check``). (b) ``creep`` (``modes="auto"``) on the
   constant-force pause: a single curve through ``fit_curve`` (profiled: parameters the
   profile bounds on one side only are reported as that bound, ``bound_text``), a map through
   ``fit_map`` + ``map_summary`` (the local identifiability test) with each curve's residual
   lag-1 recomputed from its fitted parameters; modes kept, τ_i ± stderr, τ longer than the
   pause flagged (a drift), and a window test as for the hold (first / last 10 % of the pause
   removed, same modes, t from the pause's start; the refits judged by the local test).
5. Coverage: every file of the data folder (LICENSE, SOURCE.txt and notes aside) is loaded with
   ``load_instrument``; a refusal is recorded verbatim (path dropped); a loaded file gets per
   model (hertz, creep, relaxation: ``curve_data`` on curve 0; contact: ``modulation_spectrum``)
   ``"ok"`` or the library's reason, and the analyses of this run that fitted it.

Fits warn (GoodnessOfFitWarning, AccuracyWarning, DataWarning, ModelValidityWarning): every warning
is recorded, not printed — per data set the count per category and the distinct first sentences
(numbers masked as ``#``) with their counts. A data set whose file is absent is skipped and the
output says so.

BLAS is pinned to one thread (``OPENBLAS_NUM_THREADS=1`` etc. before NumPy loads, plus
``threadpoolctl.threadpool_limits(1)``). ``--quick``: the modulation map only, its first 4 curves
for (a)–(c), and the split-half on the whole map; coverage of every file; hertz on the
single-curve files; creep on :data:`QUICK_CREEP_FILE` only. Prints the Markdown table to paste
into the README and the coverage table, and writes ``real_data.json`` (every number; keys
``schema``, ``created``, ``quick``, ``machine``, ``data_dir``, ``radius_m``, ``datasets``
(``jpk_hold``, ``zip_map``, ``modulation_map``, each with ``status``: ``"ok"``, ``"skipped"`` or
``"error"``; ``hertz`` and ``creep``, each with ``status`` and ``files``: path relative to the
data folder → that file's result with its own ``status``; ``hertz`` also ``tip_assumed``,
``tip_note``, ``poisson``, ``force_cut``, ``tilt_flag``; ``creep`` also ``window_cut``),
``coverage`` (``status``, ``data_dir``, ``n_files``, ``files``: per file ``file``, ``label``,
``bytes``, ``read_as``, ``curves``, ``load_error``, ``models``, ``analysed``, ``not_run``,
``outcome`` — ``"analysed"``, ``"not run"`` or ``"refused"`` — and ``reason``; ``markdown``),
``markdown``, ``wall_time_s``), ``real_data.md`` (the table), ``real_data_coverage.md`` and
``real_data_curves.csv`` (the chooser per curve) to ``--out`` (default studies/real_data/out). Exit
status 1 when an analysis raised, else 0.
Run ``python studies/real_data/real_data.py [--quick] [--out DIR] [--data DIR]``.
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
from datetime import UTC, datetime  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import numpy as np  # noqa: E402
from threadpoolctl import threadpool_info, threadpool_limits  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SPLIT_HALF = ROOT / "studies" / "split_half"  # split_half.py, whose functions (d) uses
DATA_DIR = ROOT.parent / "shared" / "data" / "real"
BUNDLED_MAP = ROOT / "data_examples" / "real" / "modulation-map.jpk-force-map"
HOLD_FILE = "afmformats/fmt-jpk-sr_cell1-0008.jpk-force"
ZIP_FILE = "afmformats/10.1002_btm2.10294_fig5d-cell1.zip"
MAP_FILE = "PyFMReader/map-data-2021.11.05-17.37.44.432.jpk-force-map"
SCHEMA = "viscoforce.real_data/2"
RADIUS = 10e-6          # not in the file: the CLI default is assumed
WINDOW_CUT = 0.10       # fraction of the hold's samples dropped at one end in the window test
QUICK_CURVES = 4
#: --quick: creep on this single-curve file (about 3 s; the brain-tissue curve takes 9 s), or on
#: the first single-curve file when it is absent
QUICK_CREEP_FILE = "afmformats/fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force"
#: contact materials of the map fits: key → fit_map keywords
MATERIALS = {"structural": {"material": "structural"},
             "power-law+mu": {"material": "power-law", "newtonian": True},
             "sls": {"material": "sls"}}
#: the tip of the Hertz fits where the file records none (an assumption: a colloidal probe of
#: R = 5 µm, as used on cells and gels; the files do not say)
TIP_ASSUMED = "sphere:5um"
TIP_NOTE = ("not in the files (except where a reader finds one: the UFF header's pyramid): "
            "a 5 um sphere is assumed for every file, the same for all")
FORCE_CUT = 0.5         # the Hertz window test fits the approach up to this share of the max force
TILT_FLAG = 0.2         # a fitted baseline rising by more than this share of the contact force
CURVE_MODELS = ("hertz", "creep", "relaxation")
MODEL_ORDER = ("hertz", "creep", "relaxation", "contact")
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
    from viscoforce.fitting.data import FitData
    from viscoforce.fitting.fit import fit_data
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
    from viscoforce.fitting.maps import fit_map
    from viscoforce.fitting.pixels import map_summary
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
    from viscoforce.fitting.maps import fit_map
    from viscoforce.fitting.pixels import map_summary

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
    if str(SPLIT_HALF) not in sys.path:
        sys.path.insert(0, str(SPLIT_HALF))
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
                        + ["`python studies/split_half/split_half.py`"])
    return (f"JPK modulation map, 4×4, {len(r['frequencies_hz'])} frequencies "
            f"(MAP = `{Path(MAP_FILE).name}`)", command, result)


# ── 4. force curves: hertz on the approach, creep on the constant-force pause ───────────────────

#: Short labels of the real files for the table (from the folders' SOURCE.txt; the file name
#: stays in the command column).
LABELS = {
    "fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force": "JPK creep-compliance curve, brain tissue",
    "fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force": "JPK creep-compliance curve, polymer gel",
    "fmt-jpk-sr_cell1-0008.jpk-force": "JPK stress-relaxation curve, oocyte",
    "10.1002_btm2.10294_fig5d-cell1.zip": "the 15-curve zip (oocyte)",
    "map-data-2022.10.29-12.27.34.564.jpk-force-map": "PyFMRheo JPK map, 4×4, soft sample",
    "map-data-2021.11.05-17.37.44.432.jpk-force-map": "JPK modulation map, 4×4",
    "fmt-igor-fd_SiN_FD_plot.ibw": "Asylum MFP-3D curve (.ibw), SiN",
    "fmt-igor-fd_U3_3_p10004.ibw": "Asylum MFP-3D force-map point (.ibw)",
    "fmt-chiaro-txt_AEBP1_Indentation_002.zip": "Optics11 Chiaro indentation",
    "20200904_Egel4-Z1.0_00025.uff": "UFF text export of a Bruker curve, PAAm gel",
    "20200904_Egel4-Z1.0_00025.spm": "Bruker Nanoscope curve (.spm), PAAm gel",
    "fmt-afm-workshop-fd_single_2021-10-22_14.16.csv": "AFM Workshop curve (.csv)",
    "fmt-ntmdt-txt-fd_2015_01_17_gel4-0_1_mQ_adh_6B_Curve_DFL_Height_51.txt":
        "NT-MDT text export, gel",
}
FIT_ERRORS: tuple[type[BaseException], ...] = (ValueError, ArithmeticError, RuntimeError)


def label(rel: str) -> str:
    name = Path(rel).name
    return LABELS.get(name, name)


def first_line(exc: BaseException, path: Path | None = None) -> str:
    """``Type: message`` of an exception, the file's path dropped from its message."""
    text = str(exc)
    if path is not None:
        text = text.replace(f"{path}: ", "").replace(str(path), path.name)
    return f"{type(exc).__name__}: {text}"


def hertz_tip(curves) -> tuple[Any, str]:
    """The tip of a file's Hertz fits: the file's own where it records one, else TIP_ASSUMED."""
    from viscoforce.fitting.curves import file_tip
    from viscoforce.physics.tips import parse_tip

    tip = file_tip(curves)
    return (tip, "file") if tip is not None else (parse_tip(TIP_ASSUMED), "assumed")


def tip_flag(tip_source: str) -> str:
    return f"--tip {TIP_ASSUMED}" if tip_source == "assumed" else "(the file's tip)"


def ident_labels(ds) -> dict[str, str]:
    from viscoforce.fitting.identify import IDENTIFIABILITY

    names = [str(p) for p in ds["param_i"].values]
    if "identifiability" not in ds.variables:
        return {}
    codes = np.asarray(ds["identifiability"].values).reshape(-1).tolist()
    return {n: IDENTIFIABILITY.get(int(c), str(c)) for n, c in zip(names, codes, strict=True)}


def hertz_window_fits(data, fit, tip) -> dict[str, Any]:
    """Refit the approach on two windows and move E in units of the full fit's stated stderr.

    ``force_to_half``: the approach up to where the contact force (F minus the fitted tilted
    baseline) first reaches FORCE_CUT of its maximum; ``deep_half``: the contact samples of the
    first half of the indentation depth removed (the free part and the deeper half kept).
    """
    from viscoforce.fitting.data import FitData
    from viscoforce.fitting.fit import fit_data

    x, y = data.x, data.y
    cp, b, s = (float(fit[k]) for k in ("contact_point", "baseline", "baseline_slope"))
    contact = x > cp
    if contact.sum() < 4:
        return {"error": "fewer than 4 samples in contact"}
    fc = y - (b + s * (x - cp))
    fmax = float(np.max(fc[contact]))
    depth = float(np.max(x[contact]) - cp)
    reach = np.flatnonzero(contact & (fc >= FORCE_CUT * fmax))
    stop = int(reach[0]) if reach.size else x.size
    keeps = {"force_to_half": np.arange(x.size) < stop,
             "deep_half": ~(contact & (x < cp + 0.5 * depth))}
    E, sE = float(fit["E"]), finite(fit["E_stderr"])
    sc = finite(fit["contact_point_stderr"])
    out: dict[str, Any] = {}
    for name, keep in keeps.items():
        part = FitData(x[keep], y[keep], None, {**data.source, "data_points": int(keep.sum())})
        try:
            refit = fit_data(part, "hertz", tip=tip, profile=False)
        except FIT_ERRORS as exc:
            out[name] = {"samples": int(keep.sum()), "error": first_line(exc)}
            continue
        new, cp_new = float(refit["E"]), float(refit["contact_point"])
        out[name] = {"samples": int(keep.sum()),
                     "samples_in_contact": int((keep & contact).sum()),
                     "E": new, "E_stderr": finite(refit["E_stderr"]),
                     "shift_in_stderr": finite((new - E) / sE) if sE else None,
                     "relative_shift": (new - E) / E,
                     "contact_point_shift_in_stderr": finite((cp_new - cp) / sc) if sc else None,
                     "residual_lag1": float(refit.attrs.get("residual_lag1", math.nan))}
    return out


def hertz_curve(data, fit, tip) -> dict[str, Any]:
    """The numbers of one Hertz fit (``fit`` with the derived moduli) and its window test."""
    x, y = data.x, data.y
    cp, b, s = (float(fit[k]) for k in ("contact_point", "baseline", "baseline_slope"))
    contact, free = x > cp, x <= cp
    fc = y - (b + s * (x - cp))
    fmax = float(np.max(fc[contact])) if contact.any() else math.nan
    depth = float(np.max(x[contact]) - cp) if contact.any() else 0.0
    radius = getattr(tip, "radius", None)
    tilt = abs(s) * float(cp - np.min(x[free])) if free.any() else 0.0
    names = ("E", "E_young", "contact_point", "baseline", "baseline_slope")
    return {
        "samples": int(x.size), "success": bool(int(fit["success"])),
        **{n: float(fit[n]) for n in names},
        **{f"{n}_stderr": finite(fit[f"{n}_stderr"]) for n in names},
        "identifiability": ident_labels(fit),
        "redchi": finite(fit["redchi"]),
        "residual_lag1": float(fit.attrs.get("residual_lag1", math.nan)),
        "stderr_correction": float(fit.attrs.get("stderr_correction", math.nan)),
        "effective_samples": finite(fit.attrs.get("effective_samples", math.nan)),
        "indentation_m": depth, "contact_force_n": fmax,
        "indentation_over_radius": depth / radius if radius else None,
        "baseline_tilt_share": finite(tilt / fmax) if fmax > 0 else None,
        "windows": hertz_window_fits(data, fit, tip)}


def header_tip_check(path: Path, curves, caught: list[warnings.WarningMessage]
                     ) -> dict[str, Any] | None:
    """A vendor text export's own tip radius and Hertz result, and viscoforce's fit with it.

    Only for a zip holding a text export with ``Tip radius (um)`` and ``E[v=0.500] (Pa)`` header
    lines (the Chiaro export): viscoforce's reader does not pass the radius on, so the assumed
    tip is used in the main fit; this refit with the header's radius compares with the
    instrument's own Hertz fit.
    """
    import zipfile

    from viscoforce.fitting.curves import fit_curve
    from viscoforce.physics.tips import Sphere

    if not zipfile.is_zipfile(path):
        return None
    with zipfile.ZipFile(path) as archive:
        texts = [n for n in archive.namelist() if n.lower().endswith(".txt")]
        head = archive.read(texts[0])[:8192].decode("latin-1") if texts else ""
    radius = re.search(r"Tip radius \(um\)\s+([\d.]+)", head)
    young = re.search(r"E\[v=0\.500\] \(Pa\)\s+([\d.]+)", head)
    if not (radius and young):
        return None
    tip = Sphere(float(radius.group(1)) * 1e-6)
    with recording(caught):
        fit = fit_curve(curves, "hertz", tip=tip)
    return {"tip_radius_m": tip.radius, "E_young_instrument": float(young.group(1)),
            "E_young": float(fit["E_young"]), "E_young_stderr": finite(fit["E_young_stderr"]),
            "E": float(fit["E"]), "note": "the header's tip radius and the instrument's own Hertz "
            "fit (E[v=0.500]); the reader does not pass the radius on"}


def hertz_file(path: Path, curves) -> dict[str, Any]:
    """Hertz on the approach of every curve of one file (a map also through ``fit_map``)."""
    from viscoforce.fitting.curves import curve_data, fit_curve
    from viscoforce.fitting.fit import fit_data
    from viscoforce.fitting.maps import fit_map
    from viscoforce.fitting.moduli import add_derived_moduli
    from viscoforce.fitting.pixels import map_summary

    tip, tip_source = hertz_tip(curves)
    n = int(curves.sizes["curve"])
    caught: list[warnings.WarningMessage] = []
    rows = []
    for i in range(n):
        try:
            with recording(caught):
                data = curve_data(curves, "hertz", curve=i)
                if n == 1:  # what `viscoforce fit FILE --model hertz` does (profiled)
                    fit = fit_curve(curves, "hertz", curve=i, tip=tip)
                else:       # a map's pixel: fit_map's fit, with the attrs of a single fit
                    fit = add_derived_moduli(fit_data(data, "hertz", tip=tip, profile=False))
                rows.append({"curve": i, **hertz_curve(data, fit, tip)})
        except FIT_ERRORS as exc:
            rows.append({"curve": i, "error": first_line(exc)})
    rel = path.name
    out: dict[str, Any] = {
        "status": "ok", "file": str(path), "label": label(rel),
        "format": curves.attrs.get("source"), "curves": n, "tip": tip.describe(),
        "tip_attrs": tip.as_attrs(), "tip_source": tip_source,
        "command": cmd(rel, "--model hertz", *(() if tip_source == "file"
                                                else (f"--tip {TIP_ASSUMED}",))),
        "per_curve": rows}
    if n > 1:
        with recording(caught):
            result = fit_map(curves, "hertz", tip=tip, scheduler="synchronous")
            out["map_summary"] = map_summary(result)
    out["summary"] = hertz_summary(rows)
    check = header_tip_check(path, curves, caught)
    if check is not None:
        out["header_tip_check"] = check
    out["warnings"] = warning_summary(caught)
    return out


def hertz_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Quartiles over the fitted curves; the window test as |shift| quartiles and counts ≤ 2."""
    ok = [r for r in rows if "error" not in r]

    def q(key: str) -> dict[str, float | None]:
        return quartiles(np.array([np.nan if r.get(key) is None else r[key] for r in ok],
                                  dtype=float))

    windows = {}
    for name in ("force_to_half", "deep_half"):
        shifts = np.array([r["windows"][name]["shift_in_stderr"] for r in ok
                           if r["windows"].get(name, {}).get("shift_in_stderr") is not None],
                          dtype=float)
        relative = np.array([r["windows"][name]["relative_shift"] for r in ok
                             if "relative_shift" in r["windows"].get(name, {})], dtype=float)
        windows[name] = {"n": int(shifts.size), "abs_shift": quartiles(np.abs(shifts)),
                         "shift": quartiles(shifts), "relative_shift": quartiles(relative),
                         "within_2": int(np.sum(np.abs(shifts) <= 2))}
    keys = ("E", "E_young", "E_stderr", "E_young_stderr", "contact_point_stderr",
            "residual_lag1", "stderr_correction", "effective_samples", "indentation_m",
            "indentation_over_radius", "contact_force_n", "baseline_tilt_share")
    return {"n_fitted": len(ok), "n_failed": len(rows) - len(ok),
            **{k: q(k) for k in keys}, "windows": windows}


SI_PREFIXES = ((1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n"),
               (1e-12, "p"))


def si_scale(value: float) -> tuple[float, str]:
    """(factor, prefix) of the SI prefix for ``value`` (M … p)."""
    for factor, prefix in SI_PREFIXES:
        if abs(value) >= factor:
            return factor, prefix
    return SI_PREFIXES[-1]


def si_text(value: float | None, unit: str, digits: int = 3) -> str:
    """``value`` with an SI prefix chosen for it, e.g. ``"147 nm"``."""
    if value is None or not math.isfinite(value):
        return "–"
    factor, prefix = si_scale(value)
    return f"{num(value / factor, digits)} {prefix}{unit}"


def pm_si(value: float, stderr: float | None, unit: str) -> str:
    """``v ± s`` with one SI prefix for both (rounded at the stderr's first figure)."""
    factor, prefix = si_scale(value)
    return f"{pm(value / factor, None if stderr is None else stderr / factor)} {prefix}{unit}"


def iqr_si(q: dict[str, float | None], unit: str) -> str:
    """``median (q25–q75) unit`` with one SI prefix."""
    if q["median"] is None:
        return "–"
    factor, prefix = si_scale(q["median"])
    return (f"{num(q['median'] / factor)} ({num(q['q25'] / factor, 2)}–"
            f"{num(q['q75'] / factor, 2)}) {prefix}{unit}")


def shift_text(value: float | None) -> str:
    """A shift in stderr units with its sign."""
    return "–" if value is None else f"{'+' if value > 0 else ''}{num(value, 2)}"


def hertz_row(r: dict[str, Any]) -> tuple[str, str, str]:
    s = r["summary"]
    tip = (f"{r['tip']} assumed (not in the file)" if r["tip_source"] == "assumed"
           else f"the file's tip, {r['tip']}")
    cut = f"{FORCE_CUT * 100:.0f} %"
    flagged = [c for c in r["per_curve"] if (c.get("baseline_tilt_share") or 0) > TILT_FLAG]
    if r["curves"] == 1:
        c = r["per_curve"][0]
        if "error" in c:
            return (f"Hertz, {r['label']}", r["command"], f"{tip}: {c['error']}")
        depth = si_text(c["indentation_m"], "m")
        if c["indentation_over_radius"] is not None:
            depth += f" = {num(c['indentation_over_radius'], 2)} R"
        w = c["windows"]
        parts = [f"{tip}: E = {pm_si(c['E'], c['E_stderr'], 'Pa')}, E_young = "
                 f"{pm_si(c['E_young'], c['E_young_stderr'], 'Pa')} (ν = 0.5); contact point "
                 f"± {si_text(c['contact_point_stderr'], 'm', 2)}; {depth} deep at "
                 f"{si_text(c['contact_force_n'], 'N')} ({c['samples']} samples). Stderr × "
                 f"{num(c['stderr_correction'])} for residual lag-1 {c['residual_lag1']:.3f} "
                 f"({num(c['effective_samples'], 2)} effective samples). Window test: E moves by "
                 f"{window_shift(w, 'force_to_half')} up to {cut} of the maximum contact force, "
                 f"by {window_shift(w, 'deep_half')} without the first half of the indentation"]
        check = r.get("header_tip_check")
        if check:
            parts.append(f"With the header's own R = {si_text(check['tip_radius_m'], 'm')}: "
                         f"E_young = {pm_si(check['E_young'], check['E_young_stderr'], 'Pa')}; "
                         f"the instrument's own Hertz fit: {num(check['E_young_instrument'])} Pa")
    else:
        m = r["map_summary"]
        w = s["windows"]
        lag, corr = s["residual_lag1"]["median"], s["stderr_correction"]["median"]
        depth = iqr_si(s["indentation_m"], "m")
        if s["indentation_over_radius"]["median"] is not None:
            depth += f" (median {num(s['indentation_over_radius']['median'], 2)} R)"

        def moved(name: str) -> str:
            x = w[name]
            rel = x["relative_shift"]["median"]
            return (f"{shift_text(x['shift']['median'])} stderr"
                    + ("" if rel is None else f" ({shift_text(100 * rel)} %)")
                    + f", |shift| ≤ 2 on {x['within_2']} of {x['n']}")

        parts = [f"{tip}; {r['curves']} curves, `fit_map`: {m['n_good']} good (left out: "
                 f"{left_out_text(m['left_out'])}); over the {s['n_fitted']} fitted: E = "
                 f"{iqr_si(s['E'], 'Pa')}, E_young = {iqr_si(s['E_young'], 'Pa')} (ν = 0.5); "
                 f"median stderr: E {si_text(s['E_stderr']['median'], 'Pa', 2)}, contact point "
                 f"{si_text(s['contact_point_stderr']['median'], 'm', 2)}; depth {depth}. "
                 f"Median residual lag-1 {num(lag, 2)} (stderr × {num(corr)}). Window test, "
                 f"median shift of E: {moved('force_to_half')} up to {cut} of the maximum "
                 f"contact force; {moved('deep_half')} without the first half of the "
                 f"indentation"]
    if flagged:
        share = np.median([c["baseline_tilt_share"] for c in flagged])
        parts.append(f"On {len(flagged)} of {r['curves']} curve{'s' if r['curves'] > 1 else ''} "
                     f"the fitted baseline rises by {100 * share:.0f} % of the contact force "
                     f"before the contact point (median): not a free cantilever (a long-range repulsion or "
                     f"a soft layer, or contact from the start of the approach), so the contact "
                     f"point and E rest on the model's tilted baseline")
    return f"Hertz, {r['label']}", r["command"], ". ".join(parts)


def window_shift(w: dict[str, Any], name: str) -> str:
    """``+3.4 stderr (+5.1 %)`` of one window refit, or why it has none."""
    entry = w.get(name, {})
    if "error" in entry:
        return f"– (refit failed: {entry['error']})"
    return (f"{shift_text(entry.get('shift_in_stderr'))} stderr "
            f"({shift_text(100 * entry['relative_shift'])} %)")


def creep_params(fit, pause_s: float) -> dict[str, dict[str, Any]]:
    """Each creep parameter: value, stderr, identifiability, its bound (bound_text), and for
    a τ whether it exceeds the pause."""
    from viscoforce.fitting.verdict import bound_text

    labels = ident_labels(fit)
    out = {}
    for p in (str(n) for n in fit["param_i"].values):
        value = float(fit[p])
        if not math.isfinite(value):
            continue
        entry = {"value": value, "stderr": finite(fit[f"{p}_stderr"]),
                 "identifiability": labels.get(p), "bound": bound_text(fit, p)}
        if p.startswith("tau_"):
            entry["longer_than_pause"] = value > pause_s
        out[p] = entry
    return out


def creep_windows(data, taus: dict[str, dict[str, Any]], modes: int,
                  caught: list[warnings.WarningMessage]) -> dict[str, Any]:
    """Refit the pause without its first / last WINDOW_CUT (same modes, t from the full pause's
    start) and move each τ in units of the full fit's stated stderr.

    The refits' identifiability is the local test (stderr > value, none, or at a bound), not
    the profile: profiling every refit would triple the run time.
    """
    from viscoforce.fitting.data import FitData
    from viscoforce.fitting.fit import fit_data

    size = data.x.size
    cut = int(round(WINDOW_CUT * size))
    out = {}
    for name, sl in (("first_10_percent_removed", slice(cut, None)),
                     ("last_10_percent_removed", slice(None, size - cut))):
        part = FitData(data.x[sl], data.y[sl], None,
                       {**data.source, "data_points": int(data.x[sl].size)})
        try:
            with recording(caught):
                refit = fit_data(part, "creep", modes=modes, profile=False)
        except FIT_ERRORS as exc:
            out[name] = {"samples": int(data.x[sl].size), "error": first_line(exc)}
            continue
        labels = ident_labels(refit)
        moved = {}
        for t, old in taus.items():
            new, s = float(refit[t]), old["stderr"]
            moved[t] = {"value": new, "stderr": finite(refit[f"{t}_stderr"]),
                        "identifiability": labels.get(t),
                        "shift_in_stderr": finite((new - old["value"]) / s) if s else None}
        out[name] = {"samples": int(data.x[sl].size), "t_start_s": float(data.x[sl][0]),
                     "t_stop_s": float(data.x[sl][-1]), "tau": moved}
    return out


def creep_file(path: Path, curves) -> dict[str, Any]:
    """Creep (modes by BIC) on the constant-force pause of every curve of one file."""
    from viscoforce.fitting.curves import curve_data, fit_curve
    from viscoforce.fitting.maps import fit_map
    from viscoforce.fitting.models import make_model
    from viscoforce.fitting.outcome import residual_lag1
    from viscoforce.fitting.pixels import map_summary

    n = int(curves.sizes["curve"])
    caught: list[warnings.WarningMessage] = []
    rel = path.name
    out: dict[str, Any] = {"status": "ok", "file": str(path), "label": label(rel),
                           "format": curves.attrs.get("source"), "curves": n,
                           "command": cmd(rel, "--model creep --modes auto")}
    if n == 1:  # what `viscoforce fit FILE --model creep --modes auto` does (profiled)
        with recording(caught):
            data = curve_data(curves, "creep")
            fit = fit_curve(curves, "creep", modes="auto")
        pause = float(data.x[-1] - data.x[0])
        modes = int(fit["modes"])
        params = creep_params(fit, pause)
        out.update(
            samples=int(data.x.size), pause_s=pause,
            creep_force_n=float(fit.attrs.get("creep_force", math.nan)), modes=modes,
            selection=[{"modes": int(k), "bic": float(b)} for k, b in
                       zip(fit["selection_modes"].values, fit["selection_bic"].values,
                           strict=True)],
            selection_note=fit.attrs.get("selection_note"), params=params,
            redchi=finite(fit["redchi"]),
            residual_lag1=float(fit.attrs["residual_lag1"]),
            stderr_correction=float(fit.attrs["stderr_correction"]),
            effective_samples=finite(fit.attrs.get("effective_samples", math.nan)),
            window_test=creep_windows(
                data, {k: v for k, v in params.items() if k.startswith("tau_")}, modes,
                caught))
    else:       # a map: fit_map + map_summary, each pixel's lag-1 and window test
        with recording(caught):
            result = fit_map(curves, "creep", modes="auto", scheduler="synchronous")
            out["map_summary"] = map_summary(result)
        rows = []
        for i in range(n):
            one = result.isel(curve=i)
            modes = int(one["modes"])
            if not int(one["success"]) or modes < 1:
                rows.append({"curve": i, "error": str(one["message"].values)})
                continue
            with recording(caught):
                data = curve_data(curves, "creep", curve=i)
            pause = float(data.x[-1] - data.x[0])
            params = creep_params(one, pause)
            model = make_model("creep", modes=modes)
            values = {p: params[p]["value"] for p in model.names}
            rho = residual_lag1(data.y - model.raw(data.x, values), data.x)
            rows.append({
                "curve": i, "modes": modes, "quality": int(one["quality"]), "pause_s": pause,
                "creep_force_n": float(data.source.get("creep_force", math.nan)),
                "params": params, "residual_lag1": rho,
                "stderr_correction": math.sqrt((1 + rho) / (1 - rho)) if rho > 0 else 1.0,
                "window_test": creep_windows(
                    data, {k: v for k, v in params.items() if k.startswith("tau_")}, modes,
                    caught)})
        out["per_curve"] = rows
        out["summary"] = creep_summary(rows)
    out["warnings"] = warning_summary(caught)
    return out


def creep_summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """A creep map over its fitted curves: modes kept, τ quartiles per mode count (all fitted
    curves), determined τ counts, lag-1, and the window test over the determined τ."""
    ok = [r for r in rows if "error" not in r]
    by_modes: dict[str, Any] = {}
    for m in sorted({r["modes"] for r in ok}):
        mine = [r for r in ok if r["modes"] == m]
        by_modes[str(m)] = {"n": len(mine), "tau": {
            f"tau_{i}": quartiles(np.array([r["params"][f"tau_{i}"]["value"] for r in mine]))
            for i in range(1, m + 1)},
            "tau_determined": {f"tau_{i}": quartiles(np.array(
                [r["params"][f"tau_{i}"]["value"] for r in mine
                 if r["params"][f"tau_{i}"]["identifiability"] == "determined"], dtype=float))
                for i in range(1, m + 1)},
            "tau_stderr_determined": {f"tau_{i}": quartiles(np.array(
                [r["params"][f"tau_{i}"]["stderr"] for r in mine
                 if r["params"][f"tau_{i}"]["identifiability"] == "determined"], dtype=float))
                ["median"] for i in range(1, m + 1)},
            "determined": {f"tau_{i}": sum(r["params"][f"tau_{i}"]["identifiability"]
                                           == "determined" for r in mine)
                           for i in range(1, m + 1)}}
    windows = {}
    for name in ("first_10_percent_removed", "last_10_percent_removed"):
        shifts = np.array([t["shift_in_stderr"] for r in ok
                           for k, t in r["window_test"].get(name, {}).get("tau", {}).items()
                           if t["shift_in_stderr"] is not None
                           and r["params"][k]["identifiability"] == "determined"], dtype=float)
        windows[name] = {"n": int(shifts.size), "abs_shift": quartiles(np.abs(shifts)),
                         "within_2": int(np.sum(np.abs(shifts) <= 2))}
    taus = [t for r in ok for k, t in r["params"].items() if k.startswith("tau_")]
    return {"n_fitted": len(ok), "n_failed": len(rows) - len(ok),
            "modes": dict(Counter(str(r["modes"]) for r in ok).most_common()),
            "by_modes": by_modes,
            "n_tau": len(taus),
            "n_tau_determined": sum(t["identifiability"] == "determined" for t in taus),
            "n_tau_longer_than_pause": sum(bool(t.get("longer_than_pause")) for t in taus),
            "residual_lag1": quartiles(np.array([r["residual_lag1"] for r in ok])),
            "stderr_correction": quartiles(np.array([r["stderr_correction"] for r in ok])),
            "creep_force_n": quartiles(np.array([r["creep_force_n"] for r in ok])),
            "pause_s": quartiles(np.array([r["pause_s"] for r in ok])),
            "windows": windows}


SUBSCRIPT = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")


def tau_text(name: str, p: dict[str, Any], pause: float) -> str:
    """``τ₁ = 0.0733 ± 0.002 s``, or its bound (``τ₁ < 0.0768 s``) / "not determined"."""
    sym = "τ" + name.split("_")[1].translate(SUBSCRIPT)
    if p["bound"] is not None:
        text = p["bound"].replace(name, sym)
    elif p["identifiability"] not in (None, "determined"):
        text = f"{sym} not determined ({num(p['value'], 2)} s fitted)"
    else:
        text = f"{sym} = {pm(p['value'], p['stderr'])} s"
        if p["stderr"] is None:
            text = f"{sym} = {num(p['value'])} s (no stderr: singular covariance)"
    if p.get("longer_than_pause"):
        text += f", longer than the {num(pause, 2)} s pause: a drift"
    return text


def tau_shift(m: dict[str, Any]) -> str:
    """A refitted τ's shift in stated stderr, or its value where the full fit states none."""
    if m["shift_in_stderr"] is not None:
        return shift_text(m["shift_in_stderr"]) + loose(m)
    marker = "" if m["identifiability"] == "determined" else " (not determined)"
    return f"→ {num(m['value'], 2)} s{marker}"


def creep_row(r: dict[str, Any]) -> tuple[str, str, str]:
    if r["curves"] == 1:
        n, pause = r["modes"], r["pause_s"]
        taus = {k: v for k, v in r["params"].items() if k.startswith("tau_")}
        kept = (f"BIC keeps falling up to the {n}-mode cap" if r["selection_note"]
                else f"BIC keeps {n} mode{'s' if n > 1 else ''}")
        shifts = []
        for name, text in (("first_10_percent_removed", "first"),
                           ("last_10_percent_removed", "last")):
            w = r["window_test"][name]
            head = f"without the {text} 10 % ({num(WINDOW_CUT * pause, 2)} s): "
            if "error" in w:
                shifts.append(head + f"refit failed ({w['error']})")
                continue
            shifts.append(head + ", ".join(tau_shift(m) for m in w["tau"].values()))
        result = (f"{kept} ({r['samples']} samples, {num(pause, 2)} s pause at "
                  f"{si_text(r['creep_force_n'], 'N')}): "
                  + "; ".join(tau_text(k, v, pause) for k, v in taus.items())
                  + f". Stderr × {num(r['stderr_correction'])} for residual lag-1 "
                  f"{r['residual_lag1']:.3f} ({num(r['effective_samples'], 2)} effective "
                  f"samples). Window test, {n} modes refitted, each τ's shift in stated stderr "
                  f"(→ the refitted τ where the full fit states no stderr): "
                  + "; ".join(shifts))
        return f"creep, {r['label']}", r["command"], result
    s, m = r["summary"], r["map_summary"]
    per = []
    for count, row in s["by_modes"].items():
        taus = ", ".join(
            "–" if q["median"] is None else
            f"{num(q['median'], 3)} ± {num(sd, 1)}"
            for q, sd in zip(row["tau_determined"].values(),
                             row["tau_stderr_determined"].values(), strict=True))
        det = ", ".join(str(v) for v in row["determined"].values())
        per.append(f"{count} modes on {row['n']}: {taus} s (determined on {det})")
    w = s["windows"]
    result = (f"{s['n_fitted']} of {r['curves']} pauses fitted ({num(s['pause_s']['median'], 2)} "
              f"s at {si_text(s['creep_force_n']['median'], 'N')}); `fit_map`: {m['n_good']} "
              f"good (left out: {left_out_text(m['left_out'])}); BIC's modes, and median τ ± "
              f"median stderr over the curves where each τ is determined: "
              + "; ".join(per)
              + f"; {s['n_tau_determined']} of {s['n_tau']} τ determined (local test), "
              f"{s['n_tau_longer_than_pause']} longer than the pause. Median residual lag-1 "
              f"{num(s['residual_lag1']['median'], 2)} (stderr × "
              f"{num(s['stderr_correction']['median'], 3)}). Window test over the determined "
              f"τ, median |Δτ|/stderr: "
              f"{num(w['first_10_percent_removed']['abs_shift']['median'], 2)} without the "
              f"first 10 % (≤ 2 on {w['first_10_percent_removed']['within_2']} of "
              f"{w['first_10_percent_removed']['n']}), "
              f"{num(w['last_10_percent_removed']['abs_shift']['median'], 2)} without the last "
              f"10 % (≤ 2 on {w['last_10_percent_removed']['within_2']} of "
              f"{w['last_10_percent_removed']['n']})")
    return f"creep, {r['label']}", r["command"], result


# ── 5. coverage: every real file, the models that analysed it or why none did ───────────────────

def real_files(data_dir: Path) -> list[Path]:
    """The measurement files of the data folder (not LICENSE, SOURCE.txt or the notes)."""
    return sorted(p for p in data_dir.rglob("*") if p.is_file() and not p.name.startswith(".")
                  and p.suffix.lower() != ".md"
                  and not p.name.upper().startswith(("LICENSE", "SOURCE")))


def scan(data_dir: Path) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Load every real file; per file which models find their data (``"ok"``) or why not.

    Returns the coverage entries and the loaded datasets (by path relative to ``data_dir``).
    """
    from viscoforce.exceptions import ViscoforceError
    from viscoforce.experiments.modulation import modulation_spectrum
    from viscoforce.fitting.curves import curve_data
    from viscoforce.io.instruments import load_instrument

    entries, loaded = [], {}
    for path in real_files(data_dir):
        rel = path.relative_to(data_dir).as_posix()
        entry: dict[str, Any] = {"file": rel, "label": label(rel), "bytes": path.stat().st_size}
        caught: list[warnings.WarningMessage] = []
        try:
            with recording(caught):
                ds = load_instrument(path)
        except Exception as exc:  # the reader's refusal is the record
            entry.update(read_as=None, load_error=first_line(exc, path), models={})
            entries.append(entry)
            continue
        loaded[rel] = ds
        models: dict[str, str] = {}
        for model in CURVE_MODELS:
            try:
                with recording(caught):
                    curve_data(ds, model, curve=0)
                models[model] = "ok"
            except (ViscoforceError, ValueError) as exc:
                models[model] = first_line(exc, path)
        try:
            with recording(caught):
                modulation_spectrum(ds)
            models["contact"] = "ok"
        except (ViscoforceError, ValueError) as exc:
            models["contact"] = first_line(exc, path)
        entry.update(read_as=ds.attrs.get("source"), curves=int(ds.sizes.get("curve", 1)),
                     load_error=None, models=models, load_warnings=warning_summary(caught))
        entries.append(entry)
    return entries, loaded


def cover(entries: list[dict[str, Any]], datasets: dict[str, Any], quick: bool,
          map_in_data: bool) -> None:
    """Fill each entry's ``analysed`` (the analyses of this run that fitted it), ``not_run``
    (models with data that this run did not fit, and why) and ``outcome``/``reason``."""
    ran: dict[str, dict[str, str]] = {}

    def add(rel: str, model: str, status: str) -> None:
        ran.setdefault(rel, {})[model] = status

    for key, rel, model in (("jpk_hold", HOLD_FILE, "relaxation"),
                            ("zip_map", ZIP_FILE, "relaxation")):
        add(rel, model, datasets[key].get("status", "skipped"))
    if map_in_data:
        add(MAP_FILE, "contact", datasets["modulation_map"].get("status", "skipped"))
    for model in ("hertz", "creep"):
        for rel, r in datasets[model].get("files", {}).items():
            add(rel, model, r.get("status", "skipped"))
    for e in entries:
        mine = ran.get(e["file"], {})
        e["analysed"] = [m for m in MODEL_ORDER if mine.get(m) == "ok"]
        if "hertz" in e["analysed"]:
            r = datasets["hertz"]["files"][e["file"]]
            e["tip"] = r["tip"] + (" (assumed)" if r["tip_source"] == "assumed" else
                                   " (from the file)")
        e["not_run"] = {m: ("--quick" if mine.get(m, "skipped") == "skipped" and quick
                            else datasets_error(datasets, e["file"], m) or mine.get(m, "not run"))
                        for m, v in e["models"].items() if v == "ok" and m not in e["analysed"]}
        if e["analysed"]:
            e["outcome"], e["reason"] = "analysed", None
        elif e["load_error"]:
            e["outcome"], e["reason"] = "refused", e["load_error"]
        elif e["not_run"]:
            e["outcome"] = "not run"
            e["reason"] = "; ".join(f"{m} not run: {why}" for m, why in e["not_run"].items())
        else:
            e["outcome"] = "refused"
            e["reason"] = next(v for m, v in e["models"].items() if v != "ok")


def datasets_error(datasets: dict[str, Any], rel: str, model: str) -> str | None:
    """The error of analysis ``model`` on file ``rel`` in this run, if it raised."""
    if model in ("hertz", "creep"):
        return datasets[model].get("files", {}).get(rel, {}).get("error")
    for key, path in (("jpk_hold", HOLD_FILE), ("zip_map", ZIP_FILE),
                      ("modulation_map", MAP_FILE)):
        if path == rel and datasets[key].get("status") == "error":
            return datasets[key].get("error")
    return None


ANALYSIS_TEXT = {"hertz": "hertz (approach)", "creep": "creep (constant-force pause)",
                 "relaxation": "relaxation (constant-height hold)",
                 "contact": "contact on the modulation spectrum (+ `--model auto` per curve)"}


def coverage_markdown(entries: list[dict[str, Any]]) -> str:
    lines = ["| file | read as | analysed with | not analysed: reason |", "|---|---|---|---|"]
    for e in entries:
        read = ("not read" if e["load_error"] else
                f"{e['read_as']}, {e['curves']} curve{'s' if e['curves'] > 1 else ''}")
        done = "; ".join(ANALYSIS_TEXT[m] + (f", tip {e['tip']}" if m == "hertz" else "")
                         for m in e["analysed"]) or "–"
        why = e["reason"] or ""
        if e["not_run"] and e["analysed"]:
            why = "; ".join(f"{m} not run: {v}" for m, v in e["not_run"].items())
        why = why.replace("|", "/")
        lines.append(f"| `{Path(e['file']).name}` ({e['label']}) | {read} | {done} | "
                     f"{why or '–'} |")
    return "\n".join(lines)


def curve_analyses(model: str, entries: list[dict[str, Any]], loaded: dict[str, Any],
                   data_dir: Path, quick: bool) -> dict[str, Any]:
    """Run ``model`` (hertz or creep) on every real file whose curves have its segment."""
    job = {"hertz": hertz_file, "creep": creep_file}[model]
    files: dict[str, dict[str, Any]] = {}
    start = time.perf_counter()
    single = [e["file"] for e in entries
              if e["models"].get(model) == "ok" and int(loaded[e["file"]].sizes["curve"]) == 1]
    creep_one = QUICK_CREEP_FILE if QUICK_CREEP_FILE in single else next(iter(single), None)
    for e in entries:
        if e["models"].get(model) != "ok":
            continue
        rel, ds = e["file"], loaded[e["file"]]
        if quick and (int(ds.sizes["curve"]) > 1 or (model == "creep" and rel != creep_one)):
            files[rel] = {"status": "skipped", "file": str(data_dir / rel), "reason": "--quick"}
            continue
        files[rel] = run(f"{model}, {Path(rel).name}", data_dir / rel,
                         lambda p, ds=ds: job(p, ds))
    statuses = {r["status"] for r in files.values()}
    status = ("error" if "error" in statuses else "ok" if "ok" in statuses else "skipped")
    out: dict[str, Any] = {"status": status, "files": files,
                           "seconds": time.perf_counter() - start}
    if model == "hertz":
        out.update(tip_assumed=TIP_ASSUMED, tip_note=TIP_NOTE, poisson=0.5,
                   force_cut=FORCE_CUT, tilt_flag=TILT_FLAG)
    else:
        out["window_cut"] = WINDOW_CUT
    return out


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


def print_curves(datasets: dict[str, Any]) -> None:
    """One line per Hertz / creep fit on the console, and their warnings."""
    for key in ("hertz", "creep"):
        for rel, r in datasets[key]["files"].items():
            if r["status"] != "ok":
                continue
            if key == "hertz":
                s = r["summary"]
                w = s["windows"]
                print(f"hertz {Path(rel).name}: E_young median {num(s['E_young']['median'])} Pa, "
                      f"lag-1 {num(s['residual_lag1']['median'], 3)}, |ΔE|/stderr "
                      f"{num(w['force_to_half']['abs_shift']['median'], 2)} (F ≤ "
                      f"{FORCE_CUT:.0%}), {num(w['deep_half']['abs_shift']['median'], 2)} "
                      "(deep half)")
            else:
                modes = r.get("modes", r.get("summary", {}).get("modes"))
                print(f"creep {Path(rel).name}: modes {modes}")
            print_warnings(f"{key} {Path(rel).name}", r["warnings"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"the modulation map's first {QUICK_CURVES} curves, coverage, hertz "
                             "on single curves, creep on one")
    parser.add_argument("--out", type=Path, default=HERE / "out",
                        help="output folder (default: studies/real_data/out)")
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
            print("--quick: the stress-relaxation hold, the 15-curve zip and the maps' force "
                  "curves are not run; creep on one curve only")
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
        if args.data.is_dir():
            entries, loaded = scan(args.data)
        else:
            print(f"coverage, hertz, creep: SKIPPED, no folder {args.data}")
            entries, loaded = [], {}
        for model in ("hertz", "creep"):
            datasets[model] = curve_analyses(model, entries, loaded, args.data, args.quick)
        cover(entries, datasets, args.quick, map_path == args.data / MAP_FILE)
    coverage = {"status": "ok" if entries else "skipped", "data_dir": str(args.data),
                "n_files": len(entries), "files": entries,
                "markdown": coverage_markdown(entries) if entries else ""}

    rows = []
    for key, make in (("jpk_hold", hold_row), ("zip_map", zip_row),
                      ("modulation_map", modulation_row)):
        if datasets[key]["status"] == "ok":
            rows.append(make(datasets[key]))
    for key, make in (("hertz", hertz_row), ("creep", creep_row)):
        rows += [make(r) for r in datasets[key]["files"].values() if r["status"] == "ok"]
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

    print_curves(datasets)
    print()
    print("Markdown table for the README (\"Measured on the real files\"):")
    print()
    print(table)
    print()
    if coverage["markdown"]:
        print("Coverage of the real files:")
        print()
        print(coverage["markdown"])
        print()
    report = {"schema": SCHEMA, "created": datetime.now(UTC).isoformat(timespec="seconds"),
              "quick": args.quick, "machine": facts, "data_dir": str(args.data),
              "radius_m": RADIUS, "datasets": datasets, "coverage": coverage,
              "markdown": table,
              "wall_time_s": time.perf_counter() - wall}
    (args.out / "real_data.json").write_text(json.dumps(clean(report), indent=2, allow_nan=False)
                                             + "\n")
    (args.out / "real_data.md").write_text(table + "\n")
    (args.out / "real_data_coverage.md").write_text(coverage["markdown"] + "\n")
    print(f"wrote {args.out / 'real_data.json'}, {args.out / 'real_data.md'}"
          + (f", {args.out / 'real_data_curves.csv'}" if mod["status"] == "ok" else "")
          + f" in {report['wall_time_s']:.1f} s")
    return 1 if any(d["status"] == "error" for d in datasets.values()) else 0


if __name__ == "__main__":
    raise SystemExit(main())
