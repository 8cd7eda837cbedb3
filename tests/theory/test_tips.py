"""Tip shapes (viscoforce.physics.tips) against their closed forms.

Every oracle below is written out independently of the module (Young's modulus Y and ν, Johnson's
E_star = Y/(1 − ν²), the textbook formula), so a wrong factor of 2 in the paper-E convention fails.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from viscoforce.exceptions import ParameterError
from viscoforce.physics._tip_shapes import PYRAMID_EXACT_COEFFICIENT
from viscoforce.physics.tips import (
    BILODEAU_COEFFICIENT,
    DEFAULT_POISSON,
    TIP_SHAPES,
    Cone,
    Flat,
    Paraboloid,
    Pyramid,
    Sphere,
    Tip,
    paper_from_young,
    parse_tip,
    shear_from_young,
    tip_from,
    young_from_paper,
)

R = 5e-6  # [m]
Y = 3e3  # Young's modulus [Pa]
NU = 0.5
E_STAR = Y / (1 - NU**2)  # Johnson's contact modulus [Pa]
E = paper_from_young(Y, NU)  # the paper's modulus, 2·E_star [Pa]
DELTAS = np.array([1e-9, 1e-8, 1e-7, 5e-7, 2e-6])  # [m]

ALL_TIPS = [Sphere(R), Paraboloid(R), Cone.from_degrees(20), Pyramid.from_degrees(17.5), Flat(R)]


def test_paper_modulus_is_twice_johnsons():
    assert E == pytest.approx(2 * E_STAR, rel=1e-15)
    assert E == pytest.approx(8e3, rel=1e-15)  # 2·3 kPa/(1 − 1/4)


# ── closed forms ─────────────────────────────────────────────────────────────────────────────


def test_paraboloid_is_hertz():
    tip = Paraboloid(R)
    hertz = 4 / 3 * E_STAR * math.sqrt(R) * DELTAS**1.5  # Johnson Eq. 4.23
    np.testing.assert_allclose(tip.force(DELTAS, E), hertz, rtol=1e-14, atol=0)
    np.testing.assert_allclose(tip.contact_radius(DELTAS), np.sqrt(R * DELTAS), rtol=1e-15, atol=0)
    # the contact model's √(Rδ0): k = E·√(Rδ0)
    np.testing.assert_allclose(tip.contact_stiffness_factor(DELTAS), np.sqrt(R * DELTAS),
                               rtol=1e-15, atol=0)
    # a hand value: R = 5 µm, δ = 1 µm, E_star = 4 kPa → F = (4/3)·4e3·√5e-6·1e-9 N
    assert tip.force(1e-6, E) == pytest.approx(1.1925695879998879e-08, rel=1e-14)


def test_sphere_matches_sneddon_in_contact_radius_form():
    """δ and F from Sneddon's a-form at a = R/2 and a = 0.9R (independent of the tanh path)."""
    tip = Sphere(R)
    for a in (0.5 * R, 0.9 * R, 1e-3 * R):
        log = math.log((R + a) / (R - a))
        delta = a / 2 * log
        force = E_STAR / 2 * ((a * a + R * R) * log - 2 * a * R)
        assert tip.contact_radius(delta) == pytest.approx(a, rel=1e-13)
        rtol = 1e-12 if a > 0.1 * R else 1e-6  # the a-form itself cancels at small a
        assert tip.force(delta, E) == pytest.approx(force, rel=rtol)


def test_sphere_tends_to_hertz_for_shallow_indentation():
    sphere, hertz = Sphere(R), Paraboloid(R)
    ratios = np.array([1e-6, 1e-4, 1e-3, 1e-2, 0.1, 1.0])
    rel = 1 - sphere.force(ratios * R, E) / hertz.force(ratios * R, E)
    assert rel[2] < 1e-3  # δ/R = 1e-3
    assert np.all(np.diff(rel) > 0)  # grows with δ/R
    # the series F_sphere/F_Hertz = 1 − x/10 − x²/840 + O(x³)
    small = ratios[:4]
    np.testing.assert_allclose(rel[:4], small / 10 + small**2 / 840, rtol=1e-5, atol=0)


@pytest.mark.parametrize("ratio", [1e-3, 0.3, 2.0, 10.0])
def test_sphere_force_is_the_integral_of_E_a(ratio):
    tip = Sphere(R)
    delta = ratio * R
    integral, err = quad(lambda d: tip.contact_stiffness_factor(d), 0, delta, epsabs=0,
                         epsrel=1e-12, limit=200)
    assert tip.force(delta, E) == pytest.approx(E * integral, rel=1e-6)


@pytest.mark.parametrize("tip", ALL_TIPS, ids=lambda t: t.shape)
@pytest.mark.parametrize("delta", [1e-9, 3e-8, 4e-7, 2e-6, 6e-6])
def test_stiffness_factor_is_dF_ddelta_over_E(tip, delta):
    h = 1e-4 * delta
    fd = (tip.force(delta + h, E) - tip.force(delta - h, E)) / (2 * h)
    assert tip.contact_stiffness_factor(delta) * E == pytest.approx(fd, rel=1e-7)


def test_cone_is_sneddon():
    theta = math.radians(35)
    tip = Cone(theta)
    np.testing.assert_allclose(tip.force(DELTAS, E), 2 / math.pi * E_STAR * math.tan(theta) * DELTAS**2,
                               rtol=1e-14, atol=0)
    np.testing.assert_allclose(tip.contact_radius(DELTAS), 2 * DELTAS * math.tan(theta) / math.pi,
                               rtol=1e-14, atol=0)


def test_pyramid_is_bilodeau():
    theta = math.radians(17.5)
    tip = Pyramid(theta)
    assert BILODEAU_COEFFICIENT == 0.7453
    np.testing.assert_allclose(tip.force(DELTAS, E), 0.7453 * E_STAR * math.tan(theta) * DELTAS**2,
                               rtol=1e-14, atol=0)
    np.testing.assert_allclose(tip.contact_stiffness_factor(DELTAS), 0.7453 * math.tan(theta) * DELTAS,
                               rtol=1e-14, atol=0)
    # between the inscribed (face) and circumscribed (edge) cones of the same axis
    inscribed, circumscribed = Cone(theta), Cone(math.atan(math.sqrt(2) * math.tan(theta)))
    assert inscribed.force(1e-6, E) < tip.force(1e-6, E) < circumscribed.force(1e-6, E)
    assert BILODEAU_COEFFICIENT / PYRAMID_EXACT_COEFFICIENT - 1 == pytest.approx(0.0104, abs=1e-4)


def _rigid_punch_coefficient(height, pixels):
    """C of F = C·E_star·δ² for a rigid frictionless punch of surface z = height(x, y) (δ = 1).

    Boundary elements: uniform pressure on square pixels over [−1.1, 1.1]² (Love's influence of a
    loaded rectangle, E_star = 1), the complementary energy ½pᵀKp − pᵀ(δ − z) minimised over
    p ≥ 0 (L-BFGS-B, the convolution by FFT): the contact area comes out of the solve.
    """
    from scipy.fft import irfft2, rfft2
    from scipy.optimize import minimize

    n, half = pixels, 1.1
    d = 2 * half / n
    centre = (np.arange(n) + 0.5) * d - half
    lag = np.arange(1 - n, n) * d
    x, y = np.meshgrid(lag, lag, indexing="ij")

    def corner(u, v):  # ∫∫ dξ dη / r: u ln(v + r) + v ln(u + r)
        r = np.hypot(u, v)
        with np.errstate(divide="ignore", invalid="ignore"):
            return (np.where(u != 0, u * np.log(v + r), 0.0)
                    + np.where(v != 0, v * np.log(u + r), 0.0))

    a = d / 2
    kernel = (corner(x + a, y + a) - corner(x + a, y - a) - corner(x - a, y + a)
              + corner(x - a, y - a)) / math.pi
    spectrum = rfft2(kernel, s=(2 * n, 2 * n))
    gap = (1.0 - height(*np.meshgrid(centre, centre, indexing="ij"))).ravel()

    def energy(p):
        padded = np.zeros((2 * n, 2 * n))
        padded[:n, :n] = p.reshape(n, n)
        u = irfft2(rfft2(padded) * spectrum, s=(2 * n, 2 * n))[n - 1:2 * n - 1, n - 1:2 * n - 1]
        u = u.ravel()
        return 0.5 * p @ u - p @ gap, u - gap

    fit = minimize(energy, np.maximum(gap, 0.0), jac=True, method="L-BFGS-B",
                   bounds=[(0.0, None)] * gap.size,
                   options={"maxiter": 5000, "ftol": 1e-15, "gtol": 1e-12, "maxcor": 30})
    assert fit.success
    return float(fit.x.sum()) * d * d


def test_pyramid_coefficient_against_an_exact_punch_solve():
    """Bilodeau's 0.7453 is 1.04 % above the exact pyramid (0.7376); the solver's control is the
    cone, whose 2/π it gives to 5e-5 here (measured: cone 0.63665, pyramid 0.73819 at 64 pixels
    across; 0.73767 at 240, converging from above to 0.7376)."""
    cone = _rigid_punch_coefficient(np.hypot, 64)  # z = r: tanθ = 1
    assert cone == pytest.approx(2 / math.pi, rel=2e-4)
    pyramid = _rigid_punch_coefficient(lambda x, y: np.maximum(np.abs(x), np.abs(y)), 64)
    assert PYRAMID_EXACT_COEFFICIENT < pyramid < PYRAMID_EXACT_COEFFICIENT + 1e-3
    assert BILODEAU_COEFFICIENT > 1.009 * pyramid


def test_flat_punch_is_linear():
    tip = Flat(2e-6)
    np.testing.assert_allclose(tip.force(DELTAS, E), 2 * E_STAR * 2e-6 * DELTAS, rtol=1e-15, atol=0)
    np.testing.assert_allclose(tip.contact_radius(DELTAS), 2e-6, rtol=0, atol=0)
    assert tip.contact_stiffness_factor(0.0) == 2e-6  # right-hand derivative at first contact


@pytest.mark.parametrize("tip", ALL_TIPS, ids=lambda t: t.shape)
def test_vectorised_zero_and_force_shape(tip):
    assert tip.force(0.0, E) == 0.0
    d = np.array([[0.0, 1e-8], [1e-7, 1e-6]])
    out = tip.force(d, E)
    assert out.shape == (2, 2)
    np.testing.assert_allclose(out, [[tip.force(v, E) for v in row] for row in d], rtol=1e-15)
    np.testing.assert_allclose(tip.force_shape(d), out / E, rtol=1e-15)
    assert isinstance(tip.force(1e-7, E), float)  # scalar in, scalar out
    assert np.ndim(tip.contact_radius([1e-7])) == 1


# ── input errors ─────────────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize("tip", ALL_TIPS, ids=lambda t: t.shape)
def test_bad_indentation_raises(tip):
    with pytest.raises(ParameterError, match=r"delta \(indentation\) must be >= 0 m.*entry 1 is -1e-09"):
        tip.force([1e-9, -1e-9], E)
    with pytest.raises(ParameterError, match=r"delta \(indentation\) must be finite; entry 0 is nan"):
        tip.contact_stiffness_factor([np.nan])
    with pytest.raises(ParameterError, match=r"delta \(indentation\) must be a number"):
        tip.contact_radius("1nm")
    with pytest.raises(ParameterError, match=r"E must be > 0, got -1"):
        tip.force(1e-9, -1.0)


def test_sphere_beyond_its_limit_raises():
    tip = Sphere(1e-5)
    assert tip.max_indentation == pytest.approx(18 * 1e-5)
    assert tip.contact_radius(tip.max_indentation) < tip.radius
    with pytest.raises(ParameterError, match=r"must be <= 18·R = 180 µm .* a < R.*entry 1 is 0\.00019"):
        tip.force([1e-6, 1.9e-4], E)


@pytest.mark.parametrize(("make", "match"), [
    (lambda: Sphere(0.0), r"radius must be > 0, got 0\.0"),
    (lambda: Paraboloid(-1e-6), r"radius must be > 0, got -1e-06"),
    (lambda: Flat(math.inf), r"radius must be finite, got inf"),
    (lambda: Sphere("10um"), r"radius must be a real number, got '10um'"),
    (lambda: Cone(0.0), r"half_angle must be in \(0, π/2\) rad = \(0°, 90°\), got 0\.0 rad$"),
    (lambda: Pyramid(math.pi / 2), r"half_angle must be in \(0, π/2\) rad"),
    (lambda: Cone(20), r"half_angle is in radians — for 20° use Cone\.from_degrees\(20\)"),
    (lambda: Pyramid(math.nan), r"half_angle must be finite, got nan"),
    (lambda: Cone.from_degrees(90), r"half_angle \(degree\) must be in \[0.1, 89.9\], got 90"),
    (lambda: Cone(1e-5), r"half_angle must be within the plausible range \[0.001745, 1.569\] rad "
                         r"= \[0.1°, 89.9°\], got 1e-05 rad"),
    (lambda: Sphere(2.0), r"radius must be within the plausible range \[1e-09, 1\] m .*got 2\.0 m"),
    (lambda: Flat(5e-320), r"radius must be within the plausible range \[1e-09, 1\] m"),
])
def test_bad_parameters_raise(make, match):
    with pytest.raises(ParameterError, match=match):
        make()


def test_tips_are_frozen():
    import dataclasses

    with pytest.raises(dataclasses.FrozenInstanceError):
        Sphere(R).radius = 1.0  # type: ignore[misc]
    assert Sphere(R) == Sphere(R) and Sphere(R) != Paraboloid(R)
    with pytest.raises(TypeError):
        Tip()  # type: ignore[abstract]


# ── modulus conversions ──────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize("nu", [0.0, 0.3, 0.5])
def test_modulus_round_trips(nu):
    young = np.array([1e3, 2.5e6, 7e10])
    paper = paper_from_young(young, nu)
    np.testing.assert_allclose(paper, 2 * young / (1 - nu * nu), rtol=1e-15)
    np.testing.assert_allclose(young_from_paper(paper, nu), young, rtol=1e-15)
    np.testing.assert_allclose(shear_from_young(young, nu), young / (2 * (1 + nu)), rtol=1e-15)


def test_paper_modulus_is_8_times_shear_and_8_thirds_young_at_half():
    paper = 1.2e4
    assert DEFAULT_POISSON == 0.5
    assert young_from_paper(paper) == pytest.approx(paper * 3 / 8, rel=1e-15)  # E = 2.67 Y
    assert paper / young_from_paper(paper, 0.5) == pytest.approx(2.6667, rel=1e-4)
    assert shear_from_young(young_from_paper(paper, 0.5), 0.5) == pytest.approx(paper / 8, rel=1e-15)
    assert shear_from_young(young_from_paper(paper, 0.0), 0.0) == pytest.approx(paper / 4, rel=1e-15)
    assert shear_from_young(young_from_paper(paper, 0.3), 0.3) == pytest.approx(
        paper * 0.91 / 2 / 2.6, rel=1e-15)


def test_conversions_pass_nan_and_reject_bad_values():
    out = young_from_paper([np.nan, 8.0], 0.5)
    assert np.isnan(out[0]) and out[1] == 3.0
    with pytest.raises(ParameterError, match=r"poisson must be in \[0, 0\.5\], got 0\.7"):
        young_from_paper(1e3, 0.7)
    with pytest.raises(ParameterError, match=r"poisson must be in \[0, 0\.5\], got -0\.1"):
        shear_from_young(1e3, -0.1)
    with pytest.raises(ParameterError, match=r"Y must be finite and >= 0 Pa .*entry 1 is -1\.0"):
        paper_from_young([1.0, -1.0], 0.3)
    with pytest.raises(ParameterError, match=r"E must be finite and >= 0 Pa .*entry 0 is inf"):
        young_from_paper(math.inf)


# ── text and attrs ───────────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize(("text", "expected"), [
    ("sphere:10um", Sphere(1e-5)),
    ("sphere:10µm", Sphere(1e-5)),
    ("paraboloid:2.5 µm", Paraboloid(2.5e-6)),
    ("paraboloid:1e-5m", Paraboloid(1e-5)),
    ("flat:500nm", Flat(5e-7)),
    ("  Sphere : 20nm ", Sphere(2e-8)),
    ("cone:20", Cone(math.radians(20))),
    ("cone:35°", Cone(math.radians(35))),
    ("pyramid:17.5deg", Pyramid(math.radians(17.5))),
    ("pyramid:17.5 deg", Pyramid(math.radians(17.5))),
    ("cone:0.35rad", Cone(0.35)),
])
def test_parse_tip(text, expected):
    tip = parse_tip(text)
    assert type(tip) is type(expected)
    for name in ("radius", "half_angle"):
        if hasattr(expected, name):
            assert getattr(tip, name) == pytest.approx(getattr(expected, name), rel=1e-15)


_ACCEPTED = (r"accepted: sphere:R \| paraboloid:R \| cone:ANGLE \| pyramid:ANGLE \| flat:RADIUS; "
             r"R, RADIUS: a length with its unit in \[1e-09, 1\] m, 1 nm to 1 m .*ANGLE: the "
             r"half-angle in degrees in \[0.1, 89.9\]")


@pytest.mark.parametrize(("text", "match"), [
    ("sphere", r"tip 'sphere' has no ':' between the shape and its size; write SHAPE:SIZE, one of "
               r"sphere:R \| paraboloid:R \| cone:ANGLE"),
    ("ball:10um", r"tip 'ball:10um': unknown shape 'ball' before ':' \(the shapes are sphere, "
                  r"paraboloid, cone, pyramid, flat\); " + _ACCEPTED),
    ("sphere:", r"tip 'sphere:': no radius after ':'; " + _ACCEPTED),
    ("sphere:5", r"tip 'sphere:5': the radius after ':' is wrong: '5' has no unit: a length needs "
                 r"one .*; " + _ACCEPTED),
    ("sphere:10 furlongs", r"tip 'sphere:10 furlongs': the radius after ':' is wrong: unknown "
                           r"unit 'furlongs'.*" + _ACCEPTED),
    ("sphere:10ms", r"'ms' is a unit of time.*accepted: sphere:R"),
    ("sphere:1e300m", r"the radius after ':' is wrong: radius must be within the plausible range "
                      r"\[1e-09, 1\] m .*got 1e\+300 m; " + _ACCEPTED),
    ("flat:-5um", r"tip 'flat:-5um': the radius after ':' is wrong: radius must be > 0, got -5e-06"),
    ("cone:95", r"tip 'cone:95': the half-angle after ':' is wrong: half_angle \(degree\) must be "
                r"in \[0.1, 89.9\], got 95.*" + _ACCEPTED),
    ("cone:2rad", r"half_angle \(degree\) must be in \[0.1, 89.9\], got 114\.59"),
    ("pyramid:abc", r"'abc' is not a half-angle \(a number in degrees.*" + _ACCEPTED),
    ("cone:20grad", r"'20grad' is not a half-angle"),
    ("cone:nan", r"'nan' is not a half-angle"),
])
def test_parse_tip_rejects_bad_text(text, match):
    with pytest.raises(ParameterError, match=match):
        parse_tip(text)


def test_parse_tip_rejects_non_text():
    with pytest.raises(ParameterError, match=r"tip must be text of the form .*got float 10\.0"):
        parse_tip(10.0)  # type: ignore[arg-type]


def test_tip_from():
    tip = Cone.from_degrees(20)
    assert tip_from(tip) is tip
    assert tip_from(None) is None
    assert tip_from("sphere:10um") == Sphere(1e-5)
    with pytest.raises(ParameterError, match=r"tip must be a Tip, a text such as 'sphere:10um', or None; "
                                             r"got int 5"):
        tip_from(5)  # type: ignore[arg-type]


@pytest.mark.parametrize("tip", ALL_TIPS, ids=lambda t: t.shape)
def test_attrs_round_trip(tip):
    attrs = tip.as_attrs()
    assert attrs["tip_shape"] == tip.shape and attrs["tip_shape"] in TIP_SHAPES
    assert all(isinstance(v, str | float) for v in attrs.values())  # netCDF-safe
    back = Tip.from_attrs({**attrs, "other": 1})
    assert type(back) is type(tip)
    assert type(tip).from_attrs(attrs) == back
    for name in ("radius", "half_angle"):
        if hasattr(tip, name):
            assert getattr(back, name) == pytest.approx(getattr(tip, name), rel=1e-15)
    # numpy scalars, as read from a netCDF file, work too
    assert Tip.from_attrs({k: np.float64(v) if isinstance(v, float) else v for k, v in attrs.items()})


def test_attrs_values_and_describe():
    assert Sphere(1e-5).as_attrs() == {"tip_shape": "sphere", "tip_radius": 1e-5}
    assert Cone.from_degrees(20).as_attrs()["tip_half_angle"] == pytest.approx(20.0, rel=1e-15)
    assert Sphere(1e-5).describe() == "sphere R = 10 µm"
    assert Paraboloid(2.5e-8).describe() == "paraboloid R = 25 nm"
    assert Cone.from_degrees(20).describe() == "cone half-angle = 20°"
    assert Pyramid.from_degrees(17.5).describe() == "pyramid half-angle = 17.5° (face)"
    assert Flat(5e-6).describe() == "flat punch radius = 5 µm"


@pytest.mark.parametrize(("attrs", "match"), [
    ({}, r"attrs lack 'tip_shape' \(one of sphere, paraboloid, cone, pyramid, flat\)"),
    ({"tip_shape": "ball", "tip_radius": 1.0}, r"tip_shape must be one of .*got str 'ball'"),
    ({"tip_shape": "cone", "tip_radius": 1.0}, r"tip_shape 'cone' lack 'tip_half_angle' \(\[degree\]\)"),
    ({"tip_shape": "sphere"}, r"lack 'tip_radius' \(\[m\]\)"),
    ({"tip_shape": "sphere", "tip_radius": -1.0}, r"radius must be > 0, got -1\.0"),
    ([("tip_shape", "sphere")], r"attrs must be a mapping"),
])
def test_from_attrs_rejects_bad_attrs(attrs, match):
    with pytest.raises(ParameterError, match=match):
        Tip.from_attrs(attrs)


def test_subclass_from_attrs_checks_the_shape():
    with pytest.raises(ParameterError, match=r"Cone\.from_attrs needs tip_shape 'cone', got 'sphere'"):
        Cone.from_attrs(Sphere(R).as_attrs())


# ── properties ───────────────────────────────────────────────────────────────────────────────

_lengths = st.floats(1e-9, 1e-3)
_angles = st.floats(0.5, 89.5)
_tips = st.one_of(
    st.builds(Sphere, _lengths), st.builds(Paraboloid, _lengths), st.builds(Flat, _lengths),
    st.builds(Cone.from_degrees, _angles), st.builds(Pyramid.from_degrees, _angles))


@settings(max_examples=300, deadline=None)
@given(tip=_tips, scale=st.floats(1e-9, 1e-3), lo=st.floats(1e-6, 1.0), step=st.floats(1e-6, 1.0))
def test_force_increases_and_stiffness_is_positive(tip, scale, lo, step):
    if isinstance(tip, Sphere):
        scale = min(scale, tip.max_indentation)  # deltas stay within the sphere's limit
    d1 = lo * scale / 2
    d2 = d1 * (1 + step)
    f1, f2 = tip.force([d1, d2], E)
    assert 0 < f1 < f2
    assert tip.contact_stiffness_factor(d1) > 0 and tip.contact_stiffness_factor(d2) > 0
    # mean-value check: (F2 − F1)/(δ2 − δ1) lies between E·S(δ1) and E·S(δ2) (S non-decreasing)
    slope = (f2 - f1) / (d2 - d1)
    s1, s2 = E * tip.contact_stiffness_factor(d1), E * tip.contact_stiffness_factor(d2)
    assert s1 * (1 - 1e-6) <= slope <= s2 * (1 + 1e-6)


def test_public_parameters_are_documented():
    import inspect
    import re

    funcs = [parse_tip, tip_from, young_from_paper, paper_from_young, shear_from_young, Tip.force,
             Tip.from_attrs, Cone.from_degrees]
    for func in funcs:
        doc = inspect.getdoc(func)
        for param in inspect.signature(func).parameters:
            if param in ("self", "cls"):
                continue
            assert re.search(rf"^{param} : ", doc, re.M), f"{func.__qualname__}: '{param}' undocumented"
    for cls in (Sphere, Paraboloid, Cone, Pyramid, Flat):
        doc = inspect.getdoc(cls)
        assert "Parameters\n----------" in doc and "References\n----------" in doc, cls.__name__
