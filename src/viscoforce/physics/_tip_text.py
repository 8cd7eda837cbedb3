"""The text form of a tip: :func:`parse_tip` and :func:`tip_from`.

Both are re-exported by :mod:`viscoforce.physics.tips`, whose docstring describes the grammar.
"""

from __future__ import annotations

import math
import re

from viscoforce._limits import TIP_HALF_ANGLE_RANGE, TIP_RADIUS_RANGE
from viscoforce._validation import describe_value
from viscoforce.exceptions import ParameterError, UnitError
from viscoforce.physics._tip_shapes import _CLASSES, TIP_SHAPES, Tip, _AngledTip
from viscoforce.units import parse_quantity

_FORMS = (f"sphere:R | paraboloid:R | cone:ANGLE | pyramid:ANGLE | flat:RADIUS; R, RADIUS: a "
          f"length with its unit in [{TIP_RADIUS_RANGE[0]:g}, {TIP_RADIUS_RANGE[1]:g}] m, 1 nm to "
          f"1 m (sphere:10um, flat:2.5 µm); ANGLE: the half-angle in degrees in "
          f"[{TIP_HALF_ANGLE_RANGE[0]:g}, {TIP_HALF_ANGLE_RANGE[1]:g}] (cone:20, pyramid:17.5deg, "
          f"cone:35°, cone:0.35rad)")

_NUMBER = r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"
_ANGLE_RE = re.compile(rf"(?P<number>{_NUMBER})\s*(?P<unit>deg|°|rad)?")
_BARE_RE = re.compile(_NUMBER)


def _parse_angle(text: str) -> float:
    """An angle in degrees (bare, ``deg`` or ``°``) or radians (``rad``) → degrees."""
    match = _ANGLE_RE.fullmatch(text.strip())
    if match is None:
        raise ParameterError(f"{text.strip()!r} is not a half-angle (a number in degrees, bare or "
                             "with deg or °, or with rad)")
    value = float(match["number"])
    return math.degrees(value) if match["unit"] == "rad" else value


def _parse_length(text: str, shape: str) -> float:
    """A length with its unit [m]; a bare number is refused (``sphere:5`` is not a 5 m sphere)."""
    number = text.strip()
    if _BARE_RE.fullmatch(number):
        units = ("m",) if 0 < abs(float(number)) < 1e-3 else ("um", "nm")  # 2e-6: meant SI
        write = " or ".join(f"{shape}:{number}{u}" for u in units)
        raise ParameterError(f"{number!r} has no unit: a length needs one (m, cm, mm, um/µm, nm, "
                             f"pm, Å): write {write}")
    return parse_quantity(text, "length")


def parse_tip(text: str) -> Tip:
    """Read a tip from its command-line text, e.g. ``"sphere:10um"`` or ``"pyramid:17.5deg"``.

    Parameters
    ----------
    text : str
        ``sphere:R | paraboloid:R | cone:ANGLE | pyramid:ANGLE | flat:RADIUS``. The shape name is
        case-insensitive; lengths carry their unit and are read by
        :func:`viscoforce.units.parse_quantity` (``10um``, ``2.5 µm``; a bare number is refused),
        half-angles are in degrees unless suffixed ``rad`` (``20``, ``17.5deg``, ``35°``,
        ``0.35rad``). The pyramid's angle is its face semi-angle (:class:`Pyramid`). Radii lie in
        :data:`~viscoforce._limits.TIP_RADIUS_RANGE`, half-angles in
        :data:`~viscoforce._limits.TIP_HALF_ANGLE_RANGE`.

    Returns
    -------
    Tip
        The tip.

    Raises
    ------
    ParameterError
        For anything else (not a string, no ``:``, unknown shape, a size without a unit, bad
        number or unit, value out of range); the message says which part is wrong and lists the
        accepted forms and ranges.
    """
    if not isinstance(text, str):
        raise ParameterError(f"tip must be text of the form {_FORMS}; got {describe_value(text)}")
    shape, sep, value = text.strip().partition(":")
    shape = shape.strip().lower()
    if not sep:
        raise ParameterError(f"tip {text!r} has no ':' between the shape and its size; write "
                             f"SHAPE:SIZE, one of {_FORMS}")
    if shape not in _CLASSES:
        what = f"unknown shape {shape!r}" if shape else "no shape"
        raise ParameterError(f"tip {text!r}: {what} before ':' (the shapes are "
                             f"{', '.join(TIP_SHAPES)}); accepted: {_FORMS}")
    cls = _CLASSES[shape]
    angled = issubclass(cls, _AngledTip)
    part = "half-angle" if angled else "radius"
    if not value.strip():
        raise ParameterError(f"tip {text!r}: no {part} after ':'; accepted: {_FORMS}")
    try:
        if angled:
            return cls.from_degrees(_parse_angle(value))
        return cls(_parse_length(value, shape))
    except (ParameterError, UnitError) as err:
        raise ParameterError(f"tip {text!r}: the {part} after ':' is wrong: {err}; accepted: "
                             f"{_FORMS}") from err


def tip_from(value: Tip | str | None) -> Tip | None:
    """Return a :class:`Tip` from a tip, its text (:func:`parse_tip`) or None (→ None).

    Parameters
    ----------
    value : Tip, str or None
        The tip, or its text such as ``"sphere:10um"``.

    Returns
    -------
    Tip or None
        ``value`` itself if it is a tip; None for None.

    Raises
    ------
    ParameterError
        If ``value`` is none of these, or its text is not a tip.
    """
    if value is None or isinstance(value, Tip):
        return value
    if isinstance(value, str):
        return parse_tip(value)
    raise ParameterError(f"tip must be a Tip, a text such as 'sphere:10um', or None; got "
                         f"{describe_value(value)}")
