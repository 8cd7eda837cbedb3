"""A file that lacks what a job needs is refused naming what is missing and the route that works.

* NT-MDT text exports carry no calibration. ``fit`` has no ``--spring-constant``/``--sensitivity``
  flags (they are ``load``'s), so the refusal names the route that works from either command:
  ``viscoforce load FILE --spring-constant K --sensitivity S --out curves.nc``, then
  ``viscoforce fit curves.nc``; the test runs that route.
* The AFM Workshop export has a height (its Z-Sense column) and the force in nN, but no spring
  constant: the deflection (force / k) and so the tip position are unknown. The reader says so in
  ``attrs["tip_position_channel"]`` (not "no tip position" or "no height"), with the flag that
  supplies it; a hertz fit of the file refuses naming the missing spring constant.

Real files from ``../shared/data/real/afmformats`` (MIT, see its SOURCE.txt); skipped cleanly when
they are absent.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from viscoforce.cli import main
from viscoforce.exceptions import InstrumentFormatError

pytest.importorskip("afmformats")

REAL = Path(__file__).resolve().parents[3] / "shared" / "data" / "real" / "afmformats"
NTMDT = "fmt-ntmdt-txt-fd_2015_01_17_gel4-0_1_mQ_adh_6B_Curve_DFL_Height_51.txt"
WORKSHOP = "fmt-afm-workshop-fd_single_2021-10-22_14.16.csv"


def _real(name: str) -> Path:
    path = REAL / name
    if not path.is_file():
        pytest.skip(f"real file {name} not present in {REAL}")
    return path


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _cli(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


# ── NT-MDT: no calibration in the file ────────────────────────────────────────────────────────

def test_ntmdt_refusal_names_the_load_route_in_the_library():
    from viscoforce.io.afm import read_afmformats

    path = _real(NTMDT)
    with pytest.raises(InstrumentFormatError) as info:
        read_afmformats(path)
    message = str(info.value)
    assert message.startswith(f"{path}: NT-MDT text exports carry no calibration; "
                              "spring_constant and sensitivity missing: pass spring_constant "
                              "[N/m] and sensitivity [m/V] to the reader")
    assert (f"on the command line these are `load` flags: run `viscoforce load {path} "
            "--spring-constant K --sensitivity S --out curves.nc` (K and S: your cantilever's, "
            "e.g. 0.1N/m and 50nm/V), then `viscoforce fit curves.nc ...`") in message


@pytest.mark.parametrize("command", ["fit", "load"])
def test_ntmdt_refusal_on_the_command_line_tells_a_route_that_works(capsys, tmp_path, command):
    path = _real(NTMDT)
    before = _sha(path)
    extra = (["--model", "hertz", "--tip", "sphere:5um"] if command == "fit"
             else ["--out", tmp_path / "x.nc"])
    code, _, err = _cli(capsys, command, path, *extra)
    assert code == 2 and "Traceback" not in err
    assert f"viscoforce load {path} --spring-constant K --sensitivity S --out curves.nc" in err
    assert "then `viscoforce fit curves.nc" in err
    assert "(CLI: --spring-constant" not in err  # the old hint, which fit rejects
    assert not (tmp_path / "x.nc").exists()
    assert _sha(path) == before


def test_the_route_the_ntmdt_refusal_names_works(capsys, tmp_path):
    path = _real(NTMDT)
    curves = tmp_path / "curves.nc"
    code, _, err = _cli(capsys, "load", path, "--spring-constant", "0.1N/m", "--sensitivity",
                        "50nm/V", "--out", curves)
    assert code == 0, err
    code, out, err = _cli(capsys, "fit", curves, "--model", "hertz", "--tip", "sphere:5um",
                          "--json")
    assert code == 0, err
    assert json.loads(out)["params"]["E"]["value"] > 0


def test_fit_takes_no_calibration_flags_which_is_why_the_route_goes_through_load(capsys):
    path = _real(NTMDT)
    code, _, err = _cli(capsys, "fit", path, "--model", "hertz", "--spring-constant", "0.1N/m")
    assert code == 2 and "unrecognized arguments: --spring-constant" in err


# ── AFM Workshop: a height, a force, no spring constant ───────────────────────────────────────

def test_workshop_file_says_the_spring_constant_is_missing_not_the_height():
    from viscoforce.io.afm import read_afmformats

    path = _real(WORKSHOP)
    ds = read_afmformats(path)
    assert ds.attrs["height_channel"] == "height (measured)"
    assert np.isfinite(ds["height"].values).all()  # the file has a height ...
    assert np.isnan(ds["tip_position"].values).all()  # ... but no tip position without k
    note = ds.attrs["tip_position_channel"]
    assert note.startswith("unavailable: the file has a height (the Z-Sense column, read as "
                           "'height (measured)') and the force but no spring constant, so the "
                           "deflection (force / spring constant) and the tip position "
                           "(-height - deflection) are unknown; pass spring_constant [N/m] to "
                           "the reader")
    assert (f"it is a `load` flag: run `viscoforce load {path} --spring-constant K --out "
            "curves.nc`") in note
    assert "--sensitivity" not in note  # the force is in nN: the sensitivity is not needed
    calibrated = read_afmformats(path, spring_constant=0.1)
    assert "tip_position_channel" not in calibrated.attrs
    assert np.isfinite(calibrated["tip_position"].values).all()


def test_the_note_survives_load_to_netcdf(capsys, tmp_path):
    path = _real(WORKSHOP)
    code, _, err = _cli(capsys, "load", path, "--out", tmp_path / "c.nc")
    assert code == 0, err
    import xarray as xr

    with xr.open_dataset(tmp_path / "c.nc") as ds:
        assert "no spring constant" in ds.attrs["tip_position_channel"]


def test_the_route_the_workshop_note_names_works(capsys, tmp_path):
    path = _real(WORKSHOP)
    curves = tmp_path / "curves.nc"
    code, _, err = _cli(capsys, "load", path, "--spring-constant", "0.1N/m", "--out", curves)
    assert code == 0, err
    code, out, err = _cli(capsys, "fit", curves, "--model", "hertz", "--tip", "sphere:5um",
                          "--json")
    assert code == 0, err
    assert json.loads(out)["params"]["E"]["value"] > 0


def test_a_hertz_fit_of_the_workshop_file_names_the_missing_spring_constant(capsys):
    path = _real(WORKSHOP)
    code, _, err = _cli(capsys, "fit", path, "--model", "hertz", "--tip", "sphere:5um")
    assert code == 2 and "Traceback" not in err
    assert "no spring constant" in err and "--spring-constant K" in err
    assert "gives no tip position" not in err


def test_workshop_volts_refusal_names_both_calibrations_and_the_load_route(tmp_path):
    from viscoforce.io.afm import read_afmformats

    text = _real(WORKSHOP).read_text(encoding="latin-1").replace("Force(nN)", "T-B(V)")
    path = tmp_path / "volts.csv"
    path.write_text(text, encoding="latin-1")
    with pytest.raises(InstrumentFormatError) as info:
        read_afmformats(path)
    message = str(info.value)
    assert f"viscoforce load {path} --spring-constant K --sensitivity S --out curves.nc" in message
    assert "(CLI: --spring-constant" not in message
