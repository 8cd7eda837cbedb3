"""Argument helpers of the command line: quantity types, negative values, flag tables, outputs.

* ``type=`` callables: :func:`quantity_type` (a quantity with a unit suffix, read into SI by
  :func:`viscoforce.units.parse_quantity`; lengths, times, speeds and frequencies need their unit,
  :data:`viscoforce.units.UNIT_REQUIRED`: ``--h0 2`` is refused, not read as 2 m; moduli and
  pressures may be bare Pa), :func:`integer_type` (a plain integer in a range)
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
* Error messages name the flag the user typed: :func:`typed_flags`, :func:`name_typed_option`,
  :func:`name_flag_in_error`.

This module is the CLI's single import point for its argument grammar. The negative values live
in :mod:`viscoforce.cli._negative_args`, the output files in :mod:`viscoforce.cli._outputs_check`,
the typed-flag naming in :mod:`viscoforce.cli._flag_names` and :class:`UsageError` in
:mod:`viscoforce.cli._usage`; they are re-exported here.
"""

from __future__ import annotations

import argparse
import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, NamedTuple

from viscoforce import _limits
from viscoforce.cli._flag_names import (
    PARAMETER_FLAGS,
    name_flag_in_error,
    name_typed_option,
    typed_flags,
)
from viscoforce.cli._negative_args import normalize_negative_args, value_options
from viscoforce.cli._outputs_check import (
    CSV,
    DIRECTORY,
    FIGURE,
    NETCDF,
    NETCDF_OR_CSV,
    Output,
    add_outputs,
    check_output_paths,
    check_outputs,
    figure_formats,
    format_names,
)
from viscoforce.cli._usage import UsageError
from viscoforce.exceptions import EffortError, ParameterError, UnitError, ViscoforceError
from viscoforce.physics.paper import PAPER
from viscoforce.units import (
    UNIT_REQUIRED,
    accepted_units,
    format_quantity,
    missing_unit_message,
    parse_quantity,
)

__all__ = [
    "DIRECTORY",
    "FIGURE",
    "MATERIAL_FLAGS",
    "NETCDF",
    "CSV",
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


# ── type= callables ──────────────────────────────────────────────────────────────────────────────

class _QuantityType:
    """argparse ``type=`` callable returned by :func:`quantity_type`."""

    def __init__(self, dimension: str) -> None:
        accepted_units(dimension)  # ParameterError for an unknown dimension, at once
        self.dimension = dimension
        self.__name__ = dimension.replace("_", " ")

    def __call__(self, text: str) -> float:
        try:
            return parse_quantity(text, self.dimension,
                                  require_unit=self.dimension in UNIT_REQUIRED)
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
        ``f(text) -> float`` (SI). A dimension of :data:`viscoforce.units.UNIT_REQUIRED`
        (length, time, speed, frequency) needs its unit: ``"2"`` is refused with
        :func:`viscoforce.units.missing_unit_message` (``2 has no unit: write 2nm, 2um or 2m
        ...``), ``"0"`` too, as for a frequency. On bad input it raises
        :class:`argparse.ArgumentTypeError` carrying the
        :class:`~viscoforce.exceptions.UnitError` message, so argparse prints
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
        other = "angular_frequency" if self.dimension == "frequency" else "frequency"
        try:
            return parse_quantity(text, self.dimension, require_unit=True)
        except UnitError as exc:  # rad/s for a frequency: accepted, converted
            try:
                value = parse_quantity(text, other, require_unit=True)
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
        Its value (the message is :func:`viscoforce.units.missing_unit_message`, which reads it
        from ``text``).

    Returns
    -------
    str
        ``"100 has no unit: write 100Hz (f = 100 Hz, ω = 628 rad/s) or 100rad/s (ω = 100 rad/s,
        f = 15.9 Hz)"``.
    """
    return missing_unit_message(text, "frequency")


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


def choice_type(*choices: str, what: str):
    """A text flag that must be one of ``choices`` (the message lists them)."""

    def parse(text: str) -> str:
        value = text.strip().lower()
        if value not in choices:
            raise argparse.ArgumentTypeError(f"{what} must be one of {', '.join(choices)}, got "
                                             f"{text!r}")
        return value

    return parse
