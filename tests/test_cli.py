"""Command-line contract of ``viscoforce static`` (flags and --json keys are public)."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
import xarray as xr

from viscoforce.cli import main


def run_json(capsys, argv):
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("argv", [["--h0", "-5nm", "--E", "1e9Pa"], ["--h0=-5nm", "--E=1GPa"],
                                  ["--h0", "-5e-9", "--E", "1e9"]])
def test_static_json_keys_and_values(capsys, argv):
    out = run_json(capsys, ["static", *argv, "--json"])
    for key in ("h0", "force", "force_rigid", "u_center", "h_center", "contact_radius"):
        assert key in out
    assert out["h0"] == pytest.approx(-5e-9)
    assert out["force"] == pytest.approx(1.08e-6, abs=0.005e-6)
    assert out["force_rigid"] is None  # undeformed bodies overlap: infinite rigid load
    assert out["h_center"] == pytest.approx(out["h0"] - out["u_center"])


def test_static_system_flags_change_the_answer(capsys):
    base = run_json(capsys, ["static", "--h0", "2nm", "--E", "1e9", "--json"])
    bigger = run_json(capsys, ["static", "--h0", "2nm", "--E", "1e9", "--R", "20um", "--json"])
    assert bigger["force"] > 1.5 * base["force"]
    assert base["force_rigid"] == pytest.approx(2 * 3.141592653589793 * 10e-6 * (
        1e7 * 1e-9 * 0.1353352832366127 + 1e7 * 0.5e-9 * 0.25**8 / 8), rel=1e-12)


def test_static_human_output_and_netcdf(capsys, tmp_path):
    out = tmp_path / "s.nc"
    assert main(["static", "--h0", "-3nm", "--E", "1e9", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "load F" in text and "659 nN" in text
    with xr.open_dataset(out, engine="scipy") as ds:
        assert float(ds.force) == pytest.approx(0.659e-6, rel=2e-3)


@pytest.mark.parametrize(("argv", "message"), [
    (["static", "--h0", "5s", "--E", "1e9"], "expected a length"),
    (["static", "--h0", "-5nm", "--E", "-1e9"], "E must be > 0"),
    (["static", "--h0", "-30nm", "--E", "1e9", "--outer-radius", "500nm"], "too small"),
    (["static", "--E", "1e9"], "required"),
    (["static", "--h0", "1,5nm", "--E", "1e9"], "1.5nm"),
])
def test_user_errors_exit_2_with_one_message(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_python_dash_m_entry_point():
    proc = subprocess.run([sys.executable, "-m", "viscoforce", "static", "--h0", "2nm", "--E",
                           "1e9", "--json"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["u_center"] == pytest.approx(-0.46e-9, abs=0.005e-9)


def test_simulate_triangle_json_contract(capsys):
    out = run_json(capsys, ["simulate", "--drive", "triangle", "--from", "10nm", "--to", "-5nm",
                            "--speed", "5um/s", "--t-end", "6ms", "--samples", "31", "--json"])
    for key in ("time", "position", "force", "u_center", "contact_radius", "settings"):
        assert key in out
    assert len(out["time"]) == 31 and out["time"][-1] == pytest.approx(6e-3)
    assert min(out["position"]) == pytest.approx(-5e-9)
    assert out["settings"]["stepper"] == "exponential" and out["settings"]["tau"] == 1e-3


@pytest.mark.parametrize("argv", [
    ["--drive", "step", "--from", "-5nm", "--to", "-7nm", "--t-end", "5ms"],
    ["--drive", "ramp", "--from", "5nm", "--to", "-2nm", "--speed", "5um/s", "--E", "1e9"],
    ["--drive", "sine", "--h0", "2nm", "--eta", "0.1nm", "--omega", "1kHz", "--periods", "2"],
    ["--drive", "step", "--from=-5nm", "--to=-3nm", "--method", "euler", "--t-end", "2ms"],
])
def test_simulate_drives(capsys, argv):
    out = run_json(capsys, ["simulate", *argv, "--samples", "11", "--json"])
    assert all(f > 0 for f in out["force"])


def test_simulate_trace_and_prony_files_and_netcdf(capsys, tmp_path):
    trace = tmp_path / "trace.csv"
    trace.write_text("time (ms),position (nm)\n0,5\n1,-3\n2,5\n")
    prony = tmp_path / "prony.csv"
    prony.write_text("modulus (GPa),tau (ms)\n10,0.2\n4,1\n1,\n")
    nc = tmp_path / "run.nc"
    out = run_json(capsys, ["simulate", "--drive", "trace", "--trace", str(trace), "--prony",
                            str(prony), "--samples", "9", "--out", str(nc), "--json"])
    assert out["settings"]["material"] == "PronySeries"
    assert out["time"][-1] == pytest.approx(2e-3 + 5e-3)  # drive end + 5 tau_max
    with xr.open_dataset(nc, engine="scipy") as ds:
        assert ds.force.attrs["units"] == "N"


@pytest.mark.parametrize(("argv", "message"), [
    (["simulate", "--drive", "ramp", "--from", "5nm"], "--drive ramp needs --to"),
    (["simulate", "--drive", "triangle", "--from", "10nm", "--to", "-5nm", "--speed", "5um/s",
      "--E", "1e9", "--tau", "1ms"], "give one material"),
    (["simulate", "--drive", "sine", "--h0", "2nm", "--eta", "0.1nm"], "needs --omega"),
    (["simulate", "--drive", "trace", "--trace", "/nonexistent.csv"], "file not found"),
    (["simulate", "--drive", "triangle", "--from", "10nm", "--to", "-10nm", "--speed", "5um/s",
      "--method", "euler", "--dt", "0.5ms", "--samples", "2"], "unstable"),
    (["simulate", "--drive", "step", "--from", "-5nm", "--to", "-7nm", "--E0", "1e9",
      "--E-inf", "1e10"], "E0 (instantaneous modulus) must be > E_inf"),
])
def test_simulate_user_errors(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_trace_reader_errors(tmp_path):
    from viscoforce.exceptions import UnitError
    from viscoforce.io.tables import read_trace

    p = tmp_path / "t.csv"
    p.write_text("time,position (nm)\n0,1\n1,2\n")
    with pytest.raises(UnitError, match="has no unit"):
        read_trace(p)
    p.write_text("time (s),position (nm)\n0,1\n1,\"2,5\"\n")
    with pytest.raises(ValueError, match="decimal commas"):
        read_trace(p)
    p.write_text("time (s),height (nm)\n0,1\n")
    with pytest.raises(ValueError, match="no column 'position"):
        read_trace(p)
    p.write_text("")
    with pytest.raises(ValueError, match="not a readable CSV"):
        read_trace(p)


def test_spectrum_json_contract_and_plot(capsys, tmp_path):
    png = tmp_path / "bode.png"
    out = run_json(capsys, ["spectrum", "--h0", "2nm", "--eta", "0.1nm", "--omega-range", "10",
                            "1e5", "7", "--json", "--plot", str(png)])
    for key in ("omega", "amplitude", "stiffness", "phase_deg", "mean_force", "method"):
        assert key in out
    assert out["method"] == "linear" and len(out["omega"]) == 7
    assert max(out["phase_deg"]) == pytest.approx(7.0, abs=0.6)
    assert out["mean_force"][0] == pytest.approx(61.0e-9, abs=0.05e-9)
    assert png.stat().st_size > 10_000


def test_spectrum_methods_and_auto(capsys):
    svda = run_json(capsys, ["spectrum", "--h0", "2nm", "--eta", "0.1nm", "--omega", "1kHz",
                             "--method", "svda", "--json"])
    assert svda["method"] == "svda"
    auto = run_json(capsys, ["spectrum", "--h0", "2nm", "--eta", "0.01nm", "--omega", "100",
                             "1000", "--method", "auto", "--json"])
    assert auto["method"] == "linear" and "kappa*eta" in auto["explanation"]
    td = run_json(capsys, ["spectrum", "--h0", "2nm", "--eta", "0.01nm", "--omega", "1000",
                           "--method", "time-domain", "--periods", "2", "--json"])
    lin = run_json(capsys, ["spectrum", "--h0", "2nm", "--eta", "0.01nm", "--omega", "1000",
                            "--json"])
    assert td["stiffness"][0] == pytest.approx(lin["stiffness"][0], rel=1e-3)


@pytest.mark.parametrize(("argv", "message"), [
    (["spectrum", "--h0", "2nm", "--eta", "0.1nm"], "give either --omega"),
    (["spectrum", "--h0", "2nm", "--eta", "0.1nm", "--omega-range", "100", "10", "5"],
     "0 < LO < HI"),
    (["spectrum", "--h0", "2nm", "--eta", "0.1nm", "--omega", "-5"], "omega must be >= 0"),
    (["spectrum", "--h0", "2nm", "--eta", "-1nm", "--omega", "5"], "eta must be > 0"),
])
def test_spectrum_user_errors(capsys, argv, message):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_cli_guards_and_linear_note(capsys):
    assert main(["simulate", "--drive", "step", "--from", "-5nm", "--to", "-7nm",
                 "--samples", "1"]) == 2
    assert "--samples must be an integer >= 2" in capsys.readouterr().err
    assert main(["static", "--h0", "-5", "--E", "1e9"]) == 2
    assert "forget a unit" in capsys.readouterr().err
    out = run_json(capsys, ["spectrum", "--h0=-5nm", "--eta", "1nm", "--omega", "1000", "--json"])
    assert "time-domain" in out["note"]
