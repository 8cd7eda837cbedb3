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
from viscoforce.physics.materials import Elastic, ViscoelasticMaterial
from viscoforce.physics.particle import Sphere
from viscoforce.physics.surface_forces import SurfaceForceLaw, paper_pressure_law
from viscoforce.problem import ContactProblem
from viscoforce.solvers.static import static_equilibrium
from viscoforce.units import format_quantity, normalize_negative_args, quantity_type

_LENGTH = quantity_type("length")
_PRESSURE = quantity_type("pressure")


class UsageError(ViscoforceError, ValueError):
    """A command-line combination that cannot be run (exit status 2)."""


def _finite_or_none(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _add_system_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("system (defaults: the paper's values)")
    g.add_argument("--R", type=_LENGTH, default=10e-6, metavar="LENGTH",
                   help="sphere radius R (default 10um)")
    g.add_argument("--P", type=_PRESSURE, default=1e7, metavar="PRESSURE",
                   help="double-layer pressure scale P (default 1e7Pa)")
    g.add_argument("--Pw", type=_PRESSURE, default=1e7, metavar="PRESSURE",
                   help="soft-wall pressure Pw (default 1e7Pa)")
    g.add_argument("--z0", type=_LENGTH, default=0.5e-9, metavar="LENGTH",
                   help="soft-wall length z0 (default 0.5nm)")
    g.add_argument("--debye-length", type=_LENGTH, default=1e-9, metavar="LENGTH",
                   help="Debye length 1/kappa (default 1nm)")


def _add_numerics_flags(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("numerics")
    g.add_argument("--grid-spacing", type=_LENGTH, default=None, metavar="LENGTH",
                   help="mean radial node spacing (default from sqrt(2R/kappa))")
    g.add_argument("--outer-radius", type=_LENGTH, default=None, metavar="LENGTH",
                   help="outer radius of the grid (default: where the force is negligible)")


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

    value_options = {a for action in (*parser._actions, *st._actions)
                     for a in action.option_strings if a.startswith("--") and action.nargs is None
                     and action.type is not None}
    return parser, value_options, set()


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
