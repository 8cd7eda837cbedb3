"""Type aliases and the drive protocol the solvers depend on."""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]


@runtime_checkable
class SeparationHistory(Protocol):
    """A prescribed position (undeformed separation) h0(t) [m] of the sphere's apex.

    Implementations are frozen dataclasses in :mod:`viscoforce.experiments.drives`; the solvers
    only rely on this protocol.
    """

    def position(self, t: ArrayLike) -> FloatArray:
        """Position h0(t) [m] at times ``t`` [s]."""
        ...

    def velocity(self, t: ArrayLike) -> FloatArray:
        """Drive velocity dh0/dt [m/s] at times ``t`` [s] (right-sided at kinks)."""
        ...

    @property
    def duration(self) -> float:
        """Time at which the drive ends [s]; it holds its last position afterwards."""
        ...

    def breakpoints(self) -> FloatArray:
        """Times [s] in [0, duration] where the velocity jumps (kinks); steps land on them."""
        ...
