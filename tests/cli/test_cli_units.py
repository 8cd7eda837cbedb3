"""On the command line, lengths, times, speeds and frequencies need their unit (issue 38 item 2).

A bare number used to be SI, silently: ``--tip sphere:5`` fitted a 5 m sphere and ``--h0 2`` was
2 m. Now it is refused (exit 2) with a message naming the flag and the units it takes, and the
likely spelling (``--h0 2: ... write 2nm, 2um or 2m``); ``0`` too, as for a frequency. Moduli and
pressures may stay bare Pa; tip half-angles are degrees, bare or with ``deg``/``°`` (or ``rad``).
The library keeps reading a bare number as SI (:func:`viscoforce.units.parse_quantity`).
"""

from __future__ import annotations

import argparse
import json

import pytest

from viscoforce.cli import COMMANDS, _build_parser, main
from viscoforce.cli._args import quantity_type
from viscoforce.exceptions import UnitError
from viscoforce.units import UNIT_REQUIRED, missing_unit_message, parse_quantity

LENGTH_UNITS = "(a length needs its unit: m, cm, mm, um/µm, nm, pm, Å/angstrom)"
SPECTRUM = "example:sls_spectrum.csv"
CURVES = "example:sls_step_relaxation.csv"


def _run(capsys, argv):
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize(("argv", "message"), [
    (["fit", CURVES, "--model", "hertz", "--tip", "sphere:5"],
     "argument --tip: tip 'sphere:5': the radius after ':' is wrong: '5' has no unit: a length "
     "needs one (m, cm, mm, um/µm, nm, pm, Å): write sphere:5um or sphere:5nm"),
    (["fit", CURVES, "--model", "hertz", "--tip", "flat:3"],
     "argument --tip: tip 'flat:3': the radius after ':' is wrong: '3' has no unit: a length "
     "needs one (m, cm, mm, um/µm, nm, pm, Å): write flat:3um or flat:3nm"),
    (["fit", CURVES, "--model", "hertz", "--tip", "paraboloid:2e-6"],
     "write paraboloid:2e-6m"),
    (["static", "--h0", "2", "--modulus", "1GPa"],
     f"argument --h0: 2 has no unit: write 2nm, 2um or 2m {LENGTH_UNITS}"),
    (["static", "--h0", "0", "--modulus", "1GPa"],
     "argument --h0: 0 has no unit: write 0nm, 0um or 0m"),
    (["static", "--h0", "-2", "--modulus", "1GPa"],
     "argument --h0: -2 has no unit: write -2nm, -2um or -2m"),
    (["static", "--h0=-2e-9", "--modulus", "1GPa"],
     f"argument --h0: -2e-9 has no unit: write -2e-9m {LENGTH_UNITS}"),
    (["static", "--h0", "-5nm", "--modulus", "1GPa", "--R", "10"],
     "argument --R: 10 has no unit: write 10nm, 10um or 10m"),
    (["static", "--h0", "-5nm", "--modulus", "1GPa", "--radius", "10"],
     "argument --radius: 10 has no unit"),
    (["static", "--h0", "-5nm", "--modulus", "1GPa", "--debye-length", "1"],
     "argument --debye-length: 1 has no unit"),
    (["fit", SPECTRUM, "--model", "contact", "--indentation", "5"],
     "argument --indentation: 5 has no unit: write 5nm, 5um or 5m"),
    (["fit", CURVES, "--model", "ting", "--contact-point", "1"],
     "argument --contact-point: 1 has no unit: write 1nm, 1um or 1m"),
    (["fit", SPECTRUM, "--model", "exact", "--h0", "2"], "argument --h0: 2 has no unit"),
    (["bode", SPECTRUM, "--model", "exact", "--h0", "2", "--plot", "b.png"],
     "argument --h0: 2 has no unit"),
    (["simulate", "--drive", "ramp", "--from", "2nm", "--to", "1nm", "--speed", "5"],
     "argument --speed: 5 has no unit: write 5um/s, 5nm/s or 5m/s (a speed needs its unit"),
    (["simulate", "--drive", "step", "--from", "2nm", "--to", "1nm", "--duration", "1"],
     "argument --duration: 1 has no unit: write 1ms or 1s (a time needs its unit: s, ms, us/µs, "
     "ns, min)"),
    (["simulate", "--drive", "step", "--from", "2", "--to", "1nm"],
     "argument --from: 2 has no unit"),
    (["simulate", "--drive", "sine", "--h0", "2nm", "--eta", "0.1", "--omega", "1kHz"],
     "argument --eta: 0.1 has no unit"),
    (["simulate", "--drive", "step", "--from", "2nm", "--to", "1nm", "--tau", "5"],
     "argument --tau: 5 has no unit: write 5ms or 5s"),
    (["spectrum", "--h0", "2nm", "--eta", "0.1nm", "--omega", "0"],
     "argument --omega: 0 has no unit: write 0Hz"),
    (["load", "example:sls_modulation.jpk-force", "--drag-heights", "1=a.jpk-force",
      "2um=b.jpk-force", "4um=c.jpk-force"],
     "argument --drag-heights: 1 has no unit: write 1nm, 1um or 1m"),
])
def test_a_bare_length_time_speed_or_frequency_is_refused_naming_flag_and_unit(
        capsys, tmp_path, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    code, _, err = _run(capsys, argv)
    assert code == 2
    assert message in err, err
    assert "Traceback" not in err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("h0", [["--h0=-5nm"], ["--h0", "-5nm"], ["--h0", "-5 nm"],
                                ["--h0=-0.005um"]])
def test_negative_lengths_with_their_unit_work_both_ways(capsys, h0):
    code, out, err = _run(capsys, ["static", *h0, "--modulus", "1GPa", "--json"])
    assert code == 0, err
    assert json.loads(out)["h0"] == pytest.approx(-5e-9, rel=1e-15)


def test_moduli_and_pressures_may_stay_bare_pa(capsys):
    code, out, err = _run(capsys, ["static", "--h0", "2nm", "--modulus", "1e9", "--P", "1e7",
                                   "--json"])
    assert code == 0, err
    code, out2, err = _run(capsys, ["static", "--h0", "2nm", "--modulus", "1GPa", "--P",
                                    "10MPa", "--json"])
    assert json.loads(out) == json.loads(out2)


@pytest.mark.parametrize("tip", ["cone:20", "cone:20deg", "cone:20°", "pyramid:17.5deg",
                                 "cone:0.349rad"])
def test_tip_half_angles_are_degrees_bare_or_with_their_unit(tip):
    from viscoforce.physics.tips import parse_tip

    assert parse_tip(tip).half_angle_degrees == pytest.approx(
        17.5 if "17.5" in tip else 20.0, rel=1e-3)


def test_a_length_for_an_angle_is_refused_saying_angles_are_degrees(capsys):
    code, _, err = _run(capsys, ["fit", CURVES, "--model", "hertz", "--tip", "cone:5um"])
    assert code == 2
    assert ("'5um' is not a half-angle (a number in degrees, bare or with deg or °, or with rad)"
            in err)


def test_every_length_time_speed_and_frequency_flag_of_every_command_needs_its_unit():
    """Walk the parsers: a flag of these dimensions that took a bare number would be a trap."""
    checked = set()
    for command in COMMANDS:
        _, parser = _build_parser(command)
        for action in parser._actions:  # argparse has no public accessor
            dimension = getattr(action.type, "dimension", None)
            if dimension is None or not action.option_strings:
                continue
            if dimension in UNIT_REQUIRED:
                with pytest.raises(argparse.ArgumentTypeError, match="has no unit"):
                    action.type("2")
                checked.add((command.name, action.option_strings[0]))
            else:  # a modulus, a pressure, a force ...: bare SI is allowed
                assert dimension in ("pressure", "force", "stiffness", "sensitivity", "drag",
                                     "dimensionless"), (command.name, action.option_strings)
    assert {("static", "--h0"), ("static", "--radius"), ("fit", "--indentation"),
            ("fit", "--contact-point"), ("simulate", "--speed"), ("simulate", "--dt"),
            ("spectrum", "--omega")} <= checked


def test_the_library_keeps_bare_numbers_as_si():
    assert parse_quantity("2", "length") == 2.0  # documented: a bare number is SI
    assert parse_quantity(2e-9, "length", require_unit=True) == 2e-9  # a float is SI
    with pytest.raises(UnitError, match=r"^--h0: 2 has no unit: write 2nm, 2um or 2m"):
        parse_quantity("2", "length", name="--h0", require_unit=True)
    assert parse_quantity("2nm", "length", require_unit=True) == 2e-9
    assert "pressure" not in UNIT_REQUIRED  # so the command line reads a bare modulus as Pa
    assert quantity_type("pressure")("1e9") == 1e9


@pytest.mark.parametrize(("text", "dimension", "expected"), [
    ("2", "length", f"2 has no unit: write 2nm, 2um or 2m {LENGTH_UNITS}"),
    ("2e-9", "length", f"2e-9 has no unit: write 2e-9m {LENGTH_UNITS}"),
    ("5", "time", "5 has no unit: write 5ms or 5s (a time needs its unit: s, ms, us/µs, ns, min)"),
    ("5", "speed", "5 has no unit: write 5um/s, 5nm/s or 5m/s (a speed needs its unit: m/s, mm/s, "
                   "um/s/µm/s, nm/s)"),
    ("100", "angular_frequency", "100 has no unit: write 100Hz (f = 100 Hz, ω = 628 rad/s) or "
                                 "100rad/s (ω = 100 rad/s, f = 15.9 Hz)"),
])
def test_missing_unit_message(text, dimension, expected):
    assert missing_unit_message(text, dimension) == expected


def test_require_unit_must_be_a_bool():
    from viscoforce.exceptions import ParameterError

    with pytest.raises(ParameterError, match="require_unit must be True or False, got str 'yes'"):
        parse_quantity("2nm", "length", require_unit="yes")


def test_missing_unit_message_refuses_an_unknown_dimension():
    from viscoforce.exceptions import ParameterError

    with pytest.raises(ParameterError, match="dimension must be one of length, time"):
        missing_unit_message("2", "area")
