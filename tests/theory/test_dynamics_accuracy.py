"""Viscoelastic dynamics: accuracy and convergence of the time stepping (split off from
test_dynamics.py, whose loop helper it uses, so that the two halves run on different xdist
workers)."""

from __future__ import annotations

import numpy as np
import pytest

import viscoforce as vf
from tests.theory.test_dynamics import SLS, loop
from viscoforce.experiments import Step, Triangle
from viscoforce.solvers.simulate import simulate


@pytest.fixture(scope="module")
def reference_loop():
    """The loop 10 → −10 → 10 nm at 5 µm/s (41 outputs) integrated far below every error measured
    against it, once for the accuracy and the convergence tests.

    Step tolerance 1e-18, steps ≤ 2 µs: ~6 400 steps. It differs from a run at 1e-19 and ≤ 0.5 µs
    (~18 000 steps) by 6e-8 of the peak force, < 1/800 of the smallest error measured against it
    (5.0e-5, exponential at dt = 8 µs): it moves an observed order by < 0.002.
    """
    problem = vf.ContactProblem.create(sphere=vf.PAPER.sphere(),
                                       surface_force=vf.paper_pressure_law(), material=SLS,
                                       deepest_position=-10e-9)
    return loop(lambda *_: problem, 5e-6, n=41, tol=1e-18, max_step=2e-6)


def fixed_step_error(make_problem, method, dt, reference):
    ds = loop(make_problem, 5e-6, n=41, stepper=method, dt=dt)
    return float(np.max(np.abs(ds.force - reference.force)) / reference.force.max())


@pytest.mark.filterwarnings("ignore::viscoforce.exceptions.AccuracyWarning")  # coarse on purpose
@pytest.mark.parametrize(("method", "order"), [("exponential", 2), ("exponential-euler", 1),
                                               ("euler", 1)])
def test_time_step_convergence_order(make_problem, reference_loop, method, order):
    """Halving dt divides the loop's force error by 2^order.

    Measured (loop 10 → −10 → 10 nm at 5 µm/s, dt 32 → 16 → 8 µs): exponential 2.00, 1.98;
    exponential-euler 0.95, 0.96; euler 1.08, 1.03 — still asymptotic (at 16 → 8 → 4 µs, for twice
    the steps: 1.98, 2.00; 0.96, 0.99; 1.03, 1.00; at 64 → 32 µs the exponential gives 1.80, no
    longer). The smallest error, 5.0e-5, is ~800× the reference's (see ``reference_loop``).
    """
    errors = [fixed_step_error(make_problem, method, dt, reference_loop)
              for dt in (32e-6, 16e-6, 8e-6)]
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(observed - order) < 0.25), observed


def test_adaptive_default_meets_its_accuracy(make_problem, reference_loop):
    ds = loop(make_problem, 5e-6, n=41)
    err = float(np.max(np.abs(ds.force - reference_loop.force)) / reference_loop.force.max())
    assert err < 1e-3
    assert ds.attrs["stepper"] == "exponential" and ds.attrs["steps"] > 0


def test_grid_refinement_changes_the_loop_by_less_than_1e4(make_problem):
    """Both runs at step tolerance 1e-15: integration error 7e-6 of the peak force (1.5e-6 at
    1e-16), < 1/10 of the 1e-4 asserted even were the two step sequences unrelated; measured
    difference 7e-9 (1.8e-8 at 1e-16)."""
    drive = Triangle(10e-9, -7e-9, 5e-6)
    t = np.linspace(0, drive.duration, 41)
    coarse = make_problem(SLS, -7e-9)
    fine = make_problem(SLS, -7e-9, grid_spacing=coarse.grid.spacing / 2)
    a = simulate(coarse, drive, t_end=drive.duration, t_eval=t, tol=1e-15)
    b = simulate(fine, drive, t_end=drive.duration, t_eval=t, tol=1e-15)
    assert float(np.max(np.abs(a.force - b.force)) / b.force.max()) < 1e-4


def _peak(ds, name="force"):
    values = ds[name].values
    i = int(np.argmax(values))
    return float(values[i]), float(ds.time.values[i])


@pytest.mark.parametrize(("drive", "material"), [
    (Triangle(8e-9, -6e-9, 3e-6), vf.StandardLinearSolid(E0=4e9, E_inf=1e9, tau=0.5e-3)),
    (Step(-5e-9, -7e-9), SLS),  # Fig. 1: the peak is at the end of the 0.1 ms rise
])
def test_reported_peak_is_the_true_peak(make_problem, drive, material):
    """Output times include every kink, so 401 samples report the peak of a dense run.

    The dense run samples 5× as often everywhere and 50× (t_end/20 000) within ±5 % of the run
    around the kink; a denser sampling elsewhere only adds steps (one per output time).
    Both runs use a tight step tolerance (1e-8 decay lengths) so that what is compared is the
    sampling, not the integration error of two different step sequences (≈ 2e-6 at the default).
    """
    problem = make_problem(material, drive.extent()[0])
    t_end = drive.duration + 2 * material.tau
    tol = 1e-17
    kink = drive.breakpoints()[-2 if isinstance(drive, Triangle) else -1]
    near = kink + t_end / 20000 * np.arange(-1000, 1001)
    t_dense = np.union1d(np.linspace(0, t_end, 2001), near[(near >= 0) & (near <= t_end)])
    coarse = simulate(problem, drive, t_end=t_end, t_eval=np.linspace(0, t_end, 401), tol=tol)
    dense = simulate(problem, drive, t_end=t_end, t_eval=t_dense, tol=tol)
    f_coarse, t_coarse = _peak(coarse)
    f_dense, _ = _peak(dense)
    assert t_coarse == pytest.approx(kink, rel=1e-12)
    assert f_coarse == pytest.approx(f_dense, rel=1e-6)
    assert float(coarse.contact_radius.max()) == pytest.approx(
        float(dense.contact_radius.max()), rel=1e-6)
    # without the kinks the evenly spaced outputs miss the peak
    missed = simulate(problem, drive, t_end=t_end, t_eval=np.linspace(0, t_end, 401), tol=tol,
                      output_kinks=False)
    assert _peak(missed)[0] < f_coarse * (1 - 1e-4)
