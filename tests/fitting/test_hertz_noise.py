"""Hertz on approaches that hold no indentation, or whose tip-position sign is flipped (issue 40).

A force curve of pure noise must not give a "determined" E, and a curve whose tip position runs
the wrong way (the force rises toward negative indentation) must say so; a clean Hertz curve
with realistic noise must keep a determined E within its stated stderr of the truth.

Synthetic curves come from the textbook closed forms written out here (Hertz's paraboloid,
Sneddon's cone, with E* = E/2 the paper's convention), not from ``viscoforce.physics.tips``, as
in tests/fitting/test_force_curves.py.
"""

from __future__ import annotations

import math
import warnings

import lmfit
import numpy as np
import pytest

from viscoforce.exceptions import DataWarning
from viscoforce.fitting import _params
from viscoforce.fitting.curves import fit_curve
from viscoforce.fitting.fit import local_identifiability
from viscoforce.fitting.hertz_checks import SIGNAL_SIGMA
from viscoforce.fitting.identify import IDENTIFIABILITY, WIDEST_DETERMINED, profile_parameters
from viscoforce.schema import make_curves

E_PAPER = 3.0e3  # [Pa], the paper's E = 2 E*
E_STAR = E_PAPER / 2
TAN20 = math.tan(math.radians(20.0))

#: Textbook loads F(δ) [N] with E* = E/2 (Johnson 1985; Sneddon 1965).
TEXTBOOK = {
    "paraboloid:5um": lambda d: 4 / 3 * E_STAR * math.sqrt(5e-6) * d ** 1.5,
    "cone:20": lambda d: 2 / math.pi * E_STAR * TAN20 * d ** 2,
}


def _approach(law, rng, *, noise, n=1200, contact=1.8e-6, baseline=-5e-9, slope=2e-4):
    """Tip position z [m] (toward the sample, in time order) and F [N] with white noise [N]."""
    z = np.linspace(-1.0e-6, 2.6e-6, n)
    f = baseline + slope * (z - contact) + law(np.maximum(z - contact, 0.0))
    return z, f + rng.normal(0.0, noise, n)


def _curves(z, f):
    return make_curves(np.linspace(0, 1, z.size), f, -z, np.zeros_like(z), tip_position=z,
                       segment=0, segment_names=("approach",), source="synthetic")


def _fit(z, f, tip):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = fit_curve(_curves(z, f), "hertz", tip=tip)
    return ds, [(w.category, str(w.message)) for w in caught]


def _code(ds, name):
    return IDENTIFIABILITY[int(ds["identifiability"].sel(param_i=name))]


# ── pure noise ──────────────────────────────────────────────────────────────────────────────────

#: Noise-only approaches: (tip, noise [N], seeds, kind). The cone's z from 0 to 3.6 µm, 30 pN of
#: white noise, no baseline tilt: seed 19 is the issue's case (before the fix its profile bounded
#: E on both sides, 1.4 Pa .. 30 kPa, 4.3 decades, and called it determined). The sphere's on the
#: approach of tests/fitting/test_force_curves.py (tilted baseline, 7 pN). Cone seeds 10, 11, 12, 18 and
#: sphere seed 2 have no contact point with E > 0 at all (before the fix the guess raised).
#: The sphere's exact profile makes each of its fits ~0.7 s (its Hertz shape solves s tanh s at
#: every evaluation): CI runs its seeds 0-2 (seed 2 included) with all ten cone seeds (seed 19
#: included); its seeds 3-9 are the slow study (``-m slow``), the same assertions.
NOISE_CASES = [("cone:20", 3e-11, range(10, 20), "flat"),
               ("sphere:5um", 7.2e-12, range(10), "tilted")]
SLOW_NOISE_SEEDS = {"sphere:5um": range(3, 10)}


@pytest.mark.parametrize(("tip", "noise", "seed", "kind"), [
    pytest.param(t, s, seed, k,
                 marks=[pytest.mark.slow] if seed in SLOW_NOISE_SEEDS.get(t, ()) else [])
    for t, s, seeds, k in NOISE_CASES for seed in seeds])
def test_noise_only_approach_is_not_determined_and_says_so(tip, noise, seed, kind):
    rng = np.random.default_rng(seed)
    if kind == "flat":
        z = np.linspace(0.0, 3.6e-6, 1200)
        f = rng.normal(0.0, noise, z.size)
    else:
        z, f = _approach(lambda d: 0.0 * d, rng, noise=noise)
    ds, caught = _fit(z, f, tip)
    assert _code(ds, "E") != "determined", (float(ds["E"]), float(ds["E_lower"]),
                                            float(ds["E_upper"]))
    assert _code(ds, "contact_point") != "determined"
    assert any(c is DataWarning and "no detectable indentation" in m for c, m in caught), caught
    assert not any("flipped" in m for _, m in caught)  # noise rises neither way
    # the fitted indentation force at the deepest point is within the noise
    assert ds.attrs["indentation_signal"] < SIGNAL_SIGMA


# ── the identifiability rule: a bounded but wide 2σ interval is not determined ──────────────────

@pytest.mark.parametrize("relative", [0.9, 1.1])
def test_profile_wider_than_the_local_rule_is_not_determined(relative):
    """χ² = ((log10 E − 2)/s)²: the profile's 2σ limits are 10^(2 ± 2s) exactly.

    The local test calls E not determined when stderr > E; σ(ln E) = s ln 10 = stderr/E, so the
    same verdict at relative = stderr/E = 0.9 (limits a factor e^3.6 apart: determined) and 1.1
    (e^4.4: not determined, though bounded on both sides).
    """
    s = relative / math.log(10.0)
    layout = [_params.Chain(("E",))]
    best = lmfit.Parameters()
    best.add("log_E", value=2.0, min=-4.0, max=8.0)

    def residual(params):
        return np.array([(params["log_E"].value - 2.0) / s])

    prof = profile_parameters(layout, residual, best, {"E": relative * 100.0}, 0.0, 1.0)["E"]
    assert prof.lower == pytest.approx(10 ** (2 - 2 * s), rel=0.02)
    assert prof.upper == pytest.approx(10 ** (2 + 2 * s), rel=0.02)
    assert WIDEST_DETERMINED == pytest.approx(math.exp(4.0), rel=1e-12)
    local = local_identifiability({"E": 100.0}, {"E": relative * 100.0}, [])["E"]
    assert prof.code == local == (0 if relative < 1 else 3)


# ── the tip position's sign flipped ─────────────────────────────────────────────────────────────

@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("tip", list(TEXTBOOK))
def test_flipped_tip_position_warns_and_e_is_not_determined(tip, seed):
    rng = np.random.default_rng(seed)
    z, f = _approach(TEXTBOOK[tip], rng, noise=30e-12, slope=1e-5)
    ds, caught = _fit(-z, f, tip)  # the height's sign flipped: the force rises toward -z
    flipped = [m for c, m in caught if c is DataWarning and "flipped" in m]
    assert flipped and "negative indentation" in flipped[0], caught
    assert _code(ds, "E") != "determined"
    assert _code(ds, "contact_point") != "determined"
    assert ds.attrs["approach_direction"].startswith("reversed")


# ── the control: a clean Hertz approach keeps its E ─────────────────────────────────────────────

@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("tip", list(TEXTBOOK))
def test_clean_hertz_keeps_a_determined_e_within_its_stderr(tip, seed):
    """30 pN of noise on a 3.2 nN (paraboloid) or 0.22 nN (cone: 7 noise levels) rise.

    No false alarm: E determined and within 3 stated stderr of the truth on each of 8 fits
    (0.3 % each were the seeds random). The significance of the indentation is the independent
    √λ, λ = Σ (noiseless curve − its least-squares line)²/σ² (the non-centrality of the
    likelihood ratio; within 10 %: σ from ~1000 residuals and the lag-1 factor each ≈ 3 %, the
    noise's share of Δχ² 1/√λ). The same curve in reverse sample order (a retract-ordered
    array) is not called flipped: the direction is read from where the force rises along z.
    """
    rng = np.random.default_rng(seed)
    noise = 30e-12
    z, f = _approach(TEXTBOOK[tip], rng, noise=noise, slope=1e-5)
    clean = _approach(TEXTBOOK[tip], rng, noise=0.0, slope=1e-5)[1]
    line = np.polyval(np.polyfit(z, clean, 1), z)
    expected = math.sqrt(float((clean - line) @ (clean - line))) / noise
    for order in (slice(None), slice(None, None, -1)):
        ds, caught = _fit(z[order], f[order], tip)
        assert _code(ds, "E") == "determined"
        assert abs(float(ds["E"]) - E_PAPER) < 3 * float(ds["E_stderr"]), (
            float(ds["E"]), float(ds["E_stderr"]))
        assert not any(c is DataWarning for c, _ in caught), caught
        assert ds.attrs["indentation_signal"] == pytest.approx(expected, rel=0.10)
        assert ds.attrs["indentation_signal"] > SIGNAL_SIGMA
        assert ds.attrs["approach_direction"].startswith("as recorded")


# ── maps: each pixel takes the same verdict ─────────────────────────────────────────────────────

def test_a_hertz_map_marks_noise_and_flipped_pixels_not_determined():
    """Three curves, one map: clean, noise only, flipped. Only the clean one is quality 0."""
    from viscoforce.fitting.maps import fit_map

    tip = "paraboloid:5um"
    rng = np.random.default_rng(7)
    clean = _approach(TEXTBOOK[tip], rng, noise=30e-12, slope=1e-5)
    noise = _approach(lambda d: 0.0 * d, rng, noise=30e-12, slope=0.0)
    z, f = _approach(TEXTBOOK[tip], rng, noise=30e-12, slope=1e-5)
    curves = [clean, noise, (-z, f)]
    zs = np.concatenate([c[0] for c in curves])
    fs = np.concatenate([c[1] for c in curves])
    ds = make_curves(np.tile(np.linspace(0, 1, z.size), 3), fs, -zs, np.zeros_like(zs),
                     tip_position=zs, segment=0, segment_names=("approach",),
                     sample_count=[z.size] * 3, source="synthetic")
    result = fit_map(ds, "hertz", tip=tip, scheduler="synchronous", progress=False)
    quality = result["quality"].values.tolist()
    assert quality[0] == 0 and quality[1] == 3 and quality[2] == 3, quality
    messages = [str(m) for m in result["message"].values]
    assert "no detectable indentation" in messages[1]
    assert "looks flipped" in messages[2]
    assert float(result["E"][0]) == pytest.approx(E_PAPER, rel=0.05)


# ── the depth check on real approaches (issue 37 item 6a) ───────────────────────────────────────

#: Real approaches (../shared/data/real) → (curve, tip; None: the file's own) and the shift of E
#: refitted to half the contact force that the depth check reported before issue 37, in
#: "standard errors" (√(σ_shallow² − σ_full²), floored at 1e-3 σ_full: 0 wherever the full fit's
#: residuals, inflated by the law's misfit, gave it the larger stderr).
REAL_DEPTH_CASES = {
    "PyFMReader/20200904_Egel4-Z1.0_00025.uff": (0, None, 3112.8),  # +6.7 %
    "afmformats/fmt-igor-fd_U3_3_p10004.ibw": (0, "sphere:5um", 6009.4),  # +13.2 %
    "afmformats/fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force": (0, "sphere:5um", -6241.3),  # -11 %
    "afmformats/fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force": (0, "sphere:5um", -11.8),
    "afmformats/fmt-jpk-sr_cell1-0008.jpk-force": (0, "sphere:5um", -4011.1),  # -31 %
    "PyFMRheo/map-data-2022.10.29-12.27.34.564.jpk-force-map": (0, "sphere:5um", -45363.6),
    "PyFMReader/map-data-2021.11.05-17.37.44.432.jpk-force-map": (3, "sphere:5um", -7764.6),
}


@pytest.mark.parametrize("name", sorted(REAL_DEPTH_CASES))
def test_the_depth_check_on_real_approaches_is_never_thousands_of_standard_errors(name):
    """|shift| <= |relative| / 1 % (the resolution floor): below 100 for shifts below 20 %, here
    below 40 for all (the largest, -44 % on the PyFMRheo map, is -28); the % is in the text.
    """
    from tests.conftest import REAL_DATA_DIR
    from viscoforce.io.instruments import load_instrument

    path = REAL_DATA_DIR / name
    if not path.is_file():
        pytest.skip("shared real data absent")
    curve, tip, before = REAL_DEPTH_CASES[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = fit_curve(load_instrument(path), "hertz", curve=curve,
                       **({} if tip is None else {"tip": tip}))
    shift = ds.attrs["depth_check_shift"]
    relative = ds.attrs["depth_check_E"] / float(ds["E"]) - 1  # depth_check_relative
    if abs(relative) < 0.2:
        assert abs(shift) < 100, (shift, relative)
    assert abs(shift) < 40 and abs(shift) < abs(before), (shift, relative)
    from viscoforce.fitting.hertz_checks import DEPTH_CHECK_RESOLUTION

    assert abs(shift) <= abs(relative) / DEPTH_CHECK_RESOLUTION * (1 + 1e-9)
    assert np.sign(shift) == np.sign(relative) == np.sign(before)
    assert f"{100 * relative:+.1f} %" in ds.attrs["depth_check"]
    assert ds.attrs["depth_check_relative"] == pytest.approx(relative, rel=1e-12)
