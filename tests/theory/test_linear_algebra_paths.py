"""Issue 22: the real-arithmetic helpers of linear_response and Newton's direct LAPACK calls.

Oracles: NumPy's own ``matrix @ z``, ``scipy.linalg.lu_solve`` and ``numpy.linalg.solve`` (1e-13
relative), and the error branches by LAPACK's ``info`` codes.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from viscoforce.exceptions import ConvergenceError
from viscoforce.experiments._modal import lu_solve, times
from viscoforce.solvers import newton

RNG = np.random.default_rng(7)


def _complex(shape):
    return RNG.standard_normal(shape) + 1j * RNG.standard_normal(shape)


@pytest.mark.parametrize("shape", [(6,), (6, 1), (6, 5)])
@pytest.mark.parametrize("layout", ["contiguous", "strided"])
def test_times_is_the_matrix_product(shape, layout):
    matrix = RNG.standard_normal((4, 6))
    z = _complex((shape[0], 2 * shape[1]) if len(shape) == 2 else (2 * shape[0],))
    z = z[..., ::2] if layout == "strided" else z[..., : z.shape[-1] // 2]
    np.testing.assert_allclose(times(matrix, z), matrix @ z, rtol=1e-13, atol=1e-13)
    complex_matrix = _complex((4, 6))  # complex matrices and real z take numpy's product
    np.testing.assert_allclose(times(complex_matrix, z), complex_matrix @ z, rtol=1e-13)
    real_z = RNG.standard_normal(shape)
    np.testing.assert_allclose(times(matrix, real_z), matrix @ real_z, rtol=1e-13)


@pytest.mark.parametrize("columns", [1, 5])
def test_lu_solve_of_complex_right_hand_sides_with_real_factors(columns):
    a = RNG.standard_normal((6, 6)) + 6 * np.eye(6)
    b = _complex((6, columns))
    lu = scipy.linalg.lu_factor(a)
    np.testing.assert_allclose(lu_solve(lu, b), np.linalg.solve(a, b), rtol=1e-13)
    np.testing.assert_allclose(lu_solve(lu, b), scipy.linalg.lu_solve(lu, b), rtol=1e-13)
    complex_lu = scipy.linalg.lu_factor(a + 1j * np.eye(6))
    np.testing.assert_allclose(lu_solve(complex_lu, b),
                               np.linalg.solve(a + 1j * np.eye(6), b), rtol=1e-13)


def _paper_problem():
    import viscoforce as vf

    return vf.ContactProblem.create(sphere=vf.PAPER.sphere(),
                                    surface_force=vf.paper_pressure_law(),
                                    material=vf.PAPER.material(), deepest_position=-5e-9)


def test_newton_factors_are_scipys():
    """The factor Newton keeps (for sensitivities) is what scipy.linalg.lu_factor returns."""
    from viscoforce.solvers.static import equilibrium_gap

    problem = _paper_problem()
    e_inf = problem.material.relaxed_modulus
    sol = equilibrium_gap(problem, -5e-9, e_inf)
    lu, piv = sol.factor
    assert lu.shape == (problem.grid.size,) * 2 and piv.shape == (problem.grid.size,)
    rhs = RNG.standard_normal(problem.grid.size)
    a = lu.copy()
    lower = np.tril(a, -1) + np.eye(a.shape[0])
    upper = np.triu(a)
    perm = np.arange(a.shape[0])
    for i, p in enumerate(piv):
        perm[i], perm[p] = perm[p], perm[i]
    jac = np.empty_like(a)
    jac[perm] = lower @ upper  # P·L·U: the Jacobian the factors came from
    np.testing.assert_allclose(scipy.linalg.lu_solve((lu, piv), rhs),
                               np.linalg.solve(jac, rhs), rtol=1e-10)


@pytest.mark.parametrize("info, match", [(3, "diagonal number 3 is exactly zero"),
                                         (-2, "LAPACK reported an illegal value in argument 2")])
def test_newton_reports_a_singular_jacobian(monkeypatch, info, match):
    from viscoforce.solvers.static import equilibrium_gap

    def failing(jac, overwrite_a=False):
        return jac, np.arange(jac.shape[0], dtype=np.int32), info

    problem = _paper_problem()
    monkeypatch.setattr(newton, "_GETRF", failing)
    with pytest.raises(ConvergenceError, match=f"singular Newton Jacobian: {match}"):
        equilibrium_gap(problem, -5e-9, problem.material.relaxed_modulus)
