"""The force-curve half: hertz (approach), creep (constant-force pause), segment choice, batch.

Synthetic curves are generated from the textbook closed forms written out here (Hertz, Sneddon's
cone and flat punch, Bilodeau's pyramid, with E* = E/2 the paper's convention), not from
``viscoforce.physics.tips``, so the fit and the generator are independent.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from tests.conftest import REAL_DATA_DIR
from viscoforce.exceptions import DataWarning, GoodnessOfFitWarning, ParameterError
from viscoforce.fitting.curves import creep_data, curve_data, fit_curve
from viscoforce.fitting.data import FitData
from viscoforce.fitting.fit import fit_data
from viscoforce.physics.tips import parse_tip, young_from_paper
from viscoforce.schema import make_curves

E_PAPER = 3.0e3  # [Pa], the paper's E = 2 E*
E_STAR = E_PAPER / 2
TAN20 = math.tan(math.radians(20.0))

#: Textbook loads F(δ) [N] with E* = E/2 (Johnson 1985; Sneddon 1965; Bilodeau 1992).
TEXTBOOK = {
    "paraboloid:5um": lambda d: 4 / 3 * E_STAR * math.sqrt(5e-6) * d ** 1.5,
    "cone:20": lambda d: 2 / math.pi * E_STAR * TAN20 * d ** 2,
    "pyramid:20": lambda d: 0.7453 * E_STAR * TAN20 * d ** 2,
    "flat:1um": lambda d: 2 * E_STAR * 1e-6 * d,
}


def _approach(law, rng, *, noise=0.01, n=1200, contact=1.8e-6, baseline=-5e-9, slope=2e-4):
    z = np.linspace(-1.0e-6, 2.6e-6, n)
    d = np.maximum(z - contact, 0.0)
    f = baseline + slope * (z - contact) + law(d)
    return z, f + rng.normal(0.0, noise * np.ptp(f), n)


def _quiet_fit(data, name, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fit_data(data, name, **kw)


@pytest.mark.parametrize("tip", list(TEXTBOOK))
def test_hertz_recovers_the_textbook_modulus_and_contact_point(tip, rng):
    z, f = _approach(TEXTBOOK[tip], rng)
    ds = _quiet_fit(FitData(z, f, None, {}), "hertz", tip=parse_tip(tip))
    for name, true in (("E", E_PAPER), ("contact_point", 1.8e-6), ("baseline", -5e-9),
                       ("baseline_slope", 2e-4)):
        value, err = float(ds[name]), float(ds[f"{name}_stderr"])
        assert err > 0
        assert abs(value - true) < 4 * err, (name, value, true, err)  # 4 sigma: one seed
    assert float(ds["E"]) == pytest.approx(E_PAPER, rel=0.05)
    assert "fit_approach_force" in ds and ds["tip_position"].attrs["units"] == "m"


def test_hertz_on_sneddon_sphere_tends_to_hertz_for_shallow_indentation(rng):
    # δ ≤ 0.8 µm on R = 50 µm: Sneddon's sphere is Hertz within δ/(10R) < 0.2 %
    z, f = _approach(lambda d: 4 / 3 * E_STAR * math.sqrt(50e-6) * d ** 1.5, rng, noise=0.002)
    ds = _quiet_fit(FitData(z, f, None, {}), "hertz", tip=parse_tip("sphere:50um"))
    assert float(ds["E"]) == pytest.approx(E_PAPER, rel=0.01)


def test_hertz_stderr_cover_the_truth_over_replicas(rng):
    """The stderr is a claim about the data: over 40 noisy replicas ~95 % lie within 2 sigma."""
    tip = parse_tip("cone:20")
    inside = 0
    for _ in range(40):
        z, f = _approach(TEXTBOOK["cone:20"], rng, n=400)
        ds = _quiet_fit(FitData(z, f, None, {}), "hertz", tip=tip, profile=False)
        inside += abs(float(ds["E"]) - E_PAPER) < 2 * float(ds["E_stderr"])
    assert 33 <= inside <= 40, inside  # binomial(40, 0.95): P(< 33) ~ 0.2 %


def test_hertz_fit_curve_reports_young_and_shear(rng):
    z, f = _approach(TEXTBOOK["cone:20"], rng)
    curves = make_curves(np.linspace(0, 1, z.size), f, -z, np.zeros_like(z), tip_position=z,
                         segment=0, segment_names=("approach",), source="synthetic")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = fit_curve(curves, "hertz", tip="cone:20", poisson=0.3)
    assert float(ds["E_young"]) == pytest.approx(young_from_paper(float(ds["E"]), 0.3), rel=1e-12)
    assert float(ds["E_young"]) == pytest.approx(E_PAPER * (1 - 0.09) / 2, rel=0.05)
    assert ds.attrs["tip_shape"] == "cone" and ds.attrs["poisson"] == 0.3
    with pytest.raises(ParameterError, match="needs the tip"):
        fit_curve(curves, "hertz")


def _curves(z, f):
    return make_curves(np.linspace(0, 1, z.size), f, -z, np.zeros_like(z), tip_position=z,
                       segment=0, segment_names=("approach",), source="synthetic")


def _fit_recorded(curves, **kw):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = fit_curve(curves, "hertz", **kw)
    return ds, [(w.category, str(w.message)) for w in caught]


def test_hertz_depth_check_passes_when_the_law_holds(rng):
    """Over replicas the shift is a standard normal score: |z| < 2 on ~95 %."""
    shifts = []
    for _ in range(12):
        z, f = _approach(TEXTBOOK["paraboloid:5um"], rng, n=600, slope=2e-5)
        ds, caught = _fit_recorded(_curves(z, f), tip="paraboloid:5um")
        shifts.append(ds.attrs["depth_check_shift"])
        assert ds.attrs["precontact_rise"] < 0.05
        assert not any(c is DataWarning for c, _ in caught)
    assert np.sum(np.abs(shifts) < 2) >= 9, shifts  # binomial(12, 0.95): P(< 9) ~ 0.2 %
    assert 0.4 < np.std(shifts) < 1.8, shifts


def test_hertz_depth_check_warns_when_the_tip_law_is_wrong(rng):
    """A cone's δ² curve fitted with a paraboloid's δ^1.5: E drifts with depth, and says so."""
    z, f = _approach(TEXTBOOK["cone:20"], rng, noise=0.002)
    ds, caught = _fit_recorded(_curves(z, f), tip="paraboloid:5um")
    assert abs(ds.attrs["depth_check_shift"]) > 2
    assert any(c is GoodnessOfFitWarning and "E depends on the indentation depth" in m
               for c, m in caught)


def test_hertz_warns_when_the_approach_is_not_free_before_contact(rng):
    z, f = _approach(TEXTBOOK["paraboloid:5um"], rng, noise=0.002, slope=0.0)
    f = f + 0.4 * np.ptp(f) * (z - z.min()) / np.ptp(z)  # a steady rise over the whole approach
    ds, caught = _fit_recorded(_curves(z, f), tip="paraboloid:5um")
    assert ds.attrs["precontact_rise"] > 0.2
    assert any(c is DataWarning and "not a free cantilever" in m for c, m in caught)


# ── creep ───────────────────────────────────────────────────────────────────────────────────────

def test_flat_punch_creep_times_are_the_creep_compliance_times(rng):
    """Constant force F on a flat punch of radius a: δ(t) = F C(t)/a (paper's C = 1/E).

    The fitted creep time is the SLS's τ of Eq. 3, not the stress-relaxation time τ·E_inf/E0.
    """
    e0, e_inf, tau, force, a = 9e3, 3e3, 0.4, 2e-9, 1e-6
    t = np.linspace(0, 3.0, 1500)
    compliance = 1 / e_inf + (1 / e0 - 1 / e_inf) * np.exp(-t / tau)
    z = 1e-5 + force * compliance / a + rng.normal(0, 2e-10, t.size)
    ds = _quiet_fit(FitData(t, z, None, {}), "creep")
    value, err = float(ds["tau_1"]), float(ds["tau_1_stderr"])
    assert abs(value - tau) < 4 * err and value == pytest.approx(tau, rel=0.03)
    assert abs(value - tau * e_inf / e0) > 10 * err  # not the relaxation time
    assert float(ds["dz_1"]) == pytest.approx(force / a * (1 / e0 - 1 / e_inf), rel=0.03)
    assert ds["z_inf"].attrs["units"] == "m" and ds["dz_1"].attrs["units"] == "m"


def test_creep_modes_auto_finds_two_modes(rng):
    t = np.linspace(0, 5.0, 2000)
    z = 2e-6 - 40e-9 * np.exp(-t / 0.05) - 60e-9 * np.exp(-t / 1.0) + rng.normal(0, 1e-9, t.size)
    ds = _quiet_fit(FitData(t, z, None, {}), "creep", modes="auto")
    assert int(ds["modes"]) == 2
    np.testing.assert_allclose([float(ds["tau_1"]), float(ds["tau_2"])], [0.05, 1.0], rtol=0.1)
    assert "fit_tip_position" in ds


def _held_curve(pause_type: str):
    n = 50
    t = np.arange(3 * n) * 0.01
    z = np.concatenate([np.linspace(0, 1e-6, n), 1e-6 + 1e-8 * (1 - np.exp(-t[:n] / 0.1)),
                        np.linspace(1e-6, 0, n)])
    f = np.concatenate([np.linspace(0, 1e-9, n), np.full(n, 1e-9), np.linspace(1e-9, 0, n)])
    return make_curves(t, f, -z, np.zeros_like(z), tip_position=z,
                       segment=np.repeat([0, 1, 2], n),
                       segment_names=("approach", "pause", "retract"),
                       segment_types=("extend", pause_type, "retract"), source="synthetic")


def test_segment_choice_follows_the_files_pause_type():
    force_pause = _held_curve("constant-force-pause")
    assert creep_data(force_pause).x.size == 50
    with pytest.raises(ParameterError, match=r"constant-force.*--model creep"):
        curve_data(force_pause, "relaxation")
    height_pause = _held_curve("constant-height-pause")
    assert curve_data(height_pause, "relaxation").x.size == 50
    with pytest.raises(ParameterError, match=r"constant-height.*--model relaxation"):
        curve_data(height_pause, "creep")
    assert curve_data(height_pause, "hertz").x.size == 50  # the approach
    assert curve_data(height_pause, "creep", segment=1).x.size == 50  # explicit: as asked


# ── real files ──────────────────────────────────────────────────────────────────────────────────

CC_BRAIN = REAL_DATA_DIR / "afmformats" / "fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force"
CC_GEL = REAL_DATA_DIR / "afmformats" / "fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force"
RHEO_MAP = REAL_DATA_DIR / "PyFMRheo" / "map-data-2022.10.29-12.27.34.564.jpk-force-map"
needs_real = pytest.mark.skipif(not CC_GEL.is_file(), reason="shared real data absent")


@needs_real
def test_real_creep_curve_creeps_toward_the_sample():
    from viscoforce.io.instruments import load_instrument

    curves = load_instrument(CC_GEL)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = fit_curve(curves, "creep", modes=1)
    data = creep_data(curves)
    # the tip moves toward the sample during the pause: z_inf above the start, dz_1 < 0
    assert float(ds["dz_1"]) < 0 and float(ds["z_inf"]) > data.y[0]
    assert float(ds["z_inf"]) == pytest.approx(np.median(data.y[-100:]), abs=20e-9)
    assert ds.attrs["segment_type"] == "constant-force-pause"
    assert ds.attrs["creep_force"] > 0


@needs_real
def test_real_hertz_fit_finds_the_contact_inside_the_approach():
    from viscoforce.io.instruments import load_instrument

    curves = load_instrument(CC_BRAIN)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = fit_curve(curves, "hertz", tip="sphere:5um")
    data = curve_data(curves, "hertz")
    c = float(ds["contact_point"])
    assert data.x.min() < c < data.x.max()
    # before contact the force is flat within a few % of the rise, after it rises
    before = data.y[data.x < c - 1e-6]
    assert np.ptp(before) < 0.2 * (data.y.max() - float(ds["baseline"]))
    assert ds.attrs["stderr_correction"] >= 1.0


CHIARO = REAL_DATA_DIR / "afmformats" / "fmt-chiaro-txt_AEBP1_Indentation_002.zip"


@pytest.mark.skipif(not CHIARO.is_file(), reason="shared real data absent")
def test_chiaro_header_tip_and_the_instruments_own_hertz_value():
    """The Chiaro header records its probe (R = 27.5 µm) and its own Hertz fit (117.007 Pa).

    The instrument fits its own window and baseline, so agreement within 15 % is the check.
    """
    from viscoforce.io.instruments import load_instrument

    curves = load_instrument(CHIARO)
    assert curves.attrs["tip_shape"] == "sphere"
    assert curves.attrs["tip_radius"] == pytest.approx(27.5e-6, rel=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = fit_curve(curves, "hertz", poisson=0.5)
    assert ds.attrs["tip_radius"] == pytest.approx(27.5e-6, rel=1e-12)
    assert float(ds["E_young"]) == pytest.approx(117.007, rel=0.15)
    assert abs(ds.attrs["depth_check_shift"]) < 2  # with the right tip, Hertz holds here


def _cli(capsys, *argv):
    from viscoforce.cli import main

    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


@needs_real
def test_cli_batch_over_files_into_one_table(tmp_path, capsys):
    table = tmp_path / "fits.csv"
    code, out, err = _cli(capsys, "fit", str(CC_BRAIN), str(CC_GEL), str(RHEO_MAP),
                          "--model", "hertz", "--tip", "sphere:5um", "--out", str(table),
                          "--json")
    assert code == 0, err
    info = json.loads(out)
    assert info["n_files"] == 3 and info["n_fits"] == 18  # 1 + 1 + a 4x4 map
    assert set(info["params"]) >= {"E", "E_young", "contact_point"}
    lines = table.read_text().splitlines()
    header = lines[0].split(",")
    assert header[:2] == ["file", "curve"] and "E (Pa)" in header and "E_young (Pa)" in header
    assert len(lines) == 19


@needs_real
def test_cli_hertz_without_tip_and_creep_on_a_map_without_pause(capsys):
    code, _, err = _cli(capsys, "fit", str(CC_BRAIN), "--model", "hertz")
    assert code == 2 and "--tip" in err
    code, out, err = _cli(capsys, "fit", str(CC_GEL), "--model", "creep", "--json")
    assert code == 0, err
    assert json.loads(out)["params"]["tau_1"]["value"] > 0


@needs_real
def test_cli_batch_folder_reports_refused_files(tmp_path, capsys):
    code, out, err = _cli(capsys, "fit", str(REAL_DATA_DIR / "afmformats"), "--model", "creep",
                          "--json")
    assert code == 0, err
    info = json.loads(out)
    refused = [f for f in info["files"] if "error" in f]
    assert refused and all(f["error"] for f in refused)
    fitted = [f for f in info["files"] if "error" not in f and f["n_fits"] > f["n_failed"]]
    assert {f["file"].rsplit("/", 1)[-1] for f in fitted} == {CC_BRAIN.name, CC_GEL.name}


@pytest.mark.skipif(not RHEO_MAP.is_file(), reason="shared real data absent")
def test_cli_ting_curve_with_plot_and_both_power_law_forms(tmp_path, capsys):
    plot = tmp_path / "ting.png"
    code, out, err = _cli(capsys, "fit", str(RHEO_MAP), "--model", "ting", "--tip",
                          "paraboloid:5um", "--drag", "2.5e-6", "--material", "structural",
                          "--no-newtonian", "--curve", "0", "--plot", str(plot), "--json")
    assert code == 0, err
    info = json.loads(out)
    alpha = info["params"]["alpha"]["value"]
    assert info["derived"]["beta"]["value"] == pytest.approx(alpha, rel=1e-12)  # β = α
    # E_ref = E0 Γ(1 − β)(2π f_ref t0)^β with f_ref = 1 Hz, t0 = 1 s
    e_ref = info["params"]["E_ref"]["value"]
    e0 = info["derived"]["ting_E0"]["value"]
    assert e_ref == pytest.approx(e0 * math.gamma(1 - alpha) * (2 * math.pi) ** alpha, rel=1e-9)
    assert plot.stat().st_size > 10_000
    code, _, err = _cli(capsys, "fit", str(RHEO_MAP), "--model", "ting", "--tip",
                        "paraboloid:5um", "--drag", "1e-6", "--fit-drag")
    assert code == 2 and "not both" in err
