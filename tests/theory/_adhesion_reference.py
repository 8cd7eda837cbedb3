"""An independent adhesive-contact solver for the tests (issue 39): Greenwood-style rings.

A different discretisation from viscoforce's (panels of Gauss nodes, product integration of the
elliptic kernel): the pressure is piecewise *constant* on uniform rings [r_j, r_j+1], the
deflection of each ring is the difference of two uniformly loaded disks in closed form (Johnson,
Contact Mechanics, Eq. 3.41; E* = E/2 in the paper's convention), collocated at the ring
midpoints; the load is the midpoint rule π Σ p_j (r_j+1² − r_j²) plus the rigid Derjaguin tail
beyond r_max. Second order in the ring width: two widths are Richardson-extrapolated.
Positions are followed by natural continuation with Newton (a stable branch only).
"""

from __future__ import annotations

import numpy as np
from scipy.special import ellipe, ellipk


def disk_deflection(rho, a):
    """Surface deflection × E*/p at radius ``rho`` under unit pressure on the disk r < ``a``."""
    rho = np.asarray(rho, dtype=float)
    out = np.empty(np.broadcast(rho, a).shape)
    rho, a = np.broadcast_arrays(rho, a)
    inside = rho <= a
    k2 = np.where(inside, (rho / np.where(a > 0, a, 1.0)) ** 2, 0.0)
    out[inside] = (4.0 * a[inside] / np.pi) * ellipe(k2[inside])
    o = ~inside
    m = (a[o] / rho[o]) ** 2
    out[o] = (4.0 * rho[o] / np.pi) * (ellipe(m) - (1.0 - m) * ellipk(m))
    return out


class RingSolver:
    """Elastic sphere-flat equilibrium on ``n`` uniform rings out to ``outer`` [m]."""

    def __init__(self, radius, modulus, law, outer, n):
        self.radius, self.law = radius, law
        self.edges = np.linspace(0.0, outer, n + 1)
        self.rho = 0.5 * (self.edges[1:] + self.edges[:-1])
        e_star = 0.5 * modulus
        outer_d = disk_deflection(self.rho[:, None], self.edges[None, 1:])
        inner_d = disk_deflection(self.rho[:, None], self.edges[None, :-1])
        self.b = (outer_d - inner_d) / e_star  # h = h0 + ρ²/2R + B p
        self.area = np.pi * (self.edges[1:] ** 2 - self.edges[:-1] ** 2)
        self.sag = self.rho**2 / (2.0 * radius)
        self.tail_sag = (outer**2 - self.rho[-1] ** 2) / (2.0 * radius)

    def solve(self, h0, guess):
        h = np.array(guess, dtype=float)
        for _ in range(60):
            p = self.law.pressure(h)
            res = h - h0 - self.sag - self.b @ p
            jac = np.eye(h.size) - self.b * self.law.pressure_derivative(h)[None, :]
            dh = np.linalg.solve(jac, -res)
            step = 1.0
            shrink = dh < -0.8 * h
            if shrink.any():
                step = float(np.min(-0.8 * h[shrink] / dh[shrink]))
            h = h + step * dh
            if np.abs(dh).max() < 1e-13:
                return h
        raise RuntimeError(f"reference Newton did not converge at h0 = {h0}")

    def force(self, h):
        tail = 2.0 * np.pi * self.radius * float(self.law.energy(h[-1] + self.tail_sag))
        return float(self.area @ self.law.pressure(h)) + tail

    def branch(self, positions, guess_gap_at):
        """Forces at ``positions`` (in order), the first from ``guess_gap_at(rho)``."""
        h = guess_gap_at(self.rho)
        out = []
        for h0 in positions:
            h = self.solve(h0, h)
            out.append(self.force(h))
        return np.array(out)


def reference_forces(radius, modulus, law, outer, n, positions, guess_gap_at):
    """Richardson-extrapolated forces [N] of ``n`` and ``2n`` rings along ``positions``."""
    coarse = RingSolver(radius, modulus, law, outer, n).branch(positions, guess_gap_at)
    fine = RingSolver(radius, modulus, law, outer, 2 * n).branch(positions, guess_gap_at)
    return (4.0 * fine - coarse) / 3.0, fine - coarse
