"""Hertz, Ting and the complex modulus on a layer of finite thickness (issue 37 item 5).

Oracles: curves made with :func:`viscoforce.physics.bottom_effect.force_factor` (Hertz), the
elastic limit of Ting's integral (the corrected Hertz law on approach and retract), the
closed-form power-law ramp of each series term (Ting on the layer), and k*/(S·g) (the complex
modulus). The published Dimitriadis coefficients are checked in tests/theory/test_bottom_effect.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import least_squares
from scipy.special import beta as beta_function

from viscoforce.exceptions import ParameterError
from viscoforce.fitting.data import FitData
from viscoforce.fitting.fit import fit_data
from viscoforce.fitting.models import make_model
from viscoforce.physics.bottom_effect import (
    bottom_effect_series,
    force_factor,
    max_depth,
    stiffness_factor,
)
from viscoforce.physics.layered_tip import LayeredTip
from viscoforce.physics.ting import PowerLawRelaxation, ting_force
from viscoforce.physics.tips import Cone, Paraboloid

PARABOLOID, CONE, HEIGHT = Paraboloid(5e-6), Cone(np.radians(35.0)), 5e-6


def _approach(tip, height, rng, e=2000.0, deepest=1e-6):
    """An approach to ``deepest`` on the layer: baseline 1 nN, tilt 1e-4 N/m, noise 1e-4 of the peak.

    The series itself beyond its accepted range (``force_factor`` would refuse it).
    """
    z = np.linspace(-1e-6, deepest, 600)
    d = np.maximum(z, 0.0)
    s = bottom_effect_series(tip)
    x = (np.tan(tip.half_angle) * d if isinstance(tip, Cone) else np.sqrt(tip.radius * d)) / height
    f = 1e-9 + 1e-4 * z + e * tip.force_shape(d) * s.factor(x)
    f = f + 1e-4 * float(np.max(f)) * rng.standard_normal(z.size)
    return FitData(z, f, None, {}), d


@pytest.mark.parametrize(("tip", "height", "least"), [
    (PARABOLOID, HEIGHT, 1.5),  # chi up to 0.45
    (CONE, 2e-6, 1.3),  # tan(theta) delta/h up to 0.35
])
def test_hertz_on_the_layer_recovers_e_and_the_half_space_is_off_as_expected(tip, height, least,
                                                                              rng):
    data, d = _approach(tip, height, rng)
    fit = fit_data(data, "hertz", tip=tip, sample_height=height, profile=False)
    assert float(fit["E"]) == pytest.approx(2000.0, rel=1e-3)
    assert float(fit["contact_point"]) == pytest.approx(0.0, abs=2e-9)
    assert fit.attrs["sample_height"] == height and fit.attrs["sample_base"] == "bonded"
    assert fit.attrs["bottom_effect_series"].startswith("garcia")
    assert fit.attrs["bottom_effect_max_depth"] == pytest.approx(float(max_depth(tip, height)))
    # the half-space fit is off by what scipy's least squares of the half-space law (E, contact
    # point, baseline, tilt all free) on the noise-free curve says: an independent minimiser
    plain = fit_data(data, "hertz", tip=tip, profile=False)
    clean = 1e-9 + 1e-4 * data.x + 2000.0 * tip.force_shape(d) * force_factor(tip, d, height)

    def residual(p):
        delta = np.maximum(data.x - p[1] * 1e-6, 0.0)
        return (p[2] * 1e-9 + p[3] * 1e-4 * (data.x - p[1] * 1e-6)
                + p[0] * 1e3 * tip.force_shape(delta) - clean) / 1e-9

    best = least_squares(residual, [2.0, 0.0, 1.0, 1.0], x_scale="jac", xtol=1e-14,
                         ftol=1e-14).x
    assert float(plain["E"]) == pytest.approx(best[0] * 1e3, rel=1e-3)
    assert float(plain["E"]) / 2000.0 > least and "sample_height" not in plain.attrs


def test_hertz_refuses_an_approach_deeper_than_the_series_before_the_fit(rng):
    data, _ = _approach(PARABOLOID, HEIGHT, rng, deepest=2e-6)  # chi 0.63 > 0.5
    with pytest.raises(ParameterError, match=r"depth \(indentation\) must be <= 1.25 µm at "
                                             r"sample_height 5 µm"):
        fit_data(data, "hertz", tip=PARABOLOID, sample_height=HEIGHT, profile=False)
    with pytest.raises(ParameterError, match="sample_base describes the layer of sample_height"):
        fit_data(data, "hertz", tip=PARABOLOID, sample_base="sliding", profile=False)


# ── Ting ──────────────────────────────────────────────────────────────────────────────────────

V, TM = 5e-6, 0.2  # ramp speed [m/s], turning time [s]: 1 µm deep


def _triangle(n=400):
    h = TM / n
    t = np.arange(round(-0.02 / h), round(0.4 / h) + 1) * h
    return t, np.where(t <= TM, V * t, V * (2 * TM - t))


def _ting(material, **fixed):
    t, z = _triangle()
    return t, z, make_model("ting", tip=PARABOLOID, position_trace=(t, z), material=material,
                            contact_point=0.0, **fixed)


def test_ting_elastic_limit_is_the_corrected_hertz_on_approach_and_retract():
    t, z, model = _ting("sls", sample_height=HEIGHT)
    e = 1500.0  # E0 = E_inf (1 + 1e-12): no relaxation to speak of
    force = model.raw(t, {"E0": e * (1 + 1e-12), "E_inf": e, "tau": 0.05, "baseline": 0.0,
                          "baseline_slope": 0.0})
    d = np.maximum(z, 0.0)
    hertz = e * PARABOLOID.force_shape(d) * force_factor(PARABOLOID, d, HEIGHT)
    np.testing.assert_allclose(force, hertz, rtol=1e-6, atol=1e-6 * float(np.max(hertz)))
    assert model.spec.fixed["sample_height"] == HEIGHT and model.spec.fixed["tip"] == PARABOLOID


def test_ting_on_the_layer_is_each_series_term_convolved_with_the_power_law():
    """Approach of a ramp δ = vt: F = E0 Σ_k C c_k (√R/h)^k p_k v^p_k t^(p_k − β) B(p_k, 1 − β).

    Each term g·c_k·x^k = C c_k (√R/h)^k δ^p_k, p_k = 3/2 + k/2, convolved with t^−β (the
    correspondence principle term by term); the half-space Ting force times f(δ(t)) differs
    from it by the ratio of the Beta weights (4.7 % of the first term at β = 0.2).
    """
    beta, e0 = 0.2, 1000.0
    t, z = _triangle(4000)
    tip = LayeredTip(PARABOLOID, HEIGHT)
    load = ting_force(t, z, 0.0, tip, PowerLawRelaxation(e0, beta))
    c = float(PARABOLOID.force_shape(1.0))  # g = C δ^{3/2}
    coefficients = (1.0, *bottom_effect_series(PARABOLOID).coefficients)
    on = (t > 0) & (t <= TM)
    expected = np.zeros(on.sum())
    for k, ck in enumerate(coefficients):
        p = 1.5 + 0.5 * k
        expected += (e0 * c * ck * (np.sqrt(5e-6) / HEIGHT) ** k * p * V**p
                     * t[on] ** (p - beta) * beta_function(p, 1 - beta))
    np.testing.assert_allclose(load[on], expected, rtol=2e-3, atol=1e-3 * expected.max())
    crude = ting_force(t, z, 0.0, PARABOLOID, PowerLawRelaxation(e0, beta))[on] * force_factor(
        PARABOLOID, np.maximum(z[on], 0.0), HEIGHT)
    assert np.max(np.abs(crude / expected - 1)[-10:]) > 0.005  # the two forms differ


def test_ting_fit_on_the_layer_recovers_e0_and_beta(rng):
    t, z, model = _ting("structural", newtonian=False, sample_height=HEIGHT)
    truth = {"E_ref": 2000.0, "alpha": 0.25}
    f = model.raw(t, {**truth, "baseline": 1e-9, "baseline_slope": 0.0})
    f = f + 1e-4 * float(np.max(f)) * rng.standard_normal(t.size)
    from viscoforce.fitting.ting_model import TingData

    data = TingData(t - t[0], f, None, {}, position=z)
    fit = fit_data(data, "ting", tip=PARABOLOID, position_trace=(t - t[0], z),
                   material="structural", newtonian=False, sample_height=HEIGHT, profile=False)
    for name, value in truth.items():
        assert float(fit[name]) == pytest.approx(value, rel=2e-3), name
    assert float(fit["contact_point"]) == pytest.approx(0.0, abs=2e-9)
    # Ting's E0 and beta (t0 = 1 s) of the fitted structural parameters (beta = alpha)
    fitted = PowerLawRelaxation.from_structural(float(fit["E_ref"]), float(fit["alpha"]))
    assert fitted.E0 == pytest.approx(PowerLawRelaxation.from_structural(2000.0, 0.25).E0,
                                      rel=2e-3)
    assert fit.attrs["sample_height"] == HEIGHT and fit.attrs["tip_shape"] == "paraboloid"


def test_ting_refuses_a_fixed_contact_point_deeper_than_the_series():
    with pytest.raises(ParameterError, match="sample_height 2 µm"):
        _ting("sls", sample_height=2e-6)  # 1 µm deep: chi 1.1


def test_ting_flat_punch_on_the_layer_is_scaled_by_its_constant_factor():
    from viscoforce.physics.tips import Flat

    t, z = _triangle()
    flat = Flat(1e-6)
    fixed = {"tip": flat, "position_trace": (t, z), "material": "sls", "contact_point": 0.0}
    values = {"E0": 3000.0, "E_inf": 1000.0, "tau": 0.05, "baseline": 0.0, "baseline_slope": 0.0}
    on = make_model("ting", sample_height=HEIGHT, **fixed).raw(t, values)
    off = make_model("ting", **fixed).raw(t, values)
    np.testing.assert_allclose(on, off * float(force_factor(flat, 0.0, HEIGHT)), rtol=1e-12)


# ── the complex modulus ───────────────────────────────────────────────────────────────────────


def _spectrum(depth=(0.5e-6, 1e-6)):
    from viscoforce.schema import make_spectrum

    omega = 2 * np.pi * np.logspace(0, 2, 5)
    k = (3e3 + 1e3j) * float(PARABOLOID.contact_stiffness_factor(1e-6)) * np.exp(1j * omega / 1e3)
    one = make_spectrum(omega, k, np.full(omega.size, 1e-9), 1e-8,
                        stderr={"stiffness": 1e-2 * np.abs(k), "phase": np.full(omega.size, 0.1)})
    import xarray as xr

    ds = xr.concat([one, one], dim="curve")
    return ds.assign(mean_indentation=("curve", np.asarray(depth), {"units": "m"}))


@pytest.mark.parametrize("base", ["bonded", "sliding"])
def test_complex_modulus_is_divided_by_the_stiffness_factor(base):
    from viscoforce.experiments.moduli import MODULUS_VARIABLES, add_complex_modulus

    ds = _spectrum() if base == "bonded" else _spectrum((0.05e-6, 0.1e-6))
    height = HEIGHT if base == "bonded" else 20e-6  # sliding: Dimitriadis, chi <= 0.1
    plain = add_complex_modulus(ds, PARABOLOID)
    layer = add_complex_modulus(ds, PARABOLOID, sample_height=height, sample_base=base)
    g = stiffness_factor(PARABOLOID, ds["mean_indentation"].values, height,
                         bonded=base == "bonded")
    for name in MODULUS_VARIABLES:
        for suffix in ("", "_stderr"):
            ratio = (plain[name + suffix] / layer[name + suffix]).transpose("curve", ...).values
            np.testing.assert_allclose(ratio, np.broadcast_to(g[:, None], ratio.shape),
                                       rtol=1e-12)
    assert layer.attrs["bottom_effect_factor_min"] == pytest.approx(g.min())
    assert layer.attrs["bottom_effect_factor_max"] == pytest.approx(g.max())
    assert layer.attrs["sample_base"] == base and layer.attrs["sample_height"] == height
    assert layer.attrs["bottom_effect_series"].startswith(
        "garcia" if base == "bonded" else "dimitriadis")


def test_complex_modulus_refuses_a_depth_beyond_the_series_and_a_lone_base():
    from viscoforce.experiments.moduli import add_complex_modulus

    with pytest.raises(ParameterError, match="sample_height 3 µm"):
        add_complex_modulus(_spectrum(), PARABOLOID, sample_height=3e-6)  # chi 0.75 at 1 µm
    with pytest.raises(ParameterError, match="sample_base describes the layer"):
        add_complex_modulus(_spectrum(), PARABOLOID, sample_base="bonded")
    with pytest.raises(ParameterError, match="poisson must be 0.5 for series 'garcia'"):
        add_complex_modulus(_spectrum(), CONE, poisson=0.4, sample_height=HEIGHT)
