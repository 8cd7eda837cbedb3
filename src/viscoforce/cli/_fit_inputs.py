"""What ``fit`` and ``bode`` do before fitting: read DATA, check the model, map the flags to inputs.

:func:`read_data` reads DATA (a netCDF file with a bound, an instrument file through ``load``'s
route, a streamed JPK map); :func:`_fixed` turns the flags into the model's fixed inputs (and
refuses the flags a model cannot honour); :func:`fit_one` fits one spectrum or curve.
"""

from __future__ import annotations

import argparse
from typing import Any

from viscoforce.cli._args import UsageError
from viscoforce.physics.paper import PAPER

_MODELS = ("svda", "exact", "contact", "prony", "relaxation", "step", "hertz", "creep", "ting",
           "auto")
#: Models of measured force curves (a curves dataset).
_CURVE_MODELS = ("relaxation", "hertz", "creep", "ting")
_MATERIALS = ("sls", "prony", "power-law", "structural")


def read_data(path: str, fmt: str | None = None, *, height_channel: str | None = None,
              phase_reference=None, raw: bool = False):
    """The dataset of DATA: :func:`viscoforce.measured.open.open_data` (a single curve squeezed).

    A netCDF file as written (measured data in it checked), an instrument file through
    ``load``'s route (a JPK map demodulated in chunks of curves); ``height_channel`` the
    reader's (``--height-channel``), ``phase_reference`` the lock-in's (``--phase-reference``:
    sensor, piezo, delay or a hard-surface file; default the one the data support); ``raw``:
    an instrument file's force curves even where it has modulation segments (what a curve
    model fits: ``load --raw``'s route).
    """
    from viscoforce.measured.open import OptionError, open_data

    options = {k: v for k, v in (("height_channel", height_channel),
                                 ("phase_reference", phase_reference)) if v is not None}
    if raw:
        options["raw"] = True
    try:
        return one_curve_squeezed(open_data(path, format=fmt, **options))
    except OptionError as exc:
        raise UsageError(exc.told({"path": "DATA ", "format": "--format",
                                   "height_channel": "--height-channel",
                                   "phase_reference": "--phase-reference"})) from None


def one_curve_squeezed(ds):
    """A spectrum of a single curve (``curve`` of size 1) as one spectrum, not a 1-pixel map."""
    if "omega" in ds.dims and ds.sizes.get("curve") == 1:
        return ds.isel(curve=0)
    return ds


def _kind(ds) -> str:
    from viscoforce.schema import data_kind

    kind = data_kind(ds)
    if kind is None:
        raise UsageError("DATA is neither a spectrum, curves nor a trajectory dataset")
    return kind


def measured(ds, args: argparse.Namespace) -> bool:
    """Whether ``--model auto`` fits measured data: no --h0/--mean-force, an indentation known."""
    if args.h0 is not None or args.mean_force is not None:
        return False
    return args.indentation is not None or "mean_indentation" in ds.variables


def _given(args: argparse.Namespace, *names: str) -> list[str]:
    """The flags among ``names`` (dest names) that were given."""
    return [f"--{n.replace('_', '-')}" for n in names
            if getattr(args, n, None) not in (None, False)]


#: System flags with a default (the parser cannot tell them given): every model may take them.
_DEFAULTED = ("--P", "--debye-length")


def _flag_dest(flag: str) -> str:
    return "R" if flag == "--R" else flag[2:].replace("-", "_")


def _honoured(name: str) -> set[str]:
    """The model-input flags the registry entry of model ``name`` takes.

    Its inputs' flags; ``--R`` where it takes a tip (a sphere of that radius) or builds a
    ContactProblem from the system flags (``problem``, with ``--P`` and ``--debye-length``).
    """
    from viscoforce.fitting.registry import MODELS

    entry = MODELS[name]
    own = set(entry.flags)
    if "tip" in entry.keys or "problem" in entry.keys:
        own.add("--R")
    if "problem" in entry.keys:
        own.update(_DEFAULTED)
    return own


def _refuse_unhonoured(args: argparse.Namespace, name: str) -> None:
    """Refuse the model-input flags (of any registry entry) that model ``name`` does not take."""
    from viscoforce.fitting.registry import MODELS

    every = set().union(*(e.flags for e in MODELS.values())) | {"--R"}
    given = sorted(f for f in every - set(_DEFAULTED)
                   if getattr(args, _flag_dest(f), None) not in (None, False))
    own = _honoured(name)
    bad = [f for f in given if f not in own]
    if bad:
        raise UsageError(f"--model {name} cannot honour {', '.join(bad)} (its flags: "
                         f"{', '.join(sorted(own)) or 'none'})")


def _fixed(args: argparse.Namespace, ds, kind: str) -> dict[str, Any]:
    """The model's fixed inputs from the flags (and the data); flags a model cannot honour fail.

    Which flags a named model takes is its registry entry's (:func:`_honoured`); the values are
    resolved here (the tip from --tip, --R or the file; the problem from the system flags).
    """
    model = args.model
    if model != "auto":
        _refuse_unhonoured(args, model)
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
                "debye_length": args.debye_length, **_layer(args)}
    if model == "creep":  # Lee-Radok with a tip (--tip, --R or the file's), else exponentials
        if args.tip is not None and args.R is not None:
            raise UsageError("give --tip or --R (a sphere), not both")
        from viscoforce.physics.tips import RigidSphere

        tip = args.tip if args.tip is not None else (
            RigidSphere(args.R) if args.R is not None else None)
        return {"tip": tip, "contact_point": args.contact_point}
    if model == "ting":
        if args.material not in (None, "sls", "prony", "structural"):
            raise UsageError(f"--model ting takes --material sls, prony or structural, got "
                             f"{args.material}")
        if args.fit_drag and args.drag is not None:
            raise UsageError("give --drag or --fit-drag, not both")
        return {"tip": _hertz_tip(args, ds), "material": args.material or "sls",
                "drag": args.drag, "fit_drag": bool(args.fit_drag) or None,
                "contact_point": args.contact_point,
                "reference_frequency": args.reference_frequency,
                "newtonian": False if args.no_newtonian else None, **_layer(args)}
    if model == "auto":
        bad = [b for b in _given(args, *contact_only) if b != "--drag"]
        if bad:
            raise UsageError(f"--model auto cannot honour {', '.join(bad)} (contact-model "
                             "flags; --model auto takes them on measured data, without "
                             "--h0/--mean-force)")
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
        fixed.update(_layer(args))
    if model == "contact":
        fixed.update(**_tip_inputs(args, ds), indentation=args.indentation, drag=args.drag,
                     material=args.material or "sls", debye_length=args.debye_length)
        if args.newtonian:
            fixed["newtonian"] = True
        if args.reference_frequency is not None:
            fixed["reference_frequency"] = args.reference_frequency
        fixed.update(_layer(args))
    return fixed


def _layer(args: argparse.Namespace) -> dict[str, Any]:
    """``sample_height`` and ``sample_base`` (contact, hertz, ting), where given."""
    if getattr(args, "sample_base", None) is not None and args.sample_height is None:
        raise UsageError("--sample-base describes the layer of --sample-height: give both")
    return {k: getattr(args, k) for k in ("sample_height", "sample_base")
            if getattr(args, k, None) is not None}


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
        if args.model == "creep":
            from viscoforce.fitting.creep import fit_creep

            return fit_creep(ds, segment=args.segment, modes=modes, criterion=args.criterion,
                             poisson=args.poisson, **{k: v for k, v in fixed.items()
                                                      if v is not None})
        if args.model == "ting":
            from viscoforce.fitting.ting import fit_ting

            return fit_ting(ds, segment=args.segment, modes=modes, criterion=args.criterion,
                            poisson=args.poisson, **{k: v for k, v in fixed.items()
                                                     if v is not None})
        return fit_curve(ds, args.model, segment=args.segment, modes=modes,
                         criterion=args.criterion, tip=fixed.get("tip"),
                         poisson=args.poisson if args.model == "hertz" else None,
                         sample_height=fixed.get("sample_height"),
                         sample_base=fixed.get("sample_base"),
                         # the budget's contact point method holds it (not a flag)
                         contact_window=getattr(args, "contact_window", None))
    return fit_step(ds, problem=fixed["problem"], poisson=args.poisson)
