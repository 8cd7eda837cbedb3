"""Surface-force laws and materials: identities and validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import viscoforce as vf


@settings(max_examples=60, deadline=None)
@given(gap=st.floats(0.2e-9, 30e-9))
def test_pressure_is_minus_energy_derivative_and_derivative_is_exact(gap):
    law = vf.paper_pressure_law()
    step = 1e-6 * gap
    fd_energy = -(law.energy(gap + step) - law.energy(gap - step)) / (2 * step)
    assert float(law.pressure(gap)) == pytest.approx(float(fd_energy), rel=1e-7)
    fd_p = (law.pressure(gap + step) - law.pressure(gap - step)) / (2 * step)
    assert float(law.pressure_derivative(gap)) == pytest.approx(float(fd_p), rel=1e-7)


def test_paper_law_values_and_sum():
    law = vf.paper_pressure_law()
    assert float(law.pressure(1e-9)) == pytest.approx(1e7 * np.exp(-1) + 1e7 * 0.5**9, rel=1e-15)
    assert law.decay_length == 1e-9
    assert law.negligible_gap(1e-10) == pytest.approx(1e-9 * np.log(1e10))
    three = law + vf.DoubleLayer(1.0, 2e-9)
    assert len(three.terms) == 3 and three.decay_length == 2e-9


def test_law_validation():
    with pytest.raises(vf.ParameterError, match="P \\(double-layer pressure scale\\) must be > 0"):
        vf.DoubleLayer(-1.0)
    with pytest.raises(vf.ParameterError, match="debye_length must be > 0"):
        vf.DoubleLayer(1e7, 0.0)
    with pytest.raises(vf.ParameterError, match="z0 \\(soft-wall length\\) must be finite"):
        vf.SoftWall(1e7, float("nan"))
    with pytest.raises(vf.ParameterError, match="gap must be > 0 for the soft wall"):
        vf.SoftWall().pressure(np.array([1e-9, -1e-10]))
    with pytest.raises(vf.ParameterError, match="non-empty tuple"):
        from viscoforce.physics.surface_forces import SumOfLaws

        SumOfLaws(())


def test_sls_complex_modulus_is_inverse_compliance_and_limits():
    m = vf.StandardLinearSolid(E0=1e10, E_inf=1e9, tau=1e-3)
    w = np.logspace(-2, 7, 50)
    np.testing.assert_allclose(m.complex_modulus(w) * m.complex_compliance(w), 1.0, rtol=1e-14)
    assert m.complex_compliance(0.0).real == pytest.approx(1 / 1e9)
    assert abs(m.complex_compliance(1e12)) == pytest.approx(1 / 1e10, rel=1e-6)
    assert np.all(m.complex_compliance(w).imag < 0) and np.all(m.complex_modulus(w).imag > 0)
    assert m.creep_compliance(0.0) == pytest.approx(1e-10)
    assert m.creep_compliance(1e-3) == pytest.approx(1e-9 + (1e-10 - 1e-9) * np.exp(-1))
    assert m.instantaneous_modulus == pytest.approx(1e10) and m.relaxed_modulus == pytest.approx(1e9)


def test_prony_forms_agree_with_sls():
    sls = vf.StandardLinearSolid(E0=1e10, E_inf=1e9, tau=2e-3)
    pr = vf.PronySeries.from_moduli([1e10, 1e9], [2e-3])
    split = vf.PronySeries(1e10, (0.5 * (1e-9 - 1e-10),) * 2, (2e-3, 2e-3))
    t = np.linspace(0, 1e-2, 7)
    for other in (pr, split):
        np.testing.assert_allclose(other.creep_compliance(t), sls.creep_compliance(t), rtol=1e-14)
        np.testing.assert_allclose(other.complex_compliance(t * 1e5),
                                   sls.complex_compliance(t * 1e5), rtol=1e-14)
    three = vf.PronySeries.from_moduli([1e10, 3e9, 1e9], [1e-4, 1e-2])
    assert three.relaxed_modulus == pytest.approx(1e9) and three.prony().n_modes == 2
    assert vf.Elastic(2e9).prony().n_modes == 0


def test_material_validation():
    with pytest.raises(vf.ParameterError, match=r"E0 \(instantaneous modulus\) must be > E_inf"):
        vf.StandardLinearSolid(E0=1e9, E_inf=1e9, tau=1e-3)
    with pytest.raises(vf.ParameterError, match="tau must be > 0"):
        vf.StandardLinearSolid(E0=1e10, E_inf=1e9, tau=0.0)
    with pytest.raises(vf.ParameterError, match="E_inf must be > 0"):
        vf.StandardLinearSolid(E0=1e10, E_inf=-1.0, tau=1.0)
    with pytest.raises(vf.ParameterError, match="same length"):
        vf.PronySeries(1e10, (1e-10,), (1.0, 2.0))
    with pytest.raises(vf.ParameterError, match=r"delta_compliances\[0\] must be > 0"):
        vf.PronySeries(1e10, (-1e-10,), (1.0,))
    with pytest.raises(vf.ParameterError, match="strictly decreasing"):
        vf.PronySeries.from_moduli([1e9, 1e10], [1.0])
    with pytest.raises(vf.ParameterError, match="taus must have len\\(moduli\\) - 1"):
        vf.PronySeries.from_moduli([1e10, 1e9], [1.0, 2.0])
    with pytest.raises(vf.ParameterError, match="radius \\(R\\) must be > 0"):
        vf.Sphere(0.0)
    assert vf.Sphere.effective(10e-6, 10e-6).radius == pytest.approx(5e-6)


def test_sum_of_two_double_layers_records_every_term_in_attrs(make_problem):
    """The issue's defect: DoubleLayer(1e7, 1 nm) + DoubleLayer(2e7, 3 nm) recorded one term."""
    law = vf.DoubleLayer(1e7, 1e-9) + vf.DoubleLayer(2e7, 3e-9) + vf.SoftWall(1e7, 0.5e-9)
    params = law.parameters()
    assert params["P_1"] == 1e7 and params["debye_length_1"] == 1e-9
    assert params["P_2"] == 2e7 and params["debye_length_2"] == 3e-9
    assert params["Pw"] == 1e7 and params["z0"] == 0.5e-9
    assert params["surface_force"] == ("DoubleLayer(P=1e+07, debye_length=1e-09) + "
                                       "DoubleLayer(P=2e+07, debye_length=3e-09) + "
                                       "SoftWall(Pw=1e+07, z0=5e-10)")
    problem = vf.ContactProblem.create(sphere=vf.Sphere(10e-6), surface_force=law,
                                       material=vf.Elastic(1e9), deepest_position=2e-9)
    ds = vf.static_equilibrium(problem, 2e-9)
    for name in ("P_1", "debye_length_1", "P_2", "debye_length_2", "Pw", "z0", "surface_force"):
        assert ds.attrs[name] == params[name]


def test_paper_parameters_have_one_home():
    assert vf.paper_pressure_law() == vf.PAPER.pressure_law()
    assert vf.PAPER.material() == vf.StandardLinearSolid(E0=1e10, E_inf=1e9, tau=1e-3)
    assert vf.PAPER.sphere() == vf.Sphere(10e-6)
