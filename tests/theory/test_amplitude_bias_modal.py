"""The modal, cached finite-amplitude bias equals the direct harmonic-balance solves."""

from __future__ import annotations

import numpy as np
import pytest

import viscoforce as vf
from viscoforce.experiments import finite_amplitude as fa
from viscoforce.physics.materials import PronySeries, StandardLinearSolid
from viscoforce.solvers.static import equilibrium_gap


def _direct(problem, position, omega):
    """Oracle: one dense complex solve per order and frequency (the pre-modal implementation)."""
    material = problem.material
    e_inf = material.relaxed_modulus
    gap = equilibrium_gap(problem, position, e_inf).gap
    d1, d2, d3 = fa._pressure_derivatives(problem, gap)
    a, n, grid = problem.influence, gap.size, problem.grid

    def load(v):
        return complex(grid.integrate_area(v.real) + 1j * grid.integrate_area(v.imag))

    def solve(c, pressure=None, rhs=None):
        m = np.eye(n) - 2.0 * c * (a * d1[None, :])
        return np.linalg.solve(m, rhs if rhs is not None else 2.0 * c * (a @ pressure))

    out = np.empty(omega.size, dtype=complex)
    for i, w in enumerate(omega):
        cw, c2w = (complex(c) for c in material.complex_compliance(np.array([w, 2 * w])))
        h1 = solve(cw, rhs=np.ones(n, dtype=complex))
        h20 = solve(1.0 / e_inf, d2 * np.abs(h1) ** 2 / 4)
        h22 = solve(c2w, d2 * h1 ** 2 / 4)
        q3 = d2 * (h1 * h20 + np.conj(h1) * h22 / 2) + d3 * np.abs(h1) ** 2 * h1 / 8
        out[i] = load(d1 * solve(cw, q3) + q3) / load(d1 * h1)
    return out


@pytest.mark.parametrize("position", [2e-9, -5e-9])
@pytest.mark.parametrize("material", [
    StandardLinearSolid(1e10, 1e9, 1e-3),
    PronySeries.from_moduli([1e10, 4e9, 1e9], [1e-4, 1e-2])])
def test_modal_bias_equals_the_direct_solves(position, material):
    problem = vf.ContactProblem.create(sphere=vf.PAPER.sphere(),
                                       surface_force=vf.paper_pressure_law(), material=material,
                                       deepest_position=min(position, 0.0) - 2e-9)
    omega = np.geomspace(10.0, 1e6, 7)
    ref = _direct(problem, position, omega)
    np.testing.assert_allclose(fa.amplitude_bias(problem, position, omega), ref, rtol=1e-11)
    # cached results are copies: mutating one does not change the next call
    first = fa.amplitude_bias(problem, position, omega)
    first[:] = 0
    np.testing.assert_allclose(fa.amplitude_bias(problem, position, omega), ref, rtol=1e-11)
