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
