"""Command-line interface: ``viscoforce <command> [flags]`` (also ``python -m viscoforce``).

The CLI parses flags (SI or unit-suffixed quantities), calls the public API and prints or writes
results; it holds no physics. Exit status: 0 success, 2 user error (one message on stderr, no
traceback), 1 internal error. ``--json`` prints one JSON object in SI units.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Sequence

from viscoforce import __version__
from viscoforce.exceptions import ViscoforceError
from viscoforce.experiments.drives import MeasuredTrace, Ramp, Sinusoid, Step, Triangle
from viscoforce.io.tables import read_prony_moduli, read_trace
from viscoforce.physics.materials import (
    Elastic,
    PronySeries,
    StandardLinearSolid,
    ViscoelasticMaterial,
)
from viscoforce.physics.paper import PAPER, paper_pressure_law
from viscoforce.physics.particle import Sphere
from viscoforce.physics.surface_forces import SurfaceForceLaw
from viscoforce.problem import ContactProblem
from viscoforce.solvers.simulate import default_end_time, simulate
from viscoforce.solvers.static import static_equilibrium
from viscoforce.solvers.steppers import DEFAULT_METHOD, METHODS
from viscoforce.units import format_quantity, normalize_negative_args, quantity_type

_LENGTH = quantity_type("length")
_PRESSURE = quantity_type("pressure")
_TIME = quantity_type("time")
_SPEED = quantity_type("speed")
_OMEGA = quantity_type("angular_frequency")


class UsageError(ViscoforceError, ValueError):
    """A command-line combination that cannot be run (exit status 2)."""


def _finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _add_system_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("system (defaults: the paper's values)")
    g.add_argument("--R", type=_LENGTH, default=PAPER.R, metavar="LENGTH",
                   help="sphere radius R (default 10um)")
    g.add_argument("--P", type=_PRESSURE, default=PAPER.P, metavar="PRESSURE",
                   help="double-layer pressure scale P (default 1e7Pa)")
    g.add_argument("--Pw", type=_PRESSURE, default=PAPER.Pw, metavar="PRESSURE",
                   help="soft-wall pressure Pw (default 1e7Pa)")
    g.add_argument("--z0", type=_LENGTH, default=PAPER.z0, metavar="LENGTH",
                   help="soft-wall length z0 (default 0.5nm)")
    g.add_argument("--debye-length", type=_LENGTH, default=PAPER.debye_length, metavar="LENGTH",
                   help="Debye length 1/kappa (default 1nm)")


def _add_numerics_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("numerics")
    g.add_argument("--grid-spacing", type=_LENGTH, default=None, metavar="LENGTH",
                   help="mean radial node spacing (default from sqrt(2R/kappa))")
    g.add_argument("--outer-radius", type=_LENGTH, default=None, metavar="LENGTH",
                   help="outer radius of the grid (default: where the force is negligible)")


def _add_material_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("material (default: the paper's E0=1e10Pa, E_inf=1e9Pa, tau=1ms)")
    g.add_argument("--E", type=_PRESSURE, default=None, metavar="PRESSURE",
                   help="purely elastic modulus (paper convention 2/E = sum (1-nu^2)/E_i)")
    g.add_argument("--E0", type=_PRESSURE, default=None, metavar="PRESSURE",
                   help="instantaneous modulus of the standard linear solid")
    g.add_argument("--E-inf", type=_PRESSURE, default=None, metavar="PRESSURE",
                   help="relaxed modulus of the standard linear solid")
    g.add_argument("--tau", type=_TIME, default=None, metavar="TIME",
                   help="creep time tau of Eq. 3 (decay time of C(t), not the stress-relaxation time)")
    g.add_argument("--prony", default=None, metavar="FILE.csv",
                   help="n-mode Prony series: CSV 'modulus (Pa),tau (s)', rows E_0..E_inf, "
                        "last tau empty")


def _material(args: argparse.Namespace) -> ViscoelasticMaterial:
    sls = (args.E0, args.E_inf, args.tau)
    given = [name for name, v in (("--E", args.E), ("--prony", args.prony)) if v is not None]
    if any(v is not None for v in sls):
        given.append("--E0/--E-inf/--tau")
    if len(given) > 1:
        raise UsageError(f"give one material: {' or '.join(given)} were all given")
    if args.E is not None:
        return Elastic(args.E)
    if args.prony is not None:
        return PronySeries.from_moduli(*read_prony_moduli(args.prony))
    defaults = (PAPER.E0, PAPER.E_inf, PAPER.tau)
    e0, e_inf, tau = (d if v is None else v for v, d in zip(sls, defaults, strict=True))
    return StandardLinearSolid(E0=e0, E_inf=e_inf, tau=tau)


def _law(args: argparse.Namespace) -> SurfaceForceLaw:
    return paper_pressure_law(args.P, args.debye_length, args.Pw, args.z0)


def _problem(args: argparse.Namespace, material: ViscoelasticMaterial,
             deepest: float) -> ContactProblem:
    return ContactProblem.create(sphere=Sphere(args.R), surface_force=_law(args),
                                 material=material, deepest_position=deepest,
                                 grid_spacing=args.grid_spacing, outer_radius=args.outer_radius)


def _print_table(rows: Sequence[tuple[str, float, str]]) -> None:
    width = max(len(name) for name, _, _ in rows)
    for name, value, dim in rows:
        text = format_quantity(value, dim) if math.isfinite(value) else str(value)
        print(f"{name:<{width}}  {text}")


def _cmd_static(args: argparse.Namespace) -> int:
    problem = _problem(args, Elastic(args.E), args.h0)
    ds = static_equilibrium(problem, args.h0, contact_threshold=args.contact_threshold)
    if args.out:
        ds.to_netcdf(args.out, engine="scipy")
    result = {
        "h0": float(ds.position),
        "force": float(ds.force),
        "force_rigid": _finite_or_none(float(ds.force_rigid)),
        "u_center": float(ds.u_center),
        "h_center": float(ds.h_center),
        "contact_radius": float(ds.contact_radius),
        "newton_iterations": int(ds.attrs["newton_iterations"]),
        "grid_nodes": int(problem.grid.size),
    }
    if args.json:
        print(json.dumps(result))
    else:
        _print_table([
            ("position h0", result["h0"], "length"),
            ("load F", result["force"], "force"),
            ("rigid load", float(ds.force_rigid), "force"),
            ("central deformation u(0)", result["u_center"], "length"),
            ("central gap h(0)", result["h_center"], "length"),
            ("contact radius", result["contact_radius"], "length"),
        ])
        print(f"({result['newton_iterations']} Newton iterations on {result['grid_nodes']} nodes)")
    return 0


def _drive(args: argparse.Namespace):
    kind = args.drive

    def need(*names):
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
    time, position = read_trace(args.trace)
    return MeasuredTrace(time, position)


def _cmd_simulate(args: argparse.Namespace) -> int:
    import numpy as np

    if args.samples < 2:
        raise UsageError(f"--samples must be an integer >= 2, got {args.samples}")
    if args.profiles < 0:
        raise UsageError(f"--profiles must be >= 0, got {args.profiles}")
    drive = _drive(args)
    material = _material(args)
    problem = _problem(args, material, float(drive.extent()[0]))
    t_end = default_end_time(problem, drive) if args.t_end is None else args.t_end
    t_eval = np.linspace(0.0, t_end, args.samples)
    ds = simulate(problem, drive, t_end=t_end, t_eval=t_eval, stepper=args.method, dt=args.dt,
                  tol=args.tol, profiles=args.profiles, progress=args.progress)
    if args.out:
        ds.to_netcdf(args.out, engine="scipy")
    if args.plot:
        from viscoforce.plotting import hysteresis_plot

        handle = hysteresis_plot(ds, label=f"{type(material).__name__}")
        handle.ax.set_title(str(ds.attrs["drive"]), fontsize="small")
        handle.figure.savefig(args.plot, dpi=120, bbox_inches="tight")
    settings = {k: (v.item() if hasattr(v, "item") else v) for k, v in ds.attrs.items()}
    if args.json:
        print(json.dumps({
            "time": ds.time.values.tolist(),
            "position": ds.position.values.tolist(),
            "force": ds.force.values.tolist(),
            "u_center": ds.u_center.values.tolist(),
            "contact_radius": ds.contact_radius.values.tolist(),
            "settings": settings,
        }))
    else:
        print(f"{settings['drive']}; {type(material).__name__}; stepper {settings['stepper']}: "
              f"{settings['steps']} steps ({settings['rejected_steps']} rejected), "
              f"{settings['newton_iterations']} Newton iterations")
        i = int(np.argmax(ds.force.values))
        _print_table([
            ("peak force", float(ds.force[i]), "force"),
            ("at position", float(ds.position[i]), "length"),
            ("final force", float(ds.force[-1]), "force"),
            ("final u(0)", float(ds.u_center[-1]), "length"),
            ("max contact radius", float(ds.contact_radius.max()), "length"),
        ])
        for path in (args.out, args.plot):
            if path:
                print(f"wrote {path}")
    return 0


def _choose_spectrum_method(args: argparse.Namespace, problem: ContactProblem) -> tuple[str, str]:
    """The cheapest adequate method for the requested spectrum, with the reason."""
    kappa_eta = args.eta / problem.surface_force.decay_length
    if kappa_eta <= 0.05:
        return "linear", (f"kappa*eta = {kappa_eta:.3g} <= 0.05: the nonlinear correction to the "
                          f"stiffness is O((kappa*eta)^2) ~ {kappa_eta ** 2:.1e}, so the exact "
                          "small-amplitude frequency-domain solve is used")
    return "time-domain", (f"kappa*eta = {kappa_eta:.3g} > 0.05: the response is not linear "
                           "enough, so each frequency is simulated to steady state and "
                           "demodulated")


def _cmd_spectrum(args: argparse.Namespace) -> int:
    import numpy as np

    from viscoforce.experiments.spectroscopy import SPECTRUM_METHODS

    if (args.omega is None) == (args.omega_range is None):
        raise UsageError("give either --omega W [W ...] or --omega-range LO HI N")
    if args.omega is not None:
        omega = np.array(args.omega, dtype=float)
    else:
        lo, hi, n = args.omega_range
        n_points = int(n)
        if n_points != n or n_points < 1 or not 0 < lo < hi:
            raise UsageError(
                f"--omega-range needs 0 < LO < HI and an integer N >= 1, got {lo:g} {hi:g} {n:g}")
        omega = np.geomspace(lo, hi, n_points)
    material = _material(args)
    problem = _problem(args, material, args.h0 - args.eta)
    method, explanation = args.method, ""
    auto_method, reason = _choose_spectrum_method(args, problem)
    note = ""
    if method == "auto":
        method, explanation = auto_method, reason
    elif method == "linear" and auto_method != "linear":
        note = (f"note: {reason.split(':')[0]}: the small-amplitude spectrum may differ from the "
                "finite-amplitude response by several percent; use --method time-domain")
    kwargs = {}
    if method == "time-domain":
        kwargs = {"n_jobs": args.jobs, "progress": args.progress, "periods": args.periods}
    ds = SPECTRUM_METHODS[method](problem, args.h0, args.eta, omega, **kwargs)
    if args.out:
        ds.to_netcdf(args.out, engine="scipy")
    if args.plot:
        from viscoforce.plotting import bode_plot

        handle = bode_plot(ds)
        handle.figure.savefig(args.plot, dpi=120, bbox_inches="tight")
    result = {
        "omega": ds.omega.values.tolist(),
        "amplitude": ds.amplitude.values.tolist(),
        "stiffness": ds.stiffness.values.tolist(),
        "phase_deg": ds.phase.values.tolist(),
        "mean_force": ds.mean_force.values.tolist(),
        "method": method,
    }
    if explanation:
        result["explanation"] = explanation
    if note:
        result["note"] = note
        print(f"viscoforce spectrum: {note}", file=sys.stderr)
    if args.json:
        print(json.dumps(result))
        return 0
    if explanation:
        print(f"method {method}: {explanation}")
    print(f"{'omega [rad/s]':>14} {'stiffness [N/m]':>16} {'amplitude a':>12} {'phase [deg]':>12}"
          f" {'mean force [N]':>15}")
    for row in zip(result["omega"], result["stiffness"], result["amplitude"],
                   result["phase_deg"], result["mean_force"], strict=True):
        print(f"{row[0]:14.5g} {row[1]:16.6g} {row[2]:12.6g} {row[3]:12.4f} {row[4]:15.6g}")
    if args.plot:
        print(f"wrote {args.plot}")
    return 0


def _build_parser() -> tuple[argparse.ArgumentParser, set[str], set[str]]:
    parser = argparse.ArgumentParser(
        prog="viscoforce",
        description="Viscoelastic particles with finite-ranged surface forces (SI or unit "
                    "suffixes: -5nm, 10um, 1e9Pa, 0.1ms, 5um/s).")
    parser.add_argument("--version", action="version", version=f"viscoforce {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="command")
    sub.required = True

    st = sub.add_parser("static", help="static elastic equilibrium at one position")
    st.add_argument("--h0", type=_LENGTH, required=True, metavar="LENGTH",
                    help="apex position h0 (may be negative, e.g. --h0=-5nm or --h0 -5nm)")
    st.add_argument("--E", type=_PRESSURE, required=True, metavar="PRESSURE",
                    help="elastic modulus E in the paper's convention (2/E = sum (1-nu^2)/E_i)")
    st.add_argument("--contact-threshold", type=_LENGTH, default=None, metavar="LENGTH",
                    help="gap below which surfaces count as in contact (default 1/kappa)")
    st.add_argument("--out", default=None, metavar="FILE.nc", help="write the profiles (netCDF)")
    st.add_argument("--json", action="store_true", help="print one JSON object (SI units)")
    _add_system_flags(st)
    _add_numerics_flags(st)
    st.set_defaults(func=_cmd_static)

    si = sub.add_parser("simulate", help="viscoelastic response along a drive h0(t)")
    si.add_argument("--drive", required=True, choices=["step", "ramp", "triangle", "sine", "trace"])
    si.add_argument("--from", dest="from_", type=_LENGTH, default=None, metavar="LENGTH",
                    help="start position (step, ramp) or top (triangle)")
    si.add_argument("--to", type=_LENGTH, default=None, metavar="LENGTH",
                    help="end position (step, ramp) or turning point (triangle)")
    si.add_argument("--duration", type=_TIME, default=None, metavar="TIME",
                    help="ramp duration, or step rise time (default 0.1ms)")
    si.add_argument("--speed", type=_SPEED, default=None, metavar="SPEED",
                    help="drive speed (ramp, triangle), e.g. 5um/s")
    si.add_argument("--h0", type=_LENGTH, default=None, metavar="LENGTH", help="sine mean position")
    si.add_argument("--eta", type=_LENGTH, default=None, metavar="LENGTH", help="sine amplitude")
    si.add_argument("--omega", type=_OMEGA, default=None, metavar="FREQ",
                    help="sine angular frequency (rad/s, or e.g. 100Hz)")
    si.add_argument("--periods", type=float, default=10.0, help="sine periods (default 10)")
    si.add_argument("--trace", default=None, metavar="FILE.csv",
                    help="measured trace: CSV with 'time (s)' and 'position (nm)' columns")
    si.add_argument("--t-end", type=_TIME, default=None, metavar="TIME",
                    help="total simulated time (default: drive end plus 5 tau)")
    si.add_argument("--samples", type=int, default=401, help="output samples (default 401)")
    si.add_argument("--profiles", type=int, default=0, metavar="K",
                    help="store h(r), u(r), p(r) every K-th sample in --out")
    si.add_argument("--method", default=DEFAULT_METHOD, choices=sorted(METHODS),
                    help=f"time stepper (default {DEFAULT_METHOD})")
    si.add_argument("--dt", type=_TIME, default=None, metavar="TIME",
                    help="fixed time step (default: adaptive; euler: 0.1 tau E_inf/E0)")
    si.add_argument("--tol", type=_LENGTH, default=None, metavar="LENGTH",
                    help="local error tolerance of adaptive steps (default 1e-5 debye lengths)")
    si.add_argument("--out", default=None, metavar="FILE.nc", help="write the dataset (netCDF)")
    si.add_argument("--plot", default=None, metavar="FILE.png",
                    help="write the force-position (hysteresis) plot")
    si.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                    help="progress bar (default: when stderr is a terminal)")
    si.add_argument("--json", action="store_true", help="print one JSON object (SI units)")
    _add_material_flags(si)
    _add_system_flags(si)
    _add_numerics_flags(si)
    si.set_defaults(func=_cmd_simulate)

    sp = sub.add_parser("spectrum", help="force spectroscopy: stiffness and phase vs omega")
    sp.add_argument("--h0", type=_LENGTH, required=True, metavar="LENGTH", help="mean position")
    sp.add_argument("--eta", type=_LENGTH, required=True, metavar="LENGTH",
                    help="drive amplitude eta")
    sp.add_argument("--omega", type=_OMEGA, nargs="+", default=None, metavar="FREQ",
                    help="angular frequencies (rad/s, or with Hz/kHz)")
    sp.add_argument("--omega-range", type=_OMEGA, nargs=3, default=None,
                    metavar=("LO", "HI", "N"), help="N log-spaced frequencies from LO to HI")
    sp.add_argument("--method", default="linear",
                    choices=["linear", "time-domain", "svda", "auto"],
                    help="exact frequency-domain (default), time-domain simulation + lock-in, "
                         "SVDA closed form, or auto (cheapest adequate)")
    sp.add_argument("--periods", type=int, default=4,
                    help="time-domain: demodulated periods after settling (default 4)")
    sp.add_argument("--jobs", type=int, default=1, help="time-domain: worker processes")
    sp.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                    help="progress bar (default: when stderr is a terminal)")
    sp.add_argument("--out", default=None, metavar="FILE.nc", help="write the spectrum (netCDF)")
    sp.add_argument("--plot", default=None, metavar="FILE.png", help="write a Bode plot")
    sp.add_argument("--json", action="store_true", help="print one JSON object (SI units)")
    _add_material_flags(sp)
    _add_system_flags(sp)
    _add_numerics_flags(sp)
    sp.set_defaults(func=_cmd_spectrum)

    value_options = {a for action in (*parser._actions, *st._actions, *si._actions,
                                      *sp._actions)
                     for a in action.option_strings if a.startswith("--") and action.nargs is None
                     and action.type is not None}
    return parser, value_options, {"--omega", "--omega-range"}


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (0 ok, 2 user error, 1 internal error)."""
    parser, value_options, multi_options = _build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args = parser.parse_args(normalize_negative_args(argv, value_options, multi_options))
    except SystemExit as exc:  # argparse already printed its message
        return int(exc.code or 0)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except ViscoforceError as exc:
        print(f"viscoforce {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"viscoforce {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
