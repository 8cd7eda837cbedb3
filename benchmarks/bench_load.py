#!/usr/bin/env python
"""Load benchmark: read and demodulate JPK modulation maps (the real 4x4 map, a synthetic 64x64 one).

What it measures:

1. ``real``: the 4x4 modulation map of ../shared/data/real/PyFMReader (skipped with a message when
   absent): ``load_instrument(path)`` then ``modulation_spectrum(curves)``; wall time of each,
   per-curve cost, tracemalloc peak of a second (traced) run and the process peak RSS.
2. ``synthetic``: a ``--grid`` x ``--grid`` map (default 64x64) with the real map's segment layout
   (extend, pause, six sine segments 300, 3, 100, 30, 1, 10 Hz, retract; its point counts and
   durations), written into a temporary folder with the property/encoder helpers of
   tests/io/test_jpk.py, then read and demodulated in blocks of ``--block`` curves: each block is
   ``modulation_spectrum(archive, curves=block)`` (the library path: ``jpk_to_curves`` then the
   lock-in; spectra concatenated along ``curve``), timed three ways:

   - ``dask``: one task per block on a ``LocalCluster(n_workers=2, threads_per_worker=1)`` (or
     the scheduler at ``--scheduler ADDRESS``); memory = peak RSS of the workers plus this process;
   - ``serial``: the same blocks one after the other in this process, on the first
     ``--serial-curves`` curves, extrapolated linearly to the whole map;
   - ``reopen``: ``--reopen-curves`` curves in one block that reads the map itself
     (``--open path``: ``read_jpk`` scans the member list and parses the zip's whole central
     directory per block), extrapolated: what not sharing an archive between blocks costs.

   By default (``--open archive``) the map is read once (``read_jpk``: member list, headers and
   the zip's central directory, timed inside the dask wall time) and its
   :class:`~viscoforce.io.jpk.JPKArchive` is what the blocks receive: sent once to every dask
   worker (``client.scatter(..., broadcast=True)``; it pickles with its member index and
   without its file handle), where it opens the file on its first block and keeps it open, and
   used directly by the serial run; ``--open path`` gives every block the path instead. One block is profiled
   (cProfile) and its time split into zip directory, inflation, property parsing, raw decoding,
   dataset building and lock-in.
3. PASS/FAIL of the dask run against the targets (<= 30 s, <= 1 GiB on 2 cores).

BLAS is pinned to one thread (OPENBLAS_NUM_THREADS=1 before NumPy loads, plus threadpoolctl) here
and in the local workers. Outputs (in ``--out``, default benchmarks/out/): ``load.json`` (keys in
:data:`JSON_KEYS`), ``load.csv`` (one row per timed run) and ``load.png`` (bar chart).
Run ``python benchmarks/bench_load.py [--quick] [--out DIR] [--scheduler ADDRESS]``. No test
asserts these times; tests/benchmarks/test_fits_and_io.py runs it with ``--quick`` and checks the keys.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # this process and the LocalCluster workers, before NumPy loads

import argparse  # noqa: E402
import cProfile  # noqa: E402
import math  # noqa: E402
import pstats  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
import tracemalloc  # noqa: E402
import zipfile  # noqa: E402
from contextlib import contextmanager  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from threadpoolctl import threadpool_info, threadpool_limits  # noqa: E402

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
sys.path.insert(0, str(HERE))   # benchmarks/_common.py
sys.path.insert(0, str(REPO))   # tests/io/test_jpk.py (archive helpers)
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

import viscoforce.io.jpk as jpk  # noqa: E402
from viscoforce.experiments.modulation import modulation_spectrum  # noqa: E402
from viscoforce.io.curves import jpk_to_curves  # noqa: E402
from viscoforce.io.instruments import load_instrument  # noqa: E402

SCHEMA = "viscoforce.bench_load/1"
REAL_MAP = REPO.parent / "shared" / "data" / "real" / "PyFMReader" / \
    "map-data-2021.11.05-17.37.44.432.jpk-force-map"
TARGET_S, TARGET_BYTES = 30.0, 2 ** 30
GIB = 2 ** 30
#: (style, type, points, duration [s], frequency [Hz] or None) of the real map's curves.
LAYOUT = (("extend", "z-extend-force", 1200, 0.6, None),
          ("pause", "constant-force-pause", 1024, 0.5, None),
          *(("modulation", "sine-z-modulation-segment-settings", n, periods / f, f)
            for f, n, periods in ((300.0, 2000, 20), (3.0, 2000, 10), (100.0, 4000, 20),
                                  (30.0, 4000, 20), (1.0, 1000, 5), (10.0, 4000, 20))),
          ("retract", "z-retract-height", 1200, 0.6, None))
AMPLITUDE = 1.5e-8            # height modulation amplitude [m], as in the real map
V_ENC_MULT = 1e-6             # finer vDeflection encoder than test_jpk's (2e-14 m per count)
HEIGHT0 = 2e-5                # absolute height of the contact point [m]
#: What a block receives: ``archive`` the JPKArchive read once (its member index travels with
#: it; one open file per process, kept across blocks), ``path`` the file (read_jpk per block).
OPEN_MODES = ("archive", "path")
#: The case table: the real 4x4 map (``--real``, skipped when absent) and the synthetic
#: ``grid`` × ``grid`` map, demodulated in blocks of ``block`` curves on dask, ``serial`` of its
#: curves timed in this process and ``reopen`` in one block that reads the map itself (the
#: command line's --grid, --block, --serial-curves, --reopen-curves override them).
CASES = ({"map": "real"},
         {"map": "synthetic", "grid": 64, "block": 16, "serial": 512, "reopen": 4})
#: --quick: a 4x4 synthetic map in blocks of 4.
QUICK_CASES = ({"map": "real"},
               {"map": "synthetic", "grid": 4, "block": 4, "serial": 8, "reopen": 2})
DEFAULT_GRID, QUICK_GRID = CASES[1]["grid"], QUICK_CASES[1]["grid"]  # for the help texts
#: Top-level keys of load.json.
JSON_KEYS = ("schema", "created", "quick", "machine", "target", "settings", "real", "synthetic",
             "summary", "files")


# ── memory ───────────────────────────────────────────────────────────────────────────────────────

def maxrss_bytes() -> int:
    """Peak resident set size of this process [bytes].

    VmHWM of /proc/self/status where there is one: Linux keeps ``ru_maxrss`` across fork + exec,
    so a spawned dask worker would report its parent's peak; VmHWM belongs to the process's own
    address space. Elsewhere ``ru_maxrss`` (KiB on Linux, bytes on macOS).
    """
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(rss) if sys.platform == "darwin" else int(rss) * 1024


@contextmanager
def traced(box: dict):
    """tracemalloc peak [bytes] of the block into ``box["peak_bytes"]``."""
    tracemalloc.start()
    try:
        yield
    finally:
        box["peak_bytes"] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()


# ── synthetic archive (helpers of tests/io/test_jpk.py) ──────────────────────────────────────────

def _helpers():
    """tests/io/test_jpk.py, whose serialiser, lcd-info and segment-settings helpers are reused."""
    try:
        from tests.io import test_jpk
    except ImportError:  # the layout before tests/io/
        from tests import test_jpk
    return test_jpk


def _lcd_blocks(t) -> dict[str, dict[str, str]]:
    blocks = {ch: t._lcd(ch) for ch in t.LCD}
    blocks["vDeflection"]["encoder.scaling.multiplier"] = repr(V_ENC_MULT)
    return blocks


def _shared_header(t) -> dict[str, str]:
    shared = {"lcd-infos.count": str(len(t.LCD))}
    for channel, block in _lcd_blocks(t).items():
        shared.update({f"lcd-info.{t.LCD[channel]}.{k}": v for k, v in block.items()})
    for s, (style, seg_type, n, duration, freq) in enumerate(LAYOUT):
        settings = t._segment_settings(style, seg_type, duration, n)
        if freq is not None:
            settings["settings.segment-settings.frequency"] = repr(freq)
            settings["settings.segment-settings.amplitude"] = repr(AMPLITUDE)
        shared.update({f"force-segment-header-info.{s}.{k}": v for k, v in settings.items()})
    return shared


def _signals(curve: int, rng: np.random.Generator) -> list[dict[str, np.ndarray]]:
    """SI height (= measuredHeight) and deflection [m] of every segment of one curve."""
    out, contact = [], 2e-8 * (1 + 0.2 * math.sin(curve))     # mean deflection in contact [m]
    for style, _, n, duration, freq in LAYOUT:
        tau = np.arange(n) * (duration / n)
        if style == "extend":
            rel, defl = 1e-6 * (1 - tau / duration), contact * tau / duration
        elif style == "retract":
            rel, defl = 1e-6 * tau / duration, contact * (1 - tau / duration)
        elif style == "pause":
            rel, defl = np.zeros(n), np.full(n, contact)
        else:
            w, lead = 2 * math.pi * freq, math.radians(10 + 8 * math.log10(freq))
            rel = -AMPLITUDE * np.sin(w * tau)             # height down = tip pushed in
            defl = contact + 0.2 * AMPLITUDE * np.sin(w * tau + lead)
        out.append({"height": HEIGHT0 + rel, "deflection": defl + 5e-11 * rng.standard_normal(n)})
    return out


def _encode(t, sig: dict[str, np.ndarray]) -> dict[str, bytes]:
    """Raw channel bytes that decode (test_jpk's conversion chains) to the SI signals."""
    h, d = sig["height"], sig["deflection"]
    raw = {"height": ((h / t.CAL_MULT - t.NOM_OFF) / t.NOM_MULT - t.H_OFF) / t.H_MULT,
           "measuredHeight": (h - t.S_NOM_OFF - t.S_OFF) / t.S_MULT,
           "vDeflection": ((d - t.DIST_OFF) / t.SENS - t.V_OFF) / V_ENC_MULT}
    return {ch: np.rint(v).astype(t.DTYPES[ch]).tobytes() for ch, v in raw.items()}


def write_synthetic_map(path: Path, grid: int, *, seed: int = 0) -> dict:
    """Write a ``grid`` x ``grid`` .jpk-force-map with :data:`LAYOUT`; return its facts."""
    t = _helpers()
    rng = np.random.default_rng(seed)
    pitch = 1e-7
    header = {"jpk-data-file": "spm-force-scan-map-file", "type": "force-scan-map",
              "force-scan-map.position-pattern.grid.unit.unit": "m",
              **{f"force-scan-map.position-pattern.grid.{k}": repr(v) for k, v in {
                  "ilength": grid, "jlength": grid, "ulength": grid * pitch,
                  "vlength": grid * pitch, "xcenter": 0.0, "ycenter": 0.0}.items()}}
    t0 = time.perf_counter()
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        zf.writestr("header.properties", t._serialise(header))
        zf.writestr("shared-data/header.properties", t._serialise(_shared_header(t)))
        for c in range(grid * grid):
            d = f"index/{c}/"
            curve = t._curve_header(c, "force-map")
            curve["force-scan-series.force-segments.count"] = str(len(LAYOUT))
            curve["force-scan-series.header.position.x"] = repr((c % grid - grid / 2) * pitch)
            curve["force-scan-series.header.position.y"] = repr((c // grid - grid / 2) * pitch)
            zf.writestr(d + "header.properties", t._serialise(curve))
            for s, ((_, _, n, duration, _), sig) in enumerate(zip(LAYOUT, _signals(c, rng),
                                                                  strict=True)):
                head = {"force-segment-header.num-points": str(n),
                        "force-segment-header.duration": repr(duration),
                        "force-segment-header.time-stamp": "2026-12-01 12:00:00.000 +0100",
                        "force-segment-header.baseline.baseline": repr(t.BASELINE_V),
                        "force-segment-header.baseline.measured": "true",
                        "force-segment-header.force-segment-header-info.*": str(s),
                        "channels.list": "height vDeflection measuredHeight"}
                for ch, data in _encode(t, sig).items():
                    head.update({f"channel.{ch}.lcd-info.*": str(t.LCD[ch]),
                                 f"channel.{ch}.data.file.name": f"channels/{ch}.dat",
                                 f"channel.{ch}.data.file.format": "raw",
                                 f"channel.{ch}.data.num-points": str(n)})
                    zf.writestr(f"{d}segments/{s}/channels/{ch}.dat", data)
                zf.writestr(f"{d}segments/{s}/segment-header.properties", t._serialise(head))
    with zipfile.ZipFile(path) as zf:
        members = len(zf.infolist())
    return {"path": str(path), "grid": grid, "curves": grid * grid, "members": members,
            "file_bytes": path.stat().st_size, "write_s": time.perf_counter() - t0,
            "points_per_curve": sum(s[2] for s in LAYOUT)}


# ── reading blocks ───────────────────────────────────────────────────────────────────────────────

def block_spectrum(source: jpk.JPKArchive | str, indices: list[int]) -> xr.Dataset:
    """Read curves ``indices`` and demodulate them (one dask task); see :data:`OPEN_MODES`.

    ``source`` is the map's JPKArchive (its file handle kept open across blocks) or its path
    (read and closed within the block).
    """
    with threadpool_limits(limits=1, user_api="blas"):
        spec = modulation_spectrum(source, curves=indices)
    return spec.assign_coords(curve=np.asarray(indices, dtype=np.int32))


def blocks_of(n: int, size: int) -> list[list[int]]:
    return [list(range(i, min(i + size, n))) for i in range(0, n, size)]


def concat(parts: list[xr.Dataset]) -> xr.Dataset:
    return xr.concat(parts, dim="curve", data_vars="minimal", coords="minimal",
                     compat="override", combine_attrs="drop_conflicts")


def check_spectrum(spec: xr.Dataset, n: int) -> dict:
    """Shape and sanity of the whole map's spectrum."""
    freqs = sorted(float(f) for f in spec["frequency"].values)
    ok = (spec.sizes["curve"] == n and freqs == [1.0, 3.0, 10.0, 30.0, 100.0, 300.0]
          and bool(np.isfinite(spec["stiffness"].values).all()))
    return {"curves": int(spec.sizes["curve"]), "frequencies_hz": freqs, "ok": ok,
            "stiffness_median_n_per_m": float(np.median(spec["stiffness"].values)),
            "phase_median_deg": float(np.median(spec["phase"].values))}


# ── the runs ─────────────────────────────────────────────────────────────────────────────────────

def run_real(path: Path, rows: list[dict]) -> dict:
    if not path.is_file():
        print(f"real map: {path} not found — skipped")
        return {"skipped": True, "path": str(path)}
    rss0 = maxrss_bytes()
    t0 = time.perf_counter()
    curves = load_instrument(path)
    t1 = time.perf_counter()
    spec = modulation_spectrum(curves)
    t2 = time.perf_counter()
    n = int(curves.sizes["curve"])
    rss1 = maxrss_bytes()
    box: dict = {}
    with traced(box):
        modulation_spectrum(load_instrument(path))
    res = {"skipped": False, "path": str(path), "curves": n,
           "samples": int(curves.sizes["sample"]), "load_s": t1 - t0, "spectrum_s": t2 - t1,
           "total_s": t2 - t0, "per_curve_s": (t2 - t0) / n,
           "tracemalloc_peak_bytes": box["peak_bytes"], "maxrss_before_bytes": rss0,
           "maxrss_after_bytes": rss1, "check": check_spectrum(spec, n)}
    rows.append({"part": "real", "mode": "load_instrument+modulation_spectrum", "curves": n,
                 "wall_s": res["total_s"], "per_curve_s": res["per_curve_s"],
                 "memory_bytes": res["tracemalloc_peak_bytes"], "extrapolated": False})
    print(f"real map ({n} curves): load {res['load_s']:.3f} s + spectrum {res['spectrum_s']:.3f} s "
          f"= {res['total_s']:.3f} s ({res['per_curve_s'] * 1e3:.1f} ms/curve); tracemalloc "
          f"peak {res['tracemalloc_peak_bytes'] / 2**20:.1f} MiB, process peak RSS "
          f"{rss1 / 2**20:.0f} MiB (before {rss0 / 2**20:.0f} MiB)")
    return res


def run_serial(path: Path, n: int, block: int, open_mode: str) -> dict:
    """Blocks one after the other in this process (``archive``: read once first, not timed)."""
    times, peaks = [], []
    t0 = time.perf_counter()
    source = jpk.read_jpk(path) if open_mode == "archive" else str(path)
    read_s = time.perf_counter() - t0
    try:
        for indices in blocks_of(n, block):
            box: dict = {}
            t0 = time.perf_counter()
            block_spectrum(source, indices)
            times.append(time.perf_counter() - t0)
            if not peaks:  # one traced block for its memory
                with traced(box):
                    block_spectrum(source, indices)
                peaks.append(box["peak_bytes"])
    finally:
        if isinstance(source, jpk.JPKArchive):
            source.close()
    total = sum(times)
    return {"curves": n, "blocks": len(times), "wall_s": total, "per_curve_s": total / n,
            "read_jpk_s": read_s, "block_tracemalloc_peak_bytes": peaks[0],
            "open_mode": open_mode}


def profile_block(path: Path, indices: list[int], open_mode: str) -> dict:
    """cProfile one block; split its time into the stages of reading and demodulating."""
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    archive = jpk.read_jpk(path)   # both modes read the map once here
    t_open = time.perf_counter()
    curves = jpk_to_curves(archive, curves=indices)
    archive.close()
    t_load = time.perf_counter()
    modulation_spectrum(curves)
    t_spec = time.perf_counter()
    prof.disable()
    stats = pstats.Stats(prof).stats

    def cum(file_part: str, func: str) -> float:
        return sum(v[3] for (f, _, fn), v in stats.items() if file_part in f and fn == func)

    stages = {"read_jpk_scan_s": t_open - t0,
              "zip_central_directory_s": cum("zipfile", "_RealGetContents"),
              "zlib_inflate_s": sum(v[3] for (_, _, fn), v in stats.items()
                                    if "decompress" in fn and "zlib" in fn),
              "property_parsing_s": cum("_properties", "parse_properties")
              + cum("_properties", "resolve_references"),
              "raw_decode_s": cum("_jpk_segments.py", "_decode_raw"),
              "jpk_to_curves_s": t_load - t_open,
              "lockin_modulation_spectrum_s": t_spec - t_load,
              "demodulate_s": cum("lockin", "demodulate") + cum("lockin", "harmonics")}
    return {"curves": len(indices), "open_mode": open_mode, "profiled_wall_s": t_spec - t0,
            "note": "cProfile cumulative times (inflated by profiling); stages overlap: "
                    "jpk_to_curves includes the zip directory, inflation, property parsing "
                    "and raw decoding", **stages}


def _worker_maxrss() -> int:
    return maxrss_bytes()


def _worker_blas() -> list:
    return sorted({d.get("num_threads") for d in threadpool_info() if d.get("user_api") == "blas"})


def run_dask(path: Path, n: int, block: int, open_mode: str, scheduler: str | None,
             workers: int) -> dict:
    from dask.distributed import Client, LocalCluster, wait
    cluster = None
    t_c0 = time.perf_counter()
    if scheduler:
        client = Client(scheduler)
    else:
        import dask

        # CPU-bound Python tasks: no statistical profiler thread in the workers (as fit_map)
        with dask.config.set({"distributed.worker.profile.enabled": False,
                              "distributed.admin.system-monitor.interval": "2s"}):
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None, memory_limit=0)  # measure, not cap
        client = Client(cluster)
    startup = time.perf_counter() - t_c0
    try:
        client.run(lambda: None)  # every worker up and importing
        info = client.scheduler_info()
        n_workers = len(info["workers"])
        threads = sum(w["nthreads"] for w in info["workers"].values())
        blas = client.run(_worker_blas)
        t0 = time.perf_counter()
        if open_mode == "archive":  # read once, one copy per worker (without its file handle)
            archive = jpk.read_jpk(path)
            source = client.scatter(archive, broadcast=True, hash=False)
            archive.close()
        else:
            source = str(path)
        t_read = time.perf_counter() - t0
        futures = [client.submit(block_spectrum, source, idx, pure=False)
                   for idx in blocks_of(n, block)]
        wait(futures)
        parts = client.gather(futures)
        t_tasks = time.perf_counter() - t0
        spec = concat(parts)
        wall = time.perf_counter() - t0
        rss = client.run(_worker_maxrss)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return {"curves": n, "blocks": len(futures), "wall_s": wall, "read_scatter_s": t_read,
            "tasks_s": t_tasks,
            "concat_s": wall - t_tasks, "cluster_startup_s": startup,
            "per_curve_s": wall / n, "workers": n_workers, "threads": threads,
            "worker_blas_threads": sorted({t for v in blas.values() for t in v}),
            "scheduler": scheduler or "LocalCluster", "open_mode": open_mode,
            "worker_peak_rss_bytes": sorted(rss.values()),
            "workers_peak_rss_sum_bytes": sum(rss.values()), "spectrum": spec}


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 3.6))
    labels = [f"{r['part']}\n{r['mode']}" + (" (extrap.)" if r["extrapolated"] else "")
              for r in rows]
    ax.barh(range(len(rows)), [r["wall_s"] for r in rows], color="tab:blue")
    ax.set_yticks(range(len(rows)), labels, fontsize=7)
    ax.axvline(TARGET_S, color="tab:red", ls="--", label=f"target {TARGET_S:g} s (synthetic)")
    ax.set_xscale("log")
    ax.set_xlabel("wall time [s]")
    ax.legend(fontsize=7)
    ax.set_title("JPK map: read + demodulate", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def parse(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help=f"smoke run: {QUICK_GRID}x{QUICK_GRID} synthetic map, blocks of "
                        f"{QUICK_CASES[1]['block']}")
    p.add_argument("--out", type=Path, default=OUT_DIR,
                   help="output folder (default: benchmarks/out next to this script)")
    p.add_argument("--scheduler", default=None,
                   help="address of a running dask scheduler (default: a LocalCluster)")
    p.add_argument("--workers", type=int, default=2, help="LocalCluster workers (default 2)")
    p.add_argument("--grid", type=int, default=None, help=f"synthetic map side (default "
                                                          f"{DEFAULT_GRID}, {QUICK_GRID} quick)")
    p.add_argument("--block", type=int, default=None, help="curves per task")
    p.add_argument("--serial-curves", type=int, default=None,
                   help=f"curves timed serially (default {CASES[1]['serial']}; 0: all)")
    p.add_argument("--reopen-curves", type=int, default=None,
                   help=f"curves timed in one block that reads the map itself (default "
                        f"{CASES[1]['reopen']}, {QUICK_CASES[1]['reopen']} quick)")
    p.add_argument("--open", dest="open_mode", choices=OPEN_MODES, default="archive",
                   help="what serial and dask blocks receive (default archive: the JPKArchive "
                        "read once, one open zip per process; path: the file, read per block)")
    p.add_argument("--real", type=Path, default=REAL_MAP, help="the real 4x4 map")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    synthetic = next(c for c in (QUICK_CASES if args.quick else CASES) if c["map"] == "synthetic")
    grid = args.grid or synthetic["grid"]
    block = args.block or synthetic["block"]
    n = grid * grid
    serial_n = args.serial_curves if args.serial_curves is not None else synthetic["serial"]
    serial_n = n if serial_n <= 0 else min(serial_n, n)
    reopen_n = min(args.reopen_curves or synthetic["reopen"], n)
    t_start = time.perf_counter()
    threadpool_limits(limits=1, user_api="blas")
    machine = machine_facts()
    print("viscoforce load: read + demodulate JPK modulation maps")
    print_machine(machine)
    print("BLAS pinned to one thread: OPENBLAS_NUM_THREADS=1 (this process and local workers) "
          "and threadpoolctl")
    rows: list[dict] = []
    real = run_real(args.real, rows)

    with tempfile.TemporaryDirectory(prefix="bench_load_") as tmp:
        path = Path(tmp) / f"synthetic-{grid}x{grid}.jpk-force-map"
        facts = write_synthetic_map(path, grid)
        print(f"synthetic {grid}x{grid} map: {facts['curves']} curves x "
              f"{facts['points_per_curve']} points, {facts['members']} members, "
              f"{facts['file_bytes'] / 2**20:.0f} MiB, written in {facts['write_s']:.1f} s")
        t0 = time.perf_counter()
        jpk.read_jpk(path)
        facts["read_jpk_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        with zipfile.ZipFile(path) as zf:
            facts["zip_open_s"] = time.perf_counter() - t0
            zf.close()
        print(f"read_jpk (scan of the member list and headers): {facts['read_jpk_s']:.2f} s; "
              f"zipfile.ZipFile(path) (central directory): {facts['zip_open_s']:.2f} s")

        rss_before = maxrss_bytes()
        dask_res = run_dask(path, n, block, args.open_mode, args.scheduler, args.workers)
        spec = dask_res.pop("spectrum")
        dask_res["check"] = check_spectrum(spec, n)
        dask_res["client_peak_rss_bytes"] = maxrss_bytes()
        dask_res["client_peak_rss_before_bytes"] = rss_before
        dask_res["total_peak_rss_bytes"] = (dask_res["workers_peak_rss_sum_bytes"]
                                            + dask_res["client_peak_rss_bytes"])
        rows.append({"part": "synthetic", "mode": f"dask {dask_res['workers']} workers",
                     "curves": n, "wall_s": dask_res["wall_s"],
                     "per_curve_s": dask_res["per_curve_s"],
                     "memory_bytes": dask_res["total_peak_rss_bytes"], "extrapolated": False})
        print(f"dask ({dask_res['scheduler']}, {dask_res['workers']} workers x 1 thread, worker "
              f"BLAS threads {dask_res['worker_blas_threads']}), {dask_res['blocks']} tasks of "
              f"{block} curves: {dask_res['wall_s']:.2f} s "
              f"({dask_res['per_curve_s'] * 1e3:.1f} ms/curve, of which read_jpk + scatter "
              f"{dask_res['read_scatter_s']:.2f} s, concat {dask_res['concat_s']:.2f} s; cluster start-up "
              f"{dask_res['cluster_startup_s']:.1f} s not counted); peak RSS workers "
              + " + ".join(f"{b / 2**20:.0f}" for b in dask_res["worker_peak_rss_bytes"])
              + f" MiB + this process {dask_res['client_peak_rss_bytes'] / 2**20:.0f} MiB = "
              f"{dask_res['total_peak_rss_bytes'] / 2**20:.0f} MiB; spectrum check "
              f"{'ok' if dask_res['check']['ok'] else 'FAILED'}")

        reopen = run_serial(path, reopen_n, reopen_n, "path")
        reopen["extrapolated_wall_s"] = reopen["per_curve_s"] * n
        rows.append({"part": "synthetic", "mode": "reopen serial", "curves": reopen_n,
                     "wall_s": reopen["extrapolated_wall_s"],
                     "per_curve_s": reopen["per_curve_s"],
                     "memory_bytes": reopen["block_tracemalloc_peak_bytes"], "extrapolated": True})
        print(f"reopen (each block reads the map: read_jpk + zip central directory), one block "
              f"of {reopen_n} curves: {reopen['wall_s']:.2f} s = {reopen['per_curve_s']:.3f} "
              f"s/curve -> {reopen['extrapolated_wall_s']:.0f} s for {n} curves in blocks of "
              f"{reopen_n} (extrapolated)")

        serial = run_serial(path, serial_n, block, args.open_mode)
        serial["extrapolated_wall_s"] = serial["per_curve_s"] * n
        rows.append({"part": "synthetic", "mode": "serial", "curves": serial_n,
                     "wall_s": serial["extrapolated_wall_s"],
                     "per_curve_s": serial["per_curve_s"],
                     "memory_bytes": serial["block_tracemalloc_peak_bytes"],
                     "extrapolated": serial_n < n})
        print(f"serial (open={args.open_mode}; read_jpk {serial['read_jpk_s']:.2f} s not "
              f"counted), {serial_n} curves in blocks of {block}: "
              f"{serial['wall_s']:.2f} s = {serial['per_curve_s'] * 1e3:.1f} ms/curve -> "
              f"{serial['extrapolated_wall_s']:.1f} s for {n} curves"
              f"{' (extrapolated)' if serial_n < n else ''}; one block's tracemalloc peak "
              f"{serial['block_tracemalloc_peak_bytes'] / 2**20:.0f} MiB")

        profile = profile_block(path, blocks_of(n, block)[0], args.open_mode)
        print(f"profile of one block ({profile['curves']} curves, cProfile, "
              f"{profile['profiled_wall_s']:.2f} s): " + ", ".join(
                  f"{k[:-2]} {v:.3f}" for k, v in profile.items()
                  if k.endswith("_s") and k != "profiled_wall_s"))

    time_ok = dask_res["wall_s"] <= TARGET_S
    mem_ok = dask_res["total_peak_rss_bytes"] <= TARGET_BYTES
    passed = time_ok and mem_ok and dask_res["check"]["ok"]
    verdict = pf(passed)
    print(f"summary: synthetic {grid}x{grid} read + demodulate with dask: "
          f"{dask_res['wall_s']:.1f} s (target <= {TARGET_S:g} s: {pf(time_ok)}), "
          f"{dask_res['total_peak_rss_bytes'] / GIB:.2f} GiB (target <= 1 GiB: {pf(mem_ok)}): "
          f"{verdict} [open={args.open_mode}]")

    args.out.mkdir(parents=True, exist_ok=True)
    json_path, csv_path, png_path = (args.out / f"load.{e}" for e in ("json", "csv", "png"))
    write_csv(rows, csv_path)
    plot(rows, png_path)
    report = {
        **report_head(SCHEMA, args.quick, machine),
        "target": {"wall_s": TARGET_S, "memory_bytes": TARGET_BYTES, "cores": 2,
                   "applies_to": "synthetic map, dask run; memory = peak RSS of workers + client"},
        "settings": {"grid": grid, "block": block, "serial_curves": serial_n,
                     "reopen_curves": reopen_n, "open_mode": args.open_mode,
                     "scheduler": args.scheduler, "workers": args.workers,
                     "env": {"OPENBLAS_NUM_THREADS": "1"}, "layout": [list(s) for s in LAYOUT]},
        "real": real,
        "synthetic": {"archive": facts, "reopen": reopen, "serial": serial, "profile": profile,
                      "dask": dask_res},
        "summary": {"wall_s": dask_res["wall_s"], "memory_bytes": dask_res["total_peak_rss_bytes"],
                    "time_passed": time_ok, "memory_passed": mem_ok, "passed": passed,
                    "verdict": verdict, **run_end(t_start)},
        "files": {"json": str(json_path), "csv": str(csv_path), "png": str(png_path)},
    }
    write_json(report, json_path)
    print(f"wrote {json_path}, {csv_path} and {png_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
