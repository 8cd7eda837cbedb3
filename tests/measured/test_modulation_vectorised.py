"""Vectorised contact-point search and one lock-in window per segment give the former results."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.measured.test_modulation import hertz_approach
from viscoforce.experiments import modulation
from viscoforce.experiments.modulation import demodulate_segment, find_contact_point
from viscoforce.lockin import demodulate

#: (samples, seed, exponent, z_contact [m], amplitude [N/m^p], z_threshold [m]) of the Python-loop
#: grid search (viscoforce before the vectorisation, 2026-12-01) on
#: ``hertz_approach(np.random.default_rng(seed), n=samples, tilt=2e-5, exponent=exponent)``.
#: 1200 samples take the 400-point linspace grid, 300 the grid of sample positions.
REFERENCE = (
    (1200, 0, 1.5, -8.703155372248356e-06, 3.009887533154134, -8.657047539616346e-06),
    (1200, 0, 1.0, -8.701724031228752e-06, 0.001668108224254474, -8.687739783152628e-06),
    (1200, 1, 1.5, -8.701831029315351e-06, 3.023501929233921, -8.6628023352794e-06),
    (1200, 1, 1.0, -8.700787629804534e-06, 0.0016692311443222143, -8.685821517931609e-06),
    (1200, 2, 1.5, -8.70032899239752e-06, 3.031234174529691, -8.65512927439533e-06),
    (1200, 2, 1.0, -8.70041298428594e-06, 0.0016610435171586124, -8.683903252710592e-06),
    (300, 0, 1.5, -8.693411996459526e-06, 3.106693259806508, -8.653846153846153e-06),
    (300, 0, 1.0, -8.695949559253839e-06, 0.0016638621428432677, -8.684615384615384e-06),
    (300, 1, 1.5, -8.700173338772487e-06, 3.0636170675986087, -8.66153846153846e-06),
    (300, 1, 1.0, -8.699790845742964e-06, 0.0016799291364136908, -8.684615384615384e-06),
    (300, 2, 1.5, -8.698958670563568e-06, 3.0623654820494224, -8.66153846153846e-06),
    (300, 2, 1.0, -8.698699262637105e-06, 0.0016764108435399928, -8.692307692307692e-06),
)


@pytest.mark.parametrize(("n", "seed", "exponent", "z_contact", "amplitude", "z_threshold"), REFERENCE)
def test_contact_point_matches_the_loop_search(n, seed, exponent, z_contact, amplitude, z_threshold):
    z, f = hertz_approach(np.random.default_rng(seed), n=n, tilt=2e-5, exponent=exponent)
    c = find_contact_point(z, f, exponent=exponent)
    assert c["z_threshold"] == z_threshold                   # the threshold is not searched
    # the bounded refinement stops at xatol = 1e-6 (hi - lo): allow ten times that
    lo = float(np.max(z[: int(0.3 * z.size)]))
    assert abs(c["z_contact"] - z_contact) <= 1e-5 * (z_threshold - lo)
    np.testing.assert_allclose(c["amplitude"], amplitude, rtol=1e-6)


@pytest.mark.parametrize("exponent", [1.0, 1.5, 2.0, 1.3])
def test_power_law_fits_chunked_and_special_powers(exponent, monkeypatch):
    rng = np.random.default_rng(3)
    z = np.sort(rng.uniform(0, 1, 300))
    r = np.clip(z - 0.4, 0, None) ** exponent * 2.0 + 0.01 * rng.standard_normal(300)
    grid = np.linspace(0.1, 0.7, 57)
    costs, amps = modulation._power_law_fits(z, r, grid, exponent)
    for zc, cost, amp in zip(grid, costs, amps, strict=True):     # the scalar formulas
        g = np.clip(z - zc, 0.0, None) ** exponent
        a = float(g @ r) / float(g @ g)
        np.testing.assert_allclose(amp, a, rtol=1e-12)
        np.testing.assert_allclose(cost, float((r - a * g) @ (r - a * g)), rtol=1e-10)
    monkeypatch.setattr("viscoforce.experiments.contact_point._FIT_CHUNK", 1000)  # 3 candidates per chunk
    chunked = modulation._power_law_fits(z, r, grid, exponent)
    np.testing.assert_allclose(chunked[0], costs, rtol=1e-14)
    np.testing.assert_allclose(chunked[1], amps, rtol=1e-14)
    # a candidate past every sample: the model vanishes, A = 0 and the cost is Σ r²
    costs, amps = modulation._power_law_fits(z, r, np.array([2.0]), exponent)
    assert amps[0] == 0.0 and costs[0] == pytest.approx(float(r @ r), rel=1e-14)


@pytest.mark.parametrize("detrend", ["linear", None])
def test_one_window_per_segment_equals_one_window_per_signal(detrend):
    rng = np.random.default_rng(7)
    f, per_period, periods = 30.0, 133, 12
    t = 0.25 + np.arange(per_period * periods) / (per_period * f)
    w = 2 * math.pi * f
    force = 1e-9 + 2e-10 * np.sin(w * t + 0.4) + 3e-12 * t + 1e-12 * rng.standard_normal(t.size)
    tip = 1e-8 * np.sin(w * t) + 2e-10 * t + 1e-11 * rng.standard_normal(t.size)
    height = -1.1e-8 * np.sin(w * t) + 2e-5
    settle = 1 / f - (t[1] - t[0])
    out = demodulate_segment(t, force, tip, f, settle=settle, detrend=detrend, height=height)
    for key, signal in (("F", force), ("d", tip), ("h", height)):
        alone = complex(demodulate(signal, t, w, settle=settle, detrend=detrend))
        assert abs(out[key] - alone) <= 1e-12 * abs(alone), key
    mean = complex(demodulate(force, t, w, harmonic=0, settle=settle, detrend=detrend)).real
    assert out["mean_force"] == pytest.approx(mean, rel=1e-12)
    assert out["n"] == per_period * (periods - 1) + 1 and out["periods"] == periods - 1
    assert demodulate_segment(t, force, tip, f, settle=settle, detrend=detrend)["h"] is None


def test_segment_samples_slices_contiguous_rows_and_masks_split_ones():
    seg = np.array([4, 4, 2, 2, 2, 7, 4, 9])
    where = modulation._segment_samples(seg)
    assert list(where) == [4, 2, 7, 9]                       # order of first appearance
    assert where[2] == slice(2, 5) and where[7] == slice(5, 6) and where[9] == slice(7, 8)
    np.testing.assert_array_equal(where[4], seg == 4)         # split row: a mask
