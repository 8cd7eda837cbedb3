"""Regenerate Figs. 1, 2, 5, 6, 7 and 8 of Attard's viscoelastic-particles paper.

The paper is P. Attard, "Interaction and deformation of viscoelastic particles: Nonadhesive
particles"; the figures are recomputed with the exact solver of viscoforce.

Usage::

    python notebooks/paper_figures.py [--out DIR] [--quick]

Writes ``fig1.png``, ``fig2.png``, ``fig5.png`` … ``fig8.png`` and ``figures.json`` (the key
numbers, SI units unless the key names another unit) into DIR (default ``paper_figures``), and
prints the key numbers. ``--quick`` uses fewer output times and static points (for tests).

Only the public API is used: the physics lives in viscoforce, this script only chooses the runs,
computes the summary numbers and draws with :mod:`viscoforce.plotting`.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

import viscoforce as vf  # noqa: E402
from viscoforce.closed_form import derjaguin_force  # noqa: E402
from viscoforce.exceptions import ModelValidityWarning  # noqa: E402
from viscoforce.experiments import Ramp, Step, Triangle  # noqa: E402
from viscoforce.plotting import (  # noqa: E402
    contact_radius_plot,
    force_time_plot,
    hysteresis_plot,
    profile_plot,
)
from viscoforce.solvers.simulate import simulate  # noqa: E402
from viscoforce.solvers.svda_ode import solve_svda  # noqa: E402
from viscoforce.svda import svda_ramp_deformation  # noqa: E402

# ── parameters (the paper's Fig. 1 values) ──────────────────────────────────────────────────────
PAPER = vf.PAPER
RADIUS = PAPER.R                # R [m]
PRESSURE = PAPER.P              # P = Pw [Pa]
DEBYE_LENGTH = PAPER.debye_length  # 1/κ [m]
E0 = PAPER.E0                   # instantaneous modulus [Pa]
E_INF = PAPER.E_inf             # relaxed modulus [Pa]
TAU = PAPER.tau                 # creep time τ [s]
NM, UM, MS, UN = 1e-9, 1e-6, 1e-3, 1e-6

STEP_START = -5 * NM                      # Fig. 1: equilibrated here
STEP_ENDS = (-7 * NM, -3 * NM)            # ±2 nm steps
STEP_RISE = 0.1 * MS
STEP_TAUS = (1 * MS, 2 * MS)
STEP_T_END = 10 * MS
RAMP_SPEEDS = (5 * UM, 1 * UM)            # Fig. 2 [m/s]
RAMP_FROM, RAMP_TO = 10 * NM, 0.0
TRIANGLE_TOP, TRIANGLE_TURN = 10 * NM, -10 * NM
TRIANGLE_SPEEDS = (1 * UM, 2 * UM, 5 * UM)  # Figs. 5, 6
PROFILE_EVERY = 0.4 * MS                  # Fig. 7
FIG8_TURNS = (0.0, -3 * NM, -5 * NM, -7 * NM, -10 * NM)
FIG8_SPEED = 5 * UM

PARAMETER_TEXT = (r"$R$ = 10 µm, $P = P_w$ = $10^7$ Pa, $1/\kappa$ = 1 nm, $z_0$ = 0.5 nm, "
                  r"$E_0$ = $10^{10}$ Pa, $E_\infty$ = $10^9$ Pa")


def make_problem(tau: float, deepest: float) -> vf.ContactProblem:
    """The paper's system with creep time ``tau`` [s], gridded down to ``deepest`` [m]."""
    material = vf.StandardLinearSolid(E0=E0, E_inf=E_INF, tau=tau)
    return vf.ContactProblem.create(sphere=vf.Sphere(RADIUS), surface_force=vf.paper_pressure_law(),
                                    material=material, deepest_position=deepest)


def run(problem, drive, n_out: int, *, t_end: float | None = None, profiles: int = 0):
    """Exact simulation with ``n_out`` equally spaced outputs over [0, t_end]."""
    t_end = drive.duration if t_end is None else t_end
    return simulate(problem, drive, t_end=t_end, t_eval=np.linspace(0.0, t_end, n_out),
                    profiles=profiles, progress=False)


def run_info(ds) -> dict:
    """Numerics of one run (for the JSON)."""
    return {"method": ds.attrs["stepper"], "steps": int(ds.attrs["steps"]),
            "rejected_steps": int(ds.attrs["rejected_steps"]),
            "grid_nodes": int(ds.attrs["n_panels"]) * int(ds.attrs["order"]),
            "outer_radius_m": float(ds.attrs["outer_radius"]), "tol_m": float(ds.attrs["tol"])}


def hysteresis_work(ds) -> float:
    """Energy dissipated over the loop, W = −∮ F dh0 [J]."""
    return float(-np.trapezoid(ds.force.values, ds.position.values))


def turning_index(ds) -> int:
    """Output index of the deepest position."""
    return int(np.argmin(ds.position.values))


def branch_proxies() -> list[Line2D]:
    """Legend entries for the linestyles of the two branches."""
    return [Line2D([], [], color="grey", linestyle="-", label="loading (approach)"),
            Line2D([], [], color="grey", linestyle="--", label="unloading (retraction)")]


def save(fig, out: Path, name: str) -> str:
    """Write ``fig`` as out/name (PNG), close it and return the path."""
    path = out / name
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return str(path)


# ── Fig. 1: load relaxation after a step ────────────────────────────────────────────────────────
def figure1(out: Path, quick: bool) -> dict:
    """Fig. 1: ±2 nm steps from −5 nm, τ = 1 and 2 ms; inset log |F − F*|."""
    n_out = 201 if quick else 501
    fig, ax = plt.subplots(figsize=(7.5, 5.2), layout="constrained")
    inset = ax.inset_axes((0.47, 0.5, 0.5, 0.45))
    colors = {STEP_ENDS[0]: "C0", STEP_ENDS[1]: "C3"}
    numbers: dict = {"step_rise_time_s": STEP_RISE, "t_end_s": STEP_T_END, "runs": []}
    for tau in STEP_TAUS:
        problem = make_problem(tau, min(STEP_ENDS))
        initial = float(vf.static_equilibrium(problem, STEP_START).force)
        for end in STEP_ENDS:
            ds = run(problem, Step(start=STEP_START, end=end, rise_time=STEP_RISE), n_out,
                     t_end=STEP_T_END)
            relaxed = float(vf.static_equilibrium(problem, end).force)
            t, force = ds.time.values, ds.force.values
            diff = np.abs(force - relaxed)
            window = (t >= tau) & (t <= 3 * tau)
            slope = np.polyfit(t[window], np.log(diff[window]), 1)[0]
            local = -1.0 / np.gradient(np.log(diff), t)
            local_at = {f"{k:g}tau": float(np.interp(k * tau, t, local) / tau)
                        for k in (0.25, 0.5, 1, 2, 3)}
            style = {"color": colors[end], "linewidth": 1.2 if tau == STEP_TAUS[0] else 2.6}
            label = f"$h_0$: −5 → {end / NM:.0f} nm, τ = {tau / MS:g} ms".replace("-", "−")
            force_time_plot(ds, ax=ax, label=label, line_kw=style)
            force_time_plot(ds, ax=inset, log=True, reference=relaxed, line_kw=style)
            numbers["runs"].append({
                "tau_s": tau, "end_position_m": end, "initial_load_N": initial,
                "extreme_load_N": float(force.max() if end < STEP_START else force.min()),
                "load_at_t_end_N": float(force[-1]), "relaxed_load_N": relaxed,
                "decay_time_fit_tau_to_3tau_in_tau": float(-1.0 / slope / tau),
                "local_decay_time_in_tau": local_at, **run_info(ds)})
    ax.axhline(numbers["runs"][0]["initial_load_N"] / UN, color="grey", linewidth=0.8,
               linestyle=":", label="initial load at −5 nm ($E_\\infty$)")
    ax.legend(loc="lower right", fontsize=8)
    ax.set_xlim(-0.2, STEP_T_END / MS)
    inset.set_xlim(0, STEP_T_END / MS)
    inset.set_ylim(1e-6, 5)
    inset.set_title("$|F - F^*|$, $F^*$ = relaxed load", fontsize=8)
    fits = "; ".join(f"τ = {r['tau_s'] / MS:g} ms, {r['end_position_m'] / NM:.0f} nm: "
                     f"{r['decay_time_fit_tau_to_3tau_in_tau']:.2f}τ" for r in numbers["runs"])
    inset.text(0.97, 0.95, "decay time fitted on [τ, 3τ]:\n" + fits.replace("; ", "\n")
               .replace("-", "−"), transform=inset.transAxes, fontsize=6.5, va="top", ha="right")
    inset.tick_params(labelsize=7)
    inset.xaxis.label.set_size(7)
    inset.yaxis.label.set_size(7)
    ax.set_title("Fig. 1 — load relaxation after a 0.1 ms step from $h_0$ = −5 nm to −7 / −3 nm\n"
                 "τ = 1 ms (thin) and 2 ms (bold); " + PARAMETER_TEXT, fontsize=8.5)
    numbers["png"] = save(fig, out, "fig1.png")
    return numbers


# ── Fig. 2: precontact deformation on approach, exact vs SVDA ───────────────────────────────────
def figure2(out: Path, quick: bool) -> dict:
    """Fig. 2: exact central deformation on approach against Eqs. 17 and 20; inset F/R."""
    n_out = 81 if quick else 201
    problem = make_problem(TAU, RAMP_TO)
    fig, ax = plt.subplots(figsize=(7.5, 5.2), layout="constrained")
    inset = ax.inset_axes((0.52, 0.1, 0.45, 0.48))
    svda_kw = {"E0": E0, "E_inf": E_INF, "tau": TAU, "radius": RADIUS, "P": PRESSURE,
               "debye_length": DEBYE_LENGTH}
    numbers: dict = {"runs": []}
    for color, speed in zip(("C0", "C1"), RAMP_SPEEDS, strict=True):
        drive = Ramp.from_speed(RAMP_FROM, RAMP_TO, speed)
        t_eval = np.linspace(0.0, drive.duration, n_out)
        ds = run(problem, drive, n_out)
        with warnings.catch_warnings():  # Fig. 2 shows the SVDA failing near contact, on purpose
            warnings.simplefilter("ignore", ModelValidityWarning)
            ode = solve_svda(drive, t_eval=t_eval, **svda_kw)
            eq20 = svda_ramp_deformation(t_eval, RAMP_FROM, -speed, E0, E_INF, TAU, RADIUS,
                                         PRESSURE, DEBYE_LENGTH)
        h0 = ds.position.values
        every = max(1, n_out // 25)
        ax.plot(h0[::every] / NM, ds.u_center.values[::every] / NM, "o", color=color,
                markersize=4, markerfacecolor="none", label=f"exact, {speed / UM:g} µm/s")
        ax.plot(h0 / NM, ode.deformation / NM, "-", color=color, label="SVDA ODE, Eq. 17")
        ax.plot(h0 / NM, eq20 / NM, "--", color=color, label="SVDA analytic, Eq. 20")
        f20 = derjaguin_force(h0 - eq20, RADIUS, PRESSURE, DEBYE_LENGTH)
        if speed == RAMP_SPEEDS[-1]:
            to_mn_per_m = 1e-3 * RADIUS
            inset.plot(h0[::every] / NM, ds.force.values[::every] / to_mn_per_m, "o",
                       color=color, markersize=3.5, markerfacecolor="none")
            inset.plot(h0 / NM, ode.force / to_mn_per_m, "-", color=color)
            inset.plot(h0 / NM, f20 / to_mn_per_m, "--", color=color)
            rigid_h = np.linspace(0.05 * NM, RAMP_FROM, 400)
            rigid_f = np.array([problem.rigid_load(h) for h in rigid_h])
            top = 1.4 * float(ds.force.values.max()) / to_mn_per_m
            keep = rigid_f / to_mn_per_m <= top
            inset.plot(rigid_h[keep] / NM, rigid_f[keep] / to_mn_per_m, "k-", linewidth=2.2)
            inset.set_xlim(0, 4)
            inset.set_ylim(0, top)
            inset.set_xlabel("position $h_0$ [nm]", fontsize=7)
            inset.set_ylabel("$F/R$ [mN/m]", fontsize=7)
            inset.set_title(f"force/R at {speed / UM:g} µm/s; bold: rigid", fontsize=8)
            inset.tick_params(labelsize=7)
        rows = {}
        for h in (5 * NM, 2 * NM, 1 * NM, 0.0):
            i = int(np.argmin(np.abs(h0 - h)))
            rows[f"{h / NM:g}nm"] = {
                "u_exact_m": float(ds.u_center.values[i]), "u_ode_m": float(ode.deformation[i]),
                "u_eq20_m": float(eq20[i]), "force_exact_N": float(ds.force.values[i]),
                "force_ode_N": float(ode.force[i]), "force_eq20_N": float(f20[i]),
                "force_rigid_N": problem.rigid_load(h) if h > 0 else None}
        numbers["runs"].append({"speed_m_per_s": speed, "at_position": rows, **run_info(ds)})
    ax.set_xlabel("position $h_0$ [nm]")
    ax.set_ylabel("central deformation $u(0)$ [nm]")
    ax.legend(loc="upper right", bbox_to_anchor=(0.995, 0.9), fontsize=8, ncol=2)
    ax.set_title("Fig. 2 — central deformation on approach from 10 nm toward contact at 5 and "
                 "1 µm/s\nexact (symbols), SVDA ODE Eq. 17 (solid), analytic Eq. 20 (dashed); "
                 "τ = 1 ms\n" + PARAMETER_TEXT, fontsize=8.5)
    numbers["png"] = save(fig, out, "fig2.png")
    return numbers


# ── Figs. 5–7: triangular drive 10 → −10 → 10 nm ────────────────────────────────────────────────
STATIC_LABELS = {E_INF: r"static $E$ = $10^9$ Pa", E0: r"static $E$ = $10^{10}$ Pa"}


def statics(problem, positions) -> dict:
    """Static elastic equilibria at E_inf and E0: label → (positions, forces, contact radii)."""
    curves = {}
    for modulus, label in STATIC_LABELS.items():
        eq = [vf.static_equilibrium(problem, float(h), modulus=modulus) for h in positions]
        curves[label] = (np.asarray(positions), np.array([float(e.force) for e in eq]),
                         np.array([float(e.contact_radius) for e in eq]))
    return curves


def static_at_deepest(curves: dict, column: int) -> dict:
    """Value of column 1 (force) or 2 (contact radius) at the deepest static position."""
    plain = {STATIC_LABELS[E_INF]: "E=1e9 Pa", STATIC_LABELS[E0]: "E=1e10 Pa"}
    return {plain[k]: float(v[column][np.argmin(v[0])]) for k, v in curves.items()}


def triangle_runs(problem, quick: bool) -> dict:
    """Exact runs of the 10 → −10 → 10 nm triangle at each speed (profiles for the fastest)."""
    n_out = 101 if quick else 401
    out = {}
    for speed in TRIANGLE_SPEEDS:
        drive = Triangle(top=TRIANGLE_TOP, turn=TRIANGLE_TURN, speed=speed)
        dt = drive.duration / (n_out - 1)
        stride = max(1, round(PROFILE_EVERY / dt)) if speed == max(TRIANGLE_SPEEDS) else 0
        out[speed] = run(problem, drive, n_out, profiles=stride)
    return out


def contact_onset(ds) -> tuple[float | None, float | None]:
    """Positions [m] where contact starts on loading and ends on unloading (None: never)."""
    k = turning_index(ds)
    a, h = ds.contact_radius.values, ds.position.values
    on = np.flatnonzero(a[: k + 1] > 0)
    off = np.flatnonzero(a[k:] > 0)
    return (float(h[on[0]]) if on.size else None, float(h[k + off[-1]]) if off.size else None)


def figure5(out: Path, runs: dict, curves: dict, rigid: tuple) -> dict:
    """Fig. 5: force loops with the static and rigid references."""
    fig, ax = plt.subplots(figsize=(7.5, 5.2), layout="constrained")
    numbers: dict = {"runs": []}
    fastest = max(runs)
    for speed, ds in runs.items():
        extra = ({"statics": {n: (h, f) for n, (h, f, _) in curves.items()}, "rigid": rigid}
                 if speed == fastest else {})
        hysteresis_plot(ds, ax=ax, label=f"±{speed / UM:g} µm/s", **extra)
        k = turning_index(ds)
        numbers["runs"].append({
            "speed_m_per_s": speed, "peak_force_N": float(ds.force.values.max()),
            "force_at_turn_N": float(ds.force.values[k]),
            "hysteresis_work_J": hysteresis_work(ds), **run_info(ds)})
    top = 1.3 * max(float(ds.force.values.max()) for ds in runs.values()) / UN
    ax.set_ylim(-0.05 * top, top)
    handles, _ = ax.get_legend_handles_labels()
    ax.legend(handles=handles + branch_proxies(), loc="upper right", fontsize=8)
    ax.set_title("Fig. 5 — force loops, triangle 10 → −10 → 10 nm at 1, 2, 5 µm/s; statics "
                 "(markers, off-scale above) and rigid (bold)\nτ = 1 ms; " + PARAMETER_TEXT,
                 fontsize=8.5)
    numbers["static_force_at_-10nm_N"] = static_at_deepest(curves, 1)
    numbers["png"] = save(fig, out, "fig5.png")
    return numbers


def figure6(out: Path, runs: dict, curves: dict) -> dict:
    """Fig. 6: contact-radius loops with the static references."""
    fig, ax = plt.subplots(figsize=(7.5, 5.2), layout="constrained")
    numbers: dict = {"runs": []}
    fastest = max(runs)
    for speed, ds in runs.items():
        extra = ({"statics": {n: (h, a) for n, (h, _, a) in curves.items()}}
                 if speed == fastest else {})
        contact_radius_plot(ds, ax=ax, label=f"±{speed / UM:g} µm/s", **extra)
        on, off = contact_onset(ds)
        numbers["runs"].append({"speed_m_per_s": speed,
                                "peak_contact_radius_m": float(ds.contact_radius.values.max()),
                                "contact_onset_position_m": on, "contact_loss_position_m": off})
    handles, _ = ax.get_legend_handles_labels()
    ax.legend(handles=handles + branch_proxies(), loc="upper right", fontsize=8)
    ax.set_title("Fig. 6 — contact radius loops (contact: local gap < 1 nm), same runs as Fig. 5"
                 "\nτ = 1 ms; " + PARAMETER_TEXT, fontsize=8.5)
    numbers["static_contact_radius_at_-10nm_m"] = static_at_deepest(curves, 2)
    numbers["png"] = save(fig, out, "fig6.png")
    return numbers


def figure7(out: Path, ds) -> dict:
    """Fig. 7: gap profiles every 0.4 ms of the 5 µm/s triangle."""
    handle = profile_plot(ds, r_max=600 * NM, gap_max=16 * NM)
    handle.figure.suptitle(
        "Fig. 7 — local gap h(r) every 0.4 ms (2 nm) for the 5 µm/s triangle 10 → −10 → 10 nm"
        "\nτ = 1 ms; " + PARAMETER_TEXT, fontsize=8.5)
    gap = ds.gap.values
    numbers = {"profile_times_s": [float(t) for t in ds.profile_time.values],
               "central_gap_first_profile_m": float(gap[0, 0]),
               "central_gap_last_profile_m": float(gap[-1, 0]),
               "central_deformation_at_end_m": float(ds.u_center.values[-1]),
               "central_deformation_at_start_m": float(ds.u_center.values[0])}
    numbers["png"] = save(handle.figure, out, "fig7.png")
    return numbers


# ── Fig. 8: loops with different turning points ─────────────────────────────────────────────────
def figure8(out: Path, problem, quick: bool, reuse) -> dict:
    """Fig. 8: loops at 5 µm/s for several turning points; inset on a log force axis."""
    n_out = 101 if quick else 401
    fig, ax = plt.subplots(figsize=(7.5, 5.2), layout="constrained")
    inset = ax.inset_axes((0.5, 0.42, 0.47, 0.45))
    numbers: dict = {"speed_m_per_s": FIG8_SPEED, "runs": []}
    for turn in sorted(FIG8_TURNS):
        drive = Triangle(top=TRIANGLE_TOP, turn=turn, speed=FIG8_SPEED)
        n = round((n_out - 1) * drive.duration / reuse.attrs["t_end"]) + 1
        ds = reuse if turn == TRIANGLE_TURN else run(problem, drive, max(21, n))
        label = f"turn at {turn / NM:g} nm".replace("-", "−")
        hysteresis_plot(ds, ax=ax, label=label)
        hysteresis_plot(ds, ax=inset, log=True)
        h, f = ds.position.values, ds.force.values
        k = turning_index(ds)
        tail = (h >= 5 * NM) & (np.arange(h.size) <= k)
        slope = np.polyfit(h[tail], np.log(f[tail]), 1)[0]
        tail_u = (h >= 5 * NM) & (np.arange(h.size) >= k)
        slope_u = np.polyfit(h[tail_u], np.log(f[tail_u]), 1)[0]
        numbers["runs"].append({
            "turn_position_m": turn, "peak_force_N": float(f.max()),
            "hysteresis_work_J": hysteresis_work(ds),
            "tail_decay_length_loading_m": float(-1.0 / slope),
            "tail_decay_length_unloading_m": float(-1.0 / slope_u), **run_info(ds)})
    inset.set_xlim(-10.5, 10.5)
    inset.set_ylim(1e-5, 10)
    inset.tick_params(labelsize=7)
    inset.xaxis.label.set_size(7)
    inset.yaxis.label.set_size(7)
    handles, _ = ax.get_legend_handles_labels()
    ax.legend(handles=handles + branch_proxies(), loc="lower right", bbox_to_anchor=(0.995, 0.08),
              fontsize=8, ncol=2)
    ax.set_title("Fig. 8 — force loops at 5 µm/s from 10 nm with turning points 0, −3, −5, −7, "
                 "−10 nm (inset: log scale)\nτ = 1 ms; " + PARAMETER_TEXT, fontsize=8.5)
    numbers["png"] = save(fig, out, "fig8.png")
    return numbers


# ── report ──────────────────────────────────────────────────────────────────────────────────────
def report(results: dict) -> list[str]:
    """Human-readable summary lines of the key numbers."""
    lines = []
    for r in results["fig1"]["runs"]:
        local = ", ".join(f"{k}: {v:.2f}τ" for k, v in r["local_decay_time_in_tau"].items())
        lines.append(
            f"Fig.1 tau={r['tau_s'] / MS:g} ms, step -5 -> {r['end_position_m'] / NM:+.0f} nm: "
            f"initial {r['initial_load_N'] / UN:.4g} uN, extreme {r['extreme_load_N'] / UN:.4g} "
            f"uN, at 10 ms {r['load_at_t_end_N'] / UN:.4g} uN, relaxed F* "
            f"{r['relaxed_load_N'] / UN:.4g} uN (paper 1.59 / 0.66); decay time of |F-F*| "
            f"fitted on [tau, 3tau] = {r['decay_time_fit_tau_to_3tau_in_tau']:.3f} tau "
            f"(paper 0.50 tau); local 1/|dln|F-F*|/dt| at t = {local}")
    for r in results["fig2"]["runs"]:
        for pos, v in r["at_position"].items():
            rigid = v["force_rigid_N"]
            rigid_text = f"{rigid / 1e-9:.4g} nN" if rigid is not None else "inf"
            lines.append(
                f"Fig.2 {r['speed_m_per_s'] / UM:g} um/s at h0={pos}: u exact "
                f"{v['u_exact_m'] / NM:.4f} nm, ODE {v['u_ode_m'] / NM:.4f} nm, Eq20 "
                f"{v['u_eq20_m'] / NM:.4f} nm; F exact {v['force_exact_N'] / 1e-9:.4g} nN, ODE "
                f"{v['force_ode_N'] / 1e-9:.4g} nN, Eq20 {v['force_eq20_N'] / 1e-9:.4g} nN, "
                f"rigid {rigid_text}")
    for r5, r6 in zip(results["fig5"]["runs"], results["fig6"]["runs"], strict=True):
        on, off = r6["contact_onset_position_m"], r6["contact_loss_position_m"]
        lines.append(
            f"Fig.5/6 {r5['speed_m_per_s'] / UM:g} um/s: peak force "
            f"{r5['peak_force_N'] / UN:.4g} uN, hysteresis work "
            f"{r5['hysteresis_work_J'] / 1e-15:.4g} fJ, peak contact radius "
            f"{r6['peak_contact_radius_m'] / NM:.4g} nm, contact from "
            f"h0={on / NM if on is not None else float('nan'):.3g} nm (loading) to "
            f"{off / NM if off is not None else float('nan'):.3g} nm (unloading); "
            f"{r5['steps']} steps")
    for name, f in results["fig5"]["static_force_at_-10nm_N"].items():
        a = results["fig6"]["static_contact_radius_at_-10nm_m"][name]
        lines.append(f"Fig.5/6 {name} at -10 nm: force {f / UN:.4g} uN, contact radius "
                     f"{a / NM:.4g} nm")
    f7 = results["fig7"]
    lines.append(
        f"Fig.7 central gap first/last profile {f7['central_gap_first_profile_m'] / NM:.4f} / "
        f"{f7['central_gap_last_profile_m'] / NM:.4f} nm; central deformation at start/end "
        f"{f7['central_deformation_at_start_m'] / NM:.4f} / "
        f"{f7['central_deformation_at_end_m'] / NM:.4f} nm")
    for r in results["fig8"]["runs"]:
        lines.append(
            f"Fig.8 turn {r['turn_position_m'] / NM:g} nm: peak force {r['peak_force_N'] / UN:.4g}"
            f" uN, hysteresis work {r['hysteresis_work_J'] / 1e-15:.4g} fJ, tail decay length "
            f"(h0 >= 5 nm) loading {r['tail_decay_length_loading_m'] / NM:.3f} nm, unloading "
            f"{r['tail_decay_length_unloading_m'] / NM:.3f} nm")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """Regenerate the figures; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("paper_figures"),
                        help="output directory (created if missing)")
    parser.add_argument("--quick", action="store_true",
                        help="fewer output times and static points (a fast smoke run)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    results: dict = {"parameters": {"radius_m": RADIUS, "pressure_Pa": PRESSURE,
                                    "wall_pressure_Pa": PRESSURE, "wall_length_m": 0.5e-9,
                                    "debye_length_m": DEBYE_LENGTH, "E0_Pa": E0,
                                    "E_inf_Pa": E_INF, "tau_s": TAU, "quick": args.quick}}
    results["fig1"] = figure1(args.out, args.quick)
    results["fig2"] = figure2(args.out, args.quick)
    problem = make_problem(TAU, TRIANGLE_TURN)
    runs = triangle_runs(problem, args.quick)
    positions = np.linspace(TRIANGLE_TOP, TRIANGLE_TURN, 11 if args.quick else 21)
    curves = statics(problem, positions)
    rigid_h = np.concatenate([np.geomspace(0.01 * NM, 1 * NM, 60, endpoint=False),
                              np.linspace(1 * NM, TRIANGLE_TOP, 60)])
    rigid = (rigid_h, np.array([problem.rigid_load(h) for h in rigid_h]))
    results["fig5"] = figure5(args.out, runs, curves, rigid)
    results["fig6"] = figure6(args.out, runs, curves)
    results["fig7"] = figure7(args.out, runs[max(runs)])
    results["fig8"] = figure8(args.out, problem, args.quick, runs[FIG8_SPEED])
    results["elapsed_s"] = time.perf_counter() - start
    for line in report(results):
        print(line)
    print(f"wrote {len(list(args.out.glob('fig*.png')))} PNGs and figures.json to {args.out} in "
          f"{results['elapsed_s']:.1f} s")
    (args.out / "figures.json").write_text(json.dumps(results, indent=2, ensure_ascii=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
