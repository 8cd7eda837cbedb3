"""``viscoforce demo``: the whole job in one command, on bundled data.

1. A JPK archive written by the project from a simulation with a known material: load it,
   demodulate its sine segments, fit the exact model with ``--modes auto``, print τ, E0, E_inf
   with their stderr next to the truth, and draw the Bode plot of data and fit.
2. The exact solver's hysteresis loop for the fitted material (triangle 10 → −10 → 10 nm).
3. The same on a real measured file (the bundled JPK modulation map of a living cell, MIT): the
   measured-data chooser on one curve (contact materials compared by BIC), its residuals,
   redchi and χ² p-value, then the chosen material over the map (good pixels only).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from viscoforce._files import write_text
from viscoforce.cli._args import DIRECTORY, Output, UsageError, add_outputs

__all__ = ["SUBCOMMANDS", "find_examples"]

#: The example files the demo reads (shipped in the package: :func:`viscoforce.data.example_path`).
SYNTHETIC = "sls_modulation.jpk-force"
#: Its truth (``examples/make_examples.py``: TRUE_SLS at H0 with the paper's system).
SYNTHETIC_TRUTH = {"E0": 5e9, "E_inf": 1e9, "tau": 5e-3, "h0": -5e-9}
REAL = "real/modulation-map.jpk-force-map"
#: Tip radius assumed for the real file (the file does not say).
REAL_TIP_RADIUS = 10e-6


def find_examples(given: str | None = None) -> Path:
    """The folder of the example files: ``given`` (``--data DIR``), else the package's own copy.

    The package's copy is found by :mod:`importlib.resources`, so the demo runs from any folder
    once viscoforce is installed (in the repository, ``data_examples/`` links to it).
    """
    from viscoforce.data import example_path

    folder = Path(given) if given else example_path()
    missing = [name for name in (SYNTHETIC, REAL) if not (folder / name).is_file()]
    if missing:
        if given:
            where, fix = (f"--data {given}", "give the folder that holds them, or leave --data out "
                          "to use the copy shipped inside viscoforce")
        else:
            where, fix = f"the installed package ({folder})", "reinstall viscoforce"
        raise UsageError(f"cannot find the example data in {where}: {', '.join(missing)} missing; "
                         f"{fix}")
    return folder


def add_demo(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce demo``."""
    add_outputs(parser, [Output("--out-dir", DIRECTORY, "DIR",
                                "folder for the figures and results (default viscoforce-demo; "
                                "--out DIR: the old spelling)", aliases=("--out",))])
    parser.add_argument("--data", default=None, metavar="DIR",
                        help="a folder holding the example files (default: the copy shipped "
                             "inside viscoforce)")
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object (SI units): the numbers of demo.json and the "
                             "files written (the narrative goes to stderr)")


def _show(name: str, value: float, err: float, unit: str, truth: float | None = None) -> str:
    from viscoforce.cli._output import format_estimate, format_value

    line = f"  {name:<6} = {format_estimate(value, err, unit)}"
    if truth is not None:
        line += f"   (truth {format_value(truth, unit)})"
    return line


def _params(result, truth: dict[str, float] | None = None) -> list[str]:
    lines = []
    for name in (str(n) for n in result["param_i"].values):
        lines.append(_show(name, float(result[name]), float(result[f"{name}_stderr"]),
                           str(result[name].attrs["units"]),
                           None if truth is None else truth.get(name)))
    return lines


def _synthetic(folder: Path, out: Path, report: dict[str, Any]) -> Any:
    from viscoforce.cli.model import _save_figure
    from viscoforce.experiments.modulation import modulation_spectrum
    from viscoforce.fitting.fit import fit_spectrum
    from viscoforce.io.instruments import load_instrument
    from viscoforce.physics.materials import StandardLinearSolid
    from viscoforce.physics.paper import PAPER, paper_pressure_law
    from viscoforce.physics.particle import Particle
    from viscoforce.plotting import bode_plot
    from viscoforce.problem import ContactProblem
    from viscoforce.schema import select_curve

    truth = dict(SYNTHETIC_TRUTH)
    start = time.perf_counter()
    curves = load_instrument(folder / SYNTHETIC)
    spec = modulation_spectrum(select_curve(curves, 0) if curves.sizes["curve"] > 1 else curves)
    spec = spec.isel(curve=0) if "curve" in spec.dims else spec
    problem = ContactProblem.create(sphere=Particle(PAPER.R), surface_force=paper_pressure_law(),
                                    material=StandardLinearSolid(1e10, 1e9, 1e-3),
                                    deepest_position=truth["h0"])
    fit = fit_spectrum(spec, "auto", modes="auto", position=truth["h0"], problem=problem)
    elapsed = time.perf_counter() - start
    chosen = int(fit["modes"])
    print(f"1. {SYNTHETIC} (written by viscoforce from a simulation, {spec.sizes['omega']} "
          f"frequencies): --model auto chose the {fit.attrs['model']} model at h0 = "
          f"{truth['h0'] * 1e9:g} nm, --modes auto chose {chosen} mode(s) by BIC ({elapsed:.1f} s)")
    print(f"   why: {fit.attrs['explanation']}")
    print("\n".join(_params(fit, truth)))
    _save_figure(bode_plot(spec, fit=fit, title="synthetic JPK archive: data and exact fit"),
                 str(out / "bode_synthetic.png"))
    report["synthetic"] = {"model": str(fit.attrs["model"]), "modes": chosen,
                           "explanation": str(fit.attrs["explanation"]), "seconds": elapsed, **{
        n: [float(fit[n]), float(fit[f"{n}_stderr"])] for n in fit["param_i"].values}}
    return fit, problem, truth


def _loop(fit, problem, out: Path, report: dict[str, Any]) -> None:
    from viscoforce.cli.model import _save_figure
    from viscoforce.experiments.drives import Triangle
    from viscoforce.fitting.base import material_from
    from viscoforce.plotting import hysteresis_plot
    from viscoforce.solvers.simulate import simulate

    modes = int(fit["modes"])
    material = material_from({n: float(fit[n]) for n in fit["param_i"].values}, modes)
    deep = problem.with_material(material)
    start = time.perf_counter()
    run = simulate(deep, Triangle(10e-9, -5e-9, 5e-6), progress=False, stepper="auto")
    elapsed = time.perf_counter() - start
    handle = hysteresis_plot(run)
    handle.ax.set_title("exact solver, fitted material, 5 µm/s: loading (solid), unloading "
                        "(dashed)", fontsize="medium")
    _save_figure(handle, str(out / "loop.png"))
    peak = float(run["force"].max())
    print(f"2. exact solver, fitted material, triangle 10 → −5 → 10 nm at 5 µm/s: peak force "
          f"{peak * 1e6:.3g} µN, hysteresis loop in loop.png ({elapsed:.1f} s)")
    print(f"   stepper: {run.attrs['explanation']}")
    report["loop"] = {"peak_force": peak, "seconds": elapsed, "stepper": str(run.attrs["stepper"]),
                      "explanation": str(run.attrs["explanation"])}


def _real(folder: Path, out: Path, report: dict[str, Any]) -> None:
    import warnings

    from viscoforce.cli._output import format_value
    from viscoforce.cli.model import _save_figure
    from viscoforce.experiments.modulation import modulation_spectrum
    from viscoforce.fitting.fit import fit_spectrum
    from viscoforce.fitting.maps import fit_map
    from viscoforce.fitting.pixels import map_summary
    from viscoforce.fitting.verdict import bound_text
    from viscoforce.io.instruments import load_instrument
    from viscoforce.plotting import bode_plot

    start = time.perf_counter()
    spec = modulation_spectrum(load_instrument(folder / REAL))
    one = spec.isel(curve=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        fit = fit_spectrum(one, "auto", radius=REAL_TIP_RADIUS)
        material = {"material": str(fit.attrs["material"])}
        if fit.attrs.get("newtonian"):
            material["newtonian"] = True
        modes = int(fit["modes"])
        whole = fit_map(spec, "contact", modes=modes, scheduler="synchronous",
                        radius=REAL_TIP_RADIUS, **material)
    elapsed = time.perf_counter() - start
    flagged = int((spec["quality"].values != 0).sum()) if "quality" in spec else 0
    print(f"3. {REAL} (real JPK map of a living cell, {spec.sizes['curve']} curves × "
          f"{spec.sizes['omega']} frequencies; {flagged} points flagged: phase > 90°, an "
          f"instrument lag): --model auto compared the contact materials, tip radius "
          f"{REAL_TIP_RADIUS * 1e6:g} µm assumed ({elapsed:.1f} s)")
    print(f"   curve 0: kept {fit.attrs['candidate']} (the simplest within ΔBIC "
          f"{float(fit.attrs['selection_margin']):g} of the best); redchi "
          f"{float(fit['redchi']):.3g}, chi-square p-value {float(fit['chi2_pvalue']):.2g}")
    for label, bic, redchi in zip(fit["selection_label"].values, fit["selection_bic"].values,
                                  fit["selection_redchi"].values, strict=True):
        print(f"     candidate {str(label):<13} BIC {float(bic):9.4g}, redchi {float(redchi):.3g}")
    print("\n".join(_params(fit)))
    young = [n for n in fit.data_vars if str(n).endswith("_young")]
    if young:
        print(f"   as Young's moduli (Poisson's ratio {float(fit.attrs['poisson']):g}; the "
              "values above are the paper's E = 2Y/(1 - nu^2)):")
        for n in young:
            print(_show(str(n), float(fit[n]), float(fit[f"{n}_stderr"]),
                        str(fit[n].attrs["units"])))
    for name in (str(n) for n in fit["param_i"].values):
        text = bound_text(fit, name)
        if text:
            print(f"   {name}: report as {text} (one-sided profile likelihood)")
    notes = sorted({str(w.message).split(';')[0] for w in caught})
    for note in notes:
        print(f"   note: {note}")
    summary = map_summary(whole)
    left = ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in summary["left_out"].items() if v)
    print(f"   map ({fit.attrs['candidate']} on every curve): {summary['n_good']} of "
          f"{summary['n_fits']} curves good" + (f" (left out: {left})" if left else ""))
    for name, p in summary["params"].items():
        if p["median"] is not None:
            unit = str(whole[name].attrs["units"])
            print(f"     median {name} = {format_value(p['median'], unit)} (IQR "
                  f"{format_value(p['q25'], unit)} – {format_value(p['q75'], unit)}; good pixels)")
    _save_figure(bode_plot(one, fit=fit, frequency_unit="Hz", residuals=True,
                           title=f"real JPK map, curve 0: data and {fit.attrs['candidate']} "
                                 "contact fit"),
                 str(out / "bode_real.png"))
    viewer = _viewer(whole, spec, out)
    report["real"] = {"seconds": elapsed, "viewer": viewer, "candidate": str(fit.attrs["candidate"]),
                      "redchi": float(fit["redchi"]), "chi2_pvalue": float(fit["chi2_pvalue"]),
                      "explanation": str(fit.attrs["explanation"]), "map": summary, **{
        n: [float(fit[n]), float(fit[f"{n}_stderr"])] for n in fit["param_i"].values}}


def _viewer(whole, spec, out: Path) -> str | None:
    """The real map's viewer page (map_viewer.html; None, with a note, without Bokeh).

    The map result carries each pixel's best-fit spectrum (``fit_map``), which the page draws.
    """
    try:
        from viscoforce.plotting.viewer import map_view, report_html
    except ImportError as exc:  # bokeh missing: the rest of the demo stands
        print(f"   note: map_viewer.html not written ({exc}; pip install bokeh)")
        return None
    path = out / "map_viewer.html"
    write_text(path, report_html(map_view(whole, spec, title=(
        f"real JPK map ({spec.sizes['curve']} curves): {whole.attrs['model']} model"))))
    print(f"   viewer of the map: {path} (open it in a browser; click a pixel)")
    return str(path)


def run_demo(args: argparse.Namespace) -> int:
    """Load, demodulate, fit and plot a synthetic and a real file."""
    import contextlib
    import sys

    from viscoforce.cli._output import print_json

    folder = find_examples(args.data)
    out = Path(args.out_dir or "viscoforce-demo")
    out.mkdir(parents=True, exist_ok=True)
    report: dict[str, Any] = {}
    # with --json, stdout holds the JSON object alone: the narrative goes to stderr
    with contextlib.redirect_stdout(sys.stderr) if args.json else contextlib.nullcontext():
        fit, problem, _ = _synthetic(folder, out, report)
        _loop(fit, problem, out, report)
        _real(folder, out, report)
    write_text(out / "demo.json", json.dumps(report, indent=2) + "\n")
    written = [str(out / name) for name in ("bode_synthetic.png", "loop.png", "bode_real.png",
                                            "demo.json")]
    if report["real"]["viewer"]:
        written.insert(3, report["real"]["viewer"])
    if args.json:
        print_json({**report, "out_dir": str(out), "written": written})
        return 0
    print(f"wrote {out}/bode_synthetic.png, loop.png, bode_real.png, "
          + ("map_viewer.html, " if report["real"]["viewer"] else "") + "demo.json")
    return 0


#: The commands of this module: name → (add the flags to a parser, run the parsed arguments).
SUBCOMMANDS = {"demo": (add_demo, run_demo)}
