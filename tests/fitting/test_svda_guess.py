"""The svda model's start: its closed form inverted, checked against the forward closed form.

The oracle is :func:`viscoforce.svda.svda_complex_stiffness` (validated against the ODE and the
exact solver in test_svda.py): its ω = 0 and ω → ∞ stiffness at known moduli must give the moduli
back, at a fixed position and at a fixed mean force.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from viscoforce.exceptions import ApproximationWarning
from viscoforce.fitting.base import MODULUS_BOUNDS
from viscoforce.fitting.models import make_model
from viscoforce.fitting.spectrum_models import svda_moduli_from_levels, svda_position
from viscoforce.svda import svda_complex_stiffness

R, P, DEBYE = 10e-6, 1e7, 1e-9
CASES = [(2e-9, 1e10, 1e9), (1e-9, 5e9, 1e8), (5e-9, 3e8, 1e7), (3e-9, 2e11, 1e11)]


def levels(position, e0, e_inf):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ApproximationWarning)
        k = svda_complex_stiffness(np.array([0.0, 1e15]), position, e0, e_inf, 1e-3, R, P, DEBYE)
    return float(abs(k[0])), float(abs(k[1]))


@pytest.mark.parametrize(("position", "e0", "e_inf"), CASES)
def test_the_levels_give_the_moduli_back_at_a_position(position, e0, e_inf):
    got = svda_moduli_from_levels(*levels(position, e0, e_inf), R, P, DEBYE, position=position)
    np.testing.assert_allclose(got, (e_inf, e0), rtol=1e-9)


@pytest.mark.parametrize(("position", "e0", "e_inf"), CASES)
def test_the_levels_give_the_moduli_back_at_a_mean_force(position, e0, e_inf):
    force = 1e-7
    h0 = svda_position(force, e_inf, R, P, DEBYE)
    got = svda_moduli_from_levels(*levels(h0, e0, e_inf), R, P, DEBYE, mean_force=force)
    np.testing.assert_allclose(got, (e_inf, e0), rtol=1e-9)


def test_a_level_above_the_rigid_stiffness_takes_the_top_of_the_window():
    rigid = 2 * np.pi * R * P * np.exp(-2e-9 / DEBYE)  # F̄κ of undeformed surfaces
    top = MODULUS_BOUNDS[1] / 10
    assert svda_moduli_from_levels(1.5 * rigid, 3 * rigid, R, P, DEBYE,
                                   position=2e-9) == (top, top)
    e_inf, e0 = svda_moduli_from_levels(0.5 * rigid, 2 * rigid, R, P, DEBYE, position=2e-9)
    assert e0 == top and e_inf < top  # no glassy solution beyond the rigid stiffness


def test_e0_stays_above_e_inf():
    k0, _ = levels(2e-9, 1e10, 1e9)
    e_inf, e0 = svda_moduli_from_levels(k0, k0, R, P, DEBYE, position=2e-9)
    assert e0 == pytest.approx(1.05 * e_inf)


def test_the_model_starts_at_the_noise_free_truth():
    model = make_model("svda", 1, position=2e-9, radius=R, P=P, debye_length=DEBYE)
    omega = np.geomspace(1e-2, 1e8, 40)  # the plateaus reached at both ends (τ = 1 ms)
    truth = {"E0": 1e10, "E_inf": 1e9, "tau": 1e-3}
    guess = model.guess(model.raw(omega, truth), omega)
    for name in ("E0", "E_inf"):
        assert guess[name].value == pytest.approx(truth[name], rel=1e-4)


@pytest.mark.parametrize("position", [-50e-9, -2e-9, 0.0, 2e-9, 20e-9, -1e-6])
@pytest.mark.parametrize("modulus", [1e3, 1e9, 1e12])
def test_the_unchecked_deformation_is_the_checked_one(position, modulus):
    """The fit's checks (pre-contact, model error) use the kernel; its oracle is the public form.

    −1 µm at 1 kPa puts log z beyond exp's range: the asymptotic branch.
    """
    from viscoforce.svda import svda_deformation_kernel, svda_static_deformation

    want = float(svda_static_deformation(position, modulus, R, P, DEBYE))
    got = svda_deformation_kernel(position, modulus, R, P, 1.0 / DEBYE)
    assert got == pytest.approx(want, rel=1e-13)
