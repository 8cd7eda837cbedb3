#!/usr/bin/env python
"""Linear-response benchmark: the modal LinearizedState against one complex solve per frequency.

What it measures, for h̄0 = 2 nm (paper Fig. 3, before contact) and −5 nm (Fig. 4, in contact)
on the default grid (``ContactProblem.create(..., deepest_position=h̄0)``), the paper's SLS and
pressure law, one 30-frequency evaluation (ω log-spaced in [1, 1e6] rad/s):

- ``direct``: the former implementation of ``linear_stiffness`` (static E_inf solve, then one
  batched dense complex solve (I + cM) δu = cM·1 per frequency), kept here as the reference;
- ``build``: ``LinearizedState.at(problem, h̄0)`` (static solve + eigen-decomposition) followed by
  ``stiffness_for`` (what an evaluation costs when E_inf or h̄0 changes);
- ``build_at_load``: ``LinearizedState.at_load`` at the state's mean force (bracketed position
  search + decomposition: the cost when a fit holds the mean force fixed);
- ``cached``: ``state.stiffness_for(material, omega)`` on a built state (what an evaluation costs
  when only τ or E0 change);
- ``public_cached``: ``linear_stiffness(problem, h̄0, omega)`` with the cache warm (argument checks,
  cache look-up, modal sum).

Each time is the median over ``--repeats`` samples (gc off; cheap calls batched to ≥ 2 ms per
sample, the per-call time reported), BLAS pinned to one thread with threadpoolctl. Accuracy: max
over ω of |k* − k*_direct| / |k*_direct| for every modal path. The summary gives the speed-ups over
``direct`` and the number of evaluations of each kind that fit in the 0.3 s budget of an exact
one-mode fit of 30 points (issue 13).

Outputs (in ``--out``, default benchmarks/out/): ``linear_benchmark.json`` (SI units; keys in
:data:`JSON_KEYS`), ``linear_timings.csv`` (one row per (position, path)) and
``linear_timings.png`` (bar chart, log time axis). Run
``python benchmarks/bench_linear.py [--quick] [--repeats N] [--out DIR]``; no test asserts the
times (tests/benchmarks/test_solvers.py runs ``--quick`` and checks the keys and the accuracy).
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

import viscoforce as vf  # noqa: E402
from viscoforce.experiments.linear_response import (  # noqa: E402
    LinearizedState,
    linear_stiffness,
    linearized_state,
)
from viscoforce.solvers.static import equilibrium_gap  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/_common.py, from any cwd
from _common import (  # noqa: E402
    gc_paused,
    machine_facts,
    parse_args,
    print_machine,
    report_head,
    run_end,
    write_csv,
    write_json,
)

SCHEMA = "viscoforce.bench_linear/1"
#: Top-level keys of linear_benchmark.json.
JSON_KEYS = ("schema", "created", "quick", "machine", "target", "settings", "rows", "summary",
             "files")
#: The case table: one row per scene, its mean position h̄0 [m]; every path of :data:`PATHS` is
#: timed at each (--quick times the same cases with fewer samples).
CASES = ({"scene": "Fig. 3", "h0": 2e-9}, {"scene": "Fig. 4", "h0": -5e-9})
POSITIONS = {c["scene"]: c["h0"] for c in CASES}  # scene → h̄0 [m]
N_OMEGA, OMEGA_MIN, OMEGA_MAX = 30, 1.0, 1e6  # [rad/s]
PATHS = ("direct", "build", "build_at_load", "cached", "public_cached")
FIT_BUDGET = 0.3  # [s]: an exact one-mode fit of 30 points (issue 13)
DEFAULT_REPEATS, QUICK_REPEATS = 50, 5
MIN_SAMPLE = 2e-3  # [s]: cheap calls are batched to at least this per timed sample
BATCH_ELEMENTS = 4_000_000  # as the former implementation


def direct_stiffness(problem: vf.ContactProblem, position: float,
                     omega: np.ndarray) -> np.ndarray:
    """The former ``linear_stiffness``: static solve, one batched complex solve per frequency."""
    material = problem.material
    sol = equilibrium_gap(problem, position, material.relaxed_modulus)
    stiff = -problem.surface_force.pressure_derivative(sol.gap)
    weights = 2.0 * np.pi * problem.grid.area_weights * stiff
    coupled = problem.influence * stiff[None, :]
    n = problem.grid.size
    compliance = 2.0 * np.asarray(material.complex_compliance(omega), dtype=complex)
    drive = coupled.sum(axis=1)
    k = np.empty(omega.size, dtype=complex)
    chunk = max(1, BATCH_ELEMENTS // (n * n))
    diag = np.arange(n)
    for start in range(0, omega.size, chunk):
        c = compliance[start:start + chunk]
        mats = c[:, None, None] * coupled[None, :, :]
        mats[:, diag, diag] += 1.0
        du = np.linalg.solve(mats, (c[:, None] * drive[None, :])[..., None])[..., 0]
        k[start:start + chunk] = (weights[None, :] * (1.0 - du)).sum(axis=1)
    return k


def time_call(fn, repeats: int) -> tuple[object, dict]:
    """Median and minimum time per call [s] of ``fn`` over ``repeats`` samples (gc off).

    Each sample runs ``fn`` ``calls`` times, ``calls`` chosen from a first call so that one
    sample takes at least ``MIN_SAMPLE``; two warm-up calls come first.
    """
    result = fn()
    fn()
    t0 = time.perf_counter()
    fn()
    calls = max(1, math.ceil(MIN_SAMPLE / max(time.perf_counter() - t0, 1e-9)))
    samples = []
    with gc_paused():
        for _ in range(repeats):
            t0 = time.perf_counter()
            for _ in range(calls):
                fn()
            samples.append((time.perf_counter() - t0) / calls)
    return result, {"time_median_s": statistics.median(samples), "time_min_s": min(samples),
                    "calls_per_sample": calls, "samples": repeats}


def bench_position(scene: str, position: float, omega: np.ndarray, repeats: int) -> list[dict]:
    """Time every path of :data:`PATHS` at one position; rows with the error against direct."""
    material = vf.PAPER.material()
    problem = vf.ContactProblem.create(sphere=vf.PAPER.sphere(),
                                       surface_force=vf.paper_pressure_law(),
                                       material=material, deepest_position=position)
    _ = problem.influence  # kernel built once, outside the timings
    state = LinearizedState.at(problem, position)
    linearized_state.cache_clear()
    linear_stiffness(problem, position, omega)  # warm the cache for public_cached
    runs = {
        "direct": lambda: direct_stiffness(problem, position, omega),
        "build": lambda: LinearizedState.at(problem, position).stiffness_for(material, omega),
        "build_at_load": lambda: LinearizedState.at_load(
            problem, state.mean_force).stiffness_for(material, omega),
        "cached": lambda: state.stiffness_for(material, omega),
        "public_cached": lambda: linear_stiffness(problem, position, omega)[0],
    }
    rows, ref = [], None
    for path in PATHS:
        k, stats = time_call(runs[path], repeats)
        if path == "direct":
            ref = k
        err = float(np.max(np.abs(k - ref) / np.abs(ref)))
        rows.append({"scene": scene, "h0": position, "path": path, "nodes": problem.grid.size,
                     "modes": state.modes, "n_omega": int(omega.size),
                     "mean_force": state.mean_force, **stats, "max_rel_error": err})
    direct = rows[0]["time_median_s"]
    for r in rows:
        r["speedup"] = direct / r["time_median_s"]
        r["calls_in_fit_budget"] = int(FIT_BUDGET // r["time_median_s"])
    return rows


def plot(rows: list[dict], path: Path) -> None:
    fig, ax = plt.subplots(figsize=(9.0, 5.0))
    width = 0.8 / len(POSITIONS)
    x = np.arange(len(PATHS))
    for i, (scene, colour) in enumerate(zip(POSITIONS, ("tab:blue", "tab:red"), strict=True)):
        pts = {r["path"]: r for r in rows if r["scene"] == scene}
        heights = [1e3 * pts[p]["time_median_s"] for p in PATHS]
        bars = ax.bar(x + (i - 0.5) * width, heights, width, color=colour,
                      label=f"{scene}: h̄0 = {POSITIONS[scene] * 1e9:g} nm "
                            f"({pts['direct']['nodes']} nodes)")
        for bar, p in zip(bars, PATHS, strict=True):
            ax.annotate(f"×{pts[p]['speedup']:.3g}\n{pts[p]['max_rel_error']:.0e}",
                        (bar.get_x() + bar.get_width() / 2, bar.get_height()),
                        textcoords="offset points", xytext=(0, 2), ha="center", fontsize=7)
    ax.axhline(1e3 * FIT_BUDGET / 100, color="grey", ls="--", lw=1,
               label=f"{FIT_BUDGET:g} s fit budget / 100 evaluations")
    ax.set(yscale="log", xticks=x, xticklabels=PATHS,
           ylabel=f"time per {N_OMEGA}-ω evaluation [ms]\n(median, 1 BLAS thread)",
           title="exact small-amplitude response: direct solve vs modal LinearizedState\n"
                 "labels: speed-up over direct; max relative difference from direct")
    ax.title.set_fontsize(10)
    ax.grid(True, axis="y", which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__,
                      quick_help=f"smoke run (a few seconds): {QUICK_REPEATS} samples per path",
                      repeats_help=f"timed samples per path and position (default "
                                   f"{DEFAULT_REPEATS}, {QUICK_REPEATS} with --quick)")
    repeats = args.repeats or (QUICK_REPEATS if args.quick else DEFAULT_REPEATS)
    args.out.mkdir(parents=True, exist_ok=True)
    omega = np.logspace(np.log10(OMEGA_MIN), np.log10(OMEGA_MAX), N_OMEGA)
    t_start = time.perf_counter()
    with threadpool_limits(limits=1):
        machine = machine_facts()
        print(f"viscoforce {machine['viscoforce']} linear-response benchmark"
              f"{' (quick)' if args.quick else ''}")
        print_machine(machine)
        print(f"{N_OMEGA} omega log-spaced in [{OMEGA_MIN:g}, {OMEGA_MAX:g}] rad/s, paper SLS; "
              f"median of {repeats} samples per path; load average {machine['loadavg_start']}")
        head = (f"{'scene':7} {'h0 [nm]':>7} {'nodes':>5} {'path':>14} {'time [ms]':>10} "
                f"{'min [ms]':>9} {'speed-up':>9} {'max rel err':>11} {'per 0.3 s':>9}")
        print(head)
        print("-" * len(head))
        rows = []
        for case in CASES:
            scene, position = case["scene"], case["h0"]
            for r in bench_position(scene, position, omega, repeats):
                rows.append(r)
                print(f"{scene:7} {position * 1e9:7g} {r['nodes']:5d} {r['path']:>14} "
                      f"{1e3 * r['time_median_s']:10.4f} {1e3 * r['time_min_s']:9.4f} "
                      f"{r['speedup']:9.3g} {r['max_rel_error']:11.1e} "
                      f"{r['calls_in_fit_budget']:9d}")
    worst_error = max(r["max_rel_error"] for r in rows)
    summary = {
        "speedup_build": min(r["speedup"] for r in rows if r["path"] == "build"),
        "speedup_cached": min(r["speedup"] for r in rows if r["path"] == "cached"),
        "worst_time_build_s": max(r["time_median_s"] for r in rows if r["path"] == "build"),
        "worst_time_cached_s": max(r["time_median_s"] for r in rows if r["path"] == "cached"),
        "worst_rel_error": worst_error,
        "accurate": worst_error <= 1e-10,
        **run_end(t_start),
    }
    print(f"speed-up over direct (worst position): build {summary['speedup_build']:.3g}x, cached "
          f"{summary['speedup_cached']:.3g}x; worst difference from direct {worst_error:.1e} "
          f"(<= 1e-10: {'yes' if summary['accurate'] else 'NO'})")
    files = {"png": args.out / "linear_timings.png", "csv": args.out / "linear_timings.csv",
             "json": args.out / "linear_benchmark.json"}
    plot(rows, files["png"])
    write_csv(rows, files["csv"])
    report = report_head(SCHEMA, args.quick, machine)
    report.update({
        "target": {"fit_budget_s": FIT_BUDGET, "fit": "exact one-mode fit of 30 points",
                   "rel_error": 1e-10},
        "settings": {"positions": POSITIONS, "n_omega": N_OMEGA, "omega_min": OMEGA_MIN,
                     "omega_max": OMEGA_MAX, "repeats": repeats, "min_sample_s": MIN_SAMPLE,
                     "paths": list(PATHS), "material": vf.PAPER.material().parameters()},
        "rows": rows, "summary": summary, "files": {k: str(v) for k, v in files.items()}})
    write_json(report, files["json"])
    print(f"wrote {files['png']}, {files['csv']}, {files['json']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
