"""Issue 22 (the cold ``linear_response``): each fast path against its general form.

- ``solve_gap`` (the Jacobian built in Fortran order and factored in place, the
  fraction-to-boundary pre-check, the undamped update without a product) takes the same trial
  steps as the textbook damped Newton of its module docstring, written here in the general form;
- ``_modal.lu_solve`` of real right-hand sides (LAPACK's getrs directly) equals ``scipy.linalg.lu_solve``;
- ``_modal.decompose`` (the balanced matrix built in place, no indexing when every node is active)
  diagonalises M' built by indexing, and its eigenvalues are those of M = A·diag(−p′);
- ``amplitude_bias`` in its projected modal form (G = V⁻¹|D|^½A once, load integrals from the
  modes) equals the direct dense solves with nodes that carry no force derivative (the inactive
  rows) and with complex eigenvectors (the complex-arithmetic branch).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

import viscoforce as vf
from tests._laws import Wrapped
from tests.theory.test_amplitude_bias_modal import _direct
from tests.theory.test_linearized_state import _CutOff, direct_stiffness
from viscoforce.experiments import _modal
from viscoforce.experiments import finite_amplitude as fa
from viscoforce.experiments import linear_response as lr
from viscoforce.solvers.newton import solve_gap
from viscoforce.solvers.static import STATIC_XTOL, equilibrium_gap

SLS = vf.PAPER.material()
OMEGA = np.geomspace(10.0, 1e6, 7)


@pytest.fixture(autouse=True)
def _empty_caches():
    """Every cache of the linear response empty, so that each test decomposes anew."""
    def clear():
        lr.linearized_state.cache_clear()
        _modal.DECOMPOSITIONS.clear()
        fa._BIAS_MODES.clear()
        fa._BIAS_RESULTS.clear()

    clear()
    yield
    clear()


class _Recording(Wrapped):
    """A law that records the gaps at which its pressure is evaluated (Newton's trial steps)."""

    def __init__(self, law):
        super().__init__(law)
        self.trials = []

    def pressure(self, gap):
        self.trials.append(np.array(gap, dtype=float))
        return self.law.pressure(gap)


def _textbook_newton(problem, base, coupling, initial, xtol, max_iter=60):
    """Damped Newton of newton.py's docstring in the general form; returns (gap, causes).

    ``causes`` records per iteration whether the fraction-to-boundary rule and the line search
    shortened the step.
    """
    a, law, n = problem.influence, problem.surface_force, base.size
    h = np.array(initial, dtype=float)
    res = h - base - coupling * (a @ law.pressure(h))
    norm = np.max(np.abs(res))
    causes = []
    for _ in range(max_iter):
        jac = np.eye(n) + a * ((-coupling) * law.pressure_derivative(h))[None, :]
        delta = scipy.linalg.lu_solve(scipy.linalg.lu_factor(jac), -res)
        step_norm = np.max(np.abs(delta))
        shrink = delta < 0
        alpha = min(1.0, np.min(-0.8 * h[shrink] / delta[shrink])) if shrink.any() else 1.0
        bounded, halved = alpha < 1.0, False
        while True:
            h_new = h + alpha * delta
            res_new = h_new - base - coupling * (a @ law.pressure(h_new))
            norm_new = np.max(np.abs(res_new))
            if norm_new <= (1.0 - 1e-4 * alpha) * norm or alpha * step_norm <= xtol:
                break
            alpha, halved = 0.5 * alpha, True
        h, res, norm = h_new, res_new, norm_new
        causes.append((bounded, halved))
        if alpha == 1.0 and step_norm <= xtol:
            return h, causes
    raise AssertionError("the textbook Newton did not converge")


@pytest.mark.parametrize("position", [-10e-9, -5e-9, 2e-9])
def test_newton_takes_the_textbook_steps(paper_law, position):
    grid = vf.ContactProblem.create(sphere=vf.PAPER.sphere(), surface_force=paper_law,
                                    material=SLS, deepest_position=-10e-9).grid
    fast, general = _Recording(paper_law), _Recording(paper_law)
    problems = [vf.ContactProblem(vf.PAPER.sphere(), law, SLS, grid) for law in (fast, general)]
    base = problems[0].undeformed_gap(position)
    initial = np.maximum(base, paper_law.decay_length)
    coupling, xtol = 2.0 / SLS.relaxed_modulus, STATIC_XTOL * paper_law.decay_length
    sol = solve_gap(problems[0], base, coupling, initial, xtol=xtol)
    gap, causes = _textbook_newton(problems[1], base, coupling, initial, xtol)
    # every trial step (each pressure evaluation) is the same, so every damping decision is
    assert len(fast.trials) == len(general.trials)
    for got, want in zip(fast.trials, general.trials, strict=True):
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
    np.testing.assert_allclose(sol.gap, gap, rtol=1e-14, atol=0)
    assert sol.iterations == len(causes)
    # the cases reach the branches: −10 nm is bounded by the fraction to the boundary, −5 nm
    # halved by the line search, +2 nm neither
    bounded, halved = (any(c[i] for c in causes) for i in (0, 1))
    assert (bounded, halved) == {-10e-9: (True, True), -5e-9: (False, True),
                                 2e-9: (False, False)}[position]


@pytest.mark.parametrize("shape", [(7,), (7, 1), (7, 4)])
def test_lu_solve_of_real_right_hand_sides_is_scipys(rng, shape):
    a = rng.standard_normal((7, 7)) + 7.0 * np.eye(7)
    b = rng.standard_normal(shape)
    lu = scipy.linalg.lu_factor(a)
    got = _modal.lu_solve(lu, b)
    assert got.shape == b.shape and got.dtype == np.float64
    np.testing.assert_allclose(got, scipy.linalg.lu_solve(lu, b), rtol=1e-13, atol=0)
    np.testing.assert_allclose(got, np.linalg.solve(a, b), rtol=1e-12, atol=0)


@pytest.mark.parametrize("position, cutoff", [(-5e-9, None), (-5e-9, 15e-9), (2e-9, 8e-9)])
def test_decomposition_diagonalises_the_balanced_linearisation(paper_law, position, cutoff):
    grid = vf.ContactProblem.create(sphere=vf.PAPER.sphere(), surface_force=paper_law,
                                    material=SLS, deepest_position=position).grid
    law = paper_law if cutoff is None else _CutOff(paper_law, cutoff)
    problem = vf.ContactProblem(vf.PAPER.sphere(), law, SLS, grid)
    dec = _modal.decompose(problem, equilibrium_gap(problem, position, SLS.relaxed_modulus))
    s = -law.pressure_derivative(dec.sol.gap)
    active = np.flatnonzero(s != 0.0)
    assert (active.size == grid.size) == (cutoff is None)  # both branches
    np.testing.assert_array_equal(dec.active, active)
    area = grid.area_weights[active]
    d = area * s[active]
    q = np.sqrt(np.abs(d))
    balanced = (q[:, None] * (problem.influence[np.ix_(active, active)] / area[None, :])
                * np.copysign(q, d)[None, :])
    scale = np.max(np.abs(dec.lam))
    np.testing.assert_allclose(balanced @ dec.vec, dec.vec * dec.lam[None, :], rtol=0,
                               atol=1e-13 * scale)
    # M = A diag(s) on the active nodes is similar to it: the same eigenvalues
    textbook = np.sort(scipy.linalg.eigvals(problem.influence[np.ix_(active, active)]
                                            * s[active][None, :]).real)
    np.testing.assert_allclose(np.sort(dec.lam.real), textbook, rtol=0, atol=1e-12 * scale)
    np.testing.assert_allclose(dec.unit_modes, np.linalg.solve(dec.vec, q), rtol=1e-12)


def test_bias_with_nodes_without_force_derivative_equals_the_direct_solves(make_problem,
                                                                         paper_law):
    grid = make_problem(SLS, -5e-9).grid
    problem = vf.ContactProblem(vf.PAPER.sphere(), _CutOff(paper_law, 15e-9), SLS, grid)
    modes = fa._BiasModes.build(problem, -5e-9, SLS.relaxed_modulus)
    inactive = np.count_nonzero(modes.d1 == 0.0)
    assert 0 < inactive and modes.lam.size == grid.size - inactive
    assert np.all(modes.d1[modes.lam.size:] == 0.0)  # ordered: active nodes first
    np.testing.assert_allclose(fa.amplitude_bias(problem, -5e-9, OMEGA),
                               _direct(problem, -5e-9, OMEGA), rtol=1e-11)


@pytest.mark.parametrize("cutoff", [None, 15e-9])
def test_complex_eigenvectors_give_the_direct_solves(monkeypatch, make_problem, paper_law,
                                                     cutoff):
    """Eigenvectors scaled by complex phases are still eigenvectors: the complex branch."""
    real_eig = scipy.linalg.eig

    def eig_with_phases(a, **kwargs):
        lam, vec = real_eig(a, **kwargs)
        return lam, vec * np.exp(1j * np.linspace(0.3, 2.9, vec.shape[1]))[None, :]

    monkeypatch.setattr(scipy.linalg, "eig", eig_with_phases)
    problem = make_problem(SLS, -5e-9)
    if cutoff is not None:
        problem = vf.ContactProblem(vf.PAPER.sphere(), _CutOff(paper_law, cutoff), SLS,
                                    problem.grid)
    modes = fa._BiasModes.build(problem, -5e-9, SLS.relaxed_modulus)
    assert np.iscomplexobj(modes.project) and np.iscomplexobj(modes.expand)
    np.testing.assert_allclose(fa.amplitude_bias(problem, -5e-9, OMEGA),
                               _direct(problem, -5e-9, OMEGA), rtol=1e-11)
    k, _ = lr.linear_stiffness(problem, -5e-9, OMEGA)
    np.testing.assert_allclose(k, direct_stiffness(problem, -5e-9, OMEGA)[0], rtol=1e-10, atol=0)
