"""The step fit of issue 22 item 2: forward sensitivities, the repeated grid and the same answers.

What is proved here:

- ``simulate_force`` gives the force of ``simulate`` bit for bit (with or without sensitivities);
- its sensitivities are the derivative of the discrete scheme: on a fixed step grid they equal
  central finite differences to 1e-5 (measured 2e-6: Newton's last factorisation is taken within
  the Newton tolerance of the solution);
- ``corners`` keeps a piecewise-linear trace's bends and ends only (the same function);
- ``fit_step`` recovers the material of the old implementation (one ``simulate`` per evaluation,
  finite-difference Jacobian; the copy kept in benchmarks/bench_step.py, whose answers are
  stored here and rechecked by a slow test): noise-free to 1e-4
  relative (measured 3-8e-6: the two paths discretise the drive differently, both at the default
  tolerance), and on a noisy trace to 0.05 of the stderr with stderr equal to 1 % (measured
  0.001 stderr and 3e-4);
- its reported curve is one adaptive simulation at the default tolerance at the fitted values
  (to 1e-9: its Newton solves start from the previous run's solution).
"""

from __future__ import annotations

import numpy as np
import pytest

from tests._bench import benchmark_module
from viscoforce import PAPER
from viscoforce.exceptions import ParameterError
from viscoforce.experiments.drives import MeasuredTrace, Step, Triangle
from viscoforce.fitting import make_model
from viscoforce.fitting.curve_models import StepResponse, corners
from viscoforce.fitting.curves import fit_step
from viscoforce.physics.materials import StandardLinearSolid
from viscoforce.physics.paper import paper_pressure_law
from viscoforce.physics.particle import Sphere
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_trajectory
from viscoforce.solvers.simulate import simulate, simulate_force

TRUTH = StandardLinearSolid(PAPER.E0, PAPER.E_inf, PAPER.tau)
WRONG = StandardLinearSolid(3e9, 5e8, 1e-4)
NAMES = ("E0", "E_inf", "tau")


@pytest.fixture(scope="module")
def deep():
    law = paper_pressure_law(PAPER.P, PAPER.debye_length, PAPER.Pw, PAPER.z0)
    return ContactProblem.create(sphere=Sphere(PAPER.R), surface_force=law, material=TRUTH,
                                 deepest_position=-7e-9)


def _trajectory(problem, drive, t, noise=0.0, seed=0):
    run = simulate(problem, drive, t_end=float(t[-1]), t_eval=t, output_kinks=False,
                   progress=False)
    force = run["force"].values
    if noise:
        force = force * (1.0 + noise * np.random.default_rng(seed).standard_normal(force.shape))
    return make_trajectory(t, position=run["position"].values, force=force,
                           u_center=run["u_center"].values, h_center=run["h_center"].values,
                           contact_radius=run["contact_radius"].values,
                           contact_threshold=run.attrs["contact_threshold"],
                           attrs=dict(run.attrs))


@pytest.fixture(scope="module")
def step_trace(deep):
    t = np.linspace(0.0, 1e-3, 11)
    run = simulate(deep, Step(-5e-9, -7e-9, 1e-4), t_end=1e-3, t_eval=t, output_kinks=False)
    return t, run["position"].values


# ── simulate_force and its sensitivities ────────────────────────────────────────────────────────

def test_simulate_force_is_the_force_of_simulate_bit_for_bit(deep, step_trace):
    t, h = step_trace
    drive = MeasuredTrace(t, h)
    ref = simulate(deep, drive, t_end=t[-1], t_eval=t, output_kinks=False, progress=False)
    for sens in (False, True):
        run = simulate_force(deep, drive, t_end=t[-1], t_eval=t, sensitivities=sens)
        np.testing.assert_array_equal(run.force, ref["force"].values)
        assert run.steps == ref.attrs["steps"] and run.newton == ref.attrs["newton_iterations"]
        assert (run.sensitivity is None) == (not sens)
    assert run.sensitivity.shape == (t.size, 3)
    assert run.step_gap_sensitivity.shape == (run.steps, 3, deep.grid.size)


def test_sensitivities_equal_finite_differences_on_a_fixed_grid(deep, step_trace):
    """∂F/∂ln(E0, E_inf, τ) of StepResponse against central differences on the same steps."""
    t, h = step_trace
    drive = MeasuredTrace(*corners(t, h))
    values = {"E0": TRUTH.E0, "E_inf": TRUTH.E_inf, "tau": TRUTH.tau}
    response = StepResponse(deep, drive)
    gradient = response.log_gradient(t, values)
    grid = simulate_force(deep, drive, t_end=t[-1], t_eval=t).step_time

    def force(v):
        material = StandardLinearSolid(v["E0"], v["E_inf"], v["tau"])
        return simulate_force(deep.with_material(material), drive, t_end=t[-1], t_eval=t,
                              grid=grid).force

    eps = 1e-4
    for name in NAMES:
        up, down = dict(values), dict(values)
        up[name] *= np.exp(eps)
        down[name] *= np.exp(-eps)
        fd = (force(up) - force(down)) / (2 * eps)
        scale = np.max(np.abs(gradient[name]))
        assert scale > 0
        np.testing.assert_allclose(gradient[name], fd, rtol=0, atol=1e-5 * scale)


def test_the_grid_repeat_and_warm_starts_change_no_converged_force(deep, step_trace):
    """On its own grid, warm-started from itself, a run gives the same force to Newton's tol."""
    t, h = step_trace
    drive = MeasuredTrace(*corners(t, h))
    first = simulate_force(deep, drive, t_end=t[-1], t_eval=t, sensitivities=True)
    again = simulate_force(deep, drive, t_end=t[-1], t_eval=t, sensitivities=True,
                           grid=first.step_time, warm_start=(first.step_time, first.step_gap))
    assert again.rejected == 0 and again.newton == again.steps  # one Newton iteration a step
    np.testing.assert_allclose(again.force, first.force, rtol=1e-9)
    np.testing.assert_allclose(again.sensitivity, first.sensitivity, rtol=1e-5,
                               atol=1e-6 * np.max(np.abs(first.sensitivity)))


def test_bad_warm_starts_and_flags_raise(deep, step_trace):
    t, h = step_trace
    drive = MeasuredTrace(t, h)
    with pytest.raises(ParameterError, match="warm_start gaps must be positive with shape"):
        simulate_force(deep, drive, t_eval=t, t_end=t[-1], warm_start=(t, np.ones((2, 3))))
    with pytest.raises(ParameterError, match="sensitivities must be True or False"):
        simulate_force(deep, drive, t_eval=t, t_end=t[-1], sensitivities="yes")
    with pytest.raises(ParameterError, match="drive must be a drive"):
        simulate_force(deep, object(), t_eval=t, t_end=t[-1])
    with pytest.raises(ParameterError, match="t_eval must lie in"):
        simulate_force(deep, drive, t_eval=t, t_end=t[-1] / 2)


def test_step_model_inputs_are_validated(deep, step_trace):
    trace = step_trace
    with pytest.raises(ParameterError, match="start must map E0, E_inf and tau"):
        make_model("step", problem=deep, position_trace=trace, start={"E0": 1e10})
    with pytest.raises(ParameterError, match="tol must be > 0"):
        make_model("step", problem=deep, position_trace=trace, tol=-1.0)


# ── corners ─────────────────────────────────────────────────────────────────────────────────────

def test_corners_keep_the_bends_and_ends_of_a_piecewise_linear_trace(rng):
    t = np.linspace(0.0, 4e-3, 81)
    h = Triangle(-3e-9, -7e-9, 4e-6).position(t)
    tk, hk = corners(t, h)
    np.testing.assert_allclose(tk, [0.0, 1e-3, 2e-3, 4e-3], rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.interp(t, tk, hk), h, rtol=0, atol=1e-20)
    noisy = h + 1e-12 * rng.standard_normal(h.shape)
    assert corners(t, noisy)[0].size == t.size  # a measured trace keeps every sample


# ── the fit: same answers as the old implementation ──────────────────────────────────────────────
# The old implementation's answers on the two cases below, stored (it costs ~10 s a run: one
# ``simulate`` per evaluation, finite-difference Jacobian); the slow test
# test_the_stored_old_answers_are_what_the_old_implementation_gives recomputes them.

OLD_DATA_VARS = (
    "E_inf", "E_inf_stderr", "E0", "E0_stderr", "tau", "tau_stderr", "correlation", "success",
    "redchi", "aic", "bic", "modes", "fit_force", "chi2_pvalue", "identifiability", "E_inf_young",
    "E_inf_young_stderr", "E_inf_shear", "E_inf_shear_stderr", "E0_young", "E0_young_stderr",
    "E0_shear", "E0_shear_stderr")
OLD_ATTRS = frozenset((
    "at_bound", "chisqr", "chisqr_calibrated", "data_kind", "data_points", "dof",
    "identifiability_method", "message", "model", "modulus_convention", "nfev", "poisson",
    "system_P", "system_Pw", "system_debye_length", "system_grid_spacing", "system_n_panels",
    "system_order", "system_outer_radius", "system_radius", "system_surface_force", "system_z0",
    "tip", "tip_radius", "tip_shape", "validity", "weighting"))
OLD = {  # name → (value, stderr) of old_fit_step, and the triangle's correlation and redchi
    "step": {"E0": (10000032677.713514, 13906.852452590436),
             "E_inf": (999996928.3980252, 742.1038127591695),
             "tau": (0.001000004422648722, 2.7538239912205576e-09)},
    "triangle": {"E0": (10117670004.699697, 56347746.902017035),
                 "E_inf": (999293869.4468957, 631244.6778168308),
                 "tau": (0.0009950224481665082, 2.003518846544973e-06)},
}
OLD_TRIANGLE_CORRELATION = ((1.0, 0.050076, -0.682993), (0.050076, 1.0, -0.561588),
                            (-0.682993, -0.561588, 1.0))
OLD_TRIANGLE_REDCHI = 1.9119308296160386e-18


def _step_data(deep, step_trace):
    return _trajectory(deep, Step(-5e-9, -7e-9, 1e-4), step_trace[0])


def _triangle_data(deep):
    t = np.linspace(0.0, 2.5e-3, 11)
    return _trajectory(deep, Triangle(-3e-9, -7e-9, 4e-6), t, noise=3e-3, seed=7)


def _compare(old, new):
    return {n: ((float(new[n]) - old[n][0]) / old[n][0], (float(new[n]) - old[n][0]) / old[n][1],
                float(new[f"{n}_stderr"]) / old[n][1] - 1.0) for n in NAMES}


@pytest.fixture(scope="module")
def step_fit(deep, step_trace):
    """fit_step of the noise-free step from the wrong material (read, never modified)."""
    return fit_step(_step_data(deep, step_trace), problem=deep.with_material(WRONG))


def test_noise_free_step_fit_equals_the_old_implementation(step_fit):
    new = step_fit
    for name, (rel, _, _) in _compare(OLD["step"], new).items():
        assert abs(rel) < 1e-4, name
        assert float(new[name]) == pytest.approx(getattr(TRUTH, name), rel=1e-4)
    assert list(new.data_vars) == list(OLD_DATA_VARS)
    assert set(new.attrs) == OLD_ATTRS
    assert new["fit_force"].dims == ("time",)


def test_noisy_triangle_fit_equals_the_old_implementation_within_its_stderr(deep):
    new = fit_step(_triangle_data(deep), problem=deep.with_material(WRONG))
    for name, (_, in_stderr, stderr_rel) in _compare(OLD["triangle"], new).items():
        assert abs(in_stderr) < 0.05, name
        assert abs(stderr_rel) < 1e-2, name
    np.testing.assert_allclose(new["correlation"].values, OLD_TRIANGLE_CORRELATION, atol=1e-3)
    assert float(new["redchi"]) == pytest.approx(OLD_TRIANGLE_REDCHI, rel=1e-2)


@pytest.mark.slow
def test_the_stored_old_answers_are_what_the_old_implementation_gives(deep, step_trace):
    """The copy in benchmarks/bench_step.py, rerun on both cases (~10 s): the stored numbers to
    1e-6 (the same deterministic computation; only a different BLAS could move them)."""
    old_fit_step = benchmark_module("bench_step.py").old_fit_step
    problem = deep.with_material(WRONG)
    for case, data in (("step", _step_data(deep, step_trace)), ("triangle", _triangle_data(deep))):
        old = old_fit_step(data, problem=problem)
        for name, (value, stderr) in OLD[case].items():
            assert float(old[name]) == pytest.approx(value, rel=1e-6), (case, name)
            assert float(old[f"{name}_stderr"]) == pytest.approx(stderr, rel=1e-6), (case, name)
        assert list(old.data_vars) == list(OLD_DATA_VARS) and set(old.attrs) == OLD_ATTRS
    np.testing.assert_allclose(old["correlation"].values, OLD_TRIANGLE_CORRELATION, atol=1e-6)
    assert float(old["redchi"]) == pytest.approx(OLD_TRIANGLE_REDCHI, rel=1e-6)


def test_the_reported_curve_is_one_adaptive_simulation_at_the_fitted_values(deep, step_trace,
                                                                           step_fit):
    t, h = step_trace
    new = step_fit
    material = StandardLinearSolid(float(new["E0"]), float(new["E_inf"]), float(new["tau"]))
    run = simulate_force(deep.with_material(material), MeasuredTrace(*corners(t, h)),
                         t_end=t[-1], t_eval=t)
    # the same adaptive steps; Newton started elsewhere (warm), converged to the same tolerance
    np.testing.assert_allclose(new["fit_force"].values, run.force, rtol=1e-9)
