"""Creep with a known tip (issue 37 item 3): Lee–Radok's integral of the recorded force.

The synthetic curves are written out here from the textbook (paper's E = 2 E*): Hertz's
paraboloid g = (2/3)√R δ^{3/2}, Sneddon's cone g = tan α δ²/π, the flat punch g = a δ, and the
hereditary integral ψ = ∫ C(t − s) dF(s) in closed form for a linear loading ramp followed by a
held force with an exponential overshoot (Eq. 3's C(t), and a 2-mode Prony series); the tip
position is z_c + g⁻¹(ψ) in contact. Noise: 1 nm on the tip position, 0.2 % of the held force on
the recorded force (white). Nothing here calls the package's creep integral or inversion.

The study (``slow``): over 30 seeds per case, τ and the moduli are unbiased within 1 % and the
z-score RMS of (fit − truth)/stderr lies in [0.7, 1.4]. The CI version fits 5 seeds of each case
and holds the mean error within 4 standard errors of a mean of 5 (4·rms(stderr)/√5) and every
|z| below 5: bounds that follow from honest stderr, not from the numbers seen.
"""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest

from tests.conftest import REAL_DATA_DIR
from viscoforce.exceptions import DataWarning, ModelValidityWarning, ParameterError
from viscoforce.fitting.creep import fit_creep
from viscoforce.schema import make_curves

TAN20 = math.tan(math.radians(20.0))
R = 5e-6
A_FLAT = 1e-6
#: tip text → (g(δ) [m²], g⁻¹) from the textbook, E the paper's (E* = E/2)
SHAPES = {
    "paraboloid:5um": (lambda d: 2 / 3 * math.sqrt(R) * d ** 1.5,
                       lambda g: (g / (2 / 3 * math.sqrt(R))) ** (2 / 3)),
    "cone:20": (lambda d: TAN20 / math.pi * d ** 2, lambda g: np.sqrt(g / (TAN20 / math.pi))),
    "flat:1um": (lambda d: A_FLAT * d, lambda g: g / A_FLAT),
}
CONTACT = 2e-6  # [m]
F0 = 2e-9  # held force [N]
SLS = ((6e3, 2e3), (0.5,))  # E0, E_inf [Pa]; tau [s]
PRONY2 = ((8e3, 4e3, 2e3), (0.1, 1.0))  # E0, E_1, E_inf; tau_1, tau_2
#: case → (tip, (moduli, taus), overshoot A)
CASES = {
    "paraboloid-sls-step": ("paraboloid:5um", SLS, 0.0),
    "paraboloid-sls-overshoot": ("paraboloid:5um", SLS, 0.06),
    "cone-sls-step": ("cone:20", SLS, 0.0),
    "cone-sls-overshoot": ("cone:20", SLS, 0.06),
    "flat-sls-step": ("flat:1um", SLS, 0.0),
    "paraboloid-prony2-step": ("paraboloid:5um", PRONY2, 0.0),
    "cone-prony2-overshoot": ("cone:20", PRONY2, 0.06),
}
QUICK = ("paraboloid-sls-step", "cone-sls-overshoot", "flat-sls-step", "paraboloid-prony2-step")


def exact_load(t, moduli, taus, *, overshoot=0.0, t_load=0.2, t_overshoot=0.05):
    """(F, ψ) in closed form: F rises linearly from 0 at −t_load to F0(1 + A) at 0, then
    F = F0 (1 + A e^{−t/t_o}); ψ = J_inf F − Σ ΔJ_i ∫ e^{−(t−s)/τ_i} dF(s)."""
    e = np.asarray(moduli, dtype=float)
    d_j = 1 / e[1:] - 1 / e[:-1]
    peak, start = F0 * (1 + overshoot), -t_load
    after = np.maximum(t, 0.0)
    force = np.where(t < start, 0.0, np.where(t < 0, peak * (t - start) / t_load,
                                              F0 * (1 + overshoot * np.exp(-after / t_overshoot))))
    psi = force / e[-1]
    for dj, tau in zip(d_j, taus, strict=True):
        ramp = peak / t_load * tau * (1 - np.exp(-(np.clip(t, start, 0) - start) / tau))
        at_zero = peak / t_load * tau * (1 - np.exp(-t_load / tau))
        release = 0.0
        if overshoot:
            release = -(overshoot * F0 / t_overshoot) * (
                np.exp(-after / t_overshoot) - np.exp(-after / tau)) / (1 / tau - 1 / t_overshoot)
        held = at_zero * np.exp(-after / tau) + release
        psi = psi - dj * np.where(t < start, 0.0, np.where(t < 0, ramp, held))
    return force, psi


def synthetic_curve(tip, material, rng, *, overshoot=0.0, pause=3.0, noise_z=1e-9,
                    noise_f=0.002, baseline=3e-10, monotone=True, **load):
    """Approach (0.8 s free, 0.2 s loading) and a constant-force pause, at 1 kHz."""
    moduli, taus = material
    shape, inverse = SHAPES[tip]
    t = -1.0 + 1e-3 * np.arange(int(round((pause + 1.0) / 1e-3)))
    force, psi = exact_load(t, moduli, taus, overshoot=overshoot, **load)
    depth = inverse(np.maximum(psi, 0.0))
    if monotone:  # Lee–Radok's integral holds: the contact grows
        assert np.all(np.diff(depth[t > -0.2]) >= -1e-18)
    z = np.where(t < -0.2, CONTACT - 2e-6 * (-0.2 - t) / 0.8, CONTACT + depth)
    z = z + noise_z * rng.standard_normal(t.size)
    f = force + baseline + noise_f * F0 * rng.standard_normal(t.size)
    return make_curves(t - t[0], f, -z, np.zeros_like(z), tip_position=z,
                       segment=(t >= 0).astype(int), segment_names=("approach", "pause"),
                       segment_types=("extend", "constant-force-pause"), source="synthetic")


def truth(material):
    moduli, taus = material
    if len(taus) == 1:
        out = {"tau": taus[0], "E0": moduli[0], "E_inf": moduli[1]}
    else:
        out = {"E0": moduli[0], **{f"E_{i}": m for i, m in enumerate(moduli[1:-1], 1)},
               "E_inf": moduli[-1], **{f"tau_{i}": v for i, v in enumerate(taus, 1)}}
    return {**out, "contact_point": CONTACT}


def _fit(curves, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fit_creep(curves, **kw)


def _study(case, seeds):
    """Per parameter: (fit − truth), stderr over ``seeds``."""
    tip, material, overshoot = CASES[case]
    expected = truth(material)
    errors = {n: [] for n in expected}
    stderr = {n: [] for n in expected}
    for seed in seeds:
        rng = np.random.default_rng(1000 + seed)
        curves = synthetic_curve(tip, material, rng, overshoot=overshoot,
                                 pause=3.0 if len(material[1]) == 1 else 4.0)
        ds = _fit(curves, tip=tip, modes=len(material[1]))
        for n, v in expected.items():
            errors[n].append(float(ds[n]) - v)
            stderr[n].append(float(ds[f"{n}_stderr"]))
    return expected, {n: np.array(v) for n, v in errors.items()}, {
        n: np.array(v) for n, v in stderr.items()}


# ── the numerics (viscoforce.physics.lee_radok) ─────────────────────────────────────────────


def test_the_creep_integral_is_exact_for_a_piecewise_linear_load():
    from viscoforce.physics.lee_radok import creep_integral

    t = -1.0 + 1e-3 * np.arange(4000)
    for moduli, taus in (SLS, PRONY2):
        force, psi = exact_load(t, moduli, taus)  # no overshoot: piecewise linear in t
        e = np.asarray(moduli)
        got = creep_integral(t, force, 1 / e[0], 1 / e[1:] - 1 / e[:-1], np.asarray(taus))
        np.testing.assert_allclose(got, psi, rtol=1e-9, atol=1e-12 * np.max(psi))


def test_decayed_sums_on_any_grid_and_the_adjoint_is_the_transpose(rng):
    from viscoforce.physics.lee_radok import creep_integral, creep_integral_adjoint, decayed_sums

    for t in (1e-3 * np.arange(300.0), np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 300))):
        u = rng.standard_normal(t.size)
        for tau in (1e-5, 3e-3, 0.1, 1e3):  # no memory, the block sums, one block
            direct = [np.sum(u[:k + 1] * np.exp(-(t[k] - t[:k + 1]) / tau)) for k in range(t.size)]
            np.testing.assert_allclose(decayed_sums(t, u, tau), direct, rtol=1e-10, atol=1e-12)
        f, w = rng.standard_normal(t.size), rng.standard_normal(t.size)
        material = (1 / 6e3, np.array([1 / 2e3 - 1 / 6e3, 1e-5]), np.array([0.05, 2e-3]))
        assert np.dot(creep_integral(t, f, *material), w) == pytest.approx(
            np.dot(f, creep_integral_adjoint(t, w, *material)), rel=1e-10)


def test_the_smoothing_matrix_is_savitzky_golay(rng):
    from scipy.signal import savgol_filter

    from viscoforce.physics.lee_radok import smoothing_matrix

    for n, window in ((500, 21), (40, 5), (22, 21)):
        f = rng.standard_normal(n)
        np.testing.assert_allclose(smoothing_matrix(n, window) @ f, savgol_filter(f, window, 2),
                                   rtol=0, atol=1e-12)
    f = rng.standard_normal(10)
    np.testing.assert_array_equal(smoothing_matrix(10, 21) @ f, f)  # too short: the identity


@pytest.mark.parametrize("text", ["sphere:5um", "paraboloid:5um", "cone:20", "pyramid:35",
                                  "flat:1um"])
def test_the_force_shape_is_inverted(text):
    from viscoforce.physics.lee_radok import indentation_from_shape
    from viscoforce.physics.tips import parse_tip

    tip = parse_tip(text)
    depth = np.geomspace(1e-11, 5e-5, 2000)
    np.testing.assert_allclose(indentation_from_shape(tip, tip.force_shape(depth)), depth,
                               rtol=1e-11)
    assert np.all(indentation_from_shape(tip, np.array([0.0, -1e-12])) == 0)


# ── the study ───────────────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize("case", QUICK)
def test_quick_study_is_unbiased_within_its_stderr(case):
    """5 seeds: |mean error| ≤ 4·rms(stderr)/√5 and every |z| < 5 (honest stderr)."""
    expected, errors, stderr = _study(case, range(5))
    for n in expected:
        z = errors[n] / stderr[n]
        bound = 4 * math.sqrt(np.mean(stderr[n] ** 2)) / math.sqrt(errors[n].size)
        assert abs(errors[n].mean()) <= bound, (n, errors[n], stderr[n])
        assert np.all(np.abs(z) < 5), (n, z)


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES))
def test_study_unbiased_within_one_percent_with_honest_stderr(case):
    """30 seeds: relative bias < 1 % and z-RMS in [0.7, 1.4] for τ, the moduli, the contact."""
    expected, errors, stderr = _study(case, range(30))
    for n, v in expected.items():
        z = errors[n] / stderr[n]
        rms = math.sqrt(np.mean(z ** 2))
        if n != "contact_point":
            assert abs(errors[n].mean() / v) < 0.01, (n, errors[n].mean() / v)
        assert 0.7 <= rms <= 1.4, (n, rms)


@pytest.mark.slow
def test_modes_auto_finds_two_modes_in_a_two_mode_creep():
    tip, material, overshoot = CASES["paraboloid-prony2-step"]
    for seed in range(3):
        curves = synthetic_curve(tip, material, np.random.default_rng(seed), pause=4.0)
        ds = _fit(curves, tip=tip, modes="auto")
        assert int(ds["modes"]) == 2, ds.attrs["explanation"]
        assert ds.attrs["criterion"] == "bic"


# ── what a fit reports ──────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize("tip", list(SHAPES))
def test_noise_free_creep_is_recovered_exactly(tip, rng):
    curves = synthetic_curve(tip, SLS, rng, overshoot=0.06, noise_z=0.0, noise_f=0.0)
    ds = _fit(curves, tip=tip)
    for n, v in truth(SLS).items():
        # 1e-4: the force's smoothing (21 samples) rounds the ramp's corners: E0 −4e-5, τ 3e-6
        assert float(ds[n]) == pytest.approx(v, rel=1e-4), n
    assert ds.attrs["creep_form"] == "lee-radok" and ds.attrs["model"] == "creep"
    assert ds.attrs["contact_area_decrease"] < 1e-3


def test_the_result_carries_moduli_noise_and_provenance(rng):
    curves = synthetic_curve("paraboloid:5um", SLS, rng, overshoot=0.06)
    ds = _fit(curves, tip="paraboloid:5um", poisson=0.3)
    young = 6e3 * (1 - 0.09) / 2  # Y = E (1 − ν²)/2
    assert float(ds["E0_young"]) == pytest.approx(young, rel=0.02)
    assert float(ds["E_inf_shear"]) == pytest.approx(2e3 * (1 - 0.09) / 2 / 2.6, rel=0.02)
    assert float(ds["E0_young_stderr"]) > 0 and ds.attrs["poisson"] == 0.3
    assert ds.attrs["tip_shape"] == "paraboloid" and ds.attrs["tip_radius"] == R
    assert ds.attrs["tip_position_noise"] == pytest.approx(1e-9, rel=0.1)
    assert ds.attrs["force_noise"] == pytest.approx(0.002 * F0, rel=0.1)
    assert ds.attrs["force_baseline"] == pytest.approx(3e-10, abs=2e-12)
    assert ds.attrs["creep_force"] == pytest.approx(F0, rel=0.01)
    assert ds.attrs["loading_points"] > 50 and ds["time"].values.min() < 0  # the ramp is fitted
    assert "fit_tip_position" in ds and "Lee-Radok" in ds.attrs["validity"]


def test_a_sphere_uses_sneddons_exact_shape(rng):
    """Noise-free creep under Sneddon's sphere (depth from its own g by bisection) is recovered."""
    from viscoforce.physics.tips import parse_tip

    sphere = parse_tip("sphere:2um")
    t = -1.0 + 1e-3 * np.arange(4000)
    force, psi = exact_load(t, *SLS)
    psi = psi * 3.0  # ~0.5 R deep: 3 % off Hertz
    low, high = np.zeros_like(psi), np.full_like(psi, 20e-6)
    for _ in range(80):  # bisection on g(δ) = ψ, all samples at once
        mid = 0.5 * (low + high)
        above = sphere.force_shape(mid) > psi
        low, high = np.where(above, low, mid), np.where(above, mid, high)
    depth = 0.5 * (low + high)
    z = np.where(t < -0.2, CONTACT - 2e-6 * (-0.2 - t) / 0.8, CONTACT + depth)
    curves = make_curves(t - t[0], 3 * force, -z, np.zeros_like(z), tip_position=z,
                         segment=(t >= 0).astype(int), segment_names=("approach", "pause"),
                         segment_types=("extend", "constant-force-pause"))
    ds = _fit(curves, tip=sphere)
    for n, v in truth(SLS).items():
        assert float(ds[n]) == pytest.approx(v, rel=1e-4), n  # the smoothing rounds 2 corners


def test_the_files_own_tip_is_the_default(rng):
    from viscoforce.physics.tips import parse_tip

    curves = synthetic_curve("cone:20", SLS, rng)
    curves.attrs.update(parse_tip("cone:20").as_attrs())
    ds = _fit(curves)
    assert ds.attrs["creep_form"] == "lee-radok" and ds.attrs["tip_shape"] == "cone"
    assert float(ds["tau"]) == pytest.approx(0.5, rel=0.01)


def test_a_given_contact_point_is_not_fitted(rng):
    curves = synthetic_curve("flat:1um", SLS, rng)
    ds = _fit(curves, tip="flat:1um", contact_point=CONTACT)
    assert "contact_point" not in ds and ds.attrs["contact_point"] == CONTACT
    assert float(ds["E_inf"]) == pytest.approx(2e3, rel=0.01)


def test_a_pause_without_approach_takes_a_step_load_and_needs_the_contact(rng):
    """A file of the pause alone: the load is a step at its start (said), z_c must be given."""
    t = 1e-3 * np.arange(3000)
    shape, inverse = SHAPES["paraboloid:5um"]
    compliance = 1 / 2e3 + (1 / 6e3 - 1 / 2e3) * np.exp(-t / 0.5)
    z = CONTACT + inverse(F0 * compliance) + 1e-9 * rng.standard_normal(t.size)
    curves = make_curves(t, np.full(t.size, F0), -z, np.zeros_like(z), tip_position=z,
                         segment=0, segment_names=("pause",))
    with pytest.raises(ParameterError, match="needs the approach before the pause"):
        fit_creep(curves, tip="paraboloid:5um", segment=0)
    with pytest.warns(DataWarning, match="the load is a step"):
        ds = fit_creep(curves, tip="paraboloid:5um", segment=0, contact_point=CONTACT)
    for n, v in (("tau", 0.5), ("E0", 6e3), ("E_inf", 2e3)):
        assert abs(float(ds[n]) - v) < 5 * float(ds[f"{n}_stderr"]), n


def test_a_shrinking_contact_warns(rng):
    """An overshoot of 40 % released in 5 ms: the contact area falls; Lee–Radok is approximate."""
    curves = synthetic_curve("paraboloid:5um", SLS, rng, overshoot=0.4, t_overshoot=0.005,
                             monotone=False)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = fit_creep(curves, tip="paraboloid:5um")
    assert ds.attrs["contact_area_decrease"] > 0.01
    assert any(w.category is ModelValidityWarning and "contact area shrinks" in str(w.message)
               for w in caught)


# ── without a tip ───────────────────────────────────────────────────────────────────────────


def test_without_a_tip_the_fit_is_phenomenological_and_says_so(rng):
    curves = synthetic_curve("paraboloid:5um", SLS, rng)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = fit_creep(curves)
    assert any(w.category is ModelValidityWarning and re.search(
        "only for a flat punch.*give the tip", str(w.message), re.IGNORECASE) for w in caught)
    assert {"z_inf", "dz_1", "tau_1"} <= set(ds.data_vars) and "E0" not in ds
    assert ds.attrs["creep_form"] == "phenomenological"
    assert "biased" in ds.attrs["validity"]
    # the bias it warns of: the exponential's time is not the creep time of a paraboloid
    assert float(ds["tau_1"]) < 0.5 * 0.99
    for bad in ({"poisson": 0.3}, {"contact_point": CONTACT}):
        with pytest.raises(ParameterError, match="need the tip"):
            fit_creep(curves, **bad)


# ── the registry entry ──────────────────────────────────────────────────────────────────────


def test_the_entry_declares_both_forms():
    from viscoforce.fitting.models import MODELS, make_model

    entry = MODELS["creep"]
    assert {"--tip", "--contact-point"} <= set(entry.flags)
    assert entry.parameters(1, None) == ["z_inf", "dz_1", "tau_1"]
    assert entry.parameters(1, None, tip="cone:20") == ["tau", "E0", "E_inf", "contact_point"]
    assert entry.parameters(2, None, tip="cone:20") == [
        "E0", "E_1", "E_inf", "tau_1", "tau_2", "contact_point"]
    for modes in (1, 2, 3):
        for name in entry.parameters(modes, None, tip="cone:20"):
            assert entry.parameter_unit(name)
    with pytest.raises(ParameterError, match="needs creep_history"):
        make_model("creep", 1, tip="cone:20")
    with pytest.raises(ParameterError, match="with a tip only"):
        make_model("creep", 1, contact_point=1e-6)


# ── the real creep curve ────────────────────────────────────────────────────────────────────

CC_GEL = REAL_DATA_DIR / "afmformats" / "fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force"


@pytest.mark.skipif(not CC_GEL.is_file(), reason="shared real data absent")
def test_real_creep_curve_reports_moduli_with_a_tip():
    from viscoforce.io.instruments import load_instrument

    curves = load_instrument(CC_GEL)
    ds = _fit(curves, tip="sphere:5um", poisson=0.5)
    assert ds.attrs["creep_form"] == "lee-radok" and ds.attrs["segment_type"] == (
        "constant-force-pause")
    for n in ("tau", "E0", "E_inf", "E0_young", "E_inf_young", "E0_shear"):
        assert float(ds[n]) > 0 and 0 < float(ds[f"{n}_stderr"]) < float(ds[n]), n
    assert float(ds["E0"]) > float(ds["E_inf"])
    assert 0.05 < float(ds["tau"]) < 3.0  # within the 3 s pause
    assert ds.attrs["creep_force"] == pytest.approx(1.01e-8, rel=0.05)
    assert ds.attrs["contact_area_decrease"] < 0.01  # the 6 % overshoot: the contact still grows
