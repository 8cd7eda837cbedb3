"""Tests of viscoforce.cli._args: quantity/integer types, negative values, flag tables, outputs."""

from __future__ import annotations

import argparse
import math
import os

import pytest

from viscoforce import _limits
from viscoforce.cli import main
from viscoforce.cli._args import (
    FIGURE,
    MATERIAL_FLAGS,
    NETCDF,
    NUMERICS_FLAGS,
    SYSTEM_FLAGS,
    Flag,
    FlagGroup,
    OmegaList,
    OmegaRange,
    UsageError,
    add_flags,
    check_output_paths,
    figure_formats,
    integer_type,
    normalize_negative_args,
    quantity_type,
    real_type,
    value_options,
)
from viscoforce.exceptions import ParameterError, UnitError
from viscoforce.physics.paper import PAPER

MU = "\u03bc"  # GREEK SMALL LETTER MU
TWO_PI = 2.0 * math.pi


def exact(x: float):
    """Equal to within 1e-15 relative (abs=0: pytest's default abs=1e-12 would hide nm errors)."""
    return pytest.approx(x, rel=1e-15, abs=0.0)


# --------------------------------------------------------------------------------------------
# argparse integration
# --------------------------------------------------------------------------------------------

VALUE_OPTIONS = {"--h0", "--from", "--to", "--t-end", "--speed", "--E", "-x"}
MULTI_OPTIONS = {"--omega"}


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="viscoforce")
    parser.add_argument("--h0", type=quantity_type("length"))
    parser.add_argument("--from", dest="from_", type=quantity_type("length"))
    parser.add_argument("--to", type=quantity_type("length"))
    parser.add_argument("--t-end", type=quantity_type("time"))
    parser.add_argument("--speed", type=quantity_type("speed"))
    parser.add_argument("--E", type=quantity_type("pressure"))
    parser.add_argument("-x", type=quantity_type("length"))
    parser.add_argument("--omega", nargs="+", type=quantity_type("angular_frequency"))
    parser.add_argument("--verbose", "-v", action="store_true")
    parser.add_argument("data", nargs="?")
    return parser


def parse(argv: list[str]) -> argparse.Namespace:
    return make_parser().parse_args(normalize_negative_args(argv, VALUE_OPTIONS, MULTI_OPTIONS))


@pytest.mark.parametrize(("argv", "attr", "expected"), [
    (["--h0", "-5nm"], "h0", -5e-9),
    (["--h0=-5nm"], "h0", -5e-9),
    (["--h0", "-.5nm"], "h0", -5e-10),
    (["--h0", "-1e-9m"], "h0", -1e-9),
    (["--h0", "-3m"], "h0", -3.0),
    (["--h0", "2nm"], "h0", 2e-9),
    (["--h0", "2e-9m"], "h0", 2e-9),
    (["--from", "10nm", "--to", "-10nm"], "to", -1e-8),
    (["--from", "10nm", "--to", "-10nm"], "from_", 1e-8),
    (["--from", "-10nm", "--to", "10nm"], "from_", -1e-8),
    (["--t-end", "5ms"], "t_end", 5e-3),
    (["--speed", "5um/s"], "speed", 5e-6),
    (["--speed", f"5{MU}m/s"], "speed", 5e-6),
    (["--E", "1e9Pa"], "E", 1e9),
    (["--E", "1GPa"], "E", 1e9),
    (["--E", "1e9"], "E", 1e9),  # moduli and pressures may stay bare Pa
    (["-x", "-5nm"], "x", -5e-9),
    (["--omega", "100rad/s", "1kHz"], "omega", [100.0, 1000.0 * TWO_PI]),
    (["--omega", "1rad/s", "-2kHz", "3rad/s"], "omega", [1.0, -2000.0 * TWO_PI, 3.0]),
    (["--omega", "-1e3rad/s", "-.5rad/s", "--h0", "-5nm"], "omega", [-1e3, -0.5]),
    (["--omega", "-1e3rad/s", "-.5rad/s", "--h0", "-5nm"], "h0", -5e-9),
    (["--omega", "1rad/s", "2rad/s", "-v"], "verbose", True),
])
def test_argparse_accepts(argv, attr, expected):
    value = getattr(parse(argv), attr)
    if isinstance(expected, list):
        assert value == [exact(e) for e in expected]
    else:
        assert value == exact(expected)


def test_argparse_needs_normalization_for_negative_suffixed_values(capsys):
    with pytest.raises(SystemExit) as info:
        make_parser().parse_args(["--h0", "-5nm"])
    assert info.value.code == 2
    assert "expected one argument" in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "message"), [
    (["--t-end", "5nm"], "argument --t-end: expected a time (s, ms, us/µs, ns, min), got '5nm'"),
    (["--h0", "-5xm"], "argument --h0: unknown unit 'xm' in '-5xm' for a length"),
    (["--E", "1,5GPa"], "argument --E: commas are not accepted in '1,5GPa'"),
    (["--omega", "1Hz", "-2nm"], "argument --omega: expected an angular frequency"),
    (["--h0", "nan"], "argument --h0: a length must be finite, got 'nan'"),
    (["--speed", ""], "argument --speed: empty string is not a speed"),
    # lengths, times, speeds and frequencies need their unit (a bare number is not SI here)
    (["--h0", "-3"], "argument --h0: -3 has no unit: write -3nm, -3um or -3m (a length needs "
                     "its unit: m, cm, mm, um/µm, nm, pm, Å/angstrom)"),
    (["--h0", "2e-9"], "argument --h0: 2e-9 has no unit: write 2e-9m (a length"),
    (["--h0", "0"], "argument --h0: 0 has no unit: write 0nm, 0um or 0m"),
    (["--t-end", "5"], "argument --t-end: 5 has no unit: write 5ms or 5s (a time needs its "
                       "unit"),
    (["--speed", "5"], "argument --speed: 5 has no unit: write 5um/s, 5nm/s or 5m/s"),
    (["--omega", "100"], "argument --omega: 100 has no unit: write 100Hz (f = 100 Hz, "
                         "ω = 628 rad/s) or 100rad/s"),
])
def test_argparse_errors_exit_2_with_the_unit_message(argv, message, capsys):
    with pytest.raises(SystemExit) as info:
        parse(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert message in err
    assert "Traceback" not in err


def test_quantity_type_callable():
    length = quantity_type("length")
    assert length("-5nm") == -5e-9
    assert length.__name__ == "length"
    assert repr(length) == "quantity_type('length')"
    assert quantity_type("angular_frequency").__name__ == "angular frequency"
    with pytest.raises(argparse.ArgumentTypeError, match=r"expected a length .*got '5ms'") as info:
        length("5ms")
    assert isinstance(info.value.__cause__, UnitError)


def test_normalize_negative_args_rewrites():
    argv = ["--h0", "-5nm", "--to", "-10nm", "--omega", "1", "-2", "-3kHz", "--E", "1GPa"]
    original = list(argv)
    out = normalize_negative_args(argv, VALUE_OPTIONS, MULTI_OPTIONS)
    assert out == ["--h0=-5nm", "--to=-10nm", "--omega", "1", " -2", " -3kHz", "--E", "1GPa"]
    assert argv == original  # input not modified


@pytest.mark.parametrize("argv", [
    ["--h0=-5nm"],                       # already joined
    ["--h0", "5nm"],                     # not negative
    ["--h0"],                            # value missing: argparse reports it
    ["--h0", "-v"],                      # an option, not a value
    ["--h0", "-"],                       # a lone dash
    ["--name", "-5nm"],                  # not a value option
    ["--", "--h0", "-5nm"],              # after "--" nothing is touched
    ["--omega", "1", "--", "-2"],
    [],
])
def test_normalize_negative_args_leaves_alone(argv):
    assert normalize_negative_args(argv, VALUE_OPTIONS, MULTI_OPTIONS) == argv


def test_normalize_negative_args_accepts_any_iterables():
    out = normalize_negative_args(iter(["--h0", "-5nm", "--omega", "-1"]), ("--h0",),
                                  frozenset({"--omega"}))
    assert out == ["--h0=-5nm", "--omega", " -1"]
    # without multi_value_options, a multi-value option's negative values are left alone
    assert normalize_negative_args(["--omega", "-1"], {"--h0"}) == ["--omega", "-1"]


def test_quantity_type_rejects_unknown_dimension_at_once():
    with pytest.raises(ParameterError, match=r"dimension must be one of"):
        quantity_type("area")


# --------------------------------------------------------------------------------------------
# integers and plain numbers
# --------------------------------------------------------------------------------------------

@pytest.mark.parametrize(("text", "expected"), [("5", 5), (" 7 ", 7), ("+3", 3), ("2", 2)])
def test_integer_type_accepts_plain_integers(text, expected):
    assert integer_type(2)(text) == expected


@pytest.mark.parametrize(("text", "message"), [
    ("2.5", r"expected a plain integer >= 1 \(no unit, no decimal point\), got '2.5'"),
    ("1Hz", r"expected a plain integer >= 1 .*got '1Hz'"),
    ("1e3", r"expected a plain integer"),
    ("", r"expected a plain integer"),
    ("0", r"must be an integer >= 1, got 0"),
    ("-4", r"must be an integer >= 1, got -4"),
])
def test_integer_type_rejects(text, message):
    with pytest.raises(argparse.ArgumentTypeError, match=message):
        integer_type(1)(text)


def test_integer_type_maximum_is_an_effort_limit():
    count = integer_type(2, 100, what="output samples")
    assert count("100") == 100
    with pytest.raises(argparse.ArgumentTypeError,
                       match=r"output samples: about 101 needed, beyond the limit of 100; "
                             r"refused before computing"):
        count("101")
    assert repr(count) == "integer_type(2, 100)"


@pytest.mark.parametrize(("text", "expected"), [("1", 1.0), ("2.5", 2.5), ("1e1", 10.0)])
def test_real_type_accepts(text, expected):
    assert real_type(1)(text) == expected


@pytest.mark.parametrize(("text", "message"), [
    ("0.5", r"must be >= 1, got '0.5'"),
    ("inf", r"must be finite"),
    ("nan", r"must be finite"),
    ("2Hz", r"'Hz' is a unit of frequency"),
    ("ten", r"cannot read 'ten'"),
])
def test_real_type_rejects(text, message):
    with pytest.raises(argparse.ArgumentTypeError, match=message):
        real_type(1)(text)


# --------------------------------------------------------------------------------------------
# frequency lists
# --------------------------------------------------------------------------------------------

def omega_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="p")
    parser.add_argument("--omega", nargs="+", type=quantity_type("angular_frequency"),
                        action=OmegaList)
    parser.add_argument("--omega-range", nargs=3, action=OmegaRange)
    return parser


def parse_omega(argv):
    parser = omega_parser()
    return parser.parse_args(normalize_negative_args(argv, *value_options(parser)))


def test_omega_range_reads_quantities_and_a_plain_count():
    assert parse_omega(["--omega-range", "1Hz", "1kHz", "5"]).omega_range == (
        exact(TWO_PI), exact(1000 * TWO_PI), 5)
    assert parse_omega(["--omega-range", "10rad/s", "1e5rad/s", "1"]).omega_range == (
        10.0, 1e5, 1)


@pytest.mark.parametrize(("argv", "message"), [
    (["--omega-range", "10Hz", "100Hz", "1Hz"], r"argument --omega-range: expected a plain integer"),
    (["--omega-range", "10Hz", "100Hz", "2.5"], r"argument --omega-range: expected a plain integer"),
    (["--omega-range", "10Hz", "100Hz", "0"], r"must be an integer >= 1, got 0"),
    (["--omega-range", "100rad/s", "10rad/s", "5"],
     r"needs 0 < LO < HI, got LO = 100 rad/s, HI = 10 rad/s"),
    (["--omega-range", "-1Hz", "10Hz", "5"], r"needs 0 < LO < HI"),
    (["--omega-range", "10Hz", "10Hz", "5"], r"needs 0 < LO < HI"),
    (["--omega-range", "1nm", "10Hz", "5"], r"expected an angular frequency"),
    (["--omega-range", "10", "100Hz", "5"], r"argument --omega-range: 10 has no unit: write 10Hz"),
    (["--omega-range", "10Hz", "100Hz", str(_limits.MAX_SAMPLES + 1)],
     r"frequencies: about 1e\+07 needed, beyond the limit of 1e\+07; refused before computing"),
])
def test_omega_range_errors(argv, message, capsys):
    with pytest.raises(SystemExit) as info:
        parse_omega(argv)
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert any(__import__("re").search(message, line) for line in err.splitlines()), err


def test_omega_list_is_bounded(monkeypatch, capsys):
    monkeypatch.setattr(_limits, "MAX_SAMPLES", 2)
    assert parse_omega(["--omega", "1rad/s", "2rad/s"]).omega == [1.0, 2.0]
    with pytest.raises(SystemExit):
        parse_omega(["--omega", "1rad/s", "2rad/s", "3rad/s"])
    assert "frequencies: about 3 needed, beyond the limit of 2" in capsys.readouterr().err


def test_value_options_lists_single_and_multi_value_options():
    single, multi = value_options(omega_parser())
    assert multi == {"--omega", "--omega-range"}
    assert single == set()  # -h takes no value
    parser = argparse.ArgumentParser()
    add_flags(parser, SYSTEM_FLAGS)
    parser.add_argument("--json", action="store_true")
    assert value_options(parser) == ({"--radius", "--R", "--pressure", "--P", "--wall-pressure",
                                      "--Pw", "--z0", "--debye-length"}, set())


# --------------------------------------------------------------------------------------------
# flag tables
# --------------------------------------------------------------------------------------------

def test_shared_tables_hold_the_contract_flags_and_paper_defaults():
    assert [f.flag for f in SYSTEM_FLAGS.flags] == ["--radius", "--pressure", "--wall-pressure",
                                                    "--z0", "--debye-length"]
    # the SPEC's CLI contract spellings keep working beside the long names
    assert [f.aliases for f in SYSTEM_FLAGS.flags][:3] == [("--R",), ("--P",), ("--Pw",)]
    assert [f.dest for f in SYSTEM_FLAGS.flags][:3] == ["R", "P", "Pw"]
    assert [f.default for f in SYSTEM_FLAGS.flags] == [PAPER.R, PAPER.P, PAPER.Pw, PAPER.z0,
                                                       PAPER.debye_length]
    assert [f.flag for f in MATERIAL_FLAGS.flags] == ["--modulus", "--E0", "--E-inf", "--tau",
                                                      "--prony"]
    assert MATERIAL_FLAGS.flags[0].aliases == ("--E",) and MATERIAL_FLAGS.flags[0].dest == "E"
    assert [f.flag for f in NUMERICS_FLAGS.flags] == ["--grid-spacing", "--outer-radius"]
    assert "(default 10um)" in SYSTEM_FLAGS.flags[0].help
    assert "E0=10GPa" in MATERIAL_FLAGS.title


def test_add_flags_parses_quantities_with_defaults():
    parser = argparse.ArgumentParser()
    for group in (SYSTEM_FLAGS, MATERIAL_FLAGS, NUMERICS_FLAGS):
        add_flags(parser, group)
    add_flags(parser, FlagGroup(None, (Flag("--n", integer_type(1), 3, "N", "a count"),
                                       Flag("--from", "length", None, "L", "start", dest="from_",
                                            required=True))))
    args = parser.parse_args(["--R", "20um", "--tau", "2ms", "--from=-1nm"])
    assert (args.R, args.P, args.debye_length, args.tau, args.E, args.n, args.from_) == (
        exact(20e-6), PAPER.P, PAPER.debye_length, exact(2e-3), None, 3, exact(-1e-9))
    assert args.prony is None and args.grid_spacing is None


# --------------------------------------------------------------------------------------------
# output paths
# --------------------------------------------------------------------------------------------

def test_figure_formats_come_from_matplotlib():
    """That this loads no pyplot is checked in a fresh interpreter by
    tests/project/test_install_weight.py (one interpreter for all such checks)."""
    formats = figure_formats()
    assert {"png", "pdf", "svg", "eps", "ps", "jpg", "jpeg", "tif", "tiff", "webp"} <= set(formats)


def test_check_output_paths_accepts_writable_files(tmp_path):
    check_output_paths([("--out", str(tmp_path / "a.nc"), NETCDF),
                        ("--plot", str(tmp_path / "a.PNG"), FIGURE),
                        ("--other", None, FIGURE)])
    assert list(tmp_path.iterdir()) == []  # checking writes nothing


@pytest.mark.parametrize(("outputs", "message"), [
    ([("--plot", "{d}/out.xyz", FIGURE)], r"--plot .*/out.xyz: unsupported figure format '\.xyz'; "
                                          r"supported: .*\.pdf.*\.png.*\.svg"),
    ([("--plot", "{d}", FIGURE)], r"is a directory; give a file name"),
    ([("--plot", "{d}/name", FIGURE)], r"no file extension to choose the figure format; end the "
                                       r"name in one of .*\.png"),
    ([("--out", "{d}/x", NETCDF), ("--plot", "{d}/x", FIGURE)], r"--plot .*/x: the same file as "
                                                                 r"--out"),
    ([("--out", "{d}/x.png", NETCDF)], r"a netCDF file name must end in \.nc"),
    ([("--out", "{d}/run.csv", NETCDF)], r"a netCDF file name must end in \.nc"),
    ([("--out", "{d}/missing/run.nc", NETCDF)], r"directory '.*/missing' does not exist"),
    ([("--plot", "{d}/missing/f.png", FIGURE)], r"directory '.*/missing' does not exist"),
    ([("--out", "", NETCDF)], r"--out: empty file name"),
    ([("--out", "{d}/f.txt", "directory")], r"exists and is not a directory"),
])
def test_check_output_paths_refuses(tmp_path, outputs, message):
    (tmp_path / "f.txt").write_text("")
    outputs = [(flag, path.format(d=tmp_path), kind) for flag, path, kind in outputs]
    with pytest.raises(UsageError, match=message):
        check_output_paths(outputs)


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes anywhere")
def test_check_output_paths_refuses_read_only_directory(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o500)
    with pytest.raises(UsageError, match=r"is not writable"):
        check_output_paths([("--out", str(ro / "a.nc"), NETCDF)])


def test_main_uses_the_same_checks(tmp_path, capsys):
    assert main(["static", "--h0", "2nm", "--E", "1e9", "--out", str(tmp_path / "s.txt")]) == 2
    assert "--out" in capsys.readouterr().err
