#!/usr/bin/env python
"""Map benchmark: svda maps in this process, on a 2-worker local cluster, by the cost model, and by the CLI.

What it measures, on synthetic svda maps of 4x4, 16x16 and 64x64 pixels (spectra of the svda
closed form at h0 = 2 nm with the paper's R, P and Debye length, E_inf and tau varying over the
map, 1 % seeded noise in stiffness and phase and those stderr columns; 30 frequencies):

1. ``fit_map(ds, "svda", ...)`` on the in-memory map, three ways, each with ``progress=False``:

   - ``in_process``: ``scheduler="synchronous"``;
   - ``cluster``: ``workers=2``, a local cluster started and closed inside the call (start-up
     included);
   - ``auto``: neither, so that the cost model of viscoforce.fitting.map_cost chooses; its
     choice (``attrs["execution"]``), expectation and measured per-pixel costs are recorded.
2. ``cli``: ``viscoforce fit MAP.nc --model svda --h0 2nm --json --out fits.nc`` in a child
   process (the console script of this interpreter). Its overhead is its wall time minus the
   API's ``auto`` time (the same choice, made by the same cost model). The CLI's start-up is the
   same command on a 1x2 map (its fixed cost: interpreter, imports, argument parsing, reading
   and writing netCDF; the two fits take ~5 ms); for reference, a child that only imports
   ``viscoforce.cli``, ``viscoforce.cli.fitting``, ``viscoforce.fitting.maps`` and
   ``viscoforce.fitting.fit`` is timed too. A CLI that fits on a cluster also imports the
   cluster library (dask.distributed), which the 1x2 map (fitted in-process) never does and
   which the API's process has imported since its first cluster: where the CLI's child chose
   the cluster, its start-up is that plus the import, measured as the median time of a child
   importing the fit modules and ``distributed`` minus that of the child importing the fit
   modules only.

3. ``capacity``: what two processes get from the machine at that moment: a pure-Python loop
   (:data:`SPIN`) alone, then twice at once in two child processes; capacity = 2 x alone /
   together (2.0 on two free cores, less while other processes use them). Measured once per
   round, beside the fits, so that the speed-up can be read against it.

4. ``schedule`` (issue 41 item 5: does the cost model see the host?): two real-sized maps, the
   bundled example ``sls_spectrum_map.nc`` (4x4 spectra, the exact model at h0 = -5 nm on the
   CLI's default system) and the PyFMRheo force map
   ``/work/shared/data/real/PyFMRheo/map-data-2022.10.29-12.27.34.564.jpk-force-map`` (16
   curves, hertz with ``tip="sphere:5um"``; skipped where the file is absent), each in
   :data:`SCHEDULE_ROUNDS` interleaved rounds of ``auto`` (the cost model's choice),
   ``in_process`` and ``cluster`` (the order rotating), after one untimed round of each (so that
   every timed cluster is a later one of the process, as the cost model knows); within a round
   a way is called again until its calls add up to :data:`SCHEDULE_MIN_S` and timed by their
   mean. Per round the
   host's 2-process capacity is measured beside the fits (``capacity``, as above) and the cost
   model's own capacity probe is read from ``attrs["parallel_capacity"]`` (NaN where it did
   not need one). Target: median(``auto``) <= :data:`TARGET` ``schedule_ratio`` x the smaller of
   the medians of ``in_process`` and ``cluster``, printed as that ratio, PASS/FAIL.

Every size is timed ``--repeats`` rounds (default 3; the order of the ways rotates from round to
round, so that load from other processes spreads over all of them); medians are reported.
Checks, printed PASS/FAIL:

- 64x64 on 2 workers (``cluster``) <= 10 s;
- speed-up = ``in_process`` / ``cluster`` on 64x64 >= 1.6 where the cost model chooses the
  cluster (otherwise reported, not judged);
- the cost model's time within 10 % (or 0.05 s) of the better of ``in_process`` and ``cluster``,
  for every size;
- CLI - API <= the CLI's start-up (+ the cluster library's import where the CLI fitted on a
  cluster) + 0.5 s (what grows with the map: reading it, writing fits.nc, the summary), every
  size;
- the schedule maps (part 4): median(``auto``) / min(median(``in_process``),
  median(``cluster``)) <= 1.05, over :data:`SCHEDULE_ROUNDS` rounds (``--repeats`` overrides).

BLAS is pinned to one thread (OPENBLAS/OMP/MKL_NUM_THREADS=1 before NumPy loads; inherited by
the cluster's workers and the CLI children). Outputs (in ``--out``, default benchmarks/out/):
``maps.json`` (keys in :data:`JSON_KEYS`), ``maps.csv`` (one row per timed run) and
``maps.png`` (median times per size and way). ``--quick``: the 4x4 map in this process and by the
cost model only, one round (no cluster, no CLI; a smoke run of a few seconds).
Run ``python benchmarks/bench_maps.py [--quick] [--repeats N] [--out DIR]``. No test asserts
these times; tests/benchmarks/test_fits_and_io.py runs it with ``--quick`` and checks the keys.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # this process, the forked workers and the CLI children

import json  # noqa: E402
import shutil  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import warnings  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))  # benchmarks/_common.py, from any cwd
import numpy as np  # noqa: E402
from _common import (  # noqa: E402
    load_average,
    machine_facts,
    parse_args,
    pf,
    print_machine,
    report_head,
    run_end,
    write_csv,
    write_json,
)

SCHEMA = "viscoforce.bench_maps/1"
DEFAULT_REPEATS = 3
WAYS = ("in_process", "cluster", "auto", "cli")
#: Ways of the schedule maps (part 4 of the module docstring), and their rounds.
SCHEDULE_WAYS = ("auto", "in_process", "cluster")
SCHEDULE_ROUNDS = 7
#: A schedule map's way is called again within a round until its calls add up to this [s]; the
#: round's time is their mean (a map fitted in 40 ms would otherwise be timed to the noise).
SCHEDULE_MIN_S = 0.5
REAL_MAP = Path("/work/shared/data/real/PyFMRheo/map-data-2022.10.29-12.27.34.564.jpk-force-map")
#: The case table: one n × n svda map per row (``size``), timed each of its ``ways`` (of
#: :data:`WAYS`), then the schedule maps (``map``: part 4), timed :data:`SCHEDULE_WAYS`.
CASES = (*({"size": n, "ways": WAYS} for n in (4, 16, 64)),
         {"map": "exact_example", "model": "exact", "ways": SCHEDULE_WAYS},
         {"map": "hertz_pyfmrheo", "model": "hertz", "ways": SCHEDULE_WAYS})
#: --quick: the 4x4 map in this process and by the cost model (no cluster, no CLI).
QUICK_CASES = ({"size": 4, "ways": ("in_process", "auto")},)
TARGET = {"cluster_64_s": 10.0, "speedup_64": 1.6, "auto_rel": 0.10, "auto_abs_s": 0.05,
          "cli_margin_s": 0.5, "schedule_ratio": 1.05}
OMEGA = np.geomspace(10.0, 1e6, 30)
NOISE = 0.01
POSITION = 2e-9
STARTUP_CODE = ("import viscoforce.cli, viscoforce.cli.fitting, viscoforce.fitting.maps, "
                "viscoforce.fitting.fit")
SPIN = 3_000_000  # iterations of the capacity loop (~0.25 s alone on this machine)
#: Top-level keys of maps.json.
JSON_KEYS = ("schema", "created", "quick", "machine", "target", "settings", "startup",
             "capacity", "results", "checks", "summary", "files", "wall_time_s", "loadavg_end")


def svda_map(n: int, seed: int = 0):
    """An n x n svda spectrum map (module docstring) as a viscoforce spectrum dataset."""
    from viscoforce import PAPER
    from viscoforce.schema import make_spectrum
    from viscoforce.svda import svda_complex_stiffness

    rng = np.random.default_rng(seed)
    e_inf = PAPER.E_inf * (1 + 0.3 * rng.random((n, n)))
    tau = PAPER.tau * (1 + 0.5 * rng.random((n, n)))
    k = np.empty((n, n, OMEGA.size), complex)
    with warnings.catch_warnings():  # the SVDA's validity estimate at 2 nm: the truth is the SVDA
        warnings.simplefilter("ignore")
        for i in range(n):
            for j in range(n):
                k[i, j] = svda_complex_stiffness(OMEGA, POSITION, PAPER.E0, e_inf[i, j],
                                                 tau[i, j], PAPER.R, PAPER.P, PAPER.debye_length)
    k = k * (1 + NOISE * rng.standard_normal(k.shape)) * np.exp(
        1j * NOISE * rng.standard_normal(k.shape))
    return make_spectrum(OMEGA, k, np.full(k.shape, 1e-7), 1e-10,
                         stderr={"stiffness": NOISE * np.abs(k),
                                 "phase": np.full(k.shape, np.degrees(NOISE))},
                         dims=("y", "x", "omega"), source="synthetic")


def fixed_inputs() -> dict:
    """The svda model's fixed inputs of the synthetic maps (the CLI's defaults, and --h0 2nm)."""
    from viscoforce import PAPER

    return {"position": POSITION, "radius": PAPER.R, "P": PAPER.P,
            "debye_length": PAPER.debye_length}


def cli_command(data: Path, out: Path) -> list[str]:
    """``viscoforce fit DATA --model svda --h0 2nm --json --out OUT`` (console script if any)."""
    script = Path(sys.executable).with_name("viscoforce")
    if not script.is_file():
        found = shutil.which("viscoforce")
        script = Path(found) if found else None
    head = [str(script)] if script is not None and script.is_file() else [
        sys.executable, "-m", "viscoforce"]
    return [*head, "fit", str(data), "--model", "svda", "--h0", "2nm", "--json",
            "--out", str(out)]


def schedule_map(name: str):
    """The dataset, model and fixed inputs of a schedule map (part 4), or None without its file."""
    import xarray as xr

    import viscoforce as vf

    if name == "hertz_pyfmrheo":
        if not REAL_MAP.is_file():
            return None
        from viscoforce.io.instruments import load_instrument

        return load_instrument(REAL_MAP), "hertz", {"tip": "sphere:5um"}
    from viscoforce.physics.materials import StandardLinearSolid
    from viscoforce.physics.paper import PAPER, paper_pressure_law
    from viscoforce.physics.particle import Particle
    from viscoforce.problem import ContactProblem

    with xr.open_dataset(vf.example_path("sls_spectrum_map.nc")) as opened:
        ds = opened.load()
    a = ds.attrs  # the system the example was made with (the CLI's defaults)
    problem = ContactProblem.create(
        sphere=Particle(a["radius"]),
        surface_force=paper_pressure_law(a["P"], a["debye_length"], a["Pw"], a["z0"]),
        material=StandardLinearSolid(PAPER.E0, PAPER.E_inf, PAPER.tau),
        deepest_position=-5e-9 - 2 * a["debye_length"])
    return ds, "exact", {"position": -5e-9, "problem": problem}


def run_api(ds, way: str, model: str = "svda", fixed: dict | None = None) -> tuple[float, dict]:
    """Wall time [s] of one ``fit_map`` call of ``way`` and the result's execution attrs."""
    from viscoforce.fitting.maps import fit_map

    options = {"in_process": {"scheduler": "synchronous"}, "cluster": {"workers": 2},
               "auto": {}}[way]
    t0 = time.perf_counter()
    with warnings.catch_warnings():  # the models' validity notes on real data: not timed here
        warnings.simplefilter("ignore")
        result = fit_map(ds, model, progress=False, **options,
                         **(fixed_inputs() if fixed is None else fixed))
    wall = time.perf_counter() - t0
    attrs = {k: result.attrs[k] for k in (
        "execution", "execution_reason", "expected_time_s", "pixel_cost_estimated_s",
        "pixel_cost_measured_s", "pixels_in_process", "cluster_startup_s", "n_good", "n_fits",
        "parallel_capacity")}
    return wall, attrs


def time_schedule(case: dict, rounds: int, rows: list[dict]) -> dict | None:
    """Part 4 on one schedule map: interleaved rounds, the capacity per round; None if absent."""
    loaded = schedule_map(case["map"])
    if loaded is None:
        print(f"{case['map']}: skipped ({REAL_MAP} absent)")
        return None
    ds, model, fixed = loaded
    ways = case["ways"]
    for way in ways:  # untimed: imports, caches, and this process's first local cluster
        run_api(ds, way, model, fixed)
    walls: dict[str, list[float]] = {w: [] for w in ways}
    seen: dict[str, list[dict]] = {w: [] for w in ways}
    per_round = []
    for r in range(rounds):
        host = capacity()
        order = ways[r % len(ways):] + ways[:r % len(ways)]
        line = {"round": r, "capacity": host}
        for way in order:
            wall, attrs = run_api(ds, way, model, fixed)
            calls = [wall]
            while sum(calls) < SCHEDULE_MIN_S:  # a small map: the mean of enough calls
                calls.append(run_api(ds, way, model, fixed)[0])
            wall = statistics.mean(calls)
            walls[way].append(wall)
            seen[way].append(attrs)
            line[way] = wall
            if way == "auto":
                line["choice"] = attrs["execution"]
                line["parallel_capacity"] = float(attrs["parallel_capacity"])
            rows.append({"size": case["map"], "pixels": attrs["n_fits"], "round": r, "way": way,
                         "wall_s": wall, "execution": attrs["execution"],
                         "cluster_startup_s": attrs.get("cluster_startup_s", float("nan")),
                         "loadavg_1min": (load_average() or [None])[0], "capacity": host,
                         "parallel_capacity": attrs["parallel_capacity"]})
        per_round.append(line)
        probe = line["parallel_capacity"]
        probe_text = f"{probe:.2f}" if probe == probe else "not needed"
        print(f"  {case['map']} round {r}: host capacity {host:.2f}, cost model's probe "
              f"{probe_text}; auto {line['auto']:.2f} s ({line['choice']}), "
              f"in-process {line['in_process']:.2f} s, cluster {line['cluster']:.2f} s")
        sys.stdout.flush()
    out = {"pixels": seen["auto"][0]["n_fits"], "model": model, "rounds": per_round}
    for way in ways:
        out[way] = {"time_median_s": statistics.median(walls[way]),
                    "time_min_s": min(walls[way]), "runs": len(walls[way]),
                    "executions": sorted({a["execution"] for a in seen[way]}),
                    "n_good": seen[way][0]["n_good"]}
    out["auto"]["reasons"] = [a["execution_reason"] for a in seen["auto"]]
    for key in ("expected_time_s", "pixel_cost_estimated_s", "pixel_cost_measured_s",
                "pixels_in_process"):
        out["auto"][key] = statistics.median(float(a[key]) for a in seen["auto"])
    out["auto"]["chose_cluster"] = sum(a["execution"].startswith("local cluster")
                                       for a in seen["auto"])
    return out


def run_cli(data: Path, out: Path) -> tuple[float, dict]:
    """Wall time [s] of one CLI fit of ``data`` and the execution attrs of its output file."""
    import xarray as xr

    t0 = time.perf_counter()
    proc = subprocess.run(cli_command(data, out), capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"the CLI failed ({proc.returncode}):\n{proc.stderr}")
    json.loads(proc.stdout)
    with xr.open_dataset(out) as fits:
        attrs = {k: fits.attrs[k] for k in ("execution", "execution_reason", "n_good", "n_fits")}
    return wall, attrs


def cli_startup(rounds: int, tmp: Path) -> dict:
    """Median wall time [s] of the CLI fit of a 1x2 map, and of a child importing only."""
    from viscoforce._files import write_netcdf

    data = tmp / "svda-1x2.nc"
    write_netcdf(svda_map(2).isel(y=[0]), data)
    walls, imports, cluster_imports = [], [], []
    for _ in range(rounds):
        walls.append(run_cli(data, tmp / "fits-1x2.nc")[0])
        for code, times in ((STARTUP_CODE, imports),
                            (STARTUP_CODE + ", distributed", cluster_imports)):
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-c", code], check=True)
            times.append(time.perf_counter() - t0)
    base = statistics.median(imports)
    return {"time_median_s": statistics.median(walls), "time_min_s": min(walls),
            "runs": len(walls), "imports_median_s": base, "imports_code": STARTUP_CODE,
            "cluster_import_s": max(0.0, statistics.median(cluster_imports) - base)}


def _spin(n: int = SPIN) -> int:
    total = 0
    for i in range(n):
        total += i * i
    return total


def capacity() -> float:
    """2 x (the loop alone) / (the loop in two processes at once): the machine's 2-process speed-up
    now."""
    import multiprocessing

    t0 = time.perf_counter()
    _spin()
    alone = time.perf_counter() - t0
    ctx = multiprocessing.get_context("fork" if "fork" in multiprocessing.get_all_start_methods()
                                      else "spawn")
    t0 = time.perf_counter()
    procs = [ctx.Process(target=_spin) for _ in range(2)]
    for p in procs:
        p.start()
    for p in procs:
        p.join()
    return 2 * alone / (time.perf_counter() - t0)


def time_size(n: int, ways: tuple[str, ...], repeats: int, tmp: Path, rows: list[dict],
              capacities: list[float]) -> dict:
    """All ways on the n x n map, ``repeats`` rotated rounds; per way medians and choices."""
    ds = svda_map(n)
    data = tmp / f"svda-{n}x{n}.nc"
    if "cli" in ways:
        from viscoforce._files import write_netcdf

        write_netcdf(ds, data)
    walls: dict[str, list[float]] = {w: [] for w in ways}
    seen: dict[str, list[dict]] = {w: [] for w in ways}
    for r in range(repeats):
        if "cluster" in ways:
            capacities.append(capacity())
        order = ways[r % len(ways):] + ways[:r % len(ways)]
        for way in order:
            if way == "cli":
                wall, attrs = run_cli(data, tmp / f"fits-{n}.nc")
            else:
                wall, attrs = run_api(ds, way)
            walls[way].append(wall)
            seen[way].append(attrs)
            rows.append({"size": f"{n}x{n}", "pixels": n * n, "round": r, "way": way,
                         "wall_s": wall, "execution": attrs["execution"],
                         "cluster_startup_s": attrs.get("cluster_startup_s", float("nan")),
                         "loadavg_1min": (load_average() or [None])[0]})
    out = {"pixels": n * n}
    for way in ways:
        attrs = seen[way]
        out[way] = {"time_median_s": statistics.median(walls[way]),
                    "time_min_s": min(walls[way]), "runs": len(walls[way]),
                    "executions": sorted({a["execution"] for a in attrs}),
                    "n_good": attrs[0]["n_good"]}
        if way == "cluster":
            out[way]["cluster_startup_median_s"] = statistics.median(
                float(a["cluster_startup_s"]) for a in attrs)
        if way == "auto":
            out[way]["reasons"] = [a["execution_reason"] for a in attrs]
            for key in ("expected_time_s", "pixel_cost_estimated_s", "pixel_cost_measured_s",
                        "pixels_in_process"):
                out[way][key] = statistics.median(float(a[key]) for a in attrs)
    return out


def judge(results: dict, startup: dict, quick: bool) -> dict:
    """The PASS/FAIL checks of the module docstring (None where a check does not apply)."""
    checks: dict = {}
    big = results.get("64x64")
    if big and "cluster" in big:
        cluster_s = big["cluster"]["time_median_s"]
        speedup = big["in_process"]["time_median_s"] / cluster_s
        chose_cluster = any(e.startswith("local cluster") for e in big["auto"]["executions"])
        checks["cluster_64"] = {"value_s": cluster_s, "target_s": TARGET["cluster_64_s"],
                                "passed": cluster_s <= TARGET["cluster_64_s"]}
        checks["speedup_64"] = {"value": speedup, "target": TARGET["speedup_64"],
                                "cluster_chosen": chose_cluster,
                                "passed": speedup >= TARGET["speedup_64"] if chose_cluster
                                else None}
    for size, res in results.items():
        if "rounds" in res:  # a schedule map (part 4): the ratio to the better way
            best = min(res[w]["time_median_s"] for w in ("in_process", "cluster"))
            ratio = res["auto"]["time_median_s"] / best
            checks[f"schedule_{size}"] = {
                "ratio": ratio, "target": TARGET["schedule_ratio"],
                "auto_s": res["auto"]["time_median_s"], "best_s": best,
                "capacities": [r["capacity"] for r in res["rounds"]],
                "chose_cluster": res["auto"]["chose_cluster"], "rounds": len(res["rounds"]),
                "passed": ratio <= TARGET["schedule_ratio"]}
            continue
        options = [res[w]["time_median_s"] for w in ("in_process", "cluster") if w in res]
        best = min(options)
        auto = res["auto"]["time_median_s"]
        allowed = max(best * (1 + TARGET["auto_rel"]), best + TARGET["auto_abs_s"])
        checks[f"auto_{size}"] = {"value_s": auto, "best_s": best, "allowed_s": allowed,
                                  "choice": res["auto"]["executions"],
                                  "passed": auto <= allowed}
        if "cli" in res:
            over = res["cli"]["time_median_s"] - auto
            on_cluster = any(e.startswith("local cluster") for e in res["cli"]["executions"])
            imports = startup.get("cluster_import_s", 0.0) if on_cluster else 0.0
            allowed = startup["time_median_s"] + imports + TARGET["cli_margin_s"]
            checks[f"cli_{size}"] = {"overhead_s": over, "allowed_s": allowed,
                                     "cluster_import_s": imports, "passed": over <= allowed}
    judged = [c["passed"] for c in checks.values() if c["passed"] is not None]
    return {"checks": checks, "summary": {"passed": all(judged), "verdict": pf(all(judged)),
                                          "judged": len(judged), "quick": quick}}


def plot(results: dict, path: Path) -> None:
    """Bars of the median times per map size and way (log time axis)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sizes = list(results)
    ways = [w for w in WAYS if any(w in results[s] for s in sizes)]
    fig, ax = plt.subplots(figsize=(7, 4))
    width = 0.8 / len(ways)
    for j, way in enumerate(ways):
        values = [results[s][way]["time_median_s"] if way in results[s] else np.nan
                  for s in sizes]
        ax.bar(np.arange(len(sizes)) + j * width, values, width, label=way.replace("_", "-"))
    ax.set_xticks(np.arange(len(sizes)) + width * (len(ways) - 1) / 2, sizes)
    ax.set_yscale("log")
    ax.set_ylabel("median wall time [s]")
    ax.set_title("svda maps: in-process, 2-worker cluster, cost model, CLI")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def print_results(results: dict, startup: dict | None) -> None:
    from viscoforce.fitting.map_cost import start_method

    if startup is not None:
        print(f"CLI start-up (the fit command on a 1x2 map): {startup['time_median_s']:.2f} s "
              f"median of {startup['runs']} (a child only importing the fit modules: "
              f"{startup['imports_median_s']:.2f} s; importing dask.distributed as well: "
              f"+{startup['cluster_import_s']:.2f} s)")
    for size, res in results.items():
        if "rounds" in res:
            print(f"{size} ({res['pixels']} pixels, {res['model']}): " + ", ".join(
                f"{w} {res[w]['time_median_s']:.2f} s" for w in SCHEDULE_WAYS) + " (medians)")
            continue
        parts = [f"{w} {res[w]['time_median_s']:.2f} s" for w in WAYS if w in res]
        auto = res["auto"]
        print(f"{size} ({res['pixels']} pixels): " + ", ".join(parts))
        print(f"  cost model chose {' / '.join(auto['executions'])}: probe "
              f"{auto['pixel_cost_estimated_s'] * 1e3:.2f} ms/pixel, measured "
              f"{auto['pixel_cost_measured_s'] * 1e3:.2f} ms/pixel, expected "
              f"{auto['expected_time_s']:.2f} s for the pixels after the probe")
        if "cluster" in res:
            print(f"  2-worker cluster start-up + shut-down (start method {start_method()}): "
                  f"{res['cluster']['cluster_startup_median_s']:.2f} s median")
        if "cli" in res:
            print(f"  CLI chose {' / '.join(res['cli']['executions'])}")
    sys.stdout.flush()


def print_checks(judged: dict) -> None:
    for name, c in judged["checks"].items():
        verdict = "n/a (the cost model did not choose the cluster)" if c["passed"] is None \
            else pf(c["passed"])
        if name.startswith("schedule_"):
            caps = ", ".join(f"{x:.2f}" for x in c["capacities"])
            print(f"schedule on {name[9:]}: cost model's choice {c['auto_s']:.2f} s (cluster in "
                  f"{c['chose_cluster']} of {c['rounds']} rounds) / better of in-process and "
                  f"cluster {c['best_s']:.2f} s = {c['ratio']:.3f}, target <= "
                  f"{c['target']:g}: {verdict} (host capacity per round: {caps})")
        elif name == "cluster_64":
            print(f"64x64 svda map on 2 workers: {c['value_s']:.2f} s, target <= "
                  f"{c['target_s']:g} s: {verdict}")
        elif name == "speedup_64":
            print(f"speed-up in-process / 2-worker cluster on 64x64: {c['value']:.2f}x, target "
                  f">= {c['target']:g}x where the cluster is chosen: {verdict}")
        elif name.startswith("auto_"):
            print(f"cost model on {name[5:]} ({' / '.join(c['choice'])}): {c['value_s']:.2f} s "
                  f"against the better {c['best_s']:.2f} s, target <= {c['allowed_s']:.2f} s "
                  f"(10 % or 0.05 s): {verdict}")
        else:
            imports = (f" + {c['cluster_import_s']:.2f} s importing the cluster library"
                       if c["cluster_import_s"] else "")
            print(f"CLI - API on {name[4:]}: {c['overhead_s']:.2f} s, target <= "
                  f"{c['allowed_s']:.2f} s (start-up{imports} + {TARGET['cli_margin_s']:g} s): "
                  f"{verdict}")
    print(f"overall: {judged['summary']['verdict']}")


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv, doc=__doc__,
                      quick_help="the 4x4 map in this process and by the cost model, one round "
                                 "(no cluster, no CLI)",
                      repeats_help=f"rounds per map size (default {DEFAULT_REPEATS}; --quick 1)")
    repeats = args.repeats or (1 if args.quick else DEFAULT_REPEATS)
    cases = QUICK_CASES if args.quick else CASES
    sizes = [c["size"] for c in cases if "size" in c]
    ways = tuple(dict.fromkeys(w for c in cases for w in c["ways"]))
    t_start = time.perf_counter()
    machine = machine_facts()
    print("viscoforce maps: svda maps in-process, on 2 workers, by the cost model, by the CLI")
    print_machine(machine)
    print("BLAS pinned to one thread: OPENBLAS_NUM_THREADS=1 (this process, the workers, the "
          f"CLI children); load average at start {machine['loadavg_start']}")
    from viscoforce.fitting.map_cost import start_method

    args.out.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    results: dict = {}
    capacities: list[float] = []
    with tempfile.TemporaryDirectory(prefix="bench_maps_") as tmp:
        startup = cli_startup(max(3, repeats), Path(tmp)) if "cli" in ways else None
        if startup is not None:
            print_results({}, startup)
        for case in cases:
            if "map" in case:
                found = time_schedule(case, args.repeats or SCHEDULE_ROUNDS, rows)
                if found is not None:
                    results[case["map"]] = found
                    capacities += [r["capacity"] for r in found["rounds"]]
                    print_results({case["map"]: found}, None)
                continue
            n = case["size"]
            results[f"{n}x{n}"] = time_size(n, case["ways"], repeats, Path(tmp), rows, capacities)
            print_results({f"{n}x{n}": results[f"{n}x{n}"]}, None)
    machine_capacity = ({"median": statistics.median(capacities), "min": min(capacities),
                         "max": max(capacities), "runs": len(capacities)}
                        if capacities else None)
    if machine_capacity:
        print(f"2-process capacity of the machine during the run (2.0 = two free cores): median "
              f"{machine_capacity['median']:.2f} (min {machine_capacity['min']:.2f}, max "
              f"{machine_capacity['max']:.2f}, {machine_capacity['runs']} runs)")
    judged = judge(results, startup or {"time_median_s": 0.0}, args.quick)
    print_checks(judged)
    files = {"json": str(args.out / "maps.json"), "csv": str(args.out / "maps.csv"),
             "png": str(args.out / "maps.png")}
    report = {**report_head(SCHEMA, args.quick, machine), "target": TARGET,
              "settings": {"sizes": list(sizes), "ways": list(ways), "repeats": repeats,
                           "schedule_maps": [c["map"] for c in cases if "map" in c],
                           "frequencies": int(OMEGA.size), "noise": NOISE,
                           "position_m": POSITION, "start_method": start_method(),
                           "env": {k: os.environ[k] for k in (
                               "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}},
              "startup": startup, "capacity": machine_capacity, "results": results, **judged, "files": files,
              **run_end(t_start)}
    write_json(report, Path(files["json"]))
    write_csv(rows, Path(files["csv"]))
    plot(results, Path(files["png"]))
    print(f"wrote {files['json']}, {files['csv']}, {files['png']} "
          f"({report['wall_time_s']:.0f} s, load average at end {report['loadavg_end']})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
