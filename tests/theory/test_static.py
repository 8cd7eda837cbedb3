"""Static elastic equilibrium: paper values, an independent FFT peer, grid convergence, errors."""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import xarray as xr

import viscoforce as vf
from tests.conftest import REFERENCE_DIR
from viscoforce.exceptions import ModelValidityError, ModelValidityWarning
from viscoforce.problem import HALF_SPACE_WARNING, check_half_space
from viscoforce.solvers.newton import solve_gap

#: The FFT peer's table, copied into the repository (tests/data/README.md says where from).
PEER_CSV = Path(__file__).resolve().parents[1] / "data" / "static_loads_fft_peer.csv"
PEER_SHA256 = "a6656f9dc23c5dc2e75da47e8d753cd78507edc299e455df7618356dd6c771a1"

PAPER_STATIC = [  # (h0 [m], load [N] as printed, absolute tolerance = half the last printed digit)
    (-7e-9, 1.59e-6, 0.005e-6),
    (-5e-9, 1.08e-6, 0.005e-6),
    (-3e-9, 0.66e-6, 0.005e-6),
    (2e-9, 61.0e-9, 0.05e-9),
]


@pytest.mark.parametrize(("h0", "load", "tol"), PAPER_STATIC)
def test_paper_static_loads(make_problem, h0, load, tol):
    """Paper Fig. 1 / Fig. 3 / Fig. 4 statics with E_inf = 1e9 Pa (printed to 3 digits)."""
    ds = vf.static_equilibrium(make_problem(vf.Elastic(1e9), h0), h0)
    assert float(ds.force) == pytest.approx(load, abs=tol)


def test_paper_mean_deformation_at_2nm(make_problem):
    ds = vf.static_equilibrium(make_problem(vf.Elastic(1e9), 2e-9), 2e-9)
    assert float(ds.u_center) == pytest.approx(-0.46e-9, abs=0.005e-9)
    assert float(ds.h_center) == pytest.approx(2e-9 - float(ds.u_center), rel=1e-15)


def _peer_rows():
    df = pd.read_csv(PEER_CSV)
    return [tuple(row) for row in df.itertuples(index=False)]


def test_fft_peer_copy_is_complete_and_matches_shared_source():
    """The copy in tests/data is the shared file byte for byte (checked whenever it is present)."""
    assert hashlib.sha256(PEER_CSV.read_bytes()).hexdigest() == PEER_SHA256
    assert len(_peer_rows()) == 16
    source = REFERENCE_DIR / "static_loads_fft_peer.csv"
    if source.exists():
        assert source.read_bytes() == PEER_CSV.read_bytes()


@pytest.mark.parametrize("row", _peer_rows())
def test_against_independent_fft_peer(make_problem, row):
    """3-D FFT half-space + energy minimisation (ContactMechanics/Adhesion), README: ~1e-4.

    Measured agreement of the load: 1.3e-7 … 2.3e-5 relative over all 16 rows.
    """
    E, h0, force, _h_center, u_center, _dx, _chg = row
    ds = vf.static_equilibrium(make_problem(vf.Elastic(E), h0), h0)
    assert float(ds.force) == pytest.approx(force, rel=1e-4)
    assert float(ds.u_center) == pytest.approx(u_center, rel=1e-4, abs=1e-13)


@pytest.mark.parametrize("E", [1e9, 1e10])
def test_default_grid_within_1e4_of_4x_refined_grid(make_problem, E):
    """Issue 2 item 6. Measured worst case: 1.6e-7 (E = 1e10 Pa, h0 = -10 nm)."""
    worst = 0.0
    for h0 in np.linspace(-10e-9, 10e-9, 9):
        coarse = make_problem(vf.Elastic(E), h0)
        fine = make_problem(vf.Elastic(E), h0, grid_spacing=coarse.grid.spacing / 4)
        f_c = float(vf.static_equilibrium(coarse, h0).force)
        f_f = float(vf.static_equilibrium(fine, h0).force)
        worst = max(worst, abs(f_c - f_f) / abs(f_f))
    assert worst < 1e-4


def test_load_increases_and_softer_body_carries_less(make_problem):
    h0s = [-6e-9, -4e-9, -2e-9, 0.0, 2e-9]
    soft = [float(vf.static_equilibrium(make_problem(vf.Elastic(1e9), -6e-9), h).force)
            for h in h0s]
    stiff = [float(vf.static_equilibrium(make_problem(vf.Elastic(1e10), -6e-9), h).force)
             for h in h0s]
    assert np.all(np.diff(soft) < 0) and np.all(np.diff(stiff) < 0)
    assert np.all(np.array(soft) < np.array(stiff))


def test_far_apart_limit_is_rigid_derjaguin(make_problem):
    """At 10 nm the deformation is negligible: load → 2πR P/κ e^{-κ h0} (exact for a paraboloid)."""
    ds = vf.static_equilibrium(make_problem(vf.Elastic(1e10), 10e-9), 10e-9)
    assert float(ds.force) == pytest.approx(float(ds.force_rigid), rel=1e-5)
    derjaguin = 2 * np.pi * 10e-6 * 1e7 * 1e-9 * np.exp(-10)
    assert float(ds.force_rigid) == pytest.approx(derjaguin, rel=1e-6)


def test_contact_radius_grows_with_depth_and_matches_profile(make_problem):
    pr = make_problem(vf.Elastic(1e9), -7e-9)
    radii = [float(vf.static_equilibrium(pr, h).contact_radius) for h in (1e-9, -3e-9, -7e-9)]
    assert radii[0] < radii[1] < radii[2]
    ds = vf.static_equilibrium(pr, -5e-9)
    a = float(ds.contact_radius)
    h_at_a = pr.grid.interpolate(ds.gap.values, a)[0]
    assert h_at_a == pytest.approx(1e-9, rel=1e-6)
    assert float(ds.contact_radius) > 0 and float(ds.gap.max()) > 1e-9


def test_dataset_units_attrs_and_netcdf_round_trip(make_problem, tmp_path):
    ds = vf.static_equilibrium(make_problem(vf.Elastic(1e9), -5e-9), -5e-9)
    for name in ("gap", "deformation", "pressure", "force", "u_center", "contact_radius"):
        assert "units" in ds[name].attrs and "long_name" in ds[name].attrs
    assert ds.attrs["E"] == 1e9 and ds.attrs["radius"] == 10e-6
    assert ds.attrs["debye_length"] == 1e-9 and ds.attrs["newton_iterations"] > 0
    path = tmp_path / "static.nc"
    ds.to_netcdf(path, engine="scipy")
    with xr.open_dataset(path, engine="scipy") as back:
        assert back.load().identical(ds)


def test_rigid_load_infinite_when_undeformed_bodies_overlap(make_problem):
    pr = make_problem(vf.Elastic(1e9), -5e-9)
    assert pr.rigid_load(-1e-9) == np.inf
    assert np.isfinite(pr.rigid_load(1e-9))


def test_static_uses_relaxed_modulus_of_viscoelastic_material(make_problem):
    sls = vf.StandardLinearSolid(E0=1e10, E_inf=1e9, tau=1e-3)
    a = vf.static_equilibrium(make_problem(sls, -5e-9), -5e-9)
    b = vf.static_equilibrium(make_problem(vf.Elastic(1e9), -5e-9), -5e-9)
    assert float(a.force) == pytest.approx(float(b.force), rel=1e-14)
    c = vf.static_equilibrium(make_problem(sls, -5e-9), -5e-9, modulus=1e10)
    assert float(c.force) > 5 * float(a.force)


def test_bad_inputs_raise_named_errors(make_problem):
    pr = make_problem(vf.Elastic(1e9), -5e-9)
    with pytest.raises(vf.ParameterError, match="position \\(h0\\) must be finite"):
        vf.static_equilibrium(pr, float("nan"))
    with pytest.raises(vf.ParameterError, match="modulus \\(E\\) must be > 0"):
        vf.static_equilibrium(pr, -5e-9, modulus=-1.0)
    with pytest.raises(vf.ParameterError, match="contact_threshold must be > 0"):
        vf.static_equilibrium(pr, -5e-9, contact_threshold=0.0)
    with pytest.raises(vf.ParameterError, match="outer_radius .* is too small for position"):
        vf.static_equilibrium(pr, -20e-9)
    with pytest.raises(vf.ParameterError, match="E must be > 0"):
        vf.Elastic(0.0)
    with pytest.raises(vf.ParameterError, match="material must be a ViscoelasticMaterial"):
        vf.ContactProblem(pr.sphere, pr.surface_force, "soft", pr.grid)


def test_newton_non_convergence_raises_not_nan(make_problem):
    pr = make_problem(vf.Elastic(1e10), -10e-9)
    base = pr.undeformed_gap(-10e-9)
    with pytest.raises(vf.ConvergenceError, match="did not converge in 2 iterations") as info:
        solve_gap(pr, base, 2 / 1e10, np.maximum(base, 1e-9), xtol=1e-18, max_iter=2)
    assert info.value.iterations == 2 and np.isfinite(info.value.residual_norm)
    with pytest.raises(vf.GapClosureError, match="initial gap must be > 0"):
        solve_gap(pr, base, 2 / 1e10, base, xtol=1e-18)


def test_gap_that_cannot_stay_open_raises_gap_closure(make_problem):
    """A double layer without a wall cannot hold a stiff sphere at -20 nm."""
    law = vf.DoubleLayer(1e5, 1e-9)
    pr = vf.ContactProblem.create(sphere=vf.Sphere(10e-6), surface_force=law,
                                  material=vf.Elastic(1e10), deepest_position=-20e-9)
    with pytest.raises(vf.GapClosureError, match="the gap closes"):
        vf.static_equilibrium(pr, -20e-9)


def test_contact_radius_when_only_the_centre_is_below_threshold():
    from viscoforce.problem import contact_radius

    grid = vf.RadialGrid(1e-6, 4, 8)
    gaps = np.full(grid.size, 1.0001e-9)
    a = contact_radius(grid, gaps, 0.9999e-9, 1e-9)
    assert 0.0 <= a < grid.r[0]
    assert contact_radius(grid, gaps, 1.0001e-9, 1e-9) == 0.0


# ── half-space validity ──────────────────────────────────────────────────────────────────────

R_PAPER = vf.PAPER.R


@pytest.mark.parametrize("E", [1e9, 1e10])
def test_paper_deepest_statics_are_well_inside_the_half_space_model(make_problem, E):
    """h0 = −10 nm: measured a/R = 0.030 (1e9 Pa), 0.036 (1e10 Pa); |u(0)|/R = 0.0011, 0.0010."""
    ds = vf.static_equilibrium(make_problem(vf.Elastic(E), -10e-9), -10e-9)
    a_ratio, u_ratio = check_half_space(R_PAPER, float(ds.u_center), float(ds.contact_radius))
    assert 0.02 < a_ratio < 0.04 < HALF_SPACE_WARNING["contact_radius"] / 2
    assert 5e-4 < u_ratio < 1.2e-3 < HALF_SPACE_WARNING["deformation"] / 5


def test_paper_fig5_loop_is_well_inside_the_half_space_model(make_problem):
    """Triangle 10 → −10 → 10 nm at 5 µm/s: measured max a/R = 0.034, max |u(0)|/R = 0.0011."""
    from viscoforce.experiments.drives import Triangle
    from viscoforce.solvers.simulate import simulate

    sls = vf.StandardLinearSolid(E0=1e10, E_inf=1e9, tau=1e-3)
    ds = simulate(make_problem(sls, -10e-9), Triangle(10e-9, -10e-9, 5e-6), progress=False)
    a_ratio, u_ratio = check_half_space(R_PAPER, ds.u_center.values, ds.contact_radius.values)
    assert a_ratio < 0.04 and u_ratio < 1.2e-3


def test_unit_slip_debye_length_of_one_metre_is_refused():
    """The issue's defect: --debye-length 1m gave u(0) = −158 µm and a = 4.5 mm on R = 10 µm."""
    law = vf.DoubleLayer(1e7, 1.0) + vf.SoftWall(1e7, 0.5e-9)
    pr = vf.ContactProblem.create(sphere=vf.Sphere(R_PAPER), surface_force=law,
                                  material=vf.Elastic(1e9), deepest_position=-5e-9)
    with pytest.raises(ModelValidityError,
                       match=r"outside the model at h0 = -5 nm: the contact radius a = 4\.\d+ mm = "
                             r"4\d\d R \(limit 0\.5 R\) and the central deformation \|u\(0\)\| = "
                             r"1\d\d µm = 1\d\.\d R \(limit 0\.1 R\); the half-space \(small-slope\) "
                             r"model assumes deformations and contact radii small against the "
                             r"sphere radius R = 10 µm"):
        vf.static_equilibrium(pr, -5e-9)


@pytest.mark.parametrize(("u_center", "a", "outcome", "match"), [
    (-1e-8, 3e-7, None, None),
    (-0.01 * R_PAPER, 0.1 * R_PAPER, None, None),  # exactly at the warning levels: accepted
    (-0.011 * R_PAPER, 0.0, "warn", r"\|u\(0\)\| = 110 nm = 0\.011 R \(warning above 0\.01 R\)"),
    (0.0, 0.2 * R_PAPER, "warn", r"a = 2 µm = 0\.2 R \(warning above 0\.1 R\)"),
    (+0.05 * R_PAPER, 0.0, "warn", r"\|u\(0\)\| = 500 nm = 0\.05 R"),  # the sign does not matter
    (-0.1 * R_PAPER, 0.5 * R_PAPER, "warn", r"a = 5 µm = 0\.5 R .* \|u\(0\)\| = 1 µm = 0\.1 R"),
    (-0.2 * R_PAPER, 0.0, "error", r"\|u\(0\)\| = 2 µm = 0\.2 R \(limit 0\.1 R\)"),
    (0.0, 0.6 * R_PAPER, "error", r"the contact radius a = 6 µm = 0\.6 R \(limit 0\.5 R\)"),
], ids=["paper", "at-warning-levels", "warn-u", "warn-a", "warn-u-positive", "at-error-levels",
        "error-u", "error-a"])
def test_half_space_thresholds(u_center, a, outcome, match):
    if outcome is None:
        check_half_space(R_PAPER, u_center, a)
    elif outcome == "warn":
        with pytest.warns(ModelValidityWarning, match=match):
            check_half_space(R_PAPER, u_center, a)
    else:
        with pytest.raises(ModelValidityError, match=match):
            check_half_space(R_PAPER, u_center, a)


def test_half_space_check_takes_the_worst_of_arrays_and_names_the_context():
    u = np.array([0.0, -1e-9, -2e-6, -1e-9])
    a = np.array([0.0, 1e-7, 2e-6, 0.0])
    with pytest.raises(ModelValidityError, match=r"at t = 1\.5 ms: the central deformation "
                                                 r"\|u\(0\)\| = 2 µm = 0\.2 R"):
        check_half_space(R_PAPER, u, a, where="at t = 1.5 ms")
    assert check_half_space(R_PAPER, u[:2], a[:2]) == pytest.approx((0.01, 1e-4))
    assert check_half_space(R_PAPER, [], []) == (0.0, 0.0)
    assert issubclass(ModelValidityError, vf.ViscoforceError)
    assert issubclass(ModelValidityError, ValueError)
    assert issubclass(ModelValidityWarning, UserWarning)


@pytest.mark.parametrize(("args", "match"), [
    ((0.0, 0.0, 0.0), r"radius \(R\) must be > 0"),
    ((None, 0.0, 0.0), r"radius \(R\) must be a real number"),
    ((R_PAPER, float("nan"), 0.0), r"deformation must be finite"),
    ((R_PAPER, 0.0, -1e-9), r"contact_radius must be >= 0 m"),
    ((R_PAPER, 0.0, [1e-9, float("inf")]), r"contact_radius must be finite; entry 1 is inf"),
    ((R_PAPER, "1 nm", 0.0), r"deformation must be a number or an array of real numbers"),
])
def test_half_space_check_validates_its_input(args, match):
    with pytest.raises(vf.ParameterError, match=match):
        check_half_space(*args)


@pytest.mark.parametrize(("f", "lo", "hi"), [
    (lambda x: math.cos(3 * x) + 0.3 * x**3 - 0.2, 0.0, 1.0),
    (lambda x: x**9 - 1e-3, 0.0, 2.0),  # flat on one side: Illinois must not stall
    (lambda x: math.tanh(50 * (x - 0.3)), 0.0, 1.0),
    (lambda x: x - 0.5, 0.0, 1.0),
])
def test_bracketed_root_matches_brentq(f, lo, hi):
    from scipy.optimize import brentq

    from viscoforce.problem import _bracketed_root

    expected = brentq(f, lo, hi, xtol=1e-14)
    assert _bracketed_root(f, lo, hi, f(lo), f(hi), xtol=1e-12) == pytest.approx(expected, abs=2e-12)
