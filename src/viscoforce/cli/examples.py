"""``viscoforce examples`` and the ``example:NAME`` route to the example files shipped in viscoforce.

The example files travel inside the package (:mod:`viscoforce.data`), so they are there in every
folder, not only in the repository. On the command line any input path may be written
``example:NAME`` (``viscoforce fit example:sls_spectrum.csv --model exact --h0=-5nm``): before a
command runs, :func:`resolve_example_args` replaces every such value of an *input* (DATA, FILE,
``--data``, ``--trace``, ``--phase-reference``, ``--drag-heights H=example:NAME`` ...) by the
file's path inside the installed package; an output flag given ``example:NAME`` is refused (the
examples are read, never written). NAME is a name :func:`viscoforce.data.example_names` lists
(``real/modulation-map.jpk-force-map``), or its file name alone when that is unique
(``modulation-map.jpk-force-map``); ``example:`` alone is the folder.

``viscoforce examples`` lists the files (name, what it is, size); ``--copy DIR`` copies them (or
the NAMEs given) into DIR, with the README that says how each was made and, beside the real file,
its LICENSE and SOURCE notes; files already there with the same bytes are kept, different ones
are refused, never overwritten.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from viscoforce._files import write_bytes
from viscoforce.cli._args import DIRECTORY, Output, UsageError, add_outputs

__all__ = ["DESCRIPTIONS", "PREFIX", "SUBCOMMANDS", "resolve_example", "resolve_example_args"]

#: The prefix that names a shipped example file on the command line.
PREFIX = "example:"

#: What each shipped file is (``viscoforce examples``); the data files first, then their notes.
DESCRIPTIONS: dict[str, str] = {
    "sls_spectrum.csv": "spectrum CSV, 25 frequencies 1 Hz - 3 kHz at h0 = -5 nm (truth: SLS "
                        "E0 5 GPa, E_inf 1 GPa, tau 5 ms); fit --model exact --h0=-5nm",
    "sls_spectrum_map.nc": "4 x 4 map of spectra (netCDF), tau, E0, E_inf varying across it; "
                           "fit --out fits.nc, then view",
    "sls_modulation.jpk-force": "JPK force curve with six sine-modulation segments 1 - 300 Hz; "
                                "load gives its spectrum",
    "sls_step_relaxation.csv": "force curve of a -5 -> -7 nm step held 40 ms; "
                               "fit --model relaxation",
    "approach_retract_trace.csv": "position trace of an approach-retract cycle 10 -> -8 -> 10 nm; "
                                  "simulate --drive trace --trace",
    "real/modulation-map.jpk-force-map": "real JPK modulation map of a cell, 16 curves, "
                                         "1 - 300 Hz (MIT, see real/SOURCE.md)",
    "README.md": "how each file was made, and its true parameters",
    "make_examples.py": "the script that regenerates the synthetic files",
    "real/LICENSE": "the real map's licence (MIT)",
    "real/SOURCE.md": "where the real map comes from (repository, commit, checksum)",
}

#: Notes that travel with the files of a folder when some are copied (licence and provenance).
_NOTES = {"real": ("LICENSE", "SOURCE.md")}


def _names() -> tuple[str, ...]:
    from viscoforce.data import example_names

    return example_names()


def _data_names(names: Iterable[str]) -> list[str]:
    """The example files that are data (not a README, a licence, a script), in listing order."""
    notes = {"README.md", "make_examples.py", "real/LICENSE", "real/SOURCE.md"}
    return [n for n in names if n not in notes]


def _canonical(name: str, text: str) -> str:
    """The listed name NAME stands for (itself, or the one file of that file name)."""
    names = _names()
    if name in names:
        return name
    by_file = [n for n in names if n.rsplit("/", 1)[-1] == name]
    if len(by_file) == 1:
        return by_file[0]
    stem = [n for n in _data_names(names) if n.rsplit("/", 1)[-1].split(".", 1)[0] == name]
    hint = f"; did you mean example:{stem[0]}?" if len(stem) == 1 else ""
    raise UsageError(f"{text}: no example file of that name{hint} (the examples: "
                     f"{', '.join(_data_names(names))}; `viscoforce examples` lists them)")


def resolve_example(text: str) -> str:
    """The path of the shipped example ``example:NAME`` names (``example:`` alone: the folder).

    Parameters
    ----------
    text : str
        ``"example:NAME"``: NAME as :func:`viscoforce.data.example_names` lists it, or its file
        name alone when that is unique.

    Returns
    -------
    str
        The absolute path inside the installed package.

    Raises
    ------
    UsageError
        If NAME is not a shipped example (the message lists them and ``viscoforce examples``).
    """
    from viscoforce.data import example_path

    name = text[len(PREFIX):].strip().strip("/") if text.startswith(PREFIX) else text
    if not name:
        return str(example_path())
    return str(example_path(_canonical(name, text)))


def _resolved(value: Any) -> Any:
    if isinstance(value, str):
        return resolve_example(value) if value.startswith(PREFIX) else value
    if isinstance(value, list):
        return [_resolved(v) for v in value]
    if isinstance(value, tuple):
        return tuple(_resolved(v) for v in value)
    return value


def _mentions_example(value: Any) -> bool:
    if isinstance(value, str):
        return value.startswith(PREFIX)
    if isinstance(value, list | tuple):
        return any(_mentions_example(v) for v in value)
    return False


def resolve_example_args(args: argparse.Namespace) -> None:
    """Replace every input value ``example:NAME`` of ``args`` by the shipped file's path.

    Inputs are the parsed values that are not outputs (:func:`~viscoforce.cli._args.add_outputs`)
    nor internal (a name ending in ``_``): a path, a list of paths, HEIGHT=FILE pairs.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments, changed in place.

    Raises
    ------
    UsageError
        An unknown example name, or an output flag given ``example:NAME``.
    """
    outputs = {o.flag.lstrip("-").replace("-", "_"): o for o in getattr(args, "outputs_", ())}
    typed = getattr(args, "typed_", {})
    for key, value in vars(args).items():
        if key.endswith("_") or not _mentions_example(value):
            continue
        if key in outputs:
            flag = typed.get(key, (outputs[key].flag,))[0]
            raise UsageError(f"{flag} {value}: the example files are read, never written; give "
                             "an output file name of your own")
        setattr(args, key, _resolved(value))


# ── the command ───────────────────────────────────────────────────────────────────────────────

def _size(n: int) -> str:
    for unit, factor in (("MB", 1e6), ("kB", 1e3)):
        if n >= factor:
            return f"{n / factor:.3g} {unit}"
    return f"{n} B"


def add_examples(parser: argparse.ArgumentParser) -> None:
    """Flags of ``viscoforce examples``."""
    parser.add_argument("names", metavar="NAME", nargs="*",
                        help="copy only these files (default: all); names as listed")
    add_outputs(parser, [Output("--copy", DIRECTORY, "DIR",
                                "copy the example files (and their README, LICENSE and SOURCE "
                                "notes) into DIR, created if missing")])
    parser.add_argument("--json", action="store_true",
                        help="print one JSON object: examples [{name, description, bytes, path}] "
                             "(and copied, with --copy)")


def _chosen(names: list[str]) -> list[str]:
    """The files to copy for ``names`` (all when empty), with the notes of their folders."""
    every = _names()
    if not names:
        return list(every)
    chosen: list[str] = ["README.md"]  # how each file was made, whichever is copied
    for text in names:
        name = _canonical(text[len(PREFIX):] if text.startswith(PREFIX) else text, text)
        folder = name.rsplit("/", 1)[0] if "/" in name else ""
        chosen += [name, *(f"{folder}/{n}".lstrip("/") for n in _NOTES.get(folder, ()))]
    return [n for n in every if n in chosen]


def _copy(names: list[str], target: Path) -> list[str]:
    """Copy ``names`` into ``target``; same bytes already there are kept, different ones refused."""
    from viscoforce.data import example_path

    clashes = [n for n in names if (target / n).exists()
               and (not (target / n).is_file()
                    or (target / n).read_bytes() != example_path(n).read_bytes())]
    if clashes:
        shown = ", ".join(str(target / n) for n in clashes)
        verb = "exists and differs" if len(clashes) == 1 else "exist and differ"
        raise UsageError(f"--copy {target}: {shown} {verb} from the shipped example; remove it "
                         "or copy into another folder (nothing was copied)")
    copied = []
    for name in names:
        destination = target / name
        if destination.exists():
            continue
        destination.parent.mkdir(parents=True, exist_ok=True)
        write_bytes(destination, example_path(name).read_bytes())  # whole or not at all
        copied.append(name)
    return copied


def run_examples(args: argparse.Namespace) -> int:
    """Run ``viscoforce examples``."""
    from viscoforce.cli._output import print_json
    from viscoforce.data import example_path

    if args.names and args.copy is None:
        raise UsageError("NAME: the names choose the files --copy copies; without --copy every "
                         "example is listed")
    rows = [{"name": n, "description": DESCRIPTIONS.get(n, ""),
             "bytes": example_path(n).stat().st_size, "path": str(example_path(n))}
            for n in _names()]
    copied = None
    if args.copy is not None:
        copied = _copy(_chosen(args.names), Path(args.copy))
    if args.json:
        print_json({"examples": rows, **({} if copied is None else {"copied": copied})})
        return 0
    if copied is None:
        data = _data_names(r["name"] for r in rows)
        width = max(len(n) for n in data)
        print(f"example files shipped with viscoforce ({example_path()}); use them as "
              "example:NAME wherever a command reads a file:")
        for row in rows:
            if row["name"] in data:
                print(f"  {row['name']:<{width}}  {_size(row['bytes']):>8}  {row['description']}")
        print("notes beside them: " + ", ".join(r["name"] for r in rows if r["name"] not in data))
        print("e.g. viscoforce fit example:sls_spectrum.csv --model exact --h0=-5nm; "
              "viscoforce examples --copy DIR [NAME ...] copies them")
        return 0
    print(f"copied {len(copied)} file(s) into {args.copy}"
          + (f" ({', '.join(copied)})" if copied else " (all were there already)"))
    return 0


#: name → (add the flags, run): the rows of :data:`viscoforce.cli.COMMANDS` that point here.
SUBCOMMANDS = {"examples": (add_examples, run_examples)}
