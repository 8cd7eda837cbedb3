#!/usr/bin/env python
"""Phase-lag workflow on the real JPK modulation map: phases and flags before and after.

What it does:

1. Loads the real map of a living cell (16 curves, sine modulation at 1, 3, 10, 30, 100, 300 Hz:
   ``data_examples/real/modulation-map.jpk-force-map``, else the shared copy
   ``../shared/data/real/PyFMReader/map-data-2021.11.05-17.37.44.432.jpk-force-map``; ``--path``
   for another). When no file is found it prints why and exits with status 0 (skipped).
2. Measures the lag of the calibrated height sensor (``measuredHeight``) behind the piezo drive
   signal (``height``) per frequency: the lock-in of both channels over the window
   ``modulation_spectrum`` uses, arg(ĥ_piezo/ĥ_sensor), median and sd over the curves.
3. Runs ``modulation_spectrum`` (the lock-in ``viscoforce load`` runs) four ways: as measured
   against the sensor (the default), with the README's recipe ``--phase-lag 300Hz=14``, with
   the measured sensor-vs-piezo lag at every frequency, and against the piezo signal. For each:
   the median, min and max phase per frequency and the points flagged per frequency
   (``phase_outside_passive_range``, ``low_signal``), plus ``attrs["quality_summary"]``.

Output: the table on stdout and ``studies/phase_lag_real/phase_lag_real.json`` (the committed
numbers; ``--quick``: ``studies/phase_lag_real/out/phase_lag_real.json``; ``--out`` for another
file or folder)
with keys ``schema``, ``created``, ``file``, ``frequencies_hz``, ``sensor_vs_piezo_lag_deg``
(``median``, ``sd``), ``runs`` (per run: ``description``, ``height_channel``, ``phase_lag_deg``,
``median_phase_deg``, ``min_phase_deg``, ``max_phase_deg``, ``flagged_phase``,
``flagged_low_signal``, ``quality_summary``) and ``conclusion``. Run ``python
studies/phase_lag_real/phase_lag_real.py [--quick] [--path MAP] [--out PATH]``; it takes a few
seconds (``--quick`` is the same run, written to ``out/`` so that the committed file stays).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # before NumPy loads

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
from datetime import UTC, datetime  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import viscoforce  # noqa: E402
from viscoforce.experiments.modulation import modulation_spectrum  # noqa: E402
from viscoforce.io.instruments import load_instrument  # noqa: E402
from viscoforce.lockin import harmonics  # noqa: E402

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
CANDIDATES = (REPO / "data_examples" / "real" / "modulation-map.jpk-force-map",
              REPO.parent / "shared" / "data" / "real" / "PyFMReader"
              / "map-data-2021.11.05-17.37.44.432.jpk-force-map")
SCHEMA = "viscoforce.phase_lag_real/1"
JSON_NAME = "phase_lag_real.json"
README_LAG = {300.0: 14.0}   # the README's recipe: load --phase-lag 300Hz=14


def sensor_vs_piezo_lag(sensor, piezo) -> dict[float, list[float]]:
    """Per frequency, per curve: the lag [degree] of the sensor height behind the piezo height."""
    seg = sensor["segment"].values
    counts = sensor["sample_count"].values
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    freq = sensor["segment_frequency"].values
    lags: dict[float, list[float]] = {}
    for start, count in zip(starts, counts, strict=True):
        sl = slice(int(start), int(start + count))
        t, s, p, rows = (sensor["time"].values[sl], sensor["height"].values[sl],
                         piezo["height"].values[sl], seg[sl])
        for row in np.unique(rows):
            f = float(freq[row])
            if not (math.isfinite(f) and f > 0):
                continue
            m = rows == row
            dt = float(np.median(np.diff(t[m])))
            c = harmonics(np.vstack([s[m], p[m]]), t[m], 2 * math.pi * f, 1,
                          settle=max(1.0 / f - dt, 0.0), detrend="linear")[:, 1]
            lags.setdefault(f, []).append(float(np.degrees(np.angle(c[1] / c[0]))))
    return lags


def summary(spec, description: str) -> dict:
    """Per-frequency phase statistics and flag counts of one spectrum."""
    phase, quality = spec["phase"].values, spec["quality"].values
    return {"description": description,
            "height_channel": str(spec.attrs.get("height_channel")),
            "phase_lag_deg": [float(v) for v in spec["phase_lag"].values],
            "median_phase_deg": [float(v) for v in np.median(phase, axis=0)],
            "min_phase_deg": [float(v) for v in phase.min(axis=0)],
            "max_phase_deg": [float(v) for v in phase.max(axis=0)],
            "flagged_phase": [int(v) for v in (quality == 1).sum(axis=0)],
            "flagged_low_signal": [int(v) for v in (quality == 2).sum(axis=0)],
            "n_curves": int(phase.shape[0]),
            "quality_summary": str(spec.attrs["quality_summary"])}


def json_path(out: Path | None, quick: bool) -> Path:
    """Where the report goes.

    ``out`` (a folder: ``out/phase_lag_real.json``), else the committed file, or
    ``out/phase_lag_real.json`` next to this script for ``--quick``.
    """
    if out is None:
        return HERE / "out" / JSON_NAME if quick else HERE / JSON_NAME
    return out / JSON_NAME if out.is_dir() or not out.suffix else out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--path", type=Path, default=None, help="JPK modulation map")
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: the same run, written to studies/phase_lag_real/out/")
    parser.add_argument("--out", type=Path, default=None,
                        help="JSON file, or a folder to write phase_lag_real.json in (default: "
                             "studies/phase_lag_real/phase_lag_real.json; --quick: "
                             "out/phase_lag_real.json)")
    args = parser.parse_args(argv)
    out = json_path(args.out, args.quick)
    path = args.path or next((p for p in CANDIDATES if p.exists()), None)
    if path is None or not path.exists():
        print(f"skipped: the real modulation map is absent ({path or CANDIDATES[0]})")
        return 0
    sensor = load_instrument(path)
    piezo = load_instrument(path, height_channel="height")
    lag_per_curve = sensor_vs_piezo_lag(sensor, piezo)
    freqs = sorted(lag_per_curve)
    lag_median = {f: float(np.median(lag_per_curve[f])) for f in freqs}
    runs = {
        "measured": summary(modulation_spectrum(sensor, contact_point=False),
                            "against the calibrated sensor (measuredHeight), no correction"),
        "readme_300hz_14": summary(
            modulation_spectrum(sensor, contact_point=False,
                                phase_lag={f: README_LAG.get(f, 0.0) for f in freqs}),
            "against the sensor, --phase-lag 300Hz=14 (the README's recipe)"),
        "sensor_lag_all": summary(
            modulation_spectrum(sensor, contact_point=False, phase_lag=lag_median),
            "against the sensor, the measured sensor-vs-piezo lag subtracted at every "
            "frequency (not justified: that lag is not in a sensor-based phase)"),
        "piezo": summary(modulation_spectrum(piezo, contact_point=False),
                         "against the piezo drive signal (height), no correction"),
    }
    still = runs["readme_300hz_14"]
    conclusion = (
        "The sensor height already keeps the piezo's lag out of the phase: the 14 degrees at "
        "300 Hz is the sensor's lag behind the piezo signal, absent from a sensor-based phase. "
        f"Subtracting it anyway leaves the 300 Hz points at {still['min_phase_deg'][-1]:.1f}"
        f"-{still['max_phase_deg'][-1]:.1f} deg, outside (0, 90): "
        f"{still['flagged_phase'][-1]} of {still['n_curves']} stay flagged. What remains "
        "(sensor bandwidth, deflection chain, cantilever inertia and hydrodynamics) needs a "
        "hard-surface reference measured with the same settings (--phase-reference).")
    report = {
        "schema": SCHEMA, "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "viscoforce": viscoforce.__version__, "file": path.name, "frequencies_hz": freqs,
        "sensor_vs_piezo_lag_deg": {
            "median": [lag_median[f] for f in freqs],
            "sd": [float(np.std(lag_per_curve[f])) for f in freqs]},
        "runs": runs, "conclusion": conclusion}

    print(f"{path.name}: {runs['measured']['n_curves']} curves")
    print("frequency [Hz]        " + "".join(f"{f:>9g}" for f in freqs))
    print("sensor lag vs piezo   " + "".join(f"{v:9.2f}" for v in
                                             report["sensor_vs_piezo_lag_deg"]["median"]))
    for name, run in runs.items():
        print(f"-- {name}: {run['description']}")
        print("  median phase [deg]  " + "".join(f"{v:9.1f}" for v in run["median_phase_deg"]))
        print("  min..max [deg]      " + "".join(
            f"{lo:4.0f}..{hi:<3.0f}" for lo, hi in zip(run["min_phase_deg"],
                                                       run["max_phase_deg"], strict=True)))
        print("  flagged phase       " + "".join(f"{v:9d}" for v in run["flagged_phase"]))
        print("  flagged low signal  " + "".join(f"{v:9d}" for v in run["flagged_low_signal"]))
    print(conclusion)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=1) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
