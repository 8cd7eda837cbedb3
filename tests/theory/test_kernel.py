"""The product-integration half-space operator against closed forms (paper Eq. 2)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import i0e

from viscoforce import kernel
from viscoforce.exceptions import ParameterError
from viscoforce.radial_grid import RadialGrid

E = 1e9  # paper convention: 2/E = sum (1 - nu^2)/E_i, so E = 2 E* (Johnson)
P0 = 1e7


def hertz_displacement(r, a):
    """Johnson (3.41)/(3.42) for p = p0 sqrt(1 - r^2/a^2), rewritten with E* = E/2."""
    r = np.asarray(r, dtype=float)
    out = np.empty_like(r)
    inside = r <= a
    out[inside] = -np.pi * P0 * (2 * a * a - r[inside] ** 2) / (2 * a * E)
    ro = r[~inside]
    out[~inside] = -(P0 / (a * E)) * ((2 * a * a - ro**2) * np.arcsin(a / ro)
                                      + a * np.sqrt(ro**2 - a * a))
    return out


def hertz_error(n_panels_inside, order, a=200e-9):
    grid = RadialGrid(2 * a, 2 * n_panels_inside, order)  # a panel edge sits at r = a
    r = grid.r
    p = np.where(r < a, P0 * np.sqrt(np.clip(1 - (r / a) ** 2, 0, None)), 0.0)
    u = -(2 / E) * kernel.influence_matrix(grid) @ p
    exact = hertz_displacement(r, a)
    return np.max(np.abs(u - exact)) / np.max(np.abs(exact))


def test_hertz_pressure_gives_hertz_displacement_with_measured_order():
    """Hertz pressure: the sqrt edge singularity limits the interpolant to order 1.5.

    Measured (order-8 panels, 2 → 32 panels inside the contact): errors 2.4e-4, 9.5e-5, 3.7e-5,
    1.4e-5, 5.3e-6, i.e. order 1.37 → 1.40, approaching the theoretical 1.5.
    """
    errors = [hertz_error(n, 8) for n in (4, 8, 16)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert errors[-1] < 2e-5
    assert np.all(orders > 1.3) and np.all(orders < 1.6)


def test_hertz_central_displacement_is_exact_limit():
    """u(0) = -pi p0 a / E in the paper's convention (E = 2E*): checks the factor 2."""
    a = 200e-9
    grid = RadialGrid(2 * a, 32, 8)
    p = np.where(grid.r < a, P0 * np.sqrt(np.clip(1 - (grid.r / a) ** 2, 0, None)), 0.0)
    u0 = -(2 / E) * kernel.center_row(grid) @ p
    assert u0 == pytest.approx(-np.pi * P0 * a / E, rel=1e-5)


def gaussian_error(n_panels, order, b=100e-9):
    """p = p0 exp(-r^2/b^2) → u = -(2 sqrt(pi) p0 b / E) e^{-x} I0(x), x = r^2 / 2b^2."""
    grid = RadialGrid(7 * b, n_panels, order)
    u = -(2 / E) * kernel.influence_matrix(grid) @ (P0 * np.exp(-(grid.r / b) ** 2))
    exact = -(2 * np.sqrt(np.pi) * P0 * b / E) * i0e(grid.r**2 / (2 * b * b))
    return np.max(np.abs(u - exact)) / np.max(np.abs(exact))


def test_gaussian_pressure_converges_at_the_interpolation_order():
    """Smooth pressure: error O(w^q) for q nodes per panel.

    Measured with q = 4: 9.2e-4, 4.3e-5, 2.6e-6, 9.2e-8 for 4 → 32 panels (order 4.1 – 4.8).
    """
    errors = [gaussian_error(n, 4) for n in (8, 16, 32)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 3.8)
    assert errors[-1] < 2e-7


def test_gaussian_pressure_default_order_is_near_machine_precision():
    """q = 8, 16 panels over 7b: measured 9.6e-12."""
    assert gaussian_error(16, 8) < 1e-10


@pytest.mark.parametrize("target_index", [0, 7, 8, 21, 39])
def test_rows_match_adaptive_quadrature(target_index):
    """Independent check of the singular integration against scipy.integrate.quad."""
    grid = RadialGrid(1.0, 5, 8)

    def p(s):
        return np.exp(-3 * s**2) * (1 + s)

    r = grid.r[target_index]

    def f(s):
        return kernel.kernel_times_s(r, s) * p(s)

    ref = (quad(f, 0, r, limit=200, epsabs=0, epsrel=1e-13)[0]
           + quad(f, r, 1, limit=200, epsabs=0, epsrel=1e-13)[0])
    got = kernel.influence_matrix(grid)[target_index] @ p(grid.r)
    assert got == pytest.approx(ref, rel=1e-10)


def test_matrix_scales_with_panel_width_and_arbitrary_rows_agree():
    g1, g2 = RadialGrid(1.0, 6, 8), RadialGrid(3e-7, 6, 8)
    np.testing.assert_allclose(kernel.influence_matrix(g2), 3e-7 * kernel.influence_matrix(g1),
                               rtol=1e-14)
    rows = kernel.influence_rows(g1, g1.r[[3, 30]])
    np.testing.assert_allclose(rows, kernel.influence_matrix(g1)[[3, 30]], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(kernel.influence_rows(g1, [0.0])[0], kernel.center_row(g1),
                               rtol=1e-12)


def test_grid_quadrature_and_interpolation():
    g = RadialGrid(2.0, 4, 8)
    # 2 pi int_0^2 r^3 r dr = 2 pi 32/5
    assert g.integrate_area(g.r**3) == pytest.approx(2 * np.pi * 32 / 5, rel=1e-14)
    x = np.linspace(0, 2, 17)
    np.testing.assert_allclose(g.interpolate(np.cos(g.r), x), np.cos(x), atol=1e-7)


def test_grid_validation():
    with pytest.raises(ParameterError, match="outer_radius must be > 0"):
        RadialGrid(-1.0, 4)
    with pytest.raises(ParameterError, match="n_panels must be an integer >= 1"):
        RadialGrid(1.0, 0)
    with pytest.raises(ParameterError, match=r"order must be in \[2, 30\]"):
        RadialGrid(1.0, 4, 40)
    with pytest.raises(ParameterError, match="grid_spacing must be <= outer_radius"):
        RadialGrid.from_spacing(1e-7, 1e-6)
    with pytest.raises(ParameterError, match="r must lie in"):
        RadialGrid(1.0, 2).interpolate(np.zeros(16), [2.0])
