#!/usr/bin/env python
"""Speed–accuracy study: wall time against error of every method and knob on the paper's scenes.

What it measures (see benchmarks/README.md, section ``speed_accuracy.py``; issue 15 item 1):

1. Static loads at h0 = 2, −5, −10 nm on an elastic half-space (E = 1e9 Pa):
   ``static_equilibrium`` for grid spacing = default × (0.5, 1, 2, 4, 8) against a 4×-refined
   grid, and the rigid (Derjaguin) load ``problem.rigid_load(h0)`` as a zero-cost method.
2. The Fig. 3 (h̄0 = 2 nm, η = 0.1 nm) and Fig. 4 (h̄0 = −5 nm, η = 1 nm) spectra, 10 ω over
   [0.1/τ, 100/τ]: ``vf.spectrum`` with method linear (grid knob), svda (Fig. 3 only) and
   time-domain (knobs ``samples_per_period``, ``periods``, ``tol``). Error = max |Δk*|/|k*|
   against the linear response on a 4×-refined grid (Fig. 3); for Fig. 4 (η = 1 nm, not small)
   the time-domain rows are measured against the finest time-domain setting, the linear rows
   against the refined linear response.
3. The Fig. 1 step (−5 → −7 nm, 0.1 ms rise) and the Fig. 5 loop (10 → −10 → 10 nm at 5 µm/s):
   ``vf.simulate`` with stepper exponential (tol sweep), exponential-euler and euler (dt sweeps).
   Error = max |F − F_ref| / max |F_ref| on 81 common output times; reference = exponential at
   tol = 1e-3 × default on a 2×-refined grid. A run that raises (explicit Euler above its
   stability limit) is a row with status ``fails: ...``.
4. One noiseless 30-point spectrum fit per model (svda at 2 nm, exact at −5 nm, contact at
   −15 nm) of the exact linear response: time per ``fit_spectrum`` and max relative parameter
   error against the true E0, E_inf, τ.

Outputs in ``--out``: speed_accuracy.json, speed_accuracy.csv and speed_accuracy.png (Pareto
charts, error vs time, log–log, one panel per scene, each method's default marked with a star).
BLAS is pinned to one thread. Run ``python benchmarks/speed_accuracy.py [--quick] [--out DIR]``.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import NullFormatter  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

import viscoforce as vf  # noqa: E402
from viscoforce.exceptions import ViscoforceError  # noqa: E402
from viscoforce.experiments.linear_response import linearized_state  # noqa: E402
from viscoforce.fitting import fit_spectrum  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/_common.py, from any cwd
from _common import (  # noqa: E402
    fmt,
    machine_facts,
    parse_args,
    print_machine,
    report_head,
    run_end,
    timed,
    write_csv,
    write_json,
)

RADIUS = vf.PAPER.R  # sphere radius [m]
E0, E_INF, TAU = vf.PAPER.E0, vf.PAPER.E_inf, vf.PAPER.tau  # [Pa], [Pa], creep time [s]
E_STATIC = 1e9  # [Pa] elastic modulus of the static scenes
SCHEMA = "viscoforce.speed_accuracy/1"
JSON_KEYS = ("schema", "created", "quick", "machine", "settings", "rows", "summary", "files")
ROW_KEYS = ("scene", "method", "knob", "value", "time_s", "error", "status", "is_default",
            "reference", "detail")
ERROR_FLOOR = 1e-16  # errors below this are drawn at this value
GARBAGE_ERROR = 1.0  # an "ok" row above this error returned garbage without raising

# 1. static
STATIC_POSITIONS = (2e-9, -5e-9, -10e-9)  # h0 [m]
STATIC_FACTORS, QUICK_STATIC_FACTORS = (0.5, 1.0, 2.0, 4.0, 8.0), (1.0, 4.0)
STATIC_REFINE = 4.0
# 2. spectra: scene -> (h̄0 [m], η [m])
SPECTRA = {"Fig. 3 spectrum": (2e-9, 0.1e-9), "Fig. 4 spectrum": (-5e-9, 1e-9)}
N_OMEGA, QUICK_N_OMEGA = 10, 2
SPECTRUM_FACTORS, QUICK_SPECTRUM_FACTORS = (0.5, 1.0, 2.0, 4.0), (1.0, 2.0)
SPECTRUM_REFINE = 4.0
TD_DEFAULT = {"periods": 4, "samples_per_period": 64, "tol": None}  # sweep()'s defaults
TD_TOL_DEFAULT = 1e-5  # × η: sweep()'s default tol
#: time-domain settings: (knob, value) changed from TD_DEFAULT (tol as a multiple of 1e-5 η)
TD_SETTINGS = (("default", None), ("samples_per_period", 16), ("samples_per_period", 32),
               ("samples_per_period", 128), ("periods", 2), ("periods", 8), ("tol", 10.0),
               ("tol", 0.1))
QUICK_TD_SETTINGS = (("default", None), ("periods", 2))
TD_FINEST = {"periods": 8, "samples_per_period": 128, "tol": 0.1}  # Fig. 4 reference
QUICK_TD_FINEST = {}  # --quick: the default setting is the Fig. 4 reference (0 error)
# 3. dynamics: scene -> (drive, t_end)
TOL_FACTORS, QUICK_TOL_FACTORS = (1e3, 1e2, 10.0, 1.0, 0.1), (1e2, 1.0)
DTS = {"exponential-euler": (1e-4, 3e-5, 1e-5, 3e-6, 1e-6),
       "euler": (1e-3, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 5e-6, 2e-6)}
QUICK_DTS = {"exponential-euler": (3e-5,), "euler": (2e-4, 1e-5)}
EULER_DEFAULT_DT = 0.1 * TAU * E_INF / E0  # explicit Euler's default step [s]
DYN_REF_TOL, DYN_REF_REFINE, QUICK_DYN_REF_REFINE = 1e-3, 2.0, 1.0
N_OUTPUTS = 81
# 4. fits
FIT_N_OMEGA, FIT_OMEGA = 30, (1e1, 1e6)  # [rad/s]
FIT_CASES = (("svda", 2e-9), ("exact", -5e-9), ("contact", -15e-9))
REPEATS, QUICK_REPEATS = 3, 1


# ── helpers ──────────────────────────────────────────────────────────────────────────────────────

def sls() -> vf.StandardLinearSolid:
    return vf.StandardLinearSolid(E0=E0, E_inf=E_INF, tau=TAU)


def make_problem(material, deepest: float, factor: float = 1.0) -> vf.ContactProblem:
    """The paper's sphere and pressure law; grid spacing = ``factor`` × the default spacing."""
    kw = dict(sphere=vf.Sphere(RADIUS), surface_force=vf.paper_pressure_law(), material=material,
              deepest_position=deepest)
    spacing = None
    if factor != 1.0:
        grid = vf.ContactProblem.create(**kw).grid
        spacing = factor * grid.outer_radius / grid.size
    problem = vf.ContactProblem.create(**kw, grid_spacing=spacing)
    _ = problem.influence  # build (and cache) the kernel outside every timed region
    _ = problem.center_row
    return problem


def cold(fn):
    """``fn`` run cold: the cached static states of the linear response are dropped first."""
    def run():
        linearized_state.cache_clear()
        return fn()
    return run


def row(scene, method, knob, value, *, is_default=False, reference="", fn=None, error_of=None,
        repeats=1, nonfinite="non-finite result", detail_of=None) -> dict:
    """Time ``cold(fn)`` and measure ``error_of(result)``; a ViscoforceError: a ``fails`` row."""
    out = {"scene": scene, "method": method, "knob": knob, "value": value, "time_s": math.nan,
           "error": math.nan, "status": "ok", "is_default": bool(is_default),
           "reference": reference, "detail": ""}
    try:
        result, stats = timed(cold(fn), repeats, cheap_below=0.05, cheap_repeats=5)
        out["time_s"] = stats["time_median_s"]
        out["error"] = float(error_of(result))
        if detail_of is not None:
            out["detail"] = detail_of(result)
        if not math.isfinite(out["error"]):
            out["status"] = f"fails: {nonfinite}"
    except ViscoforceError as exc:  # a failed point is data, not a crash
        out["status"] = f"fails: {type(exc).__name__}: {exc}"
    print_row(out)
    return out


def print_row(r: dict) -> None:
    value = r["value"]
    v = fmt(value, "9.3g") if isinstance(value, float) else f"{value!s:>9}"
    status = "" if r["status"] == "ok" else "  " + r["status"][:90]
    print(f"  {r['scene']:<16} {r['method']:<20} {r['knob']:<18} {v}  "
          f"{fmt(r['time_s'] * 1e3, '10.3f')} ms  err {fmt(r['error'])}"
          f"{'  *default' if r['is_default'] else ''}{status}")


def kstar(ds) -> np.ndarray:
    return ds.stiffness.values * np.exp(1j * np.radians(ds.phase.values))


def kstar_error(k, k_ref) -> float:
    return float(np.max(np.abs(k - k_ref) / np.abs(k_ref)))


# ── 1. static loads ──────────────────────────────────────────────────────────────────────────────

def bench_static(quick: bool, repeats: int) -> list[dict]:
    rows = []
    material = vf.Elastic(E_STATIC)
    for h0 in STATIC_POSITIONS:
        scene = f"static {h0 * 1e9:g} nm"
        ref = vf.static_equilibrium(make_problem(material, h0, 1 / STATIC_REFINE), h0)
        f_ref = float(ref.force)
        label = f"grid/{STATIC_REFINE:g}"
        for factor in QUICK_STATIC_FACTORS if quick else STATIC_FACTORS:
            problem = make_problem(material, h0, factor)
            rows.append(row(scene, "static_equilibrium", "grid_spacing×", factor,
                            is_default=factor == 1.0, reference=label, repeats=repeats,
                            fn=lambda p=problem, h=h0: vf.static_equilibrium(p, h),
                            error_of=lambda ds, f=f_ref: abs(float(ds.force) - f) / abs(f)))
        problem = make_problem(material, h0)
        rows.append(row(scene, "rigid (Derjaguin)", "-", math.nan, is_default=True,
                        reference=label, repeats=max(repeats, 5),
                        nonfinite="the rigid load is infinite (h0 ≤ 0: the rigid sphere "
                                  "overlaps the wall)",
                        fn=lambda p=problem, h=h0: p.rigid_load(h),
                        error_of=lambda f, r=f_ref: abs(float(f) - r) / abs(r)))
    return rows


# ── 2. spectra ───────────────────────────────────────────────────────────────────────────────────

def td_options(knob: str, value, eta: float) -> dict:
    opts = dict(TD_DEFAULT)
    if knob != "default":
        opts[knob] = value
    if opts["tol"] is not None:
        opts["tol"] = opts["tol"] * TD_TOL_DEFAULT * eta
    return {**opts, "progress": False}


def bench_spectra(quick: bool, repeats: int) -> list[dict]:
    rows = []
    n = QUICK_N_OMEGA if quick else N_OMEGA
    omega = np.logspace(math.log10(0.1 / TAU), math.log10(100 / TAU), n)
    for scene, (h0, eta) in SPECTRA.items():
        material, deepest = sls(), h0 - eta
        ref_problem = make_problem(material, deepest, 1 / SPECTRUM_REFINE)
        k_lin = kstar(vf.spectrum(ref_problem, h0, eta, omega, method="linear"))
        lin_label = f"linear, grid/{SPECTRUM_REFINE:g}"
        for factor in QUICK_SPECTRUM_FACTORS if quick else SPECTRUM_FACTORS:
            problem = make_problem(material, deepest, factor)
            rows.append(row(scene, "linear", "grid_spacing×", factor, is_default=factor == 1.0,
                            reference=lin_label, repeats=repeats,
                            fn=lambda p=problem, h=h0, e=eta: vf.spectrum(p, h, e, omega, method="linear"),
                            error_of=lambda ds, k=k_lin: kstar_error(kstar(ds), k)))
        problem = make_problem(material, deepest)
        if h0 > 0:  # the SVDA is a pre-contact approximation
            rows.append(row(scene, "svda", "-", math.nan, is_default=True, reference=lin_label,
                            repeats=max(repeats, 5),
                            fn=lambda p=problem, h=h0, e=eta: vf.spectrum(p, h, e, omega, method="svda"),
                            error_of=lambda ds, k=k_lin: kstar_error(kstar(ds), k)))
        settings = QUICK_TD_SETTINGS if quick else TD_SETTINGS
        if h0 > 0:
            k_td, td_label = k_lin, lin_label
        else:  # η = 1 nm is not small: the time domain is its own reference at its finest
            finest = dict(QUICK_TD_FINEST if quick else TD_FINEST)
            if "tol" in finest:
                finest["tol"] = finest["tol"] * TD_TOL_DEFAULT * eta
            k_td = kstar(vf.spectrum(problem, h0, eta, omega, method="time-domain",
                                     progress=False, **finest))
            td_label = "time-domain, " + (", ".join(
                f"{k}={v:g}" for k, v in finest.items()) or "default setting")
            settings = tuple(s for s in settings if s[0] != "default") + (("default", None),)
        for knob, value in settings:
            opts = td_options(knob, value, eta)
            rows.append(row(scene, "time-domain", knob if knob != "tol" else "tol×default",
                            value if value is not None else math.nan,
                            is_default=knob == "default", reference=td_label, repeats=1,
                            fn=lambda o=opts, p=problem, h=h0, e=eta: vf.spectrum(
                                p, h, e, omega, method="time-domain", **o),
                            error_of=lambda ds, k=k_td: kstar_error(kstar(ds), k)))
        if h0 < 0:  # how far the linear response is from the large-η time domain
            rows.append(row(scene, "linear vs td", "grid_spacing×", 1.0, reference=td_label,
                            fn=lambda p=problem, h=h0, e=eta: vf.spectrum(p, h, e, omega, method="linear"),
                            error_of=lambda ds, k=k_td: kstar_error(kstar(ds), k)))
    return rows


# ── 3. dynamics ──────────────────────────────────────────────────────────────────────────────────

def bench_dynamics(quick: bool, repeats: int) -> list[dict]:
    rows = []
    scenes = {"Fig. 1 step": (vf.Step(-5e-9, -7e-9, 1e-4), -7e-9, None),
              "Fig. 5 loop": (vf.Triangle(10e-9, -10e-9, 5e-6), -10e-9, "duration")}
    default_tol = 1e-5 * vf.paper_pressure_law().decay_length  # simulate()'s default tol [m]
    for scene, (drive, deepest, end) in scenes.items():
        t_end = drive.duration if end == "duration" else drive.duration + 5 * TAU
        t_eval = np.linspace(0.0, t_end, N_OUTPUTS)

        def run(p, stepper, tol=None, dt=None, drive=drive, t_end=t_end, t_eval=t_eval):
            return vf.simulate(p, drive, t_end=t_end, t_eval=t_eval, stepper=stepper, tol=tol,
                               dt=dt, progress=False, output_kinks=False)

        refine = QUICK_DYN_REF_REFINE if quick else DYN_REF_REFINE
        f_ref = run(make_problem(sls(), deepest, 1 / refine), "exponential",
                    tol=DYN_REF_TOL * default_tol).force.values
        label = f"exponential tol={DYN_REF_TOL:g}×default, grid/{refine:g}"
        problem = make_problem(sls(), deepest)

        def err(ds, f_ref=f_ref):
            return float(np.max(np.abs(ds.force.values - f_ref)) / np.max(np.abs(f_ref)))

        for factor in QUICK_TOL_FACTORS if quick else TOL_FACTORS:
            rows.append(row(scene, "exponential", "tol×default", factor, is_default=factor == 1.0,
                            reference=label, repeats=repeats,
                            fn=lambda f=factor, p=problem: run(p, "exponential", tol=f * default_tol),
                            error_of=err))
        rows.append(row(scene, "exponential-euler", "tol×default", 1.0, is_default=True,
                        reference=label, repeats=repeats,
                        fn=lambda p=problem: run(p, "exponential-euler"), error_of=err))
        for stepper in ("exponential-euler", "euler"):
            for dt in (QUICK_DTS if quick else DTS)[stepper]:
                rows.append(row(scene, stepper, "dt", dt, reference=label, repeats=repeats,
                                is_default=stepper == "euler" and math.isclose(
                                    dt, EULER_DEFAULT_DT),
                                fn=lambda s=stepper, d=dt, p=problem: run(p, s, dt=d),
                                error_of=err))
    return rows


# ── 4. fits ──────────────────────────────────────────────────────────────────────────────────────

def bench_fits(repeats: int) -> list[dict]:
    rows = []
    omega = np.logspace(*np.log10(FIT_OMEGA), FIT_N_OMEGA)
    truth = {"E0": E0, "E_inf": E_INF, "tau": TAU}
    for model, h0 in FIT_CASES:
        problem = make_problem(sls(), h0)
        data = vf.spectrum(problem, h0, 0.01e-9, omega, method="linear")
        fixed = {"svda": {"position": h0, "radius": RADIUS, "P": vf.PAPER.P,
                          "debye_length": vf.PAPER.debye_length},
                 "exact": {"problem": problem, "position": h0},
                 "contact": {"radius": RADIUS, "indentation": -h0}}[model]

        def error_of(res):
            return max(abs(float(res[n]) - v) / v for n, v in truth.items())

        def detail(res):
            return "; ".join(f"{n} {abs(float(res[n]) - v) / v:.2g}" for n, v in truth.items())

        rows.append(row("30-point fit", model, "position [nm]", h0 * 1e9, is_default=True,
                        reference="truth (noiseless exact linear data)", repeats=repeats,
                        fn=lambda d=data, m=model, f=fixed: fit_spectrum(d, m, **f),
                        error_of=error_of, detail_of=detail))
    return rows


# ── chart ────────────────────────────────────────────────────────────────────────────────────────

def plot(rows: list[dict], path: Path) -> None:
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    ncol = 4
    nrow = math.ceil(len(scenes) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.6 * nrow), squeeze=False)
    for ax, scene in zip(axes.flat, scenes, strict=False):
        here = [r for r in rows if r["scene"] == scene]
        for i, method in enumerate(dict.fromkeys(r["method"] for r in here)):
            pts = sorted(((r["time_s"], max(r["error"], ERROR_FLOOR), r["is_default"], r["knob"])
                          for r in here if r["method"] == method and r["status"] == "ok"),
                         key=lambda p: p[0])
            fails = sum(r["status"] != "ok" for r in here if r["method"] == method)
            colour = f"C{i}"
            name = method + (f" ({fails} failed)" if fails else "")
            if pts:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", color=colour, ms=4,
                        label=name, alpha=0.85)
                for t, e, d, _ in pts:
                    if d:
                        ax.plot(t, e, "*", color=colour, ms=14, mec="k", mew=0.8)
            else:
                ax.plot([], [], "o-", color=colour, label=name)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_title(scene, fontsize=10)
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel("relative error")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(scenes):]:
        ax.axis("off")
    fig.suptitle("viscoforce speed–accuracy (★ = each method's default; 1 BLAS thread)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# ── main ─────────────────────────────────────────────────────────────────────────────────────────

def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__, quick_help="coarse subsets (< 60 s)",
                      repeats_help=f"timed runs per point (default {REPEATS}, quick "
                                   f"{QUICK_REPEATS})")
    repeats = args.repeats or (QUICK_REPEATS if args.quick else REPEATS)
    args.out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    with threadpool_limits(limits=1, user_api="blas"):
        machine = machine_facts()
        print_machine(machine)
        print(f"speed–accuracy study ({'quick' if args.quick else 'full'}), repeats = {repeats}")
        rows = []
        for part in (lambda: bench_static(args.quick, repeats),
                     lambda: bench_spectra(args.quick, repeats),
                     lambda: bench_dynamics(args.quick, repeats),
                     lambda: bench_fits(repeats)):
            rows += part()
    files = {"json": "speed_accuracy.json", "csv": "speed_accuracy.csv",
             "png": "speed_accuracy.png"}
    plot(rows, args.out / files["png"])
    write_csv(rows, args.out / files["csv"])
    garbage = [f"{r['scene']}: {r['method']} {r['knob']}={r['value']:g}" for r in rows
               if r["status"] == "ok" and r["error"] > GARBAGE_ERROR]
    summary = {"rows": len(rows), "failed": sum(r["status"] != "ok" for r in rows),
               "silent_garbage": garbage, **run_end(t_start)}
    settings = {"static_positions": STATIC_POSITIONS, "static_modulus": E_STATIC,
                "spectra": SPECTRA, "material": {"E0": E0, "E_inf": E_INF, "tau": TAU},
                "n_omega": QUICK_N_OMEGA if args.quick else N_OMEGA, "repeats": repeats,
                "fit_cases": FIT_CASES, "n_outputs": N_OUTPUTS}
    report = {**report_head(SCHEMA, args.quick, machine), "settings": settings, "rows": rows,
              "summary": summary, "files": files}
    write_json(report, args.out / files["json"])
    for g in garbage:
        print(f"  silent garbage (error > {GARBAGE_ERROR:g}, no exception): {g}")
    print(f"{len(rows)} rows, {summary['failed']} failed, {summary['wall_time_s']:.1f} s; "
          f"wrote {', '.join(files.values())} to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
