#!/usr/bin/env python
"""Regression benchmark (issue 22 item 1): current tree vs the previous release vs a reference.

One run, interleaved rounds, in two worker subprocesses of the same harness (benchmarks/
_previous.py): ``current`` (this checkout's ``src/``) and ``previous`` (the git revision
``--previous``, default ``PREVIOUS_RELEASE``, extracted to a temporary folder). Each worker pins
BLAS to one thread (environment and threadpoolctl), pauses the garbage collector while timing and
returns the process CPU time per call. The cases (benchmarks/_regression_cases.py, the paper's
system on the default grid ``ContactProblem.create(..., deepest_position=h0)``, η = 1 nm,
ω log-spaced in [1, 1e6] rad/s):

- ``linear_response`` at h0 = −5 nm (50 ω) and +2 nm (no contact), cold (a new problem, every
  linear-response cache emptied, before each call) and warm (caches filled);
- ``linear_stiffness`` at −5 nm, cold and warm;
- ``static_equilibrium(problem, h0)`` at −5 and +2 nm (the public static call);
- ``reference`` (current worker only): the textbook route of _regression_cases.py — static Newton
  at E_inf, one dense complex LU solve per ω, the finite-amplitude check by direct dense solves.

Per round every case runs in both workers back to back (which one first alternates), so the
ratios are paired per round. Verdicts, each printed PASS/FAIL:

- ``reference / current cold`` at −5 nm ≥ 5 (median of the per-round ratios);
- every case: current ≤ previous × (1 + margin), on the median of the per-round ratios
  current/previous; margin = the half-width of that median's 95 % bootstrap interval (the spread
  of the interleaved samples), floored at 4 % (two workers running identical code,
  ``--previous current``, differed by up to 3.3 % on this machine: a per-process offset the
  within-run interval does not see) and capped at 5 % (noise can excuse at most 5 %);
- accuracy: k*(ω) of the reference and of the previous release equal the current
  ``linear_response`` to ≤ 1e-10 relative, the reference's finite-amplitude bias b(ω) equals the
  library's ``amplitude_bias`` to ≤ 1e-10, and all three flag the finite amplitude alike.

Outputs (in ``--out``, default benchmarks/out/): ``regression_benchmark.json`` (keys in
:data:`JSON_KEYS`), ``regression_timings.csv`` (one row per case) and ``regression_timings.png``.
Run ``python benchmarks/bench_regression.py [--quick] [--repeats ROUNDS]
[--previous REV|none|current] [--out DIR]``; no test asserts the times
(tests/benchmarks/test_solvers.py runs ``--quick``).
"""

from __future__ import annotations

import argparse
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

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/ helpers, from any cwd
from _common import (  # noqa: E402
    OUT_DIR,
    machine_facts,
    pf,
    print_machine,
    report_head,
    run_end,
    write_csv,
    write_json,
)
from _previous import PREVIOUS_RELEASE, SELF, WorkerError, Workers  # noqa: E402

SCHEMA = "viscoforce.bench_regression/1"
#: Top-level keys of regression_benchmark.json.
JSON_KEYS = ("schema", "created", "quick", "machine", "target", "settings", "workers", "accuracy",
             "rows", "checks", "summary", "files")
CASES_MODULE = "_regression_cases"
POSITION, FREE_POSITION, ETA = -5e-9, 2e-9, 1e-9  # [m]
N_OMEGA, QUICK_N_OMEGA = 50, 12
DEFAULT_ROUNDS, QUICK_ROUNDS = 40, 3
#: Each timed request runs the case often enough for ≥ this much CPU time [s] (current tree).
MIN_SAMPLE, QUICK_MIN_SAMPLE = 10e-3, 2e-3
MAX_CALLS = 400
SPEEDUP_TARGET = 5.0  # reference / current cold at −5 nm
MARGIN_FLOOR, MARGIN_CAP = 0.04, 0.05
REL_TOL = 1e-10
BOOTSTRAP, SEED = 2000, 20261203
_BOTH, _CURRENT = ("current", "previous"), ("current",)
#: The case table: label, case name of _regression_cases.py and its parameters (``n_omega``, None
#: here, is the run's: :data:`N_OMEGA`, --quick :data:`QUICK_N_OMEGA`), and which workers run it.
CASES = (
    {"label": "linear_response -5 nm cold", "case": "linear_response",
     "params": {"position": POSITION, "eta": ETA, "n_omega": None, "cold": True},
     "workers": _BOTH},
    {"label": "linear_response -5 nm warm", "case": "linear_response",
     "params": {"position": POSITION, "eta": ETA, "n_omega": None, "cold": False},
     "workers": _BOTH},
    {"label": "reference -5 nm", "case": "reference",
     "params": {"position": POSITION, "eta": ETA, "n_omega": None}, "workers": _CURRENT},
    {"label": "linear_response +2 nm cold", "case": "linear_response",
     "params": {"position": FREE_POSITION, "eta": ETA, "n_omega": None, "cold": True},
     "workers": _BOTH},
    {"label": "linear_response +2 nm warm", "case": "linear_response",
     "params": {"position": FREE_POSITION, "eta": ETA, "n_omega": None, "cold": False},
     "workers": _BOTH},
    {"label": "reference +2 nm", "case": "reference",
     "params": {"position": FREE_POSITION, "eta": ETA, "n_omega": None}, "workers": _CURRENT},
    {"label": "linear_stiffness -5 nm cold", "case": "linear_stiffness",
     "params": {"position": POSITION, "n_omega": None, "cold": True}, "workers": _BOTH},
    {"label": "linear_stiffness -5 nm warm", "case": "linear_stiffness",
     "params": {"position": POSITION, "n_omega": None, "cold": False}, "workers": _BOTH},
    {"label": "static_equilibrium -5 nm", "case": "static_equilibrium",
     "params": {"position": POSITION}, "workers": _BOTH},
    {"label": "static_equilibrium +2 nm", "case": "static_equilibrium",
     "params": {"position": FREE_POSITION}, "workers": _BOTH},
)


def cases(n_omega: int) -> list[dict]:
    """The rows of :data:`CASES` with ``n_omega`` filled in (a fresh copy for one run)."""
    return [{**c, "params": {k: n_omega if k == "n_omega" else v for k, v in c["params"].items()}}
            for c in CASES]


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke run (a few seconds): {QUICK_ROUNDS} rounds, "
                             f"{QUICK_N_OMEGA} frequencies")
    parser.add_argument("--out", type=Path, default=OUT_DIR,
                        help="output folder (default: benchmarks/out next to this script)")
    parser.add_argument("--repeats", type=int, default=None,
                        help=f"interleaved rounds (default {DEFAULT_ROUNDS}, {QUICK_ROUNDS} with "
                             "--quick)")
    parser.add_argument("--previous", default=PREVIOUS_RELEASE,
                        help=f"git revision of the previous release (default {PREVIOUS_RELEASE}); "
                             f"'none' skips it; '{SELF}' times the current tree against itself "
                             "in a second worker (A/A control: the noise floor of the ratios)")
    args = parser.parse_args(argv)
    if args.repeats is not None and args.repeats < 1:
        parser.error("--repeats must be >= 1")
    if args.previous.lower() == "none":
        args.previous = None
    return args


# ── statistics ───────────────────────────────────────────────────────────────────────────────────

def median_interval(values: list[float], rng: np.random.Generator) -> tuple[float, float, float]:
    """Median of ``values`` and its 95 % percentile-bootstrap interval."""
    v = np.asarray(values, dtype=float)
    boot = np.median(v[rng.integers(0, v.size, size=(BOOTSTRAP, v.size))], axis=1)
    lo, hi = np.percentile(boot, [2.5, 97.5])
    return float(np.median(v)), float(lo), float(hi)


def no_slower_check(label: str, current: list[float], previous: list[float],
                    rng: np.random.Generator) -> dict:
    """current ≤ previous × (1 + margin) on the paired per-round ratios (module docstring)."""
    ratios = [c / p for c, p in zip(current, previous, strict=True)]
    med, lo, hi = median_interval(ratios, rng)
    margin = min(MARGIN_CAP, max(MARGIN_FLOOR, (hi - lo) / 2.0))
    return {"check": f"{label}: current <= previous", "kind": "no_slower", "case": label,
            "ratio": med, "ratio_low": lo, "ratio_high": hi, "margin": margin,
            "limit": 1.0 + margin, "passed": med <= 1.0 + margin}


def speedup_check(label: str, reference: list[float], current: list[float],
                  rng: np.random.Generator) -> dict:
    """reference / current ≥ SPEEDUP_TARGET on the paired per-round ratios."""
    med, lo, hi = median_interval([r / c for r, c in zip(reference, current, strict=True)], rng)
    return {"check": f"reference / {label} >= {SPEEDUP_TARGET:g}", "kind": "speedup",
            "case": label, "ratio": med, "ratio_low": lo, "ratio_high": hi, "margin": None,
            "limit": SPEEDUP_TARGET, "passed": med >= SPEEDUP_TARGET}


# ── accuracy ─────────────────────────────────────────────────────────────────────────────────────

def _complex(d: dict) -> np.ndarray:
    return np.asarray(d["re"]) + 1j * np.asarray(d["im"])


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b) / np.abs(b)))


def accuracy(workers: Workers, plan: list[dict], n_omega: int) -> dict:
    """Reference and previous release against the current ``linear_response`` (module docstring)."""
    out = {}
    cur = workers["current"]
    for name, position in (("contact", POSITION), ("free", FREE_POSITION)):
        lr = {"position": position, "eta": ETA, "n_omega": n_omega}
        now = cur.value("linear_response", {**lr, "cold": True})
        ref = cur.value("reference", lr)
        cur.setup("amplitude_bias", {"position": position, "n_omega": n_omega}, warmup=0)
        bias = _complex(cur.value("amplitude_bias", {"position": position, "n_omega": n_omega}))
        k_now = _complex(now["k"])
        entry = {"h0": position,
                 "k_rel_diff_reference": _rel(_complex(ref["k"]), k_now),
                 "mean_force_rel_diff_reference": abs(ref["mean_force"] - now["mean_force"])
                 / abs(now["mean_force"]),
                 "bias_rel_diff_reference": _rel(_complex(ref["bias"]), bias),
                 "bias_max_abs": float(np.max(np.abs(bias))),
                 "warned_current": now["warned"], "warned_reference": ref["warned"],
                 "caches_cleared_current": now["caches"],
                 "k_rel_diff_previous": None, "warned_previous": None,
                 "caches_cleared_previous": None}
        lr_case = next(c for c in plan if c["case"] == "linear_response"
                       and c["params"]["position"] == position)
        if "previous" in lr_case["workers"]:
            before = workers["previous"].value("linear_response", {**lr, "cold": True})
            entry.update(k_rel_diff_previous=_rel(_complex(before["k"]), k_now),
                         warned_previous=before["warned"],
                         caches_cleared_previous=before["caches"])
        diffs = [entry[k] for k in ("k_rel_diff_reference", "mean_force_rel_diff_reference",
                                    "bias_rel_diff_reference", "k_rel_diff_previous")
                 if entry[k] is not None]
        flags = {entry[k] for k in ("warned_current", "warned_reference", "warned_previous")
                 if entry[k] is not None}
        entry["passed"] = max(diffs) <= REL_TOL and len(flags) == 1
        out[name] = entry
    return out


# ── the run ──────────────────────────────────────────────────────────────────────────────────────

def measure(workers: Workers, plan: list[dict], rounds: int, min_sample: float) -> None:
    """Set up every case, choose its calls per request, run the interleaved rounds (in place).

    Adds to each case of ``plan``: ``calls`` and ``samples`` (per worker: lists of CPU and wall
    time per call [s], one per round).
    """
    for c in plan:
        c["workers"] = tuple(w for w in c["workers"] if w in workers)
        c["note"] = None
        for w in c["workers"]:
            try:
                workers[w].setup(c["case"], c["params"], warmup=2)
            except WorkerError as exc:  # a case the previous release cannot run: left out
                if w != "previous":
                    raise
                c["workers"] = ("current",)
                c["note"] = f"previous release cannot run it: {str(exc).splitlines()[-1]}"
                print(f"note: {c['label']}: {c['note']}")
        cpu, _ = workers["current"].time(c["case"], c["params"], calls=1)
        c["calls"] = int(min(MAX_CALLS, max(1, math.ceil(min_sample / max(cpu, 1e-7)))))
        c["samples"] = {w: {"cpu": [], "wall": []} for w in c["workers"]}
    for i in range(rounds):
        for c in plan:
            order = c["workers"] if i % 2 == 0 else c["workers"][::-1]
            for w in order:
                cpu, wall = workers[w].time(c["case"], c["params"], calls=c["calls"])
                c["samples"][w]["cpu"].append(cpu)
                c["samples"][w]["wall"].append(wall)


def rows_and_checks(plan: list[dict], rng: np.random.Generator) -> tuple[list[dict], list[dict]]:
    """One row per case (medians per worker, ratios) and the PASS/FAIL checks."""
    rows, checks, by_label = [], [], {c["label"]: c for c in plan}
    for c in plan:
        s = c["samples"]
        row = {"case": c["label"], "function": c["case"], **c["params"],
               "calls_per_sample": c["calls"], "rounds": len(s["current"]["cpu"]),
               "note": c["note"]}
        for w in ("current", "previous"):
            cpu = s.get(w, {}).get("cpu")
            row[f"{w}_cpu_median_s"] = statistics.median(cpu) if cpu else None
            row[f"{w}_cpu_min_s"] = min(cpu) if cpu else None
            row[f"{w}_wall_median_s"] = statistics.median(s[w]["wall"]) if cpu else None
        row["ratio_current_previous"] = None
        if "previous" in s:
            check = no_slower_check(c["label"], s["current"]["cpu"], s["previous"]["cpu"], rng)
            checks.append(check)
            row["ratio_current_previous"] = check["ratio"]
        rows.append(row)
    ref, cold = by_label["reference -5 nm"], by_label["linear_response -5 nm cold"]
    checks.insert(0, speedup_check("current cold (-5 nm)", ref["samples"]["current"]["cpu"],
                                   cold["samples"]["current"]["cpu"], rng))
    return rows, checks


def info_ratios(plan: list[dict], rng: np.random.Generator) -> dict:
    """Reference / current and reference / previous at both positions (cold; no verdict)."""
    by_label = {c["label"]: c["samples"] for c in plan}
    out = {}
    for where in ("-5 nm", "+2 nm"):
        ref = by_label[f"reference {where}"]["current"]["cpu"]
        for w in ("current", "previous"):
            cold = by_label[f"linear_response {where} cold"].get(w)
            if cold is not None:
                med, lo, hi = median_interval(
                    [r / c for r, c in zip(ref, cold["cpu"], strict=True)], rng)
                out[f"reference_over_{w}_cold {where}"] = {"ratio": med, "low": lo, "high": hi}
    return out


def plot(rows: list[dict], checks: list[dict], path: Path, title: str) -> None:
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(13.0, 5.5), gridspec_kw={"width_ratios": [3, 2]})
    y = np.arange(len(rows))
    is_ref = np.array([r["function"] == "reference" for r in rows])
    for dy, w, colour in ((-0.2, "current", "tab:blue"), (0.2, "previous", "tab:orange")):
        vals = np.array([1e3 * (r[f"{w}_cpu_median_s"] or np.nan) for r in rows])
        keep = ~is_ref if w == "current" else np.ones(len(rows), dtype=bool)
        ax.barh(y[keep] + dy, vals[keep], 0.4, color=colour, label=w)
    ref_vals = [1e3 * r["current_cpu_median_s"] for r in rows if r["function"] == "reference"]
    ax.barh(y[is_ref], ref_vals, 0.4, color="tab:grey", label="reference (dense LU per ω)")
    ax.set(yticks=y, yticklabels=[r["case"] for r in rows], xscale="log",
           xlabel="CPU time per call [ms] (median over rounds, 1 BLAS thread)")
    ax.invert_yaxis()
    ax.grid(True, axis="x", which="both", alpha=0.3)
    ax.legend(fontsize=8)
    slow = [c for c in checks if c["kind"] == "no_slower"]
    if slow:
        yy = np.arange(len(slow))
        med = np.array([c["ratio"] for c in slow])
        err = np.array([[c["ratio"] - c["ratio_low"] for c in slow],
                        [c["ratio_high"] - c["ratio"] for c in slow]])
        colours = ["tab:green" if c["passed"] else "tab:red" for c in slow]
        bx.errorbar(med, yy, xerr=err, fmt="none", ecolor="grey", capsize=3)
        bx.scatter(med, yy, c=colours, zorder=3)
        bx.axvline(1.0, color="black", lw=1)
        bx.set(yticks=yy, yticklabels=[c["case"] for c in slow], xscale="log",
               xlabel="current / previous (median, 95 % bootstrap interval)")
        bx.invert_yaxis()
        bx.grid(True, axis="x", which="both", alpha=0.3)
    else:
        bx.text(0.5, 0.5, "previous release not timed", ha="center", transform=bx.transAxes)
        bx.set_axis_off()
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _ms(x: float | None) -> str:
    return f"{1e3 * x:10.3f}" if x is not None else f"{'-':>10}"


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    rounds = args.repeats or (QUICK_ROUNDS if args.quick else DEFAULT_ROUNDS)
    n_omega = QUICK_N_OMEGA if args.quick else N_OMEGA
    min_sample = QUICK_MIN_SAMPLE if args.quick else MIN_SAMPLE
    args.out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    t_start = time.perf_counter()
    with threadpool_limits(limits=1):
        machine = machine_facts()
    print(f"viscoforce {machine['viscoforce']} regression benchmark (issue 22 item 1)"
          f"{' (quick)' if args.quick else ''}")
    print_machine(machine)
    plan = cases(n_omega)
    with Workers(CASES_MODULE, previous=args.previous) as workers:
        if workers.note:
            print(f"note: {workers.note}; the previous-release columns are left out")
        info = {w: {**wk.info, "src": str(wk.src)} for w, wk in workers.items()}
        for w, d in info.items():
            print(f"worker {w}: pid {d['pid']}, viscoforce from {d['viscoforce_file']}, "
                  f"BLAS threads {d['blas_threads']}")
        if args.previous == SELF:
            print("A/A control: 'previous' is the current tree again, in a second worker")
        elif workers.previous_commit and "previous" in workers:
            print(f"previous release: {args.previous} = {workers.previous_commit}")
        print(f"h0 = {POSITION * 1e9:g} nm (and {FREE_POSITION * 1e9:+g} nm), eta = "
              f"{ETA * 1e9:g} nm, {n_omega} omega log-spaced in [1, 1e6] rad/s, default grid; "
              f"{rounds} interleaved rounds, >= {min_sample * 1e3:g} ms CPU per sample; "
              f"load average {machine['loadavg_start']}")
        measure(workers, plan, rounds, min_sample)
        acc = accuracy(workers, plan, n_omega)
        worker_info = {"current": info.get("current"), "previous": info.get("previous"),
                       "previous_revision": args.previous,
                       "previous_commit": workers.previous_commit if "previous" in workers
                       else None, "note": workers.note}
    rows, checks = rows_and_checks(plan, rng)
    ratios = info_ratios(plan, rng)
    head = (f"{'case':28} {'calls':>5} {'current [ms]':>12} {'previous [ms]':>13} "
            f"{'cur/prev':>8} {'95 % interval':>15} {'limit':>6} verdict")
    print(head)
    print("-" * len(head))
    by_case = {c["case"]: c for c in checks if c["kind"] == "no_slower"}
    for r in rows:
        c = by_case.get(r["case"])
        tail = (f"{c['ratio']:8.3f} [{c['ratio_low']:6.3f},{c['ratio_high']:6.3f}] "
                f"{c['limit']:6.3f} {pf(c['passed'])}" if c else "")
        print(f"{r['case']:28} {r['calls_per_sample']:5d} {_ms(r['current_cpu_median_s']):>12} "
              f"{_ms(r['previous_cpu_median_s']):>13} {tail}")
    for key, v in ratios.items():
        print(f"{key.replace('_', ' ')}: {v['ratio']:.2f}x (95 % interval {v['low']:.2f}-"
              f"{v['high']:.2f})")
    speed = checks[0]
    print(f"reference / current cold at -5 nm, eta = 1 nm, {n_omega} omega: {speed['ratio']:.2f}x "
          f"(95 % interval {speed['ratio_low']:.2f}-{speed['ratio_high']:.2f}), target >= "
          f"{SPEEDUP_TARGET:g}: {pf(speed['passed'])}")
    for a in acc.values():
        prev = ("" if a["k_rel_diff_previous"] is None
                else f", previous {a['k_rel_diff_previous']:.1e}")
        print(f"accuracy h0 = {a['h0'] * 1e9:+g} nm: max |k* - k*_current|/|k*_current|: "
              f"reference {a['k_rel_diff_reference']:.1e}{prev}; bias b(omega) reference vs "
              f"amplitude_bias {a['bias_rel_diff_reference']:.1e}; finite-amplitude flag "
              f"current/reference/previous {a['warned_current']}/{a['warned_reference']}/"
              f"{a['warned_previous']} (<= {REL_TOL:g}, same flag): {pf(a['passed'])}")
    slower = [c for c in checks if c["kind"] == "no_slower"]
    summary = {
        "speedup_reference_over_current_cold": speed["ratio"],
        "speedup_passed": speed["passed"],
        "no_slower_passed": all(c["passed"] for c in slower) if slower else None,
        "worst_ratio_current_previous": max((c["ratio"] for c in slower), default=None),
        "accuracy_passed": all(a["passed"] for a in acc.values()),
        "info_ratios": ratios,
        "previous_timed": bool(slower),
        **run_end(t_start),
    }
    summary["passed"] = bool(summary["speedup_passed"] and summary["accuracy_passed"]
                             and summary["no_slower_passed"] is not False)
    summary["verdict"] = pf(summary["passed"])
    print(f"no slower than the previous release anywhere: "
          f"{'not measured' if not slower else pf(summary['no_slower_passed'])}; overall "
          f"{summary['verdict']}")
    files = {"png": args.out / "regression_timings.png",
             "csv": args.out / "regression_timings.csv",
             "json": args.out / "regression_benchmark.json"}
    plot(rows, checks, files["png"],
         f"viscoforce: current vs previous release ({(worker_info['previous_commit'] or 'n/a')[:10]}), "
         f"{n_omega} omega, eta = 1 nm; reference/current cold at -5 nm = {speed['ratio']:.2f}x")
    write_csv(rows, files["csv"])
    report = report_head(SCHEMA, args.quick, machine)
    report.update({
        "target": {"speedup_reference_over_current_cold": SPEEDUP_TARGET,
                   "speedup_case": "linear_response at h0 = -5 nm, eta = 1 nm, default grid",
                   "no_slower": "median per-round CPU ratio current/previous <= 1 + margin",
                   "margin_floor": MARGIN_FLOOR, "margin_cap": MARGIN_CAP, "rel_error": REL_TOL},
        "settings": {"position": POSITION, "free_position": FREE_POSITION, "eta": ETA,
                     "n_omega": n_omega, "omega_min": 1.0, "omega_max": 1e6, "rounds": rounds,
                     "min_sample_s": min_sample, "bootstrap": BOOTSTRAP, "seed": SEED,
                     "cases_module": CASES_MODULE,
                     "cases": [{k: c[k] for k in ("label", "case", "params", "workers", "calls", "note")}
                               for c in plan]},
        "workers": worker_info, "accuracy": acc, "rows": rows, "checks": checks,
        "summary": summary, "files": {k: str(v) for k, v in files.items()}})
    write_json(report, files["json"])
    print(f"wrote {files['png']}, {files['csv']}, {files['json']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
