#!/usr/bin/env python
"""Stability and validity maps: where each method fails, or errs by more than 1 %, and what it says.

What it maps (see studies/validity_maps/README.md; issue 15 item 2). Every
point is classified ``ok`` (error ≤ 1 %, silent), ``warns`` (a ModelValidityWarning or
AccuracyWarning was issued), ``raises`` (a ViscoforceError) or ``silent > 1 %`` (error above
1 % and neither: a finding).

1. SVDA spectrum (``vf.spectrum(method="svda")``) against the exact linear response: max
   |Δk*|/|k*| over 13 ω in [0.1/τ, 100/τ], over position h̄0 × relaxed modulus E_inf
   (E0 = 10 E_inf); estimate 0.585 κ|u0| with u0 the relaxed SVDA central deformation.
2. Hertz contact k* = sqrt(R δ0)/C*(ω) (δ0 = −h̄0; ``vf.spectrum(method="contact")`` when it
   exists) against the exact linear response, over δ0 × Debye length λ; estimate
   1.5 (|E*(ω_max)|/E_inf) λ/δ0.
3. Lock-in (finite-amplitude) bias: the first-harmonic k* of the time-domain lock-in against the
   linear k* at the same h̄0, over κη at h̄0 = 2 nm (Fig. 3) and −5 nm (Fig. 4); estimates (κη)²/8
   and the library's 2 I1(κη)/(κη) − 1.
   The status is that of ``vf.spectrum(method="linear")`` at that η (it is what is biased).
4. Explicit Euler (``simulate(stepper="euler", dt=...)``) on the paper's Fig. 1 step (h0 → h0 − 2
   nm in 0.1 ms, outputs at 0, 0.1 ms and every 0.25 ms to 1.6 ms) against the exponential
   stepper at tol = 1e-2 × default: error max|ΔF|/max|F| over dt × h0
   (E0/E_inf = 10) and over dt × E0/E_inf (h0 = −5 nm); lines: the stepper's own stability limit
   at the start and end positions, 2τ·E_inf/E0 (deep contact) and 2τ (far apart).
5. Newton static equilibrium (``static_equilibrium``) against a 2×-refined grid: relative load
   error over h0 × E for the paper's law and for the double layer alone (no soft wall).
6. Half-space model: |u0|/R and a/R of the paper-law static states against |h0|, with the warning
   (0.01 R, 0.1 R) and error (0.1 R, 0.5 R) thresholds of ``check_half_space``.

Outputs in ``--out``: validity_maps.json, validity_maps.csv (one row per point) and
validity_maps.png (one panel per map). BLAS is pinned to one thread.
Run ``python studies/validity_maps/validity_maps.py [--quick] [--out DIR]`` (default
studies/validity_maps/out).
"""

from __future__ import annotations

import math
import sys
import time
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from scipy.special import i1  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

import viscoforce as vf  # noqa: E402
from viscoforce.closed_form import sls_complex_compliance  # noqa: E402
from viscoforce.exceptions import AccuracyWarning, ModelValidityWarning, ViscoforceError  # noqa: E402
from viscoforce.experiments.linear_response import linear_stiffness  # noqa: E402
from viscoforce.experiments.spectroscopy import SPECTRUM_METHODS  # noqa: E402
from viscoforce.physics.surface_forces import DoubleLayer  # noqa: E402
from viscoforce.problem import HALF_SPACE_ERROR, HALF_SPACE_WARNING  # noqa: E402
from viscoforce.solvers.static import static_equilibrium  # noqa: E402
from viscoforce.solvers.steppers import ExplicitEuler  # noqa: E402
from viscoforce.svda import svda_static_deformation  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "benchmarks"))  # benchmarks/_common.py, from any cwd
from _common import (  # noqa: E402
    fmt,
    machine_facts,
    parse_args,
    print_machine,
    report_head,
    run_end,
    write_csv,
    write_json,
)

RADIUS, P_DL, LAMBDA = vf.PAPER.R, vf.PAPER.P, vf.PAPER.debye_length  # [m], [Pa], [m]
E0, E_INF, TAU = vf.PAPER.E0, vf.PAPER.E_inf, vf.PAPER.tau  # [Pa], [Pa], creep time [s]
SCHEMA = "viscoforce.validity_maps/1"
JSON_KEYS = ("schema", "created", "quick", "machine", "settings", "rows", "boundaries",
             "summary", "files")
ROW_KEYS = ("map", "x_name", "x", "y_name", "y", "error", "estimate", "status", "exception",
            "warning", "time_s", "detail")
THRESHOLD = 0.01  # the 1 % error line
RATIO_FLOOR = 1e-3  # error/estimate ratios are reported where either reaches this
STATUSES = ("ok", "warns", "raises", "silent > 1 %")
COLOURS = {"ok": "#4daf4a", "warns": "#ff9f1c", "raises": "#377eb8", "silent > 1 %": "#e41a1c"}
MARKERS = {"ok": "o", "warns": "^", "raises": "X", "silent > 1 %": "s"}
SPECTRUM_OMEGA = np.logspace(math.log10(0.1 / TAU), math.log10(100 / TAU), 13)  # [rad/s]
SVDA_ESTIMATE = 0.585  # error ≈ 0.585 κ|u0| (measured universal prefactor)

# 1. SVDA: h̄0 [m] × E_inf [Pa]
SVDA_H = np.array([2, 3, 4, 5, 6, 8, 10, 15]) * 1e-9
QUICK_SVDA_H = np.array([3, 4, 6, 10]) * 1e-9
SVDA_E, QUICK_SVDA_E = (1e8, 1e9, 1e10), (1e9,)
# 2. Hertz: δ0 [m] × λ [m]
HERTZ_D = np.array([10, 20, 50, 100, 200, 400, 600]) * 1e-9
QUICK_HERTZ_D = np.array([20, 100, 300]) * 1e-9
HERTZ_L, QUICK_HERTZ_L = (0.3e-9, 1e-9, 3e-9), (0.3e-9, 1e-9)
# 3. lock-in: scene -> h̄0 [m]; κη values; ω [rad/s]
LOCKIN_H = {"Fig. 3 (2 nm)": 2e-9, "Fig. 4 (-5 nm)": -5e-9}
QUICK_LOCKIN_H = {"Fig. 4 (-5 nm)": -5e-9}
LOCKIN_KE, QUICK_LOCKIN_KE = (0.1, 0.2, 0.25, 0.3, 0.6, 1.0, 1.5), (0.25, 1.0)
LOCKIN_OMEGA, QUICK_LOCKIN_OMEGA = (0.3 / TAU, 2 / TAU, 20 / TAU), (2 / TAU,)
# 4. explicit Euler
EULER_DT = np.array([1e-6, 3e-6, 1e-5, 1.5e-5, 2e-5, 3e-5, 1e-4, 2.5e-4])  # [s]
QUICK_EULER_DT = np.array([3e-6, 2e-5, 1e-4])
EULER_H = np.array([10, 5, 2, 0, -2, -5, -10, -20]) * 1e-9
QUICK_EULER_H = np.array([5, -5]) * 1e-9
EULER_RATIO, QUICK_EULER_RATIO = (2.0, 5.0, 10.0, 30.0, 100.0), (10.0, 100.0)
EULER_H_RATIO = -5e-9  # h0 of the E0/E_inf map [m]
STEP_DEPTH, STEP_RISE, STEP_END = 2e-9, 1e-4, 1.6e-3  # [m], [s], [s]
EULER_REF_TOL = 1e-2  # × simulate()'s default tol
#: output times [s]; the time loop lands on every one, so their spacing (0.25 ms) caps dt
EULER_T_EVAL = np.concatenate([[0.0, STEP_RISE], np.arange(3.5e-4, STEP_END + 1e-9, 2.5e-4)])
# 5./6. Newton and half-space
NEWTON_H = np.array([10, 2, -2, -10, -30, -100, -300]) * 1e-9
QUICK_NEWTON_H = np.array([2, -10, -100]) * 1e-9
NEWTON_E = (1e6, 1e7, 1e8, 1e9, 1e10)
QUICK_NEWTON_E = (1e6, 1e8, 1e10)
NEWTON_REFINE = 0.5  # grid spacing factor of the reference
DEEP_H = np.array([-600, -1000]) * 1e-9  # half-space only (no refined reference)
QUICK_DEEP_H = np.array([-1000]) * 1e-9
DEEP_E, QUICK_DEEP_E = (1e6, 1e8, 1e10), (1e8,)


# ── helpers ──────────────────────────────────────────────────────────────────────────────────────

def make_problem(material, deepest: float, *, law=None, factor: float = 1.0) -> vf.ContactProblem:
    """The paper's sphere (and law unless ``law``); grid spacing = ``factor`` × the default."""
    kw = dict(sphere=vf.Sphere(RADIUS), material=material, deepest_position=deepest,
              surface_force=vf.paper_pressure_law() if law is None else law)
    spacing = None
    if factor != 1.0:
        grid = vf.ContactProblem.create(**kw).grid
        spacing = factor * grid.outer_radius / grid.size
    return vf.ContactProblem.create(**kw, grid_spacing=spacing)


def sls(e_inf: float = E_INF, ratio: float = E0 / E_INF) -> vf.StandardLinearSolid:
    return vf.StandardLinearSolid(E0=ratio * e_inf, E_inf=e_inf, tau=TAU)


def kstar(ds) -> np.ndarray:
    return ds.stiffness.values * np.exp(1j * np.radians(ds.phase.values))


def max_rel(k, k_ref) -> float:
    return float(np.max(np.abs(np.asarray(k) - k_ref) / np.abs(k_ref)))


def attempt(fn):
    """Run ``fn``; return (result or None, exception text, warning texts, time)."""
    t0 = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result, exc = fn(), ""
        except ViscoforceError as err:  # a refused point is data, not a crash
            result, exc = None, f"{type(err).__name__}: {err}"
    texts = [str(w.message) for w in caught
             if issubclass(w.category, (ModelValidityWarning, AccuracyWarning))]
    return result, exc, texts, time.perf_counter() - t0


def classify(error: float, exc: str, warned: list[str]) -> str:
    if exc:
        return "raises"
    if warned:
        return "warns"
    return "silent > 1 %" if not error <= THRESHOLD else "ok"


def make_row(map_, x_name, x, y_name, y, *, error=math.nan, estimate=math.nan, exc="",
             warned=(), time_s=math.nan, detail="", status=None) -> dict:
    r = {"map": map_, "x_name": x_name, "x": float(x), "y_name": y_name, "y": float(y),
         "error": float(error), "estimate": float(estimate),
         "status": status or classify(error, exc, list(warned)), "exception": exc[:300],
         "warning": "; ".join(warned)[:300], "time_s": float(time_s), "detail": detail}
    print(f"  {map_:<14} {x_name} {fmt(r['x'], '10.3g')}  {y_name} {fmt(r['y'], '9.3g')}  "
          f"err {fmt(r['error'])}  est {fmt(r['estimate'])}  {r['status']:<12} "
          f"{(r['exception'] or r['warning'])[:70]}")
    return r


# ── 1. SVDA ──────────────────────────────────────────────────────────────────────────────────────

def svda_estimate(h, e_inf):
    u0 = svda_static_deformation(h, e_inf, RADIUS, P_DL, LAMBDA)
    return SVDA_ESTIMATE * np.abs(u0) / LAMBDA


def map_svda(quick: bool) -> list[dict]:
    rows = []
    for e_inf in QUICK_SVDA_E if quick else SVDA_E:
        for h in QUICK_SVDA_H if quick else SVDA_H:
            problem = make_problem(sls(e_inf), h)
            k_ex, ex_exc, _, _ = attempt(lambda p=problem, h=h: linear_stiffness(p, h, SPECTRUM_OMEGA))
            ds, exc, warned, t = attempt(lambda p=problem, h=h: vf.spectrum(
                p, h, 1e-12, SPECTRUM_OMEGA, method="svda"))
            err = max_rel(kstar(ds), k_ex[0]) if ds is not None and k_ex is not None else math.nan
            rows.append(make_row("svda", "h0_m", h, "E_inf_Pa", e_inf, error=err,
                                 estimate=float(svda_estimate(h, e_inf)), exc=exc, warned=warned,
                                 time_s=t, detail=ex_exc))
    return rows


# ── 2. Hertz contact ─────────────────────────────────────────────────────────────────────────────

def hertz_estimate(depth, debye, ratio=E0 / E_INF):
    e_max = 1.0 / np.abs(sls_complex_compliance(SPECTRUM_OMEGA[-1], ratio * E_INF, E_INF, TAU))
    return 1.5 * (e_max / E_INF) * debye / depth


def map_hertz(quick: bool) -> list[dict]:
    rows = []
    has_contact = "contact" in SPECTRUM_METHODS
    for debye in QUICK_HERTZ_L if quick else HERTZ_L:
        law = vf.paper_pressure_law(debye_length=debye)
        for depth in QUICK_HERTZ_D if quick else HERTZ_D:
            h = -float(depth)
            problem = make_problem(sls(), h, law=law)
            k_ex, ex_exc, _, _ = attempt(lambda p=problem, h=h: linear_stiffness(p, h, SPECTRUM_OMEGA))
            if has_contact:
                ds, exc, warned, t = attempt(lambda p=problem, h=h: vf.spectrum(
                    p, h, 1e-12, SPECTRUM_OMEGA, method="contact"))
                k_h = kstar(ds) if ds is not None else None
            else:  # the closed form the "contact" fit model uses; it has no warning path yet
                t0 = time.perf_counter()
                k_h = math.sqrt(RADIUS * depth) / sls_complex_compliance(SPECTRUM_OMEGA, E0, E_INF, TAU)
                exc, warned, t = "", [], time.perf_counter() - t0
            err = max_rel(k_h, k_ex[0]) if k_h is not None and k_ex is not None else math.nan
            rows.append(make_row("hertz", "indentation_m", depth, "debye_length_m", debye,
                                 error=err, estimate=float(hertz_estimate(depth, debye)),
                                 exc=exc or ex_exc, warned=warned, time_s=t,
                                 detail="vf.spectrum(method='contact')" if has_contact
                                 else "closed form sqrt(R d0)/C*(w) (no method='contact' yet)"))
    return rows


# ── 3. lock-in bias ──────────────────────────────────────────────────────────────────────────────

def map_lockin(quick: bool) -> list[dict]:
    rows = []
    omega = np.array(QUICK_LOCKIN_OMEGA if quick else LOCKIN_OMEGA)
    kappa = 1.0 / LAMBDA
    for scene, h in (QUICK_LOCKIN_H if quick else LOCKIN_H).items():
        for ke in QUICK_LOCKIN_KE if quick else LOCKIN_KE:
            eta = ke / kappa
            problem = make_problem(sls(), h - eta)
            lin, exc, warned, _ = attempt(lambda p=problem, h=h, e=eta: vf.spectrum(
                p, h, e, omega, method="linear"))
            td, td_exc, _, t = attempt(lambda p=problem, h=h, e=eta: vf.spectrum(
                p, h, e, omega, method="time-domain", progress=False))
            err = max_rel(kstar(lin), kstar(td)) if lin is not None and td is not None else math.nan
            rows.append(make_row("lockin", "kappa_eta", ke, "h0_m", h, error=err,
                                 estimate=ke ** 2 / 8, exc=exc, warned=warned, time_s=t,
                                 detail=f"{scene}; time-domain: {td_exc or 'ok'}"))
    return rows


# ── 4. explicit Euler ────────────────────────────────────────────────────────────────────────────

def euler_runs(map_, y_name, y, problem, h0, dts) -> list[dict]:
    drive = vf.Step(h0, h0 - STEP_DEPTH, STEP_RISE)
    t_eval = EULER_T_EVAL
    default_tol = 1e-5 * problem.surface_force.decay_length

    def run(**kw):
        return vf.simulate(problem, drive, t_end=STEP_END, t_eval=t_eval, progress=False,
                           output_kinks=False, **kw).force.values

    f_ref = run(stepper="exponential", tol=EULER_REF_TOL * default_tol)
    limit = euler_limit(problem, h0)
    material = problem.material
    contact_limit = 2 * TAU * material.relaxed_modulus / material.instantaneous_modulus
    rows = []
    for dt in dts:
        f, exc, warned, t = attempt(lambda d=dt: run(stepper="euler", dt=float(d)))
        err = float(np.max(np.abs(f - f_ref)) / np.max(np.abs(f_ref))) if f is not None else math.nan
        if f is not None and not np.all(np.isfinite(f)):
            err = math.inf
        rows.append(make_row(map_, "dt_s", dt, y_name, y, error=err, exc=exc, warned=warned,
                             time_s=t, estimate=limit,
                             detail=f"2tau*E_inf/E0={contact_limit:.4g}"))
    return rows


def euler_limit(problem, h0: float) -> float:
    """ExplicitEuler.stability_limit [s] of the relaxed states at h0 and h0 − STEP_DEPTH (min)."""
    stepper = ExplicitEuler(problem)
    return min(stepper.stability_limit(stepper.relaxed_state(0.0, h))
               for h in (h0, h0 - STEP_DEPTH))


def map_euler(quick: bool) -> list[dict]:
    rows = []
    dts = QUICK_EULER_DT if quick else EULER_DT
    for h0 in QUICK_EULER_H if quick else EULER_H:
        rows += euler_runs("euler_h0", "h0_m", h0, make_problem(sls(), h0 - STEP_DEPTH), h0, dts)
    for ratio in QUICK_EULER_RATIO if quick else EULER_RATIO:
        rows += euler_runs("euler_ratio", "E0/E_inf", ratio,
                           make_problem(sls(ratio=ratio), EULER_H_RATIO - STEP_DEPTH),
                           EULER_H_RATIO, dts)
    return rows


# ── 5./6. Newton and half-space ──────────────────────────────────────────────────────────────────

def static_point(map_, h, e, law, refine: bool) -> dict:
    problem = make_problem(vf.Elastic(e), h, law=law)
    ds, exc, warned, t = attempt(lambda: static_equilibrium(problem, h))
    err, u_ratio, a_ratio = math.nan, math.nan, math.nan
    if ds is not None:
        u_ratio = abs(float(ds.u_center)) / RADIUS
        a_ratio = float(ds.contact_radius) / RADIUS
        if refine:
            ref, ref_exc, _, _ = attempt(lambda: static_equilibrium(
                make_problem(vf.Elastic(e), h, law=law, factor=NEWTON_REFINE), h))
            if ref is not None:
                err = abs(float(ds.force) - float(ref.force)) / abs(float(ref.force))
    status = None
    if ds is not None and not refine and not exc and not warned:
        status = "ok"  # no reference deeper than NEWTON_H: judged by the model check only
    return make_row(map_, "h0_m", h, "E_Pa", e, error=err, exc=exc, warned=warned, time_s=t,
                    status=status, estimate=abs(h) / RADIUS,
                    detail=f"u_ratio={u_ratio:.4g}; a_ratio={a_ratio:.4g}")


def map_static(quick: bool) -> list[dict]:
    rows = []
    laws = {"newton": None, "newton_dl": DoubleLayer(P_DL, LAMBDA)}
    for map_, law in laws.items():
        for e in QUICK_NEWTON_E if quick else NEWTON_E:
            for h in QUICK_NEWTON_H if quick else NEWTON_H:
                rows.append(static_point(map_, h, e, law, refine=True))
    for e in QUICK_DEEP_E if quick else DEEP_E:
        for h in QUICK_DEEP_H if quick else DEEP_H:
            rows.append(static_point("newton", h, e, None, refine=False))
    return rows


def ratios(r: dict) -> tuple[float, float]:
    parts = dict(p.split("=") for p in r["detail"].split("; "))
    return float(parts["u_ratio"]), float(parts["a_ratio"])


# ── boundaries and estimates ─────────────────────────────────────────────────────────────────────

def crossing(xs, ys, level=THRESHOLD) -> float:
    """Log–log interpolated x where ys first rises above ``level`` going along xs (nan: none)."""
    pts = [(x, y) for x, y in zip(xs, ys, strict=True) if math.isfinite(y) and y > 0]
    for (x0, y0), (x1, y1) in zip(pts, pts[1:], strict=False):
        if (y0 - level) * (y1 - level) <= 0 and y0 != y1:
            s = (math.log(level) - math.log(y0)) / (math.log(y1) - math.log(y0))
            return math.exp(math.log(abs(x0)) + s * (math.log(abs(x1)) - math.log(abs(x0)))) * (
                1 if x0 > 0 else -1)
    return math.nan


def boundaries(rows: list[dict]) -> dict:
    out = {}
    by = {}
    for r in rows:
        by.setdefault(r["map"], []).append(r)

    def bound_ratio(here):  # error / estimate where either reaches 1e-3 (the 1 % decision)
        vals = [r["error"] / r["estimate"] for r in here
                if math.isfinite(r["error"]) and r["estimate"] > 0 and r["error"] > 0
                and max(r["error"], r["estimate"]) >= RATIO_FLOOR]
        return {"min": min(vals, default=math.nan), "max": max(vals, default=math.nan),
                "bounded": all(v <= 1 for v in vals)}

    for m in ("svda", "hertz", "lockin"):
        here = by.get(m, [])
        groups = {}
        for r in here:
            groups.setdefault(r["y"], []).append(r)
        lines = {}
        for y, g in groups.items():
            g = sorted(g, key=lambda r: r["x"], reverse=m != "lockin")
            lines[f"{y:g}"] = crossing([r["x"] for r in g], [r["error"] for r in g])
        out[m] = {"error_1pct_at": lines, "error_over_estimate": bound_ratio(here)}
    for m in ("euler_h0", "euler_ratio"):
        lines = {}
        for y in dict.fromkeys(r["y"] for r in by.get(m, [])):
            g = sorted((r for r in by[m] if r["y"] == y), key=lambda r: r["x"])
            ok = [r["x"] for r in g if r["status"] == "ok"]
            raises = [r["x"] for r in g if r["status"] == "raises"]
            silent = [r["x"] for r in g if r["status"] == "silent > 1 %"]
            lines[f"{y:g}"] = {"dt_1pct": crossing([r["x"] for r in g],
                                                   [r["error"] for r in g]),
                               "largest_dt_ok": max(ok, default=math.nan),
                               "smallest_dt_raising": min(raises, default=math.nan),
                               "dt_silent_over_1pct": silent,
                               "stability_limit_s": g[0]["estimate"],
                               "max_silent_error": max((r["error"] for r in g
                                                        if r["status"] == "silent > 1 %"),
                                                       default=math.nan)}
        out[m] = lines
    for m in ("newton", "newton_dl"):
        here = by.get(m, [])
        out[m] = {s: [[r["x"], r["y"]] for r in here if r["status"] == s] for s in STATUSES}
        out[m]["max_error"] = max((r["error"] for r in here if math.isfinite(r["error"])),
                                  default=math.nan)
    return out


def silent_garbage(rows: list[dict]) -> list[str]:
    return [f"{r['map']}: {r['x_name']}={r['x']:.4g}, {r['y_name']}={r['y']:.4g}: error "
            f"{r['error']:.3g} (no warning, no exception)" for r in rows
            if r["status"] == "silent > 1 %"]


# ── chart ────────────────────────────────────────────────────────────────────────────────────────

def scatter_status(ax, here, xf, yf, *, size=70, annotate=True):
    for r in here:
        x, y = xf(r), yf(r)
        ax.scatter([x], [y], s=size, c=COLOURS[r["status"]], marker=MARKERS[r["status"]],
                   edgecolors="k", linewidths=0.4, zorder=3)
        if annotate and math.isfinite(r["error"]):
            ax.annotate(f"{r['error']:.1g}", (x, y), textcoords="offset points", xytext=(0, 6),
                        ha="center", fontsize=5.5)


def status_legend(ax, extra=()):
    handles = [Line2D([], [], ls="", marker=MARKERS[s], color=COLOURS[s], mec="k", mew=0.4,
                      label=s) for s in STATUSES]
    ax.legend(handles=handles + list(extra), fontsize=6, loc="best")


def panel_svda(ax, here):
    scatter_status(ax, here, lambda r: r["x"] * 1e9, lambda r: r["y"])
    e = np.logspace(7.8, 10.2, 60)
    h = np.linspace(0.5e-9, 30e-9, 600)
    edge = [h[np.argmax(svda_estimate(h, ei) < THRESHOLD)] * 1e9 for ei in e]
    line, = ax.plot(edge, e, "k--", lw=1, label="estimate 0.585 κ|u0| = 1 %")
    ax.set_yscale("log")
    ax.set_xlabel("mean position h̄0 [nm]")
    ax.set_ylabel("relaxed modulus E_inf [Pa] (E0 = 10 E_inf)")
    ax.set_title("1. SVDA vs exact linear: max |Δk*|/|k*|", fontsize=9)
    status_legend(ax, [line])


def panel_svda_1d(ax, here):
    for i, e in enumerate(dict.fromkeys(r["y"] for r in here)):
        g = sorted((r for r in here if r["y"] == e), key=lambda r: r["x"])
        x = np.array([r["x"] for r in g])
        ax.plot(x * 1e9, [r["error"] for r in g], "o-", color=f"C{i}", ms=3,
                label=f"measured, E_inf = {e:.0e} Pa")
        xs = np.linspace(x.min(), x.max(), 100)
        ax.plot(xs * 1e9, svda_estimate(xs, e), "--", color=f"C{i}", lw=1,
                label="0.585 κ|u0|")
    ax.axhline(THRESHOLD, color="r", lw=1, label="1 %")
    ax.set_yscale("log")
    ax.set_xlabel("mean position h̄0 [nm]")
    ax.set_ylabel("max relative error")
    ax.set_title("1b. SVDA error and its estimate", fontsize=9)
    ax.legend(fontsize=5.5)


def panel_hertz(ax, here):
    scatter_status(ax, here, lambda r: r["x"] * 1e9, lambda r: r["y"] * 1e9)
    lam = np.logspace(np.log10(0.2e-9), np.log10(4e-9), 50)
    e_max = hertz_estimate(1.0, 1.0)
    line, = ax.plot(e_max * lam / THRESHOLD * 1e9, lam * 1e9, "k--", lw=1,
                    label="estimate 1.5(|E(ω_max)|/E_inf)λ/δ0 = 1 %")
    ax.axvline(0.1 * RADIUS * 1e9, color="grey", lw=1, ls=":")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(None, 2e4)
    ax.set_xlabel("indentation δ0 = −h̄0 [nm]  (dotted: deepest grid, 0.1 R)")
    ax.set_ylabel("Debye length λ [nm]")
    ax.set_title("2. Hertz contact vs exact linear: max |Δk*|/|k*|", fontsize=9)
    status_legend(ax, [line])
    ax.legend_.set_loc("center right")


def panel_lockin(ax, here):
    for i, h in enumerate(dict.fromkeys(r["y"] for r in here)):
        g = sorted((r for r in here if r["y"] == h), key=lambda r: r["x"])
        ax.plot([r["x"] for r in g], [r["error"] for r in g], "-", color=f"C{i}", lw=1,
                label=f"h̄0 = {h * 1e9:g} nm")
        scatter_status(ax, g, lambda r: r["x"], lambda r: r["error"], size=40, annotate=False)
    ke = np.logspace(-1.2, 0.3, 50)
    ax.plot(ke, ke ** 2 / 8, "k--", lw=1, label="(κη)²/8")
    ax.plot(ke, 2 * i1(ke) / ke - 1, "k:", lw=1, label="2 I1(κη)/κη − 1")
    ax.axhline(THRESHOLD, color="r", lw=1, label="1 %")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("κη (drive amplitude / Debye length)")
    ax.set_ylabel("max |k*_lock-in − k*_linear| / |k*|")
    ax.set_title("3. finite-amplitude bias of the linear spectrum", fontsize=9)
    handles, _ = ax.get_legend_handles_labels()
    status_legend(ax, handles)


def panel_euler(ax, here, *, ratio_axis: bool):
    yf = (lambda r: r["y"]) if ratio_axis else (lambda r: r["y"] * 1e9)
    scatter_status(ax, here, lambda r: r["x"], yf)
    lim = sorted({(yf(r), r["estimate"]) for r in here})
    l0, = ax.plot([v for _, v in lim], [y for y, _ in lim], "k-", lw=1.2,
                  label="ExplicitEuler.stability_limit (at h0, h0 − 2 nm)")
    ax.set_xscale("log")
    if ratio_axis:
        ratio = np.logspace(0.2, 2.1, 40)
        l1, = ax.plot(2 * TAU / ratio, ratio, "k--", lw=1, label="2τ·E_inf/E0")
        ax.set_yscale("log")
        ax.set_ylabel(f"E0/E_inf (h0 = {EULER_H_RATIO * 1e9:g} nm)")
        extra = [l0, l1]
    else:
        l1 = ax.axvline(2 * TAU * E_INF / E0, color="k", ls="--", lw=1, label="2τ·E_inf/E0")
        l2 = ax.axvline(2 * TAU, color="k", ls=":", lw=1, label="2τ")
        ax.set_ylabel("start position h0 [nm] (step −2 nm in 0.1 ms, E0/E_inf = 10)")
        extra = [l0, l1, l2]
    ax.set_xlabel("explicit Euler time step dt [s]")
    ax.set_title("4%s. explicit Euler: max|ΔF|/max|F| vs exponential" % ("b" if ratio_axis else "a"),
                 fontsize=9)
    status_legend(ax, extra)


def panel_newton(ax, here, title):
    scatter_status(ax, here, lambda r: r["x"] * 1e9, lambda r: r["y"])
    ax.set_xscale("symlog", linthresh=10)
    ax.set_yscale("log")
    ax.set_xlabel("position h0 [nm]")
    ax.set_ylabel("modulus E [Pa]")
    ax.set_title(title, fontsize=9)
    status_legend(ax)


def panel_half_space(ax, here):
    for i, e in enumerate(dict.fromkeys(r["y"] for r in here)):
        g = sorted((r for r in here if r["y"] == e and r["x"] < 0), key=lambda r: -r["x"])
        ok = [r for r in g if r["status"] != "raises"]
        d = [-r["x"] * 1e9 for r in ok]
        u = [ratios(r)[0] for r in ok]
        a = [ratios(r)[1] or math.nan for r in ok]  # a = 0: the gap never falls below 1/κ
        ax.plot(d, u, "-", color=f"C{i}", lw=1, label=f"|u0|/R, E = {e:.0e} Pa")
        ax.plot(d, a, ":", color=f"C{i}", lw=1, label=f"a/R, E = {e:.0e} Pa")
        for r, uu, aa in zip(ok, u, a, strict=True):
            for v in (uu, aa):
                if v > 0:  # False for nan
                    ax.scatter([-r["x"] * 1e9], [v], s=25, c=COLOURS[r["status"]],
                               marker=MARKERS[r["status"]], edgecolors="k", linewidths=0.3,
                               zorder=3)
        for r in g:
            if r["status"] == "raises":
                ax.scatter([-r["x"] * 1e9], [-r["x"] / RADIUS], s=60, c=COLOURS["raises"],
                           marker=MARKERS["raises"], edgecolors="k", linewidths=0.4, zorder=4)
    for key, ls in (("deformation", "-"), ("contact_radius", ":")):
        ax.axhline(HALF_SPACE_WARNING[key], color="orange", ls=ls, lw=1.2)
        ax.axhline(HALF_SPACE_ERROR[key], color="b", ls=ls, lw=1.2)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("depth −h0 [nm]")
    ax.set_ylabel("ratio to R (solid |u0|/R, dotted a/R)")
    ax.set_title("6. half-space model (orange: warn, blue: raise thresholds)", fontsize=9)
    ax.legend(fontsize=5.5, loc="lower right")


def plot(rows: list[dict], path: Path) -> None:
    by = {}
    for r in rows:
        by.setdefault(r["map"], []).append(r)
    fig, axes = plt.subplots(3, 3, figsize=(16, 14))
    ax = axes.flat
    panel_svda(ax[0], by.get("svda", []))
    panel_svda_1d(ax[1], by.get("svda", []))
    panel_hertz(ax[2], by.get("hertz", []))
    panel_lockin(ax[3], by.get("lockin", []))
    panel_euler(ax[4], by.get("euler_h0", []), ratio_axis=False)
    panel_euler(ax[5], by.get("euler_ratio", []), ratio_axis=True)
    panel_newton(ax[6], by.get("newton", []),
                 "5a. Newton static, paper law: load error vs 2× finer grid")
    panel_newton(ax[7], by.get("newton_dl", []),
                 "5b. Newton static, double layer only (no soft wall)")
    panel_half_space(ax[8], by.get("newton", []))
    for a in ax:
        a.grid(True, which="both", alpha=0.25)
    fig.suptitle("viscoforce validity maps: ok (≤ 1 %), warns, raises, silent > 1 % "
                 "(numbers: measured error)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ── main ─────────────────────────────────────────────────────────────────────────────────────────

def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__, out_dir=HERE / "out",
                      quick_help="coarse subsets of every map (< 60 s)",
                      repeats_help="ignored (every point is run once)")
    args.out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    with threadpool_limits(limits=1, user_api="blas"):
        machine = machine_facts()
        print_machine(machine)
        print(f"validity maps ({'quick' if args.quick else 'full'})")
        rows = []
        for part in (map_svda, map_hertz, map_lockin, map_euler, map_static):
            rows += part(args.quick)
    files = {"json": "validity_maps.json", "csv": "validity_maps.csv",
             "png": "validity_maps.png"}
    plot(rows, args.out / files["png"])
    write_csv(rows, args.out / files["csv"])
    garbage = silent_garbage(rows)
    summary = {"rows": len(rows), **{s: sum(r["status"] == s for r in rows) for s in STATUSES},
               "silent_garbage": garbage, **run_end(t_start)}
    settings = {"material": {"E0": E0, "E_inf": E_INF, "tau": TAU}, "radius": RADIUS,
                "threshold": THRESHOLD, "spectrum_omega": SPECTRUM_OMEGA,
                "lockin_omega": QUICK_LOCKIN_OMEGA if args.quick else LOCKIN_OMEGA,
                "euler_step": {"depth": STEP_DEPTH, "rise_time": STEP_RISE, "t_end": STEP_END,
                               "reference_tol_factor": EULER_REF_TOL},
                "newton_refine": NEWTON_REFINE,
                "half_space_warning": HALF_SPACE_WARNING, "half_space_error": HALF_SPACE_ERROR}
    report = {**report_head(SCHEMA, args.quick, machine), "settings": settings, "rows": rows,
              "boundaries": boundaries(rows), "summary": summary, "files": files}
    write_json(report, args.out / files["json"])
    for g in garbage:
        print(f"  silent > 1 %: {g}")
    print(f"{len(rows)} points: " + ", ".join(f"{summary[s]} {s}" for s in STATUSES)
          + f"; {summary['wall_time_s']:.1f} s; wrote {', '.join(files.values())} to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
