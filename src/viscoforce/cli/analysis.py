"""Commands that analyse measured data: ``load`` (``fit`` and ``bode``: :mod:`viscoforce.cli.fitting`).

Like :mod:`viscoforce.cli.model`, each command is a pair in :data:`SUBCOMMANDS`; the library is
imported inside the run functions.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from viscoforce.cli._args import (
    NETCDF_OR_CSV,
    Flag,
    FlagGroup,
    Output,
    UsageError,
    add_flags,
    add_outputs,
    choice_type,
    format_names,
    frequency_type,
    quantity_type,
)
from viscoforce.cli._output import print_json, print_written

__all__ = ["PHASE_REFERENCE_HELP", "SUBCOMMANDS", "has_modulation", "open_streamable",
           "phase_lag_type", "phase_reference_type", "streamed_spectrum"]

_PAIR_RE = re.compile(r"^\s*(?P<f>[^=:]+?)\s*[=:]\s*(?P<deg>[-+0-9.eE]+)\s*$")
_FREQUENCY = frequency_type("frequency")


def phase_lag_type(text: str) -> float | tuple[float, float]:
    """``--phase-lag`` value: degrees (``14``) or a frequency=degrees pair (``300Hz=14``).

    Returns a float (one lag for every frequency) or a (frequency [Hz], degrees) pair. The
    frequency needs its unit (``300=14`` is refused with its two readings).
    """
    match = _PAIR_RE.match(text)
    try:
        if match is None:
            return float(text)
        frequency = _FREQUENCY(match["f"])
    except argparse.ArgumentTypeError as exc:
        raise argparse.ArgumentTypeError(f"{text}: the frequency {exc}") from None
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected degrees (e.g. 14) or FREQUENCY=DEGREES pairs (e.g. 300Hz=14), got "
            f"{text!r}") from None
    try:
        return (frequency, float(match["deg"]))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected degrees (e.g. 14) or FREQUENCY=DEGREES pairs (e.g. 300Hz=14), got "
            f"{text!r}") from None


#: The words ``--phase-reference`` takes besides a file.
PHASE_REFERENCE_WORDS = ("auto", "sensor", "piezo", "delay")
#: Its help (``load`` here; ``fit`` and ``bode`` may take the same flag).
PHASE_REFERENCE_HELP = (
    "what the phase of the indentation refers to: sensor (the height channel as recorded), "
    "piezo (the sensor's amplitude with the piezo record's phase), delay (the sensor advanced "
    "by its delay behind the piezo, one fitted per file), auto (default: the one the data "
    "support, said in the attrs phase_reference_choice); or FILE, a hard-surface measurement "
    "(any file load reads, demodulated against the sensor) whose phase per frequency is the "
    "instrument lag to subtract. A file that exists is the file, even one named like a mode")


def phase_reference_type(text: str) -> str | Path:
    """``--phase-reference`` value: a mode word (``str``) or a hard-surface file (``Path``).

    A file that exists is that file, whatever its name; else one of
    :data:`PHASE_REFERENCE_WORDS` is the mode; any other text is a file (refused by the
    reader, naming it, when absent).
    """
    if Path(text).exists() or text not in PHASE_REFERENCE_WORDS:
        return Path(text)
    return text


def _tip_type(text: str):
    """``--tip``: parsed with the flags (a bad tip is refused before the file is read)."""
    from viscoforce.physics.tips import parse_tip

    return parse_tip(text)


LOAD_FLAGS = FlagGroup(None, (
    Flag("--format", None, None, "NAME",
         f"file format: {format_names()} (default: detected from the content)"),
    Flag("--spring-constant", "stiffness", None, "STIFFNESS",
         "cantilever spring constant, e.g. 0.1N/m (for files without calibration)"),
    Flag("--sensitivity", "sensitivity", None, "SENSITIVITY",
         "deflection sensitivity, e.g. 50nm/V (for files without calibration)"),
    Flag("--drag", "drag", None, "DRAG",
         "hydrodynamic drag B, subtracted from the spectrum as i*omega*B, e.g. 1e-6N*s/m"),
    Flag("--tip", _tip_type, None, "SHAPE:SIZE",
         "tip (sphere:R | paraboloid:R | cone:ANGLE | pyramid:ANGLE | flat:RADIUS): adds "
         "E_storage, E_loss, G_storage, G_loss per point to a spectrum"),
    Flag("--poisson", None, None, "NU",
         "the sample's Poisson's ratio in [0, 0.5] for those moduli (default 0.5)"),
    Flag("--sample-height", "length", None, "LENGTH",
         "with --tip: the sample's thickness on its rigid support (a cell: 2-10um): E', E'' "
         "divided by the bottom-effect stiffness factor at each mean_indentation"),
    Flag("--sample-base", choice_type("bonded", "sliding", what="--sample-base"), None,
         "bonded|sliding", "--sample-height: the layer bonded to (default) or sliding on its "
         "support"),
))


def add_load(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce load``."""
    parser.add_argument("file", metavar="FILE", help="instrument file (JPK, CSV, ...)")
    add_flags(parser, LOAD_FLAGS)
    parser.add_argument("--phase-lag", type=phase_lag_type, nargs="+", default=None,
                        metavar="LAG", help="instrument phase lag subtracted from the spectrum: "
                        "degrees for all frequencies, or FREQUENCY=DEGREES pairs")
    parser.add_argument("--phase-reference", type=phase_reference_type, default=None,
                        metavar="sensor|piezo|delay|auto|FILE", help=PHASE_REFERENCE_HELP)
    parser.add_argument("--drag-heights", type=_height_file_type, nargs="+", default=None,
                        metavar="HEIGHT=FILE",
                        help="spectra measured out of contact at several heights above the "
                             "surface (e.g. 1um=free1.jpk-force 2um=free2.jpk-force "
                             "4um=free4.jpk-force, at least 3): the drag b(h) = 6 pi eta "
                             "a_eff^2/(h + h_eff) (Alcaraz et al. 2002) extrapolated to contact is "
                             "subtracted (instead of --drag)")
    parser.add_argument("--raw", action="store_true",
                        help="write the curves, not the spectrum of the modulation segments")
    add_outputs(parser, [Output("--out", NETCDF_OR_CSV, "FILE.nc|FILE.csv",
                                "write the dataset (netCDF), or a spectrum as a CSV table: one "
                                "row per curve and frequency, units in the headers (.csv)")])
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object: format, kind, n_curves, dims, variables")


def _height_file_type(text: str) -> tuple[float, str]:
    """``--drag-heights`` item: HEIGHT=FILE (``2um=free.jpk-force``)."""
    height, sep, path = text.partition("=")
    if not sep or not path.strip():
        raise argparse.ArgumentTypeError(f"expected HEIGHT=FILE (e.g. 2um=free2.jpk-force), got "
                                         f"{text!r}")
    return quantity_type("length")(height.strip()), path.strip()


#: The flag of each parameter of :func:`viscoforce.measured.open.read_measured` (its errors told
#: with them); ``path`` is FILE, already named by the message.
_FLAGS = {"drag": "--drag", "drag_heights": "--drag-heights", "phase_lag": "--phase-lag",
          "phase_reference": "--phase-reference", "tip": "--tip", "poisson": "--poisson",
          "raw": "--raw", "spring_constant": "--spring-constant",
          "sensitivity": "--sensitivity", "format": "--format", "path": "",
          "sample_height": "--sample-height", "sample_base": "--sample-base"}


def _phase_lag(values: list | None) -> float | dict[float, float] | None:
    """``--phase-lag`` values: one lag [deg] for all frequencies, or {Hz: deg}."""
    if values is None:
        return None
    scalars = [v for v in values if not isinstance(v, tuple)]
    if scalars and len(values) > 1:
        raise UsageError("--phase-lag takes one number of degrees or FREQUENCY=DEGREES pairs, "
                         "not both")
    return float(scalars[0]) if scalars else dict(values)


def _poisson(text: str | None) -> float | None:
    if text is None:
        return None
    try:
        return float(text)
    except ValueError:
        raise UsageError(f"--poisson must be a number in [0, 0.5], got {text!r}") from None


def has_modulation(ds) -> bool:
    """Whether a curves dataset has sine-modulation segments (:mod:`viscoforce.measured`)."""
    from viscoforce.measured.open import has_modulation as modulated

    return modulated(ds)


def open_streamable(path: str, fmt: str | None = None, options: dict | None = None):
    """:func:`viscoforce.measured.open.open_streamable`: ``(archive, probe)`` or None."""
    from viscoforce.measured.open import open_streamable as opened

    return opened(path, fmt, options)


def streamed_spectrum(path: str, fmt: str | None = None):
    """:func:`viscoforce.measured.open.streamed_spectrum`: a JPK map's spectrum, or None."""
    from viscoforce.measured.open import streamed_spectrum as streamed

    return streamed(path, fmt)


def run_load(args: argparse.Namespace) -> int:
    """Read an instrument file; modulation segments become a spectrum unless ``--raw``.

    :func:`viscoforce.measured.open.read_measured` does it (a JPK archive read in chunks of
    curves: memory bounded whatever the map's size); this maps the flags and prints.
    """
    from viscoforce.measured.open import OptionError, read_measured

    table = bool(args.out) and str(args.out).lower().endswith(".csv")
    if table and args.raw:
        raise UsageError(f"--out {args.out}: a CSV table holds a spectrum; the curves (--raw) "
                         "are written as netCDF (.nc)")
    try:
        made = read_measured(
            args.file, format=args.format, raw=args.raw, spring_constant=args.spring_constant,
            sensitivity=args.sensitivity, phase_lag=_phase_lag(args.phase_lag),
            phase_reference=args.phase_reference, drag=args.drag,
            drag_heights=args.drag_heights, tip=args.tip, poisson=_poisson(args.poisson),
            sample_height=args.sample_height, sample_base=args.sample_base,
            out=None if table else args.out, keep_streamed=False)
    except OptionError as exc:
        raise UsageError(exc.told(_FLAGS)) from None
    if table:
        if made.kind != "spectrum" or made.dataset is None:
            raise UsageError(f"--out {args.out}: a CSV table holds a spectrum; {args.file} gives "
                             f"{made.kind} (no modulation segments): write them as netCDF (.nc)")
        from viscoforce.io.csv_tables import write_spectrum_csv

        write_spectrum_csv(made.dataset, args.out)
    result = made.summary()
    if args.json:
        print_json(result)
        return 0
    print(f"{args.file}: format {result['format']}, {result['kind']} of {result['n_curves']} "
          "curve(s); dims " + ", ".join(f"{k}={v}" for k, v in result["dims"].items()))
    print("variables: " + ", ".join(result["variables"]))
    choice = made.dataset.attrs.get("phase_reference_choice") if made.dataset is not None else None
    if choice:
        print(f"phase reference: {choice}")
    if made.drag_fit is not None:
        print(f"drag at contact b(0) = {made.drag_fit.drag_at_contact:.4g} ± "
              f"{made.drag_fit.drag_at_contact_stderr:.2g} N s/m from {len(args.drag_heights)} "
              "heights (subtracted as i omega b)")
    print_written(args.out)
    return 0


#: The commands of this module: name → (add the flags to a parser, run the parsed arguments).
SUBCOMMANDS = {
    "load": (add_load, run_load),
}
