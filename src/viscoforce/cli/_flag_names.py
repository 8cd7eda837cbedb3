"""The flag the user typed, for error messages.

:func:`typed_flags` records which spelling of each option was typed and its value;
:func:`name_typed_option` reduces argparse's ``--radius/--R`` to that spelling, and
:func:`name_flag_in_error` tells a library error about a parameter (:data:`PARAMETER_FLAGS`) in
terms of that flag. All names are re-exported by :mod:`viscoforce.cli._args`.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Sequence

__all__ = ["PARAMETER_FLAGS", "name_flag_in_error", "name_typed_option", "typed_flags"]


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
    ``--radius 0um`` becomes ``--radius 0um: radius (R) must be > 0``. A message whose leading name
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
