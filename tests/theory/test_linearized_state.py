"""LinearizedState: the modal form of the exact small-amplitude response, its cache, and
position_at_load (the static position that carries a given mean force)."""

from __future__ import annotations

import numpy as np
import pytest

import viscoforce as vf
from tests._laws import Wrapped
from viscoforce.exceptions import ConvergenceError, EffortError, ParameterError
from viscoforce.experiments.linear_response import (
    STATE_CACHE_SIZE,
    LinearizedState,
    linear_stiffness,
    linearized_state,
)
from viscoforce.physics.materials import PronySeries
from viscoforce.solvers.static import equilibrium_gap, position_at_load

SLS = vf.PAPER.material()
PRONY = PronySeries.from_moduli([vf.PAPER.E0, 3e9, vf.PAPER.E_inf], [0.2 * vf.PAPER.tau,
                                                                       vf.PAPER.tau])
OMEGA = np.concatenate([[0.0], np.logspace(0, 7, 29)])  # 30 frequencies [rad/s], ω = 0 included
POSITIONS = [2e-9, -5e-9]  # pre-contact (paper Fig. 3) and in contact (Fig. 4)


def direct_stiffness(problem, position, omega):
    """Reference: one dense complex solve (I + cM) δu = cM·1 per frequency, k = Σ w (1 − δu)."""
    material = problem.material
    sol = equilibrium_gap(problem, position, material.relaxed_modulus)
    stiff = -problem.surface_force.pressure_derivative(sol.gap)
    weights = 2.0 * np.pi * problem.grid.area_weights * stiff
    coupled = problem.influence * stiff[None, :]
    eye = np.eye(problem.grid.size)
    out = []
    for c in 2.0 * material.complex_compliance(omega):
        du = np.linalg.solve(eye + c * coupled, c * coupled.sum(axis=1))
        out.append(weights @ (1.0 - du))
    return np.array(out), float(problem.load(sol.pressure))


@pytest.fixture(autouse=True)
def _empty_cache():
    linearized_state.cache_clear()
    yield
    linearized_state.cache_clear()


@pytest.mark.parametrize("position", POSITIONS)
@pytest.mark.parametrize("material", [SLS, PRONY], ids=["sls", "prony2"])
def test_modal_form_equals_the_direct_solve(make_problem, material, position):
    # measured: ≤ 1.2e-15 relative (general eig on the balanced matrix, module docstring)
    problem = make_problem(material, position)
    ref, ref_mean = direct_stiffness(problem, position, OMEGA)
    k, mean = linear_stiffness(problem, position, OMEGA)
    np.testing.assert_allclose(k, ref, rtol=1e-10, atol=0)
    assert mean == pytest.approx(ref_mean, rel=1e-13)
    state = LinearizedState.at(problem, position)
    np.testing.assert_allclose(state.stiffness_for(material, OMEGA), ref, rtol=1e-10, atol=0)
    c = 2.0 * material.complex_compliance(OMEGA)
    np.testing.assert_allclose(state.stiffness(c), ref, rtol=1e-10, atol=0)
    # k*(c) = Σw − c Σ α/(1 + cλ), and Σβ = Σw
    residue_form = state.total_weight - c * (state.residues[None, :]
                                             / (1.0 + c[:, None] * state.eigenvalues)).sum(axis=1)
    np.testing.assert_allclose(residue_form, ref, rtol=1e-10, atol=0)
    assert state.weights.sum() == pytest.approx(state.total_weight, rel=1e-12)
    assert state.modes == problem.grid.size  # the paper's law has p′ ≠ 0 on every node
    assert state.mean_force == pytest.approx(ref_mean, rel=1e-13)


def test_modal_form_with_an_attractive_term(paper_law):
    """−p′ < 0 where the attraction dominates: the signed balancing keeps the result exact."""
    from tests.theory.test_spectroscopy import _Attraction

    law = paper_law + _Attraction(2e6, 2e-9)
    problem = vf.ContactProblem.create(sphere=vf.PAPER.sphere(), surface_force=law, material=SLS,
                                       deepest_position=5.4e-9)
    sol = equilibrium_gap(problem, 5.5e-9, SLS.relaxed_modulus)
    assert np.any(law.pressure_derivative(sol.gap) > 0)
    ref, _ = direct_stiffness(problem, 5.5e-9, OMEGA)
    k, _ = linear_stiffness(problem, 5.5e-9, OMEGA)
    np.testing.assert_allclose(k, ref, rtol=1e-10, atol=0)


class _CutOff(Wrapped):
    """The paper's law set to exactly 0 beyond a gap ``cutoff`` (a finite-range law)."""

    def __init__(self, law, cutoff):
        super().__init__(law)
        self.cutoff = cutoff

    def pressure(self, gap):
        h = np.asarray(gap, dtype=float)
        return np.where(h < self.cutoff, self.law.pressure(h), 0.0)

    def pressure_derivative(self, gap):
        h = np.asarray(gap, dtype=float)
        return np.where(h < self.cutoff, self.law.pressure_derivative(h), 0.0)


def test_nodes_without_a_force_derivative_are_left_out(make_problem, paper_law):
    grid = make_problem(SLS, 2e-9).grid
    problem = vf.ContactProblem(vf.PAPER.sphere(), _CutOff(paper_law, 8e-9), SLS, grid)
    state = LinearizedState.at(problem, 2e-9)
    sol = equilibrium_gap(problem, 2e-9, SLS.relaxed_modulus)
    nonzero = np.count_nonzero(problem.surface_force.pressure_derivative(sol.gap))
    assert state.modes == nonzero < 0.6 * grid.size  # 43 of 80 nodes
    ref, _ = direct_stiffness(problem, 2e-9, OMEGA)
    np.testing.assert_allclose(state.stiffness_for(SLS, OMEGA), ref, rtol=1e-10, atol=0)


def test_state_is_read_only_and_keeps_shapes(make_problem):
    state = LinearizedState.at(make_problem(SLS, 2e-9), 2e-9)
    for arr in (state.gap, state.eigenvalues, state.weights):
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 0
    with pytest.raises(AttributeError):
        state.position = 0.0
    c = 2.0 * SLS.complex_compliance(np.array([[1.0, 10.0], [100.0, 1e3]]))
    assert state.stiffness(c).shape == (2, 2)
    assert state.stiffness(c[0, 0]).shape == ()
    np.testing.assert_allclose(state.stiffness(c).ravel(), state.stiffness(c.ravel()), rtol=0)


def test_cache_reuses_a_state_for_any_tau_and_e0_at_the_same_e_inf(make_problem):
    problem = make_problem(SLS, 2e-9)
    first = linearized_state(problem, 2e-9)
    other = vf.ContactProblem(problem.sphere, problem.surface_force,
                              vf.StandardLinearSolid(E0=5e9, E_inf=vf.PAPER.E_inf, tau=3e-3),
                              problem.grid)
    assert linearized_state(other, 2e-9) is first
    assert linearized_state(problem, 2e-9, 2e9) is not first  # another E_inf: another state
    info = linearized_state.cache_info()
    assert (info["hits"], info["misses"], info["currsize"]) == (1, 2, 2)
    # linear_stiffness goes through the cache
    k1, _ = linear_stiffness(other, 2e-9, OMEGA)
    assert linearized_state.cache_info()["hits"] == 2
    np.testing.assert_allclose(k1, direct_stiffness(other, 2e-9, OMEGA)[0], rtol=1e-10, atol=0)


def test_cache_is_bounded(make_problem):
    problem = make_problem(SLS, 2e-9)
    for i in range(STATE_CACHE_SIZE + 3):
        linearized_state(problem, 2e-9 + i * 1e-10)
    info = linearized_state.cache_info()
    assert info["currsize"] == info["maxsize"] == STATE_CACHE_SIZE
    linearized_state(problem, 2e-9 + (STATE_CACHE_SIZE + 2) * 1e-10)  # the newest: kept
    assert linearized_state.cache_info()["hits"] == 1
    linearized_state(problem, 2e-9)  # the oldest: evicted, rebuilt
    assert linearized_state.cache_info()["misses"] == STATE_CACHE_SIZE + 4


@pytest.mark.parametrize("position", POSITIONS)
@pytest.mark.parametrize("guess", [None, 0.37e-9, -2.2e-9])
def test_position_at_load_recovers_the_position(make_problem, position, guess):
    problem = make_problem(SLS, position)
    modulus = SLS.relaxed_modulus
    load = float(problem.load(equilibrium_gap(problem, position, modulus).pressure))
    found = position_at_load(problem, load, modulus,
                             guess=None if guess is None else position + guess)
    assert abs(found - position) <= 1e-12  # measured ≤ 3e-16 m


@pytest.mark.parametrize("position", POSITIONS)
def test_state_at_load_equals_state_at_position(make_problem, position):
    problem = make_problem(SLS, position)
    at_position = LinearizedState.at(problem, position)
    at_load = LinearizedState.at_load(problem, at_position.mean_force)
    assert at_load.position == pytest.approx(position, abs=1e-12)
    assert at_load.mean_force == pytest.approx(at_position.mean_force, rel=1e-9)
    np.testing.assert_allclose(at_load.stiffness_for(SLS, OMEGA),
                               at_position.stiffness_for(SLS, OMEGA), rtol=1e-8)
    cached = linearized_state(problem, load=at_position.mean_force)
    assert linearized_state(problem, load=at_position.mean_force) is cached


@pytest.mark.parametrize("load", [0.0, -1e-9, np.nan, np.inf, None, "1 uN"])
def test_position_at_load_rejects_bad_loads(make_problem, load):
    problem = make_problem(SLS, 2e-9)
    with pytest.raises(ParameterError, match=r"load must be > 0 \[N\] \(finite\), got"):
        position_at_load(problem, load, SLS.relaxed_modulus)
    if load is not None:  # load=None is "no load given" for linearized_state
        with pytest.raises(ParameterError, match=r"load must be > 0 \[N\]"):
            linearized_state(problem, load=load)


def test_position_at_load_rejects_bad_modulus_and_guess(make_problem):
    problem = make_problem(SLS, 2e-9)
    with pytest.raises(ParameterError, match=r"modulus \(E\) must be > 0"):
        position_at_load(problem, 1e-7, 0.0)
    with pytest.raises(ParameterError, match="guess must be finite"):
        position_at_load(problem, 1e-7, 1e9, guess=np.nan)


def test_position_at_load_cannot_bracket_beyond_the_grid(make_problem):
    problem = make_problem(SLS, 2e-9)  # covers h0 ≥ about 2 nm: about 61 nN at most
    with pytest.raises(ConvergenceError, match=r"cannot bracket the load 1e-06 N within the "
                                               r"grid: the deepest position it covers .* "
                                               r"deeper deepest_position"):
        position_at_load(problem, 1e-6, SLS.relaxed_modulus)
    with pytest.raises(ConvergenceError, match="cannot bracket"):
        LinearizedState.at_load(problem, 1e-6)


@pytest.mark.parametrize(("compliance", "match"), [
    ([np.nan], "entry 0 is"),
    ([2e-10, -1e-10 + 1j], "entry 1 is"),
    ([0.0], "entry 0 is"),
    ([], "at least one"),
    ("soft", "got 'soft'"),
])
def test_stiffness_rejects_bad_compliances(make_problem, compliance, match):
    state = LinearizedState.at(make_problem(SLS, 2e-9), 2e-9)
    with pytest.raises(ParameterError, match=r"compliance must be finite complex values 2C\*\(ω\) "
                                             r"\[1/Pa\] with real part > 0.*" + match):
        state.stiffness(compliance)


def test_stiffness_refuses_too_many_values(make_problem):
    from viscoforce._limits import MAX_SAMPLES

    state = LinearizedState.at(make_problem(SLS, 2e-9), 2e-9)
    with pytest.raises(EffortError, match="compliance values of LinearizedState.stiffness"):
        state.stiffness(np.broadcast_to(2e-9 + 0j, (MAX_SAMPLES + 1,)))
    with pytest.raises(EffortError, match="frequencies of LinearizedState.stiffness_for"):
        state.stiffness_for(SLS, np.broadcast_to(1.0, (MAX_SAMPLES + 1,)))


def test_stiffness_for_rejects_another_e_inf_and_bad_arguments(make_problem):
    state = LinearizedState.at(make_problem(SLS, 2e-9), 2e-9)
    other = vf.StandardLinearSolid(E0=1e10, E_inf=2e9, tau=1e-3)
    with pytest.raises(ParameterError, match=r"material relaxed modulus E_inf = 2e\+09 Pa differs "
                                             r"from the state's 1e\+09 Pa"):
        state.stiffness_for(other, OMEGA)
    with pytest.raises(ParameterError, match="material must be a ViscoelasticMaterial"):
        state.stiffness_for(None, OMEGA)
    with pytest.raises(ParameterError, match="omega must be >= 0 rad/s"):
        state.stiffness_for(SLS, [-1.0])


@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(position=np.nan), r"position must be finite \[m\]"),
    (dict(position=None), r"position must be finite \[m\]"),
    (dict(position=2e-9, relaxed_modulus=0.0), r"relaxed_modulus must be > 0 \[Pa\]"),
    (dict(position=2e-9, relaxed_modulus="1 GPa"), r"relaxed_modulus must be > 0 \[Pa\]"),
    (dict(position=-9e-9), "outer_radius .* is too small for position"),
])
def test_state_at_rejects_bad_arguments(make_problem, kwargs, match):
    problem = make_problem(SLS, 2e-9)
    with pytest.raises(ParameterError, match=match):
        LinearizedState.at(problem, **kwargs)
    if kwargs["position"] is not None:
        with pytest.raises(ParameterError, match=match):
            linearized_state(problem, **kwargs)


def test_linearized_state_needs_exactly_one_of_position_and_load(make_problem):
    problem = make_problem(SLS, 2e-9)
    with pytest.raises(ParameterError, match="give exactly one of position"):
        linearized_state(problem)
    with pytest.raises(ParameterError, match="give exactly one of position"):
        linearized_state(problem, 2e-9, load=6e-8)
    with pytest.raises(ParameterError, match="problem must be a ContactProblem"):
        linearized_state(None, 2e-9)
    with pytest.raises(ParameterError, match="problem must be a ContactProblem"):
        LinearizedState.at(None, 2e-9)
