"""Reference solve: a rigid frictionless punch on an elastic layer on a rigid base (own numerics).

The check of :mod:`viscoforce.physics.bottom_effect` against an independent solution, not a copy
of any published series. Only numpy and scipy.

Formulation (the classical Lebedev–Ufliand / Hayes et al. 1972 route, written out here)
---------------------------------------------------------------------------------------
A layer of thickness h (Poisson's ratio ν, Johnson's contact modulus E_star = E_Y/(1 − ν²)) lies on
a rigid base, either bonded to it (no slip) or on it without friction. Its frictionless top surface
carries an axisymmetric pressure p(r) with Hankel transform p̂(ξ) = ∫ p(r) r J0(ξr) dr. The surface
deflection is

    w(r) = (2/E_star) ∫0^∞ p̂(ξ) L(ξh) J0(ξr) dξ,

L = 1 for the half-space (Boussinesq). The plane-strain layer functions (derived from Navier's
equations, checked symbolically while writing this; κ = 3 − 4ν) are

    bonded:        L(u) = (2κ sinh 2u − 4u) / (2κ cosh 2u + 1 + κ² + 4u²)
    frictionless:  L(u) = (cosh 2u − 1) / (sinh 2u + 2u)          (independent of ν)

and M = 1 − L decays like u² e^{−2u}. With the representation p̂(ξ) = ∫0^a φ(t) cos(ξt) dt over the
contact radius a, Abel inversion of w(r) = δ − f(r) on r < a gives the Fredholm equation of the
second kind (lengths in units of h)

    φ(t) − (1/π) ∫0^a [k(t − s) + k(t + s)] φ(s) ds = (E_star/π) g(t),    k(x) = ∫0^∞ M(u) cos(ux) du,

with g(t) = δ − t²/R (paraboloid), δ − (π/2) t cot θ (cone), δ (flat punch), and the load
P = 2π ∫0^a φ(t) dt. A smooth punch has bounded pressure at the edge: φ(a) = 0, which fixes δ for a
given a. The kernel is smooth, so a Gauss–Legendre Nyström method converges exponentially; k(x) is
evaluated by composite Gauss–Legendre quadrature in u. For k ≡ 0 this returns Hertz, Sneddon's
cone and Boussinesq's punch exactly.

The contact stiffness needs no differentiation: for a smooth punch the pressure vanishes at the
edge, so dP/dδ equals the stiffness of a flat punch of the current contact radius a on the same
layer, 2·E_star·a·G_flat(a/h) (checked here against finite differences).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.polynomial.legendre import leggauss
from scipy.integrate import quad
from scipy.interpolate import CubicSpline

#: Upper end of the u-quadrature of k(x): M(24) < 1e-17 for both boundary conditions.
U_MAX = 24.0


def layer_m(u, poisson: float, bonded: bool):
    """M(u) = 1 − L(u) of the layer, written without cancellation (u ≥ 0, any size below ~350)."""
    u = np.asarray(u, dtype=float)
    if bonded:
        k = 3.0 - 4.0 * poisson
        num = 2.0 * k * np.exp(-2.0 * u) + 1.0 + k * k + 4.0 * u * u + 4.0 * u
        return num / (2.0 * k * np.cosh(2.0 * u) + 1.0 + k * k + 4.0 * u * u)
    small = u < 1e-3
    us = np.where(small, 1.0, u)
    big = (-np.expm1(-2.0 * us) + 2.0 * us) / (np.sinh(2.0 * us) + 2.0 * us)
    return np.where(small, 1.0 - u / 2.0, big)


def kernel_moment(poisson: float, bonded: bool, power: int = 0) -> float:
    """∫0^∞ u^power M(u) du by adaptive quadrature (I0 gives the first-order bottom effect)."""
    value, _ = quad(lambda u: u**power * float(layer_m(u, poisson, bonded)), 0.0, 60.0,
                    epsabs=1e-14, epsrel=1e-13, limit=400)
    return value


@dataclass(frozen=True)
class LayerSolve:
    """Nyström solve of the layer's Fredholm equation; lengths in units of the thickness h.

    Parameters
    ----------
    poisson : float
        ν of the layer, in [0, 0.5].
    bonded : bool
        True: bonded to the rigid base; False: on it without friction.
    nodes : int or None
        Gauss–Legendre nodes on [0, a]; None picks max(24, 12·a/h).
    """

    poisson: float = 0.5
    bonded: bool = True
    nodes: int | None = None

    def _u_rule(self, x_max: float):
        """Composite Gauss–Legendre nodes and weights on [0, U_MAX] resolving cos(u·x_max)."""
        width = min(0.5, 2.0 / max(x_max, 1e-300))
        panels = max(48, math.ceil(U_MAX / width))
        x, w = leggauss(12)
        edges = np.linspace(0.0, U_MAX, panels + 1)
        lo, hi = edges[:-1, None], edges[1:, None]
        u = (0.5 * (hi - lo) * x + 0.5 * (hi + lo)).ravel()
        wu = (0.5 * (hi - lo) * w).ravel()
        return u, wu * layer_m(u, self.poisson, self.bonded)

    def _kernel(self, x_max: float, n: int):
        """k(x) on [−x_max, x_max]: by quadrature at every argument, or, when that would take more
        than ~5e8 cosines (thin layers, a ≫ h), from a table at spacing 0.01 h by a cubic spline
        (k is smooth on the scale h: the load changes by < 1e-6 relative at a = 40 h)."""
        u, wm = self._u_rule(x_max)

        def direct(arg):
            flat = np.abs(np.ravel(arg))
            rows = max(1, 2_000_000 // u.size)          # bound the cos table to ~16 MB
            out = np.concatenate([np.cos(np.multiply.outer(flat[i:i + rows], u)) @ wm
                                  for i in range(0, flat.size, rows)])
            return out.reshape(np.shape(arg))

        if 2 * n * n * u.size <= 5e8:
            return direct
        grid = np.linspace(0.0, x_max, math.ceil(x_max / 0.01) + 1)
        spline = CubicSpline(grid, direct(grid))
        return lambda arg: spline(np.abs(arg))

    def solve(self, a: float):
        """φ for the right-hand sides 1, t, t² at the edge t = a, and their integrals over [0, a].

        Returns
        -------
        edge : ndarray (3,)
            φ_1(a), φ_t(a), φ_t²(a) (units E_star/π factored out).
        integral : ndarray (3,)
            ∫0^a φ dt for the same three right-hand sides.
        """
        n = self.nodes or max(24, math.ceil(12 * a))
        x, w = leggauss(n)
        t = 0.5 * a * (x + 1.0)
        wt = 0.5 * a * w
        k = self._kernel(2.0 * a, n)

        kernel = (k(np.subtract.outer(t, t)) + k(np.add.outer(t, t))) / math.pi
        rhs = np.stack([np.ones(n), t, t * t], axis=1)
        phi = np.linalg.solve(np.eye(n) - kernel * wt, rhs)
        edge_row = (k(a - t) + k(a + t)) / math.pi * wt
        edge = np.array([1.0, a, a * a]) + edge_row @ phi
        return edge, wt @ phi

    def flat(self, a: float) -> float:
        """Flat punch of radius a (in h): P_layer/P_half-space = G_flat(a/h)."""
        _, integral = self.solve(a)
        return float(integral[0] / a)

    def paraboloid(self, a: float):
        """Paraboloid at contact radius a (in h).

        Returns
        -------
        chi : float
            χ = √(Rδ)/h.
        force : float
            P_layer/P_Hertz at the same δ.
        stiffness : float
            (dP/dδ)_layer / (dP/dδ)_Hertz at the same δ, by the flat-punch identity.
        """
        edge, integral = self.solve(a)
        depth_r = edge[2] / edge[0]                # δR/h² from φ(a) = 0
        load = 2.0 * (depth_r * integral[0] - integral[2])   # P·R/(E_star·h³)
        chi = math.sqrt(depth_r)
        stiffness = integral[0] / chi            # 2E_star·a·G_flat(a) / (2E_star·√(Rδ))
        return chi, float(load / (4.0 / 3.0 * chi**3)), float(stiffness)

    def cone(self, a: float):
        """Cone at contact radius a (in h); x = tanθ·δ/h (the result does not depend on θ).

        Returns
        -------
        x : float
            tanθ·δ/h.
        force : float
            P_layer/P_Sneddon at the same δ.
        stiffness : float
            (dP/dδ)_layer / (dP/dδ)_Sneddon at the same δ.
        """
        edge, integral = self.solve(a)
        x = 0.5 * math.pi * edge[1] / edge[0]      # tanθ·δ/h from φ(a) = 0 (tanθ = 1)
        load = 2.0 * (x * integral[0] - 0.5 * math.pi * integral[1])
        stiffness = integral[0] / (2.0 / math.pi * x)   # over Sneddon's 2E_star·(2/π)·tanθ·δ
        return float(x), float(load / (2.0 / math.pi * x * x)), float(stiffness)

    def paraboloid_stiffness_by_difference(self, a: float, step: float = 1e-5) -> float:
        """(dP/dδ)/(dP/dδ)_Hertz by central differences in a (checks the flat-punch identity)."""
        lo, hi = self.paraboloid(a - step), self.paraboloid(a + step)
        load_lo, load_hi = (4.0 / 3.0 * c**3 * f for c, f, _ in (lo, hi))
        slope = (load_hi - load_lo) / (hi[0] ** 2 - lo[0] ** 2)
        return float(slope / (2.0 * self.paraboloid(a)[0]))
