"""Bad input to the public entry points raises ParameterError naming the parameter (never
AttributeError, TypeError, ZeroDivisionError, IndexError, a numpy warning, or a NaN result).

Each case was found by probing the entry points with None, wrong types, NaN, ±inf, 0, negatives,
complex numbers, empty and wrong-length arrays (issue 11, item 6).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import viscoforce as vf
from viscoforce import kernel
from viscoforce.exceptions import GapClosureError, ParameterError
from viscoforce.experiments.drives import Hold, MeasuredTrace
from viscoforce.io.csv_formats import read_prony_moduli, read_trace
from viscoforce.physics.paper import PaperParameters
from viscoforce.problem import contact_radius, default_outer_radius, interaction_length
from viscoforce.radial_grid import RadialGrid
from viscoforce.solvers.newton import solve_gap
from viscoforce.solvers.steppers import ExponentialTrapezoidal

NM = 1e-9
SPHERE = vf.Sphere(10e-6)
LAW = vf.paper_pressure_law()
SLS = vf.PAPER.material()
GRID = RadialGrid(1e-7, 4, 8)  # 32 nodes, cheap
PROBLEM = vf.ContactProblem(SPHERE, LAW, vf.Elastic(1e9), GRID)
GAPS = np.full(GRID.size, 2 * NM)
NAN = float("nan")
INF = float("inf")


def _create(**changes):
    kwargs = {"sphere": SPHERE, "surface_force": LAW, "material": SLS, "deepest_position": -5 * NM}
    kwargs.update(changes)
    return vf.ContactProblem.create(**kwargs)


def _paper(**changes):
    return PaperParameters(**changes)


# (id, call, message regex)
CASES = [
    # ContactProblem and its grid
    ("create-sphere-None", lambda: _create(sphere=None), r"sphere must be a Particle, got None"),
    ("create-sphere-float", lambda: _create(sphere=10e-6),
     r"sphere must be a Particle, got float 1e-05"),
    ("create-law-str", lambda: _create(surface_force="paper"),
     r"surface_force must be a SurfaceForceLaw \(e\.g\. DoubleLayer.*got str 'paper'"),
    ("create-material-None", lambda: _create(material=None),
     r"material must be a ViscoelasticMaterial \(Elastic, StandardLinearSolid or PronySeries\), "
     r"got None"),
    ("create-depth-nan", lambda: _create(deepest_position=NAN), r"deepest_position must be finite"),
    ("create-order-None", lambda: _create(order=None), r"order must be an integer >= 2, got None"),
    ("problem-grid-None", lambda: vf.ContactProblem(SPHERE, LAW, SLS, None),
     r"grid must be a RadialGrid, got None"),
    ("problem-sphere-dict", lambda: vf.ContactProblem({}, LAW, SLS, GRID),
     r"sphere must be a Particle, got dict \{\}"),
    ("default_grid-sphere", lambda: vf.default_grid(None, LAW, -5 * NM),
     r"sphere must be a Particle, got None"),
    ("default_grid-law", lambda: vf.default_grid(SPHERE, 1e7, -5 * NM),
     r"surface_force must be a SurfaceForceLaw"),
    ("outer_radius-depth-nan", lambda: default_outer_radius(SPHERE, LAW, NAN),
     r"deepest_position must be finite"),
    ("outer_radius-depth-str", lambda: default_outer_radius(SPHERE, LAW, "5 nm"),
     r"deepest_position must be a real number, got '5 nm'"),
    ("interaction_length-sphere", lambda: interaction_length(object(), LAW),
     r"sphere must be a Particle, got object"),
    ("problem-undeformed_gap-nan", lambda: PROBLEM.undeformed_gap(NAN),
     r"position \(h0\) must be finite"),
    ("problem-undeformed_gap-list", lambda: PROBLEM.undeformed_gap([1.0, 2.0]),
     r"position \(h0\) must be a real number"),
    ("problem-pressure-None", lambda: PROBLEM.pressure(None),
     r"gap must be a number or an array of real numbers, got None"),
    ("problem-load-length", lambda: PROBLEM.load(np.ones(3)),
     r"values must have 32 values along its last axis \(one per node\), got shape \(3,\)"),
    ("problem-check_covers-nan", lambda: PROBLEM.check_covers(NAN),
     r"position \(h0\) must be finite"),
    ("problem-check_covers-str", lambda: PROBLEM.check_covers("abc"),
     r"position \(h0\) must be a real number"),
    ("contact_radius-grid", lambda: contact_radius(None, GAPS, 0.5 * NM, NM),
     r"grid must be a RadialGrid, got None"),
    ("contact_radius-gap-length", lambda: contact_radius(GRID, GAPS[:3], 0.5 * NM, NM),
     r"gap must have 32 values along its last axis"),
    ("contact_radius-gap-nan", lambda: contact_radius(GRID, np.full(GRID.size, NAN), 0.5 * NM, NM),
     r"gap must be finite; entry 0 is nan"),
    ("contact_radius-center-nan", lambda: contact_radius(GRID, GAPS, NAN, NM),
     r"gap_center must be finite"),
    ("contact_radius-center-None", lambda: contact_radius(GRID, GAPS, None, NM),
     r"gap_center must be a real number, got None"),
    # geometry
    ("sphere-gap-position-nan", lambda: SPHERE.undeformed_gap(NAN, [0.0]),
     r"position \(h0\) must be finite"),
    ("sphere-gap-position-None", lambda: SPHERE.undeformed_gap(None, [0.0]),
     r"position \(h0\) must be a real number, got None"),
    ("sphere-gap-r-nan", lambda: SPHERE.undeformed_gap(0.0, [1e-9, NAN]),
     r"r must be finite; entry 1 is nan"),
    ("sphere-gap-r-negative", lambda: SPHERE.undeformed_gap(0.0, [-1e-9]), r"r must be >= 0 m"),
    ("sphere-gap-r-str", lambda: SPHERE.undeformed_gap(0.0, "abc"),
     r"r must be a number or an array of real numbers, got str 'abc'"),
    ("sphere-radius_at_gap-None", lambda: SPHERE.radius_at_gap(0.0, None),
     r"gap must be a real number, got None"),
    ("sphere-radius_at_gap-nan", lambda: SPHERE.radius_at_gap(NAN, NM),
     r"position \(h0\) must be finite"),
    # surface forces
    ("law-pressure-None", lambda: LAW.pressure(None),
     r"gap must be a number or an array of real numbers, got None"),
    ("law-pressure-nan", lambda: LAW.pressure(NAN), r"gap must not be NaN; entry 0 is nan"),
    ("law-pressure-nan-entry", lambda: LAW.pressure([NM, NAN]), r"gap must not be NaN; entry 1"),
    ("law-pressure-str", lambda: LAW.pressure("1 nm"), r"gap must be a number or an array"),
    ("law-pressure-complex", lambda: LAW.pressure(1e-9 + 1e-10j),
     r"gap must be a number or an array of real numbers, got complex"),
    ("double-layer-derivative-object", lambda: vf.DoubleLayer().pressure_derivative(object()),
     r"gap must be a number or an array of real numbers, got object"),
    ("soft-wall-energy-dict", lambda: vf.SoftWall().energy({}), r"gap must be a number or an array"),
    ("law-negligible_gap-0", lambda: LAW.negligible_gap(0.0), r"rtol must be in \(0, 1\), got 0"),
    ("law-negligible_gap-1", lambda: vf.SoftWall().negligible_gap(1.0), r"rtol must be in \(0, 1\)"),
    ("law-negligible_gap-negative", lambda: vf.DoubleLayer().negligible_gap(-1.0),
     r"rtol must be in \(0, 1\)"),
    ("law-negligible_gap-nan", lambda: LAW.negligible_gap(NAN), r"rtol must be finite"),
    ("law-negligible_gap-None", lambda: LAW.negligible_gap(None), r"rtol must be a real number"),
    # the paper's parameter set
    ("paper-R-nan", lambda: _paper(R=NAN), r"R must be finite"),
    ("paper-debye-0", lambda: _paper(debye_length=0.0), r"debye_length must be > 0"),
    ("paper-tau-negative", lambda: _paper(tau=-1e-3), r"tau must be > 0"),
    ("paper-E0-below-E_inf", lambda: _paper(E0=1e9, E_inf=1e10),
     r"E0 \(instantaneous modulus\) must be > E_inf"),
    ("paper-Pw-None", lambda: _paper(Pw=None), r"Pw must be a real number, got None"),
    # radial grid
    ("from_spacing-order-None", lambda: RadialGrid.from_spacing(1e-6, 1e-8, None),
     r"order must be an integer >= 2, got None"),
    ("from_spacing-order-0", lambda: RadialGrid.from_spacing(1e-6, 1e-8, 0),
     r"order must be an integer >= 2, got 0"),
    ("from_spacing-order-nan", lambda: RadialGrid.from_spacing(1e-6, 1e-8, NAN),
     r"order must be an integer >= 2, got nan"),
    ("grid-order-40", lambda: RadialGrid(1e-6, 4, 40), r"order must be in \[2, 30\], got 40"),
    ("integrate_area-None", lambda: GRID.integrate_area(None),
     r"values must be a number or an array of real numbers, got None"),
    ("integrate_area-nan", lambda: GRID.integrate_area(np.full(GRID.size, NAN)),
     r"values must be finite; entry 0 is nan"),
    ("integrate_area-length", lambda: GRID.integrate_area(np.ones(GRID.size + 1)),
     r"values must have 32 values along its last axis"),
    ("interpolate-values-length", lambda: GRID.interpolate(np.ones(3), [0.0]),
     r"values must have 32 values along its last axis"),
    ("interpolate-r-None", lambda: GRID.interpolate(GAPS, None),
     r"r must be a number or an array of real numbers, got None"),
    ("interpolate-r-nan", lambda: GRID.interpolate(GAPS, [NAN]), r"r must be finite"),
    ("interpolate-r-2d", lambda: GRID.interpolate(GAPS, np.full((2, 2), 1e-8)),
     r"r must be a number or a 1-D array of radii \[m\], got shape \(2, 2\)"),
    # kernel
    ("influence_matrix-None", lambda: kernel.influence_matrix(None),
     r"grid must be a RadialGrid, got None"),
    ("influence_rows-grid", lambda: kernel.influence_rows("grid", [0.0]),
     r"grid must be a RadialGrid, got str 'grid'"),
    ("influence_rows-r-nan", lambda: kernel.influence_rows(GRID, [NAN]), r"r must be finite"),
    ("influence_rows-r-inf", lambda: kernel.influence_rows(GRID, [INF]), r"r must be finite"),
    ("influence_rows-r-outside", lambda: kernel.influence_rows(GRID, [-1e-9]),
     r"r must lie in \[0, 1e-07\] m"),
    ("influence_rows-r-2d", lambda: kernel.influence_rows(GRID, np.full((2, 2), 1e-8)),
     r"r must be a number or a 1-D array"),
    ("center_row-None", lambda: kernel.center_row(None), r"grid must be a RadialGrid, got None"),
    ("kernel_times_s-r-negative", lambda: kernel.kernel_times_s([-1.0], [1.0]), r"r must be >= 0"),
    ("kernel_times_s-s-zero", lambda: kernel.kernel_times_s([1.0], [0.0]), r"s must be > 0"),
    ("kernel_times_s-nan", lambda: kernel.kernel_times_s([NAN], [1.0]), r"r must be finite"),
    ("kernel_times_s-None", lambda: kernel.kernel_times_s([1.0], None),
     r"s must be a number or an array of real numbers, got None"),
    ("kernel_times_s-shapes", lambda: kernel.kernel_times_s([1.0, 2.0], [1.0, 2.0, 3.0]),
     r"r, s and offset must broadcast together"),
    # Newton and the steppers
    ("solve_gap-problem", lambda: solve_gap(None, GAPS, 2e-9, GAPS, xtol=1e-15),
     r"problem must be a ContactProblem, got None"),
    ("solve_gap-base-length", lambda: solve_gap(PROBLEM, GAPS[:3], 2e-9, GAPS, xtol=1e-15),
     r"base must have 32 values along its last axis"),
    ("solve_gap-initial-nan", lambda: solve_gap(PROBLEM, GAPS, 2e-9, GAPS * NAN, xtol=1e-15),
     r"initial must be finite"),
    ("solve_gap-coupling-0", lambda: solve_gap(PROBLEM, GAPS, 0.0, GAPS, xtol=1e-15),
     r"coupling must be > 0, got 0\.0"),
    ("solve_gap-xtol-nan", lambda: solve_gap(PROBLEM, GAPS, 2e-9, GAPS, xtol=NAN),
     r"xtol must be finite"),
    ("solve_gap-max_iter-0", lambda: solve_gap(PROBLEM, GAPS, 2e-9, GAPS, xtol=1e-15, max_iter=0),
     r"max_iter must be an integer >= 1, got 0"),
    ("stepper-problem-None", lambda: ExponentialTrapezoidal(None),
     r"problem must be a ContactProblem, got None"),
    ("stepper-relaxed-nan", lambda: ExponentialTrapezoidal(PROBLEM).relaxed_state(0.0, NAN),
     r"position \(h0\) must be finite"),
    ("stepper-step-state", lambda: ExponentialTrapezoidal(PROBLEM).step(None, Hold(0.0, 1.0), 1e-6),
     r"state must be a State, got None"),
    # complex numbers are refused, not silently cut to their real part (a ComplexWarning before)
    ("elastic-complex", lambda: vf.Elastic(1e9 + 1j), r"E must be a real number, got \(1000000000\+1j\)"),
    ("prony-complex", lambda: vf.PronySeries(1e10, (1e-9 + 1e-10j,), (1e-3,)),
     r"delta_compliances must be a 1-D array of real numbers, got tuple"),
    ("trace-complex", lambda: MeasuredTrace([0.0, 1.0], np.array([0.0, 1e-9 + 0j])),
     r"h0 must be a 1-D array of real numbers, got ndarray"),
    ("creep_compliance-complex", lambda: SLS.creep_compliance([1e-3 + 1j]),
     r"t must be a number or an array of real numbers, got list"),
    ("complex_modulus-complex", lambda: SLS.complex_modulus(np.array([1e3 + 0j])),
     r"omega must be a number or an array of real numbers, got ndarray"),
    ("complex_compliance-None", lambda: SLS.complex_compliance(None),
     r"omega must be a number or an array of real numbers, got None"),
    ("hold-complex", lambda: Hold(1e-9 + 1e-9j, 1.0), r"h0 must be a real number"),
    ("drive-position-complex", lambda: Hold(0.0, 1.0).position(0.5 + 1j),
     r"t must be real times \[s\], got \(0\.5\+1j\)"),
    ("drive-velocity-None", lambda: Hold(0.0, 1.0).velocity(None), r"t must be real times \[s\], got None"),
    ("drive-position-ragged", lambda: Hold(0.0, 1.0).position([[0.0], [0.1, 0.2]]),
     r"t must be real times \[s\]"),
]


@pytest.mark.parametrize(("call", "match"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_raises_parameter_error(call, match):
    with pytest.raises(ParameterError, match=match):
        call()


def test_stepper_step_rejects_bad_dt():
    stepper = ExponentialTrapezoidal(PROBLEM)
    drive = Hold(2 * NM, 1e-3)
    state = stepper.relaxed_state(0.0, 2 * NM)
    for dt, match in ((0.0, "dt must be > 0"), (NAN, "dt must be finite"),
                      (None, "dt must be a real number")):
        with pytest.raises(ParameterError, match=match):
            stepper.step(state, drive, dt)
    assert stepper.step(state, drive, 1e-6).state.time == pytest.approx(1e-6)


def test_law_accepts_infinite_gap_and_overflows_to_inf_quietly():
    # +inf gap: infinitely far apart, no pressure; overflow is an honest +inf, not a warning
    np.testing.assert_array_equal(LAW.pressure([INF]), [0.0])
    np.testing.assert_array_equal(vf.DoubleLayer(1e7, 1e-9).pressure([1e300, -1e300]), [0.0, INF])
    assert float(vf.DoubleLayer(1e7, 1e-9).pressure(-1e-6)) == INF
    assert PROBLEM.rigid_load(1e300) == 0.0
    assert float(vf.SoftWall(1e7, 0.5e-9).pressure(1e-300)) == INF
    with pytest.raises(ParameterError, match="gap must be > 0 for the soft wall"):
        LAW.pressure([-INF])


def test_solve_gap_still_reports_a_closed_initial_gap():
    with pytest.raises(GapClosureError, match="initial gap must be > 0"):
        solve_gap(PROBLEM, GAPS, 2e-9, -GAPS, xtol=1e-15)


# ── files ────────────────────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize("reader", [read_trace, read_prony_moduli])
@pytest.mark.parametrize("path", [None, 3.0, ["a.csv"], b"a.csv", ""],
                         ids=["None", "float", "list", "bytes", "empty"])
def test_readers_reject_non_paths(reader, path):
    with pytest.raises(ParameterError,
                       match=r"path must be a file path \(str or pathlib\.Path\), got "):
        reader(path)


@pytest.mark.parametrize("reader", [read_trace, read_prony_moduli])
def test_readers_reject_a_directory(reader, tmp_path):
    with pytest.raises(ParameterError, match="is a directory, not a CSV file"):
        reader(tmp_path)


@pytest.mark.parametrize(("reader", "text", "match"), [
    (read_trace, "time (s),position (nm)\n0,inf\n1,2\n",
     r"column 'position \(nm\)' data row 1 \(line 2\) is not a finite number"),
    (read_trace, "time (s),position (nm)\n0,1\n-inf,2\n",
     r"column 'time \(s\)' data row 2 \(line 3\) is not a finite number"),
    (read_prony_moduli, "modulus (Pa),tau (s)\ninf,1e-3\n1e9,\n",
     r"column 'modulus \(Pa\)' data row 1 \(line 2\) is not a finite number"),
    (read_prony_moduli, "modulus (Pa),tau (s)\n1e10,inf\n1e9,\n",
     r"column 'tau \(s\)' data row 1 \(line 2\) is not a finite number"),
    (read_trace, "time (s),time (ms),position (nm)\n0,0,1\n1,1000,2\n",
     r"2 columns named 'time' \(time \(s\), time \(ms\)\); keep one"),
    (read_trace, "time (s),time (s),position (nm)\n0,0,1\n1,1,2\n",
     r"2 columns named 'time'"),
], ids=["inf-position", "inf-time", "inf-modulus", "inf-tau", "two-time-units", "same-header"])
def test_readers_reject_infinite_values_and_duplicate_columns(reader, text, match, tmp_path):
    path = tmp_path / "table.csv"
    path.write_text(text)
    before = path.read_bytes()
    with pytest.raises(ParameterError, match=match):
        reader(path)
    assert path.read_bytes() == before  # loading never modifies the file


def test_describe_value_in_messages_is_short():
    with pytest.raises(ParameterError) as info:
        _create(sphere=list(range(1000)))
    assert len(str(info.value)) < 120
    assert re.search(r"got list \[0, 1, 2, 3, 4, 5, \.\.\.\]", str(info.value))


# ── lock-in, units, closed forms, SVDA ODE, plotting (probe of issue 11, second pass) ─────────

def _more_cases():
    from viscoforce import lockin, plotting, svda, units
    from viscoforce.experiments.drives import Triangle
    from viscoforce.solvers.svda_ode import solve_svda

    t = np.linspace(0.0, 4 * 2 * np.pi / 1e3, 257)
    x = np.sin(1e3 * t)
    svda_params = {"E0": 1e10, "E_inf": 1e9, "tau": 1e-3, "radius": 10e-6, "P": 1e7,
                   "debye_length": 1e-9, "t_eval": np.linspace(0.0, 2e-4, 11)}
    tri = Triangle(2e-9, -2e-9, 4e-5)
    return [
        ("demodulate-detrend-array", lambda: lockin.demodulate(x, t, 1e3, detrend=np.array([])),
         r"detrend must be None or 'linear'"),
        ("sin-phase-None", lambda: lockin.sin_phase(None), r"amplitude must be a complex number"),
        ("sin-phase-inf", lambda: lockin.sin_phase([complex(INF, 0)]), r"amplitude must be finite"),
        ("amplitude-phase-str", lambda: lockin.amplitude_phase_from_complex("1j"),
         r"amplitude must be a complex number"),
        ("unit-factor-list", lambda: units.unit_factor("length", ["nm"]),
         r"unit must be a unit string"),
        ("format-ascii-array", lambda: units.format_quantity(1.0, "length",
                                                             ascii_only=np.array([])),
         r"ascii_only must be True or False"),
        ("svda-ramp-huge-speed",
         lambda: svda.svda_ramp_deformation([0.0, 1e-4], 1e-9, 1e300, 1e10, 1e9, 1e-3, 10e-6,
                                            1e7, 1e-9), r"outside the representable range"),
        ("svda-static-complex",
         lambda: svda.svda_static_deformation(np.array([1e-9 + 0j]), 1e9, 10e-6, 1e7, 1e-9),
         r"position must be real numbers"),
        ("solve-svda-tiny-tau", lambda: solve_svda(tri, **{**svda_params, "tau": 1e-300}),
         r"outside the representable range"),
        ("solve-svda-huge-u-start", lambda: solve_svda(tri, **svda_params, u_start=1e300),
         r"u_start is outside the representable range"),
        ("bode-ax-object", lambda: plotting.bode_plot(None, ax=object()),
         r"ax must be None or a pair of matplotlib Axes"),
        ("bode-magnitude-list", lambda: plotting.bode_plot(None, magnitude=["stiffness"]),
         r"magnitude must be one of"),
    ]


_MORE = _more_cases()


@pytest.mark.parametrize(("call", "match"), [c[1:] for c in _MORE], ids=[c[0] for c in _MORE])
def test_more_bad_input_raises_parameter_error_quietly(call, match):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning or overflow RuntimeWarning either
        with pytest.raises(ParameterError, match=match):
            call()


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"mean_force": None}, "mean_force must be real numbers, got None"),
    ({"mean_force": NAN}, "mean_force must be finite; entry 0 is nan"),
    ({"attrs": "abc"}, r"attrs must be a mapping \(dict\) or None"),
    ({"dims": object()}, "dims must be a tuple or list of names"),
    ({"amplitude": np.array([])}, "amplitude must be True, False or None"),
], ids=["mean-None", "mean-nan", "attrs-str", "dims-object", "amplitude-array"])
def test_make_spectrum_bad_input_raises_schema_error(kwargs, match):
    from viscoforce.exceptions import SchemaError
    from viscoforce.schema import make_spectrum

    args = {"mean_force": 1e-7, **kwargs}
    with pytest.raises(SchemaError, match=match):
        make_spectrum([1.0, 2.0], [1 + 1j, 2 + 1j], args.pop("mean_force"), 1e-9, **args)
