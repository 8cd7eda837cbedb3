#!/usr/bin/env python
"""Stream benchmark: peak memory and time per curve of `viscoforce load` and `fit` on big JPK maps.

What it measures (issue 22 item 4): synthetic JPK modulation maps of 16, 256, 1024 and 4096 curves
(``--quick``: 4 and 16), with the real map's segment layout (benchmarks/bench_load.py's writer:
extend, pause, six sine segments 300, 3, 100, 30, 1, 10 Hz, retract; 20 424 samples per curve),
each read by three commands run as fresh child processes:

- ``load``: ``viscoforce load MAP --out spectra.nc`` (the spectrum, demodulated in chunks);
- ``raw``: ``viscoforce load MAP --raw --out curves.nc`` (every sample, appended chunk by chunk);
- ``fit``: ``viscoforce fit MAP --model svda --mean-force 2nN --out fits.nc --no-progress``
  (read in chunks, then the map fit of ``fit_map``: a local dask cluster of 2 workers).

Memory: every command runs under a fresh Python wrapper process that starts it, samples the RSS
of the command's whole process tree (the command and, for ``fit``, its dask nanny and worker
processes) every 20 ms from /proc, and after it ends reads ``getrusage(RUSAGE_CHILDREN)``
(``ru_maxrss``: the peak of the largest single descendant, exact but not a sum). The figure
checked is the larger of the two: the sampled tree sum (which may miss a peak shorter than 20 ms)
and the largest process.

Targets (printed PASS/FAIL): peak memory <= 1 GiB for every command at every size; time per
curve flat: the wall time per curve of the largest map at most 1.5x that of 256 curves
(``--quick``: 16 against 4). Wall time includes the interpreter start, ``read_jpk`` and (fit)
the cluster start, which dominate the small maps; the marginal time per curve between the two
largest maps is reported as well.

BLAS is pinned to one thread (OPENBLAS_NUM_THREADS=1 etc. in this process and every child, and
threadpoolctl here). Outputs in ``--out`` (default benchmarks/out/): ``stream.json`` (keys in
:data:`JSON_KEYS`), ``stream.csv`` (one row per command and size), ``stream.png``. Run
``python benchmarks/bench_stream.py [--quick] [--out DIR] [--sizes 16 256 ...]``.
tests/benchmarks/test_fits_and_io.py runs ``--quick`` and checks keys and files; no test asserts a time.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # this process and every child, before NumPy loads

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from threadpoolctl import threadpool_limits  # noqa: E402

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))   # _common.py, bench_load.py (the synthetic map writer)
sys.path.insert(0, str(REPO))   # tests/io/test_jpk.py (archive helpers of the writer)
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
from bench_load import write_synthetic_map  # noqa: E402

SCHEMA = "viscoforce.bench_stream/1"
GIB = 2**30
TARGET_BYTES = GIB
TARGET_RATIO = 1.5
#: Top-level keys of stream.json.
JSON_KEYS = ("schema", "created", "quick", "machine", "target", "settings", "maps", "runs",
             "summary", "files")
#: Command name → the viscoforce arguments after the map (OUT is the output file).
COMMANDS = {
    "load": ("load", "{map}", "--out", "{out}/spectra.nc"),
    "raw": ("load", "{map}", "--raw", "--out", "{out}/curves.nc"),
    "fit": ("fit", "{map}", "--model", "svda", "--mean-force", "2nN", "--out", "{out}/fits.nc",
            "--no-progress"),
}
#: The case table: one synthetic map per row, its number of curves (a square number), run by
#: every command of :data:`COMMANDS` (``--sizes`` replaces the table's sizes).
CASES = tuple({"curves": n} for n in (16, 256, 1024, 4096))
#: --quick: maps of 4 and 16 curves.
QUICK_CASES = ({"curves": 4}, {"curves": 16})
DEFAULT_SIZES = tuple(c["curves"] for c in CASES)
QUICK_SIZES = tuple(c["curves"] for c in QUICK_CASES)
SAMPLE_S = 0.02

#: The wrapper run as a fresh child per measurement: starts the command, samples the RSS of its
#: process tree from /proc, then reports wall time, the tree's sampled peak and ru_maxrss of its
#: children as one JSON line.
WRAPPER = r"""
import json, os, resource, subprocess, sys, time
def tree(root):
    pids, todo = [], [root]
    while todo:
        pid = todo.pop()
        pids.append(pid)
        try:
            for task in os.listdir(f"/proc/{pid}/task"):
                with open(f"/proc/{pid}/task/{task}/children") as fh:
                    todo.extend(int(c) for c in fh.read().split())
        except OSError:
            pass
    return pids
def rss(pid):
    try:
        with open(f"/proc/{pid}/status") as fh:
            for line in fh:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return 0
dt = float(sys.argv[1])
t0 = time.perf_counter()
proc = subprocess.Popen(sys.argv[2:], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
peak = 0
while proc.poll() is None:
    peak = max(peak, sum(rss(p) for p in tree(proc.pid)))
    time.sleep(dt)
out, err = proc.communicate()
wall = time.perf_counter() - t0
maxrss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
print(json.dumps({"returncode": proc.returncode, "wall_s": wall, "tree_peak_bytes": peak,
                  "maxrss_children_bytes": maxrss, "stderr": err[-2000:]}))
"""


def measure(argv: list[str]) -> dict:
    """Run ``argv`` under :data:`WRAPPER` in a fresh Python process; its JSON report."""
    proc = subprocess.run([sys.executable, "-c", WRAPPER, str(SAMPLE_S), *argv],
                          capture_output=True, text=True, check=False, env=dict(os.environ))
    if proc.returncode != 0:
        raise RuntimeError(f"wrapper failed: {proc.stderr[-2000:]}")
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    if res["returncode"] != 0:
        raise RuntimeError(f"{' '.join(argv)} exited {res['returncode']}: {res['stderr']}")
    res["peak_bytes"] = max(res["tree_peak_bytes"], res["maxrss_children_bytes"])
    return res


def viscoforce_argv(command: str, path: Path, out: Path) -> list[str]:
    args = [a.format(map=path, out=out) for a in COMMANDS[command]]
    return [sys.executable, "-m", "viscoforce", *args]


def plot(runs: list[dict], sizes: list[int], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax_m, ax_t) = plt.subplots(1, 2, figsize=(9, 3.6))
    for command in COMMANDS:
        rows = [r for r in runs if r["command"] == command]
        n = [r["curves"] for r in rows]
        ax_m.plot(n, [r["peak_bytes"] / GIB for r in rows], "o-", label=command)
        ax_t.plot(n, [r["per_curve_s"] * 1e3 for r in rows], "o-", label=command)
    ax_m.axhline(TARGET_BYTES / GIB, color="tab:red", ls="--", label="target 1 GiB")
    for ax in (ax_m, ax_t):
        ax.set_xscale("log")
        ax.set_xticks(sizes, [str(s) for s in sizes])
        ax.set_xlabel("curves in the map")
        ax.legend(fontsize=7)
    ax_t.set_yscale("log")
    ax_m.set_ylabel("peak RSS [GiB]")
    ax_t.set_ylabel("wall time per curve [ms]")
    fig.suptitle("viscoforce load / fit of JPK maps, read in chunks", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def parse(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help=f"smoke run: maps of {' and '.join(map(str, QUICK_SIZES))} curves")
    p.add_argument("--out", type=Path, default=OUT_DIR,
                   help="output folder (default: benchmarks/out next to this script)")
    p.add_argument("--sizes", type=int, nargs="+", default=None,
                   help="curves per map, each a square number (default "
                        f"{' '.join(map(str, DEFAULT_SIZES))})")
    args = p.parse_args(argv)
    sizes = args.sizes or (QUICK_SIZES if args.quick else DEFAULT_SIZES)
    bad = [s for s in sizes if s < 1 or math.isqrt(s) ** 2 != s]
    if bad or len(sizes) < 2:
        p.error(f"--sizes must be at least two square numbers >= 1, got {sizes}")
    args.sizes = sorted(set(sizes))
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    t_start = time.perf_counter()
    threadpool_limits(limits=1, user_api="blas")
    machine = machine_facts()
    print("viscoforce load / fit of JPK maps read in chunks: peak memory and time per curve")
    print_machine(machine)
    print("BLAS pinned to one thread: OPENBLAS_NUM_THREADS=1 (this process and every child) and "
          "threadpoolctl")
    sizes = args.sizes
    maps, runs = [], []
    with tempfile.TemporaryDirectory(prefix="bench_stream_") as tmp:
        for n in sizes:
            grid = math.isqrt(n)
            path = Path(tmp) / f"synthetic-{grid}x{grid}.jpk-force-map"
            facts = write_synthetic_map(path, grid)
            facts.pop("path")
            maps.append(facts)
            print(f"map {grid}x{grid}: {n} curves x {facts['points_per_curve']} points, "
                  f"{facts['file_bytes'] / 2**20:.0f} MiB on disk (written in "
                  f"{facts['write_s']:.1f} s)")
            for command in COMMANDS:
                out = Path(tmp) / f"out-{command}-{n}"
                out.mkdir()
                res = measure(viscoforce_argv(command, path, out))
                written = sum(f.stat().st_size for f in out.iterdir())
                for f in out.iterdir():
                    f.unlink()
                out.rmdir()
                row = {"command": command, "curves": n, "wall_s": res["wall_s"],
                       "per_curve_s": res["wall_s"] / n, "peak_bytes": res["peak_bytes"],
                       "tree_peak_bytes": res["tree_peak_bytes"],
                       "maxrss_children_bytes": res["maxrss_children_bytes"],
                       "output_bytes": written,
                       "memory_passed": res["peak_bytes"] <= TARGET_BYTES}
                runs.append(row)
                print(f"  {command:4s} {n:5d} curves: {res['wall_s']:7.2f} s "
                      f"({row['per_curve_s'] * 1e3:7.2f} ms/curve), peak "
                      f"{res['peak_bytes'] / 2**20:5.0f} MiB (tree {res['tree_peak_bytes'] / 2**20:.0f}"
                      f", largest process {res['maxrss_children_bytes'] / 2**20:.0f}), output "
                      f"{written / 2**20:.1f} MiB: memory {pf(row['memory_passed'])}")
            path.unlink()

    ref = 256 if 256 in sizes and sizes[-1] > 256 else sizes[0]
    top = sizes[-1]
    summary: dict = {"reference_curves": ref, "largest_curves": top, "commands": {}}
    lines = []
    for command in COMMANDS:
        rows = {r["curves"]: r for r in runs if r["command"] == command}
        peak = max(r["peak_bytes"] for r in rows.values())
        ratio = rows[top]["per_curve_s"] / rows[ref]["per_curve_s"]
        prev = sizes[-2]
        marginal = (rows[top]["wall_s"] - rows[prev]["wall_s"]) / (top - prev)
        mem_ok, time_ok = peak <= TARGET_BYTES, ratio <= TARGET_RATIO
        summary["commands"][command] = {
            "peak_bytes": peak, "memory_passed": mem_ok, "per_curve_ratio": ratio,
            "time_passed": time_ok, "marginal_per_curve_s": marginal}
        lines.append(f"summary: {command} peak memory {peak / GIB:.2f} GiB over {sizes[0]}-{top} "
                     f"curves (target <= 1 GiB): {pf(mem_ok)}")
        lines.append(f"summary: {command} time per curve {top} vs {ref} curves: "
                     f"{rows[top]['per_curve_s'] * 1e3:.2f} / {rows[ref]['per_curve_s'] * 1e3:.2f} "
                     f"ms = {ratio:.2f} (target <= {TARGET_RATIO:g}; marginal "
                     f"{marginal * 1e3:.2f} ms/curve from {prev} to {top}): {pf(time_ok)}")
    passed = all(c["memory_passed"] and c["time_passed"] for c in summary["commands"].values())
    summary.update(passed=passed, verdict=pf(passed), **run_end(t_start))
    for line in lines:
        print(line)
    print(f"summary: all targets: {summary['verdict']}")

    args.out.mkdir(parents=True, exist_ok=True)
    json_path, csv_path, png_path = (args.out / f"stream.{e}" for e in ("json", "csv", "png"))
    write_csv(runs, csv_path)
    plot(runs, sizes, png_path)
    report = {
        **report_head(SCHEMA, args.quick, machine),
        "target": {"memory_bytes": TARGET_BYTES, "per_curve_ratio": TARGET_RATIO,
                   "ratio_rule": f"wall time per curve at {top} curves / at {ref} curves",
                   "memory_rule": "max(sampled RSS sum of the command's process tree, "
                                  "ru_maxrss of its largest process)"},
        "settings": {"sizes": sizes, "commands": {k: list(v) for k, v in COMMANDS.items()},
                     "sample_interval_s": SAMPLE_S, "env": {"OPENBLAS_NUM_THREADS": "1"}},
        "maps": maps,
        "runs": runs,
        "summary": summary,
        "files": {"json": str(json_path), "csv": str(csv_path), "png": str(png_path)},
    }
    write_json(report, json_path)
    print(f"wrote {json_path}, {csv_path} and {png_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
