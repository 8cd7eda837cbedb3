"""Commands that analyse measured data: ``load`` (``fit`` and ``bode``: :mod:`viscoforce.cli.fitting`).

Like :mod:`viscoforce.cli.model`, each command is a pair in :data:`SUBCOMMANDS`; the library is
imported inside the run functions.
"""

from __future__ import annotations

import argparse
import re

from viscoforce._files import write_netcdf
from viscoforce.cli._args import (
    NETCDF,
    Flag,
    FlagGroup,
    Output,
    UsageError,
    add_flags,
    add_outputs,
    format_names,
    frequency_type,
    quantity_type,
)
from viscoforce.cli._output import print_json, print_written

__all__ = ["SUBCOMMANDS", "open_streamable", "phase_lag_type", "streamed_spectrum"]

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
))


def add_load(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce load``."""
    parser.add_argument("file", metavar="FILE", help="instrument file (JPK, CSV, ...)")
    add_flags(parser, LOAD_FLAGS)
    parser.add_argument("--phase-lag", type=phase_lag_type, nargs="+", default=None,
                        metavar="LAG", help="instrument phase lag subtracted from the spectrum: "
                        "degrees for all frequencies, or FREQUENCY=DEGREES pairs")
    parser.add_argument("--phase-reference", default=None, metavar="FILE",
                        help="a hard-surface measurement (any file load reads) whose phase per "
                             "frequency is the instrument lag to subtract")
    parser.add_argument("--drag-heights", type=_height_file_type, nargs="+", default=None,
                        metavar="HEIGHT=FILE",
                        help="spectra measured out of contact at several heights above the "
                             "surface (e.g. 1um=free1.jpk-force 2um=free2.jpk-force "
                             "4um=free4.jpk-force, at least 3): the drag b(h) = 6 pi eta "
                             "a_eff^2/(h + h_eff) (Alcaraz et al. 2002) extrapolated to contact is "
                             "subtracted (instead of --drag)")
    parser.add_argument("--raw", action="store_true",
                        help="write the curves, not the spectrum of the modulation segments")
    add_outputs(parser, [Output("--out", NETCDF, "FILE.nc", "write the dataset (netCDF)")])
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object: format, kind, n_curves, dims, variables")


def _height_file_type(text: str) -> tuple[float, str]:
    """``--drag-heights`` item: HEIGHT=FILE (``2um=free.jpk-force``)."""
    height, sep, path = text.partition("=")
    if not sep or not path.strip():
        raise argparse.ArgumentTypeError(f"expected HEIGHT=FILE (e.g. 2um=free2.jpk-force), got "
                                         f"{text!r}")
    return quantity_type("length")(height.strip()), path.strip()


def _drag_from_heights(items: list[tuple[float, str]] | None, lag, reference):
    """The DragFit of the out-of-contact spectra of ``--drag-heights`` (None without it)."""
    if items is None:
        return None
    from viscoforce.experiments.drag import drag_from_heights
    from viscoforce.experiments.modulation import correct_spectrum, modulation_spectrum
    from viscoforce.io.instruments import load_instrument

    spectra = []
    for height, path in items:
        data = load_instrument(path)
        if "omega" in data.dims:
            spectrum = data if lag is None and reference is None else correct_spectrum(
                data, phase_lag=_phase_lag(lag, data), phase_reference=reference)
        elif has_modulation(data):
            spectrum = modulation_spectrum(data, phase_lag=_phase_lag(lag, data),
                                           phase_reference=reference)
        else:
            raise UsageError(f"--drag-heights {height:g}m={path}: the file has no modulation "
                             "segments (a spectrum measured out of contact is needed)")
        spectra.append(spectrum)
    return drag_from_heights(spectra, [h for h, _ in items])


def _phase_lag(values: list | None, data) -> float | dict[float, float] | None:
    """One lag [deg] for all frequencies, or {Hz: deg} with 0 for the frequencies not named."""
    if values is None:
        return None
    scalars = [v for v in values if not isinstance(v, tuple)]
    if scalars and len(values) > 1:
        raise UsageError("--phase-lag takes one number of degrees or FREQUENCY=DEGREES pairs, "
                         "not both")
    if scalars:
        return float(scalars[0])
    import numpy as np

    lags = dict(values)
    if "omega" in data.dims:  # a spectrum already made (a CSV, a netCDF from load)
        present = np.unique(np.asarray(data["omega"].values, dtype=float) / (2 * np.pi))
    elif "segment_frequency" in data:
        present = np.unique(data["segment_frequency"].values)
    else:
        present = []
    present = [float(f) for f in present if np.isfinite(f)]
    for f in lags:
        if not any(abs(f - p) <= 1e-9 * p for p in present):
            raise UsageError(f"--phase-lag {f:g}Hz: the file has no modulation at that frequency "
                             f"(it has {', '.join(f'{p:g}' for p in present)} Hz)")
    return {p: next((v for f, v in lags.items() if abs(f - p) <= 1e-9 * p), 0.0) for p in present}


_MODULI_NEED_SPECTRUM = ("--tip and --poisson give the complex modulus of a spectrum; this file "
                         "gives curves (no modulation segments, or --raw)")


def _with_moduli(ds, args: argparse.Namespace):
    """The spectrum with E′, E″, G′, G″ per point (``--tip``, ``--poisson``)."""
    from viscoforce.experiments.moduli import add_complex_modulus

    if "omega" not in ds.dims:
        raise UsageError(_MODULI_NEED_SPECTRUM)
    if args.tip is None:
        raise UsageError("--poisson needs --tip (the moduli need the tip's contact size)")
    poisson = None
    if args.poisson is not None:
        try:
            poisson = float(args.poisson)
        except ValueError:
            raise UsageError(f"--poisson must be a number in [0, 0.5], got {args.poisson!r}"
                             ) from None
    return add_complex_modulus(ds, args.tip, poisson=poisson)  # a Tip: parsed with the flags


def has_modulation(ds) -> bool:
    """Whether a curves dataset has sine-modulation segments."""
    names = ds.get("segment_name")
    return names is not None and bool((names.values == "modulation").any())


def open_streamable(path: str, fmt: str | None = None, options: dict | None = None):
    """``(archive, probe)`` of a JPK file read in chunks, or None: read it whole instead.

    A JPK archive (detected, or ``--format jpk``) without calibration options is read chunk by
    chunk (:mod:`viscoforce.io.stream`); ``probe`` is the curves dataset of its first curve
    (its segment table says whether the file has modulation segments, and at which
    frequencies), with the ``source`` and ``file`` attrs :func:`load_instrument` gives. Any
    other file, or one the JPK reader refuses, is None: the whole-file route reads it and
    reports its errors. The caller closes the archive.
    """
    from pathlib import Path

    from viscoforce.exceptions import ViscoforceError
    from viscoforce.io.curves import jpk_to_curves
    from viscoforce.io.instruments import detect_format
    from viscoforce.io.jpk import read_jpk

    if options or fmt not in (None, "jpk"):
        return None
    try:
        if fmt is None and detect_format(path).name != "jpk":
            return None
        archive = read_jpk(path)
    except ViscoforceError:
        return None
    try:
        probe = jpk_to_curves(archive, curves=0)
    except ViscoforceError:
        archive.close()
        return None
    probe.attrs.update(source="jpk", file=str(Path(path)))
    return archive, probe


def streamed_spectrum(path: str, fmt: str | None = None):
    """The spectrum of a modulated JPK file demodulated in chunks, else None (read it whole)."""
    opened = open_streamable(path, fmt)
    if opened is None:
        return None
    archive, probe = opened
    with archive:
        if not has_modulation(probe):
            return None
        from viscoforce.experiments.stream import stream_spectrum

        return stream_spectrum(archive)


def _curves_streamed(archive, out: str | None, attrs: dict) -> dict:
    """The dims and variables of the archive's curves dataset, written to ``out`` chunk by chunk."""
    from viscoforce.io.stream import CURVE_DIMS, iter_curves, write_curves_netcdf

    if out:
        return write_curves_netcdf(archive, out, attrs=attrs)
    sizes, variables = None, []
    for part in iter_curves(archive):
        if sizes is None:
            sizes = {str(k): int(v) for k, v in part.sizes.items()}
            variables = sorted(str(v) for v in part.data_vars)
        else:
            for d in CURVE_DIMS:
                sizes[d] += int(part.sizes[d])
    return {"dims": sizes, "variables": variables}


def run_load(args: argparse.Namespace) -> int:
    """Read an instrument file; modulation segments become a spectrum unless ``--raw``.

    A JPK archive is read and demodulated in chunks of curves (:func:`open_streamable`): memory
    stays bounded whatever the map's size, the results are those of reading it whole.
    """
    options = {k: v for k, v in (("spring_constant", args.spring_constant),
                                 ("sensitivity", args.sensitivity)) if v is not None}
    opened = open_streamable(args.file, args.format, options)
    if opened is None:
        return _run_load(args, None, _load_whole(args, options))
    archive, probe = opened
    with archive:
        return _run_load(args, archive, probe)


def _load_whole(args: argparse.Namespace, options: dict):
    from viscoforce.io.instruments import load_instrument

    try:
        return load_instrument(args.file, format=args.format, **options)
    except TypeError as exc:  # an option the format does not take (its own calibration)
        if not options:
            raise
        flags = " and ".join(f"--{k.replace('_', '-')}" for k in options)
        raise UsageError(f"{flags}: {exc} (this file carries its own calibration; the flags "
                         "are for files without one: NT-MDT text, AFM Workshop in volts, "
                         "Igor, Chiaro, UFF, CSV)") from None


def _run_load(args: argparse.Namespace, archive, data) -> int:
    """``load`` of ``data``: the whole file, or (``archive`` given) the probe of a JPK archive."""
    from viscoforce.experiments.modulation import correct_spectrum, modulation_spectrum
    from viscoforce.io.instruments import load_instrument

    fmt = str(data.attrs.get("source", args.format or ""))
    if args.drag is not None and args.drag_heights is not None:
        raise UsageError("give --drag or --drag-heights, not both")
    corrections = (args.drag is not None or args.phase_lag is not None
                   or args.phase_reference is not None or args.drag_heights is not None)
    if corrections and "omega" not in data.dims and (args.raw or not has_modulation(data)):
        raise UsageError("--drag, --drag-heights, --phase-lag and --phase-reference correct a "
                         "spectrum; this file gives curves (no modulation segments, or --raw)")
    reference = None
    if args.phase_reference is not None:
        reference = load_instrument(args.phase_reference)
        if "omega" not in reference.dims:
            reference = modulation_spectrum(reference)
    drag_fit = _drag_from_heights(args.drag_heights, args.phase_lag, reference)
    drag = args.drag if drag_fit is None else drag_fit.drag_at_contact
    streamed = None
    if "omega" in data.dims:  # a spectrum CSV or netCDF: the same corrections and flags
        ds = data if not corrections else correct_spectrum(
            data, phase_lag=_phase_lag(args.phase_lag, data), drag=drag,
            phase_reference=reference)
    elif args.raw or not has_modulation(data):
        if archive is not None:  # the curves go to the file chunk by chunk
            if args.tip is not None or args.poisson is not None:
                raise UsageError(_MODULI_NEED_SPECTRUM)
            streamed = _curves_streamed(archive, args.out, {k: data.attrs[k]
                                                            for k in ("source", "file")})
        ds = data
    elif archive is not None:
        from viscoforce.experiments.stream import stream_spectrum

        ds = stream_spectrum(archive, phase_lag=_phase_lag(args.phase_lag, data), drag=drag,
                             phase_reference=reference)
    else:
        ds = modulation_spectrum(data, phase_lag=_phase_lag(args.phase_lag, data), drag=drag,
                                 phase_reference=reference)
    if drag_fit is not None:
        ds.attrs.update(drag_fit.as_attrs())
    if args.tip is not None or args.poisson is not None:
        ds = _with_moduli(ds, args)
    if args.out and streamed is None:
        write_netcdf(ds, args.out)
    kind = "spectrum" if "omega" in ds.dims else "curves"
    dims = streamed["dims"] if streamed else {str(k): int(v) for k, v in ds.sizes.items()}
    result = {"format": fmt, "kind": kind,
              "n_curves": int(dims.get("curve", 1)), "dims": dims,
              "variables": streamed["variables"] if streamed
              else sorted(str(v) for v in ds.data_vars)}
    if drag_fit is not None:
        result.update(drag_at_contact=drag_fit.drag_at_contact,
                      drag_at_contact_stderr=drag_fit.drag_at_contact_stderr)
    if args.json:
        print_json(result)
        return 0
    print(f"{args.file}: format {fmt}, {kind} of {result['n_curves']} curve(s); dims "
          + ", ".join(f"{k}={v}" for k, v in result["dims"].items()))
    print("variables: " + ", ".join(result["variables"]))
    if drag_fit is not None:
        print(f"drag at contact b(0) = {drag_fit.drag_at_contact:.4g} ± "
              f"{drag_fit.drag_at_contact_stderr:.2g} N s/m from {len(args.drag_heights)} "
              "heights (subtracted as i omega b)")
    print_written(args.out)
    return 0


#: The commands of this module: name → (add the flags to a parser, run the parsed arguments).
SUBCOMMANDS = {
    "load": (add_load, run_load),
}
