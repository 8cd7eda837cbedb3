#!/usr/bin/env python
"""Pull-off of an elastic adhesive sphere against Tabor's parameter: Lennard-Jones vs Bradley, JKR, Maugis.

What it computes (issue 39 items 1 and 5, the elastic part; studies/adhesion_pulloff/README.md):

1. For each Tabor parameter μ in :data:`MUS` (0.01 … 5; ``--quick``: :data:`QUICK_MUS`), a sphere
   R = 1 µm with the Lennard-Jones law (A = 1e-20 J, z0 = 0.3 nm, Δγ = A/(16π z0²)) on an elastic
   half-space whose modulus gives that μ (E = 2E*, μ³ = RΔγ²/(E*² z0³)): the static equilibria by
   pseudo-arclength continuation (``viscoforce.solvers.continuation.equilibrium_path`` on the
   ``adhesion_grid``, whose spacing shrinks as μ^{-3/2}). First an approach from (3 + μ) z0 that
   stops at its first fold (the **jump-in**); if it has none it runs to the deep end (0, or 2 z0
   where μ ≥ 3: the deep end must only pass the force minimum) and gives the pull-off. With a
   fold, a retraction from the deep end on the contact branch, stopped at its first fold (the
   **jump-out**), gives the **pull-off** −min F on the contact branch (load control). Each μ
   also on a grid of half the resolution: the change is the grid's share of the error.
2. Against: Bradley's rigid limit 2πRΔγ, JKR's 1.5πRΔγ, and the Maugis–Dugdale pull-off at
   λ = 1.16 μ (its closed-form parametric equations, here; the same maths as
   tests/theory/test_adhesion_static.py, copied). The deviation LJ/MD − 1 per μ.
3. The μ at which the folds appear (bisection in log μ between the largest listed μ without
   folds and the smallest with).
4. One whole approach path at μ = 1 (4.5 z0 down to −1 z0, twice the default resolution): both
   stable branches, the unstable one between the folds, jump-in and jump-out.

Outputs: ``adhesion_pulloff.json`` (keys ``schema``, ``created``, ``quick``, ``machine``,
``settings``, ``rows``, ``maugis_dugdale``, ``fold_onset``, ``path``, ``summary``, ``files``),
``adhesion_pulloff.csv`` (one row per μ), ``adhesion_static_path.csv`` (the μ = 1 path) and the
figures ``adhesion_pulloff.png`` and ``adhesion_static_path.png``. A full run writes the JSON and
CSVs into studies/adhesion_pulloff/ (committed) and the figures into docs/; ``--quick`` writes
everything into studies/adhesion_pulloff/out/ (gitignored); ``--out DIR`` everything into DIR.
BLAS is pinned to one thread.
Run ``python studies/adhesion_pulloff/adhesion_pulloff.py [--quick] [--out DIR]`` (full run:
about a minute, most of it at μ = 5; ``--quick``: seconds).
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # before NumPy loads

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import matplotlib  # noqa: E402

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.optimize import brentq, minimize_scalar  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

import viscoforce as vf  # noqa: E402
from viscoforce.exceptions import ViscoforceError  # noqa: E402
from viscoforce.problem import ContactProblem  # noqa: E402
from viscoforce.solvers.continuation import (  # noqa: E402
    EquilibriumPath,
    adhesion_grid,
    equilibrium_path,
)

HERE = Path(__file__).resolve().parent
DOCS = HERE.parents[1] / "docs"
sys.path.insert(0, str(HERE.parents[1] / "benchmarks"))  # benchmarks/_common.py, from any cwd
from _common import (  # noqa: E402
    machine_facts,
    print_machine,
    report_head,
    run_end,
    write_csv,
    write_json,
)

SCHEMA = "viscoforce.adhesion_pulloff/1"
RADIUS, Z0, HAMAKER = 1e-6, 0.3e-9, 1e-20  # [m], [m], [J]
LAW = vf.lennard_jones_pressure_law(HAMAKER, Z0)
W = LAW.work_of_adhesion  # Δγ [J/m²]
UNIT = np.pi * RADIUS * W  # πRΔγ [N]
BRADLEY, JKR = 2.0, 1.5  # pull-off / (πRΔγ)
LAMBDA_PER_MU = 1.16  # Maugis' λ for the Lennard-Jones law's Tabor μ
#: Tabor parameters of the full run: log spaced 0.01 … 5 with the points of the tests. Not 10: the
#: grid there needs 2400 nodes (spacing ∝ μ^{-3/2}, dense LU ∝ nodes³), about 35x μ = 5's cost
#: per step, over an hour; a coarser grid locks the contact edge to the nodes (see the README).
MUS = (0.01, 0.03, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 2.0, 3.0, 5.0)
QUICK_MUS = (0.01, 0.1, 0.3, 1.0, 2.0)
RESOLUTION = 1.0  # adhesion_grid's default: spacing sqrt(2R z0)/(12 max(1, μ)^{3/2})
CHECK_RESOLUTION = 0.5  # the grid check: half the resolution
DEEP_MU = 3.0  # from this μ on, the deep end is 2 z0 (the pull-off lies above it)
PATH_MU, PATH_RESOLUTION = 1.0, 2.0  # the static-path figure
PATH_START, PATH_STOP = 4.5 * Z0, -1.0 * Z0
PATH_STEP = 0.05 * Z0  # max arclength step [m] of the path figure (a smooth curve)
ONSET_RTOL = 0.005  # the fold onset bisection stops when hi/lo < 1 + this
ONSET_STEP = 0.05 * Z0  # max arclength step [m] there (resolves a small fold pair)
JSON_NAME, CSV_NAME, PATH_CSV = ("adhesion_pulloff.json", "adhesion_pulloff.csv",
                                 "adhesion_static_path.csv")
PULLOFF_PNG, PATH_PNG = "adhesion_pulloff.png", "adhesion_static_path.png"


# ── the physics and the closed forms ─────────────────────────────────────────────────────────────

def modulus_for(mu: float) -> float:
    """The paper's E [Pa] giving Tabor parameter ``mu``: μ³ = RΔγ²/(E*² z0³), E = 2E*."""
    return 2.0 * np.sqrt(RADIUS * W**2 / (mu**3 * Z0**3))


def maugis_dugdale_pull_off(lam: float) -> float:
    """Maugis–Dugdale pull-off / (πRΔγ) under load control (Maugis 1992; Johnson–Greenwood 1997).

    With ā the contact radius and m = c/a the cohesive-zone ratio in Maugis' units:
    (λā²/2)[√(m²−1) + (m²−2) atan√(m²−1)] + (4λ²ā/3)[√(m²−1) atan√(m²−1) − m + 1] = 1,
    P̄ = ā³ − λā²[√(m²−1) + m² atan√(m²−1)]; the pull-off is −min over ā of P̄.
    """
    def m_of(a):
        def f(m):
            q = np.sqrt(m * m - 1.0)
            at = np.arctan(q)
            return (lam * a * a / 2 * (q + (m * m - 2) * at)
                    + 4 * lam * lam * a / 3 * (q * at - m + 1) - 1.0)
        hi = 2.0
        while f(hi) < 0:
            hi *= 2.0
        return brentq(f, 1.0 + 1e-14, hi, xtol=1e-14)

    def load(a):
        m = m_of(a)
        q = np.sqrt(m * m - 1.0)
        return a**3 - lam * a * a * (q + m * m * np.arctan(q))

    return float(-minimize_scalar(load, bounds=(1e-4, 3.0), method="bounded",
                                  options={"xatol": 1e-10}).fun)


def md_equivalent_mu(ratio: float) -> float:
    """The μ at which Maugis–Dugdale (λ = 1.16 μ) gives pull-off ``ratio`` πRΔγ (NaN outside)."""
    def gap(log_mu):
        return maugis_dugdale_pull_off(LAMBDA_PER_MU * 10.0**log_mu) - ratio
    lo, hi = -5.0, 3.0
    if not gap(lo) > 0 > gap(hi):
        return float("nan")
    return float(10.0 ** brentq(gap, lo, hi, xtol=1e-10))


def problem_for(mu: float, deepest: float, resolution: float) -> ContactProblem:
    """Sphere, law, elastic half-space of Tabor parameter ``mu`` on an adhesion grid."""
    e = modulus_for(mu)
    grid = adhesion_grid(vf.Particle(RADIUS), LAW, e, deepest, resolution=resolution)
    return ContactProblem(vf.Particle(RADIUS), LAW, vf.Elastic(e), grid)


def deep_end(mu: float) -> float:
    """The deepest h0 [m] of the paths at ``mu``."""
    return 2.0 * Z0 if mu >= DEEP_MU else 0.0


# ── part 1: pull-off and folds per μ ─────────────────────────────────────────────────────────────

def pull_off_at(mu: float, resolution: float) -> dict:
    """Jump-in, jump-out and pull-off at ``mu`` on a grid of ``resolution`` (see the docstring)."""
    deep = deep_end(mu)
    problem = problem_for(mu, deep, resolution)
    t0 = time.perf_counter()
    approach = equilibrium_path(problem, (3.0 + mu) * Z0, deep, until_fold=True)
    jump_in = approach.jump_in
    retraction = None
    if jump_in is None:
        pull, pull_at = approach.pull_off, approach.pull_off_position
    else:
        retraction = equilibrium_path(problem, deep, (4.0 + 2.0 * mu) * Z0, until_fold=True)
        pull, pull_at = retraction.pull_off, retraction.pull_off_position
    jump_out = None if retraction is None else retraction.jump_out
    points = approach.position.size + (0 if retraction is None else retraction.position.size)
    iterations = approach.parameters["newton_iterations"] + (
        0 if retraction is None else retraction.parameters["newton_iterations"])
    return {"pull_off": pull, "pull_off_position": pull_at, "jump_in": jump_in,
            "jump_out": jump_out, "nodes": problem.grid.size, "points": points,
            "newton_iterations": iterations, "time_s": time.perf_counter() - t0}


def row_for(mu: float) -> dict:
    """The table row of ``mu``: the run at RESOLUTION, MD, the limits and the grid check."""
    run = pull_off_at(mu, RESOLUTION)
    ratio = run["pull_off"] / UNIT
    md = maugis_dugdale_pull_off(LAMBDA_PER_MU * mu)
    try:
        check = pull_off_at(mu, CHECK_RESOLUTION)
        check_ratio, check_status = check["pull_off"] / UNIT, "ok"
        check_out = np.nan if check["jump_out"] is None else check["jump_out"].position / Z0
    except ViscoforceError as exc:  # a coarse grid may lose the path: recorded, not fatal
        check_ratio, check_status = float("nan"), f"fails: {type(exc).__name__}: {exc}"
        check_out = np.nan
    ji, jo = run["jump_in"], run["jump_out"]
    return {"mu": mu, "lambda_md": LAMBDA_PER_MU * mu, "modulus_pa": modulus_for(mu),
            "resolution": RESOLUTION, "nodes": run["nodes"], "deep_end_z0": deep_end(mu) / Z0,
            "pull_off_n": run["pull_off"], "pull_off_ratio": ratio,
            "pull_off_position_z0": run["pull_off_position"] / Z0,
            "md_ratio": md, "deviation_md": ratio / md - 1.0,
            "md_equivalent_mu": md_equivalent_mu(ratio),
            "deviation_bradley": ratio / BRADLEY - 1.0, "deviation_jkr": ratio / JKR - 1.0,
            "jump_in_position_z0": np.nan if ji is None else ji.position / Z0,
            "jump_in_force_ratio": np.nan if ji is None else ji.force / UNIT,
            "jump_out_position_z0": np.nan if jo is None else jo.position / Z0,
            "jump_out_force_ratio": np.nan if jo is None else jo.force / UNIT,
            "check_resolution": CHECK_RESOLUTION, "check_pull_off_ratio": check_ratio,
            "check_change": check_ratio / ratio - 1.0, "check_jump_out_position_z0": check_out,
            "check_status": check_status,
            "points": run["points"], "newton_iterations": run["newton_iterations"],
            "time_s": run["time_s"]}


def has_folds(mu: float) -> bool:
    """Whether the approach at ``mu`` has a jump-in (small steps: a young fold pair is narrow)."""
    problem = problem_for(mu, 0.0, RESOLUTION)
    path = equilibrium_path(problem, (3.0 + mu) * Z0, 0.0, until_fold=True, max_step=ONSET_STEP)
    return path.jump_in is not None


def fold_onset(rows: list[dict]) -> dict:
    """The μ where the folds appear: bisection in log μ between the neighbouring listed μ."""
    without = [r["mu"] for r in rows if np.isnan(r["jump_in_position_z0"])]
    with_ = [r["mu"] for r in rows if not np.isnan(r["jump_in_position_z0"])]
    if not without or not with_ or max(without) > min(with_):
        return {"status": "not bracketed by the listed μ", "mu_low": None, "mu_high": None}
    lo, hi = max(without), min(with_)
    evaluations = 0
    while hi / lo > 1.0 + ONSET_RTOL:
        mid = float(np.sqrt(lo * hi))
        evaluations += 1
        if has_folds(mid):
            hi = mid
        else:
            lo = mid
    return {"status": "ok", "mu_low": lo, "mu_high": hi, "lambda_md_low": LAMBDA_PER_MU * lo,
            "lambda_md_high": LAMBDA_PER_MU * hi, "evaluations": evaluations,
            "max_step_z0": ONSET_STEP / Z0}


# ── part 2: one whole path ───────────────────────────────────────────────────────────────────────

def static_path() -> EquilibriumPath:
    """The approach at μ = PATH_MU from PATH_START to PATH_STOP, through both folds."""
    return equilibrium_path(problem_for(PATH_MU, PATH_STOP, PATH_RESOLUTION),
                            PATH_START, PATH_STOP, max_step=PATH_STEP)


def jump_targets(path: EquilibriumPath) -> tuple[float, float]:
    """Forces [N] the rigid probe jumps to: contact branch at jump-in, far branch at jump-out."""
    first, last = path.folds[0].arclength, path.folds[-1].arclength
    far = path.arclength <= first
    contact = path.arclength >= last
    # far branch: h0 falls along the path; contact branch likewise (after the last fold)
    f_in = np.interp(path.jump_in.position, path.position[contact][::-1],
                     path.force[contact][::-1])
    f_out = np.interp(path.jump_out.position, path.position[far][::-1], path.force[far][::-1])
    return float(f_in), float(f_out)


def path_summary(path: EquilibriumPath) -> dict:
    ji, jo = path.jump_in, path.jump_out
    f_in, f_out = jump_targets(path)
    return {"mu": PATH_MU, "modulus_pa": path.modulus, "resolution": PATH_RESOLUTION,
            "nodes": int(path.gap.shape[1]), "points": int(path.position.size),
            "start_z0": PATH_START / Z0, "stop_z0": PATH_STOP / Z0, "n_folds": len(path.folds),
            "jump_in": {"position_z0": ji.position / Z0, "force_ratio": ji.force / UNIT,
                        "lands_at_force_ratio": f_in / UNIT},
            "jump_out": {"position_z0": jo.position / Z0, "force_ratio": jo.force / UNIT,
                         "lands_at_force_ratio": f_out / UNIT},
            "pull_off_ratio": path.pull_off / UNIT,
            "pull_off_position_z0": path.pull_off_position / Z0,
            "stable_points": int(path.stable.sum()),
            "unstable_points": int((~path.stable).sum())}


def path_rows(path: EquilibriumPath) -> list[dict]:
    return [{"arclength": s, "position_m": h, "force_n": f, "contact_radius_m": a,
             "stable": int(st), "position_z0": h / Z0, "force_ratio": f / UNIT}
            for s, h, f, a, st in zip(path.arclength, path.position, path.force,
                                      path.contact_radius, path.stable, strict=True)]


# ── figures ──────────────────────────────────────────────────────────────────────────────────────

def plot_pull_off(rows: list[dict], curve: dict, onset: dict, target: Path) -> None:
    mu = np.array([r["mu"] for r in rows])
    ratio = np.array([r["pull_off_ratio"] for r in rows])
    check = np.array([r["check_pull_off_ratio"] for r in rows])
    md = np.array([r["md_ratio"] for r in rows])
    fig, (top, low) = plt.subplots(2, 1, figsize=(7.0, 6.4), sharex=True,
                                   gridspec_kw={"height_ratios": [2.2, 1.0]})
    top.axhline(BRADLEY, color="0.45", ls="--", lw=1.0, label="Bradley (rigid): 2")
    top.axhline(JKR, color="0.45", ls=":", lw=1.2, label="JKR (soft): 1.5")
    top.plot(curve["mu"], curve["ratio"], color="#377eb8", lw=1.6,
             label=f"Maugis–Dugdale, λ = {LAMBDA_PER_MU:g} μ")
    top.plot(mu, ratio, "o-", color="#e41a1c", ms=5, lw=1.0,
             label="Lennard-Jones, viscoforce (continuation)")
    top.plot(mu, check, "o", mfc="none", color="#e41a1c", ms=8, mew=0.8,
             label=f"same, grid resolution {CHECK_RESOLUTION:g}")
    top.set_xscale("log")
    top.set_ylabel("pull-off force / (πRΔγ) [–]")
    top.set_ylim(1.4, 2.08)
    top.legend(fontsize=8, loc="lower left")
    top.set_title(f"Elastic sphere, Lennard-Jones law: R = {RADIUS * 1e6:g} µm, "
                  f"z0 = {Z0 * 1e9:g} nm, A = {HAMAKER:g} J", fontsize=9.5)
    low.axhline(0.0, color="0.45", lw=0.8)
    low.plot(mu, 100 * (ratio / md - 1), "o-", color="#e41a1c", ms=5, lw=1.0,
             label="Lennard-Jones / Maugis–Dugdale − 1")
    low.plot(mu, 100 * (check / md - 1), "o", mfc="none", color="#e41a1c", ms=8, mew=0.8,
             label=f"same, grid resolution {CHECK_RESOLUTION:g}")
    low.set_xlabel("Tabor parameter μ = ∛(RΔγ²/(E*² z0³)), E* = E/2 [–]")
    low.set_ylabel("deviation [%]")
    low.legend(fontsize=8, loc="upper left")
    for ax in (top, low):
        ax.grid(True, which="both", alpha=0.25)
        if onset["mu_low"] is not None:
            ax.axvline(np.sqrt(onset["mu_low"] * onset["mu_high"]), color="0.3", lw=0.8,
                       ls="-.")
    if onset["mu_low"] is not None:
        top.annotate(f"folds (jump-in, jump-out)\nfor μ > {onset['mu_high']:.3g} →",
                     xy=(onset["mu_high"], 1.95), xytext=(4, 0), textcoords="offset points",
                     fontsize=8, va="center")
    fig.tight_layout()
    fig.savefig(target, dpi=120)
    plt.close(fig)


def plot_path(path: EquilibriumPath, target: Path) -> None:
    h = path.position * 1e9  # [nm]
    f = path.force * 1e9  # [nN]
    ji, jo = path.jump_in, path.jump_out
    f_in, f_out = jump_targets(path)
    fig, ax = plt.subplots(figsize=(7.0, 4.8))
    far = path.arclength <= ji.arclength
    unstable = (path.arclength >= ji.arclength) & (path.arclength <= jo.arclength)
    contact = path.arclength >= jo.arclength
    ax.plot(h[far], f[far], color="#377eb8", lw=1.8, label="stable: far branch")
    ax.plot(h[unstable], f[unstable], color="0.4", lw=1.4, ls="--",
            label="unstable branch (between the folds)")
    ax.plot(h[contact], f[contact], color="#e41a1c", lw=1.8, label="stable: contact branch")
    kw = {"arrowstyle": "-|>", "lw": 1.2, "mutation_scale": 12}
    ax.annotate("", xy=(ji.position * 1e9, f_in * 1e9), xytext=(ji.position * 1e9, ji.force * 1e9),
                arrowprops={**kw, "color": "#377eb8"})
    ax.annotate("", xy=(jo.position * 1e9, f_out * 1e9),
                xytext=(jo.position * 1e9, jo.force * 1e9), arrowprops={**kw, "color": "#e41a1c"})
    ax.plot([ji.position * 1e9], [ji.force * 1e9], "v", color="#377eb8", ms=8,
            label=f"jump-in (approach): h0 = {ji.position * 1e9:.3f} nm")
    ax.plot([jo.position * 1e9], [jo.force * 1e9], "^", color="#e41a1c", ms=8,
            label=f"jump-out (retraction): h0 = {jo.position * 1e9:.3f} nm")
    ax.plot([path.pull_off_position * 1e9], [-path.pull_off * 1e9], "s", mfc="none",
            color="k", ms=8, label=f"pull-off (load control): {path.pull_off / UNIT:.3f} πRΔγ")
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel("apex position h0 [nm]")
    ax.set_ylabel("force F [nN] (> 0 repulsive)")
    ax.set_title(f"Static elastic equilibria, Lennard-Jones law, μ = {PATH_MU:g} "
                 f"(E = {path.modulus / 1e9:.3g} GPa, R = {RADIUS * 1e6:g} µm, "
                 f"z0 = {Z0 * 1e9:g} nm, A = {HAMAKER:g} J)", fontsize=9)
    top = ax.secondary_xaxis("top", functions=(lambda x: x / (Z0 * 1e9), lambda x: x * Z0 * 1e9))
    top.set_xlabel("h0 / z0 [–]")
    right = ax.secondary_yaxis("right", functions=(lambda y: y / (UNIT * 1e9),
                                                   lambda y: y * UNIT * 1e9))
    right.set_ylabel("F / (πRΔγ) [–]")
    ax.set_xlim(PATH_STOP * 1e9, PATH_START * 1e9)
    ax.grid(True, alpha=0.25)
    ax.legend(fontsize=7.5, loc="lower right")
    # the folds up close: the S between them is narrow at μ = 1
    inset = ax.inset_axes([0.27, 0.5, 0.33, 0.42])
    lo, hi = ji.position - 0.25 * (jo.position - ji.position), jo.position + 0.25 * (
        jo.position - ji.position)
    near = (path.position >= lo) & (path.position <= hi)
    for part, style in ((far, {"color": "#377eb8", "lw": 1.6}),
                        (unstable, {"color": "0.4", "lw": 1.2, "ls": "--"}),
                        (contact, {"color": "#e41a1c", "lw": 1.6})):
        inset.plot(h[part & near], f[part & near], **style)
    inset.plot([ji.position * 1e9], [ji.force * 1e9], "v", color="#377eb8", ms=6)
    inset.plot([jo.position * 1e9], [jo.force * 1e9], "^", color="#e41a1c", ms=6)
    inset.annotate("", xy=(ji.position * 1e9, f_in * 1e9),
                   xytext=(ji.position * 1e9, ji.force * 1e9),
                   arrowprops={**kw, "color": "#377eb8"})
    inset.annotate("", xy=(jo.position * 1e9, f_out * 1e9),
                   xytext=(jo.position * 1e9, jo.force * 1e9),
                   arrowprops={**kw, "color": "#e41a1c"})
    inset.set_xlim(lo * 1e9, hi * 1e9)
    inset.tick_params(labelsize=7)
    inset.set_xlabel("h0 [nm]", fontsize=7, labelpad=1)
    inset.set_ylabel("F [nN]", fontsize=7, labelpad=1)
    inset.grid(True, alpha=0.25)
    fig.tight_layout()
    fig.savefig(target, dpi=120)
    plt.close(fig)


# ── main ─────────────────────────────────────────────────────────────────────────────────────────

def output_paths(out: Path | None, quick: bool) -> dict[str, Path]:
    """Where each file goes: ``out`` (a folder) for all; else the committed places or out/."""
    if out is None and quick:
        out = HERE / "out"
    names = {"json": JSON_NAME, "csv": CSV_NAME, "path_csv": PATH_CSV, "pull_off_png": PULLOFF_PNG,
             "path_png": PATH_PNG}
    if out is not None:
        return {k: out / v for k, v in names.items()}
    return {k: (DOCS if v.endswith(".png") else HERE) / v for k, v in names.items()}


def summarise(rows: list[dict], onset: dict, t_start: float) -> dict:
    by_mu = {r["mu"]: r for r in rows}
    ratios = [r["pull_off_ratio"] for r in rows]
    worst = max(rows, key=lambda r: abs(r["deviation_md"]))
    return {"bradley_deviation_at_mu_0.01": by_mu[0.01]["deviation_bradley"] if 0.01 in by_mu
            else None,
            "jkr_deviation_at_largest_mu": rows[-1]["deviation_jkr"], "largest_mu": rows[-1]["mu"],
            "max_abs_deviation_md": abs(worst["deviation_md"]), "at_mu": worst["mu"],
            "monotone_in_mu": bool(all(a > b for a, b in zip(ratios, ratios[1:], strict=False))),
            "max_abs_check_change": float(np.nanmax(np.abs([r["check_change"] for r in rows]))),
            "fold_onset_mu": None if onset["mu_low"] is None
            else float(np.sqrt(onset["mu_low"] * onset["mu_high"])),
            **run_end(t_start)}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help=f"smoke run: μ in {QUICK_MUS}, written to studies/adhesion_pulloff/out/")
    parser.add_argument("--out", type=Path, default=None,
                        help="output folder for every file (default: a full run writes the JSON "
                             "and CSVs here and the figures into docs/)")
    args = parser.parse_args(argv)
    paths = output_paths(args.out, args.quick)
    for p in paths.values():
        p.parent.mkdir(parents=True, exist_ok=True)
    mus = QUICK_MUS if args.quick else MUS
    t_start = time.perf_counter()
    with threadpool_limits(limits=1, user_api="blas"):
        machine = machine_facts()
        print_machine(machine)
        print(f"adhesion pull-off study ({'quick' if args.quick else 'full'}): R = {RADIUS:g} m, "
              f"z0 = {Z0:g} m, A = {HAMAKER:g} J, Δγ = {W:.4g} J/m², πRΔγ = {UNIT:.4g} N")
        print(f"{'mu':>6} {'nodes':>5} {'F/πRΔγ':>8} {'MD':>7} {'dev MD':>7} {'jump-in':>8} "
              f"{'jump-out':>8} {'grid chk':>8} {'time':>6}")
        rows = []
        for mu in mus:
            r = row_for(mu)
            rows.append(r)
            print(f"{mu:6g} {r['nodes']:5d} {r['pull_off_ratio']:8.5f} {r['md_ratio']:7.4f} "
                  f"{100 * r['deviation_md']:+6.2f}% {r['jump_in_position_z0']:8.4f} "
                  f"{r['jump_out_position_z0']:8.4f} {100 * r['check_change']:+7.3f}% "
                  f"{r['time_s']:5.1f}s", flush=True)
        onset = fold_onset(rows)
        print(f"folds appear between μ = {onset['mu_low']} and {onset['mu_high']}")
        curve_mu = np.logspace(np.log10(0.005), np.log10(20.0), 61)
        curve = {"mu": curve_mu,
                 "ratio": np.array([maugis_dugdale_pull_off(LAMBDA_PER_MU * m) for m in curve_mu])}
        path = static_path()
        path_info = path_summary(path)
        print(f"μ = {PATH_MU:g} path: {path_info['points']} points, jump-in "
              f"{path_info['jump_in']['position_z0']:.4f} z0, jump-out "
              f"{path_info['jump_out']['position_z0']:.4f} z0, pull-off "
              f"{path_info['pull_off_ratio']:.5f} πRΔγ")
    plot_pull_off(rows, curve, onset, paths["pull_off_png"])
    plot_path(path, paths["path_png"])
    write_csv(rows, paths["csv"])
    write_csv(path_rows(path), paths["path_csv"])
    settings = {"radius_m": RADIUS, "z0_m": Z0, "hamaker_j": HAMAKER,
                "work_of_adhesion_j_m2": W, "pull_off_unit_n": UNIT, "mus": mus,
                "lambda_per_mu": LAMBDA_PER_MU, "resolution": RESOLUTION,
                "check_resolution": CHECK_RESOLUTION, "deep_end": "0, or 2 z0 where mu >= 3",
                "approach_start": "(3 + mu) z0", "retraction_stop": "(4 + 2 mu) z0",
                "modulus": "E = 2 E*, mu^3 = R dgamma^2 / (E*^2 z0^3)"}
    files = {k: p.name for k, p in paths.items()}
    report = {**report_head(SCHEMA, args.quick, machine), "settings": settings, "rows": rows,
              "maugis_dugdale": curve, "fold_onset": onset, "path": path_info,
              "summary": summarise(rows, onset, t_start), "files": files}
    write_json(report, paths["json"])
    s = report["summary"]
    print(f"max |LJ/MD − 1| = {100 * s['max_abs_deviation_md']:.2f} % at μ = {s['at_mu']:g}; "
          f"monotone: {s['monotone_in_mu']}; {s['wall_time_s']:.1f} s; wrote "
          + ", ".join(str(p) for p in paths.values()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
