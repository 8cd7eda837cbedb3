#!/usr/bin/env python
"""Speed–accuracy study: wall time against error of every method and knob on the paper's scenes.

What it measures (see studies/speed_accuracy/README.md; issue 15 item 1):

1. Static loads at h0 = 2, −5, −10 nm on an elastic half-space (E = 1e9 Pa):
   ``static_equilibrium`` for grid spacing = default × (0.5 … 8) and outer radius = default ×
   (0.5, 0.75, 1.5, 2), against grid/4 with outer radius × 4; the rigid (Derjaguin) load
   ``problem.rigid_load(h0)`` as a zero-cost method.
2. Spectra, 10 ω over [0.1/τ, 100/τ]: Fig. 3 (h̄0 = 2 nm, η = 0.1 nm) and Fig. 4 (−5 nm, 1 nm)
   with ``vf.spectrum`` linear (grid and outer-radius knobs), time-domain (samples_per_period,
   periods, tol), the SVDA closed form and the SVDA ODE (``svda_sweep``: rtol, periods; Fig. 3)
   and Hertz contact (``method="contact"``, Fig. 4); a deep-indentation spectrum (h̄0 = −100 nm,
   0.1 nm Debye length, E0/E_inf = 3) with linear (grid) and Hertz contact. Error = max
   |Δk*|/|k*| against the refined linear response (Fig. 4 time domain: its finest setting).
3. The Fig. 1 step (−5 → −7 nm) and the Fig. 5 loop (10 → −10 → 10 nm at 5 µm/s):
   ``vf.simulate`` with stepper exponential (tol and grid knobs), exponential-euler and euler (dt);
   on the loop also the SVDA ODE ``solve_svda`` (rtol) and the SVDA closed form (Eqs. 20–22, the
   approach half). Error = max |F − F_ref| / max |F_ref| on 81 output times against the
   exponential stepper at tol = 1e-3 × default on a 2×-refined grid. A run that raises is a row
   with status ``fails: ...``.
4. 30-point spectrum fits with each spectrum model (svda at 8, 5, 2 nm; exact at −5 nm; contact
   at the deep scene and −15 nm; prony at the deep scene), noiseless and with 1 % complex noise:
   time per ``fit_spectrum`` and max relative error of E0, E_inf, τ against the truth.
5. Where ``viscoforce.experiments.choice`` exists: an "auto" row per spectrum and dynamics scene
   (``method="auto"`` / ``stepper="auto"``, accuracy 1e-3).

Runs under 1 s are timed ``--repeats`` times (median); longer ones once. Outputs in ``--out``:
speed_accuracy.json, speed_accuracy.csv and speed_accuracy.png (Pareto charts, error vs time,
log–log, one panel per scene, each method's default starred, auto as red diamonds). BLAS is
pinned to one thread. Run ``python studies/speed_accuracy/speed_accuracy.py [--quick] [--out DIR]``
(default studies/speed_accuracy/out).
"""

from __future__ import annotations

import math
import statistics
import sys
import time
import warnings
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
from viscoforce.experiments.spectroscopy import svda_sweep  # noqa: E402
from viscoforce.fitting import fit_spectrum  # noqa: E402
from viscoforce.solvers.svda_ode import solve_svda  # noqa: E402
from viscoforce.svda import svda_complex_stiffness, svda_ramp_deformation  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "benchmarks"))  # benchmarks/_common.py, from any cwd
from _common import (  # noqa: E402
    fmt,
    gc_paused,
    machine_facts,
    parse_args,
    print_machine,
    report_head,
    run_end,
    write_csv,
    write_json,
)

RADIUS = vf.PAPER.R  # sphere radius [m]
E0, E_INF, TAU = vf.PAPER.E0, vf.PAPER.E_inf, vf.PAPER.tau  # [Pa], [Pa], creep time [s]
E_STATIC = 1e9  # [Pa] elastic modulus of the static scenes
SCHEMA = "viscoforce.speed_accuracy/1"
JSON_KEYS = ("schema", "created", "quick", "machine", "settings", "rows", "summary", "files")
ROW_KEYS = ("scene", "method", "knob", "value", "time_s", "error", "status", "is_default",
            "reference", "detail", "runs")
ERROR_FLOOR = 1e-16  # errors below this are drawn at this value
GARBAGE_ERROR = 1.0  # an "ok" row at or above this error returned garbage without raising
LARGE_ERROR = 0.1  # an "ok" row above this error with no warning is listed as silently far off
AUTO_ACCURACY = 1e-3  # the accuracy asked of the "auto" rows
REPEATS, QUICK_REPEATS = 3, 1
CHEAP_S = 1.0  # [s] a run longer than this is timed once; shorter ones `repeats` times (median)
VERY_CHEAP_S, VERY_CHEAP_REPEATS = 0.05, 5  # and runs under 50 ms at least 5 times
QUICK_VERY_CHEAP_REPEATS = 1  # --quick: no extra runs of the cheap points
very_cheap_repeats = VERY_CHEAP_REPEATS  # main() sets QUICK_VERY_CHEAP_REPEATS with --quick

# 1. static
STATIC_POSITIONS = (2e-9, -5e-9, -10e-9)  # h0 [m]
STATIC_FACTORS, QUICK_STATIC_FACTORS = (0.5, 1.0, 2.0, 4.0, 8.0), (1.0, 4.0)
#: outer radius × the default (1 is the grid row's default); < 1 is refused by the library
OUTER_FACTORS, QUICK_OUTER_FACTORS = (0.5, 0.75, 1.5, 2.0), (2.0,)
REF_REFINE, REF_OUTER = 4.0, 4.0  # reference: grid spacing / 4, outer radius × 4
QUICK_REF_REFINE, QUICK_REF_OUTER = 2.0, 2.0  # --quick (the same to 1e-13)
# 2. spectra: scene -> (h̄0 [m], η [m])
SPECTRA = {"Fig. 3 spectrum": (2e-9, 0.1e-9), "Fig. 4 spectrum": (-5e-9, 1e-9)}
#: --quick: the lowest ω only (20τ of settling is 0.3 periods there, 300 at 100/τ)
N_OMEGA, QUICK_N_OMEGA = 10, 1
SPECTRUM_FACTORS, QUICK_SPECTRUM_FACTORS = (0.5, 1.0, 2.0, 4.0), (1.0, 2.0)
TD_DEFAULT = {"periods": 4, "samples_per_period": 64, "tol": None}  # sweep()'s defaults
TD_TOL_DEFAULT = 1e-5  # × η: sweep()'s default tol
#: time-domain settings: (knob, value) changed from TD_DEFAULT (tol as a multiple of 1e-5 η)
TD_SETTINGS = (("default", None), ("samples_per_period", 16), ("samples_per_period", 32),
               ("samples_per_period", 128), ("periods", 2), ("periods", 8), ("tol", 10.0),
               ("tol", 0.1))
QUICK_TD_SETTINGS = (("default", None),)
TD_FINEST = {"periods": 8, "samples_per_period": 128, "tol": 0.1}  # Fig. 4 reference
QUICK_TD_FINEST = {}  # --quick: the default setting is the Fig. 4 reference (0 error)
SVDA_ODE_DEFAULT = {"rtol": 1e-10, "periods": 4}  # svda_sweep()'s defaults
#: svda ODE spectrum settings (Fig. 3): (knob, value) changed from SVDA_ODE_DEFAULT
SVDA_ODE_SETTINGS = (("default", None), ("rtol", 1e-4), ("rtol", 1e-6), ("periods", 2))
QUICK_SVDA_ODE_SETTINGS = (("default", None),)
#: the deep-indentation scene: short-range law, moderate E0/E_inf, Hertz contact should hold
DEEP = {"scene": "deep spectrum", "h0": -100e-9, "eta": 0.01e-9, "E0": 3e9, "E_inf": 1e9,
        "tau": 1e-3, "P": 1e7, "debye_length": 0.1e-9, "Pw": 1e7, "z0": 0.05e-9}
DEEP_FACTORS, QUICK_DEEP_FACTORS = (1.0, 2.0, 4.0), (1.0,)
DEEP_REF_REFINE, DEEP_REF_OUTER = 2.0, 1.25  # a grid/4 reference costs ~30 s cold
QUICK_DEEP_REF_OUTER = 1.0
# 3. dynamics: scene -> (drive, t_end)
TOL_FACTORS, QUICK_TOL_FACTORS = (1e3, 1e2, 10.0, 1.0, 0.1), (1e2, 1.0)
DYN_GRID_FACTORS, QUICK_DYN_GRID_FACTORS = (0.5, 2.0, 4.0), (2.0,)
DTS = {"exponential-euler": (1e-4, 3e-5, 1e-5, 3e-6, 1e-6),
       "euler": (1e-3, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5, 5e-6, 2e-6)}
QUICK_DTS = {"exponential-euler": (3e-5,), "euler": (2e-4, 1e-5)}
EULER_DEFAULT_DT = 0.1 * TAU * E_INF / E0  # explicit Euler's default step [s]
DYN_REF_TOL, DYN_REF_REFINE, QUICK_DYN_REF_REFINE = 1e-3, 2.0, 1.0
QUICK_DYN_REF_TOL = 1e-2  # --quick (within 2e-6 of tol 1e-3; the rows' errors are >= 4e-5)
N_OUTPUTS = 81
SVDA_RTOLS, QUICK_SVDA_RTOLS = (1e-4, 1e-6, 1e-8, 1e-10), (1e-8,)
SVDA_DEFAULT_RTOL = 1e-8  # solve_svda()'s default
# 4. fits: (model, scene of the data); scenes: "paper <h0 nm>" or "deep"
FIT_N_OMEGA, FIT_OMEGA = 30, (1e1, 1e6)  # [rad/s]
FIT_ETA = 0.01e-9  # [m] drive amplitude of the fitted (exact linear) data
FIT_CASES = (("svda", 8e-9, True), ("svda", 5e-9, False), ("svda", 2e-9, False),
             ("exact", -5e-9, True),
             ("contact", "deep", True), ("contact", -15e-9, False), ("prony", "deep", True),
             ("auto", 8e-9, True), ("auto", -5e-9, False))
FIT_NOISE, FIT_SEED = 0.01, 20261201  # 1 % complex Gaussian noise, seeded Generator


# ── helpers ──────────────────────────────────────────────────────────────────────────────────────

def sls(e0: float = E0, e_inf: float = E_INF, tau: float = TAU) -> vf.StandardLinearSolid:
    return vf.StandardLinearSolid(E0=e0, E_inf=e_inf, tau=tau)


def deep_law() -> vf.SumOfLaws:
    return vf.SumOfLaws((vf.DoubleLayer(P=DEEP["P"], debye_length=DEEP["debye_length"]),
                         vf.SoftWall(Pw=DEEP["Pw"], z0=DEEP["z0"])))


def deep_material() -> vf.StandardLinearSolid:
    return sls(DEEP["E0"], DEEP["E_inf"], DEEP["tau"])


def make_problem(material, deepest: float, factor: float = 1.0, outer: float = 1.0,
                 law=None) -> vf.ContactProblem:
    """The paper's sphere (and pressure law unless ``law``); grid spacing = ``factor`` × the
    default spacing, outer radius = ``outer`` × the default outer radius."""
    kw = dict(sphere=vf.Sphere(RADIUS), surface_force=law or vf.paper_pressure_law(),
              material=material, deepest_position=deepest)
    spacing = radius = None
    if factor != 1.0 or outer != 1.0:
        grid = vf.ContactProblem.create(**kw).grid
        spacing = factor * grid.outer_radius / grid.size
        radius = outer * grid.outer_radius
    problem = vf.ContactProblem.create(**kw, grid_spacing=spacing, outer_radius=radius)
    _ = problem.influence  # build (and cache) the kernel outside every timed region
    _ = problem.center_row
    return problem


def cold(fn):
    """``fn`` run cold: the cached static states of the linear response are dropped first."""
    def run():
        linearized_state.cache_clear()
        return fn()
    return run


def measure(fn, repeats: int):
    """First result and (median wall time [s], runs): a run over CHEAP_S once, else repeated."""
    wall, result = [], None
    with gc_paused():
        n = 1
        while len(wall) < n:
            t0 = time.perf_counter()
            out = fn()
            wall.append(time.perf_counter() - t0)
            if len(wall) == 1:
                result = out
                if wall[0] < VERY_CHEAP_S:
                    n = max(repeats, very_cheap_repeats)
                elif wall[0] < CHEAP_S:
                    n = repeats
    return result, statistics.median(wall), len(wall)


def row(scene, method, knob, value, *, is_default=False, reference="", fn=None, error_of=None,
        repeats=1, nonfinite="non-finite result", detail_of=None, detail="") -> dict:
    """Time ``cold(fn)`` and measure ``error_of(result)``; a ViscoforceError: a ``fails`` row."""
    out = {"scene": scene, "method": method, "knob": knob, "value": value, "time_s": math.nan,
           "error": math.nan, "status": "ok", "is_default": bool(is_default),
           "reference": reference, "detail": detail, "runs": 0}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result, out["time_s"], out["runs"] = measure(cold(fn), repeats)
            out["error"] = float(error_of(result))
            if detail_of is not None:
                out["detail"] = "; ".join(s for s in (detail, detail_of(result)) if s)
            if not math.isfinite(out["error"]):
                out["status"] = f"fails: {nonfinite}"
        except ViscoforceError as exc:  # a failed point is data, not a crash
            out["status"] = f"fails: {type(exc).__name__}: {exc}"
    seen = list(dict.fromkeys(f"{type(w.message).__name__}: {w.message}" for w in caught))
    if seen:
        out["detail"] = "; ".join(s for s in (out["detail"], "warned " + " | ".join(seen)) if s)
    print_row(out)
    return out


def print_row(r: dict) -> None:
    value = r["value"]
    v = fmt(value, "9.3g") if isinstance(value, float) else f"{value!s:>9}"
    status = "" if r["status"] == "ok" else "  " + r["status"][:90]
    print(f"  {r['scene'][:16]:<16} {r['method'][:20]:<20} {r['knob'][:18]:<18} {v}  "
          f"{fmt(r['time_s'] * 1e3, '10.3f')} ms  err {fmt(r['error'])}"
          f"{'  *default' if r['is_default'] else ''}{status}", flush=True)


def kstar(ds) -> np.ndarray:
    return ds.stiffness.values * np.exp(1j * np.radians(ds.phase.values))


def kstar_error(k, k_ref) -> float:
    return float(np.max(np.abs(k - k_ref) / np.abs(k_ref)))


def hertz_kstar(material, radius: float, indentation: float, omega) -> np.ndarray:
    """Hertz contact k*(ω) = sqrt(R δ0)/C*(ω) (the paper's E convention, E = 1/C) [N/m]."""
    return math.sqrt(radius * indentation) / material.complex_compliance(omega)


def hertz_row(scene, problem, h0, eta, omega, k_ref, label, repeats) -> dict:
    """``spectrum(method="contact")`` (Hertz at δ0 = −h̄0) against the exact linear k*."""
    k_formula = hertz_kstar(problem.material, RADIUS, -h0, omega)
    return row(scene, "Hertz contact", "-", math.nan, is_default=True, reference=label,
               repeats=max(repeats, 5),
               fn=lambda: vf.spectrum(problem, h0, eta, omega, method="contact"),
               error_of=lambda ds: kstar_error(kstar(ds), k_ref),
               detail_of=lambda ds: "vs sqrt(R delta0)/C*(omega): "
                                    f"{kstar_error(kstar(ds), k_formula):.2g}")


def auto_hooks() -> tuple[bool, str]:
    """Whether the "auto" choices exist (``choose_spectrum`` and ``choose_simulation``)."""
    try:
        from viscoforce.experiments import choice
        spectrum_choice = choice.choose_spectrum
        try:
            simulation_choice = choice.choose_simulation
        except AttributeError:
            from viscoforce.choice import choose_simulation as simulation_choice
    except (ImportError, AttributeError) as exc:
        return False, f"not available: {type(exc).__name__}: {exc}"
    return callable(spectrum_choice) and callable(simulation_choice), "available"


def auto_detail(ds) -> str:
    a = ds.attrs
    chose = a.get("method", a.get("stepper", "?"))
    return (f"chose {chose}; estimated error {a.get('estimated_error', math.nan):.2g}; "
            f"{a.get('explanation', '')}")


def auto_row(scene, fn, error_of, reference, repeats, skip_slow=None) -> list[dict]:
    """The "auto" row (``method="auto"``/``stepper="auto"``), or none before the choice exists.

    ``skip_slow`` (--quick): a callable giving the route the choice would take; a time-domain
    route (tens of seconds) is then skipped and said so.
    """
    if not AUTO[0]:
        return []
    try:
        if skip_slow is not None:
            chosen = skip_slow()
            if chosen in SLOW_ROUTES:
                print(f"  {scene}: auto row skipped in --quick (the choice is {chosen})")
                return []
        r = row(scene, "auto", f"accuracy={AUTO_ACCURACY:g}", AUTO_ACCURACY, is_default=True,
                reference=reference, repeats=repeats, fn=fn, error_of=error_of,
                detail_of=auto_detail)
    except (ImportError, TypeError, AttributeError) as exc:  # the hook changed under us
        print(f"  {scene}: auto row skipped ({type(exc).__name__}: {exc})")
        return []
    if r["status"] == "ok":
        meets = "yes" if r["error"] <= AUTO_ACCURACY else "NO"
        r["detail"] = f"error <= {AUTO_ACCURACY:g}: {meets}; {r['detail']}"
    return [r]


AUTO = auto_hooks()
SLOW_ROUTES = ("time-domain", "svda-ode")  # auto rows skipped in --quick when chosen


def spectrum_choice(problem, h0, eta, omega):
    """The route ``choose_spectrum`` takes (for --quick's skip of slow auto rows)."""
    from viscoforce.experiments.choice import choose_spectrum
    return choose_spectrum(problem, h0, eta, omega, accuracy=AUTO_ACCURACY).method


# ── 1. static loads ──────────────────────────────────────────────────────────────────────────────

def bench_static(quick: bool, repeats: int) -> list[dict]:
    rows = []
    material = vf.Elastic(E_STATIC)
    refine, outer = (QUICK_REF_REFINE, QUICK_REF_OUTER) if quick else (REF_REFINE, REF_OUTER)
    label = f"grid/{refine:g}, outer radius×{outer:g}"
    for h0 in STATIC_POSITIONS:
        scene = f"static {h0 * 1e9:g} nm"
        ref = vf.static_equilibrium(make_problem(material, h0, 1 / refine, outer), h0)
        f_ref = float(ref.force)

        def err(ds, f=f_ref):
            return abs(float(ds.force) - f) / abs(f)

        for knob, factors in (("grid_spacing×", QUICK_STATIC_FACTORS if quick else STATIC_FACTORS),
                              ("outer_radius×", QUICK_OUTER_FACTORS if quick else OUTER_FACTORS)):
            for factor in factors:
                try:
                    problem = (make_problem(material, h0, factor) if knob == "grid_spacing×"
                               else make_problem(material, h0, outer=factor))
                except ViscoforceError as exc:  # the library refuses too small an outer radius
                    rows.append(failed_row(scene, "static_equilibrium", knob, factor, label, exc))
                    continue
                rows.append(row(scene, "static_equilibrium", knob, factor,
                                is_default=knob == "grid_spacing×" and factor == 1.0,
                                reference=label, repeats=repeats,
                                fn=lambda p=problem, h=h0: vf.static_equilibrium(p, h),
                                error_of=err))
        problem = make_problem(material, h0)
        rows.append(row(scene, "rigid (Derjaguin)", "-", math.nan, is_default=True,
                        reference=label, repeats=max(repeats, 5),
                        nonfinite="the rigid load is infinite (h0 ≤ 0: the rigid sphere "
                                  "overlaps the wall)",
                        fn=lambda p=problem, h=h0: p.rigid_load(h),
                        error_of=lambda f, r=f_ref: abs(float(f) - r) / abs(r)))
    return rows


def failed_row(scene, method, knob, value, reference, exc) -> dict:
    """A row for a setting the library refuses to build (no time, no error)."""
    out = {"scene": scene, "method": method, "knob": knob, "value": value, "time_s": math.nan,
           "error": math.nan, "status": f"fails: {type(exc).__name__}: {exc}",
           "is_default": False, "reference": reference, "detail": "refused when building the "
           "problem", "runs": 0}
    print_row(out)
    return out


# ── 2. spectra ───────────────────────────────────────────────────────────────────────────────────

def td_options(knob: str, value, eta: float) -> dict:
    opts = dict(TD_DEFAULT)
    if knob != "default":
        opts[knob] = value
    if opts["tol"] is not None:
        opts["tol"] = opts["tol"] * TD_TOL_DEFAULT * eta
    return {**opts, "progress": False}


def spectrum_omega(quick: bool) -> np.ndarray:
    n = QUICK_N_OMEGA if quick else N_OMEGA
    return np.logspace(math.log10(0.1 / TAU), math.log10(100 / TAU), n)


def linear_rows(scene, material, h0, eta, omega, k_ref, label, grid_factors, outer_factors,
                repeats, law=None) -> list[dict]:
    """``spectrum(method="linear")`` over the grid-spacing and outer-radius knobs."""
    rows = []
    knobs = [("grid_spacing×", f) for f in grid_factors]
    knobs += [("outer_radius×", f) for f in outer_factors]
    for knob, factor in knobs:
        try:
            problem = (make_problem(material, h0 - eta, factor, law=law) if knob == "grid_spacing×"
                       else make_problem(material, h0 - eta, outer=factor, law=law))
        except ViscoforceError as exc:
            rows.append(failed_row(scene, "linear", knob, factor, label, exc))
            continue
        rows.append(row(scene, "linear", knob, factor,
                        is_default=knob == "grid_spacing×" and factor == 1.0,
                        reference=label, repeats=repeats,
                        fn=lambda p=problem: vf.spectrum(p, h0, eta, omega, method="linear"),
                        error_of=lambda ds: kstar_error(kstar(ds), k_ref)))
    return rows


def bench_spectra(quick: bool, repeats: int) -> list[dict]:
    rows = []
    omega = spectrum_omega(quick)
    for scene, (h0, eta) in SPECTRA.items():
        material, deepest = sls(), h0 - eta
        refine, outer = (QUICK_REF_REFINE, QUICK_REF_OUTER) if quick else (REF_REFINE, REF_OUTER)
        ref_problem = make_problem(material, deepest, 1 / refine, outer)
        with warnings.catch_warnings():  # the Fig. 4 κη = 1 warning: recorded on each row
            warnings.simplefilter("ignore")
            k_lin = kstar(vf.spectrum(ref_problem, h0, eta, omega, method="linear"))
        lin_label = f"linear, grid/{refine:g}, outer radius×{outer:g}"
        rows += linear_rows(scene, material, h0, eta, omega, k_lin, lin_label,
                            QUICK_SPECTRUM_FACTORS if quick else SPECTRUM_FACTORS,
                            QUICK_OUTER_FACTORS if quick else OUTER_FACTORS, repeats)
        problem = make_problem(material, deepest)
        if h0 > 0:  # the SVDA is a pre-contact approximation
            rows += svda_spectrum_rows(scene, problem, h0, eta, omega, k_lin, lin_label, quick,
                                       repeats)
        else:  # Hertz contact at δ0 = −h̄0 (expected to fail at 5 nm with a 1 nm Debye length)
            rows.append(hertz_row(scene, problem, h0, eta, omega, k_lin, lin_label, repeats))
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
        k_auto, auto_label = (k_lin, lin_label) if h0 > 0 else (k_td, td_label)
        rows += auto_row(scene, lambda p=problem, h=h0, e=eta: vf.spectrum(
            p, h, e, omega, method="auto", accuracy=AUTO_ACCURACY),
            lambda ds, k=k_auto: kstar_error(kstar(ds), k), auto_label, repeats,
            skip_slow=(lambda p=problem, h=h0, e=eta: spectrum_choice(p, h, e, omega))
            if quick else None)
    rows += bench_deep_spectrum(quick, repeats)
    return rows


def svda_spectrum_rows(scene, problem, h0, eta, omega, k_lin, lin_label, quick,
                       repeats) -> list[dict]:
    """The SVDA closed form and the SVDA ODE (``svda_sweep``) against the exact linear k*."""
    rows = []
    p = vf.PAPER
    with warnings.catch_warnings():  # its validity warning is recorded on the svda rows
        warnings.simplefilter("ignore")
        k_closed = svda_complex_stiffness(omega, h0, E0, E_INF, TAU, RADIUS, p.P,
                                          p.debye_length)
    # --quick: the lowest ω only (the settling time is 20τ at every ω: ~45 s for the highest)
    n = 1 if quick else omega.size
    note = "quick: the lowest omega only" if quick else ""
    rows.append(row(scene, "svda closed form", "-", math.nan, is_default=True, reference=lin_label,
                    repeats=max(repeats, 5),
                    fn=lambda: vf.spectrum(problem, h0, eta, omega, method="svda"),
                    error_of=lambda ds: kstar_error(kstar(ds), k_lin)))
    for knob, value in QUICK_SVDA_ODE_SETTINGS if quick else SVDA_ODE_SETTINGS:
        opts = dict(SVDA_ODE_DEFAULT)
        if knob != "default":
            opts[knob] = value
        rows.append(row(scene, "svda ODE", knob, value if value is not None else math.nan,
                        is_default=knob == "default", reference=lin_label, repeats=1,
                        fn=lambda o=opts: svda_sweep(problem, h0, eta, omega[:n], progress=False,
                                                     **o),
                        error_of=lambda ds: kstar_error(kstar(ds), k_lin[:n]), detail=note,
                        detail_of=lambda ds: "vs the svda closed form: "
                                             f"{kstar_error(kstar(ds), k_closed[:n]):.2g}"))
    return rows


def bench_deep_spectrum(quick: bool, repeats: int) -> list[dict]:
    """Deep indentation (h̄0 = −100 nm), 0.1 nm Debye length: linear (grid) and Hertz contact."""
    scene, h0, eta = DEEP["scene"], DEEP["h0"], DEEP["eta"]
    omega, material, law = spectrum_omega(quick), deep_material(), deep_law()
    outer = QUICK_DEEP_REF_OUTER if quick else DEEP_REF_OUTER
    ref_problem = make_problem(material, h0 - eta, 1 / DEEP_REF_REFINE, outer, law=law)
    k_ref = kstar(vf.spectrum(ref_problem, h0, eta, omega, method="linear"))
    label = f"linear, grid/{DEEP_REF_REFINE:g}, outer radius×{outer:g}"
    rows = linear_rows(scene, material, h0, eta, omega, k_ref, label,
                       QUICK_DEEP_FACTORS if quick else DEEP_FACTORS, (), repeats, law=law)
    problem = make_problem(material, h0 - eta, law=law)
    rows.append(hertz_row(scene, problem, h0, eta, omega, k_ref, label, repeats))
    rows += auto_row(scene, lambda: vf.spectrum(problem, h0, eta, omega, method="auto",
                                                accuracy=AUTO_ACCURACY),
                     lambda ds: kstar_error(kstar(ds), k_ref), label, repeats,
                     skip_slow=(lambda: spectrum_choice(problem, h0, eta, omega))
                     if quick else None)
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

        def run(p, stepper, tol=None, dt=None, drive=drive, t_end=t_end, t_eval=t_eval, **kw):
            return vf.simulate(p, drive, t_end=t_end, t_eval=t_eval, stepper=stepper, tol=tol,
                               dt=dt, progress=False, output_kinks=False, **kw)

        refine = QUICK_DYN_REF_REFINE if quick else DYN_REF_REFINE
        ref_tol = QUICK_DYN_REF_TOL if quick else DYN_REF_TOL
        f_ref = run(make_problem(sls(), deepest, 1 / refine), "exponential",
                    tol=ref_tol * default_tol).force.values
        label = f"exponential tol={ref_tol:g}×default, grid/{refine:g}"
        problem = make_problem(sls(), deepest)

        def err(ds, f_ref=f_ref):
            return float(np.max(np.abs(ds.force.values - f_ref)) / np.max(np.abs(f_ref)))

        for factor in QUICK_TOL_FACTORS if quick else TOL_FACTORS:
            rows.append(row(scene, "exponential", "tol×default", factor, is_default=factor == 1.0,
                            reference=label, repeats=repeats,
                            fn=lambda f=factor, p=problem: run(p, "exponential", tol=f * default_tol),
                            error_of=err))
        for factor in QUICK_DYN_GRID_FACTORS if quick else DYN_GRID_FACTORS:
            p = make_problem(sls(), deepest, factor)
            rows.append(row(scene, "exponential", "grid_spacing×", factor, reference=label,
                            repeats=repeats, fn=lambda p=p: run(p, "exponential"), error_of=err))
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
        if scene == "Fig. 5 loop":
            rows += svda_loop_rows(scene, drive, t_eval, f_ref, label, quick, repeats)
        rows += auto_row(scene, lambda p=problem, d=drive, te=t_end, tv=t_eval: vf.simulate(
            p, d, t_end=te, t_eval=tv, stepper="auto", accuracy=AUTO_ACCURACY,
            progress=False, output_kinks=False), err, label, repeats)
    return rows


def svda_loop_rows(scene, drive, t_eval, f_ref, label, quick, repeats) -> list[dict]:
    """SVDA ODE (``solve_svda``, rtol knob) and closed form (Eqs. 20–22, approach only).

    The SVDA is a pre-contact approximation and the loop goes 10 nm into contact: the rows record
    how far off it is there; the detail gives the error on the pre-contact part (h0 ≥ 2 nm).
    """
    rows = []
    p = vf.PAPER
    kw = dict(E0=E0, E_inf=E_INF, tau=TAU, radius=RADIUS, P=p.P, debye_length=p.debye_length)
    position = np.array([drive.position(t) for t in t_eval])
    scale = np.max(np.abs(f_ref))
    pre = position >= 2e-9

    def err_on(force, mask):
        return float(np.max(np.abs(force[mask] - f_ref[mask])) / scale)

    for rtol in QUICK_SVDA_RTOLS if quick else SVDA_RTOLS:
        rows.append(row(scene, "svda ODE", "rtol", rtol, is_default=rtol == SVDA_DEFAULT_RTOL,
                        reference=label, repeats=repeats,
                        fn=lambda r=rtol: solve_svda(drive, t_eval=t_eval, rtol=r, **kw),
                        error_of=lambda tr: err_on(tr.force, slice(None)),
                        detail_of=lambda tr: f"pre-contact part (h0 >= 2 nm): "
                                             f"{err_on(tr.force, pre):.2g}; in contact the SVDA "
                                             "does not apply"))
    # the closed form is a constant-speed ramp from u = 0: the approach half of the loop only
    t_turn = drive.breakpoints()[1]
    approach = t_eval <= t_turn
    speed = float(drive.velocity(0.5 * t_turn))
    kappa = 1.0 / p.debye_length

    def closed_form():
        u = svda_ramp_deformation(t_eval[approach], drive.position(0.0), speed, **kw)
        return 2 * math.pi * RADIUS / kappa * p.P * np.exp(-kappa * (position[approach] - u))

    def err_closed(force):
        return float(np.max(np.abs(force - f_ref[approach])) / scale)

    rows.append(row(scene, "svda closed form", "-", math.nan, is_default=True,
                    reference=label + " (approach half only)", repeats=max(repeats, 5),
                    fn=closed_form, error_of=err_closed,
                    detail_of=lambda f: "approach half only (Eqs. 20-22 start from u = 0 at "
                                        "constant speed); pre-contact part (h0 >= 2 nm): "
                                        f"{err_on_mask(f, pre[approach], f_ref[approach], scale):.2g}"))
    return rows


def err_on_mask(force, mask, f_ref, scale) -> float:
    return float(np.max(np.abs(force[mask] - f_ref[mask])) / scale)


# ── 4. fits ──────────────────────────────────────────────────────────────────────────────────────

def noisy(ds, rng: np.random.Generator, level: float):
    """``ds`` with k* × (1 + level·(n1 + i n2)/√2), n1, n2 standard normal."""
    k = kstar(ds)
    k = k * (1 + level * (rng.standard_normal(k.shape) + 1j * rng.standard_normal(k.shape))
             / math.sqrt(2))
    out = ds.copy()
    out["stiffness"] = ds.stiffness.copy(data=np.abs(k))  # keeps the units and attributes
    out["phase"] = ds.phase.copy(data=np.degrees(np.angle(k)))
    return out


def fit_parameters(res, model: str, root: float) -> dict:
    """E0, E_inf, τ (creep time) of a fit; prony's k_inf, dk_1, τ_1 mapped through Hertz."""
    if model != "prony":
        return {n: float(res[n]) for n in ("E0", "E_inf", "tau")}
    k_inf, dk, tau_relax = float(res["k_inf"]), float(res["dk_1"]), float(res["tau_1"])
    e_inf, e0 = k_inf / root, (k_inf + dk) / root
    return {"E0": e0, "E_inf": e_inf, "tau": tau_relax * e0 / e_inf}


def bench_fits(repeats: int, quick: bool = False) -> list[dict]:
    """The 30-point fits of FIT_CASES, noiseless and noisy (``quick``: noiseless only)."""
    rows = []
    omega = np.logspace(*np.log10(FIT_OMEGA), FIT_N_OMEGA)
    rng = np.random.default_rng(FIT_SEED)
    p = vf.PAPER
    for model, where, default in FIT_CASES:
        if where == "deep":
            h0, material, law = DEEP["h0"], deep_material(), deep_law()
            truth = {"E0": DEEP["E0"], "E_inf": DEEP["E_inf"], "tau": DEEP["tau"]}
            case = f"deep {h0 * 1e9:g} nm"
        else:
            h0, material, law = where, sls(), None
            truth = {"E0": E0, "E_inf": E_INF, "tau": TAU}
            case = f"{h0 * 1e9:g} nm"
        problem = make_problem(material, h0 - FIT_ETA, law=law)
        clean = vf.spectrum(problem, h0, FIT_ETA, omega, method="linear")
        fixed = {"svda": {"position": h0, "radius": RADIUS, "P": p.P,
                          "debye_length": p.debye_length},
                 "exact": {"problem": problem, "position": h0},
                 "contact": {"radius": RADIUS, "indentation": -h0,
                             "debye_length": problem.surface_force.decay_length},
                 "prony": {},
                 "auto": {"problem": problem, "position": h0}}[model]
        root = math.sqrt(RADIUS * max(-h0, 0.0))
        note = ("prony fits k_inf, dk_1, tau_1 (stiffness); E0, E_inf, tau via Hertz "
                "sqrt(R delta0) and tau = tau_1 E0/E_inf" if model == "prony" else
                "auto: fit_spectrum(..., 'auto', accuracy=1e-3)" if model == "auto" else "")
        for noise in (0.0,) if quick else (0.0, FIT_NOISE):
            data = clean if noise == 0 else noisy(clean, rng, noise)

            def error_of(res, m=model, t=truth, k=root):
                got = fit_parameters(res, m, k)
                return max(abs(got[n] - v) / v for n, v in t.items())

            def detail(res, m=model, t=truth, k=root):
                got = fit_parameters(res, m, k)
                errors = ", ".join(f"{n} {abs(got[n] - v) / v:.2g}" for n, v in t.items())
                return f"chose {res.attrs['model']}; {errors}" if m == "auto" else errors

            label = f"{case}, {'noiseless' if noise == 0 else f'{noise:.0%} noise'}"
            rows.append(row("30-point fit", model, "data", label,
                            is_default=default and noise == 0,
                            reference="truth (exact linear data, h0 " + case + ")",
                            repeats=repeats, detail=note,
                            fn=lambda d=data, m=model, f=fixed: fit_spectrum(d, m, **f),
                            error_of=error_of, detail_of=detail))
    return rows


# ── chart ────────────────────────────────────────────────────────────────────────────────────────

KNOB_MARKERS = {"grid_spacing×": "o", "outer_radius×": "s", "tol×default": "P", "dt": "^",
                "rtol": "v", "periods": "<", "samples_per_period": ">", "default": "o",
                "data": "o", "-": "o"}


def plot(rows: list[dict], path: Path) -> None:
    """Error vs wall time, log–log, one panel per scene; one colour per method, one marker per
    knob; each method's default as a star, the "auto" rows as red diamonds."""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    ncol = 3
    nrow = math.ceil(len(scenes) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(6.0 * ncol, 4.6 * nrow), squeeze=False)
    for ax, scene in zip(axes.flat, scenes, strict=False):
        here = [r for r in rows if r["scene"] == scene]
        methods = [m for m in dict.fromkeys(r["method"] for r in here) if m != "auto"]
        for i, method in enumerate(methods):
            colour = f"C{i % 10}"
            mine = [r for r in here if r["method"] == method]
            first = True
            for knob in dict.fromkeys(r["knob"] for r in mine):
                pts = sorted(((r["time_s"], max(r["error"], ERROR_FLOOR), r["is_default"])
                              for r in mine if r["knob"] == knob and r["status"] == "ok"),
                             key=lambda q: q[0])
                fails = sum(r["status"] != "ok" for r in mine if r["knob"] == knob)
                knob_label = "" if knob in ("-", "data", "default") else f" [{knob}]"
                name = method + knob_label + (f" ({fails} failed)" if fails else "")
                if not pts:  # every row of this knob failed
                    ax.plot([], [], "x", color=colour, label=name)
                    continue
                style = "none" if scene == "30-point fit" else ("-" if first else "--")
                first = False
                ax.plot([q[0] for q in pts], [q[1] for q in pts], marker=KNOB_MARKERS.get(
                    knob, "o"), ls=style, color=colour, ms=4, label=name, alpha=0.85)
                for t, e, d in pts:
                    if d:
                        ax.plot(t, e, "*", color=colour, ms=14, mec="k", mew=0.8)
        for r in here:
            if r["method"] == "auto" and r["status"] == "ok":
                ax.plot(r["time_s"], max(r["error"], ERROR_FLOOR), "D", color="red", ms=9,
                        mec="k", mew=0.8, label=f"auto (accuracy {AUTO_ACCURACY:g})")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_title(scene, fontsize=11)
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel("relative error [-]" if scene != "30-point fit"
                      else "max relative parameter error [-]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="best", framealpha=0.8)
    for ax in list(axes.flat)[len(scenes):]:
        ax.axis("off")
    fig.suptitle("viscoforce speed–accuracy (★ = each method's default, red ◆ = auto; "
                 "1 BLAS thread)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


# ── main ─────────────────────────────────────────────────────────────────────────────────────────

def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__, out_dir=HERE / "out",
                      quick_help="coarse subsets (< 90 s)",
                      repeats_help=f"timed runs per cheap point (default {REPEATS}, quick "
                                   f"{QUICK_REPEATS})")
    global very_cheap_repeats
    repeats = args.repeats or (QUICK_REPEATS if args.quick else REPEATS)
    very_cheap_repeats = QUICK_VERY_CHEAP_REPEATS if args.quick else VERY_CHEAP_REPEATS
    args.out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    with threadpool_limits(limits=1, user_api="blas"):
        machine = machine_facts()
        print_machine(machine)
        print(f"speed–accuracy study ({'quick' if args.quick else 'full'}), repeats = {repeats}; "
              f"auto rows: {AUTO[1]}")
        rows = []
        for part in (lambda: bench_static(args.quick, repeats),
                     lambda: bench_spectra(args.quick, repeats),
                     lambda: bench_dynamics(args.quick, repeats),
                     lambda: bench_fits(repeats, args.quick)):
            rows += part()
    files = {"json": "speed_accuracy.json", "csv": "speed_accuracy.csv",
             "png": "speed_accuracy.png"}
    plot(rows, args.out / files["png"])
    write_csv(rows, args.out / files["csv"])
    garbage = [f"{r['scene']}: {r['method']}" + (f" {r['knob']}={r['value']}" if r["knob"] != "-"
                                                  else "") for r in rows
               if r["status"] == "ok" and r["error"] >= GARBAGE_ERROR]
    far_off = [f"{r['scene']}: {r['method']}" + (f" {r['knob']}={r['value']}" if r["knob"] != "-"
                                                 else "") + f" ({r['error']:.2g})" for r in rows
               if r["status"] == "ok" and r["error"] > LARGE_ERROR and "warned" not in r["detail"]]
    auto = [r for r in rows if r["method"] == "auto"]
    summary = {"rows": len(rows), "failed": sum(r["status"] != "ok" for r in rows),
               "silent_garbage": garbage, "silent_large_error": far_off,
               "auto_meets_accuracy": {r["scene"]: r["status"] == "ok"
                                       and r["error"] <= AUTO_ACCURACY for r in auto},
               **run_end(t_start)}
    settings = {"static_positions": STATIC_POSITIONS, "static_modulus": E_STATIC,
                "reference_grid": {"refine": REF_REFINE, "outer_radius_factor": REF_OUTER},
                "outer_radius_factors": QUICK_OUTER_FACTORS if args.quick else OUTER_FACTORS,
                "spectra": SPECTRA, "deep_spectrum": DEEP,
                "deep_reference_grid": {"refine": DEEP_REF_REFINE,
                                        "outer_radius_factor": DEEP_REF_OUTER},
                "material": {"E0": E0, "E_inf": E_INF, "tau": TAU},
                "n_omega": QUICK_N_OMEGA if args.quick else N_OMEGA, "repeats": repeats,
                "timing": f"median of `repeats` runs (at least {very_cheap_repeats} under "
                          f"{VERY_CHEAP_S:g} s) for a first run under {CHEAP_S:g} s; a run "
                          f"longer than {CHEAP_S:g} s (time-domain spectra, svda ODE spectra, "
                          "slow steppers) is timed once; `runs` per row",
                "fit_cases": FIT_CASES, "fit_noise": FIT_NOISE, "fit_seed": FIT_SEED,
                "fit_note": "spectrum models only (svda, exact, contact, prony); relaxation and "
                            "step are time-domain (force-curve) models, not spectrum fits",
                "n_outputs": N_OUTPUTS, "auto": {"accuracy": AUTO_ACCURACY, "hooks": AUTO[1]}}
    report = {**report_head(SCHEMA, args.quick, machine), "settings": settings, "rows": rows,
              "summary": summary, "files": files}
    write_json(report, args.out / files["json"])
    for g in garbage:
        print(f"  silent garbage (error >= {GARBAGE_ERROR:g}, no exception): {g}")
    for g in far_off:
        print(f"  far off without a warning (error > {LARGE_ERROR:g}): {g}")
    for scene, ok in summary["auto_meets_accuracy"].items():
        print(f"  auto on {scene}: error <= {AUTO_ACCURACY:g}: {'yes' if ok else 'NO'}")
    print(f"{len(rows)} rows, {summary['failed']} failed, {summary['wall_time_s']:.1f} s; "
          f"wrote {', '.join(files.values())} to {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
