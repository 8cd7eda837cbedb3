#!/usr/bin/env python
"""Viscoelastic adhesive loops through jump-in and jump-out, and Δγ_eff against speed (issue 39, 3-5).

What it computes (studies/adhesion_loops/README.md):

1. Fig. 5-style approach–retract triangles 6 z0 → −z0 → 6 z0 at three speeds (0.01, 1 and 100
   z0/τ) for a sphere R = 1 µm with the Lennard-Jones law (A = 1e-20 J, z0 = 0.3 nm) on an SLS
   with E0/E_inf = 10, τ = 1 ms, E_inf at Tabor parameter μ = 2 (glassy μ0 = 0.43): force and
   contact radius, the jump-in / jump-out events, pull-off, hysteresis energy −∮F dh0 with its
   quadrature error, wall time, and an error estimate (the pull-off and energy again at 10× the
   local tolerance: their change).
2. The relaxed (E_inf) and glassy (E0) static paths of part 1 on the same grid (the τ → 0 and
   τ → ∞ limits the loops must meet).
3. Δγ_eff(v) = pull-off/(1.5πR) over retraction speeds 1e-3 … 1e3 z0/τ, (a) after quasi-static
   loading (the relaxed contact at −z0, then a retraction at v; Afferrante & Violano 2022: rises
   monotonically) and (b) loading and unloading at the same v (bell-shaped).

Outputs: ``adhesion_loops.json`` (keys ``schema``, ``created``, ``quick``, ``settings``,
``loops``, ``limits``, ``speed_series``) and the figure ``adhesion_loops.png``. A full run
writes the JSON into studies/adhesion_loops/ and the figure into docs/; ``--quick`` writes both
into studies/adhesion_loops/out/ (two speeds per series); ``--out DIR`` into DIR. BLAS is pinned
to one thread. Run ``python studies/adhesion_loops/adhesion_loops.py [--quick] [--out DIR]``.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # before NumPy loads

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import viscoforce as vf  # noqa: E402
from viscoforce.experiments.drives import Ramp, Triangle  # noqa: E402
from viscoforce.physics.surface_forces import LennardJones  # noqa: E402
from viscoforce.problem import ContactProblem  # noqa: E402
from viscoforce.solvers.adhesive_dynamics import ADHESIVE_TOL, simulate_adhesive  # noqa: E402
from viscoforce.solvers.continuation import adhesion_grid, equilibrium_path  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
#: The JSON report's schema (name/version).
SCHEMA = "viscoforce.adhesion_loops/1"
R, Z0, HAMAKER, TAU, RATIO = 1e-6, 0.3e-9, 1e-20, 1e-3, 10.0
LAW = LennardJones(HAMAKER, Z0)
E_INF = 2.0 * np.sqrt(R * LAW.work_of_adhesion**2 / (2.0**3 * Z0**3))  # μ = 2
TOP, TURN = 6 * Z0, -Z0
LOOP_SPEEDS = (0.01, 1.0, 100.0)  # z0/τ
SERIES_SPEEDS = (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0, 1e3)
QUICK_SERIES = (1e-2, 100.0)


def run(problem, drive, tol_factor=1.0, samples=401):
    ds = simulate_adhesive(problem, drive, t_end=drive.duration,
                           t_eval=np.linspace(0.0, drive.duration, samples),
                           tol=tol_factor * ADHESIVE_TOL * Z0)
    return ds


def loop_record(problem, speed):
    drive = Triangle(TOP, TURN, speed * Z0 / TAU)
    start = time.perf_counter()
    ds = run(problem, drive)
    wall = time.perf_counter() - start
    coarse = run(problem, drive, tol_factor=10.0, samples=3).attrs
    a = ds.attrs
    jumps = {k: {f: float(a[f"{k}_{f}"]) for f in ("position", "time", "force")}
             for k in ("jump_in", "jump_out") if f"{k}_time" in a}
    return ds, {
        "speed_z0_per_tau": speed, "speed": speed * Z0 / TAU, "wall_s": wall,
        "steps": int(a["steps"]), "rejected": int(a["rejected_steps"]),
        "glassy_jumps": int(a["glassy_jumps"]), "pull_off": float(a["pull_off"]),
        "pull_off_error_estimate": abs(float(a["pull_off"]) - float(coarse["pull_off"])),
        "hysteresis_energy": float(a["hysteresis_energy"]),
        "hysteresis_error_estimate": abs(float(a["hysteresis_energy"])
                                         - float(coarse["hysteresis_energy"]))
        + float(a["hysteresis_quadrature_error"]),
        "effective_work_of_adhesion": float(a["effective_work_of_adhesion"]), **jumps}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)
    out = args.out or (HERE / "out" if args.quick else HERE)
    figure_dir = args.out or (HERE / "out" if args.quick else ROOT / "docs")
    out.mkdir(parents=True, exist_ok=True)
    figure_dir.mkdir(parents=True, exist_ok=True)
    grid = adhesion_grid(vf.Particle(R), LAW, E_INF, TURN, resolution=0.5)
    problem = ContactProblem(vf.Particle(R), LAW,
                             vf.StandardLinearSolid(RATIO * E_INF, E_INF, TAU), grid)
    loops, datasets = [], []
    for speed in LOOP_SPEEDS:
        ds, rec = loop_record(problem, speed)
        loops.append(rec)
        datasets.append(ds)
    limits, paths = {}, {}
    for name, modulus in (("relaxed", E_INF), ("glassy", RATIO * E_INF)):
        path = equilibrium_path(ContactProblem(vf.Particle(R), LAW, vf.Elastic(modulus), grid),
                                TOP, TURN)
        paths[name] = path
        limits[name] = {"modulus": modulus, "pull_off": path.pull_off,
                        "folds": [{"kind": f.kind, "position": f.position, "force": f.force}
                                  for f in path.folds]}
    series = {"after_quasi_static_loading": [], "equal_speeds": []}
    for speed in QUICK_SERIES if args.quick else SERIES_SPEEDS:
        v = speed * Z0 / TAU
        retract = run(problem, Ramp(TURN, TOP, (TOP - TURN) / v), samples=3).attrs
        both = run(problem, Triangle(TOP, TURN, v), samples=3).attrs
        for key, attrs in (("after_quasi_static_loading", retract), ("equal_speeds", both)):
            series[key].append({"speed_z0_per_tau": speed, "pull_off": float(attrs["pull_off"]),
                                "effective_work_of_adhesion":
                                    float(attrs["effective_work_of_adhesion"]),
                                "hysteresis_energy": float(attrs["hysteresis_energy"])})
    result = {
        "schema": SCHEMA, "created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "quick": bool(args.quick),
        "settings": {"R": R, "z0": Z0, "hamaker": HAMAKER, "work_of_adhesion":
                     LAW.work_of_adhesion, "E_inf": E_INF, "E0": RATIO * E_INF, "tau": TAU,
                     "tabor_relaxed": LAW.tabor_parameter(R, E_INF),
                     "tabor_glassy": LAW.tabor_parameter(R, RATIO * E_INF), "top": TOP,
                     "turn": TURN, "grid_nodes": grid.size, "tol": ADHESIVE_TOL * Z0},
        "loops": loops, "limits": limits, "speed_series": series}
    (out / "adhesion_loops.json").write_text(json.dumps(result, indent=1))
    _figure(datasets, loops, paths, series, figure_dir / "adhesion_loops.png")
    for rec in loops:
        print(f"v = {rec['speed_z0_per_tau']:g} z0/tau: pull-off {rec['pull_off']:.4g} N "
              f"(+- {rec['pull_off_error_estimate']:.1g}), energy {rec['hysteresis_energy']:.3g} J, "
              f"{rec['steps']} steps, {rec['wall_s']:.2f} s")
    return 0


def _figure(datasets, loops, paths, series, target: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax_r, ax_g) = plt.subplots(1, 3, figsize=(15, 4.6))
    for name, style in (("relaxed", ":"), ("glassy", "--")):
        p = paths[name]
        ax.plot(p.position / Z0, p.force * 1e9, style, color="grey", lw=1,
                label=f"static {name} path ({'E_inf' if name == 'relaxed' else 'E0'})")
    for ds, rec in zip(datasets, loops, strict=True):
        line, = ax.plot(ds.position / Z0, ds.force * 1e9,
                        label=f"v = {rec['speed_z0_per_tau']:g} z0/tau")
        ax_r.plot(ds.position / Z0, ds.contact_radius * 1e9, color=line.get_color())
        for kind, marker in (("jump_in", "v"), ("jump_out", "^")):
            if kind in rec:
                ax.plot(rec[kind]["position"] / Z0, rec[kind]["force"] * 1e9, marker,
                        color=line.get_color(), ms=9, mec="k")
    ax.set_xlabel("position h0 / z0")
    ax.set_ylabel("force F [nN]")
    ax.set_title("adhesive loops (v: jump-in, ^: jump-out)", fontsize="small")
    ax.legend(fontsize="x-small")
    ax_r.set_xlabel("position h0 / z0")
    ax_r.set_ylabel("contact radius [nm]")
    w = LAW.work_of_adhesion
    for key, marker in (("after_quasi_static_loading", "o-"), ("equal_speeds", "s--")):
        rows = series[key]
        ax_g.semilogx([r["speed_z0_per_tau"] for r in rows],
                      [r["effective_work_of_adhesion"] / w for r in rows], marker,
                      label=key.replace("_", " "))
    ax_g.axhline(paths["relaxed"].pull_off / (1.5 * np.pi * R) / w, color="grey", ls=":",
                 label="relaxed static")
    ax_g.axhline(paths["glassy"].pull_off / (1.5 * np.pi * R) / w, color="grey", ls="--",
                 label="glassy static")
    ax_g.set_xlabel("retraction speed v tau / z0")
    ax_g.set_ylabel("Δγ_eff / Δγ = pull-off / (1.5 πRΔγ)")
    ax_g.legend(fontsize="x-small")
    fig.tight_layout()
    fig.savefig(target, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
