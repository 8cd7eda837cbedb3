"""The contact model on a layer of finite thickness (issue 37 item 5): ``sample_height``.

A spectrum made on a bonded incompressible layer (k* = E*(ω)·S(δ0)·g, g the stiffness factor of
:mod:`viscoforce.physics.bottom_effect`) is fitted back to its moduli with ``sample_height``;
without it the moduli come out g times too large, as the correction says they would.
"""

from __future__ import annotations

import numpy as np
import pytest

from viscoforce.closed_form import structural_complex_modulus
from viscoforce.fitting import fit_spectrum
from viscoforce.physics.bottom_effect import stiffness_factor
from viscoforce.physics.tips import Paraboloid
from viscoforce.schema import make_spectrum

TIP, DEPTH, HEIGHT = Paraboloid(5e-6), 1e-6, 5e-6
OMEGA = 2 * np.pi * np.logspace(0, 2.5, 8)
TRUTH = {"E_ref": 800.0, "alpha": 0.15, "mu": 1.0}


def _spectrum(base="bonded", height=HEIGHT):
    g = float(stiffness_factor(TIP, DEPTH, height, bonded=base == "bonded"))
    e = structural_complex_modulus(OMEGA, TRUTH["E_ref"], TRUTH["alpha"], TRUTH["mu"], 1.0)
    k = e * float(TIP.contact_stiffness_factor(DEPTH)) * g
    ds = make_spectrum(OMEGA, k, np.full(OMEGA.size, 1e-9), 1e-8,
                       stderr={"stiffness": 1e-3 * np.abs(k), "phase": np.full(OMEGA.size, 0.05)})
    return ds, g


@pytest.mark.parametrize(("base", "height", "least"), [
    ("bonded", HEIGHT, 1.5),  # chi 0.45 (Garcia & Garcia): the correction matters
    ("sliding", 25e-6, 1.05)])  # chi 0.09, within Dimitriadis' non-bonded range
def test_the_layer_is_fitted_back_to_its_moduli(base, height, least):
    ds, g = _spectrum(base, height)
    fit = fit_spectrum(ds, "contact", tip=TIP, indentation=DEPTH, material="structural",
                       sample_height=height, sample_base=base, debye_length=1e-9)
    for name, value in TRUTH.items():
        assert float(fit[name]) == pytest.approx(value, rel=1e-6)
    assert fit.attrs["bottom_effect_factor"] == pytest.approx(g)
    assert g > least


def test_without_the_height_the_moduli_are_the_factor_too_large():
    ds, g = _spectrum()
    fit = fit_spectrum(ds, "contact", tip=TIP, indentation=DEPTH, material="structural",
                       debye_length=1e-9)
    assert float(fit["E_ref"]) == pytest.approx(g * TRUTH["E_ref"], rel=1e-6)
    assert "bottom_effect_factor" not in fit.attrs


def test_a_layer_too_thin_for_the_series_is_refused_naming_it():
    from viscoforce.exceptions import ParameterError

    ds, _ = _spectrum()
    with pytest.raises(ParameterError, match="sample_height"):
        fit_spectrum(ds, "contact", tip=TIP, indentation=DEPTH, material="structural",
                     sample_height=1e-6, debye_length=1e-9)
