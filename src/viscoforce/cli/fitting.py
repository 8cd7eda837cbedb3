"""Commands that fit: ``fit`` (parameters out) and ``bode`` (data against fit, as a figure).

DATA is any file ``load`` reads (an instrument file: modulation segments become a spectrum), a
netCDF file the project wrote (spectrum, curves or trajectory), or a spectrum CSV.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from viscoforce._files import write_netcdf, write_text
from viscoforce.cli._args import (
    FIGURE,
    NETCDF_OR_CSV,
    NUMERICS_FLAGS,
    SYSTEM_FLAGS,
    Flag,
    FlagGroup,
    Output,
    UsageError,
    add_flags,
    add_outputs,
    format_names,
    frequency_type,
    integer_type,
    real_type,
)
from viscoforce.cli._output import (
    DIGITS,
    format_estimate,
    format_value,
    print_json,
    print_written,
)
from viscoforce.physics.paper import PAPER

__all__ = ["SUBCOMMANDS", "modes_type", "read_data"]

_MODELS = ("svda", "exact", "contact", "prony", "relaxation", "step", "hertz", "creep", "ting",
           "auto")
#: Models of measured force curves (a curves dataset).
_CURVE_MODELS = ("relaxation", "hertz", "creep", "ting")
_MATERIALS = ("sls", "prony", "power-law", "structural")
_WEIGHTS = ("stderr", "relative")


def choice_type(*choices: str, what: str):
    """A text flag that must be one of ``choices`` (the message lists them)."""

    def parse(text: str) -> str:
        value = text.strip().lower()
        if value not in choices:
            raise argparse.ArgumentTypeError(f"{what} must be one of {', '.join(choices)}, got "
                                             f"{text!r}")
        return value

    return parse


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
    add_flags(parser, FIT_SYSTEM_FLAGS)
    add_flags(parser, NUMERICS_FLAGS)


def add_fit(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce fit``."""
    _add_fit_flags(parser, required=True, batch=True)
    add_flags(parser, MAP_FLAGS)
    add_outputs(parser, [Output("--out", NETCDF_OR_CSV, "FILE.nc|FILE.csv",
                                "write the fit result: netCDF (.nc) or a table, one row per "
                                "curve/pixel with units in the headers (.csv)"),
                         Output("--plot", FIGURE, "FILE.png",
                                "data and fit (one spectrum/curve), or a map of one fitted "
                                "variable over the pixels (a map; --plot-variable)")])
    parser.add_argument("--reports", action="store_true",
                        help="a map: keep each pixel's lmfit report in --out (the text variable "
                             "fit_report; one more least-squares run per pixel)")
    parser.add_argument("--plot-variable", default=None, metavar="NAME",
                        help="the variable of a map's --plot (default: the first fitted "
                             "parameter; any per-pixel variable, e.g. E0_young, redchi)")
    parser.add_argument("--json", action="store_true", help="print one JSON object (SI units)")
    parser.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                        help="progress bar of map fits (default: when stderr is a terminal)")


class _BodeOut(argparse.Action):
    """bode ``--out``: a data file (.nc, .csv); an image name is the old spelling of ``--plot``."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        from pathlib import Path

        if Path(values).suffix.lower() in (".nc", ".csv"):
            namespace.out = values
        else:  # --out bode.png (before --plot existed): the figure
            namespace.out_figure_ = values
            if namespace.plot is None:
                namespace.plot = values


#: bode's outputs: the figure, and the data (``--out`` is parsed by :class:`_BodeOut`).
_BODE_OUTPUTS = (
    Output("--plot", FIGURE, "FILE.png", "write the Bode plot"),
    Output("--out", NETCDF_OR_CSV, "FILE.nc|FILE.csv",
           "write the data: the fit result with --model (netCDF, or a CSV table), else the "
           "spectrum drawn (netCDF); an image name (--out bode.png) still means --plot "
           "(deprecated spelling)"))


def add_bode(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce bode``."""
    _add_fit_flags(parser, required=False)
    parser.set_defaults(model=None, out_figure_=None)
    parser.add_argument("--moduli", "--modulus", action="store_true", dest="modulus",
                        help="add a panel of Young's storage and loss moduli (needs --tip, or a "
                             "spectrum loaded with --tip; --modulus: the old spelling)")
    plot, out = _BODE_OUTPUTS
    add_outputs(parser, [plot])
    parser.add_argument(out.flag, action=_BodeOut, default=None, metavar=out.metavar,
                        help=out.help)
    parser.set_defaults(outputs_=_BODE_OUTPUTS)
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (SI units): the files written, the spectrum "
                             "(omega, stiffness, phase_deg) and the fit (as fit --json)")


# ── data ────────────────────────────────────────────────────────────────────────────────────────

def read_data(path: str, fmt: str | None = None):
    """The dataset of DATA: netCDF as written, instrument files through ``load``'s route.

    Measured data in a netCDF file (``source`` an instrument format, not "simulation" or absent)
    pass the checks the instrument readers apply (:func:`viscoforce.io.quality.check_measured`):
    a file written elsewhere, or edited, may hold values no measurement gives.
    """
    from pathlib import Path

    from viscoforce.cli.analysis import has_modulation, streamed_spectrum
    from viscoforce.exceptions import EffortError
    from viscoforce.io.instruments import load_instrument
    from viscoforce.io.netcdf import open_netcdf
    from viscoforce.io.quality import check_measured

    if Path(path).suffix.lower() == ".nc" and fmt is None:
        if not Path(path).is_file():
            raise UsageError(f"DATA {path}: no such file")
        try:
            ds = open_netcdf(path)
        except EffortError:
            raise
        except (OSError, ValueError) as exc:
            raise UsageError(f"DATA {path}: not a readable netCDF file ({exc})") from None
        if str(ds.attrs.get("source", "simulation")) != "simulation":  # measured
            check_measured(ds, str(path))
        return one_curve_squeezed(ds)
    streamed = streamed_spectrum(path, fmt)  # a JPK map: demodulated in chunks of curves
    if streamed is not None:
        return one_curve_squeezed(streamed)
    data = load_instrument(path, format=fmt)
    if "omega" not in data.dims and has_modulation(data):
        from viscoforce.experiments.modulation import modulation_spectrum

        data = modulation_spectrum(data)
    return one_curve_squeezed(data)


def one_curve_squeezed(ds):
    """A spectrum of a single curve (``curve`` of size 1) as one spectrum, not a 1-pixel map."""
    if "omega" in ds.dims and ds.sizes.get("curve") == 1:
        return ds.isel(curve=0)
    return ds


def _kind(ds) -> str:
    if "omega" in ds.dims and "stiffness" in ds.variables:
        return "spectrum"
    if "sample" in ds.dims:
        return "curves"
    if "time" in ds.dims and "position" in ds.variables:
        return "trajectory"
    raise UsageError("DATA is neither a spectrum, curves nor a trajectory dataset")


def measured(ds, args: argparse.Namespace) -> bool:
    """Whether ``--model auto`` fits measured data: no --h0/--mean-force, an indentation known."""
    if args.h0 is not None or args.mean_force is not None:
        return False
    return args.indentation is not None or "mean_indentation" in ds.variables


def _given(args: argparse.Namespace, *names: str) -> list[str]:
    """The flags among ``names`` (dest names) that were given."""
    return [f"--{n.replace('_', '-')}" for n in names
            if getattr(args, n, None) not in (None, False)]


def _fixed(args: argparse.Namespace, ds, kind: str) -> dict[str, Any]:
    """The model's fixed inputs from the flags (and the data); flags a model cannot honour fail."""
    model = args.model
    if args.h0 is not None and args.mean_force is not None:
        raise UsageError("give --h0 or --mean-force, not both")
    if args.material is not None and args.material not in _MATERIALS:
        raise UsageError(f"--material must be one of {', '.join(_MATERIALS)}, got "
                         f"{args.material!r}")
    contact_only = ("material", "newtonian", "reference_frequency", "indentation")
    if model == "auto" and kind == "spectrum" and measured(ds, args):
        bad = _given(args, "newtonian", "segment")
        if bad:
            raise UsageError(f"--model auto on measured data cannot honour {', '.join(bad)} (it "
                             "compares power-law with and without mu itself)")
        return {**_tip_inputs(args, ds), "indentation": args.indentation, "drag": args.drag,
                "material": args.material, "reference_frequency": args.reference_frequency,
                "debye_length": args.debye_length}
    if model == "ting":
        bad = _given(args, "indentation", "newtonian", "h0", "mean_force")
        if bad:
            raise UsageError(f"--model ting cannot honour {', '.join(bad)}")
        if args.material not in (None, "sls", "prony", "structural"):
            raise UsageError(f"--model ting takes --material sls, prony or structural, got "
                             f"{args.material}")
        if args.fit_drag and args.drag is not None:
            raise UsageError("give --drag or --fit-drag, not both")
        return {"tip": _hertz_tip(args, ds), "material": args.material or "sls",
                "drag": args.drag, "fit_drag": bool(args.fit_drag) or None,
                "contact_point": args.contact_point,
                "reference_frequency": args.reference_frequency,
                "newtonian": False if args.no_newtonian else None}
    if model != "contact":
        bad = _given(args, *contact_only)
        if model == "auto":
            bad = [b for b in bad if b != "--drag"]
        if bad:
            raise UsageError(f"--model {model} cannot honour {', '.join(bad)} (contact-model "
                             "flags" + ("; --model auto takes them on measured data, without "
                                        "--h0/--mean-force" if model == "auto" else "") + ")")
    fixed: dict[str, Any] = {}
    if model in ("svda", "exact", "auto"):
        if args.h0 is None and args.mean_force is None:
            median = ""
            if "mean_force" in ds.variables:
                import numpy as np

                median = (f" (this spectrum's median mean force is "
                          f"{float(np.nanmedian(ds['mean_force'].values)):.4g} N)")
            hint = ("; on measured data give --indentation D0 (or load a file with a contact "
                    "point) to compare contact materials") if model == "auto" else ""
            raise UsageError(f"--model {model} needs the mean position: --h0 H or --mean-force "
                             f"F{median}{hint}")
        fixed["position" if args.h0 is not None else "mean_force"] = (
            args.h0 if args.h0 is not None else args.mean_force)
    if model in ("svda", "exact", "step", "auto"):
        if args.tip is not None:
            raise UsageError(f"--model {model} models the paper's sphere: give --R, not --tip "
                             "(--tip applies to --model contact and --model auto on measured "
                             "data)")
        if args.R is None:
            args.R = PAPER.R
    if model == "svda":
        fixed.update(radius=args.R, P=args.P, debye_length=args.debye_length)
    if model in ("exact", "step", "auto"):
        fixed["problem"] = _problem(args, ds, kind)
    if model == "auto" and args.drag is not None:
        fixed["drag"] = args.drag
    if model == "hertz":
        fixed["tip"] = _hertz_tip(args, ds)
    if model in ("relaxation", "creep") and (args.tip is not None or args.R is not None):
        raise UsageError(f"--model {model} fits {'forces' if model == 'relaxation' else 'the tip position'}"
                         " over time: it takes no --tip or --R")
    if model == "contact":
        fixed.update(**_tip_inputs(args, ds), indentation=args.indentation, drag=args.drag,
                     material=args.material or "sls", debye_length=args.debye_length)
        if args.newtonian:
            fixed["newtonian"] = True
        if args.reference_frequency is not None:
            fixed["reference_frequency"] = args.reference_frequency
    return fixed


def _tip_inputs(args: argparse.Namespace, ds) -> dict[str, Any]:
    """``tip`` or ``radius`` of the contact model; measured data without either are refused.

    A measured file does not record the tip here: a silent 10 µm would put every modulus off by
    √(10 µm / R). Spectra the project simulated (``source`` "simulation" or none) take the
    paper's sphere.
    """
    if args.tip is not None and args.R is not None:
        raise UsageError("give --tip or --R (the paper's sphere), not both")
    if args.tip is not None:
        return {"tip": args.tip}
    if args.R is not None:
        return {"radius": args.R}
    from viscoforce.fitting.curves import file_tip

    recorded = file_tip(ds)
    if recorded is not None:  # the file's own tip metadata
        return {"tip": recorded}
    source = str(ds.attrs.get("source", "simulation"))
    if source != "simulation":
        raise UsageError(
            f"the moduli need the tip, which this {source} file does not record: give --tip "
            "sphere:R | paraboloid:R | cone:HALF_ANGLE | pyramid:HALF_ANGLE | flat:RADIUS "
            "(e.g. --tip sphere:5um) or --R (the paper's sphere)")
    return {"radius": PAPER.R}


def _hertz_tip(args: argparse.Namespace, ds):
    """The hertz model's tip: --tip, --R (a sphere) or the file's own; else a usage error."""
    from viscoforce.fitting.curves import file_tip
    from viscoforce.physics.tips import Sphere

    if args.tip is not None and args.R is not None:
        raise UsageError("give --tip or --R (a sphere), not both")
    if args.tip is not None:
        return args.tip
    if args.R is not None:
        return Sphere(args.R)
    tip = file_tip(ds)
    if tip is None:
        raise UsageError(
            f"--model {args.model} needs the tip, which this {ds.attrs.get('source', '')} file "
            "does not "
            "record: give --tip sphere:R | paraboloid:R | cone:HALF_ANGLE | pyramid:HALF_ANGLE | "
            "flat:RADIUS (e.g. --tip cone:20) or --R")
    return tip


def _problem(args: argparse.Namespace, ds, kind: str):
    import numpy as np

    from viscoforce.cli.model import problem_from_args
    from viscoforce.physics.materials import StandardLinearSolid
    from viscoforce.physics.paper import PAPER

    if kind == "trajectory":
        deepest = float(np.min(ds["position"].values))
    else:
        deepest = args.h0 if args.h0 is not None else -20e-9
    material = StandardLinearSolid(PAPER.E0, PAPER.E_inf, PAPER.tau)
    return problem_from_args(args, material, min(deepest, 0.0) - 2 * args.debye_length)


def _check_model(args: argparse.Namespace, kind: str) -> None:
    spectrum_models = ("svda", "exact", "contact", "prony", "auto")
    wanted = {"spectrum": spectrum_models, "curves": _CURVE_MODELS, "trajectory": ("step",)}
    if args.model not in wanted[kind]:
        raise UsageError(f"--model {args.model} does not fit {kind} data; for {kind}: "
                         f"{', '.join(wanted[kind])}")
    if args.modes == "auto" and args.model not in ("exact", "contact", "prony", "relaxation",
                                                   "creep", "ting", "auto"):
        raise UsageError(f"--modes auto needs a model with several modes, not {args.model}")
    if args.criterion not in ("bic", "aic"):
        raise UsageError(f"--criterion must be bic or aic, got {args.criterion!r}")


def _extra_dims(ds, kind: str) -> list[str]:
    if kind == "spectrum":
        return [str(d) for d in ds["stiffness"].dims if d != "omega"]
    if kind == "curves":
        return ["curve"] if int(ds.sizes["curve"]) > 1 else []
    return []


def _select_curve(ds, kind: str, index: int | None):
    if index is None:
        return ds
    dims = _extra_dims(ds, kind)
    if not dims:
        if index != 0:
            raise UsageError(f"--curve {index}: DATA holds one spectrum or curve (use 0)")
        return ds
    if kind == "curves":
        from viscoforce.schema import select_curve

        n = int(ds.sizes["curve"])
        if index >= n:
            raise UsageError(f"--curve {index}: DATA has {n} curves (0 to {n - 1})")
        return select_curve(ds, index)
    stacked = ds.stack(pixel=dims)
    n = stacked.sizes["pixel"]
    if index >= n:
        raise UsageError(f"--curve {index}: DATA has {n} spectra (0 to {n - 1})")
    return stacked.isel(pixel=index).drop_vars(["pixel", *dims], errors="ignore")


def fit_one(args: argparse.Namespace, ds, kind: str):
    """The fit result of one spectrum, curve or trajectory."""
    from viscoforce.fitting.curves import fit_curve, fit_hold, fit_step
    from viscoforce.fitting.fit import fit_spectrum

    fixed = _fixed(args, ds, kind)
    if kind == "spectrum":
        if args.model == "auto":
            if args.accuracy is not None and measured(ds, args):
                raise UsageError("--accuracy chooses between the theory's approximations (with "
                                 "--h0 or --mean-force); on measured data --model auto compares "
                                 "materials by the criterion: leave --accuracy out")
            if args.accuracy is not None:
                fixed["accuracy"] = args.accuracy
            if args.weights is not None and not measured(ds, args):
                raise UsageError("--weights applies to named models and to --model auto on "
                                 "measured data")
        elif args.accuracy is not None:
            raise UsageError("--accuracy needs --model auto")
        weights = {} if args.weights is None else {"weights": args.weights}
        chosen = getattr(args, "identifiability", None)  # bode --fit has no such flag
        options = {} if chosen is None else {"identifiability": chosen}
        return fit_spectrum(ds, args.model, modes=args.modes, criterion=args.criterion,
                            poisson=args.poisson, **weights, **options, **fixed)
    if getattr(args, "identifiability", None) is not None:
        raise UsageError("--identifiability applies to spectra and maps (curve fits use "
                         "their own rule)")
    if args.weights is not None:
        raise UsageError("--weights applies to spectra (curve fits are unweighted)")
    modes = 1 if args.modes is None else args.modes
    if kind == "curves":
        if args.model == "hertz" and args.modes not in (None, 1):
            raise UsageError("--model hertz has no modes: leave --modes out")
        if args.model == "relaxation":
            return fit_hold(ds, segment=args.segment, modes=modes, criterion=args.criterion)
        if args.model == "ting":
            from viscoforce.fitting.ting import fit_ting

            return fit_ting(ds, segment=args.segment, modes=modes, criterion=args.criterion,
                            poisson=args.poisson, **{k: v for k, v in fixed.items()
                                                     if v is not None})
        return fit_curve(ds, args.model, segment=args.segment, modes=modes,
                         criterion=args.criterion, tip=fixed.get("tip"),
                         poisson=args.poisson if args.model == "hertz" else None)
    return fit_step(ds, problem=fixed["problem"], poisson=args.poisson)


# ── fit ─────────────────────────────────────────────────────────────────────────────────────────

def show_value(value: float | None, unit: str, digits: int = DIGITS) -> str:
    """A parameter value for humans (:func:`~viscoforce.cli._output.format_value`)."""
    return format_value(value, unit, digits)


def _single_json(result) -> dict[str, Any]:
    import numpy as np

    from viscoforce.fitting.identify import IDENTIFIABILITY
    from viscoforce.fitting.verdict import bound_text

    names = [str(n) for n in result["param_i"].values]
    codes = (np.asarray(result["identifiability"].values).reshape(-1).tolist()
             if "identifiability" in result else [0] * len(names))
    params = {}
    for n, code in zip(names, codes, strict=True):
        entry = {"value": float(result[n]), "stderr": float(result[f"{n}_stderr"]),
                 "identified": IDENTIFIABILITY[int(code)]}
        for side in ("lower", "upper"):
            if f"{n}_{side}" in result:
                entry[side] = float(result[f"{n}_{side}"])
        text = bound_text(result, n)
        if text:
            entry["report_as"] = text
        params[n] = entry
    corr = result["correlation"].values
    out: dict[str, Any] = {
        "model": result.attrs["model"], "modes": int(result["modes"]), "params": params,
        "correlations": {a: {b: float(corr[i, j]) for j, b in enumerate(names) if j != i}
                         for i, a in enumerate(names)},
        "redchi": float(result["redchi"]), "aic": float(result["aic"]),
        "bic": float(result["bic"]), "success": bool(int(result["success"])),
        "chi2_pvalue": float(result["chi2_pvalue"]) if "chi2_pvalue" in result else None,
        "weighting": str(result.attrs.get("weighting", "")),
        "at_bound": [s for s in str(result.attrs.get("at_bound", "")).split(", ")
                     if s and s != "none"]}
    derived = {str(n): {"value": float(result[n]), "stderr": float(result[f"{n}_stderr"])}
               for n in result.data_vars if str(n).endswith(("_young", "_shear"))
               or str(n) in ("ting_E0", "beta")}
    if derived:
        out["derived"] = derived
        out["poisson"] = float(result.attrs.get("poisson", 0.5))
    for key in ("tip", "tip_shape", "tip_radius", "tip_half_angle"):
        if key in result.attrs:
            value = result.attrs[key]
            out[key] = value if isinstance(value, str) else float(value)
    for key in ("material", "candidate", "residual_lag1", "effective_samples", "validity",
                "identifiability_method", "ting_error",
                "depth_check", "depth_check_E", "depth_check_shift", "precontact_rise",
                "creep_force", "segment_type"):
        if key in result.attrs:
            value = result.attrs[key]
            out[key] = value if isinstance(value, str) else float(value)
    if "selection_modes" in result:
        rows = []
        for i in range(result.sizes["candidate"]):
            row = {"modes": int(result["selection_modes"].values[i]),
                   "aic": float(result["selection_aic"].values[i]),
                   "bic": float(result["selection_bic"].values[i])}
            for key in ("label", "redchi", "pvalue", "parameters"):
                if f"selection_{key}" in result:
                    value = result[f"selection_{key}"].values[i]
                    row[key] = str(value) if key == "label" else float(value)
            rows.append(row)
        out["selection"] = rows
        out["criterion"] = result.attrs.get("criterion", "bic")
        if "selection_note" in result.attrs:
            out["selection_note"] = str(result.attrs["selection_note"])
    if "explanation" in result.attrs:  # --model auto
        out["explanation"] = str(result.attrs["explanation"])
        if "estimated_model_error" in result.attrs:
            out["estimated_model_error"] = float(result.attrs["estimated_model_error"])
    return out


def _map_json(result) -> dict[str, Any]:
    from viscoforce.fitting.pixels import map_summary

    return {"model": result.attrs["model"], **map_summary(result),
            "n_failed": int(result.attrs["n_failed"])}


def _print_single(info: dict[str, Any]) -> None:
    from viscoforce.schema.fit import parameter_units

    p_value = info.get("chi2_pvalue")
    fit_text = (f"chi-square p-value {p_value:.2g}" if p_value is not None and p_value == p_value
                else f"no p-value (weights {info.get('weighting') or 'unknown'})")
    label = f" ({info['candidate']})" if "candidate" in info else ""
    print(f"model {info['model']}{label}, {info['modes']} mode(s), "
          f"{'converged' if info['success'] else 'DID NOT CONVERGE'}; redchi "
          f"{info['redchi']:.4g}, {fit_text}, AIC {info['aic']:.4g}, BIC {info['bic']:.4g}")
    for name, p in info["params"].items():
        unit = parameter_units(name)
        line = f"  {name:<8} = {format_estimate(p['value'], p['stderr'], unit)}"
        if "report_as" in p:
            line += f"   -> report as {p['report_as']} ({info.get('identifiability_method', '')})"
        print(line)
    if info.get("derived"):
        nu = info["poisson"]
        print(f"  Young's and shear moduli (Poisson's ratio {nu:g}; E above is the paper's "
              "2/E = sum (1 - nu^2)/E_i):")
        for name, p in info["derived"].items():
            base = name if name in ("ting_E0", "beta") else name.rsplit("_", 1)[0]
            unit = parameter_units(base)
            print(f"  {name:<12} = {format_estimate(p['value'], p['stderr'], unit)}")
    if "tip" in info:
        print(f"  tip: {info['tip']}")
    if info["at_bound"]:
        print(f"  at a bound (not identified by these data): {', '.join(info['at_bound'])}")
    for row in info.get("selection", []):
        name = row.get("label", f"{row['modes']} mode(s)")
        extra = f", redchi {row['redchi']:.3g}" if "redchi" in row else ""
        print(f"  candidate {name}: AIC {row['aic']:.4g}, BIC {row['bic']:.4g}{extra}")
    if "selection_note" in info:
        print(f"  note: {info['selection_note']}")
    if "explanation" in info:
        print(f"  model choice: {info['explanation']}")
    if "depth_check" in info:
        print(f"  depth check: {info['depth_check']}")
    if "validity" in info:
        print(f"  validity: {info['validity']}")


def _print_map(info: dict[str, Any]) -> None:
    from viscoforce.schema.fit import parameter_units

    left = ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in info["left_out"].items() if v)
    print(f"model {info['model']}: {info['n_fits']} fits, {info['n_good']} good"
          + (f"; left out of the summary: {left}" if left else ""))
    for modes, block in info["by_modes"].items():
        print(f"  {modes} mode(s), {block['n']} good pixel(s):")
        for name, p in block["params"].items():
            unit = parameter_units(name)
            print(f"    {name:<8} median {show_value(p['median'], unit)}, IQR "
                  f"{show_value(p['q25'], unit)} .. {show_value(p['q75'], unit)}")
    if info.get("derived"):
        print(f"  Young's and shear moduli (Poisson's ratio {info['poisson']:g}), the pixels of "
              f"{info['modes']} mode(s):")
        for name, p in info["derived"].items():
            unit = parameter_units(name.rsplit("_", 1)[0])
            print(f"    {name:<12} median {show_value(p['median'], unit)}, IQR "
                  f"{show_value(p['q25'], unit)} .. {show_value(p['q75'], unit)}")


def _fit_recording(run, *args: Any, **kwargs: Any):
    """``run(*args, **kwargs)`` with the viscoforce warnings recorded, then shown; (result, texts)."""
    import warnings

    from viscoforce.exceptions import (
        AccuracyWarning,
        DataWarning,
        GoodnessOfFitWarning,
        ModelValidityWarning,
    )

    kinds = (ModelValidityWarning, AccuracyWarning, GoodnessOfFitWarning, DataWarning)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = run(*args, **kwargs)
    texts = []
    for w in caught:
        if issubclass(w.category, kinds):
            text = str(w.message)
            if text not in texts:
                texts.append(text)
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return result, texts


#: File suffixes a folder given as DATA contributes to a batch fit (what ``load`` reads).
BATCH_SUFFIXES = (".jpk-force", ".jpk-force-map", ".zip", ".ibw", ".csv", ".tsv", ".txt", ".nc",
                  ".uff", ".spm")


def data_paths(items: list[str] | str) -> list[str]:
    """The files of DATA: each file as given, each folder's readable files (sorted, recursive)."""
    from pathlib import Path

    out: list[str] = []
    for item in [items] if isinstance(items, str) else items:
        path = Path(item)
        if path.is_dir():
            found = sorted(str(p) for p in path.rglob("*") if p.is_file()
                           and p.name.lower().endswith(BATCH_SUFFIXES)
                           and not p.name.startswith(".") and p.stem.upper() not in (
                               "README", "LICENSE", "SOURCE", "NOTES"))
            if not found:
                raise UsageError(f"DATA {item}: the folder holds no file to fit (suffixes "
                                 f"{', '.join(BATCH_SUFFIXES)})")
            out.extend(found)
        else:
            out.append(item)
    return out


def _refuse_writing_inputs(args: argparse.Namespace, paths: list[str]) -> None:
    """Refuse an output that is one of the files DATA stands for (a folder's files included).

    The parser's check (:func:`viscoforce.cli._args.check_outputs`) compares the outputs with
    the arguments as typed; a folder given as DATA stands for the files in it.
    """
    from pathlib import Path

    from viscoforce._files import same_file

    for flag in ("out", "plot"):
        target = getattr(args, flag, None)
        if target is None or not Path(target).exists():
            continue
        for source in paths:
            if same_file(target, source):
                raise UsageError(f"--{flag} {target} is an input of this command ({source}, a "
                                 "file of DATA): writing it would destroy the data; give another "
                                 "file name")


def run_fit(args: argparse.Namespace) -> int:
    """Fit DATA; one spectrum/curve → parameters, a map → per-pixel parameters.

    Several files (or a folder) are fitted one after the other into one table (:func:`run_batch`).
    """
    paths = data_paths(args.data)
    _refuse_writing_inputs(args, paths)
    if len(paths) > 1:
        return run_batch(args, paths)
    args.data = paths[0]
    ds = read_data(args.data, args.format)
    kind = _kind(ds)
    _check_model(args, kind)
    ds = _select_curve(ds, kind, args.curve)
    is_map = bool(_extra_dims(ds, kind))
    if not is_map and getattr(args, "reports", False):
        raise UsageError("--reports keeps a map's per-pixel lmfit reports; a single fit has "
                         "its report in the API (ds.lmfit.fit_report())")
    if not is_map and getattr(args, "plot_variable", None) is not None:
        raise UsageError("--plot-variable chooses what a map's --plot shows; this is one "
                         "spectrum or curve")
    if is_map and args.model == "auto":
        raise UsageError("--model auto fits one spectrum: add --curve I, or name the model "
                         "for the whole map")
    if is_map and args.identifiability == "auto":
        raise UsageError("--identifiability auto applies to a single spectrum; a map takes "
                         "local (default) or profile")
    if is_map:
        from viscoforce.fitting.maps import fit_map

        if args.weights is not None:
            raise UsageError("--weights applies to single fits; maps weight by the data's "
                             "stderr when present")
        fixed = _fixed(args, ds, kind)
        progress = sys.stderr.isatty() if args.progress is None else args.progress
        options = {} if args.identifiability is None else {
            "identifiability": args.identifiability}
        result, texts = _fit_recording(
            fit_map, ds, args.model, modes=1 if args.modes is None else args.modes,
            criterion=args.criterion, scheduler=args.scheduler, workers=args.workers,
            progress=progress, segment=args.segment, poisson=args.poisson,
            reports=args.reports, **options, **fixed)
        info = _map_json(result)
    else:
        result, texts = _fit_recording(fit_one, args, ds, kind)
        info = _single_json(result)
    info["warnings"] = texts
    if args.out and args.out.lower().endswith(".csv"):
        write_table(result, args.out)
    elif args.out:
        write_netcdf(result, args.out)
    if args.plot:
        _plot(ds, "map" if is_map else kind, result, args)
    if args.json:
        print_json(info)
        return 0
    if is_map:
        _print_map(info)
    else:
        _print_single(info)
    print_written(args.out, args.plot)
    return 0


def table_rows(result) -> tuple[list[str], list[list[Any]]]:
    """A fit result as table rows: ``name (unit)`` headers and one row per curve/pixel.

    Columns: the map's coordinates, each parameter and its stderr, the derived Young's and shear
    moduli, ``redchi``, ``chi2_pvalue``, ``quality`` (maps), ``success``, ``modes``; every column
    read over the rows by dim name (:func:`viscoforce.schema.flat_over`).
    """
    from viscoforce.schema import flat_over

    names = [str(n) for n in result["param_i"].values]
    columns = [n for name in names for n in (name, f"{name}_stderr")]
    columns += [str(n) for n in result.data_vars if str(n).endswith(
        ("_young", "_shear", "_young_stderr", "_shear_stderr"))]
    columns += [n for n in ("redchi", "chi2_pvalue", "quality", "success", "modes")
                if n in result.variables]
    dims = [str(d) for d in result["success"].dims]
    coords = [str(c) for c in result.coords
              if c not in ("param_i", "param_j", "omega", "time", "tip_position")
              and set(result[c].dims) <= set(dims) and result[c].dims]

    def header(name: str) -> str:
        unit = str(result[name].attrs.get("units", ""))
        return f"{name} ({unit})" if unit else name

    headers = [header(c) for c in (*coords, *columns)]
    rows = [list(row) for row in zip(*(flat_over(result, c, tuple(dims))
                                       for c in (*coords, *columns)), strict=True)]
    return headers, rows


def _write_csv(path: str, headers: list[str], rows: list[list[Any]]) -> None:
    import csv
    import io

    import numpy as np

    handle = io.StringIO(newline="")
    writer = csv.writer(handle)
    writer.writerow(headers)
    for row in rows:
        writer.writerow(["" if v is None else f"{v:.10g}" if isinstance(
            v, float | np.floating) else v for v in row])
    write_text(path, handle.getvalue())


def write_table(result, path: str) -> None:
    """A fit result as CSV: one row per curve/pixel, ``name (unit)`` headers (:func:`table_rows`)."""
    _write_csv(path, *table_rows(result))


# ── batch: many files into one table ────────────────────────────────────────────────────────────

def _fit_file(args: argparse.Namespace, path: str):
    """The fit result of one file of a batch (a map's curves fitted in this process)."""
    ds = read_data(path, args.format)
    kind = _kind(ds)
    _check_model(args, kind)
    ds = _select_curve(ds, kind, args.curve)
    if _extra_dims(ds, kind):
        from viscoforce.fitting.maps import fit_map

        options = {} if args.identifiability is None else {
            "identifiability": args.identifiability}
        return fit_map(ds, args.model, modes=1 if args.modes is None else args.modes,
                       criterion=args.criterion, scheduler=args.scheduler or "synchronous",
                       workers=args.workers, progress=False, segment=args.segment,
                       poisson=args.poisson, **options, **_fixed(args, ds, kind))
    return fit_one(args, ds, kind)


def run_batch(args: argparse.Namespace, paths: list[str]) -> int:
    """Fit each file with the same model and flags into one table: a row per curve/pixel.

    A file that cannot be read or fitted is a row with ``success`` 0 and its reason in
    ``message``; the exit status is 0 when at least one curve was fitted.
    """
    import numpy as np
    from tqdm.auto import tqdm

    from viscoforce.exceptions import ViscoforceError

    if args.model == "auto":
        raise UsageError("--model auto fits one spectrum: name the model for a batch of files")
    if args.plot:
        raise UsageError("--plot draws one spectrum or curve: give one file")
    if args.curve is not None:
        raise UsageError("--curve picks a curve of one file: give one file")
    progress = sys.stderr.isatty() if args.progress is None else args.progress
    headers: list[str] = ["file", "curve", "message"]
    rows: list[dict[str, Any]] = []
    files: list[dict[str, Any]] = []
    texts: list[str] = []
    for path in tqdm(paths, desc=f"fit {args.model}", unit="file", disable=not progress):
        try:
            result, caught = _fit_recording(_fit_file, args, path)
        except (UsageError, ViscoforceError, ValueError, ArithmeticError) as exc:
            reason = str(exc).splitlines()[0]
            rows.append({"file": path, "curve": 0, "message": reason, "success": 0})
            files.append({"file": path, "n_fits": 0, "n_failed": 1, "error": reason})
            continue
        texts.extend(f"{path}: {t}" for t in caught)
        names, values = table_rows(result)
        names = ["curve" if h.split(" (")[0] == "curve" else h for h in names]
        headers.extend(h for h in names if h not in headers)
        n_failed = 0
        for i, row in enumerate(values):
            entry = dict(zip(names, row, strict=True))
            entry.update(file=path, curve=int(entry.get("curve", i)), message="")
            if "message" in result.variables and result["message"].ndim:
                entry["message"] = str(np.asarray(result["message"].values).reshape(-1)[i])
            n_failed += int(not int(entry.get("success", 1)))
            rows.append(entry)
        files.append({"file": path, "n_fits": len(values), "n_failed": n_failed})
    headers = [h for h in headers if h != "curve"]
    headers.insert(1, "curve")
    headers.remove("message")
    headers.append("message")
    if "success" in headers:
        headers.remove("success")
        headers.insert(len(headers) - 1, "success")
    else:
        headers.insert(len(headers) - 1, "success")
    table = [[row.get(h) for h in headers] for row in rows]
    if args.out and args.out.lower().endswith(".csv"):
        _write_csv(args.out, headers, table)
    elif args.out:
        write_netcdf(_table_dataset(headers, table, args.model), args.out)
    fitted = [r for r in rows if int(r.get("success") or 0)]
    params: dict[str, dict[str, float]] = {}
    for h in headers:
        name = h.split(" (")[0]
        if h in ("file", "curve", "message", "success") or name.endswith("_stderr") or name in (
                "x", "y", "redchi", "chi2_pvalue", "quality", "modes"):
            continue
        values = np.array([float(r[h]) for r in fitted if r.get(h) is not None], dtype=float)
        values = values[np.isfinite(values)]
        if values.size:
            q25, median, q75 = np.percentile(values, [25, 50, 75])
            params[name] = {"median": float(median), "q25": float(q25), "q75": float(q75),
                            "n": int(values.size)}
    info = {"model": args.model, "n_files": len(paths), "n_fits": len(rows),
            "n_failed": len(rows) - len(fitted), "params": params, "files": files,
            "warnings": texts}
    if args.json:
        print_json(info)
    else:
        from viscoforce.schema.fit import parameter_units

        print(f"model {args.model}: {len(paths)} files, {len(rows)} fits, {len(fitted)} fitted")
        for name, p in params.items():
            try:
                unit = parameter_units(name.removesuffix("_young").removesuffix("_shear"))
            except ViscoforceError:
                unit = ""
            print(f"  {name:<14} median {show_value(p['median'], unit)}, IQR "
                  f"{show_value(p['q25'], unit)} .. {show_value(p['q75'], unit)} "
                  f"({p['n']} fits)")
        for entry in files:
            if "error" in entry:
                print(f"  {entry['file']}: not fitted: {entry['error']}")
        print_written(args.out)
    if not fitted:
        print(f"error: no curve of the {len(paths)} files could be fitted with --model "
              f"{args.model} (reasons in the table's message column)", file=sys.stderr)
        return 2
    return 0


def _table_dataset(headers: list[str], table: list[list[Any]], model: str):
    """The batch table as a netCDF-ready dataset over ``fit`` (units from the headers)."""
    import numpy as np
    import xarray as xr

    data = {}
    for j, h in enumerate(headers):
        name, _, unit = h.partition(" (")
        column = [row[j] for row in table]
        if name in ("file", "message"):
            data[name] = ("fit", np.array(["" if v is None else str(v) for v in column]))
        else:
            values = np.array([np.nan if v is None else float(v) for v in column])
            attrs = {"units": unit.rstrip(")")} if unit else {}
            if name in ("curve", "success", "modes", "quality") and np.all(np.isfinite(values)):
                values = values.astype(np.int32)
            data[name] = ("fit", values, attrs)
    ds = xr.Dataset(data)
    ds.attrs.update(model=model, long_name="batch fit: one row per curve/pixel of each file")
    return ds


def _plot(ds, kind: str, result, args: argparse.Namespace) -> None:
    from viscoforce.cli.model import _save_figure
    from viscoforce.plotting import bode_plot, fit_curve_plot

    if kind == "map":
        from viscoforce.exceptions import ParameterError
        from viscoforce.plotting import map_plot

        try:
            handle = map_plot(result, args.plot_variable)
        except ParameterError as exc:
            raise UsageError(f"--plot-variable: {exc}") from None
    elif kind == "spectrum":
        handle = bode_plot(ds, fit=result, residuals=True)
    else:
        if kind == "curves":
            from viscoforce.fitting.curves import curve_data

            fitted = curve_data(ds, args.model, segment=args.segment)
            data = (fitted.x, fitted.y)
        else:
            data = (ds["time"].values, ds["force"].values)
        handle = fit_curve_plot(result, data=data, title=str(args.data))
    _save_figure(handle, args.plot)


# ── bode ────────────────────────────────────────────────────────────────────────────────────────

def run_bode(args: argparse.Namespace) -> int:
    """Bode plot of a spectrum (one curve of a map with ``--curve``), with a fit if asked."""
    if args.out_figure_ is not None and args.plot != args.out_figure_:
        raise UsageError(f"--out {args.out_figure_} is the old spelling of --plot: give one "
                         "figure name")
    if not args.plot and not args.out:
        raise UsageError("bode needs --plot FILE.png (the figure) or --out FILE.nc (the data)")
    if args.out and args.out.lower().endswith(".csv") and args.model is None:
        raise UsageError(f"--out {args.out}: a CSV table holds a fit result (give --model); "
                         "the spectrum is written as netCDF (.nc)")
    ds = read_data(args.data, args.format)
    kind = _kind(ds)
    if kind != "spectrum":
        raise UsageError(f"bode draws spectra; DATA holds {kind}")
    if _extra_dims(ds, kind) and args.curve is None:
        raise UsageError(f"DATA holds several spectra (dims {_extra_dims(ds, kind)}): pick one "
                         "with --curve I")
    ds = _select_curve(ds, kind, args.curve)
    fit = None
    if args.model is not None:
        _check_model(args, kind)
        fit = fit_one(args, ds, kind)
    from viscoforce.cli.model import _save_figure
    from viscoforce.plotting import bode_plot

    if args.modulus and ("E_storage" not in ds or args.tip is not None):
        if args.tip is None:
            raise UsageError("--modulus needs --tip (the complex modulus needs the tip's contact "
                             "size), or a spectrum loaded with load --tip")
        from viscoforce.experiments.moduli import add_complex_modulus

        ds = add_complex_modulus(ds, args.tip, poisson=args.poisson)
    measured_data = str(ds.attrs.get("source", "simulation")) != "simulation"
    if args.out and args.out.lower().endswith(".csv"):
        write_table(fit, args.out)
    elif args.out:
        write_netcdf(ds if fit is None else fit, args.out)
    if args.plot:
        _save_figure(bode_plot(ds, fit=fit, modulus=args.modulus, residuals=fit is not None,
                               frequency_unit="Hz" if measured_data else "rad/s"), args.plot)
    if args.json:
        print_json({"plot": args.plot, "out": args.out,
                    "omega": ds["omega"].values, "stiffness": ds["stiffness"].values,
                    "phase_deg": ds["phase"].values,
                    "fit": None if fit is None else _single_json(fit)})
        return 0
    if fit is not None:
        _print_single(_single_json(fit))
    print_written(args.plot, args.out)
    return 0


#: The commands of this module: name → (add the flags to a parser, run the parsed arguments).
SUBCOMMANDS = {
    "fit": (add_fit, run_fit),
    "bode": (add_bode, run_bode),
}
