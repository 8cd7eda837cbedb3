"""Units, signs and conventions of viscoforce: the rulebook.

Every module follows the rules below; a docstring that says otherwise is a bug.

Units
-----
* **SI inside, always.** Every float that crosses a function boundary inside viscoforce is in SI:
  lengths [m], times [s], pressures and moduli [Pa], forces [N], stiffnesses [N/m],
  speeds [m/s]. Angular frequency ω is in [rad/s] everywhere inside; cyclic frequency
  f = ω / 2π [Hz] appears only at the edges.
* **Conversions happen only at the edges**: this module (command-line quantities such as
  ``-5nm``, ``1ms``, ``1e9Pa``, ``5um/s``, ``1kHz``), the instrument loaders (``io``) on the way
  in, and plotting / human-readable messages (:func:`format_quantity`) on the way out.
* Datasets carry their units in ``attrs["units"]`` as CF/UDUNITS strings (``"m"``, ``"N"``,
  ``"N/m"``, ``"rad/s"``, ``"degree"``, ``"1"``).
* Angles: the reported phase χ is in degrees (Spectrum variable ``phase``, CLI key
  ``phase_deg``); angles inside complex arithmetic (``numpy.angle``) are radians and are
  converted only where they are reported.

Geometry and signs
------------------
* **Position** ``h0`` [m]: the undeformed separation of the two apexes (sphere of radius R against
  a flat; two spheres combine as 1/R = 1/R1 + 1/R2). It may be negative: the undeformed bodies
  would overlap, the deformed ones do not. The undeformed gap profile is
  h0(r) = h0 + r²/2R.
* **Deformation** ``u(r)`` [m]: ``u < 0`` means flattening (the surfaces retreat from each other
  under repulsion).
* **Gap** (separation) ``h(r) = h0 + r²/2R − u(r)`` [m] is always > 0. A gap driven through zero
  is an error (:class:`~viscoforce.exceptions.GapClosureError`), never a silently wrong curve.
* **Pressure** ``p(h)`` [Pa] and **force** (load) ``F = 2π ∫ p(h(r)) r dr`` [N] are > 0 for
  repulsion. Loading (compression) means decreasing ``h0``: the force rises and ``u`` becomes more
  negative.
* **Stiffness** ``|F1|/η`` [N/m] is a magnitude (≥ 0).

Material
--------
* ``tau`` (τ) [s] is the decay time of the CREEP compliance of the standard linear solid
  (the paper's Eq. 3), C(t) = 1/E_inf + (1/E0 − 1/E_inf) exp(−t/τ), a retardation time.
  The stress-relaxation time of the same solid is τ·E_inf/E0; never mix the two.
* ``E0`` is the short-time (glassy) modulus, ``E_inf`` the long-time modulus, E0 > E_inf.
* Every modulus called ``E``, ``E0`` or ``E_inf`` in viscoforce is the **paper's E**, defined by
  2/E = (1 − ν1²)/E1 + (1 − ν2²)/E2, i.e. ``E = 2·E_star``, twice Johnson's contact modulus
  ``E_star`` (1/E_star = Σ (1 − νi²)/Ei). A body of Young's modulus Y and Poisson ratio ν against a
  rigid flat has E = 2Y/(1 − ν²); two identical such bodies have E = Y/(1 − ν²).

Spectroscopy convention (copied from the SPEC; use exactly this)
----------------------------------------------------------------
Drive h0(t) = h̄0 + η sin ωt. The force's first harmonic, demodulated over whole periods after the
transient, is F(t) ≈ F̄ + |F1| sin(ωt + ψ). Report:

* ``amplitude`` a = |F1| / F̄, the relative amplitude (dimensionless, the paper's a), and
  ``stiffness`` |F1|/η in N/m;
* ``phase`` χ in degrees = the angle by which the force oscillation LEADS the compression
  (compression = −(h0 − h̄0)); χ > 0 for a viscoelastic material (the paper's 7° and 38° peaks).

Both time-domain simulation + lock-in and the exact small-amplitude frequency-domain response
follow it. (Since the compression is −η sin ωt = η sin(ωt − 180°), χ = ψ + 180° wrapped to
(−180°, 180°].)

Quantity strings
----------------
:func:`parse_quantity` reads ``<number>[<space>][<unit>]``: an optional sign, a decimal number
with an optional exponent (``1e9``, ``1E-9``, ``1.5e+3``, ``.5``), optional whitespace, then a unit
of the requested dimension (see :func:`accepted_units`). A bare number is SI (rad/s for an angular
frequency, Hz for a frequency), unless ``require_unit=True``. The command line sets it for the
dimensions of :data:`UNIT_REQUIRED` (lengths, times, speeds, frequencies), where a bare number is
refused with the unit it needs spelled out (:func:`missing_unit_message`: ``--h0 2`` is not 2 m,
``--omega 100`` is neither 100 Hz nor 100 rad/s); moduli, pressures, forces and the other
dimensions may stay bare SI there. Decimal-prefixed units convert exactly (the result is the
correctly rounded double of the decimal value): ``parse_quantity("3nm", "length") == 3e-9``.
Units are case-sensitive (``mN`` is not ``MN``); both micro signs (U+00B5 ``µ`` and U+03BC ``μ``)
and ASCII ``u`` are accepted; ``A`` is not accepted for ångström (it is the ampere), write
``Å`` or ``angstrom``.

The command line reads its flags with these functions; its argparse helpers (``type=``
callables, negative values such as ``--h0 -5nm``) live in :mod:`viscoforce.cli._args`.
"""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass
from decimal import Decimal

from viscoforce.exceptions import ParameterError, UnitError

__all__ = [
    "DIMENSIONS",
    "UNIT_REQUIRED",
    "accepted_units",
    "format_quantity",
    "missing_unit_message",
    "parse_quantity",
    "unit_factor",
]

_MICRO_SIGNS = ("\u00b5", "\u03bc")  # MICRO SIGN µ, GREEK SMALL LETTER MU μ
_ANGSTROM_SIGNS = ("\u00c5", "\u212b")  # LATIN CAPITAL A WITH RING, ANGSTROM SIGN


@dataclass(frozen=True)
class _Unit:
    """One accepted unit: 1 unit = mult · 10**exp10 [· 2π] in SI."""

    mult: int
    exp10: int
    two_pi: bool = False

    @property
    def factor(self) -> float:
        base = float(Decimal(self.mult).scaleb(self.exp10))
        return base * 2.0 * math.pi if self.two_pi else base


@dataclass(frozen=True)
class _Dimension:
    """A dimension: its names, an example, the accepted units and the display units."""

    phrase: str  # "a length": what the user was asked for
    noun: str  # "length": as in "'nm' is a unit of length"
    example: str
    #: ordered (canonical spelling, unit) pairs; canonical spellings use ``µ`` and ``Å``
    units: tuple[tuple[str, _Unit], ...]
    #: units :func:`format_quantity` may choose (canonical spellings, increasing factor)
    display: tuple[str, ...]


def _d(*pairs: tuple[str, int, int] | tuple[str, int, int, bool]) -> tuple[tuple[str, _Unit], ...]:
    return tuple((p[0], _Unit(*p[1:])) for p in pairs)


_DIMENSIONS: dict[str, _Dimension] = {
    "length": _Dimension(
        "a length", "length", "-5nm",
        _d(("m", 1, 0), ("cm", 1, -2), ("mm", 1, -3), ("µm", 1, -6), ("nm", 1, -9),
           ("pm", 1, -12), ("Å", 1, -10), ("angstrom", 1, -10)),
        ("pm", "nm", "µm", "mm", "m")),
    "time": _Dimension(
        "a time", "time", "1ms",
        _d(("s", 1, 0), ("ms", 1, -3), ("µs", 1, -6), ("ns", 1, -9), ("min", 60, 0)),
        ("ns", "µs", "ms", "s")),
    "pressure": _Dimension(
        "a pressure", "pressure", "1e7Pa",
        _d(("Pa", 1, 0), ("kPa", 1, 3), ("MPa", 1, 6), ("GPa", 1, 9),
           ("N/m2", 1, 0), ("N/m^2", 1, 0), ("N/m²", 1, 0)),
        ("Pa", "kPa", "MPa", "GPa")),
    "speed": _Dimension(
        "a speed", "speed", "5um/s",
        _d(("m/s", 1, 0), ("mm/s", 1, -3), ("µm/s", 1, -6), ("nm/s", 1, -9)),
        ("nm/s", "µm/s", "mm/s", "m/s")),
    "angular_frequency": _Dimension(
        "an angular frequency", "angular frequency", "100rad/s",
        _d(("rad/s", 1, 0), ("krad/s", 1, 3), ("mHz", 1, -3, True), ("Hz", 1, 0, True),
           ("kHz", 1, 3, True), ("MHz", 1, 6, True)),
        ("rad/s",)),
    "frequency": _Dimension(
        "a frequency", "frequency", "10Hz",
        _d(("mHz", 1, -3), ("Hz", 1, 0), ("kHz", 1, 3), ("MHz", 1, 6)),
        ("mHz", "Hz", "kHz", "MHz")),
    "force": _Dimension(
        "a force", "force", "1uN",
        _d(("N", 1, 0), ("mN", 1, -3), ("µN", 1, -6), ("nN", 1, -9), ("pN", 1, -12)),
        ("pN", "nN", "µN", "mN", "N")),
    "stiffness": _Dimension(
        "a stiffness", "stiffness", "0.1N/m",
        _d(("N/m", 1, 0), ("mN/m", 1, -3), ("nN/nm", 1, 0), ("pN/nm", 1, -3)),
        ("mN/m", "N/m")),
    "sensitivity": _Dimension(
        "a deflection sensitivity", "deflection sensitivity", "50nm/V",
        _d(("m/V", 1, 0), ("mm/V", 1, -3), ("µm/V", 1, -6), ("nm/V", 1, -9)),
        ("nm/V", "µm/V", "m/V")),
    "drag": _Dimension(
        "a drag coefficient", "drag coefficient", "1e-6N*s/m",
        _d(("N*s/m", 1, 0), ("Ns/m", 1, 0), ("N s/m", 1, 0), ("kg/s", 1, 0), ("mN*s/m", 1, -3),
           ("µN*s/m", 1, -6), ("nN*s/m", 1, -9), ("pN*s/nm", 1, -3)),
        ("N*s/m",)),
    "dimensionless": _Dimension(
        "a dimensionless number", "dimensionless quantities", "0.5",
        _d(("1", 1, 0)),
        ("",)),
}

#: The dimensions :func:`parse_quantity` understands.
DIMENSIONS: tuple[str, ...] = tuple(_DIMENSIONS)

#: The dimensions whose command-line value needs its unit (``parse_quantity(...,
#: require_unit=True)``): a bare number there is a trap (``--tip sphere:5`` a 5 m sphere,
#: ``--omega 100`` a factor 2π from what was meant), so it is refused, naming the unit.
UNIT_REQUIRED: tuple[str, ...] = ("length", "time", "speed", "angular_frequency", "frequency")

#: The units a refusal of a bare number suggests first, per dimension of :data:`UNIT_REQUIRED`.
_SUGGESTED: dict[str, tuple[str, ...]] = {
    "length": ("nm", "um", "m"), "time": ("ms", "s"), "speed": ("um/s", "nm/s", "m/s")}


def _spellings(canonical: str) -> tuple[str, ...]:
    """All accepted spellings of a canonical unit (micro and ångström variants)."""
    if "µ" in canonical:
        return (canonical.replace("µ", "u"), *(canonical.replace("µ", m) for m in _MICRO_SIGNS))
    if canonical == "Å":
        return _ANGSTROM_SIGNS
    return (canonical,)


_LOOKUP: dict[str, dict[str, _Unit]] = {
    dim: {"": _Unit(1, 0)}  # a bare number is SI
    | {s: unit for canonical, unit in spec.units for s in _spellings(canonical)}
    for dim, spec in _DIMENSIONS.items()
}

_NUMBER_RE = re.compile(
    r"(?P<number>[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)\s*(?P<unit>.*)", re.DOTALL)
_NUMBERLIKE_RE = re.compile(r"[0-9.+\-eE]")  # a "unit" starting like this is a botched number
_NONFINITE_RE = re.compile(r"[+-]?(?:nan|inf|infinity)\b", re.IGNORECASE)


def _dimension(dimension: str) -> _Dimension:
    try:
        return _DIMENSIONS[dimension]
    except (KeyError, TypeError):
        raise ParameterError(
            f"dimension must be one of {', '.join(DIMENSIONS)}; got {dimension!r}") from None


def _describe(value: object) -> str:
    """Short text for a rejected value: ``None``, ``list [1, 2]``, ``ndarray array([], ...)``."""
    if value is None:
        return "None"
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def _require_unit_text(name: str, unit: object) -> str:
    """Return ``unit`` unchanged, raising ParameterError unless it is a string."""
    if not isinstance(unit, str):
        raise ParameterError(
            f"{name} must be a unit string (see accepted_units()), got {_describe(unit)}")
    return unit


def _unit_list(dimension: str) -> str:
    """Human list of accepted units, e.g. ``m, cm, mm, um/µm, nm, pm, Å/angstrom``."""
    if dimension == "dimensionless":
        return "no unit or 1"
    parts: list[str] = []
    for canonical, _unit in _DIMENSIONS[dimension].units:
        if canonical == "angstrom":
            parts[-1] += "/angstrom"
        elif "µ" in canonical:
            parts.append(f"{canonical.replace('µ', 'u')}/{canonical}")
        else:
            parts.append(canonical)
    return ", ".join(parts)


def accepted_units(dimension: str) -> tuple[str, ...]:
    """Every unit spelling :func:`parse_quantity` accepts for ``dimension``.

    Parameters
    ----------
    dimension : str
        One of :data:`DIMENSIONS`.

    Returns
    -------
    tuple of str
        The spellings, including the micro-sign variants (``um``, ``µm``, ``μm``); ``""`` stands
        for a bare number (SI).

    Raises
    ------
    ParameterError
        If ``dimension`` is not one of :data:`DIMENSIONS`.
    """
    _dimension(dimension)
    return ("", *(s for s in _LOOKUP[dimension] if s))


def unit_factor(dimension: str, unit: str) -> float:
    """SI value of one ``unit`` of ``dimension`` (``unit_factor("length", "nm") == 1e-9``).

    Parameters
    ----------
    dimension : str
        One of :data:`DIMENSIONS`.
    unit : str
        An accepted spelling (see :func:`accepted_units`); ``""`` is the SI unit.

    Returns
    -------
    float
        The factor [SI unit / unit]; ``Hz`` as an angular frequency gives 2π [rad/s per Hz].

    Raises
    ------
    ParameterError
        If ``dimension`` is unknown or ``unit`` is not a string.
    UnitError
        If ``unit`` is not accepted for ``dimension``.
    """
    _dimension(dimension)
    _require_unit_text("unit", unit)
    return _lookup_unit(dimension, unit, repr(unit), None).factor


def _other_dimension(unit: str) -> str | None:
    """Return the dimension ``unit`` belongs to (frequency before angular frequency), if any."""
    for dim in ("frequency", *DIMENSIONS):
        if unit in _LOOKUP[dim]:
            return dim
    return None


def _lookup_unit(dimension: str, unit: str, original: str, name: str | None) -> _Unit:
    table = _LOOKUP[dimension]
    if unit in table:
        return table[unit]
    spec = _DIMENSIONS[dimension]
    prefix = f"{name}: " if name else ""
    other = _other_dimension(unit)
    if other is not None:
        raise UnitError(
            f"{prefix}expected {spec.phrase} ({_unit_list(dimension)}), got {original}: "
            f"'{unit}' is a unit of {_DIMENSIONS[other].noun}")
    message = (f"{prefix}unknown unit '{unit}' in {original} for {spec.phrase}; "
               f"accepted: {_unit_list(dimension)}")
    if any(c.isspace() for c in unit):
        message += " (no spaces inside a unit)"
    if unit == "A" and dimension == "length":
        message += " ('A' is the ampere; write 'Å' or 'angstrom')"
    close = [s for s in table if s and s.lower() == unit.lower()]
    if close:
        options = " or ".join(repr(s) for s in close)
        message += f"; did you mean {options}? (units are case-sensitive)"
    raise UnitError(message)


def _real(value: object, message: str) -> float:
    """Return a real number (not a bool) as a float, raising ParameterError with ``message``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParameterError(f"{message}, got {value!r}")
    try:
        return float(value)
    except OverflowError:
        raise ParameterError(f"{message} within the double-precision range, "
                             f"got {value!r}") from None


def _or_list(items: list[str]) -> str:
    return items[0] if len(items) == 1 else f"{', '.join(items[:-1])} or {items[-1]}"


def _looks_si(text: str) -> bool:
    """Whether a bare number reads as an SI value of a small quantity (``2e-9``, ``0.0001``)."""
    try:
        value = abs(float(text))
    except ValueError:
        return False
    return 0 < value < 1e-3


def missing_unit_message(text: str, dimension: str) -> str:
    """Why a bare number is refused for ``dimension``, and what to write instead.

    Parameters
    ----------
    text : str
        The number as typed (``"2"``).
    dimension : str
        One of :data:`DIMENSIONS`, normally of :data:`UNIT_REQUIRED`.

    Returns
    -------
    str
        ``"2 has no unit: write 2nm, 2um or 2m (a length needs its unit: m, cm, mm, um/µm, nm,
        pm, Å/angstrom)"``: the likely units first (ms, s for a time; um/s, nm/s, m/s for a
        speed), the SI unit alone for a number that looks SI (``2e-9``: ``write 2e-9m``); for a
        frequency both readings, ``"100 has no unit: write 100Hz (f = 100 Hz, ω = 628 rad/s) or
        100rad/s (ω = 100 rad/s, f = 15.9 Hz)"``.

    Raises
    ------
    ParameterError
        If ``dimension`` is unknown.
    """
    spec = _dimension(dimension)
    text = str(text).strip()
    if dimension in ("frequency", "angular_frequency"):
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if math.isfinite(value):
            two_pi = 2 * math.pi

            def f(x: float) -> str:
                return format_quantity(x, "frequency")

            def w(x: float) -> str:
                return format_quantity(x, "angular_frequency")

            return (f"{text} has no unit: write {text}Hz (f = {f(value)}, ω = {w(two_pi * value)}) "
                    f"or {text}rad/s (ω = {w(value)}, f = {f(value / two_pi)})")
    units = ((_si_symbol(dimension),) if _looks_si(text)  # 2e-9 for a length: meant 2e-9m
             else _SUGGESTED.get(dimension, tuple(c for c, _ in spec.units[:3])))
    written = [f"{text}{u}" for u in units]
    return (f"{text} has no unit: write {_or_list(written)} ({spec.phrase} needs its unit: "
            f"{_unit_list(dimension)})")


def _scaled(number: str, unit: _Unit) -> float:
    """Return ``number`` (decimal text) times the unit, correctly rounded before any 2π."""
    sign, digits, exponent = Decimal(number).as_tuple()
    assert isinstance(exponent, int)  # the regex admits finite numbers only
    mantissa = int("".join(map(str, digits))) * unit.mult
    value = float(Decimal(f"{'-' if sign else ''}{mantissa}e{exponent + unit.exp10}"))
    return value * (2.0 * math.pi) if unit.two_pi else value


def parse_quantity(text: str | float, dimension: str, *, name: str | None = None,
                   require_unit: bool = False) -> float:
    """Read a quantity with an optional unit suffix and return it in SI.

    Parameters
    ----------
    text : str or float
        ``"<number>[<space>][<unit>]"``, e.g. ``"-5nm"``, ``"1E-9 m"``, ``"1.5e+3Hz"``,
        ``"5um/s"``; a bare number (string or real) is SI. See the module docstring for the
        grammar and :func:`accepted_units` for the units.
    dimension : str
        One of :data:`DIMENSIONS` (``"length"``, ``"time"``, ``"pressure"``, ``"speed"``,
        ``"angular_frequency"``, ``"frequency"``, ``"force"``, ``"stiffness"``,
        ``"dimensionless"``).
    name : str, optional
        Parameter name to prefix error messages with (e.g. ``"--h0"``).
    require_unit : bool, optional
        Refuse a bare number *text* (``"2"``) with :func:`missing_unit_message`, as the command
        line does for :data:`UNIT_REQUIRED` (default False: a bare number is SI). A real number
        passed as such is SI either way.

    Returns
    -------
    float
        The finite value in SI units ([m], [s], [Pa], [m/s], [rad/s], [Hz], [N], [N/m], [1]).
        Decimal-prefixed units convert exactly: the result is the correctly rounded double of
        the decimal value (``"3nm"`` gives ``3e-9``).

    Raises
    ------
    UnitError
        For any string that is not a finite quantity of ``dimension``: empty, ``nan``/``inf``,
        a decimal comma (``"1,5nm"``), garbage (``"nm5"``, ``"--5nm"``, ``"5 n m"``), an unknown
        unit, a unit of another dimension (``"5nm"`` for a time), a value that overflows, or
        (``require_unit=True``) a number without its unit.
    ParameterError
        If ``dimension`` is unknown, ``text`` is not a string or a finite real number, or
        ``name`` is not a string or None.
    """
    spec = _dimension(dimension)
    if name is not None and not isinstance(name, str):
        raise ParameterError(f"name must be a string or None, got {_describe(name)}")
    if not isinstance(require_unit, bool):
        raise ParameterError(f"require_unit must be True or False, got {_describe(require_unit)}")
    prefix = f"{name}: " if name else ""
    if not isinstance(text, str):
        value = _real(text, f"{prefix}expected {spec.phrase} as a string or real number")
        if not math.isfinite(value):
            raise ParameterError(f"{prefix}{spec.phrase} must be finite, got {text!r}")
        return value

    stripped = text.strip()
    shown = repr(stripped)
    if not stripped:
        raise UnitError(f"{prefix}empty string is not {spec.phrase}; "
                        f"give a number with an optional unit, e.g. '{spec.example}'")
    if _NONFINITE_RE.match(stripped):
        raise UnitError(f"{prefix}{spec.phrase} must be finite, got {shown}")
    if "," in stripped:
        raise UnitError(
            f"{prefix}commas are not accepted in {shown}; use a decimal point "
            f"({stripped.replace(',', '.', 1)!r}) and no thousands separators")
    match = _NUMBER_RE.fullmatch(stripped)
    if match is None or (_NUMBERLIKE_RE.match(match["unit"]) and match["unit"] != "1"):
        raise UnitError(f"{prefix}cannot read {shown} as {spec.phrase}: expected a number with an "
                        f"optional unit ({_unit_list(dimension)}), e.g. '{spec.example}'")
    if require_unit and not match["unit"]:
        raise UnitError(prefix + missing_unit_message(stripped, dimension))
    unit = _lookup_unit(dimension, match["unit"], shown, name)
    value = _scaled(match["number"], unit)
    if not math.isfinite(value):
        raise UnitError(f"{prefix}{shown} is too large for a double-precision float")
    return value


def format_quantity(value: float, dimension: str, unit: str | None = None, *, digits: int = 3,
                    ascii_only: bool = False) -> str:
    """Format an SI value for humans with a sensible prefix (``1.08e-6 N`` → ``"1.08 µN"``).

    Parameters
    ----------
    value : float
        The value in SI units (see :func:`parse_quantity` for the SI unit of each dimension).
        Non-finite values are shown in the SI unit (``"nan m"``).
    dimension : str
        One of :data:`DIMENSIONS`.
    unit : str, optional
        Force this unit (any spelling :func:`accepted_units` lists). By default the largest
        display unit whose rounded mantissa is >= 1 is chosen (the smallest one below that;
        the SI unit for zero and non-finite values). Angular frequencies are shown in rad/s
        unless ``unit`` asks for Hz.
    digits : int, optional
        Significant digits, 1 to 17 (default 3). With 17 the text reads back to the same double
        within a few ulp.
    ascii_only : bool, optional
        Write the micro prefix as ``u`` (``"1.08 uN"``) instead of ``µ`` (and ``Å`` as
        ``angstrom``).

    Returns
    -------
    str
        ``"<mantissa> <unit>"`` (just the mantissa for a dimensionless number), which
        :func:`parse_quantity` reads back.

    Raises
    ------
    ParameterError
        If ``dimension`` is unknown, ``value`` is not a real number, ``digits`` is not an
        integer in [1, 17], ``unit`` is not a string or None, or ``ascii_only`` is not a bool.
    UnitError
        If ``unit`` is not accepted for ``dimension``.
    """
    spec = _dimension(dimension)
    x = _real(value, "value must be a real number")
    if isinstance(digits, bool) or not isinstance(digits, int) or not 1 <= digits <= 17:
        raise ParameterError(f"digits must be an integer in [1, 17], got {digits!r}")
    if not isinstance(ascii_only, bool):
        raise ParameterError(f"ascii_only must be True or False, got {_describe(ascii_only)}")
    if unit is not None:
        _require_unit_text("unit", unit)
        chosen, factor = unit, _lookup_unit(dimension, unit, repr(unit), "unit").factor
    elif x == 0.0 or not math.isfinite(x):
        chosen, factor = _si_symbol(dimension), 1.0
    else:
        # the largest display unit whose *rounded* mantissa is >= 1 (else the smallest unit)
        chosen, factor = spec.display[0], _LOOKUP[dimension][spec.display[0]].factor
        for symbol in reversed(spec.display):
            f = _LOOKUP[dimension][symbol].factor
            if abs(float(f"{x / f:.{digits}g}")) >= 1.0:
                chosen, factor = symbol, f
                break
    if ascii_only:
        for m in _MICRO_SIGNS:
            chosen = chosen.replace(m, "u")
        for a in _ANGSTROM_SIGNS:
            chosen = chosen.replace(a, "angstrom")
    mantissa = f"{x / factor:.{digits}g}"
    return f"{mantissa} {chosen}" if chosen and chosen != "1" else mantissa


def _si_symbol(dimension: str) -> str:
    """Return the SI unit spelling of ``dimension`` (the first unit, factor 1)."""
    return "" if dimension == "dimensionless" else _DIMENSIONS[dimension].units[0][0]
