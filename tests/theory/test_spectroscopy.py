"""Force spectroscopy: two independent paths agree; paper Figs. 2–4 checks; dataset contract."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy.optimize import minimize_scalar

import viscoforce as vf
from viscoforce._limits import MAX_SAMPLES
from viscoforce.exceptions import EffortError
from viscoforce.experiments import Ramp
from viscoforce.experiments.linear_response import linear_response, linear_stiffness
from viscoforce.experiments.spectroscopy import (
    spectrum,
    svda_spectrum,
    sweep,
)
from viscoforce.schema import SchemaError, validate_spectrum
from viscoforce.solvers.simulate import simulate
from viscoforce.solvers.svda_ode import solve_svda
from viscoforce.svda import svda_peak_phase_frequency, svda_ramp_deformation

#: The paper's Fig. 3 scene (2 nm) is deliberately evaluated with the SVDA, which warns there
#: (estimated error > 1 %, issue 15); the warning itself is tested in tests/theory/test_failure_regions.py.
pytestmark = pytest.mark.filterwarnings(
    "ignore:the SVDA is about:viscoforce.exceptions.ModelValidityWarning")


TAU = vf.PAPER.tau
SLS = vf.PAPER.material()


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
    with pytest.warns(vf.ModelValidityWarning, match=r"kappa\*eta = 1"):  # η = 1 nm: not small
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
        sv = solve_svda(drive, E0=1e10, E_inf=1e9, tau=TAU, radius=10e-6, P=1e7,
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
    with pytest.raises(vf.ParameterError, match="omega must be > 0"):
        linear_response(problem, 2e-9, 1e-10, [-1.0])
    with pytest.raises(vf.ParameterError, match="omega must be > 0"):
        sweep(problem, 2e-9, 1e-10, [0.0])
    with pytest.raises(vf.ParameterError, match="periods must be an integer >= 1"):
        sweep(problem, 2e-9, 1e-10, [1.0], periods=0)
    prony = vf.PronySeries.from_moduli([1e10, 3e9, 1e9], [1e-4, 1e-3])
    with pytest.raises(vf.ParameterError, match="single-relaxation-time"):
        svda_spectrum(make_problem(prony, 2e-9), 2e-9, 1e-10, [1.0])


# Every bad argument raises ParameterError naming the parameter and its allowed range, before
# any computing (the problem is built once; each call fails in its argument checks).
_PROBLEM = "problem must be a ContactProblem"
_POSITION = r"position must be finite \[m\]"
_ETA = r"eta must be > 0 \[m\] \(finite\)"
_OMEGA_POS = r"omega must be .*> 0 rad/s"
_OMEGA_NONNEG = r"omega must be .*>= 0 rad/s"
_COMMON = [
    (dict(problem=None), _PROBLEM),
    (dict(problem="paper"), _PROBLEM),
    (dict(position=None), _POSITION),
    (dict(position=np.nan), _POSITION),
    (dict(position=np.inf), _POSITION),
    (dict(position="2nm"), _POSITION),
    (dict(eta=None), _ETA),
    (dict(eta=np.nan), _ETA),
    (dict(eta=-np.inf), _ETA),
    (dict(eta=0.0), _ETA),
    (dict(eta=-1e-10), _ETA),
    (dict(eta="0.1nm"), _ETA),
    (dict(omega=None), r"omega must be a non-empty 1-D array"),
    (dict(omega=[]), r"omega must be a non-empty 1-D array.*needs at least 1 values, got 0"),
    (dict(omega="fast"), r"omega must be a non-empty 1-D array"),
    (dict(omega=[[1.0, 2.0]]), r"omega must be a non-empty 1-D array.*must be 1-D"),
    (dict(omega=[1.0, np.nan]), r"omega must be .*finite; entry 1 is nan"),
    (dict(omega=[np.inf]), r"omega must be .*finite; entry 0 is inf"),
]
_SWEEP_ONLY = [
    (dict(omega=[1.0, 0.0]), r"omega must be > 0 rad/s; entry 1 is 0.0"),
    (dict(omega=[-1.0]), _OMEGA_POS),
    (dict(settle=np.nan), r"settle must be >= 0 \[s\] \(finite; None for 10 tau_max\), got nan"),
    (dict(settle=np.inf), r"settle must be >= 0 \[s\]"),
    (dict(settle=-1e-3), r"settle must be >= 0 \[s\]"),
    (dict(settle="1ms"), r"settle must be >= 0 \[s\]"),
    (dict(periods=0), "periods must be an integer >= 1, got 0"),
    (dict(periods=2.0), "periods must be an integer >= 1, got 2.0"),
    (dict(periods="4"), "periods must be an integer >= 1, got '4'"),
    (dict(periods=2, accuracy=1e-3), r"give periods or accuracy \(which chooses them\), not both"),
    (dict(accuracy=0.5), r"accuracy must be"),
    (dict(settle=0.0, accuracy=1e-4), r"settle must be longer for accuracy = 0.0001: settle = 0 s"),
    (dict(samples_per_period=7), "samples_per_period must be an integer >= 8"),
    (dict(tol=0.0), r"tol must be > 0 \[m\]"),
    (dict(tol=np.nan), r"tol must be > 0 \[m\]"),
    (dict(stepper="rk4"), r"stepper must be one of \['euler', 'exponential', 'exponential-euler'\]"),
    (dict(stepper=None), "stepper must be one of"),
    (dict(steps_per_period=0), "steps_per_period must be an integer >= 1"),
    (dict(n_jobs=0), "n_jobs must be an integer >= 1"),
    (dict(n_jobs=None), "n_jobs must be an integer >= 1"),
    (dict(progress="yes"), "progress must be True, False or None"),
]


def _call(func, problem, kwargs):
    args = dict(problem=problem, position=2e-9, eta=1e-10, omega=[1e3])
    args.update(kwargs)
    return func(args.pop("problem"), args.pop("position"), args.pop("eta"), args.pop("omega"),
                **args)


@pytest.mark.parametrize(("kwargs", "match"), _COMMON + _SWEEP_ONLY)
def test_sweep_rejects_every_bad_argument(make_problem, no_compute, kwargs, match):
    with pytest.raises(vf.ParameterError, match=match):
        _call(sweep, make_problem(SLS, 1.9e-9), kwargs)


@pytest.mark.parametrize(("kwargs", "match"), _COMMON + [(dict(omega=[-1.0]), _OMEGA_POS)])
@pytest.mark.parametrize("func", [linear_response, svda_spectrum])
def test_frequency_domain_routes_reject_every_bad_argument(make_problem, no_compute, func, kwargs,
                                                           match):
    with pytest.raises(vf.ParameterError, match=match):
        _call(func, make_problem(SLS, 1.9e-9), kwargs)


@pytest.mark.parametrize(("args", "match"), [
    ((None, 2e-9, [1.0]), _PROBLEM),
    (("problem", 2e-9, [1.0]), _PROBLEM),
    ((..., np.nan, [1.0]), _POSITION),
    ((..., None, [1.0]), _POSITION),
    ((..., 2e-9, []), r"omega must be a non-empty 1-D array"),
    ((..., 2e-9, None), r"omega must be a non-empty 1-D array"),
    ((..., 2e-9, [-1.0]), _OMEGA_NONNEG),
    ((..., 2e-9, [np.nan]), r"omega must be .*finite"),
])
def test_linear_stiffness_rejects_bad_arguments(make_problem, no_compute, args, match):
    problem = make_problem(SLS, 1.9e-9) if args[0] is ... else args[0]
    with pytest.raises(vf.ParameterError, match=match):
        linear_stiffness(problem, *args[1:])


@pytest.mark.parametrize("method", ["auto", "linear", "time-domain", "svda"])
@pytest.mark.parametrize(("kwargs", "match"), [
    (dict(problem=None), _PROBLEM),
    (dict(eta=np.nan), _ETA),
    (dict(eta=None), _ETA),
    (dict(eta=0.0), _ETA),
    (dict(omega=[]), r"omega must be a non-empty 1-D array"),
    (dict(omega=None), r"omega must be a non-empty 1-D array"),
    (dict(position=np.nan), _POSITION),
])
def test_spectrum_rejects_bad_arguments_for_every_method(make_problem, no_compute, method, kwargs,
                                                          match):
    with pytest.raises(vf.ParameterError, match=match):
        _call(spectrum, make_problem(SLS, 1.9e-9), {"method": method, **kwargs})


@pytest.mark.parametrize("method", [None, "fast", ["linear"], 3])
def test_spectrum_rejects_unknown_methods(make_problem, method):
    with pytest.raises(vf.ParameterError, match=r"method must be 'auto' or one of \['contact', "
                                                r"'linear', 'svda', 'svda-ode', 'time-domain'\], "
                                                r"got"):
        spectrum(make_problem(SLS, 1.9e-9), 2e-9, 1e-10, [1e3], method=method)


def test_spectrum_options_only_for_the_time_domain(make_problem):
    with pytest.raises(TypeError, match="method 'linear' takes no options, got \\['periods'\\]"):
        spectrum(make_problem(SLS, 1.9e-9), 2e-9, 1e-10, [1e3], method="linear", periods=2)


def test_choose_spectrum_rejects_bad_arguments(make_problem):
    from viscoforce.experiments.choice import choose_spectrum

    with pytest.raises(vf.ParameterError, match="problem must be a ContactProblem"):
        choose_spectrum(None, 2e-9, 1e-10, [1.0])
    with pytest.raises(vf.ParameterError, match="eta must be"):
        choose_spectrum(make_problem(SLS, 1.9e-9), 2e-9, np.nan, [1.0])


# ── effort guards: refused before computing, the estimate in the message (fast) ────────────────

@pytest.fixture
def no_compute(monkeypatch):
    """Make any simulation or static solve fail at once: a refusal test must never compute."""
    from viscoforce.experiments import _modal
    from viscoforce.experiments import linear_response as lr_module
    from viscoforce.experiments import spectroscopy as sp_module

    def forbidden(*args, **kwargs):
        raise AssertionError("computed although the request should have been refused")

    monkeypatch.setattr(sp_module, "simulate", forbidden)
    monkeypatch.setattr(lr_module, "equilibrium_gap", forbidden)
    monkeypatch.setattr(_modal, "equilibrium_gap", forbidden)


def test_time_domain_spectrum_at_1e9_rad_s_is_refused_instantly(make_problem, no_compute):
    # τ = 1 ms: 10τ settling at ω = 1e9 rad/s is 1.59e6 periods, ≥ 8 steps each.
    problem = make_problem(SLS, 1.9e-9)
    with pytest.raises(EffortError, match=r"time steps of the time-domain sweep \(1 frequency, "
                                          r"settling and demodulated periods, at least 8 steps per "
                                          r"period\): about 1.27e\+07 needed, beyond the limit of "
                                          r"5e\+06; "
                                          r"refused before computing \(fewer or lower frequencies"):
        spectrum(problem, 2e-9, 1e-9, [1e9], method="time-domain")
    with pytest.raises(EffortError, match="about 1.27e\\+07 needed"):
        sweep(problem, 2e-9, 1e-10, [1e9], n_jobs=4)


def test_sweep_effort_counts_every_frequency_and_the_stepper(make_problem, no_compute):
    problem = make_problem(SLS, 1.9e-9)
    # 4000 frequencies at 1e5 rad/s: 160 settling periods x ≥ 8 steps + 4 x 64 samples = 1536
    # steps per ω, 6.14e6 in all (4 periods given; the 1 chosen by default: 5.38e6)
    with pytest.raises(EffortError, match=r"\(4000 frequencies.*about 6.14e\+06 needed"):
        sweep(problem, 2e-9, 1e-10, np.full(4000, 1e5), periods=4)
    with pytest.raises(EffortError, match=r"\(4000 frequencies.*about 5.38e\+06 needed"):
        sweep(problem, 2e-9, 1e-10, np.full(4000, 1e5))
    # a fixed step of period/1e5 at 1e3 rad/s: 6 periods x 1e5 steps = 6e5 per ω; 10 ω = 6e6
    with pytest.raises(EffortError, match=r"steps_per_period = 100000\): about 6e\+06 needed"):
        sweep(problem, 2e-9, 1e-10, np.full(10, 1e3), steps_per_period=100_000, periods=4)
    # explicit Euler's default dt = 0.1 τ E_inf/E0 = 1e-5 s: 5 periods at 10 rad/s = 3.14 s,
    # 3.1e5 steps per ω; 20 ω = 6.28e6
    with pytest.raises(EffortError, match=r"euler stepper's default dt = 1e-05 s\): about "
                                          r"6.28e\+06 needed"):
        sweep(problem, 2e-9, 1e-10, np.full(20, 10.0), stepper="euler", periods=4)
    with pytest.raises(EffortError, match=r"output samples of the time-domain sweep \(2 "
                                          r"frequencies x 40000001\): about 8e\+07"):
        sweep(problem, 2e-9, 1e-10, [1e3, 2e3], samples_per_period=10_000_000, periods=4)


def test_linear_response_refuses_more_than_max_samples_frequencies(make_problem, no_compute):
    problem = make_problem(SLS, 1.9e-9)
    too_many = np.broadcast_to(10.0, (MAX_SAMPLES + 1,))  # a view: no 80 MB allocation
    with pytest.raises(EffortError, match=r"frequencies of linear_stiffness \(10000001 "
                                          r"requested\): about 1e\+07 needed, beyond the limit"):
        linear_response(problem, 2e-9, 1e-10, too_many)
    with pytest.raises(EffortError, match="refused before computing"):
        linear_stiffness(problem, 2e-9, too_many)


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


@pytest.mark.filterwarnings("ignore::viscoforce.exceptions.AccuracyWarning")  # coarse on purpose
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
