"""The surface-force flags of ``static``, ``simulate`` and ``spectrum`` (issue 39's adhesion).

``--force-law``, ``--hamaker`` (with the system's ``--z0``) and ``--branch``: the law they build,
and the static state an attractive law takes at one h0 (:mod:`viscoforce.solvers.adhesive_static`).
"""

from __future__ import annotations

import argparse

from viscoforce.cli._args import Flag, FlagGroup
from viscoforce.cli._usage import UsageError
from viscoforce.physics.paper import paper_pressure_law


def law_from_args(args: argparse.Namespace):
    """The surface force of ``--force-law`` (default the paper's double layer + soft wall).

    ``lennard-jones``: p = A/(6πh³)[(z0/h)⁶ − 1] with ``--hamaker`` and ``--z0``; ``both``: the
    double layer (``--P``, ``--debye-length``) plus that law (its (z0/h)⁹ term is the wall).
    """
    kind = getattr(args, "force_law", None) or "double-layer"
    hamaker = getattr(args, "hamaker", None)
    if kind == "double-layer":
        if hamaker is not None:
            raise UsageError("--hamaker needs --force-law lennard-jones or both")
        return paper_pressure_law(args.P, args.debye_length, args.Pw, args.z0)
    from viscoforce.physics.surface_forces import DoubleLayer, lennard_jones_pressure_law

    if hamaker is None:
        raise UsageError(f"--force-law {kind} needs --hamaker A (in J, e.g. 1e-20J)")
    layer = DoubleLayer(args.P, args.debye_length) if kind == "both" else None
    return lennard_jones_pressure_law(hamaker, args.z0, double_layer=layer)


def _hamaker_type(text: str) -> float:
    """A Hamaker constant: ``1e-20J`` or a bare number of joules."""
    body = text.strip()
    body = body[:-1] if body.endswith("J") else body
    try:
        return float(body)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"invalid Hamaker constant {text!r}: give joules, e.g. 1e-20J") from None


FORCE_LAW_FLAGS = FlagGroup("surface force", (
    Flag("--force-law", str, "double-layer", "LAW",
         "double-layer (the paper's, with the soft wall), lennard-jones or both (double layer + "
         "Lennard-Jones; --z0 is then its equilibrium separation)"),
    Flag("--hamaker", _hamaker_type, None, "ENERGY",
         "Hamaker constant A of the Lennard-Jones law, in J (1e-20J or 1e-20)"),
    Flag("--branch", str, "approach", "HISTORY",
         "with an attractive law, which equilibrium at h0 (static --h0, spectrum): approach "
         "(from far apart: the far branch above the jump-in) or retract (from deep contact: the "
         "contact branch below the jump-out)"),
))


def _check_force_law(args: argparse.Namespace) -> None:
    if args.force_law not in ("double-layer", "lennard-jones", "both"):
        raise UsageError(f"--force-law must be double-layer, lennard-jones or both, got "
                         f"{args.force_law!r}")
    if args.branch not in ("approach", "retract"):
        raise UsageError(f"--branch must be approach or retract, got {args.branch!r}")
    if args.branch != "approach" and args.force_law == "double-layer":
        raise UsageError("--branch applies to an attractive law (--force-law lennard-jones or "
                         "both): the double layer has one equilibrium at every h0")


def _equilibrium(args: argparse.Namespace, problem) -> tuple:
    """The static equilibrium at --h0: Newton's, or (attractive law) the --branch history's."""
    from viscoforce.solvers.continuation import lennard_jones_term

    if lennard_jones_term(problem.surface_force) is None:
        from viscoforce.solvers.static import static_equilibrium

        return static_equilibrium(problem, args.h0, contact_threshold=args.contact_threshold), {}
    from viscoforce.solvers.adhesive_static import adhesive_equilibrium

    ds = adhesive_equilibrium(problem, args.h0, branch=args.branch,
                              contact_threshold=args.contact_threshold)
    return ds, _branch_result(ds.attrs)


def _branch_result(attrs) -> dict:
    """The --json keys of a static state chosen by --branch (attrs of BranchEquilibrium)."""
    extra = {"branch": attrs["branch"], "on_branch": attrs["on_branch"],
             "force_includes_tail": True, "pull_off": attrs.get("pull_off")}
    for name in ("jump_in", "jump_out"):
        value = attrs.get(f"{name}_position")
        extra[name] = None if value is None else {
            "position": float(value), "time": None, "force": float(attrs[f"{name}_force"])}
    return extra
