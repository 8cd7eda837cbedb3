"""Tests of viscoforce.units: quantity parsing/formatting, the rulebook.

The argparse helpers (quantity_type, normalize_negative_args) live in viscoforce.cli._args and
are tested in tests/cli/test_cli_args.py.
"""

from __future__ import annotations

import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from viscoforce import units
from viscoforce.exceptions import ParameterError, UnitError
from viscoforce.units import (
    DIMENSIONS,
    accepted_units,
    format_quantity,
    parse_quantity,
    unit_factor,
)

MICRO = "\u00b5"  # MICRO SIGN
MU = "\u03bc"  # GREEK SMALL LETTER MU
TWO_PI = 2.0 * math.pi


def exact(x: float):
    """Equal to within 1e-15 relative (abs=0: pytest's default abs=1e-12 would hide nm errors)."""
    return pytest.approx(x, rel=1e-15, abs=0.0)


# --------------------------------------------------------------------------------------------
# conversions, table-driven
# --------------------------------------------------------------------------------------------

CONVERSIONS = [
    # length
    ("1", "length", 1.0),
    ("2m", "length", 2.0),
    ("3cm", "length", 3e-2),
    ("3mm", "length", 3e-3),
    ("10um", "length", 1e-5),
    ("3nm", "length", 3e-9),
    ("-5nm", "length", -5e-9),
    ("+2 nm", "length", 2e-9),
    ("7pm", "length", 7e-12),
    ("5angstrom", "length", 5e-10),
    ("5\u00c5", "length", 5e-10),
    ("5\u212b", "length", 5e-10),
    ("1E-9 m", "length", 1e-9),
    ("-.5nm", "length", -5e-10),
    ("5.nm", "length", 5e-9),
    ("  0.1 nm  ", "length", 1e-10),
    ("1e-3um", "length", 1e-9),
    ("-0nm", "length", -0.0),
    # time
    ("1", "time", 1.0),
    ("1s", "time", 1.0),
    ("0.1ms", "time", 1e-4),
    ("5ms", "time", 5e-3),
    ("3us", "time", 3e-6),
    ("20ns", "time", 2e-8),
    ("2min", "time", 120.0),
    ("0.1 min", "time", 6.0),
    # pressure
    ("1e9Pa", "pressure", 1e9),
    ("1e7", "pressure", 1e7),
    ("1GPa", "pressure", 1e9),
    ("10 MPa", "pressure", 1e7),
    ("3kPa", "pressure", 3e3),
    ("1e10N/m2", "pressure", 1e10),
    ("1e10 N/m^2", "pressure", 1e10),
    ("1e10 N/m\u00b2", "pressure", 1e10),
    # speed
    ("5um/s", "speed", 5e-6),
    ("1 mm/s", "speed", 1e-3),
    ("2m/s", "speed", 2.0),
    ("300nm/s", "speed", 3e-7),
    # angular frequency
    ("100", "angular_frequency", 100.0),
    ("100rad/s", "angular_frequency", 100.0),
    ("2krad/s", "angular_frequency", 2000.0),
    ("1Hz", "angular_frequency", TWO_PI),
    ("1.5e+3Hz", "angular_frequency", 1500.0 * TWO_PI),
    ("1kHz", "angular_frequency", 1000.0 * TWO_PI),
    ("2MHz", "angular_frequency", 2e6 * TWO_PI),
    ("10mHz", "angular_frequency", 1e-2 * TWO_PI),
    # frequency
    ("10", "frequency", 10.0),
    ("10Hz", "frequency", 10.0),
    ("1.5kHz", "frequency", 1500.0),
    ("3MHz", "frequency", 3e6),
    ("5mHz", "frequency", 5e-3),
    # force
    ("1N", "force", 1.0),
    ("2mN", "force", 2e-3),
    ("1.08uN", "force", 1.08e-6),
    ("61nN", "force", 6.1e-8),
    ("5 pN", "force", 5e-12),
    # stiffness
    ("0.1N/m", "stiffness", 0.1),
    ("40mN/m", "stiffness", 4e-2),
    ("3nN/nm", "stiffness", 3.0),
    ("20pN/nm", "stiffness", 2e-2),
    # deflection sensitivity and drag (viscoforce load --sensitivity, --drag)
    ("50nm/V", "sensitivity", 5e-8),
    ("1.1028e-7m/V", "sensitivity", 1.1028e-7),
    ("2um/V", "sensitivity", 2e-6),
    ("1e-6N*s/m", "drag", 1e-6),
    ("3uN*s/m", "drag", 3e-6),
    ("2kg/s", "drag", 2.0),
    # dimensionless
    ("0.5", "dimensionless", 0.5),
    ("0.5 1", "dimensionless", 0.5),
    ("-3e-2", "dimensionless", -3e-2),
]


@pytest.mark.parametrize(("text", "dimension", "expected"), CONVERSIONS)
def test_parse_quantity_table(text, dimension, expected):
    value = parse_quantity(text, dimension)
    assert type(value) is float
    assert value == exact(expected)
    assert math.copysign(1.0, value) == math.copysign(1.0, expected)


def test_table_covers_every_dimension_and_unit():
    covered = {(d, t.strip()) for t, d, _ in CONVERSIONS}
    for dim in DIMENSIONS:
        assert any(d == dim for d, _ in covered), dim


@pytest.mark.parametrize(("text", "expected"), [
    ("3nm", 3e-9), ("0.1nm", 1e-10), ("7nm", 7e-9), ("1.1um", 1.1e-6), ("0.3ms", 3e-4),
])
def test_decimal_prefixes_are_exact(text, expected):
    # 3 * 1e-9 == 3.0000000000000004e-09 in floating point; the parser rounds the decimal value.
    dim = "time" if text.endswith("ms") else "length"
    assert parse_quantity(text, dim) == expected


@pytest.mark.parametrize("micro", ["u", MICRO, MU])
@pytest.mark.parametrize(("unit", "dimension", "factor"), [
    ("um", "length", 1e-6), ("us", "time", 1e-6), ("um/s", "speed", 1e-6), ("uN", "force", 1e-6),
])
def test_micro_sign_variants(micro, unit, dimension, factor):
    spelled = unit.replace("u", micro, 1)
    assert parse_quantity(f"2.5{spelled}", dimension) == exact(2.5 * factor)
    assert spelled in accepted_units(dimension)
    assert unit_factor(dimension, spelled) == factor


@pytest.mark.parametrize(("value", "dimension"), [
    (5e-9, "length"), (-5e-9, "length"), (3, "time"), (np.float64(1e9), "pressure"),
    (Fraction(1, 4), "dimensionless"), (0, "force"),
])
def test_numbers_are_si(value, dimension):
    result = parse_quantity(value, dimension)
    assert type(result) is float
    assert result == float(value)


def test_unit_factor_and_accepted_units():
    assert unit_factor("length", "nm") == 1e-9
    assert unit_factor("length", "") == 1.0
    assert unit_factor("angular_frequency", "Hz") == TWO_PI
    assert unit_factor("angular_frequency", "kHz") == exact(1000 * TWO_PI)
    assert unit_factor("time", "min") == 60.0
    assert unit_factor("pressure", "N/m^2") == 1.0
    assert accepted_units("length")[0] == ""
    assert {"m", "nm", "um", MICRO + "m", MU + "m", "angstrom", "\u00c5", "\u212b"} <= set(
        accepted_units("length"))
    assert "A" not in accepted_units("length")
    assert set(accepted_units("dimensionless")) == {"", "1"}
    assert accepted_units("time")[-1] == "min"


# --------------------------------------------------------------------------------------------
# every raise branch of parse_quantity / unit_factor
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize(("text", "dimension", "pattern"), [
    ("5nm", "time", r"expected a time \(s, ms, us/µs, ns, min\), got '5nm': 'nm' is a unit of "
                    r"length"),
    ("1ms", "length", r"expected a length \(m, cm, mm, um/µm, nm, pm, Å/angstrom\), got '1ms'"),
    ("5Hz", "length", r"'Hz' is a unit of frequency"),
    ("1e9Pa", "force", r"expected a force .*'Pa' is a unit of pressure"),
    ("5 1", "length", r"'1' is a unit of dimensionless quantities"),
    ("10rad/s", "frequency", r"expected a frequency \(mHz, Hz, kHz, MHz\).*angular frequency"),
    ("5nm", "dimensionless", r"expected a dimensionless number \(no unit or 1\)"),
])
def test_wrong_dimension(text, dimension, pattern):
    with pytest.raises(UnitError, match=pattern):
        parse_quantity(text, dimension)


@pytest.mark.parametrize(("text", "dimension", "pattern"), [
    ("5nmm", "length", r"unknown unit 'nmm' in '5nmm' for a length; accepted: m, cm, mm, "
                       r"um/µm, nm, pm, Å/angstrom$"),
    ("5 n m", "length", r"unknown unit 'n m' .*\(no spaces inside a unit\)"),
    ("5A", "length", r"unknown unit 'A'.*'A' is the ampere; write 'Å' or 'angstrom'"),
    ("5 mpa", "pressure", r"unknown unit 'mpa'.*did you mean 'MPa'\? \(units are case-sensitive\)"),
    ("5 mhz", "frequency", r"did you mean 'mHz' or 'MHz'\?"),
    ("1 hz", "angular_frequency", r"accepted: rad/s, krad/s, mHz, Hz, kHz, MHz; did you mean 'Hz'"),
    ("0x10", "length", r"unknown unit 'x10' in '0x10'"),
    ("1 um/ms", "speed", r"unknown unit 'um/ms'.*accepted: m/s, mm/s, um/s/µm/s, nm/s"),
    ("2 N/mm", "stiffness", r"accepted: N/m, mN/m, nN/nm, pN/nm"),
    ("2 %", "dimensionless", r"unknown unit '%'.*accepted: no unit or 1"),
])
def test_unknown_unit(text, dimension, pattern):
    with pytest.raises(UnitError, match=pattern):
        parse_quantity(text, dimension)


@pytest.mark.parametrize("text", ["nm5", "--5nm", "- 5nm", "nm", ".", "e5", "5..0nm", "++5",
                                  "\u0665nm", "5e", "5 e-9", "1.5.2nm", "5-3nm", "5 +nm", "5 2"])
def test_garbage(text):
    with pytest.raises(UnitError, match=r"cannot read '.*' as a length: expected a number with an "
                                        r"optional unit \(m, cm, .*\), e\.g\. '-5nm'"):
        parse_quantity(text, "length")


@pytest.mark.parametrize("text", ["0x10", "5 n m", "1,5nm"])
def test_every_rejected_string_is_a_value_error(text):
    # UnitError mixes in ValueError, so `except ValueError` keeps working
    with pytest.raises(ValueError):
        parse_quantity(text, "length")


@pytest.mark.parametrize("text", ["", "   ", "\t\n"])
def test_empty(text):
    with pytest.raises(UnitError, match=r"empty string is not a force; give a number with an "
                                        r"optional unit, e\.g\. '1uN'"):
        parse_quantity(text, "force")


@pytest.mark.parametrize("text", ["nan", "NaN", "inf", "-inf", "+Infinity", "nan nm", "inf m"])
def test_nonfinite_strings(text):
    with pytest.raises(UnitError, match=r"a length must be finite, got '.*'"):
        parse_quantity(text, "length")


@pytest.mark.parametrize(("text", "suggestion"), [("1,5nm", "'1.5nm'"), ("1,000 m", "'1.000 m'")])
def test_decimal_comma(text, suggestion):
    with pytest.raises(UnitError, match=rf"commas are not accepted in '{text}'; use a decimal "
                                        rf"point \({suggestion}\) and no thousands separators"):
        parse_quantity(text, "length")


@pytest.mark.parametrize("text", ["1e400", "1e308 kPa", "-2e308"])
def test_overflow(text):
    with pytest.raises(UnitError, match=r"is too large for a double-precision float"):
        parse_quantity(text, "pressure")


def test_underflow_goes_to_zero():
    assert parse_quantity("1e-400 nm", "length") == 0.0


@pytest.mark.parametrize(("value", "pattern"), [
    (float("nan"), r"a length must be finite, got nan"),
    (float("-inf"), r"a length must be finite, got -inf"),
    (np.float64("inf"), r"a length must be finite"),
    (True, r"expected a length as a string or real number, got True"),
    (None, r"expected a length as a string or real number, got None"),
    (b"5nm", r"expected a length as a string or real number, got b'5nm'"),
    (1j, r"expected a length as a string or real number, got 1j"),
    (10**400, r"expected a length as a string or real number within the double-precision range"),
])
def test_bad_numeric_input(value, pattern):
    with pytest.raises(ParameterError, match=pattern):
        parse_quantity(value, "length")


@pytest.mark.parametrize("dimension", ["Length", "area", "", None])
def test_unknown_dimension(dimension):
    with pytest.raises(ParameterError, match=r"dimension must be one of length, time, pressure, "
                                             r"speed, angular_frequency, frequency, force, "
                                             r"stiffness, sensitivity, drag, dimensionless; got"):
        parse_quantity("1", dimension)
    with pytest.raises(ParameterError, match=r"dimension must be one of"):
        accepted_units(dimension)
    with pytest.raises(ParameterError, match=r"dimension must be one of"):
        unit_factor(dimension, "")
    with pytest.raises(ParameterError, match=r"dimension must be one of"):
        format_quantity(1.0, dimension)


def test_name_prefixes_messages():
    with pytest.raises(UnitError, match=r"^--h0: unknown unit 'xm'"):
        parse_quantity("5xm", "length", name="--h0")
    with pytest.raises(UnitError, match=r"^--tau: expected a time"):
        parse_quantity("5nm", "time", name="--tau")
    with pytest.raises(UnitError, match=r"^--E: a pressure must be finite"):
        parse_quantity("inf", "pressure", name="--E")
    with pytest.raises(ParameterError, match=r"^R: a length must be finite"):
        parse_quantity(float("nan"), "length", name="R")


def test_unit_factor_rejects_unknown_and_foreign_units():
    with pytest.raises(UnitError, match=r"unknown unit 'furlong'"):
        unit_factor("length", "furlong")
    with pytest.raises(UnitError, match=r"expected a length .* 's' is a unit of time"):
        unit_factor("length", "s")


# --------------------------------------------------------------------------------------------
# properties
# --------------------------------------------------------------------------------------------

UNIT_PAIRS = [(d, u) for d in DIMENSIONS for u in accepted_units(d)]
finite = st.floats(min_value=-1e290, max_value=1e290, allow_nan=False, allow_infinity=False)
finite = finite.filter(lambda v: v == 0.0 or abs(v) > 1e-290)


@given(v=finite, pair=st.sampled_from(UNIT_PAIRS), space=st.sampled_from(["", " ", "  "]))
def test_round_trip_repr_with_unit(v, pair, space):
    dimension, unit = pair
    if dimension == "dimensionless" and unit == "1" and not space:
        space = " "  # "0.51" is the number 0.51, not 0.5 times the unit 1
    result = parse_quantity(f"{v!r}{space}{unit}", dimension)
    assert result == exact(v * unit_factor(dimension, unit))


@given(v=finite.filter(lambda v: v != 0.0), dimension=st.sampled_from(DIMENSIONS))
def test_format_parse_round_trip(v, dimension):
    text = format_quantity(v, dimension)
    # 3 significant digits: half a unit in the third digit of a mantissa >= 1
    assert parse_quantity(text, dimension) == pytest.approx(v, rel=5e-3, abs=0.0)
    text17 = format_quantity(v, dimension, digits=17, ascii_only=True)
    assert text17.isascii()
    assert parse_quantity(text17, dimension) == exact(v)


@given(v=finite, pair=st.sampled_from(UNIT_PAIRS))
def test_format_with_unit_round_trip(v, pair):
    dimension, unit = pair
    text = format_quantity(v, dimension, unit, digits=17)
    assert parse_quantity(text, dimension) == pytest.approx(v, rel=1e-15, abs=1e-300)


# --------------------------------------------------------------------------------------------
# format_quantity
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize(("value", "dimension", "unit", "expected"), [
    (1.08e-6, "force", None, "1.08 µN"),
    (6.1e-8, "force", None, "61 nN"),
    (0.5, "force", None, "500 mN"),
    (1.59e-6, "force", None, "1.59 µN"),
    (-5e-9, "length", None, "-5 nm"),
    (1e-5, "length", None, "10 µm"),
    (999.96e-9, "length", None, "1 µm"),  # rounds up into the next unit
    (999.4e-9, "length", None, "999 nm"),
    (12.0, "length", None, "12 m"),
    (1e-20, "length", None, "1e-08 pm"),
    (0.0, "force", None, "0 N"),
    (1e-3, "time", None, "1 ms"),
    (120.0, "time", None, "120 s"),
    (1e7, "pressure", None, "10 MPa"),
    (5e12, "pressure", None, "5e+03 GPa"),
    (5e-6, "speed", None, "5 µm/s"),
    (1000.0, "angular_frequency", None, "1e+03 rad/s"),
    (1000.0 * TWO_PI, "angular_frequency", "kHz", "1 kHz"),
    (2000.0, "frequency", None, "2 kHz"),
    (0.1, "stiffness", None, "100 mN/m"),
    (2.0, "stiffness", None, "2 N/m"),
    (0.5, "dimensionless", None, "0.5"),
    (0.5, "dimensionless", "1", "0.5"),
    (5e-9, "length", "angstrom", "50 angstrom"),
    (5e-9, "length", "um", "0.005 um"),
    (float("nan"), "force", None, "nan N"),
    (float("-inf"), "length", None, "-inf m"),
    (float("inf"), "angular_frequency", None, "inf rad/s"),
])
def test_format_quantity(value, dimension, unit, expected):
    assert format_quantity(value, dimension, unit) == expected


def test_format_quantity_micro_sign_and_options():
    text = format_quantity(1.08e-6, "force")
    assert text[-2] == MICRO  # U+00B5 MICRO SIGN, not the Greek mu
    assert format_quantity(1.08e-6, "force", ascii_only=True) == "1.08 uN"
    assert format_quantity(1e-10, "length", "\u212b", ascii_only=True) == "1 angstrom"
    assert format_quantity(1.08e-6, "force", digits=1) == "1 µN"
    assert format_quantity(1.0 / 3.0, "dimensionless", digits=6) == "0.333333"
    assert format_quantity(np.float64(2e-9), "length") == "2 nm"
    assert format_quantity(3, "time") == "3 s"


@pytest.mark.parametrize("digits", [0, 18, -1, 2.5, True, "3"])
def test_format_quantity_bad_digits(digits):
    with pytest.raises(ParameterError, match=r"digits must be an integer in \[1, 17\], got"):
        format_quantity(1.0, "length", digits=digits)


@pytest.mark.parametrize(("value", "pattern"), [
    ("5nm", r"value must be a real number, got '5nm'"),
    (True, r"value must be a real number, got True"),
    (None, r"value must be a real number, got None"),
    (10**400, r"value must be a real number within the double-precision range"),
])
def test_format_quantity_bad_value(value, pattern):
    with pytest.raises(ParameterError, match=pattern):
        format_quantity(value, "length")


def test_format_quantity_bad_unit():
    with pytest.raises(UnitError, match=r"^unit: unknown unit 'furlong'"):
        format_quantity(1.0, "length", "furlong")
    with pytest.raises(UnitError, match=r"^unit: expected a length .* 'ms' is a unit of time"):
        format_quantity(1.0, "length", "ms")


# --------------------------------------------------------------------------------------------
# the rulebook
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize("phrase", [
    "SI inside",
    "u < 0`` means flattening",
    "h(r) = h0 + r²/2R − u(r)",
    "> 0 for\n  repulsion",
    "CREEP compliance",
    "τ·E_inf/E0",
    "2/E = (1 − ν1²)/E1 + (1 − ν2²)/E2",
    "E = 2·E_star",
    "Drive h0(t) = h̄0 + η sin ωt",
    "F(t) ≈ F̄ + |F1| sin(ωt + ψ)",
    "the angle by which the force oscillation LEADS the compression\n"
    "  (compression = −(h0 − h̄0)); χ > 0 for a viscoelastic material",
    "``amplitude`` a = |F1| / F̄",
    "``stiffness`` |F1|/η in N/m",
])
def test_module_docstring_states_the_conventions(phrase):
    assert phrase in units.__doc__


def test_public_names_have_docstrings():
    for name in units.__all__:
        obj = getattr(units, name)
        if callable(obj):
            assert obj.__doc__ and "Parameters" in obj.__doc__, name


def test_units_holds_no_argparse_helpers():
    source = Path(units.__file__).read_text(encoding="utf-8")
    assert "import argparse" not in source
    assert not {"quantity_type", "normalize_negative_args"} & set(units.__all__)


# ── bad argument types (robustness probe) ─────────────────────────────────────────────────────

@pytest.mark.parametrize(("call", "match"), [
    (lambda: unit_factor("length", None), r"unit must be a unit string .*got None"),
    (lambda: unit_factor("length", ["nm"]), r"unit must be a unit string .*got list \['nm'\]"),
    (lambda: unit_factor("length", {}), r"unit must be a unit string .*got dict \{\}"),
    (lambda: unit_factor("length", np.array([])), "unit must be a unit string .*got ndarray"),
    (lambda: unit_factor("length", 1e-9), "unit must be a unit string .*got float 1e-09"),
    (lambda: format_quantity(5e-9, "length", ["nm"]), "unit must be a unit string .*got list"),
    (lambda: format_quantity(5e-9, "length", {"nm": 1}), "unit must be a unit string .*got dict"),
    (lambda: format_quantity(5e-9, "length", ascii_only=np.array([])),
     r"ascii_only must be True or False, got ndarray array\(\[\]"),
    (lambda: format_quantity(5e-9, "length", ascii_only="yes"),
     "ascii_only must be True or False, got str 'yes'"),
    (lambda: format_quantity(5e-9, "length", ascii_only=None),
     "ascii_only must be True or False, got None"),
    (lambda: parse_quantity("5nm", "length", name=np.array([])),
     "name must be a string or None, got ndarray"),
    (lambda: parse_quantity("5nm", "length", name=["--h0"]),
     r"name must be a string or None, got list \['--h0'\]"),
], ids=["factor-None", "factor-list", "factor-dict", "factor-array", "factor-float",
        "format-unit-list", "format-unit-dict", "format-ascii-array", "format-ascii-str",
        "format-ascii-None", "parse-name-array", "parse-name-list"])
def test_bad_argument_types_raise_parameter_error(call, match):
    with pytest.raises(ParameterError, match=match):
        call()
