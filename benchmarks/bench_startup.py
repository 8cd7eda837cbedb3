#!/usr/bin/env python
"""Start-up benchmark: a whole ``viscoforce static`` process against a bare xarray/scipy process.

What it measures:

1. The wall time (and the child's CPU time) of two commands, each a fresh Python process, run
   alternately ``--repeats`` times after one warm-up run of each (none with --quick):

   - ``cli``: ``viscoforce static --h0=-5nm --E 1e9 --json`` (the console script next to this
     interpreter, else ``python -m viscoforce``); its output is checked (exit 0, JSON with
     ``force``);
   - ``baseline``: ``python -c "import xarray, scipy.linalg, scipy.special;
     xarray.Dataset({'a': ('x', [1.0])})"``, the libraries any static solve needs anyway.

   Every child runs with ``OPENBLAS_NUM_THREADS=1`` (BLAS pinned to one thread).
2. The ratio of the median wall times, cli / baseline, with the ratios of the minima and of the
   median CPU times beside it; a final PASS/FAIL line against the target ratio ≤ 1.15.
3. What the CLI imports beyond the baseline: one ``python -X importtime`` run of each command,
   the self time of every module only the CLI imports, summed per top-level package, and the
   largest such modules (diagnostic only: import times under ``-X importtime`` are inflated).

Outputs (in ``--out``, default benchmarks/out/): ``startup.json`` (SI units; keys in
:data:`JSON_KEYS`) and ``startup.csv`` (one row per timed run: round, command, wall_s, cpu_s).
Run ``python benchmarks/bench_startup.py [--quick] [--repeats N] [--out DIR]``. No test asserts
these times; tests/benchmarks/test_fits_and_io.py runs it with ``--quick --repeats 1`` and checks the
keys.
"""

from __future__ import annotations

import os

os.environ["OPENBLAS_NUM_THREADS"] = "1"  # this process too, before NumPy loads (machine facts)

import json  # noqa: E402
import re  # noqa: E402
import resource  # noqa: E402
import shutil  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/_common.py, from any cwd
from _common import (  # noqa: E402
    machine_facts,
    parse_args,
    pf,
    print_machine,
    report_head,
    run_end,
    write_csv,
    write_json,
)

SCHEMA = "viscoforce.bench_startup/1"
TARGET_RATIO = 1.15  # median wall time of the CLI / that of the baseline
DEFAULT_REPEATS = 21
QUICK_REPEATS = 5
PINNED_ENV = {"OPENBLAS_NUM_THREADS": "1"}
#: The case table: the two commands timed alternately, each a fresh process: ``cli``, the
#: viscoforce console script with ``args``; ``baseline``, this interpreter running ``code`` (the
#: same --quick, with fewer rounds).
CASES = ({"name": "cli", "args": ("static", "--h0=-5nm", "--E", "1e9", "--json")},
         {"name": "baseline",
          "code": "import xarray, scipy.linalg, scipy.special; xarray.Dataset({'a': ('x', [1.0])})"})
CLI_ARGS = CASES[0]["args"]
BASELINE_CODE = CASES[1]["code"]
TOP_IMPORTS = 12  # largest CLI-only modules listed
#: Top-level keys of startup.json.
JSON_KEYS = ("schema", "created", "quick", "machine", "target", "settings", "results", "ratio",
             "extra_imports", "summary", "files")

_IMPORTTIME_RE = re.compile(r"import time:\s+(\d+) \|\s+(\d+) \|( *)(\S+)")


def cli_command() -> list[str]:
    """``viscoforce`` (the console script of this interpreter's environment) or ``-m viscoforce``."""
    script = Path(sys.executable).with_name("viscoforce")
    if not script.is_file():
        found = shutil.which("viscoforce")
        script = Path(found) if found else None
    if script is not None and script.is_file():
        return [str(script), *CLI_ARGS]
    return [sys.executable, "-m", "viscoforce", *CLI_ARGS]


def child_env() -> dict[str, str]:
    """The environment of every child: ours with BLAS pinned to one thread."""
    return dict(os.environ, **PINNED_ENV)


def run_once(command: list[str], env: dict[str, str]) -> tuple[float, float, str]:
    """Run ``command``; return its wall time [s], CPU time (user + system) [s] and stdout."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(command, env=env, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed ({proc.returncode}):\n{proc.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.stdout


def check_cli_output(stdout: str) -> None:
    """The CLI must have printed its JSON object with a load."""
    result = json.loads(stdout)
    if "force" not in result:
        raise SystemExit(f"unexpected CLI output: {stdout!r}")


def time_commands(commands: dict[str, list[str]], repeats: int,
                  warmup: bool = True) -> list[dict]:
    """One warm-up run of each command (unless not ``warmup``: --quick), then ``repeats``
    alternating rounds; one row per timed run. The CLI's first output is checked."""
    env = child_env()
    checked = False
    if warmup:
        for name, command in commands.items():
            _, _, out = run_once(command, env)
            if name == "cli":
                check_cli_output(out)
                checked = True
    rows = []
    for i in range(repeats):
        order = list(commands) if i % 2 == 0 else list(reversed(commands))
        for name in order:
            wall, cpu, out = run_once(commands[name], env)
            if name == "cli" and not checked:
                check_cli_output(out)
                checked = True
            rows.append({"round": i, "command": name, "wall_s": wall, "cpu_s": cpu})
    return rows


def statistics_of(rows: list[dict], name: str) -> dict:
    """Median and minimum wall time, median CPU time and run count of one command."""
    wall = [r["wall_s"] for r in rows if r["command"] == name]
    cpu = [r["cpu_s"] for r in rows if r["command"] == name]
    return {"time_median_s": statistics.median(wall), "time_min_s": min(wall),
            "cpu_median_s": statistics.median(cpu), "runs": len(wall)}


def importtime(command: list[str], env: dict[str, str]) -> dict[str, int]:
    """Self import time [µs] of every module ``command`` imports (one ``-X importtime`` run)."""
    if Path(command[0]).name.startswith("python") or command[0] == sys.executable:
        argv = [command[0], "-X", "importtime", *command[1:]]
    else:  # a console script: run its module with the same interpreter
        argv = [sys.executable, "-X", "importtime", "-m", "viscoforce", *command[1:]]
    proc = subprocess.run(argv, env=env, capture_output=True, text=True, check=False)
    out: dict[str, int] = {}
    for line in proc.stderr.splitlines():
        m = _IMPORTTIME_RE.match(line)
        if m:
            out[m[4]] = out.get(m[4], 0) + int(m[1])
    return out


def extra_imports(commands: dict[str, list[str]]) -> dict:
    """Modules only the CLI imports: self time per top-level package and the largest modules."""
    env = child_env()
    cli, base = importtime(commands["cli"], env), importtime(commands["baseline"], env)
    extra = {m: t for m, t in cli.items() if m not in base}
    packages = Counter()
    for module, t in extra.items():
        packages[module.split(".")[0]] += t
    largest = sorted(extra.items(), key=lambda kv: -kv[1])[:TOP_IMPORTS]
    return {"note": "self times of one `python -X importtime` run (inflated by the tracing); "
                    "modules the baseline also imports are left out",
            "cli_modules": len(cli), "baseline_modules": len(base), "extra_modules": len(extra),
            "extra_self_time_s": sum(extra.values()) * 1e-6,
            "by_package_s": {k: v * 1e-6 for k, v in packages.most_common()},
            "largest_s": {k: v * 1e-6 for k, v in largest}}


def print_results(results: dict, ratio: dict, extra: dict, repeats: int, warmup: int) -> None:
    print(f"{repeats} alternating runs of each command after {'one' if warmup else 'no'} warm-up "
          "run of each")
    print(f"{'command':<9} {'median [s]':>11} {'min [s]':>9} {'cpu median [s]':>15}")
    for name, r in results.items():
        print(f"{name:<9} {r['time_median_s']:11.3f} {r['time_min_s']:9.3f} "
              f"{r['cpu_median_s']:15.3f}")
    print(f"ratio cli/baseline: median {ratio['median']:.3f}, min {ratio['min']:.3f}, "
          f"cpu median {ratio['cpu_median']:.3f}")
    packages = ", ".join(f"{k} {v * 1e3:.0f} ms" for k, v in extra["by_package_s"].items())
    print(f"imported only by the CLI ({extra['extra_modules']} modules, -X importtime self "
          f"time): {packages or 'nothing'}")
    for module, t in list(extra["largest_s"].items())[:6]:
        print(f"  {module:<48} {t * 1e3:7.1f} ms")


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__,
                      quick_help=f"smoke run: {QUICK_REPEATS} rounds instead of {DEFAULT_REPEATS}, "
                                 "no warm-up run",
                      repeats_help=f"timed rounds per command (default {DEFAULT_REPEATS}, "
                                   f"{QUICK_REPEATS} with --quick)")
    repeats = args.repeats or (QUICK_REPEATS if args.quick else DEFAULT_REPEATS)
    t_start = time.perf_counter()
    machine = machine_facts()
    commands = {c["name"]: cli_command() if c["name"] == "cli" else [sys.executable, "-c", c["code"]]
                for c in CASES}
    print("viscoforce start-up: a whole `viscoforce static` process against a bare "
          "xarray/scipy one")
    print_machine(machine)
    print("BLAS pinned to one thread in every child: OPENBLAS_NUM_THREADS=1")
    for name, command in commands.items():
        print(f"{name:<9} {' '.join(command)}")

    warmup = 0 if args.quick else 1
    rows = time_commands(commands, repeats, warmup=bool(warmup))
    results = {name: statistics_of(rows, name) for name in commands}
    cli, base = results["cli"], results["baseline"]
    ratio = {"median": cli["time_median_s"] / base["time_median_s"],
             "min": cli["time_min_s"] / base["time_min_s"],
             "cpu_median": cli["cpu_median_s"] / base["cpu_median_s"]}
    extra = extra_imports(commands)
    print_results(results, ratio, extra, repeats, warmup)

    passed = ratio["median"] <= TARGET_RATIO
    verdict = pf(passed)
    print(f"summary: start-up ratio {ratio['median']:.3f} (median wall time, cli/baseline), "
          f"target <= {TARGET_RATIO}: {verdict}")

    args.out.mkdir(parents=True, exist_ok=True)
    json_path, csv_path = args.out / "startup.json", args.out / "startup.csv"
    write_csv(rows, csv_path)
    summary = {"ratio": ratio["median"], "passed": passed, "verdict": verdict,
               **run_end(t_start)}
    report = {
        **report_head(SCHEMA, args.quick, machine),
        "target": {"ratio": TARGET_RATIO, "statistic": "median wall time, cli / baseline"},
        "settings": {"repeats": repeats, "warmup_runs": warmup, "env": PINNED_ENV,
                     "commands": commands, "alternating": True},
        "results": results,
        "ratio": ratio,
        "extra_imports": extra,
        "summary": summary,
        "files": {"json": str(json_path), "csv": str(csv_path)},
    }
    write_json(report, json_path)
    print(f"wrote {json_path} and {csv_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
