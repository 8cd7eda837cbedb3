#!/usr/bin/env python
"""Split-half check of the lock-in standard errors on the real JPK modulation map (white vs new).

What it does:

1. Loads ``data_examples/real/modulation-map.jpk-force-map`` (16 curves of a living cell, sine
   modulation at 1, 3, 10, 30, 100, 300 Hz; ``--path`` for another map) with
   ``load_instrument``; exits with status 2 and a message when the file is absent.
2. For every curve and frequency splits the lock-in window of ``modulation_spectrum`` (default
   settle: one period) into its first and its last ⌊m/2⌋ whole periods and demodulates each
   half apart, with its own standard errors (``viscoforce.experiments.modulation.
   _demodulate_halves``). Per real component of k*, z = (k*_A − k*_B)/√(σ_A² + σ_B²) with σ the
   stiffness standard error of each half: the white-noise formula (``white``, the errors before
   the residual-spectrum method) and the residual-spectrum errors (``new``). Where the errors
   hold, the rms z over the curves is 1 (about 1.15 with the 8 degrees of freedom of the new
   errors of a half). It also reports the mean z per component per frequency: a z that keeps
   its sign over the curves is a systematic change between the halves (a drifting response),
   not noise.
3. Times one lock-in per segment (``_demodulate_stacked`` on each of the 96 segments, best of
   ``--repeats`` rounds of process CPU time) with and without the residual-spectrum part (the
   latter with ``_band_errors`` replaced by a stub: what the white-only lock-in costs).

BLAS is pinned to one thread (``OPENBLAS_NUM_THREADS=1`` etc. before NumPy loads, plus
``threadpoolctl.threadpool_limits(1)``); the BLAS libraries and their thread counts are printed
and stored. Output: ``studies/split_half/split_half.json`` (the committed numbers; ``--quick``:
``studies/split_half/out/split_half.json``; ``--out`` for another file or folder) with keys
``schema``, ``created``, ``machine``, ``file``, ``frequencies_hz``, ``periods``, ``rms_z``
(``white``/``new`` lists per frequency), ``mean_z`` (per component), ``n_values`` and
``cost_us_per_segment``. Run ``python studies/split_half/split_half.py [--quick] [--path MAP]
[--out PATH] [--repeats N]``; ``--quick`` times one round instead of 20 (the split-half figures
are the full run's).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # before NumPy loads

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from datetime import UTC, datetime  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from threadpoolctl import threadpool_info, threadpool_limits  # noqa: E402

import viscoforce  # noqa: E402
from viscoforce.experiments import modulation  # noqa: E402
from viscoforce.io.instruments import load_instrument  # noqa: E402

HERE = Path(__file__).resolve().parent
REAL_MAP = HERE.parents[1] / "data_examples" / "real" / "modulation-map.jpk-force-map"
SCHEMA = "viscoforce.split_half/1"
JSON_NAME = "split_half.json"
METHODS = {"white": "rho_white", "new": "rho"}


def segments(path: Path) -> list[tuple[float, np.ndarray, np.ndarray, float, float]]:
    """Per modulation segment: frequency [Hz], time [s], rows F [N], δ [m], height [m], settle
    [s] (as ``modulation_spectrum``'s default) and the median sampling interval [s]."""
    inp = modulation._curves_of(load_instrument(path), None, None)
    out = []
    for curve in inp.curves:
        for row, t, force, tip, height in curve:
            if inp.names[row] == "modulation":
                f = float(inp.freq[row])
                dt = float(np.median(np.diff(t)))
                out.append((f, t, np.vstack([force, tip, height]), max(1.0 / f - dt, 0.0), dt))
    return out


def split_half(segs) -> dict:
    """rms z and mean z per frequency for each method, and the window periods."""
    z: dict[str, dict[float, list[complex]]] = {name: {} for name in METHODS}
    periods: dict[float, int] = {}
    for f, t, stacked, settle, dt in segs:
        a, b = modulation._demodulate_halves(t, stacked[:2], f, settle=settle, dt=dt)
        periods[f] = a["periods"]
        ka, kb = a["F"] / a["d"], b["F"] / b["d"]
        for name, key in METHODS.items():
            sigma = math.hypot(a[key] * abs(ka), b[key] * abs(kb))
            z[name].setdefault(f, []).append((ka - kb) / sigma)
    freqs = sorted(periods)
    rms = {name: [float(np.sqrt(np.mean(np.abs(np.asarray(z[name][f])) ** 2 / 2)))
                  for f in freqs] for name in METHODS}
    mean = {name: {"real": [float(np.mean(np.real(z[name][f]))) for f in freqs],
                   "imag": [float(np.mean(np.imag(z[name][f]))) for f in freqs]}
            for name in METHODS}
    return {"frequencies_hz": freqs, "periods_per_half": [periods[f] for f in freqs],
            "rms_z": rms, "mean_z": mean, "n_values": [2 * len(z["new"][f]) for f in freqs]}


def cost(segs, repeats: int) -> dict:
    """Best process CPU time per segment [µs] of the lock-in with and without the band errors."""
    def one_round() -> float:
        start = time.process_time()
        for f, t, stacked, settle, dt in segs:
            modulation._demodulate_stacked(t, stacked, f, settle=settle, detrend="linear", dt=dt)
        return (time.process_time() - start) / len(segs) * 1e6

    # the module whose _demodulate_stacked looks _band_errors up (experiments._demodulation since
    # the lock-in moved there; modulation re-exports the name, so patching it there does nothing)
    owner = sys.modules[modulation._demodulate_stacked.__module__]
    real_band = owner._band_errors

    def stub(*args, **kwargs) -> dict:
        return {"rho": 0.0, "sigma_F_hat": 0.0, "sigma_d_hat": 0.0, "sigma_mean": 0.0,
                "stderr_bins": 1}

    with_band, without = [], []
    try:
        for _ in range(repeats):   # interleaved, so that a burst of load spoils both alike
            owner._band_errors = real_band
            with_band.append(one_round())
            owner._band_errors = stub
            without.append(one_round())
    finally:
        owner._band_errors = real_band
    best_with, best_without = min(with_band), min(without)
    return {"with_residual_spectrum": best_with, "white_only": best_without,
            "increase_percent": 100.0 * (best_with / best_without - 1.0), "rounds": repeats}


def machine() -> dict:
    blas = [{"library": Path(d.get("filepath", "")).name, "internal_api": d.get("internal_api"),
             "num_threads": d.get("num_threads")}
            for d in threadpool_info() if d.get("user_api") == "blas"]
    return {"python": platform.python_version(), "platform": platform.platform(),
            "cpu_count": os.cpu_count(), "numpy": np.__version__,
            "viscoforce": viscoforce.__version__, "blas": blas,
            "loadavg": list(os.getloadavg()) if hasattr(os, "getloadavg") else None}


def json_path(out: Path | None, quick: bool) -> Path:
    """Where the report goes.

    ``out`` (a folder: ``out/split_half.json``), else the committed file, or
    ``out/split_half.json`` next to this script for ``--quick`` (never the committed numbers).
    """
    if out is None:
        return HERE / "out" / JSON_NAME if quick else HERE / JSON_NAME
    return out / JSON_NAME if out.is_dir() or not out.suffix else out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--path", type=Path, default=REAL_MAP, help="JPK modulation map")
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: one timing round, written to studies/split_half/out/")
    parser.add_argument("--out", type=Path, default=None,
                        help="JSON file, or a folder to write split_half.json in (default: "
                             "studies/split_half/split_half.json; --quick: out/split_half.json)")
    parser.add_argument("--repeats", type=int, default=None,
                        help="timing rounds (default 20; 1 with --quick)")
    args = parser.parse_args(argv)
    if args.repeats is None:
        args.repeats = 1 if args.quick else 20
    if args.repeats < 1:
        parser.error("--repeats must be >= 1")
    out = json_path(args.out, args.quick)
    if not args.path.is_file():
        print(f"split_half: no file {args.path}", file=sys.stderr)
        return 2
    with threadpool_limits(limits=1):
        facts = machine()
        print("BLAS pinned to one thread:",
              ", ".join(f"{b['library']} ({b['num_threads']} thread)" for b in facts["blas"])
              or "no BLAS found")
        segs = segments(args.path)
        result = split_half(segs)
        timing = cost(segs, args.repeats)
    print(f"{args.path.name}: {len(segs)} segments; split-half rms z per frequency "
          "(1 where the standard errors hold)")
    print(f"{'f [Hz]':>8} {'periods/half':>13} {'white':>7} {'new':>7} {'mean z new (re, im)':>22}")
    for i, f in enumerate(result["frequencies_hz"]):
        print(f"{f:8g} {result['periods_per_half'][i]:13d} {result['rms_z']['white'][i]:7.2f} "
              f"{result['rms_z']['new'][i]:7.2f} "
              f"{result['mean_z']['new']['real'][i]:+10.2f} {result['mean_z']['new']['imag'][i]:+7.2f}")
    print(f"lock-in per segment (best of {timing['rounds']}, CPU time): "
          f"{timing['with_residual_spectrum']:.0f} us with the residual-spectrum errors, "
          f"{timing['white_only']:.0f} us white only (+{timing['increase_percent']:.0f} %)")
    report = {"schema": SCHEMA, "created": datetime.now(UTC).isoformat(timespec="seconds"),
              "machine": facts, "file": str(args.path), **result,
              "cost_us_per_segment": timing}
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
