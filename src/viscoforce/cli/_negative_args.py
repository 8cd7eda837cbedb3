"""Negative values on the command line: ``--h0 -5nm``.

:func:`normalize_negative_args` lets ``--h0 -5nm`` through (argparse alone takes ``-5nm`` for an
option); :func:`value_options` lists the options of a parser it applies to. Both are re-exported
by :mod:`viscoforce.cli._args`.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Iterable

__all__ = ["normalize_negative_args", "value_options"]


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
