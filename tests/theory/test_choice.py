"""The chooser (issue 15 item 3): ``method="auto"``, ``stepper="auto"``, ``model="auto"``.

Each scene of the speed–accuracy study is run through the chooser and the result is compared with
an independent converged reference: the choice must meet the accuracy it promises, and where it
rejected a cheaper method that method must indeed miss the accuracy (so the estimates are not
merely conservative by accident). Tolerances are the requested accuracies, never tuned.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

import viscoforce as vf
from viscoforce import PAPER
from viscoforce.choice import (
    ACCURACY_RANGE,
    amplitude_error,
    choose_simulation,
    require_accuracy,
)
from viscoforce.cli import main
from viscoforce.exceptions import ModelValidityWarning, ParameterError
from viscoforce.experiments.choice import choose_spectrum
from viscoforce.experiments.drives import Step, Triangle
from viscoforce.experiments.finite_amplitude import amplitude_bias
from viscoforce.experiments.linear_response import linear_stiffness
from viscoforce.fitting import fit_spectrum
from viscoforce.schema import make_spectrum

ACCURACY = 1e-3
OMEGA = np.geomspace(0.1 / PAPER.tau, 100 / PAPER.tau, 3)  # the study's range, 3 points


def sls():
    return vf.StandardLinearSolid(E0=PAPER.E0, E_inf=PAPER.E_inf, tau=PAPER.tau)


def problem(deepest, law=None, material=None, factor=1.0):
    kw = dict(sphere=vf.Sphere(PAPER.R), surface_force=law or vf.paper_pressure_law(),
              material=material or sls(), deepest_position=deepest)
    spacing = None
    if factor != 1.0:
        grid = vf.ContactProblem.create(**kw).grid
        spacing = factor * grid.outer_radius / grid.size
    return vf.ContactProblem.create(**kw, grid_spacing=spacing)


def k_of(ds):
    return ds.stiffness.values * np.exp(1j * np.radians(ds.phase.values))


def rel(a, b):
    return float(np.max(np.abs(a / b - 1.0)))


# ── spectra ──────────────────────────────────────────────────────────────────────────────────────

#: The frequency of the largest finite-amplitude bias (ω = 20/τ, studies/validity_maps/validity_maps.py).
OMEGA_BIAS = np.array([20.0 / PAPER.tau])


def _finer(p, h0, eta, omega):
    """Time-domain spectrum at 0.1 x the default tol: 1.2e-5 from converged (study, Fig. 4)."""
    return vf.spectrum(p, h0, eta, omega, method="time-domain", tol=1e-6 * eta, progress=False)


def test_fig3_auto_is_linear_and_meets_the_accuracy_against_a_finer_time_domain():
    p = problem(2e-9 - 0.1e-9)
    auto = vf.spectrum(p, 2e-9, 0.1e-9, OMEGA_BIAS, method="auto", progress=False)
    assert auto.attrs["method"] == "linear"  # κη = 0.1: harmonic-balance bias 5.5e-4 x 1.1
    assert rel(k_of(auto), k_of(_finer(p, 2e-9, 0.1e-9, OMEGA_BIAS))) <= ACCURACY


def test_contact_small_eta_auto_is_linear_and_meets_the_accuracy():
    p = problem(-5e-9 - 0.02e-9)
    auto = vf.spectrum(p, -5e-9, 0.02e-9, OMEGA_BIAS, method="auto")
    assert auto.attrs["method"] == "linear"
    assert "harmonic balance" in auto.attrs["explanation"]
    reference = vf.spectrum(p, -5e-9, 0.02e-9, OMEGA_BIAS, method="time-domain", progress=False)
    assert rel(k_of(auto), k_of(reference)) <= ACCURACY


def test_contact_bias_above_the_rigid_estimate_is_caught():
    # at -5 nm the measured bias at κη = 0.1 is 3.5e-3, 2.8x (κη)²/8: linear must be refused
    p = problem(-5e-9 - 0.06e-9)
    assert choose_spectrum(p, -5e-9, 0.06e-9, OMEGA_BIAS).method == "time-domain"


def test_fig4_auto_simulates_and_linear_would_miss():
    p = problem(-6e-9)
    omega = OMEGA_BIAS
    choice = choose_spectrum(p, -5e-9, 1e-9, omega)
    assert choice.method == "time-domain"
    with pytest.warns(ModelValidityWarning, match=r"kappa\*eta = 1"):
        linear = vf.spectrum(p, -5e-9, 1e-9, omega, method="linear")
    auto = vf.spectrum(p, -5e-9, 1e-9, omega, method="auto", progress=False)
    assert auto.attrs["method"] == "time-domain"
    finer = _finer(p, -5e-9, 1e-9, omega)
    assert rel(k_of(auto), k_of(finer)) <= ACCURACY
    assert rel(k_of(linear), k_of(finer)) > 0.01  # the rejected route does miss (and warns)


@pytest.mark.parametrize("h0", [10e-9, 12e-9])
def test_precontact_auto_is_svda_and_meets_the_accuracy(h0):
    p = problem(h0)
    auto = vf.spectrum(p, h0, 0.01e-9, OMEGA, method="auto")
    assert auto.attrs["method"] == "svda"
    exact, _ = linear_stiffness(problem(h0, factor=0.5), h0, OMEGA)
    assert rel(k_of(auto), exact) <= ACCURACY


def test_svda_rejected_at_4nm_where_it_misses():
    p = problem(4e-9)
    choice = choose_spectrum(p, 4e-9, 0.01e-9, OMEGA)
    assert choice.method == "linear"
    with pytest.warns(ModelValidityWarning, match="the SVDA is about"):
        svda = vf.spectrum(p, 4e-9, 0.01e-9, OMEGA, method="svda")
    exact, _ = linear_stiffness(p, 4e-9, OMEGA)
    assert rel(k_of(svda), exact) > 0.01


def test_deep_indentation_auto_is_contact_at_a_loose_accuracy():
    law = vf.SumOfLaws((vf.DoubleLayer(P=1e7, debye_length=0.1e-9),
                        vf.SoftWall(Pw=1e7, z0=0.05e-9)))
    omega = np.geomspace(1.0, 50.0, 3)  # ωτ ≤ 0.05: the relaxed end, |E*| ≈ E_inf
    p = problem(-100e-9, law=law)
    auto = vf.spectrum(p, -100e-9, 0.002e-9, omega, method="auto", accuracy=1e-2)
    assert auto.attrs["method"] == "contact"
    exact, _ = linear_stiffness(p, -100e-9, omega)
    assert rel(k_of(auto), exact) <= 1e-2
    strict = choose_spectrum(p, -100e-9, 0.002e-9, omega)  # 1e-3: Hertz is not adequate
    assert strict.method == "linear"


def test_amplitude_bias_is_the_rigid_bessel_limit_for_a_stiff_solid():
    stiff = vf.StandardLinearSolid(E0=1e17, E_inf=1e16, tau=PAPER.tau)  # no deformation
    p = problem(5e-9, law=vf.DoubleLayer(P=PAPER.P, debye_length=1e-9), material=stiff)
    b = amplitude_bias(p, 5e-9, OMEGA)
    np.testing.assert_allclose(b, 1 / (8 * (1e-9) ** 2), rtol=1e-5)  # (κη)²/8, κ = 1/nm


@pytest.mark.parametrize(("h0", "eta", "measured"), [(2e-9, 0.1e-9, 5.5e-4),
                                                      (-5e-9, 0.1e-9, 3.5e-3)])
def test_amplitude_bias_matches_the_measured_lockin_bias(h0, eta, measured):
    # measured: linear vs time-domain lock-in at ω = 20/τ (studies/validity_maps/validity_maps.py); the
    # harmonic balance's leading term, 1.00x (Fig. 3) and 1.05x (-5 nm) of it
    p = problem(h0 - eta)
    bias = float(np.abs(amplitude_bias(p, h0, OMEGA_BIAS)[0])) * eta ** 2
    assert bias == pytest.approx(measured, rel=0.1)


def test_amplitude_error_is_the_bessel_series():
    x = 0.3
    assert amplitude_error(x * 1e-9, 1e-9) == pytest.approx(
        x ** 2 / 8 + x ** 4 / 192 + x ** 6 / 9216, rel=1e-6)


# ── simulations ──────────────────────────────────────────────────────────────────────────────────

@pytest.fixture(scope="module")
def scene_runs():
    """Scene → (problem, drive, t_end, output times, converged reference): the reference (step
    tolerance 1e-3 × 1e-5 κ⁻¹) is run once per scene for both accuracies (never modified)."""
    cache = {}

    def get(scene):
        if scene not in cache:
            drive = (Step(-5e-9, -7e-9, 1e-4) if scene == "Fig. 1 step"
                     else Triangle(10e-9, -10e-9, 5e-6))
            p = problem(float(drive.extent()[0]))
            t_end = float(drive.duration) + 5 * PAPER.tau
            t = np.linspace(0.0, t_end, 81)
            reference = vf.simulate(p, drive, t_eval=t, t_end=t_end,
                                    tol=1e-3 * 1e-5 * PAPER.debye_length)
            cache[scene] = (p, drive, t_end, t, reference)
        return cache[scene]

    return get


@pytest.mark.parametrize("accuracy", [1e-3, 1e-4])
@pytest.mark.parametrize("scene", ["Fig. 1 step", "Fig. 5 loop"])
def test_stepper_auto_meets_the_accuracy(scene_runs, scene, accuracy):
    p, drive, t_end, t, reference = scene_runs(scene)
    auto = vf.simulate(p, drive, t_eval=t, t_end=t_end, stepper="auto", accuracy=accuracy)
    assert auto.attrs["stepper"] == "exponential"
    assert "exponential is the cheapest stepper" in auto.attrs["explanation"]
    force = np.interp(t, auto.time.values, auto.force.values)
    ref = np.interp(t, reference.time.values, reference.force.values)
    assert np.max(np.abs(force - ref)) / np.max(np.abs(ref)) <= accuracy


def test_stepper_choice_loosens_tol_for_a_loose_accuracy():
    p = problem(-7e-9)
    loose, tight = (choose_simulation(p, Step(-5e-9, -7e-9, 1e-4), accuracy=a)
                    for a in (1e-2, 1e-4))
    assert loose.options["tol"] > tight.options["tol"]
    assert loose.estimated_error <= 1e-2 and tight.estimated_error <= 1e-4


# ── fits ─────────────────────────────────────────────────────────────────────────────────────────

def _spectrum(h0, omega=None):
    omega = np.geomspace(1e1, 1e6, 30) if omega is None else omega
    k, mean = linear_stiffness(problem(min(h0, -1e-9)), h0, omega)
    return make_spectrum(omega, k, np.full(omega.size, mean), 1e-12)


@pytest.mark.parametrize("h0", [10e-9, -5e-9])
def test_fit_auto_meets_the_accuracy_on_the_moduli(h0):
    spec = _spectrum(h0)
    guess = problem(min(h0, -1e-9), material=vf.StandardLinearSolid(E0=3e9, E_inf=5e8, tau=3e-3))
    fit = fit_spectrum(spec, "auto", problem=guess, position=h0, weights="relative")
    truth = {"E0": PAPER.E0, "E_inf": PAPER.E_inf, "tau": PAPER.tau}
    assert max(abs(float(fit[n]) / v - 1) for n, v in truth.items()) <= ACCURACY
    assert fit.attrs["model"] == "exact"
    assert fit.attrs["estimated_model_error"] <= ACCURACY


def test_fit_auto_rejects_svda_where_its_moduli_are_biased():
    spec = _spectrum(10e-9)
    with pytest.warns(ModelValidityWarning, match="the fitted moduli are biased"):
        svda = fit_spectrum(spec, "svda", position=10e-9, radius=PAPER.R, P=PAPER.P,
                            debye_length=PAPER.debye_length, weights="relative")
    bias = abs(float(svda["E_inf"]) / PAPER.E_inf - 1)
    assert 0.1 < svda.attrs["estimated_model_error"] and 0.1 < bias  # 0.30 estimated, 0.41 real
    guess = problem(-1e-9)
    fit = fit_spectrum(spec, "auto", problem=guess, position=10e-9, weights="relative")
    assert "svda" in fit.attrs["explanation"] and "too inaccurate" in fit.attrs["explanation"]
    assert bias > ACCURACY  # the rejected model is indeed biased (41 % measured)


def test_contact_fit_with_a_debye_length_warns_where_hertz_is_off():
    spec = _spectrum(-15e-9)
    with pytest.warns(ModelValidityWarning, match="Hertz contact is about"):
        fit = fit_spectrum(spec, "contact", radius=PAPER.R, indentation=15e-9,
                           debye_length=PAPER.debye_length, weights="relative")
    truth = abs(float(fit["E_inf"]) / PAPER.E_inf - 1)
    assert truth > 0.01 and fit.attrs["estimated_model_error"] > 0.01  # 26 % measured


# ── bad input ────────────────────────────────────────────────────────────────────────────────────

@pytest.mark.parametrize("bad", [0.0, 1e-5, 0.5, math.nan, "1e-3", True])
def test_accuracy_out_of_range_is_refused(bad):
    with pytest.raises(ParameterError, match=r"accuracy must be a number in \[0.0001, 0.1\]"):
        require_accuracy(bad)
    assert ACCURACY_RANGE == (1e-4, 0.1)


def test_auto_options_that_conflict_are_refused():
    p = problem(-7e-9)
    with pytest.raises(TypeError, match="method 'auto' chooses tol itself"):
        vf.spectrum(p, -5e-9, 1e-9, OMEGA, method="auto", tol=1e-15)
    with pytest.raises(ParameterError, match="stepper='auto' chooses"):
        vf.simulate(p, Step(-5e-9, -7e-9, 1e-4), stepper="auto", tol=1e-12)
    with pytest.raises(ParameterError, match="accuracy applies to stepper 'auto' only"):
        vf.simulate(p, Step(-5e-9, -7e-9, 1e-4), accuracy=1e-3)
    with pytest.raises(ParameterError, match="accuracy applies to method 'auto' only"):
        vf.spectrum(p, -5e-9, 1e-11, OMEGA, method="linear", accuracy=1e-3)
    with pytest.raises(ParameterError, match="model 'auto' needs problem"):
        fit_spectrum(_spectrum(-5e-9), "auto", position=-5e-9)


# ── CLI ──────────────────────────────────────────────────────────────────────────────────────────

def _json(capsys, argv):
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)


def test_cli_auto_reports_the_explanation(capsys, tmp_path):
    out = _json(capsys, ["spectrum", "--h0", "10nm", "--eta", "0.01nm", "--omega", "100rad/s",
                         "--method", "auto", "--json"])
    assert out["method"] == "svda" and "svda is the cheapest" in out["explanation"]
    assert out["estimated_error"] <= ACCURACY
    out = _json(capsys, ["simulate", "--drive", "step", "--from=-5nm", "--to", "-6nm",
                         "--method", "auto", "--accuracy", "1e-2", "--json"])
    assert out["settings"]["stepper"] == "exponential" and "accuracy 0.01" in out["explanation"]
    path = tmp_path / "spectrum.nc"
    _spectrum(-5e-9).to_netcdf(path)
    out = _json(capsys, ["fit", str(path), "--model", "auto", "--h0=-5nm", "--json"])
    assert out["model"] == "exact" and "exact is the cheapest fit model" in out["explanation"]


def test_cli_linear_at_large_eta_warns_in_the_note(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = _json(capsys, ["spectrum", "--h0=-5nm", "--eta", "1nm", "--omega", "2e4rad/s",
                             "--json"])
    assert "kappa*eta = 1" in out["note"] and "time-domain" in out["note"]


def test_deep_auto_coarsens_the_grid_within_its_budget():
    law = vf.SumOfLaws((vf.DoubleLayer(P=1e7, debye_length=0.1e-9),
                        vf.SoftWall(Pw=1e7, z0=0.05e-9)))
    material = vf.StandardLinearSolid(E0=3e9, E_inf=1e9, tau=PAPER.tau)
    p = problem(-100e-9 - 0.01e-9, law=law, material=material)
    choice = choose_spectrum(p, -100e-9, 0.01e-9, OMEGA)
    assert choice.method == "linear" and choice.options == {"grid_factor": 2.0}
    auto = vf.spectrum(p, -100e-9, 0.01e-9, OMEGA, method="auto")
    assert int(auto.attrs["n_panels"]) < p.grid.n_panels
    exact, _ = linear_stiffness(p, -100e-9, OMEGA)  # the default grid: 9e-10 from converged
    assert rel(k_of(auto), exact) <= 0.1 * ACCURACY  # the grid's share of the budget
