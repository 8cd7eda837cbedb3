#!/usr/bin/env python
"""Ting on a non-uniformly sampled real curve against a uniform one (issue 41 item 1).

JPK files record their segments at different rates; Ting's hereditary integral there takes the
piecewise-uniform path of :mod:`viscoforce.physics._ting_segments` (FFT within each uniformly
sampled run, the earlier runs carried through the exponentials) instead of a Python loop over
the samples. What it measures, per case of :data:`CASES` (``--quick``: one repeat):

1. ``fit``: a whole ``fit_ting`` (material ``structural``, sphere tip of 5 µm, curve 0), the
   wall time of each of ``--repeats`` runs, the two cases alternating, and the model
   evaluations it took (calls of ``ting_solve``, the guess's and the error estimate's included);
2. ``evaluation``: one ``ting_force`` at the fitted parameters (median of
   :data:`EVALUATIONS` runs), and on the non-uniform case the same evaluation on the loop over
   the nodes (the path before, ``sample_runs`` switched off; one run) with the largest
   difference of the two loads against the error estimate ``ting_error``.

Target: the fit of the non-uniform curve costs ≤ :data:`TARGET_RATIO` × the fit of the uniform
one (medians of the same run). BLAS is pinned to one thread (environment before NumPy loads and
threadpoolctl). Outputs (``--out``, default benchmarks/out/): ``ting_nonuniform.json`` (keys
:data:`JSON_KEYS`) and ``ting_nonuniform.csv`` (one row per timed fit). The real files are read
from ../shared/data/real/ (a case without its file is reported and the target not judged).
Run ``python benchmarks/bench_ting_nonuniform.py [--quick] [--repeats N] [--out DIR]``.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # before NumPy loads

import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/_common.py, from any cwd
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

from viscoforce.fitting.ting import fit_ting  # noqa: E402
from viscoforce.fitting.ting_model import ting_data  # noqa: E402
from viscoforce.measured import open_data  # noqa: E402
from viscoforce.physics import ting  # noqa: E402
from viscoforce.physics.tips import tip_from  # noqa: E402

SCHEMA = "viscoforce.bench_ting_nonuniform/1"
TARGET_RATIO = 10.0  # fit of the non-uniform curve / fit of the uniform one
DEFAULT_REPEATS, QUICK_REPEATS = 3, 1
EVALUATIONS = 9  # timed evaluations at the fitted parameters (median)
TIP = "sphere:5um"
MATERIAL = "structural"
REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
#: The case table: the non-uniformly sampled real curve (``role`` subject: the JPK modulation
#: map, 9 segments at 7 rates, 20,424 samples) and the uniform floor (the PyFMRheo map, 4,000 +
#: 4,000 samples at one rate); curve 0 of each.
CASES = (
    {"case": "nonuniform_modulation_map", "role": "subject", "curve": 0,
     "file": REAL / "PyFMReader" / "map-data-2021.11.05-17.37.44.432.jpk-force-map"},
    {"case": "uniform_pyfmrheo_map", "role": "floor", "curve": 0,
     "file": REAL / "PyFMRheo" / "map-data-2022.10.29-12.27.34.564.jpk-force-map"},
)
#: Top-level keys of ting_nonuniform.json (documented in benchmarks/README.md).
JSON_KEYS = ("schema", "created", "quick", "machine", "target", "settings", "results", "ratio",
             "summary", "files")


class _Counted:
    """``ting.ting_solve`` wrapped to count the model evaluations (ting_force calls it)."""

    def __init__(self):
        self.calls = 0
        self._solve = ting.ting_solve

    def __enter__(self):
        def counted(*args, **kwargs):
            self.calls += 1
            return self._solve(*args, **kwargs)
        ting.ting_solve = counted
        return self

    def __exit__(self, *exc):
        ting.ting_solve = self._solve


def _fit(ds) -> tuple[float, int, object]:
    with warnings.catch_warnings(), _Counted() as count, gc_paused():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        result = fit_ting(ds, curve=0, tip=TIP, material=MATERIAL)
        return time.perf_counter() - t0, count.calls, result


def _evaluation(case: dict, ds, result) -> dict:
    """One ``ting_force`` at the fitted parameters; on the subject also the loop path."""
    t, z = ting_data(ds, curve=case["curve"]).position_trace
    tip = tip_from(TIP)
    kernel = ting.PowerLawRelaxation.from_structural(
        float(result["E_ref"]), float(result["alpha"]), float(result["mu"]))
    c = float(result["contact_point"])
    history = ting._history(t, z, c, tip)
    row = {"samples": int(t.size), "uniform": history.step is not None,
           "runs": 1 if history.runs is None else int(history.runs.steps.size),
           "step_spread": float(np.ptp(np.diff(t)) / np.mean(np.diff(t)))}
    times = []
    with gc_paused():
        for _ in range(EVALUATIONS):
            t0 = time.perf_counter()
            fast = ting.ting_solve(t, z, c, tip, kernel)
            times.append(time.perf_counter() - t0)
    row["evaluation_s"] = statistics.median(times)
    if case["role"] == "subject":
        error = ting.ting_error(t, z, c, tip, kernel)
        runs = ting.sample_runs
        ting.sample_runs = lambda *args: None  # the loop over the nodes: the path before
        try:
            t0 = time.perf_counter()
            loop = ting.ting_solve(t, z, c, tip, kernel)
            row["loop_evaluation_s"] = time.perf_counter() - t0
        finally:
            ting.sample_runs = runs
        diff = np.abs(fast.force - loop.force)
        row.update({"max_difference_to_loop_n": float(diff.max()),
                    "peak_force_n": float(np.max(np.abs(fast.force))),
                    "max_error_estimate_n": float(error.max()),
                    "difference_within_error": bool(np.all(diff <= error + 1e-12
                                                           * np.max(np.abs(fast.force)))),
                    "evaluation_speedup": row["loop_evaluation_s"] / row["evaluation_s"]})
    return row


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__, quick_help="smoke run: one fit of each case",
                      repeats_help=f"timed fits per case (default {DEFAULT_REPEATS}, "
                                   f"{QUICK_REPEATS} with --quick)")
    repeats = args.repeats or (QUICK_REPEATS if args.quick else DEFAULT_REPEATS)
    t_start = time.perf_counter()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with threadpool_limits(limits=1):
        machine = machine_facts()
        print("Ting on a non-uniformly sampled real curve against a uniform one")
        print_machine(machine)
        present = [c for c in CASES if c["file"].is_file()]
        for c in CASES:
            if c not in present:
                print(f"{c['case']}: skipped ({c['file']} absent)")
        data = {c["case"]: open_data(c["file"], raw=True) for c in present}
        samples: list[dict] = []
        fits: dict[str, list] = {c["case"]: [] for c in present}
        for i in range(repeats):  # the cases alternate: one load for both
            for c in present if i % 2 == 0 else present[::-1]:
                wall, calls, result = _fit(data[c["case"]])
                fits[c["case"]].append(result)
                samples.append({"case": c["case"], "repeat": i, "fit_s": wall,
                                "evaluations": calls})
                print(f"{c['case']}: fit {wall:.3f} s, {calls} evaluations", flush=True)
        results = []
        for c in present:
            walls = [s["fit_s"] for s in samples if s["case"] == c["case"]]
            row = {"case": c["case"], "role": c["role"], "file": c["file"].name,
                   "curve": c["curve"], "fit_median_s": statistics.median(walls),
                   "fit_min_s": min(walls), "fits": len(walls),
                   "evaluations": samples[[s["case"] for s in samples].index(c["case"])][
                       "evaluations"],
                   "params": {n: float(fits[c["case"]][0][n]) for n in
                              ("E_ref", "alpha", "mu", "contact_point")},
                   "ting_error_n": float(fits[c["case"]][0].attrs["ting_error"])}
            row.update(_evaluation(c, data[c["case"]], fits[c["case"]][0]))
            results.append(row)
            extra = (f"; loop path {row['loop_evaluation_s']:.3f} s "
                     f"({row['evaluation_speedup']:.0f}x), |fast - loop| "
                     f"{row['max_difference_to_loop_n']:.2e} N <= error estimate: "
                     f"{row['difference_within_error']}" if "loop_evaluation_s" in row else "")
            print(f"{c['case']}: {row['samples']} samples, {row['runs']} uniform run(s); fit "
                  f"{row['fit_median_s']:.3f} s ({row['evaluations']} evaluations), one "
                  f"evaluation {1e3 * row['evaluation_s']:.1f} ms{extra}")
    by = {r["role"]: r for r in results}
    judged = "subject" in by and "floor" in by
    ratio = by["subject"]["fit_median_s"] / by["floor"]["fit_median_s"] if judged else None
    passed = judged and ratio <= TARGET_RATIO
    evaluation_ratio = (by["subject"]["evaluation_s"] / by["floor"]["evaluation_s"]
                        if judged else None)
    csv_path, json_path = out / "ting_nonuniform.csv", out / "ting_nonuniform.json"
    write_csv(samples, csv_path)
    report = {**report_head(SCHEMA, args.quick, machine),
              "target": {"ratio_max": TARGET_RATIO,
                         "what": "fit of the non-uniform real curve / fit of the uniform real "
                                 "curve, median wall times of one run"},
              "settings": {"repeats": repeats, "evaluations": EVALUATIONS, "tip": TIP,
                           "material": MATERIAL, "cases": [c["case"] for c in CASES]},
              "results": results,
              "ratio": {"fit": ratio, "evaluation": evaluation_ratio},
              "summary": {"judged": judged, "passed": passed, "verdict": pf(passed),
                          **run_end(t_start)},
              "files": {"json": str(json_path), "csv": str(csv_path)}}
    write_json(report, json_path)
    if judged:
        print(f"summary: fit ratio non-uniform / uniform {ratio:.2f} (one evaluation "
              f"{evaluation_ratio:.2f}), target <= {TARGET_RATIO:g}: {pf(passed)}")
    else:
        print("summary: a real file is absent, the target is not judged")
    print(f"wrote {json_path} and {csv_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
