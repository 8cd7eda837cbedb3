"""Regenerate the bundled example files (deterministic: fixed seeds).

python data_examples/make_examples.py [--out DIR] [NAME ...]

Every file comes from viscoforce itself (the exact linear response, or the time-domain simulator)
of one known material, the paper's Fig. 1 system (R = 10 µm, double layer P = 1e7 Pa, 1/κ = 1 nm,
soft wall P_w = 1e7 Pa, z0 = 0.5 nm) and :data:`TRUE_SLS`, with seeded noise and drift; the
README gives each file's true parameters.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

import viscoforce as vf
from viscoforce.experiments.linear_response import linear_stiffness
from viscoforce.io.jpk_write import ForceSegment, write_jpk_force
from viscoforce.schema import make_spectrum, validate_spectrum

HERE = Path(__file__).resolve().parent

#: The material of every example but the map: a standard linear solid (tau = creep time, Eq. 3).
TRUE_SLS = {"E0": 5e9, "E_inf": 1e9, "tau": 5e-3}
#: Mean position h̄0 of the spectra [m] (in contact: the paper's Fig. 4 operating point).
H0 = -5e-9
#: Relative noise per real component of k* in the spectra (stiffness and phase stderr).
SPECTRUM_NOISE = 0.015
#: Cantilever of the JPK and time-series examples: spring constant [N/m], sensitivity [m/V].
CANTILEVER = {"spring_constant": 40.0, "sensitivity": 50e-9}
#: Modulation frequencies of the JPK example, in the order measured (as the real JPK map) [Hz],
#: and the whole drive periods in each segment.
JPK_FREQUENCIES = (300.0, 3.0, 100.0, 30.0, 1.0, 10.0)
JPK_PERIODS = (30, 6, 20, 12, 4, 10)
#: Tip indentation amplitude of the JPK modulation [m].
JPK_ETA = 1e-9


def paper_problem(E0: float, E_inf: float, tau: float,  # noqa: N803 (the paper's names)
                  deepest: float = -7e-9) -> vf.ContactProblem:
    """The paper's system with a standard linear solid, grid down to ``deepest`` [m]."""
    return vf.ContactProblem.create(
        sphere=vf.Sphere(vf.PAPER.R), surface_force=vf.paper_pressure_law(),
        material=vf.StandardLinearSolid(E0, E_inf, tau), deepest_position=deepest)


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


def _noisy(k: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """k*·(1 + σ(ε₁ + iε₂)): relative noise σ = SPECTRUM_NOISE per real component."""
    eps = rng.normal(0.0, SPECTRUM_NOISE, k.shape) + 1j * rng.normal(0.0, SPECTRUM_NOISE, k.shape)
    return k * (1.0 + eps)


def spectrum_csv(path: Path) -> None:
    """Spectrum CSV: exact linear response of TRUE_SLS at h̄0 = −5 nm, 25 frequencies, 1.5 % noise.

    1 Hz – 3 kHz log-spaced; seed 11. Columns as SPEC "Spectrum CSV", plus the static mean force
    and the drive amplitude (0.5 nm).
    """
    rng = np.random.default_rng(11)
    frequency = np.geomspace(1.0, 3000.0, 25)
    k, mean_force = linear_stiffness(paper_problem(**TRUE_SLS), H0, 2 * np.pi * frequency)
    k = _noisy(k, rng)
    se_phase = math.degrees(SPECTRUM_NOISE)
    with path.open("w") as f:
        f.write("# viscoforce example: spectrum of a standard linear solid at h0 = -5 nm "
                "(synthetic, see README.md)\n")
        f.write("frequency (Hz),stiffness (N/m),phase (deg),stiffness_stderr (N/m),"
                "phase_stderr (deg),mean_force (N),drive_amplitude (m)\n")
        for fi, ki in zip(frequency, k, strict=True):
            f.write(f"{fi:.6g},{abs(ki):.6g},{math.degrees(np.angle(ki)):.5f},"
                    f"{SPECTRUM_NOISE * abs(ki):.4g},{se_phase:.4g},{mean_force:.6g},5e-10\n")


def relaxation_csv(path: Path) -> None:
    """Time series of a stress-relaxation step: hold −5 nm 1 ms, step to −7 nm in 0.1 ms, hold 40 ms.

    ``viscoforce.simulate`` (exponential stepper) of TRUE_SLS, sampled every 40 µs; the force gets
    2 nN rms white noise and a slow drift (5 nN over the record, seed 13), the cantilever
    (CANTILEVER) deflects by force / k, the height sensor (0.05 nm rms noise) reads
    2 µm + h0 − deflection (height grows away from the sample).
    """
    rng = np.random.default_rng(13)
    dwell, rise, hold, dt = 1e-3, 1e-4, 40e-3, 40e-6
    t = np.arange(0.0, dwell + rise + hold + 0.5 * dt, dt)
    drive = vf.Sequence((vf.Hold(H0, dwell), vf.Step(H0, -7e-9, rise), vf.Hold(-7e-9, hold)))
    run = vf.simulate(paper_problem(**TRUE_SLS), drive, t_eval=t, t_end=float(t[-1]),
                      output_kinks=False, progress=False)
    force_true = run["force"].values
    k_c = CANTILEVER["spring_constant"]
    height = 2e-6 + run["position"].values - force_true / k_c + rng.normal(0.0, 5e-11, t.size)
    force = force_true + 5e-9 * (t / t[-1]) ** 1.5 + rng.normal(0.0, 2e-9, t.size)
    labels = np.where(t < dwell, "dwell", np.where(t <= dwell + rise, "extend", "hold"))
    with path.open("w") as f:
        f.write("# viscoforce example: simulated stress relaxation after a 2 nm step "
                "(synthetic, see README.md)\n")
        f.write("time (s),force (N),deflection (m),height (m),segment\n")
        for row in zip(t, force, force / k_c, height, labels, strict=True):
            f.write(f"{row[0]:.6f},{row[1]:.7g},{row[2]:.7g},{row[3]:.10g},{row[4]}\n")


def _drift(rng: np.random.Generator, points: list[int], per_segment: float) -> list[np.ndarray]:
    """Continuous piecewise-linear drift: ±per_segment·U(0.5, 1.5) [m] over each segment."""
    out, level = [], 0.0
    for n in points:
        change = per_segment * rng.uniform(0.5, 1.5) * rng.choice((-1.0, 1.0))
        out.append(level + change * np.arange(n) / n)
        level += change
    return out


def modulation_jpk(path: Path) -> None:
    """JPK ``.jpk-force`` of a modulation experiment in contact, written by write_jpk_force.

    Extend 100 → −5 nm in 0.2 s and a 0.2 s pause (simulated together), six sine-modulation
    segments (JPK_FREQUENCIES; tip indentation δ = −η sin ωt, η = 1 nm, force
    F̄ + Re[k*(ω) δ̂ e^{iωt}] from the exact linear response at h̄0 = −5 nm), retract −5 → 100 nm in
    0.2 s (simulated). Cantilever CANTILEVER, free deflection offset 2 nm (the file's baseline);
    measuredHeight = 2 µm + h0 − F/k plus ≈ 20 nm of drift per segment and 0.1 nm rms noise;
    piezo height with a slow creep and 0.2 nm noise; deflection noise 0.02 nm rms. Seed 17.
    """
    rng = np.random.default_rng(17)
    problem = paper_problem(**TRUE_SLS)
    k_c, offset, top = CANTILEVER["spring_constant"], 2e-9, 100e-9
    durations, points, positions, forces, styles, settings = [], [], [], [], [], []

    n_ext, n_pause, t_ext, t_pause = 400, 200, 0.2, 0.2
    t = np.arange(n_ext + n_pause) * (t_ext / n_ext)
    approach = vf.simulate(problem, vf.Sequence((vf.Ramp(top, H0, t_ext), vf.Hold(H0, t_pause))),
                           t_eval=t, t_end=t_ext + t_pause, output_kinks=False, progress=False)
    for style, part, duration in (("extend", slice(0, n_ext), t_ext),
                                  ("pause", slice(n_ext, None), t_pause)):
        positions.append(approach["position"].values[part])
        forces.append(approach["force"].values[part])
        durations.append(duration)
        styles.append(style)
        settings.append({})

    omega = 2 * np.pi * np.asarray(JPK_FREQUENCIES)
    k, mean_force = linear_stiffness(problem, H0, omega)
    n_mod = 1000
    for f, periods, w, kw in zip(JPK_FREQUENCIES, JPK_PERIODS, omega, k, strict=True):
        duration = periods / f
        tt = np.arange(n_mod) * (duration / n_mod)
        delta_hat = 1j * JPK_ETA                       # δ = Re[δ̂ e^{iωt}] = −η sin ωt
        positions.append(H0 + JPK_ETA * np.sin(w * tt))  # h0 = h̄0 − δ
        forces.append(mean_force + (kw * delta_hat * np.exp(1j * w * tt)).real)
        durations.append(duration)
        styles.append("modulation")
        settings.append({"frequency": f, "amplitude": float(abs(1 + kw / k_c) * JPK_ETA)})

    n_ret, t_ret = 400, 0.2
    t = np.arange(n_ret) * (t_ret / n_ret)
    retract = vf.simulate(problem, vf.Ramp(H0, top, t_ret), t_eval=t, t_end=t_ret,
                          output_kinks=False, progress=False)
    positions.append(retract["position"].values)
    forces.append(retract["force"].values)
    durations.append(t_ret)
    styles.append("retract")
    settings.append({})

    points = [p.size for p in positions]
    sensor_drift = _drift(rng, points, 20e-9)
    start = np.cumsum([0.0, *durations[:-1]])
    segments = []
    for s, style in enumerate(styles):
        n = points[s]
        deflection_true = forces[s] / k_c
        height_true = 2e-6 + positions[s] - deflection_true
        tt = start[s] + np.arange(n) * (durations[s] / n)
        creep = 30e-9 * np.log1p(tt / 0.5)
        channels = {
            "vDeflection": deflection_true + offset + rng.normal(0.0, 2e-11, n),
            "height": height_true + creep + rng.normal(0.0, 2e-10, n),
            "measuredHeight": height_true + sensor_drift[s] + rng.normal(0.0, 1e-10, n),
        }
        segments.append(ForceSegment(style, durations[s], channels, **settings[s]))
    write_jpk_force(path, segments, position=(1e-6, 2e-6), baseline=offset,
                    instrument="viscoforce synthetic (data_examples/make_examples.py)",
                    **CANTILEVER)


#: The map: 4 × 4 pixels, 1 µm apart; material varying smoothly across it.
MAP_SHAPE = (4, 4)
MAP_FREQUENCIES = np.geomspace(1.0, 3000.0, 12)


def map_material(iy: int, ix: int) -> dict[str, float]:
    """True SLS of pixel (y, x), varying geometrically across the map.

    tau 2 → 8 ms along x, E0 3 → 6 GPa along y, E_inf 0.8 → 1.2 GPa along the diagonal.
    """
    ny, nx = MAP_SHAPE
    fx, fy = ix / (nx - 1), iy / (ny - 1)
    return {"E0": 3e9 * 2.0**fy, "E_inf": 0.8e9 * 1.5 ** (0.5 * (fx + fy)),
            "tau": 2e-3 * 4.0**fx}


def spectrum_map_nc(path: Path) -> None:
    """Spectrum map (y, x, omega) in netCDF (h5netcdf): exact linear response per pixel.

    h̄0 = −5 nm, 12 frequencies 1 Hz – 3 kHz, 1.5 % noise (seed 19), drive amplitude 0.5 nm;
    the true parameters are stored as ``true_E0``, ``true_E_inf``, ``true_tau`` over (y, x).
    """
    rng = np.random.default_rng(19)
    ny, nx = MAP_SHAPE
    omega = 2 * np.pi * MAP_FREQUENCIES
    base = paper_problem(**TRUE_SLS)
    k = np.empty((ny, nx, omega.size), complex)
    mean = np.empty((ny, nx, omega.size))
    truth = {name: np.empty((ny, nx)) for name in TRUE_SLS}
    for iy in range(ny):
        for ix in range(nx):
            material = map_material(iy, ix)
            for name, value in material.items():
                truth[name][iy, ix] = value
            problem = base.with_material(vf.StandardLinearSolid(**material))
            k[iy, ix], mean[iy, ix] = linear_stiffness(problem, H0, omega)
    k = _noisy(k, rng)
    ds = make_spectrum(
        omega, k, mean, 5e-10, dims=("y", "x", "omega"),
        coords={"y": ("y", 1e-6 * np.arange(ny)), "x": ("x", 1e-6 * np.arange(nx))},
        stderr={"stiffness": SPECTRUM_NOISE * np.abs(k),
                "phase": np.full(k.shape, math.degrees(SPECTRUM_NOISE))},
        source="synthetic",
        attrs={"position": H0, "description": "viscoforce example: 4x4 spectrum map of a "
               "standard linear solid varying across the map (synthetic, see README.md)",
               "radius": vf.PAPER.R, "P": vf.PAPER.P, "debye_length": vf.PAPER.debye_length,
               "Pw": vf.PAPER.Pw, "z0": vf.PAPER.z0})
    units = {"E0": "Pa", "E_inf": "Pa", "tau": "s"}
    ds = ds.assign({f"true_{name}": (("y", "x"), values, {
        "units": units[name], "long_name": f"true {name} of the pixel (SLS, tau = creep time)"})
        for name, values in truth.items()})
    validate_spectrum(ds).to_netcdf(path, engine="h5netcdf")


#: File name → the function that writes it.
EXAMPLES: dict[str, Callable[[Path], None]] = {
    "approach_retract_trace.csv": approach_retract_trace,
    "sls_spectrum.csv": spectrum_csv,
    "sls_step_relaxation.csv": relaxation_csv,
    "sls_modulation.jpk-force": modulation_jpk,
    "sls_spectrum_map.nc": spectrum_map_nc,
}


def main(argv: list[str] | None = None) -> int:
    """Write the examples (all, or the NAMEs given) into ``--out`` (default: this folder)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", metavar="NAME",
                        help=f"files to write (default all: {', '.join(EXAMPLES)})")
    parser.add_argument("--out", type=Path, default=HERE, help="directory (default: here)")
    args = parser.parse_args(argv)
    unknown = sorted(set(args.names) - set(EXAMPLES))
    if unknown:
        parser.error(f"unknown example(s) {', '.join(unknown)}; known: {', '.join(EXAMPLES)}")
    for name in args.names or EXAMPLES:
        EXAMPLES[name](args.out / name)
        print("wrote", args.out / name)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
