"""Surface-force laws that wrap another law, for tests that change or watch one of its methods."""

from __future__ import annotations

from viscoforce.physics.surface_forces import SurfaceForceLaw


class Wrapped(SurfaceForceLaw):
    """``law`` itself: every method delegated (subclasses override what they change)."""

    def __init__(self, law):
        self.law = law

    def pressure(self, gap):
        return self.law.pressure(gap)

    def pressure_derivative(self, gap):
        return self.law.pressure_derivative(gap)

    def energy(self, gap):
        return self.law.energy(gap)

    @property
    def decay_length(self):
        return self.law.decay_length

    def negligible_gap(self, rtol):
        return self.law.negligible_gap(rtol)
