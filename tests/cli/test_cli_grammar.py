"""One CLI grammar (issue 23 item 3): long names beside the SPEC's spellings, frequencies with
units, ``--out`` a data file and ``--plot`` a figure, ``--json`` everywhere, errors that name the
flag typed."""

from __future__ import annotations

import argparse
import json

import pytest

from viscoforce.cli import main
from viscoforce.cli._args import (
    frequency_type,
    name_flag_in_error,
    name_typed_option,
    typed_flags,
    unitless_frequency_message,
)
from viscoforce.data import example_path

TWO_PI = 6.283185307179586


def run_json(capsys, argv):
    code = main(argv)
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return json.loads(captured.out)


# ── long names and their aliases ─────────────────────────────────────────────────────────────────

@pytest.mark.parametrize(("long", "short"), [
    (["--radius", "20um"], ["--R", "20um"]),
    (["--pressure", "2e7Pa"], ["--P", "2e7Pa"]),
    (["--wall-pressure", "2e7Pa"], ["--Pw", "2e7Pa"]),
    (["--modulus", "2GPa"], ["--E", "2GPa"]),
])
def test_long_names_and_the_spec_spellings_give_the_same_answer(capsys, long, short):
    base = ["static", "--h0", "2nm", "--json"]
    modulus = [] if "--modulus" in long else ["--modulus", "1GPa"]
    assert run_json(capsys, [*base, *modulus, *long]) == run_json(capsys, [*base, *modulus, *short])


def test_workers_and_jobs_are_one_flag(capsys):
    argv = ["spectrum", "--h0", "2nm", "--eta", "0.01nm", "--omega", "1kHz", "--method",
            "time-domain", "--periods", "1", "--json"]
    assert run_json(capsys, [*argv, "--workers", "1"]) == run_json(capsys, [*argv, "--jobs", "1"])


def test_format_help_lists_the_registry(capsys):
    from viscoforce.io.instruments import FORMATS

    for command in ("load", "fit", "bode"):
        assert main([command, "--help"]) == 0
        text = " ".join(capsys.readouterr().out.split())
        assert all(f.name in text for f in FORMATS), command


# ── frequencies need a unit ──────────────────────────────────────────────────────────────────────

def test_frequency_type_reads_hz_and_rad_s_and_refuses_bare_numbers():
    omega, f = frequency_type(), frequency_type("frequency")
    assert omega("100rad/s") == 100.0 and omega("1Hz") == pytest.approx(TWO_PI)
    assert f("10Hz") == 10.0 and f(f"{TWO_PI}rad/s") == pytest.approx(1.0)
    for parse in (omega, f):
        with pytest.raises(argparse.ArgumentTypeError, match="100 has no unit: write 100Hz"):
            parse("100")
    with pytest.raises(argparse.ArgumentTypeError, match="expected a frequency"):
        f("5nm")


def test_the_unitless_message_spells_out_both_readings():
    assert unitless_frequency_message("100", 100.0) == (
        "100 has no unit: write 100Hz (f = 100 Hz, ω = 628 rad/s) or 100rad/s "
        "(ω = 100 rad/s, f = 15.9 Hz)")


@pytest.mark.parametrize("argv", [
    ["simulate", "--drive", "sine", "--h0", "2nm", "--eta", "0.1nm", "--omega", "100"],
    ["spectrum", "--h0", "2nm", "--eta", "0.1nm", "--omega", "100"],
    ["spectrum", "--h0", "2nm", "--eta", "0.1nm", "--omega-range", "10", "1kHz", "3"],
])
def test_a_bare_frequency_is_refused_with_the_flag(capsys, argv):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "has no unit: write" in err and "rad/s" in err and "Traceback" not in err


# ── errors name the flag typed ───────────────────────────────────────────────────────────────────

def test_argparse_errors_name_the_spelling_typed():
    message = "argument --radius/--R: unknown unit"
    assert name_typed_option(message, ["--R", "5parsec"]) == "argument --R: unknown unit"
    assert name_typed_option(message, ["--radius=5parsec"]) == "argument --radius: unknown unit"
    assert name_typed_option(message, []) == message


def test_library_errors_are_told_in_terms_of_the_flag():
    parser = argparse.ArgumentParser()
    parser.add_argument("--h0")
    parser.add_argument("--radius", "--R", dest="R")
    parser.add_argument("--json", action="store_true")
    typed = typed_flags(parser, ["--h0", "-5mm", "--R=0", "--json"])
    assert typed == {"h0": ("--h0", "-5mm"), "R": ("--R", "0"), "json": ("--json", None)}
    assert name_flag_in_error("deepest_position must be >= -0.1 R, got -0.005", typed) == (
        "--h0 -5mm: the deepest position must be >= -0.1 R, got -0.005")
    assert name_flag_in_error("radius (R) must be > 0", typed) == (
        "--R 0: the radius (R) must be > 0")
    assert name_flag_in_error("tau must be > 0", typed) == "tau must be > 0"  # not typed
    assert name_flag_in_error("result outside the model", typed) == "result outside the model"


def test_h0_in_millimetres_blames_h0(capsys):
    assert main(["static", "--h0", "-5mm", "--modulus", "1GPa"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("viscoforce static: error: --h0 -5mm: the deepest position")
    assert "deepest_position" not in err


# ── bode: --plot a figure, --out data, --json ────────────────────────────────────────────────────

SPECTRUM_CSV = str(example_path("sls_spectrum.csv"))


def test_bode_plot_out_and_json(capsys, tmp_path):
    png, nc = tmp_path / "bode.png", tmp_path / "fit.nc"
    out = run_json(capsys, ["bode", SPECTRUM_CSV, "--plot", str(png), "--out", str(nc),
                            "--fit", "exact", "--h0=-5nm", "--json"])
    assert png.stat().st_size > 10_000 and nc.is_file()
    assert out["plot"] == str(png) and out["out"] == str(nc)
    assert len(out["omega"]) == len(out["stiffness"]) == len(out["phase_deg"]) > 3
    assert out["fit"]["model"] == "exact" and "E0" in out["fit"]["params"]
    import xarray as xr

    with xr.open_dataset(nc) as fit:
        assert "E0_stderr" in fit


def test_bode_out_png_is_still_the_figure(capsys, tmp_path):
    png = tmp_path / "old.png"
    assert main(["bode", SPECTRUM_CSV, "--out", str(png)]) == 0
    assert png.stat().st_size > 10_000 and f"wrote {png}" in capsys.readouterr().out
    assert main(["bode", SPECTRUM_CSV, "--out", str(png), "--plot",
                 str(tmp_path / "new.png")]) == 2
    assert "the old spelling of --plot" in capsys.readouterr().err


def test_bode_out_nc_without_a_fit_writes_the_spectrum(capsys, tmp_path):
    import xarray as xr

    nc = tmp_path / "spectrum.nc"
    assert main(["bode", SPECTRUM_CSV, "--out", str(nc)]) == 0
    with xr.open_dataset(nc) as ds:
        assert "stiffness" in ds and "omega" in ds.dims


def test_every_command_has_json(capsys):
    from viscoforce.cli import COMMANDS

    for command in COMMANDS:
        assert main([command.name, "--help"]) == 0
        assert "--json" in capsys.readouterr().out, command.name


# ── one formatter ────────────────────────────────────────────────────────────────────────────────

def test_numbers_print_with_units_and_three_significant_digits():
    from viscoforce.cli._output import format_estimate, format_value

    assert format_value(3691245895633.2104, "Pa") == "3.69e+03 GPa"
    assert format_estimate(4.97e9, 37.3e6, "Pa") == "4.97 GPa ± 37.3 MPa"
    assert format_estimate(5.0474e-3, 73.5e-6, "s") == "5.05 ms ± 73.5 µs"
    assert format_estimate(0.575, float("nan"), "1") == "0.575 (no stderr)"
    assert format_value(2.21, "Pa s") == "2.21 Pa s" and format_value(None, "Pa") == "n/a"


def test_fit_summaries_use_the_formatter(capsys, tmp_path):
    assert main(["fit", SPECTRUM_CSV, "--model", "exact", "--h0=-5nm"]) == 0
    text = capsys.readouterr().out
    assert "E0       = 4.94 GPa ± 51 MPa" in text and "tau      = 5.05 ms ± 73.5 µs" in text
    assert main(["fit", str(example_path("sls_spectrum_map.nc")), "--model", "exact",
                 "--h0=-5nm"]) == 0
    text = capsys.readouterr().out
    assert "E0       median 4.26 GPa, IQR 3.57 GPa .. 5.13 GPa" in text
