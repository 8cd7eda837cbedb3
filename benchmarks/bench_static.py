#!/usr/bin/env python
"""Static-solve benchmark: time per elastic equilibrium and its accuracy.

What it measures (see benchmarks/README.md, section ``bench_static.py``):

1. At the DEFAULT grid (``ContactProblem.create(..., deepest_position=h0)``) for E ∈ {1e9, 1e10} Pa
   and h0 ∈ {−10, −7, −5, −3, 0, 2, 5, 10} nm: the median time of the full public call
   ``static_equilibrium`` and of the bare Newton solve ``equilibrium_gap``; the Newton iterations;
   the grid size; the relative load error against a 4×-refined grid and against the independent FFT
   peer (``shared/data/reference/static_loads_fft_peer.csv``) where it has a row. The one-off kernel
   build (cached per panel count and order) is timed separately and is not part of a solve.
2. A speed–accuracy sweep over grid spacing (× the default node spacing) and Gauss order at the
   hardest case (h0 = −10 nm, E = 1e10 Pa) and a weak-contact case (h0 = 2 nm, E = 1e9 Pa), against
   a reference at spacing/8, order 8. Chart and data go to ``--out`` (default benchmarks/out/).
3. A final PASS/FAIL line against the target: ≤ 5 ms per static solve (the full public call) at
   ≤ 1e-4 relative load error (against the 4×-refined grid).

BLAS is pinned to one thread. Run ``python benchmarks/bench_static.py [--quick] [--out DIR]``.
"""

from __future__ import annotations

import csv
import math
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

import viscoforce as vf  # noqa: E402
from viscoforce.exceptions import ViscoforceError  # noqa: E402
from viscoforce.kernel import _node_matrix_unit  # noqa: E402
from viscoforce.solvers.static import equilibrium_gap  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/_common.py, from any cwd
from _common import (  # noqa: E402
    cold_build,
    fmt,
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

RADIUS = vf.PAPER.R  # sphere radius [m]
#: The case table. Part 1, ``default_grid``: the default grid at each position h0 [nm] for each
#: modulus E [Pa] (paper convention), timed in this order. Part 2, ``sweep``: at each (h0 [m],
#: E [Pa]) every grid spacing (``factors`` × the default node spacing) at every Gauss order.
CASES = (
    *({"part": "default_grid", "h0_nm": h0_nm, "E": modulus}
      for h0_nm in (-10.0, -7.0, -5.0, -3.0, 0.0, 2.0, 5.0, 10.0) for modulus in (1e9, 1e10)),
    {"part": "sweep", "h0": -10e-9, "E": 1e10, "factors": (4.0, 3.0, 2.0, 1.5, 1.0, 0.5),
     "orders": (4, 6, 8, 10)},
    {"part": "sweep", "h0": 2e-9, "E": 1e9, "factors": (4.0, 3.0, 2.0, 1.5, 1.0, 0.5),
     "orders": (4, 6, 8, 10)},
)
#: --quick: the same default grid; the sweep at spacing factors 2 and 1, orders 4 and 8.
QUICK_CASES = (*(c for c in CASES if c["part"] == "default_grid"),
               *({**c, "factors": (2.0, 1.0), "orders": (4, 8)} for c in CASES
                 if c["part"] == "sweep"))
REFINE = 4  # default-table reference: spacing / REFINE, same order
TARGET_TIME = 5e-3  # [s] per static solve
TARGET_ERROR = 1e-4  # relative load error
SWEEP_REF_DIVISOR = 8  # sweep reference: default spacing / 8 ...
SWEEP_REF_ORDER = 8  # ... at order 8
MIN_REPEAT_TIME = 1e-3  # [s]: calls per repeat are batched up to this (timeit autorange-like)
ERROR_FLOOR = 1e-16  # errors below this are drawn at this value (round-off level)
SCHEMA = "viscoforce.bench_static/1"
PEER_CSV = Path(__file__).resolve().parents[2] / "shared" / "data" / "reference" / \
    "static_loads_fft_peer.csv"
#: Top-level keys of static_benchmark.json (documented in benchmarks/README.md).
JSON_KEYS = ("schema", "created", "quick", "machine", "target", "settings", "build",
             "default_grid", "sweep", "summary", "files")


# ── helpers ──────────────────────────────────────────────────────────────────────────────────────

@dataclass
class Timed:
    """One timed callable: ``number`` calls per sample; wall and CPU time per call [s]."""

    fn: Callable[[], object]
    number: int
    wall: list[float] = field(default_factory=list)
    cpu: list[float] = field(default_factory=list)

    @classmethod
    def prepare(cls, fn: Callable[[], object], warmup: int) -> Timed:
        """Warm up, then batch calls so that a sample lasts at least ``MIN_REPEAT_TIME``."""
        for _ in range(warmup):
            fn()
        t0 = time.perf_counter()
        fn()
        single = time.perf_counter() - t0
        return cls(fn, max(1, math.ceil(MIN_REPEAT_TIME / max(single, 1e-9))))

    def sample(self) -> None:
        fn, number = self.fn, self.number
        c0, t0 = time.process_time(), time.perf_counter()
        for _ in range(number):
            fn()
        t1, c1 = time.perf_counter(), time.process_time()
        self.wall.append((t1 - t0) / number)
        self.cpu.append((c1 - c0) / number)

    def stats(self) -> dict[str, float]:
        return {"median_s": statistics.median(self.wall), "min_s": min(self.wall),
                "cpu_median_s": statistics.median(self.cpu), "calls_per_sample": self.number,
                "samples": len(self.wall)}


def run_rounds(timers: list[Timed], repeats: int) -> None:
    """``repeats`` rounds, each taking one sample of every timer (timeit-style: gc off).

    Interleaving spreads each timer's samples over the whole run, so a burst of load from another
    process on this small machine spoils one sample of many timers, not many samples of one.
    """
    with gc_paused():
        for _ in range(repeats):
            for timer in timers:
                timer.sample()


def make_problem(h0: float, modulus: float, *, grid_spacing: float | None = None,
                 order: int = 8) -> vf.ContactProblem:
    return vf.ContactProblem.create(sphere=vf.Sphere(RADIUS), surface_force=vf.paper_pressure_law(),
                                    material=vf.Elastic(modulus), deepest_position=h0,
                                    grid_spacing=grid_spacing, order=order)


def part(cases: tuple[dict, ...], name: str) -> list[dict]:
    """The rows of ``cases`` (:data:`CASES` or :data:`QUICK_CASES`) of one part."""
    return [c for c in cases if c["part"] == name]


def rel_err(value: float, reference: float) -> float:
    return abs(value - reference) / abs(reference)


def load_peer(path: Path) -> dict[tuple[float, int], float]:
    """FFT-peer loads keyed by (E [Pa], h0 [pm, rounded]); empty if the file is absent."""
    if not path.is_file():
        return {}
    out = {}
    with path.open(newline="") as fh:
        for row in csv.DictReader(fh):
            key = (float(row["E (Pa)"]), round(float(row["h0 (m)"]) * 1e12))
            out[key] = float(row["force (N)"])
    return out


# ── part 1: default grid ─────────────────────────────────────────────────────────────────────────

def bench_default(cases: list[dict], repeats: int, warmup: int,
                  peer: dict) -> tuple[list[dict], list[dict]]:
    builds, rows, timers = [], [], []
    positions: dict[float, list[float]] = {}  # h0 [nm] → its moduli, in the table's order
    for case in cases:
        positions.setdefault(case["h0_nm"], []).append(case["E"])
    for h0_nm, moduli in positions.items():
        h0 = h0_nm * 1e-9
        cold = make_problem(h0, moduli[0])
        build_s = cold_build(cold)
        _node_matrix_unit.cache_clear()
        cold = make_problem(h0, moduli[0])
        t0 = time.perf_counter()
        vf.static_equilibrium(cold, h0)
        first_call_s = time.perf_counter() - t0
        ref_spacing = cold.grid.spacing / REFINE
        ref_grid = make_problem(h0, moduli[0], grid_spacing=ref_spacing).grid
        builds.append({"h0": h0, "n_panels": cold.grid.n_panels, "order": cold.grid.order,
                       "nodes": cold.grid.size, "build_s": build_s,
                       "first_call_s": first_call_s, "refined_nodes": ref_grid.size})
        for modulus in moduli:
            problem = make_problem(h0, modulus)
            ds = vf.static_equilibrium(problem, h0)
            force = float(ds.force)
            ref = make_problem(h0, modulus, grid_spacing=ref_spacing)
            force_ref = float(vf.static_equilibrium(ref, h0).force)
            force_peer = peer.get((modulus, round(h0 * 1e12)), math.nan)
            rows.append({
                "E": modulus, "h0": h0, "nodes": problem.grid.size,
                "n_panels": problem.grid.n_panels, "order": problem.grid.order,
                "spacing": problem.grid.spacing, "outer_radius": problem.grid.outer_radius,
                "newton_iterations": int(ds.attrs["newton_iterations"]),
                "force": force, "refined_nodes": ref.grid.size, "force_refined": force_ref,
                "rel_error_refined": rel_err(force, force_ref),
                "force_peer": force_peer,
                "rel_error_peer": (rel_err(force, force_peer) if math.isfinite(force_peer)
                                   else math.nan),
            })
            timers.append((
                Timed.prepare(lambda p=problem, x=h0: vf.static_equilibrium(p, x), warmup),
                Timed.prepare(lambda p=problem, x=h0, e=modulus: equilibrium_gap(p, x, e),
                              warmup)))
    # every kernel any timed problem needs is cached now; time all cases in interleaved rounds
    run_rounds([t for pair in timers for t in pair], repeats)
    for row, (pub, newton) in zip(rows, timers, strict=True):
        sp, sn = pub.stats(), newton.stats()
        row.update({"time_public_s": sp["median_s"], "time_public_min_s": sp["min_s"],
                    "time_public_cpu_s": sp["cpu_median_s"],
                    "time_newton_s": sn["median_s"], "time_newton_min_s": sn["min_s"],
                    "time_newton_cpu_s": sn["cpu_median_s"],
                    "calls_per_sample_public": sp["calls_per_sample"],
                    "calls_per_sample_newton": sn["calls_per_sample"],
                    "samples": sp["samples"]})
    return builds, rows


# ── part 2: speed–accuracy sweep ─────────────────────────────────────────────────────────────────

def bench_sweep(cases: list[dict], repeats: int, warmup: int) -> list[dict]:
    rows = []
    for case in cases:
        h0, modulus = case["h0"], case["E"]
        base = make_problem(h0, modulus).grid.spacing  # default node spacing (order 8) [m]
        ref = make_problem(h0, modulus, grid_spacing=base / SWEEP_REF_DIVISOR,
                           order=SWEEP_REF_ORDER)
        force_ref = float(vf.static_equilibrium(ref, h0).force)
        case_rows, timers = [], []
        for order in case["orders"]:
            for factor in case["factors"]:
                problem = make_problem(h0, modulus, grid_spacing=base * factor, order=order)
                row = {"case": f"h0={h0 * 1e9:g}nm,E={modulus:g}Pa", "E": modulus, "h0": h0,
                       "order": order, "spacing_factor": factor,
                       "spacing": problem.grid.spacing, "nodes": problem.grid.size,
                       "n_panels": problem.grid.n_panels, "reference_nodes": ref.grid.size,
                       "force_reference": force_ref,
                       "is_default": bool(order == 8 and factor == 1.0)}
                try:
                    row["build_s"] = cold_build(problem)
                    ds = vf.static_equilibrium(problem, h0)
                    force = float(ds.force)
                    row.update({"status": "ok",
                                "newton_iterations": int(ds.attrs["newton_iterations"]),
                                "force": force, "rel_error": rel_err(force, force_ref)})
                    timers.append((
                        row,
                        Timed.prepare(lambda p=problem, x=h0: vf.static_equilibrium(p, x),
                                      warmup),
                        Timed.prepare(lambda p=problem, x=h0, e=modulus: equilibrium_gap(p, x, e),
                                      warmup)))
                except ViscoforceError as exc:  # a failed point is data, not a crash
                    row.update({"status": f"failed: {type(exc).__name__}: {exc}",
                                "newton_iterations": math.nan, "time_public_s": math.nan,
                                "time_newton_s": math.nan, "force": math.nan,
                                "rel_error": math.nan})
                case_rows.append(row)
        run_rounds([t for _, pub, newton in timers for t in (pub, newton)], repeats)
        for row, pub, newton in timers:
            row.update({"time_public_s": pub.stats()["median_s"],
                        "time_newton_s": newton.stats()["median_s"]})
        rows.extend(case_rows)
    return rows


def plot_sweep(rows: list[dict], path: Path) -> None:
    cases = list(dict.fromkeys((r["h0"], r["E"]) for r in rows))
    orders = sorted({r["order"] for r in rows})
    colours = dict(zip(orders, plt.cm.viridis(np.linspace(0.0, 0.85, len(orders))), strict=True))
    fig, axes = plt.subplots(1, len(cases), figsize=(6.0 * len(cases), 5.6), squeeze=False)
    for ax, (h0, modulus) in zip(axes[0], cases, strict=True):
        sub = [r for r in rows if (r["h0"], r["E"]) == (h0, modulus) and r["status"] == "ok"]
        for order in orders:
            pts = sorted((r for r in sub if r["order"] == order), key=lambda r: r["nodes"])
            if not pts:
                continue
            t_pub = [1e3 * r["time_public_s"] for r in pts]
            t_new = [1e3 * r["time_newton_s"] for r in pts]
            err = [max(r["rel_error"], ERROR_FLOOR) for r in pts]
            ax.plot(t_pub, err, "o-", color=colours[order], label=f"order {order}")
            ax.plot(t_new, err, ".--", color=colours[order], alpha=0.45, lw=1)
            if order == 8:
                for r, x, y in zip(pts, t_pub, err, strict=True):
                    ax.annotate(f"×{r['spacing_factor']:g}", (x, y), textcoords="offset points",
                                xytext=(5, -3), fontsize=7, color=colours[order])
        for r in sub:
            if r["is_default"]:
                ax.plot(1e3 * r["time_public_s"], max(r["rel_error"], ERROR_FLOOR), "*",
                        ms=18, mfc="none", mec="crimson", mew=2, zorder=5,
                        label="default grid (order 8, ×1)")
        errs = [max(r["rel_error"], ERROR_FLOOR) for r in sub] or [TARGET_ERROR]
        times = [1e3 * r["time_newton_s"] for r in sub] or [1e3 * TARGET_TIME]
        xlim = (0.7 * min(times), 2e3 * TARGET_TIME)
        ylim = (0.2 * min(errs), max(30 * TARGET_ERROR, 3 * max(errs)))
        ax.fill_between([xlim[0], 1e3 * TARGET_TIME], ylim[0], TARGET_ERROR, color="tab:green",
                        alpha=0.15, lw=0, label="target: ≤ 5 ms per solve, ≤ 1e-4 error")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(xlim)
        ax.set_ylim(ylim)
        ax.plot([], [], "k-", label="time of static_equilibrium (full public call)")
        ax.plot([], [], "k--", alpha=0.45, lw=1, label="time of equilibrium_gap (bare Newton)")
        ax.set_xlabel("time per static solve [ms] (median, 1 BLAS thread)")
        ax.set_ylabel("relative load error |F − F_ref| / F_ref [–]")
        ax.set_title(f"h0 = {h0 * 1e9:g} nm, E = {modulus:.0e} Pa", fontsize=11)
        ax.grid(True, which="major", alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle("viscoforce static solve: speed vs accuracy over grid spacing and Gauss order\n"
                 f"(reference: spacing/{SWEEP_REF_DIVISOR}, order {SWEEP_REF_ORDER}; labels on "
                 "the order-8 line: node spacing × default)", fontsize=11)
    fig.tight_layout(rect=(0, 0.1, 1, 1))
    fig.savefig(path, dpi=130)
    plt.close(fig)


# ── reporting ────────────────────────────────────────────────────────────────────────────────────

def print_default(builds: list[dict], rows: list[dict]) -> None:
    print("\nOne-off kernel build per default grid (cached per (n_panels, order); not in a solve):")
    print(f"{'h0 [nm]':>8} {'panels':>6} {'nodes':>5} {'build [ms]':>10} {'1st call [ms]':>13}")
    for b in builds:
        print(f"{b['h0'] * 1e9:8.0f} {b['n_panels']:6d} {b['nodes']:5d} {1e3 * b['build_s']:10.1f} "
              f"{1e3 * b['first_call_s']:13.1f}")
    print("\nDefault grid (median wall time per solve; public = static_equilibrium, (cpu) = its "
          "process CPU time, newton = equilibrium_gap;\n relative load error vs the "
          f"{REFINE}x-refined grid and vs the FFT peer):")
    head = (f"{'E [Pa]':>7} {'h0 [nm]':>7} {'nodes':>5} {'iters':>5} {'public [ms]':>11} "
            f"{'(cpu) [ms]':>10} {'newton [ms]':>11} {'force [N]':>12} {'err refined':>11} "
            f"{'err peer':>9}")
    print(head)
    print("-" * len(head))
    for r in rows:
        print(f"{r['E']:7.0e} {r['h0'] * 1e9:7.0f} {r['nodes']:5d} {r['newton_iterations']:5d} "
              f"{1e3 * r['time_public_s']:11.3f} {1e3 * r['time_public_cpu_s']:10.3f} "
              f"{1e3 * r['time_newton_s']:11.3f} "
              f"{r['force']:12.5e} {fmt(r['rel_error_refined']):>11} "
              f"{fmt(r['rel_error_peer']):>9}")


def print_sweep(rows: list[dict]) -> None:
    print(f"\nSpeed–accuracy sweep (ref: spacing/{SWEEP_REF_DIVISOR}, order {SWEEP_REF_ORDER}):")
    head = (f"{'case':>22} {'order':>5} {'x dflt':>6} {'nodes':>5} {'iters':>5} "
            f"{'public [ms]':>11} {'newton [ms]':>11} {'rel error':>9}")
    print(head)
    print("-" * len(head))
    for r in rows:
        if r["status"] != "ok":
            print(f"{r['case']:>22} {r['order']:5d} {r['spacing_factor']:6g} {r['nodes']:5d} "
                  f"{r['status']}")
            continue
        print(f"{r['case']:>22} {r['order']:5d} {r['spacing_factor']:6g} {r['nodes']:5d} "
              f"{r['newton_iterations']:5d} {1e3 * r['time_public_s']:11.3f} "
              f"{1e3 * r['time_newton_s']:11.3f} {fmt(r['rel_error'])}")


def summarise(rows: list[dict]) -> dict:
    peer = [r["rel_error_peer"] for r in rows if math.isfinite(r["rel_error_peer"])]
    worst_t = max(r["time_public_s"] for r in rows)
    worst_e = max(r["rel_error_refined"] for r in rows)
    ok = worst_t <= TARGET_TIME and worst_e <= TARGET_ERROR
    return {"worst_time_public_s": worst_t,
            "worst_time_newton_s": max(r["time_newton_s"] for r in rows),
            "worst_time_public_cpu_s": max(r["time_public_cpu_s"] for r in rows),
            "worst_rel_error_refined": worst_e,
            "worst_rel_error_peer": max(peer) if peer else math.nan,
            "n_peer_rows": len(peer), "passed": ok, "verdict": pf(ok)}


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__,
                      quick_help="few-second smoke run: fewer repeats and sweep points",
                      repeats_help="timed samples per default-grid measurement (default 50; 5 "
                                   "with --quick); the sweep takes 20 (5 with --quick)")
    repeats = args.repeats or (5 if args.quick else 50)
    sweep_repeats = min(repeats, 5 if args.quick else 20)
    warmup = 1 if args.quick else 3
    cases = QUICK_CASES if args.quick else CASES
    default_cases, sweep_cases = part(cases, "default_grid"), part(cases, "sweep")
    args.out.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()

    with threadpool_limits(limits=1):
        machine = machine_facts(cpu_model_name=False)
        print(f"viscoforce {machine['viscoforce']} static-solve benchmark"
              f"{' (quick)' if args.quick else ''}")
        print_machine(machine)
        print(f"timing: median of {repeats} samples (default grid, interleaved rounds; sweep "
              f"{sweep_repeats}) after {warmup} warm-up call(s), gc off, time.perf_counter; "
              f"load average {machine['loadavg_start']}")
        # process warm-up: lazy imports and first-call costs outside every timed region
        vf.static_equilibrium(make_problem(10e-9, default_cases[0]["E"]), 10e-9)
        peer = load_peer(PEER_CSV)
        if not peer:
            print(f"FFT peer file not found ({PEER_CSV}): peer comparison skipped")

        builds, default_rows = bench_default(default_cases, repeats, warmup, peer)
        print_default(builds, default_rows)
        sweep_rows = bench_sweep(sweep_cases, sweep_repeats, warmup)
        print_sweep(sweep_rows)

    png = args.out / "static_speed_accuracy.png"
    sweep_csv = args.out / "static_speed_accuracy.csv"
    json_path = args.out / "static_benchmark.json"
    plot_sweep(sweep_rows, png)
    write_csv(sweep_rows, sweep_csv)
    summary = summarise(default_rows)
    summary.update(run_end(t_start))
    report = {
        **report_head(SCHEMA, args.quick, machine),
        "target": {"time_per_solve_s": TARGET_TIME, "relative_error": TARGET_ERROR,
                   "time_measured_on": "static_equilibrium (full public call)",
                   "error_measured_against": f"same position, grid spacing / {REFINE}"},
        "settings": {"radius": RADIUS, "moduli": list(dict.fromkeys(c["E"] for c in default_cases)),
                     "positions": [x * 1e-9 for x in dict.fromkeys(c["h0_nm"]
                                                                   for c in default_cases)],
                     "repeats": repeats,
                     "sweep_repeats": sweep_repeats, "warmup": warmup, "refine": REFINE,
                     "sweep_factors": list(sweep_cases[0]["factors"]),
                     "sweep_orders": list(sweep_cases[0]["orders"]),
                     "sweep_cases": [{"h0": c["h0"], "E": c["E"]} for c in sweep_cases],
                     "sweep_reference": {"spacing_divisor": SWEEP_REF_DIVISOR,
                                         "order": SWEEP_REF_ORDER},
                     "peer_csv": str(PEER_CSV) if peer else None},
        "build": builds,
        "default_grid": default_rows,
        "sweep": sweep_rows,
        "summary": summary,
        "files": {"png": str(png), "sweep_csv": str(sweep_csv), "json": str(json_path)},
    }
    write_json(report, json_path)
    print(f"\nwrote {json_path}, {sweep_csv}, {png}")
    peer_txt = (f"; worst deviation from FFT peer {summary['worst_rel_error_peer']:.2e} "
                f"({summary['n_peer_rows']} rows)" if summary["n_peer_rows"] else "")
    print(f"SUMMARY: default grid, {len(default_rows)} solves: worst time per solve "
          f"{1e3 * summary['worst_time_public_s']:.2f} ms (static_equilibrium; bare Newton "
          f"{1e3 * summary['worst_time_newton_s']:.2f} ms), worst error vs {REFINE}x-refined grid "
          f"{summary['worst_rel_error_refined']:.2e}{peer_txt} -> {summary['verdict']} "
          f"(target <= {1e3 * TARGET_TIME:g} ms at <= {TARGET_ERROR:g}); "
          f"wall {summary['wall_time_s']:.1f} s")
    if not summary["passed"] and summary["worst_rel_error_refined"] <= TARGET_ERROR \
            and summary["worst_time_public_cpu_s"] <= TARGET_TIME:
        print(f"NOTE: the CPU-time medians pass ({1e3 * summary['worst_time_public_cpu_s']:.2f} ms "
              f"worst); the wall-time FAIL may be load from other processes (load average "
              f"{summary['loadavg_end']}): rerun on a quiet machine")
    return 0


if __name__ == "__main__":
    sys.exit(main())
