"""Maps warn pixel by pixel: quality codes, p-values, identifiability, notes, coords, summary.

Truths are Hertz-contact spectra of a standard linear solid, k* = sqrt(R·δ0)/C*(ω) with the
closed-form compliance (:func:`viscoforce.closed_form.sls_complex_compliance`), with seeded
noise whose size is what the stderr columns say, so that χ² is absolute and its p-value means
what it says.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from viscoforce.closed_form import sls_complex_compliance
from viscoforce.exceptions import ParameterError
from viscoforce.fitting.identify import IDENTIFIABILITY
from viscoforce.fitting.maps import IDENTIFIABILITY_METHODS, fit_map
from viscoforce.fitting.pixels import MAP_QUALITY, map_summary, pixel_quality
from viscoforce.schema import make_curves, make_spectrum, validate_fit_result, validate_spectrum

OMEGA = np.geomspace(10.0, 1e5, 20)  # [rad/s]
RADIUS = 5e-6  # [m]
DEPTH = 50e-9  # [m]
NOISE = 0.01  # relative stiffness noise and phase noise [rad], = the stderr columns
CONTACT = {"radius": RADIUS, "indentation": DEPTH}
GOOD = {v: k for k, v in MAP_QUALITY.items()}
CODES = {v: k for k, v in IDENTIFIABILITY.items()}


def _contact(E0, E_inf, tau, depth=DEPTH):  # noqa: N803
    """k* [N/m] of Hertz contact on an SLS (tau: creep time [s])."""
    return np.sqrt(RADIUS * depth) / sls_complex_compliance(OMEGA, E0, E_inf, tau)


def _noisy(k, rng):
    return k * (1 + NOISE * rng.standard_normal(k.shape)) * np.exp(
        1j * NOISE * rng.standard_normal(k.shape))


def _spectrum(k, dims, **kw):
    return make_spectrum(OMEGA, k, 1e-7, 1e-9, dims=dims,
                         stderr={"stiffness": NOISE * np.abs(k),
                                 "phase": np.full(k.shape, np.degrees(NOISE))}, **kw)


def _grid(rng, ny=2, nx=3):
    """An SLS contact map over (y, x): E0 varies with y, tau with x."""
    k = np.empty((ny, nx, OMEGA.size), complex)
    for i in range(ny):
        for j in range(nx):
            k[i, j] = _noisy(_contact(2e6 * (1 + 0.1 * i), 5e5, 1e-3 * (1 + 0.2 * j)), rng)
    return k


def test_a_garbage_pixel_is_a_bad_fit_and_the_summary_leaves_it_out(rng):
    k = _grid(rng)
    scale = float(np.abs(k[0, 0]).mean())
    # no material gives this: a random stiffness and a random passive phase at every frequency
    k[1, 1] = rng.uniform(0.5, 2.0, OMEGA.size) * scale * np.exp(
        1j * np.radians(rng.uniform(1.0, 89.0, OMEGA.size)))
    ds = _spectrum(k, ("y", "x", "omega"))
    result = fit_map(ds, "contact", scheduler="synchronous", **CONTACT)
    validate_fit_result(result)
    quality = result["quality"].values
    assert quality.dtype == np.int8 and result["quality"].dims == ("y", "x")
    assert int(quality[1, 1]) == GOOD["bad_fit"]
    assert int(result["success"][1, 1]) == 1  # the optimiser converged: the model is wrong
    assert float(result["chi2_pvalue"][1, 1]) < 1e-3
    good = np.ones(quality.shape, bool)
    good[1, 1] = False
    np.testing.assert_array_equal(quality[good], 0)
    assert np.all(result["chi2_pvalue"].values[good] > 1e-3)
    assert result.attrs["n_good"] == 5 and result.attrs["n_failed"] == 0
    assert "bad_fit" in result.attrs["quality_rule"]
    assert result["quality"].attrs["flag_meanings"].split() == list(MAP_QUALITY.values())

    info = map_summary(result)
    json.dumps(info, allow_nan=False)  # JSON as it is: no NaN, no numpy types
    assert info["n_fits"] == 6 and info["n_good"] == 5
    assert info["left_out"] == {"optimiser_failed": 0, "bad_fit": 1, "not_determined": 0,
                                "at_bound": 0, "depth_dependent": 0}
    assert info["by_modes"]["1"]["n"] == 5 and info["modes"] == 1
    e_inf = result["E_inf"].values[good]
    assert info["params"]["E_inf"]["median"] == pytest.approx(float(np.median(e_inf)))
    assert info["params"]["tau"]["q25"] == pytest.approx(
        float(np.percentile(result["tau"].values[good], 25)))
    # the garbage pixel's own E_inf is not among what the median saw
    assert info["params"] == info["by_modes"]["1"]["params"]


def test_a_nan_point_is_left_out_and_the_pixel_is_fitted_from_the_others(rng):
    k = _grid(rng)
    k[0, 2, 7] = np.nan  # a failed lock-in point, not flagged
    ds = _spectrum(k, ("y", "x", "omega"), source="synthetic")
    result = fit_map(ds, "contact", scheduler="synchronous", **CONTACT)
    assert result.attrs["n_failed"] == 0
    assert int(result["success"][0, 2]) == 1 and int(result["quality"][0, 2]) == 0
    message = str(result["message"].values[0, 2])
    assert "1 point(s) left out" in message and f"{OMEGA[7]:.4g}" in message
    assert "left out" not in str(result["message"].values[0, 1])
    keep = np.arange(OMEGA.size) != 7
    alone = fit_map(ds.isel(y=[0], x=[2], omega=keep), "contact", scheduler="synchronous",
                    **CONTACT)
    for name in ("E0", "E_inf", "tau"):
        assert float(result[name][0, 2]) == pytest.approx(float(alone[name][0, 0]), rel=1e-9)


def test_every_spectrum_variable_broadcasts(rng):
    """Per-pixel mean force and indentation, a scalar drive: the same fits as per point."""
    k = _grid(rng)
    ny, nx = k.shape[:2]
    depth = DEPTH * (1 + 0.5 * np.arange(ny * nx).reshape(ny, nx))  # each pixel its own depth
    k = k * np.sqrt(depth / DEPTH)[..., None]
    shape = k.shape
    full = make_spectrum(OMEGA, k, np.full(shape, 1e-7), np.full(shape, 1e-9),
                         dims=("y", "x", "omega"), mean_indentation=depth[..., None],
                         quality=np.zeros(shape, dtype=int),
                         stderr={"stiffness": NOISE * np.abs(k),
                                 "phase": np.full(shape, np.degrees(NOISE))})
    assert full["mean_indentation"].dims == ("y", "x", "omega")
    assert full["drive_amplitude"].dims == ("y", "x", "omega")
    bare = full.assign(
        mean_force=full["mean_force"].isel(omega=0, drop=True),
        mean_indentation=full["mean_indentation"].isel(omega=0, drop=True),
        drive_amplitude=full["drive_amplitude"].isel(y=0, x=0, omega=0, drop=True),
        phase_stderr=full["phase_stderr"].isel(y=0, x=0, omega=0, drop=True),
        quality=full["quality"].isel(y=0, x=0, drop=True))
    assert bare["mean_force"].dims == ("y", "x") and bare["drive_amplitude"].dims == ()
    assert bare["quality"].dims == ("omega",) and bare["phase_stderr"].dims == ()
    validate_spectrum(bare)
    one = fit_map(full, "contact", scheduler="synchronous", radius=RADIUS)
    two = fit_map(bare, "contact", scheduler="synchronous", radius=RADIUS)
    assert one.attrs["n_good"] == ny * nx
    for name in ("E0", "E_inf", "tau", "E0_stderr", "chi2_pvalue"):
        np.testing.assert_allclose(two[name].values, one[name].values, rtol=1e-12, atol=0)
    # the pixels' own depths were used: E_inf scales as 1/sqrt(depth) of a wrong depth
    np.testing.assert_allclose(one["E_inf"].values, 5e5, rtol=0.05)


def test_a_scalar_mean_force_validates_and_fits(rng):
    k = _grid(rng)
    ds = _spectrum(k, ("y", "x", "omega"))
    ds = ds.assign(mean_force=ds["mean_force"].isel(y=0, x=0, omega=0, drop=True))
    validate_spectrum(ds)
    result = fit_map(ds, "contact", scheduler="synchronous", **CONTACT)
    assert result.attrs["n_good"] == 6


def test_a_mean_force_over_a_dim_the_spectrum_lacks_is_refused(rng):
    from viscoforce.exceptions import SchemaError

    ds = _spectrum(_grid(rng), ("y", "x", "omega"))
    odd = ds.assign(mean_force=xr.DataArray(np.ones(2), dims=("z",), attrs={"units": "N"}))
    with pytest.raises(SchemaError, match=r"'mean_force' must have dims within \('y', 'x', "
                                          r"'omega'\), got \('z',\)"):
        validate_spectrum(odd)


def test_the_map_keeps_x_and_y_of_a_curve_spectrum(rng):
    k = np.stack([_noisy(_contact(2e6, 5e5, 1e-3 * (1 + 0.3 * i)), rng) for i in range(3)])
    x = np.array([0.0, 1e-6, 2e-6])
    y = np.array([5e-6, 5e-6, 6e-6])
    ds = _spectrum(k, ("curve", "omega"), coords={
        "x": ("curve", x), "y": ("curve", y), "curve": ("curve", [10, 11, 12]),
        "frequency": ("omega", OMEGA / (2 * np.pi))})
    result = fit_map(ds, "contact", scheduler="synchronous", **CONTACT)
    np.testing.assert_array_equal(result["x"].values, x)
    np.testing.assert_array_equal(result["y"].values, y)
    assert result["x"].dims == ("curve",) and result["x"].attrs["units"] == "m"
    assert result["curve"].values.tolist() == [10, 11, 12]
    assert "frequency" not in result.variables  # over omega: not a map coordinate
    assert "x" in result.coords


def _curves(rng, taus, x, y):
    """Curves of an approach (20 samples) and a relaxing hold (300 samples) each."""
    times, forces, segments, counts = [], [], [], []
    for tau in taus:
        t_app = np.linspace(0.0, 0.1, 20, endpoint=False)
        t_hold = 0.1 + np.linspace(0.0, 3.0, 300)
        f_app = np.linspace(0.0, 5e-8, 20)
        f_hold = 1e-8 + 4e-8 * np.exp(-(t_hold - t_hold[0]) / tau)
        f_hold = f_hold + 1e-11 * rng.standard_normal(t_hold.size)
        times.append(np.concatenate([t_app, t_hold]))
        forces.append(np.concatenate([f_app, f_hold]))
        segments.append(np.repeat([0, 1], [20, 300]))
        counts.append(320)
    force = np.concatenate(forces)
    return make_curves(np.concatenate(times), force, np.zeros_like(force), force / 0.1,
                       segment=np.concatenate(segments), segment_names=("approach", "pause"),
                       sample_count=counts, per_curve={"x": x, "y": y})


def test_a_relaxation_map_keeps_the_coords_over_curve(rng):
    x, y = np.array([0.0, 2e-6]), np.array([1e-6, 1e-6])
    curves = _curves(rng, (0.3, 0.6), x, y)
    result = fit_map(curves, "relaxation", scheduler="synchronous")
    assert result["tau_1"].dims == ("curve",)
    np.testing.assert_allclose(result["tau_1"].values, [0.3, 0.6], rtol=1e-2)
    np.testing.assert_array_equal(result["x"].values, x)
    np.testing.assert_array_equal(result["y"].values, y)
    assert "time" not in result.variables and "segment_name" not in result.variables
    # unweighted curves: no p-value, so no pixel can be a bad fit
    assert np.all(np.isnan(result["chi2_pvalue"].values))


def test_profile_flags_a_one_sided_modulus(rng):
    """Creep time 1 µs, data up to 1e5 rad/s: the glassy plateau is above the window.

    The loss there fixes only τ(1/E_inf − 1/E0), so E0 → ∞ (with τ adjusting) fits as well:
    the profile likelihood bounds E0 from below only, and the pixel is not_determined.
    """
    k = np.stack([_noisy(_contact(2e6, 5e5, 1e-6), rng), _noisy(_contact(2e6, 5e5, 1e-3), rng)])
    ds = _spectrum(k, ("curve", "omega"))
    result = fit_map(ds, "contact", scheduler="synchronous", identifiability="profile",
                     **CONTACT)
    validate_fit_result(result)
    assert result.attrs["identifiability_method"].startswith("profile")
    codes = result["identifiability"]
    assert codes.dims == ("curve", "param_i") and codes.dtype == np.int8
    assert int(codes.sel(curve=0, param_i="E0")) == CODES["lower_bound_only"]
    assert np.isfinite(float(result["E0_lower"][0])) and np.isnan(float(result["E0_upper"][0]))
    assert int(result["quality"][0]) == GOOD["not_determined"]
    # the well-sampled pixel: every parameter bounded on both sides, a good pixel
    np.testing.assert_array_equal(codes.sel(curve=1).values, 0)
    assert int(result["quality"][1]) == GOOD["good"]
    assert float(result["E0_lower"][1]) < float(result["E0"][1]) < float(result["E0_upper"][1])
    assert map_summary(result)["left_out"]["not_determined"] == 1


def test_local_identifiability_is_the_default_and_adds_no_limits(rng):
    ds = _spectrum(np.stack([_noisy(_contact(2e6, 5e5, 1e-3), rng)]), ("curve", "omega"))
    result = fit_map(ds, "contact", scheduler="synchronous", **CONTACT)
    assert result.attrs["identifiability_method"].startswith("local")
    assert "E0_lower" not in result.variables
    np.testing.assert_array_equal(result["identifiability"].values, 0)


@pytest.mark.parametrize("value", ["global", "Profile", None, True, 1])
def test_an_unknown_identifiability_option_is_refused(rng, value):
    ds = _spectrum(np.stack([_contact(2e6, 5e5, 1e-3)]), ("curve", "omega"))
    with pytest.raises(ParameterError,
                       match=r"identifiability must be one of 'local', 'profile', got "):
        fit_map(ds, "contact", scheduler="synchronous", identifiability=value, **CONTACT)
    assert IDENTIFIABILITY_METHODS == ("local", "profile")


def _pixel(**kw):
    base = {"names": ["E0", "tau"], "values": {"E0": 1.0, "tau": 1.0},
            "stderr": {"E0": 0.1, "tau": 0.1}, "success": True, "chi2_pvalue": 0.5,
            "identifiability": {"E0": 0, "tau": 0}, "at_bound": []}
    return {**base, **kw}


@pytest.mark.parametrize(("pixel", "expected"), [
    ({"success": False, "message": "no data"}, "optimiser_failed"),
    (_pixel(success=False, chi2_pvalue=0.0, identifiability={"E0": 3, "tau": 3}),
     "optimiser_failed"),
    (_pixel(chi2_pvalue=1e-5, identifiability={"E0": 1, "tau": 0}, at_bound=["tau"]),
     "bad_fit"),
    (_pixel(chi2_pvalue=float("nan"), identifiability={"E0": 1, "tau": 3}, at_bound=["tau"]),
     "not_determined"),
    (_pixel(identifiability={"E0": 0, "tau": 3}, at_bound=["tau"]), "at_bound"),
    (_pixel(identifiability={"E0": 0, "tau": 0}, at_bound=["tau"]), "at_bound"),
    (_pixel(chi2_pvalue=2e-3), "good"),
    (_pixel(stderr={"E0": 2.0, "tau": 0.1}, identifiability=None), "not_determined"),
])
def test_quality_precedence(pixel, expected):
    if pixel.get("identifiability", 0) is None:  # an old-style result: the local test
        pixel = {k: v for k, v in pixel.items() if k != "identifiability"}
    assert pixel_quality(pixel) == GOOD[expected]


def test_map_summary_counts_modes_and_handles_no_good_pixel():
    names = ["E_inf", "tau_1", "tau_2"]
    values = {"E_inf": [1.0, 2.0, 3.0, 4.0], "tau_1": [0.1, 0.2, 0.3, 0.4],
              "tau_2": [np.nan, np.nan, 5.0, np.nan]}
    ds = xr.Dataset({n: ("curve", v) for n, v in values.items()} | {
        "quality": ("curve", np.array([0, 0, 0, 1], dtype=np.int8)),
        "modes": ("curve", np.array([1, 1, 2, 0], dtype=np.int32))},
        coords={"param_i": names}, attrs={"model": "relaxation"})
    info = map_summary(ds)
    json.dumps(info, allow_nan=False)
    assert info["by_modes"]["1"]["n"] == 2 and info["by_modes"]["2"]["n"] == 1
    assert set(info["by_modes"]["1"]["params"]) == {"E_inf", "tau_1"}
    assert info["by_modes"]["2"]["params"]["tau_2"]["median"] == 5.0
    assert info["modes"] == 1 and info["params"]["E_inf"]["median"] == 1.5
    assert info["left_out"]["optimiser_failed"] == 1
    none = map_summary(ds.assign(quality=ds["quality"] * 0 + 2))
    assert none["n_good"] == 0 and none["modes"] is None
    assert none["params"]["E_inf"] == {"median": None, "q25": None, "q75": None}
    assert none["by_modes"]["1"]["params"]["E_inf"]["median"] is None


def test_map_summary_refuses_what_is_not_a_map_result():
    with pytest.raises(ParameterError, match="map_summary needs what fit_map returns"):
        map_summary(xr.Dataset({"tau": 1.0}))
    with pytest.raises(ParameterError, match="got dict"):
        map_summary({"quality": 0})


def test_the_map_result_with_its_flags_survives_netcdf(rng, tmp_path):
    ds = _spectrum(np.stack([_noisy(_contact(2e6, 5e5, 1e-3), rng),
                             _noisy(_contact(2e6, 5e5, 1e-6), rng)]), ("curve", "omega"),
                   coords={"x": ("curve", [0.0, 1e-6])})
    result = fit_map(ds, "contact", scheduler="synchronous", identifiability="profile",
                     **CONTACT)
    path = tmp_path / "map.nc"
    result.to_netcdf(path, engine="h5netcdf")
    with xr.open_dataset(path, engine="h5netcdf") as opened:
        back = opened.load()
    validate_fit_result(back)
    assert back["quality"].dtype == np.int8 and back["identifiability"].dtype == np.int8
    np.testing.assert_array_equal(back["quality"].values, result["quality"].values)
    np.testing.assert_array_equal(back["x"].values, [0.0, 1e-6])


def test_pixels_of_different_layouts_put_each_value_and_correlation_under_its_name():
    """assemble_map over pixels fitted with 1 and 2 modes (modes="auto"): the union of the
    names, in order of first appearance; each pixel's values, stderr and correlations under
    its own names, NaN elsewhere; a pixel with the map's full layout takes its rows as they are."""
    from viscoforce.fitting.pixels import assemble_map

    one = ["E0", "E_inf", "tau"]
    two = ["E0", "E_1", "E_inf", "tau_1", "tau_2"]

    def pixel(names, seed):
        corr = np.eye(len(names))
        corr[0, -1] = corr[-1, 0] = 0.1 * seed
        return {"names": names, "values": {n: float(seed + j) for j, n in enumerate(names)},
                "stderr": {n: 0.01 * (seed + j) for j, n in enumerate(names)},
                "identifiability": dict.fromkeys(names, 0), "correlation": corr,
                "redchi": 1.0, "aic": 0.0, "bic": 0.0, "chi2_pvalue": 0.5, "success": True,
                "modes": 1 if names == one else 2, "message": "ok"}

    results = [pixel(one, 1), pixel(two, 2), pixel(one + ["E_1", "tau_1", "tau_2"], 3)]
    ds = assemble_map(results, ("curve",), {"shape": {"curve": 3}, "coords": {}}, "prony", None,
                      3)
    names = [str(n) for n in ds["param_i"].values]
    assert names == ["E0", "E_inf", "tau", "E_1", "tau_1", "tau_2"]
    for i, r in enumerate(results):
        for n in names:
            want = r["values"].get(n, np.nan)
            np.testing.assert_equal(float(ds[n][i]), want)
            np.testing.assert_equal(float(ds[f"{n}_stderr"][i]), r["stderr"].get(n, np.nan))
        corr = ds["correlation"].values[i]
        own = [names.index(n) for n in r["names"]]
        np.testing.assert_array_equal(corr[np.ix_(own, own)], r["correlation"])
        others = [j for j in range(len(names)) if j not in own]
        assert np.isnan(corr[others]).all() and np.isnan(corr[:, others]).all()


# ── hertz maps run the single fit's depth check per pixel (issue 37 item 6b) ────────────────────

E_PAPER = 3.0e3  # [Pa], the paper's E = 2 E*


def _hertz_approach(shape, rng, *, noise=30e-12, slope=0.0, n=1200, contact=1.8e-6):
    """Tip position z [m] and F [N]: F = E·shape(δ) on a baseline, white noise [N]."""
    z = np.linspace(-1.0e-6, 2.6e-6, n)
    f = -5e-9 + slope * (z - contact) + E_PAPER * shape(np.maximum(z - contact, 0.0))
    return z, f + rng.normal(0.0, noise, n)


def _paraboloid(d):
    """Hertz's paraboloid (R = 5 µm): F/E = (2/3)√R δ^1.5, E* = E/2 (Johnson 1985)."""
    return 2 / 3 * np.sqrt(5e-6) * d ** 1.5


def _cone(d):
    """Sneddon's 20° cone: F/E = tan(20°) δ²/π, E* = E/2 (Sneddon 1965)."""
    return 1 / np.pi * np.tan(np.radians(20.0)) * d ** 2


def test_a_hertz_map_flags_the_pixels_whose_single_fit_warns_that_e_depends_on_depth(rng):
    """Two approaches, both fitted with a paraboloid tip: a paraboloid's (good) and a cone's.

    The cone's δ² curve is not the paraboloid's δ^1.5 law: its single fit warns that E depends
    on the depth (GoodnessOfFitWarning). Before issue 37 the map ran no depth check and called
    that pixel good (quality 0); now it is ``depth_dependent`` with the single fit's shift. The
    untilted baseline (slope 0) leaves both pixels' baseline_slope determined (item 6d: before,
    a slope within its stderr of 0 made the pixel not_determined).
    """
    import warnings

    from viscoforce.exceptions import GoodnessOfFitWarning
    from viscoforce.fitting.curves import fit_curve

    tip = "paraboloid:5um"
    curves = [_hertz_approach(_paraboloid, rng), _hertz_approach(_cone, rng)]
    z = np.concatenate([c[0] for c in curves])
    f = np.concatenate([c[1] for c in curves])
    n = curves[0][0].size
    ds = make_curves(np.tile(np.linspace(0, 1, n), 2), f, -z, np.zeros_like(z), tip_position=z,
                     segment=0, segment_names=("approach",), sample_count=[n] * 2,
                     source="synthetic")
    result = fit_map(ds, "hertz", tip=tip, scheduler="synchronous", progress=False)
    validate_fit_result(result)
    assert result["quality"].values.tolist() == [GOOD["good"], GOOD["depth_dependent"]]
    assert "depth_dependent" in result.attrs["quality_rule"]
    assert "E depends on the indentation depth" in str(result["message"].values[1])
    assert map_summary(result)["left_out"]["depth_dependent"] == 1
    shifts = result["depth_check_shift"].values
    for i, (zi, fi) in enumerate(curves):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            single = fit_curve(make_curves(np.linspace(0, 1, n), fi, -zi, np.zeros_like(zi),
                                           tip_position=zi, segment=0,
                                           segment_names=("approach",), source="synthetic"),
                               "hertz", tip=tip)
        depth = [w for w in caught if issubclass(w.category, GoodnessOfFitWarning)
                 and "E depends on the indentation depth" in str(w.message)]
        assert bool(depth) == (i == 1)
        assert shifts[i] == pytest.approx(single.attrs["depth_check_shift"], rel=1e-6)
        assert result["depth_check_relative"].values[i] == pytest.approx(
            single.attrs["depth_check_relative"], rel=1e-6)
    assert abs(shifts[0]) < 2 < abs(shifts[1])
    codes = result["identifiability"].sel(param_i="baseline_slope").values
    assert codes.tolist() == [CODES["determined"]] * 2


def test_the_depth_code_comes_after_a_failed_or_bad_fit_and_before_not_determined():
    base = {"names": ["E"], "success": True, "values": {"E": 1.0}, "stderr": {"E": 0.1},
            "identifiability": {"E": 0}, "at_bound": []}
    assert pixel_quality({**base, "depth_dependent": True}) == GOOD["depth_dependent"]
    assert pixel_quality({**base, "depth_dependent": False}) == GOOD["good"]
    assert pixel_quality({**base, "depth_dependent": True,
                          "chi2_pvalue": 1e-6}) == GOOD["bad_fit"]
    assert pixel_quality({**base, "depth_dependent": True,
                          "identifiability": {"E": 3}}) == GOOD["depth_dependent"]
