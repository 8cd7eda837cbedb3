"""The systematic error budget (issue 37 item 1): :mod:`viscoforce.fitting.budget` and ``fit``.

The calibration shifts are checked against the exact scalings of the contact laws (a force scale
ε moves a modulus by ε; a tip size by (1 + ε)^p with p the power of the size in the force
shape; Poisson's ratio through E_Y = E(1 − ν²)/2 and G = E_Y/2(1 + ν)); the interval and the
two rules (2 stderr; a factor 2 or 0.1 in an exponent) on hand-made results; the command on the
real map's Ting fit, where the height record moves β by many stderr (issue 37's bar).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.fitting.budget import (
    add_budget,
    alternative_shifts,
    calibration_shifts,
    check_uncertainties,
)


def _result(values, stderr, units, **attrs):
    ds = xr.Dataset({n: xr.DataArray(v, attrs={"units": units[n]}) for n, v in values.items()})
    for n, s in stderr.items():
        ds[f"{n}_stderr"] = xr.DataArray(s, attrs={"units": units[n]})
    ds = ds.assign_coords(param_i=("param_i", [n for n in values if not n.endswith(
        ("_young", "_shear"))]))
    ds.attrs.update(attrs)
    return ds


UNITS = {"E0": "Pa", "tau": "s", "alpha": "1", "baseline": "N", "E0_young": "Pa",
         "E0_shear": "Pa"}


@pytest.mark.parametrize(("shape", "power"), [("sphere", -0.5), ("paraboloid", -0.5),
                                              ("cone", -1.0), ("pyramid", -1.0), ("flat", -1.0)])
def test_calibration_shifts_follow_the_contact_laws(shape, power):
    ds = _result({"E0": 1e4, "tau": 0.1, "alpha": 0.2, "baseline": 1e-9, "E0_young": 3750.0,
                  "E0_shear": 1250.0}, {}, UNITS, tip_shape=shape, poisson=0.5)
    shifts = calibration_shifts(ds, {"spring_constant": 0.1, "tip": 0.2})
    assert shifts["spring_constant"]["E0"] == pytest.approx(1e3)
    assert shifts["spring_constant"]["baseline"] == pytest.approx(1e-10)
    assert shifts["sensitivity"]["E0"] == pytest.approx(500.0)  # the default 5 %
    assert "tau" not in shifts["spring_constant"] and "alpha" not in shifts["sensitivity"]
    assert shifts["tip"]["E0"] == pytest.approx(1e4 * (1.2 ** power - 1))
    assert "baseline" not in shifts["tip"]
    young = (1 - 0.45 ** 2) / (1 - 0.5 ** 2)
    assert shifts["poisson"]["E0_young"] == pytest.approx(3750.0 * (young - 1))
    assert shifts["poisson"]["E0_shear"] == pytest.approx(1250.0 * (young * 1.5 / 1.45 - 1))
    assert "E0" not in shifts["poisson"]  # the paper's E does not depend on it


def test_no_tip_no_tip_source():
    ds = _result({"E0": 1e4}, {}, UNITS)
    assert "tip" not in calibration_shifts(ds) and "poisson" not in calibration_shifts(ds)


@pytest.mark.parametrize(("given", "match"), [({"spring": 0.1}, "not a calibration source"),
                                              ({"tip": 1.5}, r"\[0, 1\)"),
                                              ({"tip": "x"}, r"\[0, 1\)")])
def test_bad_uncertainties_are_refused(given, match):
    with pytest.raises(ParameterError, match=match):
        check_uncertainties(given)


def test_the_interval_is_the_envelope_of_the_choices_widened_by_two_stderr():
    ds = _result({"E0": 100.0, "alpha": 0.30}, {"E0": 2.0, "alpha": 0.01}, UNITS)
    out = add_budget(ds, {"spring_constant": {"E0": 10.0}, "height_record": {"E0": -30.0,
                                                                            "alpha": -0.2}},
                     {"height_record": "sensor vs piezo"})
    assert list(out["budget_source"].values) == ["spring_constant", "height_record"]
    np.testing.assert_allclose(out["E0_systematic"].values, [10.0, -30.0])
    # estimates 100, 110, 70 and the calibration's mirror 90: [70 - 4, 110 + 4]
    assert float(out["E0_budget_lower"]) == pytest.approx(66.0)
    assert float(out["E0_budget_upper"]) == pytest.approx(114.0)
    assert int(out["E0_budget_determined"]) == 1  # 114/66 < 2
    assert int(out["alpha_budget_determined"]) == 0  # 0.1..0.32: wider than 0.1
    notes = out.attrs["budget_notes"]
    assert "E0 moves by +10 (+5.0 stderr) with the spring constant" in notes
    assert "alpha is not determined by these data" in notes
    assert "height_record: sensor vs piezo" in out.attrs["budget_sources"]


def test_a_small_shift_says_nothing_and_a_factor_two_is_not_determined():
    ds = _result({"E0": 100.0}, {"E0": 10.0}, UNITS)
    quiet = add_budget(ds, {"model": {"E0": 15.0}})
    assert quiet.attrs["budget_notes"] == "none"
    wide = add_budget(ds, {"model": {"E0": 150.0}})
    assert int(wide["E0_budget_determined"]) == 0
    assert "put it anywhere in [80, 270]" in wide.attrs["budget_notes"]


def test_alternative_shifts_are_the_other_fits_values_minus_these():
    a = _result({"E0": 100.0, "tau": 0.1}, {}, UNITS)
    b = _result({"E0": 130.0, "alpha": 0.3}, {}, UNITS)
    assert alternative_shifts(a, b) == {"E0": pytest.approx(30.0)}


REAL_MAP = (Path(__file__).resolve().parents[3] / "shared" / "data" / "real" / "PyFMRheo"
            / "map-data-2022.10.29-12.27.34.564.jpk-force-map")


@pytest.mark.skipif(not REAL_MAP.is_file(), reason=f"{REAL_MAP} absent")
def test_ting_on_the_real_map_reports_the_height_record_dependence_of_beta(capsys):
    """Issue 37's bar: beta moves with the height record by many stderr, and says so."""
    from viscoforce.cli import main

    args = ["fit", str(REAL_MAP), "--model", "ting", "--tip", "sphere:5um", "--material",
            "structural", "--curve", "0", "--json"]
    assert main(args) == 0
    info = json.loads(capsys.readouterr().out)
    assert "height record" in info["height_record"]
    alpha = info["params"]["alpha"]
    shift = alpha["systematic"]["height_record"]
    assert abs(shift) > 2 * alpha["stderr"]
    assert alpha["interval"][0] <= alpha["value"] <= alpha["interval"][1]
    assert not alpha["determined"]  # the two records disagree by more than 0.1 in beta
    assert any(n.startswith("alpha moves by") and "height record" in n
               for n in info["budget_notes"])
    assert {"spring_constant", "sensitivity", "tip"} <= set(info["params"]["E_ref"]["systematic"])
    assert main([*args[:-1], "--height-channel", "piezo", "--json"]) == 0
    piezo = json.loads(capsys.readouterr().out)
    assert "height_record" not in piezo  # named: no choice made, none reported
    assert math.isclose(piezo["params"]["alpha"]["value"], alpha["value"] + shift,
                        rel_tol=1e-6) or math.isclose(
        piezo["params"]["alpha"]["value"], alpha["value"], rel_tol=1e-6)


def test_near_ties_of_the_measured_chooser_are_the_model_source():
    from types import SimpleNamespace

    from viscoforce.fitting.measured import MARGIN, _near_ties
    from viscoforce.fitting.selection import Tried

    def tried(label, score, **values):
        return Tried(label, SimpleNamespace(criterion={"bic": score}, values=values))

    kept = tried("sls", 100.0, E0=1e4, E_inf=1e3, tau=0.1)
    near = tried("prony 2", 100.0 + MARGIN - 1, E0=1.3e4, E_inf=0.9e3, tau_1=0.01)
    far = tried("structural", 100.0 + MARGIN + 1, E_ref=5e3)
    ds = _result({"E0": 1e4, "E_inf": 1e3, "tau": 0.1}, {"E0": 100.0, "E_inf": 10.0,
                                                         "tau": 0.001},
                 {"E0": "Pa", "E_inf": "Pa", "tau": "s"})
    out = _near_ties(ds, [kept, near, far], kept, "bic")
    assert list(out["budget_source"].values) == ["model"]
    assert float(out["E0_systematic"].sel(budget_source="model")) == pytest.approx(3e3)
    assert float(out["tau_systematic"].sel(budget_source="model")) == 0.0
    assert "prony 2" in out.attrs["budget_sources"] and "structural" not in out.attrs[
        "budget_sources"]
    assert "E0 moves by +3e+03 (+30.0 stderr) with the model among the near-ties" in out.attrs[
        "budget_notes"]


def test_a_map_carries_the_budget_per_pixel_and_flags_pixels_on_the_same_rule():
    from viscoforce.fitting.budget import add_map_budget

    e = xr.DataArray([[1e4, 2e4], [3e4, 4e4]], dims=("y", "x"), attrs={"units": "Pa"})
    s = xr.DataArray([[1e2, 1e2], [1e2, 2e4]], dims=("y", "x"), attrs={"units": "Pa"})
    ds = xr.Dataset({"E0": e, "E0_stderr": s}).assign_coords(param_i=("param_i", ["E0"]))
    ds.attrs["tip_shape"] = "cone"
    out = add_map_budget(ds, {"spring_constant": 0.1, "sensitivity": 0.0, "tip": 0.25})
    np.testing.assert_allclose(out["E0_systematic"].sel(budget_source="spring_constant"),
                               0.1 * e)
    np.testing.assert_allclose(out["E0_systematic"].sel(budget_source="tip"), -0.2 * e)
    # the widest side: 0.2 (tip) each way; the last pixel's 2 stderr make it a factor > 2
    np.testing.assert_allclose(out["E0_budget_lower"], 0.8 * e - 2 * s)
    np.testing.assert_allclose(out["E0_budget_upper"], 1.2 * e + 2 * s)
    np.testing.assert_array_equal(out["E0_budget_determined"], [[1, 1], [1, 0]])
    assert "E0 is not determined by these data on 1 of 4 pixels" in out.attrs["budget_notes"]


def test_a_spectrum_referred_to_the_fitted_delay_weighs_the_sensors_phase(capsys):
    """The phase reference is a budget source where the data chose it (issue 37 item 1)."""
    from viscoforce.cli import main

    args = ["fit", "example:modulation-map.jpk-force-map", "--model", "contact", "--material",
            "structural", "--tip", "sphere:5um", "--curve", "3", "--json"]
    assert main(args) == 0
    info = json.loads(capsys.readouterr().out)
    text = info["phase_reference_budget"]
    assert text.startswith("phase reference delay") and "sensor's own phase" in text
    settled = "the data settle the choice" in text
    assert settled == ("phase_reference" not in info["params"]["alpha"]["systematic"])
    assert main([*args[:-1], "--phase-reference", "sensor", "--json"]) == 0
    assert "phase_reference_budget" not in json.loads(capsys.readouterr().out)
