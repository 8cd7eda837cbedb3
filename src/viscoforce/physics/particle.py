"""Geometry of the interacting bodies: a sphere (or two spheres) facing a flat.

:class:`Particle` is the particle's paraboloidal apex (paper Eq. 1); ``Sphere`` is its earlier
name, kept (``viscoforce.Sphere``). The rigid spherical *tip* of indentation fits is another
thing: :class:`viscoforce.physics.tips.RigidSphere`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._typing import FloatArray
from viscoforce._validation import as_float_array, require_finite, require_positive
from viscoforce.exceptions import ParameterError


@dataclass(frozen=True)
class Particle:
    """Paraboloidal apex of radius R: undeformed gap h0(r) = h0 + r²/2R (paper Eq. 1).

    Parameters
    ----------
    radius : float
        R [m], > 0. For two spheres use the effective radius 1/R = 1/R1 + 1/R2
        (:meth:`effective`).
    """

    radius: float = 10e-6

    def __post_init__(self):
        object.__setattr__(self, "radius", require_positive("radius (R)", self.radius))

    @classmethod
    def effective(cls, radius_1: float, radius_2: float) -> Particle:
        """Two spheres of radii R1, R2 [m] → the equivalent sphere against a flat."""
        r1 = require_positive("radius_1", radius_1)
        r2 = require_positive("radius_2", radius_2)
        return cls(r1 * r2 / (r1 + r2))

    def undeformed_gap(self, position: float, r: ArrayLike) -> FloatArray:
        """h0(r) = h0 + r²/2R [m] for apex position ``position`` [m] at radii ``r`` [m] (finite, ≥ 0)."""
        position = require_finite("position (h0)", position)
        r = as_float_array("r", r)
        if np.any(r < 0):
            raise ParameterError(f"r must be >= 0 m, got min {float(np.min(r))!r}")
        return position + r * r / (2.0 * self.radius)

    def radius_at_gap(self, position: float, gap: float) -> float:
        """Radius [m] where the undeformed gap equals ``gap`` [m] (0 if it is already below)."""
        position = require_finite("position (h0)", position)
        gap = require_finite("gap", gap)
        return float(np.sqrt(max(2.0 * self.radius * (gap - position), 0.0)))


#: The earlier name of :class:`Particle` (``viscoforce.Sphere``, ``ContactProblem.create(sphere=...)``).
Sphere = Particle
