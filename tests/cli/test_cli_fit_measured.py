"""``viscoforce fit`` on measured data (issue 20): the chooser, warnings in --json, refusals."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from viscoforce.cli import main
from viscoforce.closed_form import structural_complex_modulus
from viscoforce.schema import make_spectrum

MAP = Path(__file__).resolve().parents[2] / "data_examples" / "real" / "modulation-map.jpk-force-map"
needs_map = pytest.mark.skipif(not MAP.is_file(), reason="bundled real map missing")


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def structural_file(tmp_path):
    """A structural contact spectrum (R 5 µm, δ0 0.5 µm), 1 % stderr, noiseless, as netCDF."""
    omega = 2 * np.pi * np.geomspace(0.3, 1000, 10)
    k = math.sqrt(5e-6 * 500e-9) * structural_complex_modulus(omega, 1e3, 0.15, 0.5)
    path = tmp_path / "cell.nc"
    make_spectrum(omega, k, np.full(10, 1e-9), 1e-8,
                  stderr={"stiffness": 0.01 * np.abs(k), "phase": np.full(10, np.degrees(0.01))},
                  mean_indentation=np.full(10, 500e-9)).to_netcdf(path, engine="h5netcdf")
    return path


def test_auto_on_measured_data_needs_no_h0_and_reports_its_candidates(capsys, structural_file):
    code, out, err = _run(capsys, "fit", structural_file, "--model", "auto", "--R", "5um",
                          "--json")
    assert code == 0, err
    info = json.loads(out)
    assert info["candidate"] == "structural" and info["material"] == "structural"
    assert {row["label"] for row in info["selection"]} >= {"sls", "structural", "power-law+mu"}
    assert all("bic" in row and "redchi" in row for row in info["selection"])
    assert info["chi2_pvalue"] == pytest.approx(1.0, abs=1e-6)  # noiseless, stderr given
    assert info["params"]["alpha"]["value"] == pytest.approx(0.15, rel=1e-5)
    assert info["params"]["alpha"]["identified"] == "determined"
    assert info["warnings"] == [] and info["weighting"] == "stderr"


def test_fit_json_lists_the_warnings_it_printed(capsys, structural_file):
    code, out, err = _run(capsys, "fit", structural_file, "--model", "contact", "--R", "5um",
                          "--material", "sls", "--json")
    assert code == 0, err
    info = json.loads(out)
    assert any("does not describe these data" in w for w in info["warnings"])
    for text in info["warnings"]:
        assert text in err  # the same text as stderr


def test_contact_flags_are_refused_where_they_cannot_be_honoured(capsys, structural_file):
    code, _, err = _run(capsys, "fit", structural_file, "--model", "prony", "--material",
                        "structural")
    assert code == 2 and "--model prony cannot honour --material" in err
    code, _, err = _run(capsys, "fit", structural_file, "--model", "auto", "--h0", "-5nm",
                        "--indentation", "5nm")
    assert code == 2 and "cannot honour --indentation" in err
    code, _, err = _run(capsys, "fit", structural_file, "--model", "auto", "--newtonian")
    assert code == 2 and "cannot honour --newtonian" in err
    code, _, err = _run(capsys, "fit", structural_file, "--model", "auto", "--accuracy", "1e-3")
    assert code == 2 and "--accuracy chooses between the theory's approximations" in err
    code, _, err = _run(capsys, "fit", structural_file, "--model", "contact", "--weights", "x")
    assert code == 2 and "--weights must be one of stderr, relative" in err


def test_newtonian_power_law_and_reference_frequency_flags(capsys, structural_file):
    code, out, err = _run(capsys, "fit", structural_file, "--model", "contact", "--R", "5um",
                          "--material", "power-law", "--newtonian", "--json")
    assert code == 0, err
    assert set(json.loads(out)["params"]) == {"E0", "C1", "m", "mu"}
    code, out, err = _run(capsys, "fit", structural_file, "--model", "contact", "--R", "5um",
                          "--material", "structural", "--reference-frequency", "10Hz", "--json")
    assert code == 0, err
    e_ref = json.loads(out)["params"]["E_ref"]["value"]
    assert e_ref == pytest.approx(1e3 * 10 ** 0.15, rel=1e-5)  # |E*| of the power law at 10 Hz


@needs_map
def test_real_map_curve_with_the_chooser(capsys):
    code, out, err = _run(capsys, "fit", MAP, "--model", "auto", "--curve", "0", "--R", "10um",
                          "--json")
    assert code == 0, err
    info = json.loads(out)
    assert info["candidate"] in {row["label"] for row in info["selection"]}
    assert 0.0 <= info["chi2_pvalue"] <= 1.0
    assert isinstance(info["warnings"], list) and info["validity"]


@needs_map
def test_real_map_summary_counts_good_pixels_only(capsys):
    code, out, err = _run(capsys, "fit", MAP, "--model", "contact", "--R", "10um", "--material", "structural",
                          "--scheduler", "synchronous", "--json")
    assert code == 0, err
    info = json.loads(out)
    assert info["n_fits"] == 16
    assert info["n_good"] + sum(info["left_out"].values()) == 16
    code, out, _ = _run(capsys, "fit", MAP, "--model", "contact", "--R", "10um", "--material", "structural",
                        "--scheduler", "synchronous")
    assert "good" in out and "left out of the summary" in out and "Pa" in out


@needs_map
def test_measured_data_need_the_tip_and_report_youngs_moduli(capsys):
    code, _, err = _run(capsys, "fit", MAP, "--model", "auto", "--curve", "0")
    assert code == 2 and "the moduli need the tip, which this jpk file does not record" in err
    code, _, err = _run(capsys, "fit", MAP, "--model", "auto", "--curve", "0", "--R", "10um",
                        "--tip", "cone:20")
    assert code == 2 and "give --tip or --R" in err
    code, out, err = _run(capsys, "fit", MAP, "--model", "contact", "--curve", "0", "--tip",
                          "pyramid:20", "--material", "structural", "--poisson", "0.45", "--json")
    assert code == 0, err
    info = json.loads(out)
    e_ref = info["params"]["E_ref"]["value"]
    young = info["derived"]["E_ref_young"]
    assert young["value"] == pytest.approx(e_ref * (1 - 0.45**2) / 2, rel=1e-12)
    assert info["derived"]["E_ref_shear"]["value"] == pytest.approx(young["value"] / 2.9, rel=1e-12)
    assert info["poisson"] == 0.45 and info["tip_shape"] == "pyramid"
    code, _, err = _run(capsys, "fit", MAP, "--model", "contact", "--curve", "0", "--R", "10um",
                        "--poisson", "0.7")
    assert code == 2 and "poisson must be in [0, 0.5]" in err


SR = Path(__file__).resolve().parents[3] / "shared" / "data" / "real" / "afmformats" / \
    "fmt-jpk-sr_cell1-0008.jpk-force"


@pytest.mark.skipif(not SR.is_file(), reason="real stress-relaxation file absent")
def test_relaxation_force_is_relative_to_the_free_cantilever_baseline():
    from viscoforce.fitting.curves import hold_data
    from viscoforce.io.instruments import load_instrument

    curves = load_instrument(SR)
    data = hold_data(curves)
    row = int(np.flatnonzero(curves["segment_name"].values == "pause")[-1])
    baseline = float(curves["segment_baseline"].values[row])
    raw = curves["force"].values[curves["segment"].values == row]
    np.testing.assert_allclose(data.y, raw[np.isfinite(raw)] - baseline, rtol=0, atol=1e-20)
    assert data.source["force_baseline"] == baseline
    assert "free-cantilever baseline" in data.source["force_reference"]


@needs_map
def test_fit_out_csv_is_one_row_per_pixel_with_units(capsys, tmp_path):
    import csv

    out = tmp_path / "fits.csv"
    code, _, err = _run(capsys, "fit", MAP, "--model", "contact", "--R", "10um", "--material",
                        "structural", "--scheduler", "synchronous", "--out", out)
    assert code == 0, err
    with out.open(newline="") as handle:
        rows = list(csv.reader(handle))
    header, body = rows[0], rows[1:]
    assert len(body) == 16
    assert {"curve", "x (m)", "y (m)", "alpha (1)", "E_ref (Pa)", "E_ref_stderr (Pa)",
            "E_ref_young (Pa)", "quality", "chi2_pvalue (1)"} <= set(header)
    assert all(len(row) == len(header) for row in body)
    code, _, err = _run(capsys, "fit", MAP, "--model", "contact", "--R", "10um", "--out",
                        tmp_path / "fits.txt")
    assert code == 2 and "must end in .nc (netCDF) or .csv" in err
