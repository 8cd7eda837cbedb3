"""identifiability="auto": the profile likelihood where the curvature can mislead, ±2σ elsewhere.

The quadratic limits are checked against the profile's own on well-determined fits (they must
agree to within 10 % of each limit's distance from the value), the trigger rule on constructed
inputs, and the one-sided case must still be profiled and reported as a bound.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from viscoforce import PAPER
from viscoforce.closed_form import structural_complex_modulus
from viscoforce.exceptions import ParameterError
from viscoforce.fitting import _params
from viscoforce.fitting.fit import fit_spectrum
from viscoforce.fitting.identify import (
    QUADRATIC_CORRELATION,
    QUADRATIC_DECADES,
    needs_profile,
    quadratic_limits,
)
from viscoforce.physics.materials import StandardLinearSolid
from viscoforce.schema import make_spectrum
from viscoforce.svda import svda_complex_stiffness

R, DEPTH = 5e-6, 500e-9
OMEGA = 2 * np.pi * np.geomspace(0.3, 1000.0, 12)
LAYOUT = [_params.Chain(("E_inf", "E0")), _params.Chain(("tau",)), _params.Signed("offset")]


def _spectrum(k, omega, noise, seed):
    rng = np.random.default_rng(seed)
    data = k * (1 + noise * rng.standard_normal(k.shape)) * np.exp(
        1j * noise * rng.standard_normal(k.shape))
    err = {"stiffness": noise * np.abs(k), "phase": np.full(k.shape, np.degrees(noise))}
    return make_spectrum(omega, data, np.full(k.shape, 1e-9), 1e-8, stderr=err,
                         mean_indentation=np.full(k.shape, DEPTH))


def _fit(*args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fit_spectrum(*args, **kwargs)


def _structural():
    k = math.sqrt(R * DEPTH) * structural_complex_modulus(OMEGA, 1e3, 0.15, 0.5, 1.0)
    return _spectrum(k, OMEGA, 0.01, 3), {"radius": R, "indentation": DEPTH,
                                          "material": "structural"}


def _svda():
    omega = np.geomspace(10.0, 1e6, 20)
    with warnings.catch_warnings():  # the SVDA's own validity warning: not the subject here
        warnings.simplefilter("ignore")
        k = svda_complex_stiffness(omega, 2e-9, 1e10, 1e9, 1e-3, PAPER.R, PAPER.P,
                                   PAPER.debye_length)
    fixed = {"position": 2e-9, "radius": PAPER.R, "P": PAPER.P,
             "debye_length": PAPER.debye_length}
    return _spectrum(k, omega, 0.01, 4), fixed


@pytest.mark.parametrize("case", [_structural, _svda], ids=["structural", "svda"])
def test_quadratic_limits_agree_with_the_profile_where_auto_skips_it(case):
    ds_in, fixed = case()
    model = "svda" if "position" in fixed else "contact"
    auto = _fit(ds_in, model, **fixed)
    full = _fit(ds_in, model, identifiability="profile", **fixed)
    skipped = [str(n) for n, p in zip(auto["param_i"].values, auto["profiled"].values,
                                      strict=True) if not p]
    assert skipped, "the case must exercise the quadratic limits"
    assert full["profiled"].values.all()
    for n in skipped:
        value = float(auto[n])
        for side in ("lower", "upper"):
            quad = abs(float(auto[f"{n}_{side}"]) - value)
            prof = abs(float(full[f"{n}_{side}"]) - value)
            assert quad == pytest.approx(prof, rel=0.10), (n, side)
        assert int(auto["identifiability"].sel(param_i=n)) == int(
            full["identifiability"].sel(param_i=n)) == 0
    assert "curvature" in auto.attrs["identifiability_method"]
    assert full.attrs["identifiability_method"] == "profile likelihood (2 sigma)"


def test_auto_still_profiles_a_one_sided_modulus_and_reports_a_bound():
    truth = StandardLinearSolid(1e5, 1e3, 1e-5)
    k = math.sqrt(R * DEPTH) / truth.complex_compliance(OMEGA)
    ds = _fit(_spectrum(k, OMEGA, 0.02, 6), "contact", radius=R, indentation=DEPTH)
    profiled = dict(zip(ds["param_i"].values, ds["profiled"].values, strict=True))
    assert profiled["E0"] == 1
    assert int(ds["identifiability"].sel(param_i="E0")) == 1
    assert math.isnan(float(ds["E0_upper"])) and float(ds["E0_lower"]) < 1e5


def test_local_gives_no_limits_and_a_bad_choice_names_the_options():
    ds_in, fixed = _structural()
    local = _fit(ds_in, "contact", identifiability="local", **fixed)
    assert "E_ref_lower" not in local and "profiled" not in local
    with pytest.raises(ParameterError, match="identifiability must be one of 'auto'"):
        fit_spectrum(ds_in, "contact", identifiability="maybe", **fixed)


def _corr(rho):
    c = np.eye(4)
    c[0, 1] = c[1, 0] = rho
    return c


@pytest.mark.parametrize(("stderr", "rho", "at_bound", "expected"), [
    # all narrow, weakly correlated: nothing to profile
    ({"E_inf": 1e7, "E0": 1e8, "tau": 1e-5, "offset": 0.05}, 0.5, [], []),
    # E0's 2σ wider than QUADRATIC_DECADES
    ({"E_inf": 1e7, "E0": 2e9, "tau": 1e-5, "offset": 0.05}, 0.5, [], ["E0"]),
    # stderr above the value, none, or at a bound: the local test's doubts
    ({"E_inf": 1e7, "E0": 1e8, "tau": 2e-3, "offset": None}, 0.5, ["E_inf"],
     ["E_inf", "tau", "offset"]),
    # a strongly correlated pair: both
    ({"E_inf": 1e7, "E0": 1e8, "tau": 1e-5, "offset": 0.05}, 0.99, [], ["E_inf", "E0"]),
])
def test_the_trigger_rule(stderr, rho, at_bound, expected):
    values = {"E_inf": 1e9, "E0": 1e10, "tau": 1e-3, "offset": -0.2}
    assert needs_profile(LAYOUT, values, stderr, _corr(rho), at_bound) == expected
    assert QUADRATIC_CORRELATION < 0.99


def test_quadratic_limits_are_two_sigma_in_log10_for_positive_parameters():
    values = {"E_inf": 1e9, "offset": -0.2}
    out = quadratic_limits(LAYOUT, values, {"E_inf": 1e8, "offset": 0.1}, ["E_inf", "offset"])
    width = 2 * 1e8 / (1e9 * math.log(10))
    assert width < 2 * QUADRATIC_DECADES
    assert out["E_inf"].lower == pytest.approx(1e9 * 10 ** -width, rel=1e-12)
    assert out["E_inf"].upper == pytest.approx(1e9 * 10 ** width, rel=1e-12)
    assert (out["offset"].lower, out["offset"].upper) == pytest.approx((-0.4, 0.0))
    assert out["E_inf"].code == out["offset"].code == 0


def test_the_cli_takes_identifiability_for_one_spectrum(tmp_path):
    from viscoforce.cli import main

    ds_in, _ = _structural()
    path = tmp_path / "spectrum.nc"
    ds_in.to_netcdf(path)
    out = tmp_path / "fit.nc"
    code = main(["fit", str(path), "--model", "contact", "--R", "5um", "--indentation", "500nm",
                 "--material", "structural", "--identifiability", "profile", "--out", str(out)])
    assert code == 0
    import xarray as xr

    with xr.open_dataset(out) as fit:
        assert fit["profiled"].values.all()
        assert fit.attrs["identifiability_method"] == "profile likelihood (2 sigma)"
