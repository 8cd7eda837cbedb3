#!/usr/bin/env python
"""Hertz fit per curve, in process: viscoforce's ``fit_curve(..., "hertz")`` against nanite's.

Issue 41 item 4: a Hertz fit took 4.85x nanite's time per curve (51 ms against 10.6 ms), 87 % of
it in the contact-point scan (85 linear least squares over the whole approach, four scans per
curve with the checks' refit). Part 1: the scan solved in closed form for all candidates at
once, coarse then local (``viscoforce.fitting._hertz_scan``), the depth check refitting by the
same scan and a 1-D search. Part 2: the fit starts at that least-squares minimum (variable
projection: MINPACK stops after 6 evaluations instead of 20-45), the checks' sum of squares
reuses the start's scan and the direction check its costs mirrored (three scans per curve),
the tips' law runs unchecked inside (checked once), one curve is sliced from the map instead of
selected, and the scan's blocks live in scratch arrays. Part 3: the direction check screens
the mirrored model (``_hertz_scan.hertz_screen``: the subsample pass's best three candidates on
every sample) and asks the whole grid only near its threshold (two scans and a screen per
curve). The target is viscoforce's time per curve <= nanite's, measured in one run.

What it measures, per case of :data:`CASES` (``--quick``: :data:`QUICK_CASES`):

* **viscoforce**: ``viscoforce.fit_curve(curves, "hertz", curve=i, tip=TIP)`` on a curves
  dataset already read (``open_data``), checks and derived moduli included: the in-process
  call, one timed sample per curve and round (process CPU time and wall time).
* **nanite** (GPL: never installed in the project's environment): the same curves fitted by
  nanite's default Hertz model (``hertz_para``, R = 5 um) after its usual preprocessing
  (``compute_tip_position``, ``correct_force_offset``, ``correct_tip_offset``), in a child
  process of another interpreter: ``VISCOFORCE_NANITE_PYTHON``, else
  ``/tmp/nanite-venv/bin/python`` where it exists (``python -m venv /tmp/nanite-venv &&
  /tmp/nanite-venv/bin/pip install nanite``). The JPK map is read by nanite itself; the UFF file
  (which nanite does not read) is handed over as arrays (``height (measured)`` = −tip position −
  F/k, so nanite's tip position is viscoforce's, negated). Without such an interpreter the
  issue's figure, :data:`NANITE_FIGURE_S` per curve on this host class, stands in (said so).

The rounds run viscoforce, nanite, viscoforce (half the rounds before, half after: both see the
same load); one untimed round warms each up. The figure is the median over every (curve, round)
sample of all cases; **target**: viscoforce's median CPU time per curve / nanite's <= 1 (CPU
time: both are single-threaded with BLAS pinned, and the 2-core machine is shared; wall times are
printed and stored too). BLAS is pinned to one thread (``OPENBLAS_NUM_THREADS=1`` before NumPy
loads, and threadpoolctl). Outputs (``--out``, default benchmarks/out/): ``hertz_speed.json`` and
``hertz_speed.csv`` (one row per timed sample). Real files are read from ../shared/data/real/
(cases without their file are skipped, saying so).
Run ``python benchmarks/bench_hertz_speed.py [--quick] [--repeats N] [--out DIR]``.
"""

from __future__ import annotations

import os

for _name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"  # before NumPy loads (here and in the nanite child)

import json  # noqa: E402
import math  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
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

SCHEMA = "viscoforce.bench_hertz_speed/1"
TARGET_RATIO = 1.0  # viscoforce's median CPU time per curve / nanite's
DEFAULT_REPEATS = 4
#: nanite's time per curve [s] in the issue (41 item 4, this host class): used without nanite.
NANITE_FIGURE_S = 10.6e-3
NANITE_RADIUS = 5e-6  # [m], hertz_para's R
NANITE_DEFAULT = Path("/tmp/nanite-venv/bin/python")
REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"

#: (name, data file, viscoforce tip, curves): the cases timed.
CASES = (
    ("pyfmrheo_map", REAL / "PyFMRheo" / "map-data-2022.10.29-12.27.34.564.jpk-force-map",
     "paraboloid:5um", tuple(range(16))),
    ("uff_egel", REAL / "PyFMReader" / "20200904_Egel4-Z1.0_00025.uff", "pyramid:20", (0,)),
)
#: The --quick subset (a smoke run: two curves of the map, one round).
QUICK_CASES = ((CASES[0][0], CASES[0][1], CASES[0][2], (0, 1)),)

#: The nanite child: reads its cases (JSON) from stdin, prints per-sample times (JSON).
NANITE_CHILD = r"""
import json, sys, time, warnings
import numpy as np
import nanite
warnings.simplefilter("ignore")
spec = json.load(sys.stdin)
PRE = ["compute_tip_position", "correct_force_offset", "correct_tip_offset"]

def curves(case):
    if case["npz"] is None:
        group = nanite.IndentationGroup(case["path"])
        out = [group[i] for i in case["curves"]]
    else:
        d = np.load(case["npz"])
        out = [nanite.Indentation(
            data={"force": d["force"], "height (measured)": d["height"],
                  "segment": d["segment"].astype(bool), "time": d["time"]},
            metadata={"spring constant": float(d["k"]), "imaging mode": "force-distance",
                      "path": case["npz"], "enum": 0})]
    for idnt in out:  # read now, not in the timed region
        idnt["force"], idnt["height (measured)"]
    return out

def fit(idnt):
    idnt.apply_preprocessing(PRE)
    params = idnt.get_initial_fit_parameters(model_key="hertz_para")
    params["R"].set(spec["radius"])
    idnt.fit_model(model_key="hertz_para", params_initial=params)
    return float(idnt.fit_properties["params_fitted"]["E"].value)

rows, young = [], {}
for rnd in range(-1, spec["rounds"]):
    for case in spec["cases"]:
        for curve, idnt in zip(case["curves"], curves(case)):
            c0, t0 = time.process_time(), time.perf_counter()
            e = fit(idnt)
            t1, c1 = time.perf_counter(), time.process_time()
            young[f"{case['name']}:{curve}"] = e
            if rnd >= 0:
                rows.append({"case": case["name"], "curve": curve, "round": rnd,
                             "cpu_s": c1 - c0, "wall_s": t1 - t0})
print(json.dumps({"nanite": nanite.__version__, "rows": rows, "E_young": young}))
"""


def nanite_python() -> Path | None:
    """The interpreter with nanite: ``VISCOFORCE_NANITE_PYTHON``, else the default venv's."""
    given = os.environ.get("VISCOFORCE_NANITE_PYTHON")
    path = Path(given) if given else NANITE_DEFAULT
    return path if path.is_file() else None


def _uff_arrays(curves, folder: Path) -> Path:
    """The UFF curve as nanite's columns in an .npz (nanite reads no UFF)."""
    k = float(curves["spring_constant"].values[0])
    force = np.asarray(curves["force"].values, dtype=float)
    tip = np.asarray(curves["tip_position"].values, dtype=float)
    path = folder / "uff_curve.npz"
    np.savez(path, force=force, height=-tip - force / k,
             segment=np.asarray(curves["segment"].values), time=curves["time"].values, k=k)
    return path


def time_nanite(python: Path, cases: list[dict], rounds: int) -> dict:
    """nanite's samples from a child process of ``python`` (its stdout's JSON)."""
    spec = {"cases": cases, "rounds": rounds, "radius": NANITE_RADIUS}
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": ""}
    done = subprocess.run([str(python), "-c", NANITE_CHILD], input=json.dumps(spec),
                          capture_output=True, text=True, env=env, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"the nanite child failed: {done.stderr.strip()[-800:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def time_viscoforce(loaded: dict, cases: tuple, rounds: range, rows: list[dict],
                    young: dict) -> None:
    """Time every curve of ``cases`` once per round (appending to ``rows``).

    Each curve twice: the public call (tool ``viscoforce``, the target's) and, for information,
    the fit without its checks (tool ``viscoforce_fit_only``: ``fit_data`` of ``curve_data``,
    the fit and its result dataset; no direction, signal or depth check, no derived moduli).
    """
    import viscoforce as vf
    from viscoforce.fitting.curves import curve_data
    from viscoforce.fitting.fit import fit_data
    from viscoforce.physics.tips import tip_from

    for rnd in rounds:
        for name, _, tip, curves in cases:
            law = tip_from(tip)
            for curve in curves:
                with warnings.catch_warnings(), gc_paused():
                    warnings.simplefilter("ignore")
                    c0, t0 = time.process_time(), time.perf_counter()
                    ds = vf.fit_curve(loaded[name], "hertz", curve=curve, tip=tip)
                    t1, c1 = time.perf_counter(), time.process_time()
                    fit_data(curve_data(loaded[name], "hertz", curve=curve), "hertz", tip=law)
                    c2 = time.process_time()
                young[f"{name}:{curve}"] = float(ds["E_young"])
                if rnd >= 0:
                    rows.append({"tool": "viscoforce", "case": name, "curve": curve,
                                 "round": rnd, "cpu_s": c1 - c0, "wall_s": t1 - t0})
                    rows.append({"tool": "viscoforce_fit_only", "case": name, "curve": curve,
                                 "round": rnd, "cpu_s": c2 - c1, "wall_s": math.nan})


def _medians(rows: list[dict], tool: str, case: str | None = None) -> dict:
    pick = [r for r in rows if r["tool"] == tool and (case is None or r["case"] == case)]
    if not pick:
        return {"cpu_median_s": None, "wall_median_s": None, "samples": 0}
    return {"cpu_median_s": statistics.median(r["cpu_s"] for r in pick),
            "wall_median_s": statistics.median(r["wall_s"] for r in pick),
            "samples": len(pick)}


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__, quick_help="two curves of the map, one round",
                      repeats_help=f"timed rounds over every curve (default {DEFAULT_REPEATS})")
    rounds = args.repeats or (1 if args.quick else DEFAULT_REPEATS)
    t_start = time.perf_counter()
    threadpool_limits(1)
    machine = machine_facts()
    print_machine(machine)
    print("BLAS pinned to one thread (OPENBLAS_NUM_THREADS=1, threadpoolctl)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    import viscoforce as vf

    cases, skipped, loaded = [], [], {}
    for case in QUICK_CASES if args.quick else CASES:
        if not case[1].is_file():
            skipped.append(f"{case[0]}: {case[1]} absent")
            print(f"{case[0]}: skipped ({case[1]} absent)")
            continue
        cases.append(case)
        loaded[case[0]] = vf.open_data(case[1])
    rows: list[dict] = []
    young: dict = {}
    python = nanite_python()
    nanite_young: dict = {}
    nanite_version = None
    first = rounds - rounds // 2
    time_viscoforce(loaded, tuple(cases), range(-1, first), rows, young)
    if python is not None and cases:
        with tempfile.TemporaryDirectory() as folder:
            child_cases = [{"name": n, "path": str(p), "curves": list(c),
                            "npz": str(_uff_arrays(loaded[n], Path(folder)))
                            if p.suffix == ".uff" else None} for n, p, _, c in cases]
            found = time_nanite(python, child_cases, rounds)
        rows += [{"tool": "nanite", **r} for r in found["rows"]]
        nanite_young, nanite_version = found["E_young"], found["nanite"]
    time_viscoforce(loaded, tuple(cases), range(first, rounds), rows, young)

    ours = _medians(rows, "viscoforce")
    if nanite_version is not None:
        theirs = _medians(rows, "nanite")
        source = f"measured: nanite {nanite_version} in {python}"
    else:
        theirs = {"cpu_median_s": NANITE_FIGURE_S, "wall_median_s": NANITE_FIGURE_S,
                  "samples": 0}
        source = (f"the issue's figure ({1e3 * NANITE_FIGURE_S:g} ms per curve): no nanite "
                  "interpreter (VISCOFORCE_NANITE_PYTHON or /tmp/nanite-venv/bin/python)")
    per_case = {n: {"viscoforce": _medians(rows, "viscoforce", n),
                    "nanite": _medians(rows, "nanite", n)} for n, *_ in cases}
    ratio = (ours["cpu_median_s"] / theirs["cpu_median_s"]
             if ours["cpu_median_s"] is not None else None)
    wall_ratio = (ours["wall_median_s"] / theirs["wall_median_s"]
                  if ours["wall_median_s"] is not None else None)
    passed = ratio is not None and ratio <= TARGET_RATIO
    for name, m in per_case.items():
        v, n = m["viscoforce"], m["nanite"]
        there = (f"nanite {1e3 * n['cpu_median_s']:.2f} ms CPU, {1e3 * n['wall_median_s']:.2f} "
                 "ms wall" if n["samples"] else "nanite not measured")
        print(f"{name}: viscoforce {1e3 * v['cpu_median_s']:.2f} ms CPU, "
              f"{1e3 * v['wall_median_s']:.2f} ms wall per curve ({v['samples']} samples); "
              f"{there}")
    print(f"nanite: {source}")
    if ratio is not None:
        print(f"per curve, all cases: viscoforce {1e3 * ours['cpu_median_s']:.2f} ms CPU "
              f"({1e3 * ours['wall_median_s']:.2f} ms wall), nanite "
              f"{1e3 * theirs['cpu_median_s']:.2f} ms CPU ({1e3 * theirs['wall_median_s']:.2f} "
              f"ms wall): ratio {ratio:.2f} CPU, {wall_ratio:.2f} wall")
    fit_only = _medians(rows, "viscoforce_fit_only")
    fit_only_ratio = (fit_only["cpu_median_s"] / theirs["cpu_median_s"]
                      if fit_only["cpu_median_s"] is not None else None)
    if fit_only_ratio is not None and ratio is not None:
        print(f"information: the fit without its checks (fit_data of curve_data) "
              f"{1e3 * fit_only['cpu_median_s']:.2f} ms CPU per curve, {fit_only_ratio:.2f} "
              f"nanite's; the checks (direction, signal, depth) and derived moduli "
              f"{1e3 * (ours['cpu_median_s'] - fit_only['cpu_median_s']):.2f} ms")
    print(f"viscoforce / nanite per curve (CPU, medians) <= {TARGET_RATIO:g}: {pf(passed)}")
    report = {**report_head(SCHEMA, args.quick, machine),
              "target": {"ratio_max": TARGET_RATIO,
                         "what": "viscoforce / nanite median CPU time per Hertz fit of a curve, "
                                 "in process, measured in this run"},
              "settings": {"rounds": rounds, "cases": [[n, p.name, t, list(c)]
                                                       for n, p, t, c in cases],
                           "nanite_model": "hertz_para", "nanite_radius_m": NANITE_RADIUS},
              "nanite_source": source,
              "results": {"viscoforce": ours, "nanite": theirs, "per_case": per_case,
                          "viscoforce_fit_only": fit_only, "fit_only_ratio_cpu": fit_only_ratio,
                          "E_young": {"viscoforce": young, "nanite": nanite_young}},
              "skipped": skipped,
              "summary": {"passed": passed, "ratio_cpu": ratio, "ratio_wall": wall_ratio,
                          **run_end(t_start)},
              "files": ["hertz_speed.json", "hertz_speed.csv"]}
    write_json(report, out / "hertz_speed.json")
    write_csv(rows, out / "hertz_speed.csv")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
