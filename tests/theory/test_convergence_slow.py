"""Convergence studies (slow; skipped in CI): ``python -m pytest -m slow``."""

from __future__ import annotations

import numpy as np
import pytest

import viscoforce as vf
from viscoforce.experiments import Triangle
from viscoforce.experiments.linear_response import linear_stiffness
from viscoforce.solvers.simulate import simulate

pytestmark = pytest.mark.slow

SLS = vf.PAPER.material()
DRIVE = Triangle(10e-9, -10e-9, 5e-6)
T_EVAL = np.linspace(0, DRIVE.duration, 81)


def fig5(problem, **kw):
    return simulate(problem, DRIVE, t_end=DRIVE.duration, t_eval=T_EVAL, **kw).force.values


def test_fig5_loop_time_step_order_is_two(make_problem):
    problem = make_problem(SLS, -10e-9)
    ref = fig5(problem, tol=1e-19, max_step=2e-7)
    errors = [np.max(np.abs(fig5(problem, dt=dt) - ref)) / ref.max()
              for dt in (4e-6, 2e-6, 1e-6, 5e-7)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(orders - 2.0) < 0.2), orders


def test_fig5_loop_grid_convergence(make_problem):
    """Default grid against 2× and 4× refinement: spectral, differences < 1e-5."""
    coarse = make_problem(SLS, -10e-9)
    forces = [fig5(make_problem(SLS, -10e-9, grid_spacing=coarse.grid.spacing / f), tol=1e-17)
              for f in (1, 2, 4)]
    assert np.max(np.abs(forces[0] - forces[2])) / forces[2].max() < 1e-5
    assert np.max(np.abs(forces[1] - forces[2])) / forces[2].max() < 1e-6


@pytest.mark.parametrize("position", [2e-9, -5e-9, -10e-9])
def test_linear_response_grid_convergence(make_problem, position):
    coarse = make_problem(SLS, position)
    fine = make_problem(SLS, position, grid_spacing=coarse.grid.spacing / 4)
    w = np.geomspace(10, 1e5, 25)
    k_c, _ = linear_stiffness(coarse, position, w)
    k_f, _ = linear_stiffness(fine, position, w)
    assert np.max(np.abs(k_c - k_f) / np.abs(k_f)) < 1e-5
