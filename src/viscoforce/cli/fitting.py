"""Commands that fit: ``fit`` (parameters out) and ``bode`` (data against fit, as a figure).

DATA is any file ``load`` reads (an instrument file: modulation segments become a spectrum), a
netCDF file the project wrote (spectrum, curves or trajectory), or a spectrum CSV.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from viscoforce._files import write_netcdf
from viscoforce.cli._args import (
    CSV,
    FIGURE,
    NETCDF_OR_CSV,
    Output,
    UsageError,
    add_flags,
    add_outputs,
)
from viscoforce.cli._fit_budget import (
    Kept,
    budget_json,
    budgeted,
    height_channel,
    map_alternatives,
    with_map_budget,
)
from viscoforce.cli._fit_inputs import (  # noqa: F401 - read_data, one_curve_squeezed: public here
    _CURVE_MODELS,
    _MATERIALS,
    _MODELS,
    _check_model,
    _extra_dims,
    _fixed,
    _kind,
    _select_curve,
    fit_one,
    measured,
    one_curve_squeezed,
    read_data,
)
from viscoforce.cli._fit_report import (
    _fit_recording,
    _map_json,
    _print_map,
    _print_single,
    _single_json,
    recorded,
    show,
    show_value,
)
from viscoforce.cli._fit_tables import _write_csv, table_rows, write_table  # noqa: F401
from viscoforce.cli._output import print_json, print_written

__all__ = ["SUBCOMMANDS", "modes_type", "read_data"]

from viscoforce.cli._fit_flags import (  # noqa: F401 - modes_type, choice_type: public here
    FIT_FLAGS,
    FIT_SYSTEM_FLAGS,
    MAP_FLAGS,
    _add_fit_flags,
    choice_type,
    modes_type,
)


def add_fit(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce fit``."""
    _add_fit_flags(parser, required=True, batch=True)
    add_flags(parser, MAP_FLAGS)
    add_outputs(parser, [Output("--out", NETCDF_OR_CSV, "FILE.nc|FILE.csv",
                                "write the fit result: netCDF (.nc) or a table, one row per "
                                "curve/pixel with units in the headers (.csv)"),
                         Output("--plot", FIGURE, "FILE.png",
                                "data and fit (one spectrum/curve), or a map of one fitted "
                                "variable over the pixels (a map; --plot-variable)"),
                         Output("--curves-out", CSV, "FILE.csv",
                                "write the data, the best fit and the residual of every fitted "
                                "point (one spectrum or curve, or a map of spectra: a long "
                                "table with a column per pixel coordinate)")])
    parser.add_argument("--reports", action="store_true",
                        help="a map: keep each pixel's lmfit report in --out (the text variable "
                             "fit_report; one more least-squares run per pixel)")
    parser.add_argument("--plot-variable", default=None, metavar="NAME",
                        help="the variable of a map's --plot (default: Young's modulus of the "
                             "main modulus, e.g. E_young, else the first fitted parameter; any "
                             "per-pixel variable, e.g. E0 (the paper's), redchi)")
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


# ── fit ─────────────────────────────────────────────────────────────────────────────────────────

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


def _reader(args: argparse.Namespace):
    """:func:`read_data` for ``args.model``.

    A curve model reads an instrument file's force curves even where the file has modulation
    segments (``load --raw``'s route), so ``fit MAP --model hertz`` fits the map's approaches
    instead of refusing its spectrum.
    """
    import functools

    return functools.partial(read_data, raw=args.model in _CURVE_MODELS)


def run_fit(args: argparse.Namespace) -> int:
    """Fit DATA; one spectrum/curve → parameters, a map → per-pixel parameters.

    Several files (or a folder) are fitted one after the other into one table (:func:`run_batch`).
    """
    paths = data_paths(args.data)
    _refuse_writing_inputs(args, paths)
    if len(paths) > 1:
        return run_batch(args, paths)
    args.data = paths[0]
    read = _reader(args)
    ds = read(args.data, args.format, height_channel=height_channel(args),
                   phase_reference=args.phase_reference)
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
    if getattr(args, "curves_out", None) and is_map and kind == "curves":
        raise UsageError("--curves-out writes best-fit curves of one curve or of spectra; a "
                         "map of curve fits keeps none: add --curve I for one curve")
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
        def fit_all(data, show_progress=progress):
            return fit_map(data, args.model, modes=1 if args.modes is None else args.modes,
                           criterion=args.criterion, scheduler=args.scheduler,
                           workers=args.workers, progress=show_progress, segment=args.segment,
                           poisson=args.poisson, reports=args.reports, **options, **fixed)

        result, texts = _fit_recording(fit_all, ds)
        if progress:  # the map's schedule: where it was fitted, and the cost model's numbers
            print(f"map fitted {result.attrs.get('execution', '')}: "
                  f"{result.attrs.get('execution_reason', '')}", file=sys.stderr)
        result, alternatives, described = map_alternatives(
            args, ds, kind, result, lambda data: fit_all(data, False), read)
        result = with_map_budget(args, result, fixed, alternatives, described)
        info = _map_json(result)
    else:
        first, first_texts, first_caught = recorded(fit_one, args, ds, kind)
        kept = Kept(first, ds, first_texts, first_caught)
        kept, result, why = budgeted(args, kept, kind, fit_one, read)
        show(kept.caught)
        texts = kept.texts
        info = _single_json(result)
        info.update(budget_json(result, info["params"]))
        if why:
            info["height_record"] = why
    info["warnings"] = texts
    if getattr(args, "curves_out", None):
        from viscoforce.io.fit_tables import export_fits

        info["curves_out"] = export_fits(result, ds if is_map else kept.data, args.curves_out)
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
    print_written(args.out, args.plot, getattr(args, "curves_out", None))
    return 0


# ── batch: many files into one table ────────────────────────────────────────────────────────────

def _fit_file(args: argparse.Namespace, path: str):
    """The fit result of one file of a batch (a map's curves fitted in this process)."""
    read = _reader(args)
    ds = read(path, args.format, height_channel=height_channel(args),
              phase_reference=args.phase_reference)
    kind = _kind(ds)
    _check_model(args, kind)
    ds = _select_curve(ds, kind, args.curve)
    one = argparse.Namespace(**{**vars(args), "data": path})  # the refits re-read this file
    if _extra_dims(ds, kind):
        from viscoforce.fitting.maps import fit_map

        options = {} if args.identifiability is None else {
            "identifiability": args.identifiability}
        fixed = _fixed(args, ds, kind)

        def fit_all(data):
            return fit_map(data, args.model, modes=1 if args.modes is None else args.modes,
                           criterion=args.criterion, scheduler=args.scheduler or "synchronous",
                           workers=args.workers, progress=False, segment=args.segment,
                           poisson=args.poisson, **options, **fixed)

        result, alternatives, described = map_alternatives(one, ds, kind, fit_all(ds), fit_all,
                                                           read)
        return with_map_budget(args, result, fixed, alternatives, described)
    return budgeted(one, Kept(fit_one(args, ds, kind), ds), kind, fit_one, read)[1]


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
    if getattr(args, "curves_out", None):
        raise UsageError("--curves-out writes the best fits of one file: give one file (or "
                         "fit each file apart)")
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
    ds = read_data(args.data, args.format, height_channel=height_channel(args),
                   phase_reference=args.phase_reference)
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

    spectrum_table = bool(args.out) and args.out.lower().endswith(".csv") and fit is None
    if (args.modulus or (spectrum_table and args.tip is not None)) and (
            "E_storage" not in ds or args.tip is not None):
        if args.tip is None:
            raise UsageError("--modulus needs --tip (the complex modulus needs the tip's contact "
                             "size), or a spectrum loaded with load --tip")
        from viscoforce.experiments.moduli import add_complex_modulus

        ds = add_complex_modulus(ds, args.tip, poisson=args.poisson)
    measured_data = str(ds.attrs.get("source", "simulation")) != "simulation"
    if spectrum_table:  # the spectrum drawn: one row per frequency (E', E'' ... with --tip)
        from viscoforce.io.csv_tables import write_spectrum_csv

        write_spectrum_csv(ds, args.out)
    elif args.out and args.out.lower().endswith(".csv"):
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
