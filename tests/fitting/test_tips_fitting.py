"""Issue 21 (items 1, 2): the contact model with any tip; Young's and shear moduli with stderr."""

from __future__ import annotations

import math

import numpy as np
import pytest

from viscoforce.exceptions import ParameterError
from viscoforce.fitting import fit_spectrum
from viscoforce.fitting.moduli import add_derived_moduli
from viscoforce.physics.materials import StandardLinearSolid
from viscoforce.physics.tips import Cone, Flat, Paraboloid, Pyramid, Sphere
from viscoforce.schema import make_spectrum

#: These synthetic contact spectra have no surface force: the paper's double layer that a contact
#: fit without debye_length assumes for its validity estimate is not theirs (that warning is tested
#: in tests/fitting/test_silent_cases.py).
pytestmark = pytest.mark.filterwarnings(
    "ignore:with the paper's double layer:viscoforce.exceptions.ApproximationWarning")

OMEGA = 2 * np.pi * np.geomspace(0.3, 1000.0, 10)
DEPTH = 500e-9
SLS = {"E0": 5e3, "E_inf": 1e3, "tau": 0.01}


def _spectrum(tip):
    k = float(tip.contact_stiffness_factor(DEPTH)) / StandardLinearSolid(
        **SLS).complex_compliance(OMEGA)
    return make_spectrum(OMEGA, k, np.full(k.shape, 1e-9), 1e-8,
                         stderr={"stiffness": 0.01 * np.abs(k),
                                 "phase": np.full(k.shape, np.degrees(0.01))},
                         mean_indentation=np.full(k.shape, DEPTH))


@pytest.mark.parametrize("tip", [Sphere(5e-6), Paraboloid(5e-6), Cone.from_degrees(20),
                                 Pyramid.from_degrees(17.5), Flat(1e-6)],
                         ids=lambda t: t.shape)
def test_contact_fit_with_any_tip_recovers_the_material_and_records_the_tip(tip):
    ds = fit_spectrum(_spectrum(tip), "contact", tip=tip)
    for name, value in SLS.items():
        assert float(ds[name]) == pytest.approx(value, rel=1e-6)
    assert ds.attrs["tip_shape"] == tip.shape and ds.attrs["tip"] == tip.describe()


def test_radius_is_the_papers_sphere_and_tip_text_is_accepted():
    by_radius = fit_spectrum(_spectrum(Paraboloid(5e-6)), "contact", radius=5e-6)
    by_text = fit_spectrum(_spectrum(Paraboloid(5e-6)), "contact", tip="paraboloid:5um")
    assert float(by_radius["E0"]) == pytest.approx(float(by_text["E0"]), rel=1e-12)
    assert by_radius.attrs["tip_shape"] == "paraboloid"


def test_the_contact_model_needs_one_tip():
    with pytest.raises(ParameterError, match="not both"):
        fit_spectrum(_spectrum(Paraboloid(5e-6)), "contact", radius=5e-6, tip=Cone(0.3))
    with pytest.raises(ParameterError, match="neither was given"):
        fit_spectrum(_spectrum(Paraboloid(5e-6)), "contact")


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.5])
def test_youngs_and_shear_moduli_and_their_stderr(nu):
    rng = np.random.default_rng(1)
    spec = _spectrum(Paraboloid(5e-6))
    spec["stiffness"] = spec["stiffness"] * (1 + 0.01 * rng.standard_normal(OMEGA.size))
    ds = fit_spectrum(spec, "contact", radius=5e-6, poisson=nu)
    for name in ("E0", "E_inf"):
        young = (1 - nu**2) / 2
        assert float(ds[f"{name}_young"]) == pytest.approx(float(ds[name]) * young, rel=1e-12)
        assert float(ds[f"{name}_young_stderr"]) == pytest.approx(
            float(ds[f"{name}_stderr"]) * young, rel=1e-12)
        assert float(ds[f"{name}_shear"]) == pytest.approx(
            float(ds[f"{name}_young"]) / (2 * (1 + nu)), rel=1e-12)
    assert "tau_young" not in ds and ds.attrs["poisson"] == nu
    if nu == 0.5:  # the issue: E is 2.67x Young's and 8x the shear modulus
        assert float(ds["E_inf"]) / float(ds["E_inf_young"]) == pytest.approx(8 / 3)
        assert float(ds["E_inf"]) / float(ds["E_inf_shear"]) == pytest.approx(8.0)


def test_poisson_out_of_range_is_refused():
    ds = fit_spectrum(_spectrum(Paraboloid(5e-6)), "contact", radius=5e-6)
    with pytest.raises(ParameterError, match=r"poisson must be in \[0, 0.5\]"):
        add_derived_moduli(ds, 0.7)
    assert math.isfinite(float(ds["E0_young"]))  # default 0.5 applied
