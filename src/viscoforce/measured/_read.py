"""How a file is read: a netCDF file with a bound, a JPK archive in chunks, any other file whole.

:func:`open_streamable` decides whether a JPK archive is read chunk by chunk (then memory stays
bounded by a chunk of curves whatever the map's size); :func:`read_netcdf` reads the netCDF
files viscoforce writes as they are; :func:`read_whole` reads any instrument file through
:func:`~viscoforce.io.instruments.load_instrument`.
"""

from __future__ import annotations

from os import PathLike
from pathlib import Path
from typing import Any

from viscoforce.measured._options import OptionError, has_modulation, literal

__all__ = ["curves_streamed", "open_streamable", "read_netcdf", "read_whole",
           "streamed_spectrum"]

#: Options that calibrate a file without its own calibration (text formats).
CALIBRATION = ("spring_constant", "sensitivity")


def open_streamable(path: str | PathLike[str], fmt: str | None = None,
                    options: dict | None = None, *, height_channel: str | None = None):
    """``(archive, probe)`` of a JPK file read in chunks, or None: read it whole instead.

    A JPK archive (detected, or ``fmt="jpk"``) without calibration ``options`` is read chunk by
    chunk (:mod:`viscoforce.io.stream`); ``probe`` is the curves dataset of its first curve
    (its segment table says whether the file has modulation segments, and at which
    frequencies), with the ``source`` and ``file`` attrs
    :func:`~viscoforce.io.instruments.load_instrument` gives. Any other file, or one the JPK
    reader refuses, is None: the whole-file route reads it and reports its errors. The caller
    closes the archive.
    """
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
        probe = jpk_to_curves(archive, curves=0, height_channel=height_channel)
    except ViscoforceError:
        archive.close()
        return None
    probe.attrs.update(source="jpk", file=str(Path(path)))
    return archive, probe


def streamed_spectrum(path: str | PathLike[str], fmt: str | None = None):
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


def curves_streamed(archive, out: str | PathLike[str] | None, attrs: dict,
                    height_channel: str | None) -> dict:
    """The dims and variables of the archive's curves, written to ``out`` chunk by chunk.

    Without ``out`` the chunks are read and counted, one at a time.
    """
    from viscoforce.io.stream import CURVE_DIMS, iter_curves, write_curves_netcdf

    if out:
        return write_curves_netcdf(archive, out, attrs=attrs, height_channel=height_channel)
    sizes: dict[str, int] = {}
    variables: list[str] = []
    for part in iter_curves(archive, height_channel=height_channel):
        if not sizes:
            sizes = {str(k): int(v) for k, v in part.sizes.items()}
            variables = sorted(str(v) for v in part.data_vars)
        else:
            for d in CURVE_DIMS:
                sizes[d] += int(part.sizes[d])
    return {"dims": sizes, "variables": variables}


def read_netcdf(path: str | PathLike[str]):
    """A netCDF file as written, read whole with a bound; measured data pass the checks.

    Measured data (``source`` an instrument format, not "simulation" or absent) pass the
    checks the instrument readers apply (:func:`viscoforce.io.quality.check_measured`): a file
    written elsewhere, or edited, may hold values no measurement gives.
    """
    from viscoforce.exceptions import EffortError
    from viscoforce.io.netcdf import open_netcdf
    from viscoforce.io.quality import check_measured

    if not Path(path).is_file():
        raise OptionError("{path}" + f"{literal(path)}: no such file")
    try:
        ds = open_netcdf(path)
    except EffortError:
        raise
    except (OSError, ValueError) as exc:
        raise OptionError("{path}" + f"{literal(path)}: not a readable netCDF file "
                          f"({literal(exc)})") from None
    if str(ds.attrs.get("source", "simulation")) != "simulation":  # measured
        check_measured(ds, str(path))
    return ds


def read_whole(path: str | PathLike[str], fmt: Any, options: dict):
    """:func:`~viscoforce.io.instruments.load_instrument`; an option the format lacks named."""
    from viscoforce.io.instruments import load_instrument

    try:
        return load_instrument(path, format=fmt, **options)
    except TypeError as exc:  # an option the format does not take
        if not options:
            raise
        names = " and ".join("{" + k + "}" for k in options)
        if any(k in CALIBRATION for k in options):
            why = ("this file carries its own calibration; they are for files without one: "
                   "NT-MDT text, AFM Workshop in volts, Igor, Chiaro, UFF, CSV")
        else:
            why = "height_channel chooses the height channel of a JPK archive"
        raise OptionError(f"{names}: {literal(exc)} ({why})") from None
