"""The flags of ``fit`` and ``bode``: the model's, the system's, the maps' (flag groups as data)."""

from __future__ import annotations

import argparse

from viscoforce.cli._args import (
    NUMERICS_FLAGS,
    SYSTEM_FLAGS,
    Flag,
    FlagGroup,
    add_flags,
    choice_type,
    format_names,
    frequency_type,
    integer_type,
    real_type,
)
from viscoforce.cli._fit_budget import HEIGHT_RECORDS, uncertainty_type
from viscoforce.cli._fit_inputs import _MODELS

_WEIGHTS = ("stderr", "relative")


def modes_type(text: str) -> int | str:
    """``--modes``: a positive integer or ``auto``."""
    if text.strip().lower() == "auto":
        return "auto"
    return integer_type(1, 10, what="modes (or 'auto')")(text)


FIT_FLAGS = FlagGroup("model", (
    Flag("--modes", modes_type, None, "N|auto",
         "relaxation modes (exact, contact --material prony, prony, relaxation, creep; default "
         "1); "
         "auto: 1, 2, ... by the criterion (the default of --model auto on measured data)"),
    Flag("--criterion", None, "bic", "bic|aic", "information criterion of --modes auto"),
    Flag("--h0", "length", None, "LENGTH", "mean position (svda, exact)"),
    Flag("--mean-force", "force", None, "FORCE",
         "mean force, the static E_inf load of the setpoint (svda, exact; instead of --h0)"),
    Flag("--indentation", "length", None, "LENGTH",
         "operating indentation D0 (contact; default: the data's mean_indentation)"),
    Flag("--material", None, None, "sls|prony|power-law|structural",
         "material of the contact model (default sls; --model auto on measured data: compare "
         "only this family)"),
    Flag("--reference-frequency", frequency_type("frequency"), None, "FREQ",
         "contact --material structural: f_ref of E_ref, with its unit (default 1Hz)"),
    Flag("--weights", choice_type(*_WEIGHTS, what="--weights"), None, "stderr|relative",
         "fit weights: the data's stderr (default when present) or relative 1/|k*|"),
    Flag("--drag", "drag", None, "DRAG", "hydrodynamic drag B of the contact model (i*omega*B)"),
    Flag("--segment", integer_type(0), None, "N",
         "relaxation, hertz, creep: the curve's N-th segment (from 0; default the model's own: "
         "the constant-height pause after the approach, the approach, the constant-force "
         "pause)"),
    Flag("--curve", integer_type(0), None, "I", "fit only curve (pixel) I of a map"),
    Flag("--contact-point", "length", None, "LENGTH",
         "ting: the contact point (tip position) held fixed (default: fitted)"),
    Flag("--sample-height", "length", None, "LENGTH",
         "contact, hertz, ting: the sample's thickness on its rigid support (a cell: 2-10um): "
         "the bottom-effect correction (Garcia & Garcia 2018 bonded, Dimitriadis et al. 2002 "
         "sliding; docs/bottom_effect.md)"),
    Flag("--sample-base", choice_type("bonded", "sliding", what="--sample-base"), None,
         "bonded|sliding", "--sample-height: the layer bonded to (default) or sliding on its "
         "support"),
    Flag("--accuracy", real_type(0.0), None, "REL",
         "--model auto: the relative model error required, in [1e-4, 0.1] (default 1e-3)"),
))

def _tip_type(text: str):
    from viscoforce.physics.tips import parse_tip

    return parse_tip(text)


#: The system flags of fit and bode: --R without a default (measured data need the tip; the
#: theory's models take the paper's 10 µm when it is not given), --tip and --poisson.
FIT_SYSTEM_FLAGS = FlagGroup(SYSTEM_FLAGS.title, (
    Flag("--radius", "length", None, "LENGTH",
         "the paper's sphere radius R (paraboloidal profile; svda/exact/step default 10 µm; "
         "measured data: give --radius or --tip)", dest="R", aliases=("--R",)),
    *(f for f in SYSTEM_FLAGS.flags if f.dest != "R"),
    Flag("--tip", _tip_type, None, "SHAPE:SIZE",
         "tip of the contact and hertz models: sphere:R | paraboloid:R | cone:HALF_ANGLE | "
         "pyramid:HALF_ANGLE (four-sided, Bilodeau) | flat:RADIUS (angles in degrees; default "
         "the file's own where it records one)"),
    Flag("--poisson", real_type(0.0), None, "NU",
         "the sample's Poisson's ratio in [0, 0.5] for the Young's and shear moduli "
         "(default 0.5)"),
))

MAP_FLAGS = FlagGroup("maps (several spectra or curves)", (
    Flag("--identifiability", choice_type("auto", "local", "profile", what="--identifiability"),
         None, "auto|local|profile",
         "identifiability test and 2-sigma limits: maps local (default) or profile (profile "
         "likelihood, slower); a single spectrum auto (default: the profile where the "
         "curvature can mislead), profile (every parameter) or local (no limits)"),
    Flag("--scheduler", None, None, "ADDRESS",
         "a running dask scheduler (tcp://host:8786); default: this process or a local "
         "cluster, whichever the cost model expects to finish sooner. Only give a "
         "scheduler you control: dask exchanges pickles, so the scheduler can run code in "
         "this process (docs/security.md)"),
    Flag("--workers", integer_type(1), None, "N",
         "workers of a local cluster (default: the cost model's choice)"),
))


def _add_fit_flags(parser: argparse.ArgumentParser, *, required: bool, batch: bool = False
                   ) -> None:
    if batch:
        parser.add_argument("data", metavar="DATA", nargs="+",
                            help="spectrum or curves: an instrument file, a netCDF file or a "
                                 "CSV; several files or a folder fit each into one table")
    else:
        parser.add_argument("data", metavar="DATA",
                            help="spectrum or curves: an instrument file, a netCDF file or a CSV")
    parser.add_argument("--format", default=None, metavar="NAME",
                        help=f"instrument file format: {format_names()} (default: detected)")
    parser.add_argument("--model", *(() if required else ("--fit",)), choices=_MODELS,
                        required=required, default=None, dest="model",
                        help="model of the SPEC table" if required else
                             "fit this model and draw it over the data (--fit: the same)")
    add_flags(parser, FIT_FLAGS)
    parser.add_argument("--no-newtonian", action="store_true",
                        help="ting --material structural: Ting's pure power law (no mu)")
    parser.add_argument("--fit-drag", action="store_true",
                        help="ting: fit the viscous drag B instead of holding --drag")
    parser.add_argument("--newtonian", action="store_true",
                        help="contact --material power-law: fit a Newtonian viscosity mu in "
                             "parallel")
    from viscoforce.cli.analysis import PHASE_REFERENCE_HELP, phase_reference_type

    parser.add_argument("--phase-reference", type=phase_reference_type, default=None,
                        metavar="sensor|piezo|delay|FILE", help=PHASE_REFERENCE_HELP)
    parser.add_argument("--height-channel", choices=tuple(HEIGHT_RECORDS), default=None,
                        help="force curves: the tip height from the calibrated sensor or the "
                             "piezo (default: both fitted, the one leaving the smaller residual "
                             "kept, the other's values in the error budget)")
    parser.add_argument("--uncertainty", type=uncertainty_type, action="append", default=None,
                        metavar="SOURCE=REL",
                        help="relative calibration uncertainty of the error budget: "
                             "spring-constant (default 10%%), sensitivity (5%%), tip (10%%), "
                             "poisson (0.05), sample-height (10%%, with --sample-height); "
                             "repeat for several")
    parser.add_argument("--budget", choices=("full", "calibration"), default="full",
                        help="error budget: full (default: the calibration sources and the "
                             "refits of the choices the data may not settle: height record, "
                             "phase reference, fit window, contact point, sample height; a map "
                             "refits the height record or phase reference, about 2x its fit) or "
                             "calibration (no refits)")
    add_flags(parser, FIT_SYSTEM_FLAGS)
    add_flags(parser, NUMERICS_FLAGS)
