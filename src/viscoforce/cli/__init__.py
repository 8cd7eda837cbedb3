"""Command-line interface: ``viscoforce <command> [flags]`` (also ``python -m viscoforce``).

The CLI parses flags (lengths, times, speeds and frequencies with their unit; moduli and pressures
may be bare Pa), calls the public API and prints or writes results; it holds no physics. Any
input file may be written ``example:NAME``, a file shipped inside viscoforce
(:mod:`viscoforce.cli.examples`; ``viscoforce examples`` lists them). Exit status: 0 success,
2 user error (one message on stderr, no traceback; also an output that cannot be written: a full
disk, a file-size limit), 1 internal error, 143 stopped by SIGTERM (partial outputs removed).
``--json`` prints one JSON object in SI units.

Commands are rows of :data:`COMMANDS`: a name, the module of this package that implements it and
a one-line help. A command module holds a ``SUBCOMMANDS`` mapping, name → (function adding the
command's flags to its parser, function running the parsed arguments and returning the exit
status). Only the module of the command being run is imported, so start-up pays for that command
alone; adding a command is one row here and one entry in its module.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import signal
import sys
import threading
import traceback
import warnings
from collections.abc import Iterator, Sequence
from typing import NamedTuple

from viscoforce import __version__
from viscoforce.cli._args import (
    UsageError,
    check_outputs,
    name_flag_in_error,
    name_typed_option,
    normalize_negative_args,
    typed_flags,
    value_options,
)
from viscoforce.cli._examples import epilog
from viscoforce.cli.examples import resolve_example_args
from viscoforce.exceptions import (
    AccuracyWarning,
    DataWarning,
    GoodnessOfFitWarning,
    ModelValidityWarning,
    ViscoforceError,
)

__all__ = ["COMMANDS", "Command", "main"]


class Command(NamedTuple):
    """One row of the command table.

    Attributes
    ----------
    name : str
        The command (``viscoforce <name>``).
    module : str
        The module of :mod:`viscoforce.cli` whose ``SUBCOMMANDS[name]`` implements it.
    help : str
        The one-line help ``viscoforce --help`` shows.
    """

    name: str
    module: str
    help: str


#: The commands, in the order ``viscoforce --help`` lists them.
COMMANDS: tuple[Command, ...] = (
    Command("static", "model", "static elastic equilibrium at one position"),
    Command("simulate", "model", "viscoelastic response along a drive h0(t)"),
    Command("spectrum", "model", "force spectroscopy: stiffness and phase vs omega"),
    Command("load", "analysis", "instrument file to curves or a modulation spectrum"),
    Command("fit", "fitting", "fit a model to a spectrum, a curve or a map of them"),
    Command("bode", "fitting", "Bode plot of a spectrum, with a fitted model"),
    Command("view", "view", "interactive viewer of a fitted map: an HTML page or a server"),
    Command("demo", "demo", "load, demodulate, fit and plot the bundled example data"),
    Command("examples", "examples", "list or copy the example files shipped (example:NAME)"),
)

_DESCRIPTION = ("Viscoelastic particles with finite-ranged surface forces. Lengths, times, speeds "
                "and frequencies take their unit (-5nm, 10um, 0.1ms, 5um/s, 100Hz); moduli and "
                "pressures may be bare Pa (1e9 or 1GPa). Any input file may be a shipped example, "
                "example:NAME (viscoforce examples lists them).")


def _requested(argv: Sequence[str]) -> Command | None:
    """The command named by the first non-option token of ``argv`` (None if there is none)."""
    for token in argv:
        if token == "--" or not token.startswith("-"):
            return next((c for c in COMMANDS if c.name == token), None)
    return None


class _Parser(argparse.ArgumentParser):
    """An argparse parser whose errors name the spelling of an option the user typed."""

    #: The command line as given (set by :func:`main`).
    argv_: Sequence[str] = ()

    def error(self, message: str):  # noqa: D102 - argparse's
        super().error(name_typed_option(message, self.argv_))


def _build_parser(command: Command | None) -> tuple[argparse.ArgumentParser,
                                                    argparse.ArgumentParser | None]:
    """The parser, with the flags of ``command`` only (the other commands are names and help)."""
    parser = _Parser(prog="viscoforce", description=_DESCRIPTION)
    parser.add_argument("--version", action="version", version=f"viscoforce {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="command", required=True)
    selected = None
    for c in COMMANDS:
        p = sub.add_parser(c.name, help=c.help, description=c.help, epilog=epilog(c.name),
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        if c is command:
            module = importlib.import_module(f"{__name__}.{c.module}")
            add_arguments, run = module.SUBCOMMANDS[c.name]
            add_arguments(p)
            p.set_defaults(run_=run)
            selected = p
    return parser, selected


def _output_flag(args: argparse.Namespace, filename: object) -> str | None:
    """The output flag (as typed) whose value is ``filename``, if one is."""
    for o in getattr(args, "outputs_", ()):
        dest = o.flag.lstrip("-").replace("-", "_")
        if filename is not None and getattr(args, dest, None) == filename:
            return getattr(args, "typed_", {}).get(dest, (o.flag,))[0]
    return None


def _message(exc: BaseException, args: argparse.Namespace | None = None) -> str:
    """One line: the error's text with any line breaks (e.g. a parser's) folded.

    An output that could not be written (an :class:`OSError` naming the value of an output flag,
    as :mod:`viscoforce._files` raises it) is told with its flag.
    """
    if isinstance(exc, OSError) and exc.strerror and exc.filename is not None:
        flag = _output_flag(args, exc.filename) if args is not None else None
        if flag is not None:
            return (f"{flag} {exc.filename}: could not write ({exc.strerror}); any previous file "
                    "there is unchanged")
        return f"{exc.strerror}: {exc.filename}"
    return "; ".join(line.strip() for line in str(exc).splitlines() if line.strip())


def _run(args: argparse.Namespace) -> int:
    name = args.command

    def show(message, category, filename, lineno, file=None, line=None):  # noqa: ARG001
        print(f"viscoforce {name}: warning: {message}", file=sys.stderr)

    try:
        with warnings.catch_warnings():
            for shown in (ModelValidityWarning, AccuracyWarning, GoodnessOfFitWarning,
                          DataWarning):  # once per result, not raised
                warnings.simplefilter("always", shown)
            warnings.showwarning = show
            resolve_example_args(args)  # example:NAME inputs → the shipped files
            check_outputs(args)
            return int(args.run_(args))
    except (ViscoforceError, OSError) as exc:
        text = _message(exc, args)
        if isinstance(exc, ViscoforceError) and not isinstance(exc, UsageError):
            text = name_flag_in_error(text, getattr(args, "typed_", {}))
        print(f"viscoforce {name}: error: {text}", file=sys.stderr)
        return 2
    except Exception as exc:  # a bug: say so, with the traceback for the report
        print(f"viscoforce {name}: internal error ({type(exc).__name__}: {exc}); please report "
              "it with the traceback below", file=sys.stderr)
        traceback.print_exc()
        return 1


class _Terminated(SystemExit):
    """SIGTERM during :func:`main`: unwinds like an error (partial outputs are removed)."""


@contextlib.contextmanager
def _sigterm_raises() -> Iterator[None]:
    """SIGTERM raises :class:`_Terminated` inside the block, if it would kill the process.

    Only SIGTERM's default action (end the process at once, leaving a half-written temporary
    file) is replaced: a handler someone installed, or SIGTERM ignored, stays. The previous
    setting is restored on leaving. Signal handlers can be set in the main thread only.
    """
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL):
        yield
        return

    def terminate(signum: int, frame: object) -> None:  # noqa: ARG001 - a signal handler's
        raise _Terminated(128 + signum)

    previous = signal.signal(signal.SIGTERM, terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments without the program name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 success (also ``--help`` and ``--version``), 2 user error (a bad flag or value, a file
        that cannot be read or written, any :class:`~viscoforce.exceptions.ViscoforceError`:
        one message on stderr, no traceback), 1 internal error (message and traceback), 143
        SIGTERM while the command ran (one message; the temporary file of an output being
        written is removed, as on an error; :func:`_sigterm_raises`).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    parser, selected = _build_parser(_requested(argv))
    for p in (parser, selected):
        if p is not None:
            p.argv_ = argv
    single, multi = value_options(parser, *([selected] if selected is not None else []))
    try:
        args, extra = parser.parse_known_args(normalize_negative_args(argv, single, multi))
        if extra:  # reported by the command's own parser, so the message names the command
            (selected or parser).error(f"unrecognized arguments: {' '.join(extra)}")
    except SystemExit as exc:  # argparse printed the help, the version or its error message
        return 0 if exc.code is None else exc.code if isinstance(exc.code, int) else 2
    args.typed_ = typed_flags(selected, argv) if selected is not None else {}
    try:
        with _sigterm_raises():
            return _run(args)
    except _Terminated as exc:
        print(f"viscoforce {args.command}: stopped by SIGTERM", file=sys.stderr)
        return int(exc.code)
