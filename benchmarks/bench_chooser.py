#!/usr/bin/env python
"""The measured-data chooser (``fit --model auto`` without --h0): its time and how often it is right.

Issue 20, item 2: "Seconds, not minutes: ≤ 5 s for one 6-point curve on this machine".

1. Time: ``fit_spectrum(curve, "auto", radius=10 µm)`` on every curve of the bundled real JPK
   modulation map (6 frequencies 1–300 Hz, the 300 Hz points flagged; its first 4 curves with
   --quick), CPU and wall time per curve (median and maximum over the curves, one repeat each),
   and what it kept.
2. Accuracy: synthetic contact spectra (10 frequencies 0.3 Hz – 1 kHz, 2 % complex noise with
   its stderr given, R = 5 µm, δ0 = 0.5 µm) of three families — structural (E_ref 1 kPa, α 0.15,
   μ 0.5 Pa·s), SLS (E0 5 kPa, E_inf 1 kPa, τ 10 ms), two-mode Prony (20, 5, 1 kPa; 2 ms, 0.2 s) —
   ``--replicas`` seeded replicas each (default 20; 5 with --quick): the fraction kept right.

Targets: ≤ 5 s per real curve (max), ≥ 90 % right per family. BLAS pinned to one thread
(threadpoolctl). Prints the figures with PASS/FAIL; writes ``chooser.json`` and ``chooser.csv`` to
``--out`` (default benchmarks/out).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT / "data_examples" / "real" / "modulation-map.jpk-force-map"
TARGET_SECONDS = 5.0
TARGET_RIGHT = 0.9
#: The case table. ``real``: the chooser timed on the real map's curves (all; ``curves``: the
#: first so many). ``synthetic``: one family per row, its material's parameters (structural: E_ref
#: [Pa], α, μ [Pa·s]; sls: E0, E_inf [Pa], τ [s]; prony 2: moduli [Pa], times [s]); its seeded
#: replicas are fitted and the family kept is counted.
CASES = (
    {"part": "real", "curves": None},
    {"part": "synthetic", "family": "structural", "params": (1e3, 0.15, 0.5)},
    {"part": "synthetic", "family": "sls", "params": (5e3, 1e3, 0.01)},
    {"part": "synthetic", "family": "prony 2", "params": ([2e4, 5e3, 1e3], [0.002, 0.2])},
)
#: --quick: the real map's first 4 curves (and 5 replicas of each family, :func:`main`).
QUICK_CASES = tuple({**c, "curves": 4} if c["part"] == "real" else c for c in CASES)


def _synthetic():
    from viscoforce.closed_form import structural_complex_modulus
    from viscoforce.physics.materials import PronySeries, StandardLinearSolid

    radius, depth = 5e-6, 500e-9
    omega = 2 * np.pi * np.geomspace(0.3, 1000.0, 10)
    root = math.sqrt(radius * depth)
    families = {
        "structural": lambda p: root * structural_complex_modulus(omega, *p),
        "sls": lambda p: root / StandardLinearSolid(*p).complex_compliance(omega),
        "prony 2": lambda p: root / PronySeries.from_moduli(*p).complex_compliance(omega),
    }
    truths = {c["family"]: families[c["family"]](c["params"]) for c in CASES
              if c["part"] == "synthetic"}
    return radius, depth, omega, truths


def accuracy(replicas: int) -> dict[str, dict[str, object]]:
    from viscoforce.fitting import fit_spectrum
    from viscoforce.schema import make_spectrum

    radius, depth, omega, truths = _synthetic()
    out = {}
    for seed, (name, k) in enumerate(truths.items()):
        rng = np.random.default_rng(100 + seed)
        picks, seconds = [], []
        for _ in range(replicas):
            noisy = k * (1 + 0.02 * rng.standard_normal(k.shape)) * np.exp(
                1j * 0.02 * rng.standard_normal(k.shape))
            spec = make_spectrum(omega, noisy, np.full(k.shape, 1e-9), 1e-8,
                                 stderr={"stiffness": 0.02 * np.abs(k),
                                         "phase": np.full(k.shape, np.degrees(0.02))},
                                 mean_indentation=np.full(k.shape, depth))
            start = time.process_time()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fit = fit_spectrum(spec, "auto", radius=radius)
            seconds.append(time.process_time() - start)
            picks.append(str(fit.attrs["candidate"]))
        right = picks.count(name) / replicas
        out[name] = {"right": right, "picks": picks, "cpu_median_s": statistics.median(seconds),
                     "pass": right >= TARGET_RIGHT}
    return out


def real_times(curves: int | None = None) -> list[dict[str, object]]:
    """Time ``fit_spectrum(curve, "auto")`` on the real map's curves (the first ``curves``)."""
    from viscoforce.experiments.modulation import modulation_spectrum
    from viscoforce.fitting import fit_spectrum
    from viscoforce.io.instruments import load_instrument

    spec = modulation_spectrum(load_instrument(REAL))
    rows = []
    for i in range(min(spec.sizes["curve"], curves or spec.sizes["curve"])):
        one = spec.isel(curve=i)
        wall, cpu = time.perf_counter(), time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = fit_spectrum(one, "auto", radius=10e-6)
        rows.append({"curve": i, "wall_s": time.perf_counter() - wall,
                     "cpu_s": time.process_time() - cpu, "kept": str(fit.attrs["candidate"]),
                     "redchi": float(fit["redchi"]), "chi2_pvalue": float(fit["chi2_pvalue"])})
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="5 replicas, 4 real curves")
    parser.add_argument("--replicas", type=int, default=None)
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "out",
                        help="output folder (default: benchmarks/out)")
    args = parser.parse_args(argv)
    replicas = args.replicas or (5 if args.quick else 20)
    args.out.mkdir(parents=True, exist_ok=True)
    with threadpool_limits(1):
        load = ", ".join(f"{v:.2f}" for v in os.getloadavg())
        print(f"BLAS pinned to 1 thread (threadpoolctl); load average {load}")
        real = next(c for c in (QUICK_CASES if args.quick else CASES) if c["part"] == "real")
        rows = real_times(real["curves"]) if REAL.is_file() else []
        right = accuracy(replicas)
    ok = True
    if rows:
        worst = max(r["wall_s"] for r in rows)
        passed = worst <= TARGET_SECONDS
        ok &= passed
        median = statistics.median(r["wall_s"] for r in rows)
        print(f"real map, {len(rows)} curves: wall median {median:.2f} s, max {worst:.2f} s "
              f"(target <= {TARGET_SECONDS:g} s): {'PASS' if passed else 'FAIL'}")
        kept = {}
        for r in rows:
            kept[r["kept"]] = kept.get(r["kept"], 0) + 1
        print(f"  kept: {kept}")
    else:
        print(f"real map not found at {REAL}: time not measured")
    for name, r in right.items():
        ok &= bool(r["pass"])
        print(f"synthetic {name}: {100 * r['right']:.0f} % right of {replicas} "
              f"(target >= {100 * TARGET_RIGHT:.0f} %), CPU median {r['cpu_median_s']:.2f} s: "
              f"{'PASS' if r['pass'] else 'FAIL'}")
    (args.out / "chooser.json").write_text(json.dumps(
        {"real": rows, "synthetic": right, "replicas": replicas, "blas_threads": 1}, indent=2))
    with open(args.out / "chooser.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, ["curve", "wall_s", "cpu_s", "kept", "redchi",
                                         "chi2_pvalue"])
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {args.out / 'chooser.json'}, {args.out / 'chooser.csv'}")
    print(f"overall: {'PASS' if ok else 'FAIL'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
