#!/usr/bin/env python
"""Step-fit benchmark: the ``step`` model's fit, old (one simulation per evaluation) against new.

What it measures (issue 22 item 2, see benchmarks/README.md, section ``bench_step.py``): the CPU
time of one ``fit_step`` of a simulated trajectory, by two paths timed interleaved in one run
(old, new, old, new, …; median CPU time of ``--repeats`` fits each):

- ``old``: the model as it was before (kept here verbatim as the reference): every evaluation is
  one ``simulate(problem.with_material(...), MeasuredTrace(t, h0), output_kinks=False)``, and
  lmfit's ``leastsq`` takes its Jacobian by finite differences (n_params + 1 simulations an
  iteration); the fit and result dataset of ``fit_data`` (``fit_once`` + ``result_dataset``).
- ``new``: :func:`viscoforce.fitting.curves.fit_step` (the exact Jacobian from forward
  sensitivities integrated with the force, one simulation an iteration; a repeated step grid with
  Newton warm starts near where it was chosen; a search at 100× the tolerance, then the fit at
  the default tolerance and a final adaptive simulation for the curve, χ² and covariance).

Cases (the paper's 10 µm sphere and pressure law; truth SLS E0 = 1e10 Pa, E_inf = 1e9 Pa,
τ = 1 ms; each fit starts from the data's guess with the problem's material E0 = 3e9, E_inf =
5e8 Pa, τ = 0.1 ms, which the guess ignores):

1. ``fig1_step``: the Fig. 1 step h0 = −5 → −7 nm in 0.1 ms, 101 samples over 5 ms (``--quick``:
   11 samples over 1 ms), noise-free (the test case of tests/fitting/test_fitting.py).
2. ``triangle``: a triangle −3 → −7 → −3 nm at 4 µm/s (2 ms), 101 samples over 4 ms, with 0.3 %
   seeded Gaussian noise on the force (a measured-trace-like case; not run with ``--quick``).

Reported per case: per-fit CPU median of each path, the speed-up old/new with its target ≥ 5
(PASS/FAIL per case and overall), simulations and Newton iterations per fit, and the parameter
and stderr differences new − old (relative, and in units of the old stderr).

BLAS is pinned to one thread (environment before NumPy loads, plus threadpoolctl; reported).
Run ``python benchmarks/bench_step.py [--quick] [--out DIR] [--repeats N]``. Outputs in
``--out``: ``step.json`` (keys :data:`JSON_KEYS`), ``step.csv`` (one row per timed fit) and
``step.png``. tests/benchmarks/test_solvers.py runs ``--quick`` and checks keys and files.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # before NumPy loads

import math  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import (  # noqa: E402
    gc_paused,
    machine_facts,
    parse_args,
    pf,
    print_machine,
    report_head,
    run_end,
    write_csv,
    write_json,
)

from viscoforce import PAPER  # noqa: E402
from viscoforce.experiments.drives import MeasuredTrace, Step, Triangle  # noqa: E402
from viscoforce.fitting import base as B  # noqa: E402
from viscoforce.fitting import guesses as G  # noqa: E402
from viscoforce.fitting import models as M  # noqa: E402
from viscoforce.fitting.curves import fit_step, trajectory_data  # noqa: E402
from viscoforce.fitting.fit import result_dataset  # noqa: E402
from viscoforce.fitting.model_error import validity_note  # noqa: E402
from viscoforce.fitting.moduli import add_derived_moduli  # noqa: E402
from viscoforce.fitting.outcome import fit_once  # noqa: E402
from viscoforce.fitting.verdict import warn_fit  # noqa: E402
from viscoforce.physics.materials import StandardLinearSolid  # noqa: E402
from viscoforce.physics.paper import paper_pressure_law  # noqa: E402
from viscoforce.physics.particle import Sphere  # noqa: E402
from viscoforce.problem import ContactProblem  # noqa: E402
from viscoforce.schema import make_trajectory  # noqa: E402
from viscoforce.solvers import simulate as S  # noqa: E402

JSON_KEYS = ("schema", "created", "quick", "machine", "target", "settings", "results", "summary",
             "files", "wall_time_s", "loadavg_end")
CASE_KEYS = ("old", "new", "speedup", "passed", "params", "truth")
PATH_KEYS = ("cpu_median_s", "cpu_s", "wall_median_s", "nfev", "simulations", "newton")
PARAM_KEYS = ("old", "new", "old_stderr", "new_stderr", "rel_diff", "diff_in_stderr",
              "stderr_rel_diff", "truth_rel_error_new")
NAMES = ("E0", "E_inf", "tau")
TARGET = 5.0
TRUTH = StandardLinearSolid(PAPER.E0, PAPER.E_inf, PAPER.tau)
WRONG = StandardLinearSolid(3e9, 5e8, 1e-4)
#: The case table: name, drive, deepest position [m], (t_end [s], samples), relative force noise,
#: description. Each is simulated with :data:`TRUTH` and fitted from the problem with :data:`WRONG`.
CASES = (
    {"name": "fig1_step", "drive": Step(-5e-9, -7e-9, 1e-4), "deepest": -7e-9,
     "times": (5e-3, 101), "noise": 0.0, "text": "Fig. 1 step -5 -> -7 nm in 0.1 ms, noise-free"},
    {"name": "triangle", "drive": Triangle(-3e-9, -7e-9, 4e-6), "deepest": -7e-9,
     "times": (4e-3, 101), "noise": 3e-3,
     "text": "triangle -3 -> -7 -> -3 nm at 4 um/s, 0.3 % noise"},
)
#: --quick: the step case on 11 samples over 1 ms (no triangle: the old path alone costs ~2 s a
#: fit even on 11 samples).
QUICK_CASES = ({**CASES[0], "times": (1e-3, 11)},)


# ── the old model, kept verbatim as the reference ────────────────────────────────────────────────

def old_step_model(problem: ContactProblem, position_trace) -> B.FitModel:
    """The ``step`` FitModel before issue 22: one ``simulate`` per evaluation, FD Jacobian."""
    trace_t, trace_h = (np.asarray(a, dtype=float) for a in position_trace)
    drive = MeasuredTrace(trace_t, trace_h)
    spec = B.ModelSpec("step", 1, M.check_fixed("step", {"problem": problem,
                                                         "position_trace": position_trace}))

    def function(t, v):
        run = S.simulate(problem.with_material(B.material_from(v, 1)), drive, t_end=float(t[-1]),
                         t_eval=np.asarray(t, dtype=float), output_kinks=False, progress=False)
        return run["force"].values

    def guesser(f, t):
        from viscoforce.solvers.static import equilibrium_gap

        f = np.asarray(f, dtype=float)
        i_peak = int(np.argmax(np.abs(f - f[0])))
        end = float(np.interp(t[-1], trace_t, trace_h))
        peak_position = float(np.interp(t[i_peak], trace_t, trace_h))

        def load(position):
            return lambda e: abs(float(problem.load(problem.pressure(
                equilibrium_gap(problem, position, e).gap))))

        e_inf = G.solve_modulus(load(end), max(abs(float(f[-1])), 1e-15), 1e9)
        e0 = G.solve_modulus(load(peak_position), max(abs(float(f[i_peak])), 1e-15), 2 * e_inf)
        tail = np.abs(f[i_peak:] - f[-1])
        below = np.flatnonzero(tail < tail[0] / math.e)
        tau = float(t[i_peak + below[0]] - t[i_peak]) if below.size else float(np.ptp(t)) / 5
        return {"E_inf": e_inf, "E0": max(e0, 1.05 * e_inf), "tau": max(tau, 1e-9)}

    return B.FitModel(spec, function, B.material_layout(1), "t", guesser, G.time_window)


def old_fit_step(trajectory, *, problem):
    """``fit_step`` before issue 22 (``fit_data(data, "step", ...)`` with the old model)."""
    data, trace = trajectory_data(trajectory)
    outcome = fit_once(old_step_model(problem, trace), data)
    ds = result_dataset(outcome, data, profile=False)
    ds.attrs["validity"] = validity_note("step", ds)
    warn_fit(ds)
    return add_derived_moduli(ds, None)


# ── cases ────────────────────────────────────────────────────────────────────────────────────────

def cases(quick: bool) -> dict:
    """Name → (trajectory, problem with the wrong material, description) of each case."""
    law = paper_pressure_law(PAPER.P, PAPER.debye_length, PAPER.Pw, PAPER.z0)
    out = {}
    rng = np.random.default_rng(20260122)
    for case in QUICK_CASES if quick else CASES:
        name, drive, deepest, (t_end, samples), noise, text = (
            case[k] for k in ("name", "drive", "deepest", "times", "noise", "text"))
        problem = ContactProblem.create(sphere=Sphere(PAPER.R), surface_force=law,
                                        material=TRUTH, deepest_position=deepest)
        t = np.linspace(0.0, t_end, samples)
        run = S.simulate(problem, drive, t_end=t_end, t_eval=t, output_kinks=False,
                         progress=False)
        force = run["force"].values
        if noise:
            force = force * (1.0 + noise * rng.standard_normal(force.shape))
        data = make_trajectory(t, position=run["position"].values, force=force,
                               u_center=run["u_center"].values, h_center=run["h_center"].values,
                               contact_radius=run["contact_radius"].values,
                               contact_threshold=run.attrs["contact_threshold"],
                               attrs=dict(run.attrs))
        out[name] = (data, problem.with_material(WRONG),
                     f"{text}; {samples} samples over {t_end * 1e3:g} ms")
    return out


def counted(fn):
    """Run ``fn`` counting simulations and Newton iterations (simulate and simulate_force)."""
    counts = {"simulations": 0, "newton": 0}
    originals = (S.simulate, S.simulate_force)

    def sim(*a, **k):
        ds = originals[0](*a, **k)
        counts["simulations"] += 1
        counts["newton"] += int(ds.attrs["newton_iterations"])
        return ds

    def sim_force(*a, **k):
        run = originals[1](*a, **k)
        counts["simulations"] += 1
        counts["newton"] += int(run.newton)
        return run

    S.simulate, S.simulate_force = sim, sim_force
    try:
        return fn(), counts
    finally:
        S.simulate, S.simulate_force = originals


def time_fit(fn) -> tuple[object, float, float]:
    """(result, CPU [s], wall [s]) of one fit, garbage collector paused."""
    with gc_paused():
        c0, t0 = time.process_time(), time.perf_counter()
        out = fn()
        t1, c1 = time.perf_counter(), time.process_time()
    return out, c1 - c0, t1 - t0


def compare(old, new) -> dict:
    """Parameter and stderr differences new − old (relative and in units of the old stderr)."""
    out = {}
    for n in NAMES:
        vo, vn = float(old[n]), float(new[n])
        so, sn = float(old[f"{n}_stderr"]), float(new[f"{n}_stderr"])
        truth = {"E0": TRUTH.E0, "E_inf": TRUTH.E_inf, "tau": TRUTH.tau}[n]
        out[n] = {"old": vo, "new": vn, "old_stderr": so, "new_stderr": sn,
                  "rel_diff": (vn - vo) / vo, "diff_in_stderr": (vn - vo) / so if so > 0 else math.nan,
                  "stderr_rel_diff": (sn - so) / so if so > 0 else math.nan,
                  "truth_rel_error_new": (vn - truth) / truth}
    return out


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; return the exit status (0; the verdict is printed, not returned)."""
    args = parse_args(argv, doc=__doc__, quick_help="the step case only, 11 samples, one repeat (seconds)",
                      repeats_help="interleaved fits per path and case (default 3; --quick 1)")
    repeats = args.repeats or (1 if args.quick else 3)
    args.out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    with threadpool_limits(limits=1, user_api="blas"):
        machine = machine_facts()
        print_machine(machine)
        print(f"OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}, repeats = {repeats}, "
              f"quick = {args.quick}")
        rows, results = [], {}
        for name, (trajectory, problem, text) in cases(args.quick).items():
            print(f"\n{name}: {text}")
            paths = {"old": lambda tr=trajectory, pr=problem: old_fit_step(tr, problem=pr),
                     "new": lambda tr=trajectory, pr=problem: fit_step(tr, problem=pr)}
            cpu = {p: [] for p in paths}
            wall = {p: [] for p in paths}
            first, counts = {}, {}
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # fit-quality warnings of a noise-free fit
                for r in range(repeats):
                    for path, fn in paths.items():
                        (ds, count), c, w = time_fit(lambda fn=fn: counted(fn))
                        cpu[path].append(c)
                        wall[path].append(w)
                        first.setdefault(path, ds)
                        counts.setdefault(path, count)
                        rows.append({"case": name, "path": path, "repeat": r, "cpu_s": c,
                                     "wall_s": w, "nfev": int(ds.attrs["nfev"]), **count})
            per_path = {p: {"cpu_median_s": statistics.median(cpu[p]), "cpu_s": cpu[p],
                            "wall_median_s": statistics.median(wall[p]),
                            "nfev": int(first[p].attrs["nfev"]), **counts[p]} for p in paths}
            speedup = per_path["old"]["cpu_median_s"] / per_path["new"]["cpu_median_s"]
            params = compare(first["old"], first["new"])
            results[name] = {"old": per_path["old"], "new": per_path["new"], "speedup": speedup,
                             "passed": speedup >= TARGET, "params": params,
                             "truth": {"E0": TRUTH.E0, "E_inf": TRUTH.E_inf, "tau": TRUTH.tau}}
            for p in paths:
                q = per_path[p]
                print(f"  {p}: {q['cpu_median_s']:.3f} s CPU per fit (wall "
                      f"{q['wall_median_s']:.3f} s), nfev {q['nfev']}, {q['simulations']} "
                      f"simulations, {q['newton']} Newton iterations")
            for n, d in params.items():
                print(f"  {n:5s} old {d['old']:.10g} +- {d['old_stderr']:.3g}, new "
                      f"{d['new']:.10g} +- {d['new_stderr']:.3g}: diff {d['rel_diff']:+.2e} "
                      f"relative = {d['diff_in_stderr']:+.3f} stderr; stderr diff "
                      f"{d['stderr_rel_diff']:+.2e} relative")
            print(f"  speed-up old/new {speedup:.2f}x, target >= {TARGET:g}x: "
                  f"{pf(speedup >= TARGET)}")
        passed = all(r["passed"] for r in results.values())
        worst = min(r["speedup"] for r in results.values())
        print(f"\nstep fit speed-up (smallest over the cases) {worst:.2f}x, target >= "
              f"{TARGET:g}x: {pf(passed)}")
    files = {"json": "step.json", "csv": "step.csv", "png": "step.png"}
    write_csv(rows, args.out / files["csv"])
    _plot(results, args.out / files["png"])
    report = report_head("viscoforce.bench_step/1", args.quick, machine)
    report.update(target={"speedup": TARGET},
                  settings={"env": {"OPENBLAS_NUM_THREADS": os.environ["OPENBLAS_NUM_THREADS"]},
                            "repeats": repeats, "interleaved": True, "cases": list(results)},
                  results=results,
                  summary={"verdict": pf(passed), "passed": passed, "min_speedup": worst},
                  files=files, **run_end(t_start))
    write_json(report, args.out / files["json"])
    print(f"wrote {', '.join(str(args.out / f) for f in files.values())}")
    return 0


def _plot(results: dict, path: Path) -> None:
    fig, ax = plt.subplots(figsize=(6, 3.5))
    names = list(results)
    x = np.arange(len(names))
    for i, (p, color) in enumerate((("old", "tab:gray"), ("new", "tab:blue"))):
        ax.bar(x + (i - 0.5) * 0.38, [results[n][p]["cpu_median_s"] for n in names], 0.38,
               label=p, color=color)
    for j, n in enumerate(names):
        ax.annotate(f"{results[n]['speedup']:.1f}x", (x[j], results[n]["old"]["cpu_median_s"]),
                    ha="center", va="bottom")
    ax.set_xticks(x, names)
    ax.set_ylabel("CPU per fit [s]")
    ax.set_title(f"step fit: old (FD, simulate per evaluation) vs new; target >= {TARGET:g}x")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
