"""Force spectroscopy: two independent paths agree; paper Figs. 2–4 checks; dataset contract."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy.optimize import minimize_scalar

import viscoforce as vf
from viscoforce.closed_form import svda_peak_phase_frequency, svda_ramp_deformation
from viscoforce.experiments import Ramp
from viscoforce.experiments.linear_response import linear_response, linear_stiffness
from viscoforce.experiments.spectroscopy import svda_spectrum, sweep
from viscoforce.schema import SchemaError, validate_spectrum
from viscoforce.solvers.simulate import simulate
from viscoforce.svda import solve_svda

TAU = 1e-3
SLS = vf.StandardLinearSolid(E0=1e10, E_inf=1e9, tau=TAU)


def phase_peak(problem, position):
    """Maximum of the linear-response phase over log ω (bounded scalar search)."""

    def neg(log_w):
        k, _ = linear_stiffness(problem, position, [10.0**log_w])
        return -np.degrees(np.angle(k[0]))

    res = minimize_scalar(neg, bounds=(1.0, 5.0), method="bounded",
                          options={"xatol": 1e-6})
    return -res.fun, 10.0**res.x


@pytest.mark.parametrize(("position", "eta"), [(2e-9, 0.01e-9), (-5e-9, 0.01e-9)])
def test_time_domain_lockin_equals_frequency_domain_at_small_eta(make_problem, position, eta):
    """The strongest end-to-end check: simulate + demodulate vs one complex solve per ω.

    Measured at η = 0.01 nm: |Δk|/k ≤ 5e-5 and |Δχ| ≤ 2e-3° (issue: ≤ 1e-3 and ≤ 0.05°).
    """
    problem = make_problem(SLS, position - eta)
    omega = np.array([100.0, 1e3, 1e4])
    td = sweep(problem, position, eta, omega)
    lin = linear_response(problem, position, eta, omega)
    np.testing.assert_allclose(td.stiffness, lin.stiffness, rtol=1e-3)
    np.testing.assert_allclose(td.phase, lin.phase, atol=0.05)
    np.testing.assert_allclose(td.mean_force, lin.mean_force, rtol=1e-4)


def test_fig3_exact_spectrum_at_2nm(make_problem):
    """Paper Fig. 3 (h̄0 = 2 nm): 61.0 nN, −0.46 nm, phase max ≈ 7°, amplitude ratio ≈ 1.3.

    Measured (linear response, default grid): peak 7.04° at ωτ = 1.08, ratio 1.280; the paper
    puts the amplitude transition and the phase peak at ωτ = 0.78.
    """
    problem = make_problem(SLS, 2e-9)
    static = vf.static_equilibrium(problem, 2e-9)
    assert float(static.force) == pytest.approx(61.0e-9, abs=0.05e-9)
    assert float(static.u_center) == pytest.approx(-0.46e-9, abs=0.005e-9)
    peak, w_peak = phase_peak(problem, 2e-9)
    assert peak == pytest.approx(7.0, abs=0.5)
    assert 0.5 < w_peak * TAU < 1.5
    sp = linear_response(problem, 2e-9, 0.1e-9, [1e-2 / TAU, 1e3 / TAU])
    ratio = float(sp.amplitude[1] / sp.amplitude[0])
    assert ratio == pytest.approx(1.3, abs=0.05)
    assert float(sp.amplitude[0]) == pytest.approx(0.0757, abs=5e-4)


def test_fig3_svda_peak_phase_frequency():
    """SVDA (ω0τ)² = (1 + cE0/E_inf)/(1 + c): the paper prints ω0⁻¹ = 0.85τ; we get 0.852τ."""
    w0 = svda_peak_phase_frequency(2e-9, 1e10, 1e9, TAU, 10e-6, 1e7, 1e-9)
    assert 1.0 / (w0 * TAU) == pytest.approx(0.85, abs=0.005)


def test_fig4_exact_spectrum_at_minus_5nm(make_problem):
    """Paper Fig. 4 (h̄0 = −5 nm): 1.08 µN, amplitude ratio ≈ 4, phase peak 38° at ωτ ≈ 2.

    Measured (small-amplitude limit, default grid): peak 36.2° at ωτ = 2.3, ratio 4.15. The
    paper's 38° is a finding we do not reproduce exactly; see the η = 1 nm time-domain values
    in benchmarks/README.md.
    """
    problem = make_problem(SLS, -6e-9)
    assert float(vf.static_equilibrium(problem, -5e-9).force) == pytest.approx(1.08e-6, abs=5e-9)
    peak, w_peak = phase_peak(problem, -5e-9)
    assert 34.0 < peak < 39.0
    assert 1.5 < w_peak * TAU < 3.0
    sp = linear_response(problem, -5e-9, 1e-9, [1e-2 / TAU, 1e3 / TAU])
    assert float(sp.stiffness[1] / sp.stiffness[0]) == pytest.approx(4.0, abs=0.3)


def test_phase_peak_is_grid_converged(make_problem):
    coarse = make_problem(SLS, -5e-9)
    fine = make_problem(SLS, -5e-9, grid_spacing=coarse.grid.spacing / 2)
    assert phase_peak(coarse, -5e-9)[0] == pytest.approx(phase_peak(fine, -5e-9)[0], abs=1e-3)


def test_linear_response_limits(make_problem):
    """ω → 0: the static E_inf stiffness −dF/dh0 (finite differences of the statics); χ → 0 at
    both ends; ω → ∞ stiffer (the E0 response about the same E_inf state)."""
    problem = make_problem(SLS, -3e-9)
    k, mean = linear_stiffness(problem, -2e-9, [1e-6, 1e12])
    d = 1e-13
    fp = float(vf.static_equilibrium(problem, -2e-9 + d).force)
    fm = float(vf.static_equilibrium(problem, -2e-9 - d).force)
    assert k[0].real == pytest.approx(-(fp - fm) / (2 * d), rel=1e-5)
    assert mean == pytest.approx(float(vf.static_equilibrium(problem, -2e-9).force), rel=1e-14)
    assert abs(np.degrees(np.angle(k))).max() < 1e-3
    assert k[1].real > 2 * k[0].real
    elastic = make_problem(vf.Elastic(1e9), -3e-9)
    ke, _ = linear_stiffness(elastic, -2e-9, [1.0, 1e3, 1e6])
    np.testing.assert_allclose(ke, ke[0], rtol=1e-12)


def test_svda_spectrum_close_to_exact_before_contact(make_problem):
    """Fig. 3: the SVDA overestimates the phase and underestimates the amplitude (paper)."""
    problem = make_problem(SLS, 4e-9)
    w = np.geomspace(10, 1e5, 9)
    lin = linear_response(problem, 4e-9, 0.1e-9, w)
    svda = svda_spectrum(problem, 4e-9, 0.1e-9, w)
    assert float(svda.phase.max()) > float(lin.phase.max())
    np.testing.assert_allclose(svda.stiffness, lin.stiffness, rtol=0.05)


def test_fig2_exact_vs_svda_ode_vs_eq20():
    """Ramps from 10 nm at 5 and 1 µm/s: Eq. 17 is quantitatively accurate before contact,
    Eq. 20 overestimates |u| close to contact, slower driving deforms more (paper Fig. 2).

    Measured at h0 = 2 nm: exact −0.1545 / −0.3080 nm, Eq. 17 −0.1518 / −0.2985, Eq. 20
    −0.1696 / −0.3732 (5 / 1 µm/s).
    """
    law = vf.paper_pressure_law()
    problem = vf.ContactProblem.create(sphere=vf.Sphere(10e-6), surface_force=law, material=SLS,
                                       deepest_position=0.0)
    u_exact = {}
    for v in (5e-6, 1e-6):
        drive = Ramp.from_speed(10e-9, 2e-9, v)
        t = np.linspace(0, drive.duration, 5)
        ex = simulate(problem, drive, t_end=drive.duration, t_eval=t)
        sv = solve_svda(drive, E0=1e10, E_inf=1e9, tau=TAU, radius=10e-6, pressure=1e7,
                        debye_length=1e-9, t_eval=t)
        eq20 = svda_ramp_deformation(t, 10e-9, -v, 1e10, 1e9, TAU, 10e-6, 1e7, 1e-9)
        u = ex.u_center.values
        np.testing.assert_allclose(sv.deformation[1:], u[1:], rtol=0.04)
        assert abs(eq20[-1]) > abs(sv.deformation[-1]) and abs(eq20[-1]) > abs(u[-1])
        u_exact[v] = u[-1]
    assert u_exact[1e-6] < u_exact[5e-6] < 0


def test_spectrum_dataset_contract_and_netcdf(make_problem, tmp_path):
    problem = make_problem(SLS, 2e-9)
    sp = linear_response(problem, 2e-9, 0.1e-9, [10.0, 100.0])
    assert sp.omega.attrs["units"] == "rad/s" and sp.phase.attrs["units"] == "degree"
    assert sp.stiffness.attrs["units"] == "N/m" and sp.attrs["method"] == "linear"
    np.testing.assert_allclose(sp.amplitude, sp.stiffness * 0.1e-9 / sp.mean_force, rtol=1e-14)
    path = tmp_path / "sp.nc"
    sp.to_netcdf(path, engine="scipy")
    with xr.open_dataset(path, engine="scipy") as back:
        assert back.load().identical(sp)
    validate_spectrum(sp)
    with pytest.raises(SchemaError, match="missing 'phase'"):
        validate_spectrum(sp.drop_vars("phase"))
    bad = sp.copy()
    bad["stiffness"].attrs["units"] = "N"
    with pytest.raises(SchemaError, match="'stiffness' must have units 'N/m'"):
        validate_spectrum(bad)


def test_spectroscopy_bad_inputs(make_problem):
    problem = make_problem(SLS, 2e-9)
    with pytest.raises(vf.ParameterError, match="eta must be > 0"):
        linear_response(problem, 2e-9, 0.0, [1.0])
    with pytest.raises(vf.ParameterError, match="omega must be >= 0"):
        linear_response(problem, 2e-9, 1e-10, [-1.0])
    with pytest.raises(vf.ParameterError, match="omega must be > 0"):
        sweep(problem, 2e-9, 1e-10, [0.0])
    with pytest.raises(vf.ParameterError, match="periods must be an integer >= 1"):
        sweep(problem, 2e-9, 1e-10, [1.0], periods=0)
    prony = vf.PronySeries.from_moduli([1e10, 3e9, 1e9], [1e-4, 1e-3])
    with pytest.raises(vf.ParameterError, match="single-relaxation-time"):
        svda_spectrum(make_problem(prony, 2e-9), 2e-9, 1e-10, [1.0])


def test_bode_plot_overlays_methods_with_error_bars(make_problem):
    from viscoforce.plotting import bode_plot

    problem = make_problem(SLS, 2e-9)
    w = np.geomspace(10, 1e5, 12)
    lin = linear_response(problem, 2e-9, 0.1e-9, w)
    data = lin.copy()
    data["phase_stderr"] = xr.full_like(lin.phase, 0.2)
    handle = bode_plot({"exact": lin, "svda": svda_spectrum(problem, 2e-9, 0.1e-9, w),
                        "data": data}, frequency_unit="Hz", magnitude="amplitude")
    mag, phase = handle.axes
    assert mag.get_xscale() == "log" and "Hz" in phase.get_xlabel()
    assert "deg" in phase.get_ylabel() and "amplitude" in mag.get_ylabel()
    assert len(handle.lines) == 6
    x = mag.lines[0].get_xdata()
    np.testing.assert_allclose(x, w / (2 * np.pi))
    with pytest.raises(vf.ParameterError, match="magnitude must be"):
        bode_plot(lin, magnitude="power")
    with pytest.raises(SchemaError, match="has no 'phase'"):
        bode_plot(lin.drop_vars("phase"))


def test_sweep_in_parallel_equals_serial(make_problem):
    problem = make_problem(SLS, 1.9e-9)
    w = np.array([1e3, 3e3])
    serial = sweep(problem, 2e-9, 0.1e-9, w, periods=2, settle=2e-3)
    parallel = sweep(problem, 2e-9, 0.1e-9, w, periods=2, settle=2e-3, n_jobs=2)
    np.testing.assert_allclose(parallel.phase, serial.phase, rtol=1e-12)


def test_fig4_explicit_euler_coarse_steps_overestimate_the_phase(make_problem):
    """Finding (benchmarks/README.md): explicit Euler at dt = period/N overshoots the phase at
    first order (Fig. 4, ω = 2342 rad/s: 52.9° at N = 16, 43.2° at 32, 39.4° at 64, converging to
    ≈ 35.7°); the paper's 38° corresponds to N ≈ 100. The converged solver gives 35.8° at η = 1 nm.
    """
    problem = make_problem(SLS, -6e-9)
    w = [2342.0]
    coarse = sweep(problem, -5e-9, 1e-9, w, stepper="euler", steps_per_period=16,
                   samples_per_period=16, periods=2)
    exact = sweep(problem, -5e-9, 1e-9, w, periods=2)
    assert float(coarse.phase[0]) == pytest.approx(52.9, abs=0.5)
    assert float(exact.phase[0]) == pytest.approx(35.8, abs=0.3)


class _Attraction(vf.physics.surface_forces.SurfaceForceLaw):
    """p = −A e^{−h/λ}: an attractive term (a pluggable law written by a user)."""

    def __init__(self, amplitude, length):
        self.amplitude, self.length = amplitude, length

    def pressure(self, gap):
        return -self.amplitude * np.exp(-np.asarray(gap, dtype=float) / self.length)

    def pressure_derivative(self, gap):
        return -self.pressure(gap) / self.length

    def energy(self, gap):
        return self.pressure(gap) * self.length

    @property
    def decay_length(self):
        return self.length

    def negligible_gap(self, rtol):
        return self.length * np.log(1.0 / rtol)


def test_linear_response_with_an_attractive_term_matches_the_time_domain():
    """p′ > 0 where the attraction dominates: the linearisation must use −p′, not |p′|."""
    law = vf.paper_pressure_law() + _Attraction(2e6, 2e-9)
    problem = vf.ContactProblem.create(sphere=vf.Sphere(10e-6), surface_force=law, material=SLS,
                                       deepest_position=5.4e-9)
    w = [1e3]
    lin = linear_response(problem, 5.5e-9, 0.01e-9, w)
    td = sweep(problem, 5.5e-9, 0.01e-9, w, periods=2)
    np.testing.assert_allclose(td.stiffness, lin.stiffness, rtol=2e-3)
    np.testing.assert_allclose(td.phase, lin.phase, atol=0.05)


def test_svda_spectrum_refuses_contact(make_problem):
    with pytest.raises(vf.ParameterError, match="holds before contact only"):
        svda_spectrum(make_problem(SLS, -6e-9), -5e-9, 1e-9, [1e3])
