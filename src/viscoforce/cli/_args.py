"""Argument helpers of the command line: quantity types, negative values, flag tables, outputs.

* ``type=`` callables: :func:`quantity_type` (a quantity with an optional unit suffix, read into SI
  by :func:`viscoforce.units.parse_quantity`), :func:`integer_type` (a plain integer in a range)
  and :func:`real_type` (a finite plain number in a range). Bad input raises
  :class:`argparse.ArgumentTypeError`, so argparse prints ``argument --h0: <message>`` and exits
  with status 2.
* :func:`normalize_negative_args` lets ``--h0 -5nm`` through (argparse alone takes ``-5nm`` for an
  option); :func:`value_options` lists the options of a parser it applies to.
* Flag tables are data: a :class:`FlagGroup` is a title and a tuple of :class:`Flag` rows
  (flag, dimension, default, metavar, help); :func:`add_flags` adds one to a parser. The system,
  material and numerics tables shared by every physics command are :data:`SYSTEM_FLAGS`,
  :data:`MATERIAL_FLAGS` and :data:`NUMERICS_FLAGS` (defaults from
  :data:`viscoforce.physics.paper.PAPER`).
* Output files are declared with :func:`add_outputs` (:class:`Output` rows: a netCDF file, a
  figure, a directory) and checked by :func:`check_outputs` before anything is computed.
"""

from __future__ import annotations

import argparse
import math
import os
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

from viscoforce import _limits
from viscoforce._files import same_file
from viscoforce.exceptions import EffortError, ParameterError, UnitError, ViscoforceError
from viscoforce.physics.paper import PAPER
from viscoforce.units import accepted_units, format_quantity, parse_quantity

__all__ = [
    "DIRECTORY",
    "FIGURE",
    "MATERIAL_FLAGS",
    "NETCDF",
    "NETCDF_OR_CSV",
    "NUMERICS_FLAGS",
    "PARAMETER_FLAGS",
    "SYSTEM_FLAGS",
    "Flag",
    "FlagGroup",
    "OmegaList",
    "OmegaRange",
    "Output",
    "UsageError",
    "add_flags",
    "add_outputs",
    "check_output_paths",
    "check_outputs",
    "figure_formats",
    "format_names",
    "frequency_type",
    "integer_type",
    "name_flag_in_error",
    "name_typed_option",
    "normalize_negative_args",
    "quantity_type",
    "real_type",
    "typed_flags",
    "unitless_frequency_message",
    "value_options",
]


class UsageError(ViscoforceError, ValueError):
    """A command-line combination that cannot be run (exit status 2)."""


# ── type= callables ──────────────────────────────────────────────────────────────────────────────

class _QuantityType:
    """argparse ``type=`` callable returned by :func:`quantity_type`."""

    def __init__(self, dimension: str) -> None:
        accepted_units(dimension)  # ParameterError for an unknown dimension, at once
        self.dimension = dimension
        self.__name__ = dimension.replace("_", " ")

    def __call__(self, text: str) -> float:
        try:
            return parse_quantity(text, self.dimension)
        except (UnitError, ParameterError) as exc:
            raise argparse.ArgumentTypeError(str(exc)) from exc

    def __repr__(self) -> str:
        return f"quantity_type({self.dimension!r})"


def quantity_type(dimension: str) -> Callable[[str], float]:
    """Make an argparse ``type=`` callable that reads a quantity of ``dimension`` into SI.

    Parameters
    ----------
    dimension : str
        One of :data:`viscoforce.units.DIMENSIONS`.

    Returns
    -------
    callable
        ``f(text) -> float`` (SI). On bad input it raises :class:`argparse.ArgumentTypeError`
        carrying the :class:`~viscoforce.exceptions.UnitError` message, so argparse prints
        ``argument --h0: <message>`` and exits with status 2. Its ``__name__`` is the dimension
        (``"angular frequency"``) and its repr ``quantity_type('length')``.

    Raises
    ------
    ParameterError
        If ``dimension`` is unknown (raised at once, not at parse time).

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser()
    >>> _ = parser.add_argument("--h0", type=quantity_type("length"))
    >>> parser.parse_args(normalize_negative_args(["--h0", "-5nm"], {"--h0"})).h0
    -5e-09
    """
    return _QuantityType(dimension)


class _FrequencyType(_QuantityType):
    """argparse ``type=`` callable returned by :func:`frequency_type`."""

    def __call__(self, text: str) -> float:
        stripped = text.strip()
        try:
            bare = float(stripped)
        except ValueError:
            bare = None
        if bare is not None and math.isfinite(bare):
            raise argparse.ArgumentTypeError(unitless_frequency_message(stripped, bare))
        other = "angular_frequency" if self.dimension == "frequency" else "frequency"
        try:
            return parse_quantity(text, self.dimension)
        except UnitError as exc:  # rad/s for a frequency: accepted, converted
            try:
                value = parse_quantity(text, other)
            except (UnitError, ParameterError):
                raise argparse.ArgumentTypeError(str(exc)) from exc
            return value / (2 * math.pi) if self.dimension == "frequency" else value
        except ParameterError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from exc

    def __repr__(self) -> str:
        return f"frequency_type({self.dimension!r})"


def unitless_frequency_message(text: str, value: float) -> str:
    """Why a frequency without a unit is refused: its two readings, spelled out.

    Parameters
    ----------
    text : str
        The number as typed (``"100"``).
    value : float
        Its value.

    Returns
    -------
    str
        ``"100 has no unit: write 100Hz (f = 100 Hz, ω = 628 rad/s) or 100rad/s (ω = 100 rad/s,
        f = 15.9 Hz)"``.
    """
    two_pi = 2 * math.pi

    def f(x: float) -> str:
        return format_quantity(x, "frequency")

    def w(x: float) -> str:
        return format_quantity(x, "angular_frequency")

    return (f"{text} has no unit: write {text}Hz (f = {f(value)}, ω = {w(two_pi * value)}) "
            f"or {text}rad/s (ω = {w(value)}, f = {f(value / two_pi)})")


def frequency_type(dimension: str = "angular_frequency") -> Callable[[str], float]:
    """Make an argparse ``type=`` callable for a frequency flag: a unit is required.

    A bare number is ambiguous (Hz or rad/s, a factor 2π apart) and refused with both readings
    spelled out (:func:`unitless_frequency_message`); ``100Hz``, ``1kHz``, ``628rad/s`` are read
    whatever the flag's own dimension (Hz ↔ rad/s converted).

    Parameters
    ----------
    dimension : str
        ``"angular_frequency"`` (the value in rad/s) or ``"frequency"`` (the value in Hz).

    Returns
    -------
    callable
        ``f(text) -> float`` (rad/s or Hz); bad input raises
        :class:`argparse.ArgumentTypeError`.

    Examples
    --------
    >>> frequency_type()("100rad/s")
    100.0
    >>> round(frequency_type("frequency")("628.3185307179587rad/s"), 9)
    100.0
    """
    if dimension not in ("angular_frequency", "frequency"):
        raise ParameterError(f"dimension must be 'angular_frequency' or 'frequency', got "
                             f"{dimension!r}")
    return _FrequencyType(dimension)


_INTEGER_RE = re.compile(r"[+-]?[0-9]+")


def _range_text(minimum: float, maximum: float | None) -> str:
    return f">= {minimum:g}" if maximum is None else f"in [{minimum:g}, {maximum:g}]"


class _IntegerType:
    """argparse ``type=`` callable returned by :func:`integer_type`."""

    def __init__(self, minimum: int, maximum: int | None, what: str) -> None:
        self.minimum, self.maximum, self.what = minimum, maximum, what
        self.__name__ = "integer"

    def __call__(self, text: str) -> int:
        stripped = text.strip()
        if _INTEGER_RE.fullmatch(stripped) is None:
            raise argparse.ArgumentTypeError(
                f"expected a plain integer >= {self.minimum} (no unit, no decimal point), "
                f"got {text!r}")
        value = int(stripped)
        if value < self.minimum:
            raise argparse.ArgumentTypeError(
                f"must be an integer >= {self.minimum}, got {value}")
        if self.maximum is not None:
            try:
                _limits.check_effort(self.what, value, self.maximum, hint="ask for fewer")
            except EffortError as exc:
                raise argparse.ArgumentTypeError(str(exc)) from exc
        return value

    def __repr__(self) -> str:
        return f"integer_type({self.minimum!r}, {self.maximum!r})"


def integer_type(minimum: int, maximum: int | None = None, *,
                 what: str = "requested count") -> Callable[[str], int]:
    """Make an argparse ``type=`` callable that reads a plain integer ``>= minimum``.

    Parameters
    ----------
    minimum : int
        Smallest accepted value.
    maximum : int, optional
        Largest accepted value, an effort limit (:mod:`viscoforce._limits`): a larger value is
        refused with the :class:`~viscoforce.exceptions.EffortError` message (estimate and
        limit).
    what : str
        What the integer counts, for that message (``"output samples"``).

    Returns
    -------
    callable
        ``f(text) -> int``; ``"2.5"``, ``"1Hz"``, ``"1e3"`` and out-of-range values raise
        :class:`argparse.ArgumentTypeError`.
    """
    return _IntegerType(int(minimum), None if maximum is None else int(maximum), what)


class _RealType:
    """argparse ``type=`` callable returned by :func:`real_type`."""

    def __init__(self, minimum: float) -> None:
        self.minimum = minimum
        self.__name__ = "number"

    def __call__(self, text: str) -> float:
        try:
            value = parse_quantity(text, "dimensionless")
        except (UnitError, ParameterError) as exc:
            raise argparse.ArgumentTypeError(str(exc)) from exc
        if not value >= self.minimum:
            raise argparse.ArgumentTypeError(f"must be >= {self.minimum:g}, got {text.strip()!r}")
        return value

    def __repr__(self) -> str:
        return f"real_type({self.minimum!r})"


def real_type(minimum: float) -> Callable[[str], float]:
    """Make an argparse ``type=`` callable that reads a finite number ``>= minimum``.

    Parameters
    ----------
    minimum : float
        Smallest accepted value.

    Returns
    -------
    callable
        ``f(text) -> float``; ``nan``, ``inf``, units and values below ``minimum`` raise
        :class:`argparse.ArgumentTypeError`.
    """
    return _RealType(float(minimum))


# ── frequency lists ──────────────────────────────────────────────────────────────────────────────

def _check_count(action: argparse.Action, n: int) -> None:
    try:
        _limits.check_effort("frequencies", n, _limits.MAX_SAMPLES, hint="ask for fewer")
    except EffortError as exc:
        raise argparse.ArgumentError(action, str(exc)) from exc


class OmegaList(argparse.Action):
    """``--omega W [W ...]``: angular frequencies (quantities), at most ``MAX_SAMPLES`` of them."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        _check_count(self, len(values))
        setattr(namespace, self.dest, list(values))


class OmegaRange(argparse.Action):
    """``--omega-range LO HI N``: frequencies 0 < LO < HI (with units) and an integer 1 <= N <= MAX_SAMPLES.

    Stores the tuple ``(lo, hi, n)`` [rad/s, rad/s, 1]; the count is checked before any array is
    built.
    """

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        lo_text, hi_text, n_text = values
        omega = frequency_type("angular_frequency")
        try:
            lo, hi = omega(lo_text), omega(hi_text)
            n = integer_type(1)(n_text)
        except argparse.ArgumentTypeError as exc:
            raise argparse.ArgumentError(self, str(exc)) from exc
        if not 0 < lo < hi:
            raise argparse.ArgumentError(
                self, f"needs 0 < LO < HI, got LO = {lo:g} rad/s, HI = {hi:g} rad/s")
        _check_count(self, n)
        setattr(namespace, self.dest, (lo, hi, n))


# ── negative values ──────────────────────────────────────────────────────────────────────────────

_NEGATIVE_VALUE_RE = re.compile(r"-[0-9.]")


def _looks_negative(token: str) -> bool:
    return _NEGATIVE_VALUE_RE.match(token) is not None


def normalize_negative_args(argv: Iterable[str], value_options: Iterable[str],
                            multi_value_options: Iterable[str] = ()) -> list[str]:
    """Rewrite ``argv`` so that argparse accepts negative quantities such as ``-5nm``.

    argparse takes any token that starts with ``-`` and is not a plain negative number
    (``-5``, ``-.5``) for an option, so ``--h0 -5nm`` fails with "expected one argument".
    A token "looks negative" here when it starts with ``-`` followed by a digit or ``.``
    (``-5nm``, ``-.5nm``, ``-1e-9``, ``-3``).

    * For an option in ``value_options`` (one value) followed by such a token, the pair is
      joined: ``["--h0", "-5nm"]`` → ``["--h0=-5nm"]`` (a one-dash option ``-x`` becomes
      ``-x-5nm``). ``--h0=-5nm`` is left alone.
    * For an option in ``multi_value_options`` (``nargs="+"``/``"*"``/N), every following token
      up to the next option is a value; each that looks negative gets a leading space
      (``["--omega", "1", "-2kHz"]`` → ``["--omega", "1", " -2kHz"]``). argparse treats a token
      that does not start with ``-`` as a value, and :func:`~viscoforce.units.parse_quantity`
      strips the space. (``--omega=-2`` cannot work for ``nargs="+"``: it gives that single
      value.)

    Everything after a bare ``--`` is left untouched. Option names are matched exactly: give the
    full names (argparse's prefix abbreviations such as ``--ome`` are not recognised here).
    The scheme assumes that no option of the parser itself looks like a negative number.

    Parameters
    ----------
    argv : iterable of str
        Command-line tokens without the program name (``sys.argv[1:]``).
    value_options : iterable of str
        Option strings that take exactly one value (``{"--h0", "--from", "--to"}``).
    multi_value_options : iterable of str, optional
        Option strings that take one or more values (``{"--omega"}``).

    Returns
    -------
    list of str
        A new token list; ``argv`` is not modified.
    """
    single = set(value_options)
    multi = set(multi_value_options)
    tokens = list(argv)
    out: list[str] = []
    i = 0
    while i < len(tokens):
        token = tokens[i]
        if token == "--":
            out.extend(tokens[i:])
            break
        out.append(token)
        i += 1
        if token in multi:
            while i < len(tokens) and (not tokens[i].startswith("-") or _looks_negative(tokens[i])):
                out.append(" " + tokens[i] if _looks_negative(tokens[i]) else tokens[i])
                i += 1
        elif token in single and i < len(tokens) and _looks_negative(tokens[i]):
            joiner = "=" if token.startswith("--") else ""
            out[-1] = f"{token}{joiner}{tokens[i]}"
            i += 1
    return out


def value_options(*parsers: argparse.ArgumentParser) -> tuple[set[str], set[str]]:
    """The option strings of ``parsers`` that take one value, and those that take several.

    Parameters
    ----------
    *parsers : argparse.ArgumentParser
        The parsers whose options :func:`normalize_negative_args` should know.

    Returns
    -------
    tuple of set of str
        ``(single, multi)``: the options with ``nargs=None`` (one value), and those with
        ``nargs`` ``"+"``, ``"*"`` or an integer > 1.
    """
    single: set[str] = set()
    multi: set[str] = set()
    for parser in parsers:
        for action in parser._actions:  # argparse has no public accessor
            nargs = action.nargs
            target = (single if nargs is None else
                      multi if nargs in ("+", "*") or (isinstance(nargs, int) and nargs > 1)
                      else None)
            if target is not None:
                target.update(o for o in action.option_strings if o.startswith("-"))
    return single, multi


# ── flag tables ──────────────────────────────────────────────────────────────────────────────────

class Flag(NamedTuple):
    """One command-line flag, as data.

    Attributes
    ----------
    flag : str
        The option string (``"--debye-length"``).
    dimension : str, callable or None
        A dimension of :mod:`viscoforce.units` (the value is a quantity read into SI), a ``type=``
        callable, or None (the value is kept as text, e.g. a file name).
    default : object
        The default (SI for a quantity); None when the flag is optional without one.
    metavar : str
        The value's name in the help (``"LENGTH"``).
    help : str
        One-line help.
    required : bool
        Whether the flag must be given.
    dest : str or None
        Attribute name in the namespace (default: argparse's, ``debye_length``).
    aliases : tuple of str
        Other spellings that keep working (``("--R",)`` beside ``--radius``: the SPEC's CLI
        contract names are never removed).
    """

    flag: str
    dimension: str | Callable[[str], Any] | None
    default: Any
    metavar: str
    help: str
    required: bool = False
    dest: str | None = None
    aliases: tuple[str, ...] = ()


@dataclass(frozen=True)
class FlagGroup:
    """A titled table of flags (an argparse argument group); ``title=None`` adds them ungrouped."""

    title: str | None
    flags: tuple[Flag, ...]


class _LibraryType:
    """A ``type=`` callable of the library (``parse_tip``) whose errors argparse prints as is.

    argparse turns a ValueError from ``type=`` into "invalid <name> value: '...'", dropping the
    message; a :class:`~viscoforce.exceptions.ViscoforceError` (which names the parameter, the
    wrong part and the range) becomes an :class:`argparse.ArgumentTypeError` with its text.
    """

    def __init__(self, function: Callable[[str], Any]) -> None:
        self.function = function
        self.__name__ = getattr(function, "__name__", "value")

    def __call__(self, text: str) -> Any:
        try:
            return self.function(text)
        except ViscoforceError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from exc

    def __repr__(self) -> str:
        return repr(self.function)


def _type(dimension: str | Callable[[str], Any] | None) -> Callable[[str], Any] | None:
    if dimension is None:
        return None
    if callable(dimension):
        return dimension if isinstance(dimension, _QuantityType) else _LibraryType(dimension)
    return quantity_type(dimension)


def add_flags(parser: argparse.ArgumentParser, group: FlagGroup) -> None:
    """Add the flags of ``group`` to ``parser`` (as an argument group when it has a title).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The (sub)command parser.
    group : FlagGroup
        The table to add.
    """
    target = parser if group.title is None else parser.add_argument_group(group.title)
    for f in group.flags:
        extra = {} if f.dest is None else {"dest": f.dest}
        target.add_argument(f.flag, *f.aliases, type=_type(f.dimension), default=f.default,
                            metavar=f.metavar, help=f.help, required=f.required, **extra)


def _paper(value: float, dimension: str) -> str:
    return format_quantity(value, dimension, ascii_only=True).replace(" ", "")


#: System flags of every physics command (defaults: the paper's values, :data:`PAPER`).
SYSTEM_FLAGS = FlagGroup("system (defaults: the paper's values)", (
    Flag("--radius", "length", PAPER.R, "LENGTH",
         f"sphere radius R (default {_paper(PAPER.R, 'length')})", dest="R", aliases=("--R",)),
    Flag("--pressure", "pressure", PAPER.P, "PRESSURE",
         f"double-layer pressure scale P (default {_paper(PAPER.P, 'pressure')})", dest="P",
         aliases=("--P",)),
    Flag("--wall-pressure", "pressure", PAPER.Pw, "PRESSURE",
         f"soft-wall pressure Pw (default {_paper(PAPER.Pw, 'pressure')})", dest="Pw",
         aliases=("--Pw",)),
    Flag("--z0", "length", PAPER.z0, "LENGTH",
         f"soft-wall length z0 (default {_paper(PAPER.z0, 'length')})"),
    Flag("--debye-length", "length", PAPER.debye_length, "LENGTH",
         f"Debye length 1/kappa (default {_paper(PAPER.debye_length, 'length')})"),
))

#: Material flags: ``--E`` (elastic), or the standard linear solid, or an n-mode Prony file.
MATERIAL_FLAGS = FlagGroup(
    f"material (default: the paper's E0={_paper(PAPER.E0, 'pressure')}, "
    f"E_inf={_paper(PAPER.E_inf, 'pressure')}, tau={_paper(PAPER.tau, 'time')})", (
        Flag("--modulus", "pressure", None, "PRESSURE",
             "purely elastic modulus E (paper convention 2/E = sum (1-nu^2)/E_i)", dest="E",
             aliases=("--E",)),
        Flag("--E0", "pressure", None, "PRESSURE",
             "instantaneous modulus of the standard linear solid"),
        Flag("--E-inf", "pressure", None, "PRESSURE",
             "relaxed modulus of the standard linear solid"),
        Flag("--tau", "time", None, "TIME",
             "creep time tau of Eq. 3 (decay time of C(t), not the stress-relaxation time)"),
        Flag("--prony", None, None, "FILE.csv",
             "n-mode Prony series: CSV 'modulus (Pa),tau (s)', rows E_0..E_inf, last tau empty"),
    ))

#: Grid flags (defaults: chosen by :meth:`~viscoforce.problem.ContactProblem.create`).
NUMERICS_FLAGS = FlagGroup("numerics", (
    Flag("--grid-spacing", "length", None, "LENGTH",
         "mean radial node spacing (default from sqrt(2R/kappa))"),
    Flag("--outer-radius", "length", None, "LENGTH",
         "outer radius of the grid (default: where the force is negligible)"),
))


# ── output files ─────────────────────────────────────────────────────────────────────────────────

#: Output kinds of :class:`Output`.
NETCDF, FIGURE, DIRECTORY = "netcdf", "figure", "directory"
#: An output that is a netCDF file (.nc) or a CSV table (.csv), by its extension.
NETCDF_OR_CSV = "netcdf-or-csv"

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


# ── the flag the user typed ──────────────────────────────────────────────────────────────────────

#: Library parameter names that are not the name of the flag that sets them: name → (the dests
#: that may have set it, in order of preference; the words shown instead of the name).
PARAMETER_FLAGS: dict[str, tuple[tuple[str, ...], str]] = {
    "deepest_position": (("h0", "to", "from_"), "the deepest position"),
    "position": (("h0",), "the position"),
    "radius": (("R",), "the radius"),
    "rise_time": (("duration",), "the rise time"),
    "n_jobs": (("jobs",), "the number of workers"),
    "reference_frequency": (("reference_frequency",), "the reference frequency"),
    "load": (("mean_force",), "the mean force"),
}

_ALTERNATIVES_RE = re.compile(r"argument ((?:--?[\w-]+/)+--?[\w-]+)")
_LEADING_NAME_RE = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)(?=[ \[(:]|$)")


def typed_flags(parser: argparse.ArgumentParser, argv: Sequence[str]
                ) -> dict[str, tuple[str, str | None]]:
    """Which spelling of each option the user typed, and its value as typed.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The command's parser (its actions give the option strings and dests).
    argv : sequence of str
        The tokens as given (before :func:`normalize_negative_args`).

    Returns
    -------
    dict
        dest → (option string as typed, value text or None for a flag without one value); the
        last occurrence wins, as in argparse.
    """
    by_option = {o: a for a in parser._actions for o in a.option_strings}
    tokens = list(argv)
    out: dict[str, tuple[str, str | None]] = {}
    for i, token in enumerate(tokens):
        if token == "--":
            break
        name, eq, value = token.partition("=")
        action = by_option.get(name)
        if action is None:
            continue
        if not eq:
            value = tokens[i + 1] if action.nargs is None and i + 1 < len(tokens) else None
        out[action.dest] = (name, value if action.nargs is None else None)
    return out


def name_typed_option(message: str, argv: Sequence[str]) -> str:
    """Rewrite argparse's ``argument --radius/--R: ...`` as ``argument --R: ...`` if ``--R`` was typed.

    Parameters
    ----------
    message : str
        An argparse error message.
    argv : sequence of str
        The tokens as given.

    Returns
    -------
    str
        The message with each ``A/B`` option list reduced to the spelling found in ``argv``
        (unchanged where none of them is).
    """
    typed = {t.partition("=")[0] for t in argv}

    def pick(match: re.Match[str]) -> str:
        options = match[1].split("/")
        chosen = next((o for o in options if o in typed), None)
        return f"argument {chosen}" if chosen else match[0]

    return _ALTERNATIVES_RE.sub(pick, message)


def name_flag_in_error(message: str, typed: dict[str, tuple[str, str | None]]) -> str:
    """A library error about a parameter, told in terms of the flag the user typed.

    ``deepest_position must be >= -0.1 R ..., got -0.005`` after ``--h0 -5mm`` becomes
    ``--h0 -5mm: the deepest position must be >= ...``; ``radius (R) must be > 0`` after
    ``--radius 0`` becomes ``--radius 0: radius (R) must be > 0``. A message whose leading name
    no typed flag sets is returned unchanged.

    Parameters
    ----------
    message : str
        The error text.
    typed : dict
        :func:`typed_flags` of the command line.

    Returns
    -------
    str
        The message, prefixed with ``FLAG VALUE:`` when a typed flag set the parameter named.
    """
    match = _LEADING_NAME_RE.match(message)
    if match is None:
        return message
    name = match[1]
    dests, words = PARAMETER_FLAGS.get(name, ((name,), None))
    dest = next((d for d in dests if d in typed), None)
    if dest is None:
        return message
    option, value = typed[dest]
    if words is not None:
        message = words + message[match.end():]
    return f"{option}{'' if value is None else ' ' + value}: {message}"
