"""Output files of the commands: declared as data, checked before anything is computed.

Output-file flags are declared with :func:`add_outputs` (:class:`Output` rows: a netCDF file, a
figure, a directory) and checked by :func:`check_outputs` (:func:`check_output_paths`: writable,
the right extension, not the same file twice, not an input of the command). All names are
re-exported by :mod:`viscoforce.cli._args`.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import NamedTuple

from viscoforce._files import same_file
from viscoforce.cli._usage import UsageError

__all__ = [
    "CSV",
    "DIRECTORY",
    "FIGURE",
    "NETCDF",
    "NETCDF_OR_CSV",
    "Output",
    "add_outputs",
    "check_output_paths",
    "check_outputs",
    "figure_formats",
    "format_names",
]


#: Output kinds of :class:`Output`.
NETCDF, FIGURE, DIRECTORY = "netcdf", "figure", "directory"
#: An output that is a netCDF file (.nc) or a CSV table (.csv), by its extension.
NETCDF_OR_CSV = "netcdf-or-csv"
#: An output that is a CSV table (.csv).
CSV = "csv"

#: Figure formats assumed when matplotlib cannot be asked.
_FALLBACK_FIGURE_FORMATS = ("eps", "jpeg", "jpg", "pdf", "png", "ps", "svg", "tif", "tiff",
                            "webp")


class Output(NamedTuple):
    """An output-file flag, as data.

    Attributes
    ----------
    flag : str
        The option string (``"--out"``).
    kind : str
        :data:`NETCDF`, :data:`FIGURE` or :data:`DIRECTORY` (what :func:`check_output_paths`
        requires of the path).
    metavar, help : str
        As shown by ``--help``.
    aliases : tuple of str
        Other spellings that keep working (``demo --out`` beside ``--out-dir``).
    """

    flag: str
    kind: str
    metavar: str
    help: str
    aliases: tuple[str, ...] = ()


def add_outputs(parser: argparse.ArgumentParser, outputs: Sequence[Output]) -> None:
    """Add output-file flags to ``parser`` and record them for :func:`check_outputs`.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The (sub)command parser.
    outputs : sequence of Output
        The flags (default None: not written).
    """
    for o in outputs:
        parser.add_argument(o.flag, *o.aliases, default=None, metavar=o.metavar, help=o.help,
                            dest=_dest(o.flag))
    parser.set_defaults(outputs_=tuple(outputs))


def format_names() -> str:
    """The instrument formats ``--format`` takes, from the registry (``"jpk, csv-curves, ..."``)."""
    from viscoforce.io.instruments import FORMATS

    return ", ".join(f.name for f in FORMATS)


def figure_formats() -> tuple[str, ...]:
    """File extensions (without the dot) that matplotlib's ``savefig`` can write.

    Asks :meth:`matplotlib.backend_bases.FigureCanvasBase.get_supported_filetypes` (pyplot is
    not imported); a fixed list (png, pdf, svg, eps, ps, jpg, jpeg, tif, tiff, webp) if
    matplotlib cannot be imported.
    """
    try:
        from matplotlib.backend_bases import FigureCanvasBase
    except ImportError:  # pragma: no cover - matplotlib is a dependency
        return _FALLBACK_FIGURE_FORMATS
    return tuple(sorted(FigureCanvasBase.get_supported_filetypes()))


def _check_one(flag: str, text: str, kind: str) -> None:
    path = Path(text)
    shown = f"{flag} {text}"
    if not text.strip():
        raise UsageError(f"{flag}: empty file name")
    if kind == DIRECTORY:
        if path.exists() and not path.is_dir():
            raise UsageError(f"{shown}: exists and is not a directory")
        return
    if path.is_dir():
        raise UsageError(f"{shown}: is a directory; give a file name")
    suffix = path.suffix.lower()
    if kind == NETCDF and suffix != ".nc":
        raise UsageError(f"{shown}: a netCDF file name must end in .nc")
    if kind == CSV and suffix != ".csv":
        raise UsageError(f"{shown}: a CSV table's file name must end in .csv")
    if kind == NETCDF_OR_CSV and suffix not in (".nc", ".csv"):
        raise UsageError(f"{shown}: the file name must end in .nc (netCDF) or .csv (a table)")
    if kind == FIGURE:
        formats = figure_formats()
        listed = ", ".join(f".{f}" for f in formats)
        if not suffix:
            raise UsageError(f"{shown}: no file extension to choose the figure format; end the "
                             f"name in one of {listed}")
        if suffix[1:] not in formats:
            raise UsageError(f"{shown}: unsupported figure format '{suffix}'; supported: {listed}")
    parent = path.parent
    if not parent.is_dir():
        raise UsageError(f"{shown}: directory '{parent}' does not exist")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{shown}: the existing file is not writable")
    if not path.exists() and not os.access(parent, os.W_OK | os.X_OK):
        raise UsageError(f"{shown}: directory '{parent}' is not writable")


def check_output_paths(paths: Iterable[tuple[str, str | None, str]]) -> None:
    """Refuse output paths that cannot be written, before anything is computed.

    Parameters
    ----------
    paths : iterable of (flag, path or None, kind)
        Each output flag, its value (None: not given) and its kind (:data:`NETCDF`: must end in
        ``.nc``; :data:`FIGURE`: an extension matplotlib can write, see :func:`figure_formats`;
        :data:`DIRECTORY`: a directory, created by the command if missing).

    Raises
    ------
    UsageError
        Two flags naming the same file; an empty name; a file path that is a directory or
        whose parent directory does not exist or is not writable; a wrong or missing extension.
    """
    given = [(flag, text, kind) for flag, text, kind in paths if text is not None]
    seen: dict[str, str] = {}
    for flag, text, _ in given:
        key = os.path.normcase(os.path.realpath(text)) if text.strip() else ""
        if key and key in seen:
            raise UsageError(f"{flag} {text}: the same file as {seen[key]}; give two different "
                             "file names")
        seen[key] = flag
    for flag, text, kind in given:
        _check_one(flag, text, kind)


def _dest(flag: str) -> str:
    return flag.lstrip("-").replace("-", "_")


def check_outputs(args: argparse.Namespace) -> None:
    """:func:`check_output_paths` for the outputs a parser declared with :func:`add_outputs`.

    Parameters
    ----------
    args : argparse.Namespace
        Parsed arguments (without declared outputs nothing is checked).
    """
    outputs: Sequence[Output] = getattr(args, "outputs_", ())
    typed = getattr(args, "typed_", {})

    def shown(o: Output) -> str:  # the spelling the user typed
        return typed.get(_dest(o.flag), (o.flag,))[0]

    check_output_paths((shown(o), getattr(args, _dest(o.flag)), o.kind) for o in outputs)
    written = {_dest(o.flag) for o in outputs}
    inputs = [text for key, value in vars(args).items()
              if key not in written and not key.endswith("_") for text in _strings(value)]
    for o in outputs:
        target = getattr(args, _dest(o.flag))
        if target is None or o.kind == DIRECTORY or not Path(target).exists():
            continue
        for source in inputs:
            if same_file(target, source):
                raise UsageError(f"{shown(o)} {target} is an input of this command ({source}): "
                                 "writing it would destroy the data; give another file name")


def _strings(value: object) -> list[str]:
    """The strings in an argument value (a path, a list of paths, HEIGHT=FILE pairs)."""
    if isinstance(value, str):
        return [value]
    if isinstance(value, list | tuple):
        return [s for v in value for s in _strings(v)]
    return []
