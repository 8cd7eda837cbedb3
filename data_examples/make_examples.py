"""Regenerate the bundled example files (deterministic: fixed seed).

python data_examples/make_examples.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def approach_retract_trace(path: Path) -> None:
    """Write a piezo position trace like an AFM force-curve export.

    10 → −8 → 10 nm at 2 µm/s, sampled at 25 kHz, with 5 pm rms sensor noise (seed 7) and a
    0.2 ms dwell at the turn.
    """
    rng = np.random.default_rng(7)
    speed, top, turn, dwell, rate = 2e-6, 10e-9, -8e-9, 0.2e-3, 25e3
    t_ramp = (top - turn) / speed
    t = np.arange(0.0, 2 * t_ramp + dwell + 0.5 / rate, 1.0 / rate)
    pos = np.where(t < t_ramp, top - speed * t,
                   np.where(t < t_ramp + dwell, turn, turn + speed * (t - t_ramp - dwell)))
    pos = np.minimum(pos, top) + rng.normal(0.0, 5e-12, t.size)
    with path.open("w") as f:
        f.write("# viscoforce example: approach-retract piezo trace (synthetic, see README.md)\n")
        f.write("time (ms),position (nm)\n")
        for ti, pi in zip(t, pos, strict=True):
            f.write(f"{ti * 1e3:.4f},{pi * 1e9:.5f}\n")


if __name__ == "__main__":
    approach_retract_trace(HERE / "approach_retract_trace.csv")
    print("wrote", HERE / "approach_retract_trace.csv")
