#!/usr/bin/env python
"""``--modes auto`` on relaxation and creep curves against ``--modes 1`` (issue 41 item 2).

Issue 41 item 2: the exponential sums' amplitudes enter linearly, so each candidate of
``modes="auto"`` is searched by variable projection (:mod:`viscoforce.fitting._varpro`) and the
profile likelihood refits on the package's engine. Target: relaxation ``modes="auto"`` ≤ 20× the
time of ``modes=1`` on the real hold (fmt-jpk-sr_cell1-0008.jpk-force).

What it measures, per case of :data:`CASES` (``--quick``: :data:`QUICK_CASES`): the library
call the CLI makes on data already read — ``fit_hold(curves, curve=i, modes=m)`` (relaxation)
or ``fit_creep(curves, curve=i, modes=m)`` (creep without a tip: the exponential fit) — with
m = 1 and ``"auto"``, interleaved in rounds (the order reversed every other round), the
garbage collector paused, BLAS pinned to one thread (environment before NumPy loads, and
threadpoolctl). Each case reports the median ms per curve of each and their ratio, the modes
kept and the evaluations; the zip's 15 curves are one case (per curve: the median over its
curves of each curve's median). The target's ratio is the real hold's, measured in this run.

Outputs (``--out``, default benchmarks/out/): ``modes_auto.json`` and ``modes_auto.csv`` (one
row per timed sample). Cases whose file is absent are skipped, saying so (then the target is
not measured and the run does not fail).

Run ``python benchmarks/bench_modes_auto.py [--quick] [--repeats N] [--out DIR]``.
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

SCHEMA = "viscoforce.bench_modes_auto/1"
#: Largest time of ``modes="auto"`` / ``modes=1`` on the real hold (issue 41 item 2).
TARGET_RATIO = 20.0
DEFAULT_REPEATS = 7
REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real" / "afmformats"
#: (name, file, model, curves timed (None: all), target case): the case table.
CASES = (
    ("hold", REAL / "fmt-jpk-sr_cell1-0008.jpk-force", "relaxation", None, True),
    ("creep_brain", REAL / "fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force", "creep", None, False),
    ("creep_polymergel", REAL / "fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force", "creep",
     None, False),
    ("zip_15_curves", REAL / "10.1002_btm2.10294_fig5d-cell1.zip", "relaxation", None, False),
)
#: --quick: the hold and the zip's first two curves, once.
QUICK_CASES = tuple((n, p, m, 2 if n.startswith("zip") else c, t)
                    for n, p, m, c, t in CASES if n in ("hold", "zip_15_curves"))


def _fitter(model: str):
    if model == "relaxation":
        from viscoforce.fitting.curves import fit_hold

        return fit_hold
    from viscoforce.fitting.creep import fit_creep

    return fit_creep


def _time_case(name: str, path: Path, model: str, curves: int | None, repeats: int
               ) -> tuple[dict, list[dict]]:
    from viscoforce.io.instruments import load_instrument

    data = load_instrument(path)
    fit = _fitter(model)
    n = int(data.sizes["curve"]) if curves is None else min(curves, int(data.sizes["curve"]))
    rows: list[dict] = []
    per_curve: dict[str, list[float]] = {"1": [], "auto": []}
    kept, nfev = [], {"1": [], "auto": []}
    for curve in range(n):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for modes in (1, "auto"):  # warm: imports and caches out of the timing
                fit(data, curve=curve, modes=modes)
            samples: dict[str, list[float]] = {"1": [], "auto": []}
            for r in range(repeats):
                order = (1, "auto") if r % 2 == 0 else ("auto", 1)
                for modes in order:
                    with gc_paused():
                        t0 = time.perf_counter()
                        ds = fit(data, curve=curve, modes=modes)
                        seconds = time.perf_counter() - t0
                    samples[str(modes)].append(seconds)
                    rows.append({"case": name, "curve": curve, "modes": str(modes),
                                 "sample": r, "ms": 1e3 * seconds,
                                 "modes_kept": int(ds["modes"])})
                    if r == 0:
                        nfev[str(modes)].append(int(ds.attrs.get("nfev", -1)))
                        if modes == "auto":
                            kept.append(int(ds["modes"]))
        for key in per_curve:
            per_curve[key].append(statistics.median(samples[key]))
    one, auto = statistics.median(per_curve["1"]), statistics.median(per_curve["auto"])
    return {"case": name, "file": path.name, "model": model, "curves": n,
            "ms_per_curve_modes_1": 1e3 * one, "ms_per_curve_modes_auto": 1e3 * auto,
            "ratio": auto / one, "modes_kept": kept, "nfev_kept_fit": nfev}, rows


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__, quick_help="the hold and two zip curves, once",
                      repeats_help=f"timed rounds per curve (default {DEFAULT_REPEATS})")
    repeats = args.repeats or (1 if args.quick else DEFAULT_REPEATS)
    t_start = time.perf_counter()
    machine = machine_facts()
    print_machine(machine)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results, rows, skipped = [], [], []
    target = None
    with threadpool_limits(1):
        print("BLAS pinned to one thread (environment and threadpoolctl)")
        for name, path, model, curves, is_target in QUICK_CASES if args.quick else CASES:
            if not path.is_file():
                skipped.append(f"{name}: {path} absent")
                print(f"{name}: skipped ({path} absent)")
                continue
            result, samples = _time_case(name, path, model, curves, repeats)
            results.append(result)
            rows += samples
            if is_target:
                target = result
            print(f"{name} ({model}, {result['curves']} curve(s)): modes 1 "
                  f"{result['ms_per_curve_modes_1']:.1f} ms, auto "
                  f"{result['ms_per_curve_modes_auto']:.1f} ms per curve, ratio "
                  f"{result['ratio']:.1f}; kept {result['modes_kept']}")
    passed = target is None or target["ratio"] <= TARGET_RATIO
    report = {**report_head(SCHEMA, args.quick, machine),
              "target": {"ratio_max": TARGET_RATIO,
                         "what": "modes='auto' / modes=1 time on the real hold, medians"},
              "settings": {"repeats": repeats, "cases": [c[0] for c in CASES]},
              "results": results, "skipped": skipped,
              "summary": {"passed": passed,
                          "target_ratio": None if target is None else target["ratio"],
                          **run_end(t_start)},
              "files": ["modes_auto.json", "modes_auto.csv"]}
    write_json(report, out / "modes_auto.json")
    write_csv(rows, out / "modes_auto.csv")
    if target is None:
        print("the real hold is absent: the target was not measured")
    else:
        print(f"relaxation modes auto / modes 1 on the real hold: {target['ratio']:.1f} "
              f"(target <= {TARGET_RATIO:g}): {pf(passed)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
