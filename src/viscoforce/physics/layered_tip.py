"""A tip pressed into a layer on a rigid support: the half-space laws times the bottom-effect factors.

:class:`LayeredTip` wraps a :class:`~viscoforce.physics.tips.Tip` so that every law written for a
tip (Hertz's fit, Ting's hereditary integral, the contact model's S(δ0)) gives the layer's own
modulus, with the factors of :mod:`viscoforce.physics.bottom_effect`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

from numpy.typing import ArrayLike

from viscoforce._typing import FloatArray
from viscoforce.physics.bottom_effect import (
    BottomEffectSeries,
    bottom_effect_series,
    force_factor,
    max_depth,
    stiffness_factor,
)
from viscoforce.physics.tips import Tip
from viscoforce.units import format_quantity

__all__ = ["LayeredTip", "layer_attrs"]


@dataclass(frozen=True)
class LayeredTip(Tip):
    """``base`` pressed into a layer of height h on a rigid support (the bottom effect).

    The half-space laws of ``base`` times this module's factors (the default series for
    ν = 0.5: Garcia & Garcia 2018 bonded, Dimitriadis et al. 2002 sliding):
    ``force_shape`` = F/E·f(δ, h), ``contact_stiffness_factor`` = S·g(δ, h), so that a law
    written for a :class:`~viscoforce.physics.tips.Tip` (Hertz's fit, Ting's hereditary integral,
    the contact model's S(δ0)) gives the layer's modulus unchanged. ``contact_radius`` is the
    half-space one. ``max_indentation`` is the deepest indentation the series is accepted for
    (:func:`max_depth`), which bounds a fitted contact point (the fits' contact window reads a
    tip's ``max_indentation``); beyond it the factors raise the module's
    :class:`~viscoforce.exceptions.ParameterError` naming ``sample_height``.

    Parameters
    ----------
    base : Tip
        The tip (paraboloid, sphere, cone, pyramid or flat punch).
    sample_height : float
        The layer's thickness h [m] at the indented point.
    bonded : bool
        True: bonded to its support; False: sliding on it.
    """

    base: Tip
    sample_height: float
    bonded: bool = True
    shape: ClassVar[str] = "layered"

    def __post_init__(self) -> None:
        self.series  # noqa: B018 - refuses a shape or base no series covers, up front
        max_depth(self.base, self.sample_height, bonded=self.bonded)  # refuses a bad height

    @property
    def series(self) -> BottomEffectSeries:
        """The bottom-effect series used (name, coefficients, accepted range, reference)."""
        return bottom_effect_series(self.base, bonded=self.bonded)

    @property
    def max_indentation(self) -> float:
        """Deepest indentation [m] accepted: the series' and the base tip's own, if it has one."""
        deepest = float(max_depth(self.base, self.sample_height, bonded=self.bonded))
        own = getattr(self.base, "max_indentation", None)
        return deepest if own is None else min(deepest, float(own))

    def force_shape(self, delta: ArrayLike) -> FloatArray:
        """F/E [m²] on the layer: the base's times the force factor f(δ, h)."""
        return self.base.force_shape(delta) * force_factor(
            self.base, delta, self.sample_height, bonded=self.bonded)

    def contact_stiffness_factor(self, delta: ArrayLike) -> FloatArray:
        """(dF/dδ)/E [m] on the layer: the base's times the stiffness factor g(δ, h)."""
        return self.base.contact_stiffness_factor(delta) * stiffness_factor(
            self.base, delta, self.sample_height, bonded=self.bonded)

    def contact_radius(self, delta: ArrayLike) -> FloatArray:
        """a(δ) [m] of the base tip on a half-space."""
        return self.base.contact_radius(delta)

    def describe(self) -> str:
        """The base tip's text and the layer, e.g. ``"sphere R = 5 µm on a 5 µm bonded layer"``."""
        return (f"{self.base.describe()} on a {format_quantity(self.sample_height, 'length')} "
                f"{'bonded' if self.bonded else 'sliding'} layer")

    def as_attrs(self) -> dict[str, str | float]:
        """The base tip's attrs and the layer's (``sample_height``, ``sample_base``, series)."""
        return {**self.base.as_attrs(), **layer_attrs(self)}


def layer_attrs(tip: LayeredTip) -> dict[str, str | float]:
    """Result attrs of a layer: ``sample_height`` [m], ``sample_base``, the series, its depth limit."""
    s = tip.series
    return {"sample_height": float(tip.sample_height),
            "sample_base": "bonded" if tip.bonded else "sliding",
            "bottom_effect_series": f"{s.name}: {s.reference}, accepted for {s.variable} <= "
                                    f"{s.max_variable:g}",
            "bottom_effect_max_depth": float(tip.max_indentation)}
