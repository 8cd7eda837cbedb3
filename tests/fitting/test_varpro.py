"""Variable projection of the exponential sums (issue 41 item 2): the fast path against the old.

The projected search (:mod:`viscoforce.fitting._varpro`) only moves where each fit starts; the
engine's χ², covariance and stderr stay the full-parameter ones, and the profile's refits run on
the package's engine instead of ``lmfit.minimize``. The reference values below are the results
of the path before the change (lmfit refits, finite-difference search from the data's guess),
computed on this checkout on 2026-12-06 before the change was made; the tolerance is the brief's,
0.1 stderr for values, stderr and profile limits, with the same number of modes kept.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from tests.conftest import REAL_DATA_DIR
from viscoforce.fitting import _params
from viscoforce.fitting._varpro import ExponentialModel, project, search
from viscoforce.fitting.base import FitModel
from viscoforce.fitting.data import FitData
from viscoforce.fitting.fit import fit_data
from viscoforce.fitting.models import make_model

AFM = REAL_DATA_DIR / "afmformats"
HOLD = AFM / "fmt-jpk-sr_cell1-0008.jpk-force"
BRAIN = AFM / "fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force"
GEL = AFM / "fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force"
needs_real = pytest.mark.skipif(not HOLD.is_file(), reason="shared real data absent")
#: Largest difference allowed from the old path, in units of the old stderr.
TOLERANCE = 0.1

# (modes kept, {name: (value, stderr, 2σ lower, 2σ upper)}) of the old path (module docstring)
REFERENCE = {
    "hold/auto": (1, {
        "F_inf": (1.2155041118325458e-07, 1.3146099376401733e-09, 1.1892119130797423e-07,
                  1.2417963105853493e-07),
        "dF_1": (1.7089002281637262e-07, 5.9338937231951e-09, 1.5902223536998241e-07,
                 1.8275781026276283e-07),
        "tau_1": (3.2979293506648015, 0.19104977691549402, 2.937134245527103,
                  3.703044223647487)}),
    "brain/auto": (1, {
        "z_inf": (-1.596442790097918e-05, 3.032459585167029e-08, -1.6025077092682522e-05,
                  -1.590377870927584e-05),
        "dz_1": (-1.6047474194821771e-06, 2.484775891234926e-08, -1.6544429373068756e-06,
                 -1.5550519016574787e-06),
        "tau_1": (1.5151885409517132, 0.06715375343810524, 1.3866615452520017,
                  1.6556284570609912)}),
    "gel/auto": (1, {
        "z_inf": (-2.5587700046826826e-05, 1.176597135135577e-09, -2.55900532410971e-05,
                  -2.5585346852556554e-05),
        "dz_1": (-1.599992272715725e-07, 2.2395116324771316e-09, -1.6447825053652677e-07,
                 -1.5552020400661824e-07),
        "tau_1": (0.6777340326061453, 0.022281881084189572, 0.6346038029148985,
                  0.7237955663719584)}),
    # the piezo record of the brain curve: one-sided profiles (the engine's refits)
    "brain-height/1": (1, {
        "z_inf": (-1.7967147382436312e-05, 3.3960641622025194e-07, -1.8247226376174984e-05,
                  math.nan),
        "dz_1": (-6.809435324091245e-07, 3.257750068904446e-07, math.nan,
                 -4.1760324996250335e-07),
        "tau_1": (4.198754818308206, 2.941604311760208, 1.7926905707081506, math.nan)}),
    "synthetic/auto": (2, {
        "F_inf": (9.986283649335138e-08, 7.775299453915202e-11, 9.970733050427307e-08,
                  1.0001834248242968e-07),
        "dF_1": (1.9986447288287495e-07, 6.315474911591525e-10, 1.9860137790055665e-07,
                 2.0112756786519324e-07),
        "dF_2": (9.966717179877538e-08, 2.8740885987571573e-10, 9.909235407902395e-08,
                 1.002419895185268e-07),
        "tau_1": (0.20215812819971843, 0.001207508586078983, 0.19975747887067263,
                  0.20458762809913403),
        "tau_2": (3.0170215001724854, 0.014452738245475208, 2.9882540513045934,
                  3.046065888718249)}),
}


def _two_mode_data(seed: int = 0) -> FitData:
    """F = 0.1 + 0.2 e^{−t/0.2 s} + 0.1 e^{−t/3 s} µN, 2 nN white noise, 3000 samples of 5 ms."""
    rng = np.random.default_rng(seed)
    t = np.arange(3000) * 0.005
    y = 1e-7 + 2e-7 * np.exp(-t / 0.2) + 1e-7 * np.exp(-t / 3.0)
    return FitData(t, y + 2e-9 * rng.standard_normal(t.size), None, {"data_kind": "synthetic"})


def _agrees(ds, key: str) -> None:
    modes, reference = REFERENCE[key]
    assert int(ds["modes"]) == modes
    for name, (value, err, lower, upper) in reference.items():
        assert abs(float(ds[name]) - value) <= TOLERANCE * err, name
        assert abs(float(ds[f"{name}_stderr"]) - err) <= TOLERANCE * err, name
        for limit, side in ((lower, "lower"), (upper, "upper")):
            got = float(ds[f"{name}_{side}"])
            if math.isnan(limit):
                assert math.isnan(got), (name, side)
            else:
                assert abs(got - limit) <= TOLERANCE * err, (name, side)


# ── the projection itself ───────────────────────────────────────────────────────────────────

def test_projection_is_linear_least_squares_with_the_jacobian_of_its_residual():
    """c = lstsq(Φ, y) (an independent solve); on data in the model's span (zero residual,
    where Kaufman's dropped term vanishes) the Jacobian is the residual's own, by central
    differences; weights scale rows."""
    t = np.linspace(0.0, 10.0, 400)
    log_taus = np.log10([0.3, 2.0])
    phi = np.column_stack([np.ones_like(t), np.exp(-t[:, None] / 10 ** log_taus)])
    exact = phi @ np.array([1.0, 2.0, -0.5])
    noisy = exact + 0.01 * np.sin(7 * t)
    got = project(t, noisy, log_taus)
    assert got.rank_ok
    np.testing.assert_allclose(got.coef, np.linalg.lstsq(phi, noisy, rcond=None)[0], rtol=1e-9)
    np.testing.assert_allclose(got.residual, noisy - phi @ got.coef, atol=1e-12)
    at_zero = project(t, exact, log_taus)
    for i in range(2):
        step = np.zeros(2)
        step[i] = 1e-6
        fd = (project(t, exact, log_taus + step).residual
              - project(t, exact, log_taus - step).residual) / 2e-6
        np.testing.assert_allclose(at_zero.jacobian[:, i], fd, rtol=1e-5, atol=1e-9)
    w = np.linspace(1.0, 3.0, t.size)
    weighted = project(t, noisy, log_taus, w)
    np.testing.assert_allclose(weighted.coef, np.linalg.lstsq(
        phi * w[:, None], w * noisy, rcond=None)[0], rtol=1e-9)
    merged = project(t, noisy, np.log10([1.0, 1.0]))  # Φ has two equal columns
    assert not merged.rank_ok
    one = np.column_stack([np.ones_like(t), np.exp(-t)])  # the same span, full rank
    assert merged.chisqr == pytest.approx(
        float(np.linalg.lstsq(one, noisy, rcond=None)[1][0]), rel=1e-8)


def test_search_finds_noise_free_times_from_the_data_guess():
    """Noise-free two-mode data: the projected search lands on the truth (an exact minimum)."""
    t = np.arange(3000) * 0.005
    y = 1e-7 + 2e-7 * np.exp(-t / 0.2) + 1e-7 * np.exp(-t / 3.0)
    model = make_model("relaxation", 2)
    assert isinstance(model, ExponentialModel)
    params = FitModel.internal_guess(model, y, t)  # the data's guess, not yet searched
    chi2 = search(t, y, params, "F_inf", ("dF_1", "dF_2"), ("tau_1", "tau_2"))
    values = _params.reported_values(model.layout, params.valuesdict())
    assert chi2 < 1e-20 * float(y @ y)
    for name, truth in (("tau_1", 0.2), ("tau_2", 3.0), ("dF_1", 2e-7), ("dF_2", 1e-7),
                        ("F_inf", 1e-7)):
        assert values[name] == pytest.approx(truth, rel=1e-6)


def test_fixed_times_are_not_searched():
    t = np.linspace(0, 1, 50)
    params = make_model("relaxation", 1).internal_guess(np.exp(-t / 0.3), t)
    params["log_tau_1"].set(vary=False)
    before = params.valuesdict()
    assert math.isnan(search(t, np.exp(-t / 0.3), params, "F_inf", ("dF_1",), ("tau_1",)))
    assert params.valuesdict() == before


# ── the fast path against the old one ───────────────────────────────────────────────────────

def test_synthetic_two_modes_agree_with_the_old_path():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = fit_data(_two_mode_data(), "relaxation", modes="auto")
    _agrees(ds, "synthetic/auto")


@needs_real
@pytest.mark.parametrize(("key", "path", "model", "modes", "height"), [
    ("hold/auto", HOLD, "relaxation", "auto", None),
    ("brain/auto", BRAIN, "creep", "auto", None),
    ("gel/auto", GEL, "creep", "auto", None),
    ("brain-height/1", BRAIN, "creep", 1, "height"),
])
def test_real_curves_agree_with_the_old_path(key, path, model, modes, height):
    from viscoforce.fitting.curves import fit_curve
    from viscoforce.io.instruments import load_instrument

    curves = load_instrument(path, height_channel=height)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = fit_curve(curves, model, modes=modes)
    _agrees(ds, key)
