"""Model commands: ``static``, ``simulate`` and ``spectrum`` (the solver side of the CLI).

Each command is a pair in :data:`SUBCOMMANDS`: a function that adds its flags to a parser and a
function that runs it on the parsed arguments (returning the exit status). The library is
imported inside the run functions, so that building a parser (``--help``) stays cheap and each
command loads only what it uses.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

from viscoforce._files import write_netcdf
from viscoforce._limits import MAX_SAMPLES
from viscoforce.cli._args import (
    FIGURE,
    MATERIAL_FLAGS,
    NETCDF,
    NUMERICS_FLAGS,
    SYSTEM_FLAGS,
    Flag,
    FlagGroup,
    OmegaList,
    OmegaRange,
    Output,
    UsageError,
    add_flags,
    add_outputs,
    frequency_type,
    integer_type,
    real_type,
)
from viscoforce.cli._force_law import (
    FORCE_LAW_FLAGS,
    _branch_result,
    _check_force_law,
    _equilibrium,
    law_from_args,
)
from viscoforce.cli._output import print_json, print_table, print_written
from viscoforce.exceptions import ModelValidityWarning
from viscoforce.physics.materials import Elastic, PronySeries, StandardLinearSolid
from viscoforce.physics.paper import PAPER

if TYPE_CHECKING:
    from viscoforce._typing import SeparationHistory
    from viscoforce.physics.materials import ViscoelasticMaterial
    from viscoforce.problem import ContactProblem

__all__ = ["SUBCOMMANDS", "material_from_args", "problem_from_args"]

_JSON = "print one JSON object (SI units)"
_PROGRESS = "progress bar (default: when stderr is a terminal)"


# ── from flags to library objects (shared by the commands) ───────────────────────────────────────

def material_from_args(args: argparse.Namespace) -> ViscoelasticMaterial:
    """The material of the :data:`~viscoforce.cli._args.MATERIAL_FLAGS` (default: the paper's).

    Raises
    ------
    UsageError
        If more than one material is given.
    """
    sls = (args.E0, args.E_inf, args.tau)
    given = [name for name, v in (("--E", args.E), ("--prony", args.prony)) if v is not None]
    if any(v is not None for v in sls):
        given.append("--E0/--E-inf/--tau")
    if len(given) > 1:
        raise UsageError(f"give one material: {' or '.join(given)} were all given")
    if args.E is not None:
        return Elastic(args.E)
    if args.prony is not None:
        from viscoforce.io.csv_formats import read_prony_moduli

        return PronySeries.from_moduli(*read_prony_moduli(args.prony))
    defaults = (PAPER.E0, PAPER.E_inf, PAPER.tau)
    e0, e_inf, tau = (d if v is None else v for v, d in zip(sls, defaults, strict=True))
    return StandardLinearSolid(E0=e0, E_inf=e_inf, tau=tau)


def _range_type(text: str) -> tuple[float, float]:
    """``START:STOP`` positions with units (``2nm:-1nm``; the path runs from START to STOP)."""
    from viscoforce.units import parse_quantity

    parts = text.split(":")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(
            f"invalid range {text!r}: give START:STOP with units, e.g. 2nm:-1nm")
    try:
        return tuple(parse_quantity(p, "length", name="--h0-range") for p in parts)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def problem_from_args(args: argparse.Namespace, material: ViscoelasticMaterial,
                      deepest: float, *, adhesive_grid: bool = False) -> ContactProblem:
    """The contact problem of the system and numerics flags, sized for ``deepest`` [m].

    ``adhesive_grid``: with a Lennard-Jones law and neither --grid-spacing nor --outer-radius,
    the compact grid of :func:`~viscoforce.solvers.continuation.adhesion_grid` (E = E_inf; the
    slowly decaying attraction beyond it is the rigid tail the adhesive solvers add).
    """
    from viscoforce.physics.particle import Particle
    from viscoforce.problem import ContactProblem

    law = law_from_args(args)
    if adhesive_grid and args.grid_spacing is None and args.outer_radius is None:
        from viscoforce.solvers.continuation import adhesion_grid, lennard_jones_term

        if lennard_jones_term(law) is not None:
            grid = adhesion_grid(Particle(args.R), law, material.relaxed_modulus, deepest)
            return ContactProblem(Particle(args.R), law, material, grid)
    return ContactProblem.create(sphere=Particle(args.R), surface_force=law, material=material,
                                 deepest_position=deepest, grid_spacing=args.grid_spacing,
                                 outer_radius=args.outer_radius)


def _save_figure(handle, path: str) -> None:
    import matplotlib.pyplot as plt

    from viscoforce._files import atomic_output

    try:
        with atomic_output(path) as tmp:
            handle.figure.savefig(tmp, dpi=120, bbox_inches="tight",
                                  format=Path(path).suffix.lstrip(".").lower() or None)
    finally:
        plt.close(handle.figure)


# ── static ───────────────────────────────────────────────────────────────────────────────────────

STATIC_FLAGS = FlagGroup(None, (
    Flag("--h0", "length", None, "LENGTH",
         "apex position h0 (may be negative, e.g. --h0=-5nm or --h0 -5nm); or --h0-range"),
    Flag("--h0-range", _range_type, None, "START:STOP",
         "trace the equilibria from START to STOP through the jumps (pseudo-arclength "
         "continuation), e.g. --h0-range=2nm:-1nm; --json adds jump_in, jump_out, pull_off"),
    Flag("--modulus", "pressure", None, "PRESSURE",
         "elastic modulus E in the paper's convention (2/E = sum (1-nu^2)/E_i)", required=True,
         dest="E", aliases=("--E",)),
    Flag("--contact-threshold", "length", None, "LENGTH",
         "gap below which surfaces count as in contact (default 1/kappa)"),
))


def add_static(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce static``."""
    add_flags(parser, STATIC_FLAGS)
    add_outputs(parser, [Output("--out", NETCDF, "FILE.nc", "write the profiles (netCDF)")])
    parser.add_argument("--json", action="store_true", help=_JSON)
    add_flags(parser, SYSTEM_FLAGS)
    add_flags(parser, FORCE_LAW_FLAGS)
    add_flags(parser, NUMERICS_FLAGS)


def _run_static_path(args: argparse.Namespace) -> int:
    """``static --h0-range``: the equilibrium path, its jumps and the pull-off."""
    from viscoforce.solvers.continuation import equilibrium_path

    start, stop = args.h0_range
    problem = problem_from_args(args, Elastic(args.E), min(start, stop), adhesive_grid=True)
    path = equilibrium_path(problem, start, stop, contact_threshold=args.contact_threshold)
    if args.out:
        write_netcdf(path.to_dataset(), args.out, engine="scipy")
    result = {"position": path.position, "force": path.force, "stable": path.stable.tolist(),
              "pull_off": path.pull_off}
    for name in ("jump_in", "jump_out"):
        fold = getattr(path, name)
        result[name] = None if fold is None else {"position": fold.position, "time": None,
                                                  "force": fold.force}
    if args.json:
        print_json(result)
        return 0
    rows = [(f"{f.kind} at h0", f.position, "length") for f in path.folds]
    rows += [(f"{f.kind} force", f.force, "force") for f in path.folds]
    if path.pull_off is not None:
        rows.append(("pull-off force", path.pull_off, "force"))
    print_table(rows)
    print(f"({len(path.position)} equilibria on {problem.grid.size} nodes)")
    print_written(args.out)
    return 0


def run_static(args: argparse.Namespace) -> int:
    """Static elastic equilibrium at ``--h0``; prints the loads, deformation, contact radius."""
    _check_force_law(args)
    if (args.h0 is None) == (args.h0_range is None):
        raise UsageError("give either --h0 H or --h0-range START:STOP")
    if args.h0_range is not None:
        return _run_static_path(args)
    problem = problem_from_args(args, Elastic(args.E), args.h0, adhesive_grid=True)
    ds, extra = _equilibrium(args, problem)
    if args.out:
        write_netcdf(ds, args.out, engine="scipy")
    result = {
        "h0": float(ds.position),
        "force": float(ds.force),
        "force_rigid": float(ds.force_rigid),  # +inf where the undeformed bodies overlap: null
        "u_center": float(ds.u_center),
        "h_center": float(ds.h_center),
        "contact_radius": float(ds.contact_radius),
        "newton_iterations": int(ds.attrs["newton_iterations"]),
        "grid_nodes": int(problem.grid.size),
    } | extra
    if args.json:
        print_json(result)
        return 0
    print_table([
        ("position h0", result["h0"], "length"),
        ("load F", result["force"], "force"),
        ("rigid load", result["force_rigid"], "force"),
        ("central deformation u(0)", result["u_center"], "length"),
        ("central gap h(0)", result["h_center"], "length"),
        ("contact radius", result["contact_radius"], "length"),
    ])
    print(f"({result['newton_iterations']} Newton iterations on {result['grid_nodes']} nodes)")
    if extra:
        print(f"attractive law: the {args.branch} history's equilibrium, on the "
              f"{extra['on_branch']} branch (load with the rigid tail beyond the grid)")
    print_written(args.out)
    return 0


# ── simulate ─────────────────────────────────────────────────────────────────────────────────────

DRIVE_FLAGS = FlagGroup("drive", (
    Flag("--from", "length", None, "LENGTH", "start position (step, ramp) or top (triangle)",
         dest="from_"),
    Flag("--to", "length", None, "LENGTH",
         "end position (step, ramp) or turning point (triangle)"),
    Flag("--duration", "time", None, "TIME", "ramp duration, or step rise time (default 0.1ms)"),
    Flag("--speed", "speed", None, "SPEED", "drive speed (ramp, triangle), e.g. 5um/s"),
    Flag("--h0", "length", None, "LENGTH", "sine mean position"),
    Flag("--eta", "length", None, "LENGTH", "sine amplitude"),
    Flag("--omega", frequency_type(), None, "FREQ",
         "sine frequency with its unit: 100Hz (f) or 628rad/s (omega); a bare number is "
         "refused"),
    Flag("--periods", real_type(1.0), 10.0, "N", "sine periods, a finite number >= 1 (default 10)"),
    Flag("--trace", None, None, "FILE.csv",
         "measured trace: CSV with 'time (s)' and 'position (nm)' columns"),
))

SIMULATE_FLAGS = FlagGroup(None, (
    Flag("--t-end", "time", None, "TIME", "total simulated time (default: drive end plus 5 tau)"),
    Flag("--samples", integer_type(2, MAX_SAMPLES, what="output samples"), 401, "N",
         "output samples, an integer >= 2 (default 401)"),
    Flag("--profiles", integer_type(0), 0, "K",
         "store h(r), u(r), p(r) every K-th sample in --out (0: none)"),
    Flag("--dt", "time", None, "TIME",
         "fixed time step (default: adaptive; euler: 0.1 tau E_inf/E0)"),
    Flag("--tol", "length", None, "LENGTH",
         "local error tolerance of adaptive steps (default 1e-5 debye lengths)"),
))


def _add_run_flags(parser: argparse.ArgumentParser, own: FlagGroup) -> None:
    """--progress, --json, the command's own group, then material, system and numerics flags."""
    parser.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                        help=_PROGRESS)
    parser.add_argument("--json", action="store_true", help=_JSON)
    for group in (own, MATERIAL_FLAGS, SYSTEM_FLAGS, NUMERICS_FLAGS):
        add_flags(parser, group)


def add_simulate(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce simulate``."""
    from viscoforce.solvers.steppers import DEFAULT_METHOD, METHODS

    parser.add_argument("--drive", required=True, choices=["step", "ramp", "triangle", "sine",
                                                           "trace"])
    add_flags(parser, SIMULATE_FLAGS)
    parser.add_argument("--method", default=DEFAULT_METHOD, choices=[*sorted(METHODS), "auto"],
                        help=f"time stepper (default {DEFAULT_METHOD}); auto: the stepper and "
                             "tol that meet --accuracy")
    parser.add_argument("--accuracy", type=real_type(0.0), default=None, metavar="REL",
                        help="--method auto: relative force error required, in [1e-4, 0.1] "
                             "(default 1e-3)")
    add_outputs(parser, [
        Output("--out", NETCDF, "FILE.nc", "write the dataset (netCDF)"),
        Output("--plot", FIGURE, "FILE.png", "write the force-position (hysteresis) plot"),
    ])
    _add_run_flags(parser, DRIVE_FLAGS)
    add_flags(parser, FORCE_LAW_FLAGS)


def drive_from_args(args: argparse.Namespace) -> SeparationHistory:
    """The drive of ``--drive`` and the drive flags.

    Raises
    ------
    UsageError
        If a flag the drive needs is missing.
    """
    from viscoforce.experiments.drives import MeasuredTrace, Ramp, Sinusoid, Step, Triangle

    kind = args.drive

    def need(*names: str) -> None:
        missing = [f"--{n.replace('_', '-').rstrip('-')}" for n in names
                   if getattr(args, n) is None]
        if missing:
            raise UsageError(f"--drive {kind} needs {', '.join(missing)}")

    if kind in ("step", "ramp"):
        need("from_", "to")
        if kind == "step":
            return Step(args.from_, args.to, 1e-4 if args.duration is None else args.duration)
        if args.duration is not None:
            return Ramp(args.from_, args.to, args.duration)
        need("speed")
        return Ramp.from_speed(args.from_, args.to, args.speed)
    if kind == "triangle":
        need("from_", "to", "speed")
        return Triangle(args.from_, args.to, args.speed)
    if kind == "sine":
        need("h0", "eta", "omega")
        return Sinusoid(args.h0, args.eta, args.omega, periods=args.periods)
    need("trace")
    from viscoforce.io.csv_formats import read_trace

    time, position = read_trace(args.trace)
    return MeasuredTrace(time, position)


def run_simulate(args: argparse.Namespace) -> int:
    """Viscoelastic response along the drive; prints a summary, writes --out and --plot."""
    import numpy as np

    from viscoforce.solvers.simulate import default_end_time, simulate

    drive = drive_from_args(args)
    material = material_from_args(args)
    _check_force_law(args)
    if args.branch != "approach":
        raise UsageError("--branch applies to static --h0 and spectrum: simulate's drive is the "
                         "history that chooses the branch")
    problem = problem_from_args(args, material, float(drive.extent()[0]), adhesive_grid=True)
    t_end = default_end_time(problem, drive) if args.t_end is None else args.t_end
    t_eval = np.linspace(0.0, t_end, args.samples)
    if args.accuracy is not None and args.method != "auto":
        raise UsageError("--accuracy needs --method auto")
    if args.method == "auto" and (args.dt is not None or args.tol is not None):
        raise UsageError("--method auto chooses the stepper and its tolerance: drop --dt/--tol, "
                         "or name the stepper (--method exponential)")
    ds = simulate(problem, drive, t_end=t_end, t_eval=t_eval, stepper=args.method, dt=args.dt,
                  tol=args.tol, profiles=args.profiles, progress=args.progress,
                  accuracy=args.accuracy)
    if args.out:
        write_netcdf(ds, args.out, engine="scipy")
    if args.plot:
        from viscoforce.plotting import hysteresis_plot

        handle = hysteresis_plot(ds, label=f"{type(material).__name__}")
        handle.ax.set_title(str(ds.attrs["drive"]), fontsize="small")
        _save_figure(handle, args.plot)
    settings = dict(ds.attrs)
    chosen = {"explanation": settings["explanation"]} if "explanation" in settings else {}
    adhesion = _adhesion_result(settings)
    if args.json:
        print_json({name: ds[name].values for name in ("time", "position", "force", "u_center",
                                                        "contact_radius")}
                   | {"settings": settings} | chosen | adhesion)
        return 0
    if chosen:
        print(f"stepper {settings['stepper']}: {chosen['explanation']}")
    print(f"{settings['drive']}; {type(material).__name__}; stepper {settings['stepper']}: "
          f"{settings['steps']} steps ({settings['rejected_steps']} rejected), "
          f"{settings['newton_iterations']} Newton iterations")
    i = int(np.argmax(ds.force.values))
    print_table([
        ("peak force", float(ds.force[i]), "force"),
        ("at position", float(ds.position[i]), "length"),
        ("final force", float(ds.force[-1]), "force"),
        ("final u(0)", float(ds.u_center[-1]), "length"),
        ("max contact radius", float(ds.contact_radius.max()), "length"),
    ])
    if adhesion:
        rows = [("pull-off force", adhesion["pull_off"], "force")]
        for kind in ("jump_in", "jump_out"):
            if adhesion[kind] is not None:
                rows += [(f"{kind} at h0", adhesion[kind]["position"], "length"),
                         (f"{kind} force", adhesion[kind]["force"], "force")]
        print_table(rows)
        print(f"hysteresis energy -∮F dh0 = {adhesion['hysteresis_energy']:.4g} J")
    print_written(args.out, args.plot)
    return 0


def _adhesion_result(settings: dict) -> dict:
    """The adhesion keys of an adhesive run's ``--json`` (empty for a repulsive law).

    ``jump_in``, ``jump_out`` ({position, time, force, end_*} or None), ``pull_off`` [N],
    ``hysteresis_energy`` [J] and ``effective_work_of_adhesion`` [J/m²].
    """
    if "pull_off" not in settings:
        return {}
    from viscoforce.solvers.adhesive_dynamics import jumps_from_attrs

    return jumps_from_attrs(settings) | {
        "hysteresis_energy": float(settings["hysteresis_energy"]),
        "hysteresis_quadrature_error": float(settings["hysteresis_quadrature_error"]),
        "effective_work_of_adhesion": float(settings["effective_work_of_adhesion"])}


# ── spectrum ─────────────────────────────────────────────────────────────────────────────────────

SPECTRUM_FLAGS = FlagGroup(None, (
    Flag("--h0", "length", None, "LENGTH", "mean position", required=True),
    Flag("--eta", "length", None, "LENGTH", "drive amplitude eta", required=True),
))

TIME_DOMAIN_FLAGS = FlagGroup("time-domain method", (
    Flag("--periods", integer_type(1), None, "N",
         "demodulated periods after settling (default: per frequency the fewest whose lock-in "
         "transient bound is <= 1/10 of the accuracy, 1e-3; svda-ode: 4)"),
    Flag("--workers", integer_type(1), 1, "N", "worker processes (default 1)", dest="jobs",
         aliases=("--jobs",)),
))


def add_spectrum(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce spectrum``."""
    add_flags(parser, SPECTRUM_FLAGS)
    parser.add_argument("--omega", type=frequency_type(), nargs="+",
                        action=OmegaList, default=None, metavar="FREQ",
                        help="frequencies with their unit: 100Hz (f), 628rad/s (omega), 1kHz; a "
                             "bare number is refused")
    parser.add_argument("--omega-range", nargs=3, action=OmegaRange, default=None,
                        metavar=("LO", "HI", "N"),
                        help="N log-spaced frequencies from LO to HI (LO, HI with units, e.g. "
                             "1Hz 1kHz; N a plain integer >= 1)")
    parser.add_argument("--method", default="linear",
                        choices=["linear", "time-domain", "svda", "svda-ode", "contact", "auto"],
                        help="exact frequency-domain (default), time-domain simulation + "
                             "lock-in, SVDA closed form, SVDA ODE + lock-in, Hertz contact, or "
                             "auto (the cheapest meeting --accuracy)")
    parser.add_argument("--accuracy", type=real_type(0.0), default=None, metavar="REL",
                        help="--method auto: relative error of k* required, in [1e-4, 0.1] "
                             "(default 1e-3)")
    add_outputs(parser, [
        Output("--out", NETCDF, "FILE.nc", "write the spectrum (netCDF)"),
        Output("--plot", FIGURE, "FILE.png", "write a Bode plot"),
    ])
    _add_run_flags(parser, TIME_DOMAIN_FLAGS)
    add_flags(parser, FORCE_LAW_FLAGS)


def _omega(args: argparse.Namespace):
    import numpy as np

    if (args.omega is None) == (args.omega_range is None):
        raise UsageError("give either --omega W [W ...] or --omega-range LO HI N")
    if args.omega is not None:
        return np.array(args.omega, dtype=float)
    lo, hi, n = args.omega_range  # validated (and n bounded) by OmegaRange
    return np.geomspace(lo, hi, n)


def _print_spectrum(result: dict) -> None:
    if result.get("explanation"):
        print(f"method {result['method']}: {result['explanation']}")
    print(f"{'omega [rad/s]':>14} {'stiffness [N/m]':>16} {'amplitude a':>12} {'phase [deg]':>12}"
          f" {'mean force [N]':>15}")
    for row in zip(result["omega"], result["stiffness"], result["amplitude"],
                   result["phase_deg"], result["mean_force"], strict=True):
        print(f"{row[0]:14.5g} {row[1]:16.6g} {row[2]:12.6g} {row[3]:12.4f} {row[4]:15.6g}")


def run_spectrum(args: argparse.Namespace) -> int:
    """Force spectrum by the chosen method (``auto``: the library's choice, with its reason)."""
    from viscoforce.experiments.spectroscopy import spectrum

    _check_force_law(args)
    omega = _omega(args)
    problem = problem_from_args(args, material_from_args(args), args.h0 - args.eta,
                                adhesive_grid=True)
    adhesive = args.force_law != "double-layer"
    if args.accuracy is not None and args.method != "auto":
        raise UsageError("--accuracy needs --method auto")
    options: dict = {}
    if args.method == "svda-ode":
        options = {"progress": args.progress}
    if args.method in ("time-domain", "auto"):  # auto drops them unless it simulates
        options = {"n_jobs": args.jobs, "progress": args.progress}
    if args.periods is not None and options:  # the linear routes take no options
        options["periods"] = args.periods
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ModelValidityWarning)
        if adhesive:  # the one route: the linear response about the --branch state
            options = {"branch": args.branch}
        ds = spectrum(problem, args.h0, args.eta, omega, method=args.method,
                      accuracy=args.accuracy, **options)
    notes = [str(w.message) for w in caught if issubclass(w.category, ModelValidityWarning)]
    for w in caught:
        if not issubclass(w.category, ModelValidityWarning):
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    note = "; ".join(notes)
    if args.out:
        write_netcdf(ds, args.out, engine="scipy")
    if args.plot:
        from viscoforce.plotting import bode_plot

        _save_figure(bode_plot(ds), args.plot)
    result = {"omega": ds.omega.values.tolist(), "amplitude": ds.amplitude.values.tolist(),
              "stiffness": ds.stiffness.values.tolist(), "phase_deg": ds.phase.values.tolist(),
              "mean_force": ds.mean_force.values.tolist(), "method": str(ds.attrs["method"])}
    if adhesive:
        result |= _branch_result(ds.attrs)
    if ds.attrs.get("explanation"):
        result["explanation"] = str(ds.attrs["explanation"])
        result["estimated_error"] = float(ds.attrs["estimated_error"])
    if note:
        result["note"] = note
        print(f"viscoforce spectrum: warning: {note}", file=sys.stderr)
    if args.json:
        print_json(result)
        return 0
    _print_spectrum(result)
    print_written(args.out, args.plot)
    return 0


#: The commands of this module: name → (add the flags to a parser, run the parsed arguments).
SUBCOMMANDS = {
    "static": (add_static, run_static),
    "simulate": (add_simulate, run_simulate),
    "spectrum": (add_spectrum, run_spectrum),
}
