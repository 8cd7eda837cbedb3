"""The sample's layer in a contact fit (hertz, ting): the tip on it, its window, its depth limit.

A fit given ``sample_height`` (and ``sample_base``) fits with the tip on that layer
(:class:`~viscoforce.physics.layered_tip.LayeredTip`), so its modulus is the layer's own.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from viscoforce.exceptions import ParameterError
from viscoforce.physics.bottom_effect import force_factor
from viscoforce.physics.layered_tip import LayeredTip
from viscoforce.physics.tips import Tip

__all__ = ["layer_window", "layered", "require_layer_depth"]


def layered(tip: Tip, fixed: Mapping[str, Any]) -> Tip:
    """``tip`` on the layer of ``fixed``'s ``sample_height`` / ``sample_base`` (``tip`` without).

    Raises
    ------
    ParameterError
        ``sample_base`` without ``sample_height``, or a tip, height or base no series covers.
    """
    height, base = fixed.get("sample_height"), fixed.get("sample_base")
    if height is None:
        if base is not None:
            raise ParameterError("sample_base describes the layer of sample_height: give both "
                                 "(--sample-height H --sample-base bonded|sliding)")
        return tip
    return LayeredTip(tip, float(height), (base or "bonded") == "bonded")


def layer_window(tip: Tip, z: np.ndarray, window: tuple[float, float]) -> tuple[float, float]:
    """A given contact-point window [m], no deeper than a :class:`LayeredTip`'s series accepts.

    The low end is raised to max(z) − 0.99·``max_indentation`` (as
    :func:`~viscoforce.fitting.curve_models.contact_window` does for a tip's own limit).

    Raises
    ------
    ParameterError
        The whole window lies deeper than that.
    """
    lo, hi = window
    if isinstance(tip, LayeredTip):
        lo = max(lo, float(np.max(z)) - 0.99 * tip.max_indentation)
        if lo >= hi:
            raise ParameterError(
                f"contact_window {window!r} lies entirely deeper than the bottom-effect series "
                f"accepts at sample_height {tip.sample_height!r} m (deepest indentation "
                f"{tip.max_indentation:.4g} m below the approach's end {float(np.max(z))!r} m)")
    return lo, hi


def require_layer_depth(tip: Tip, z: np.ndarray, f: np.ndarray) -> None:
    """Refuse, before a fit, an approach deeper than the bottom-effect series accepts.

    The deepest indentation is max(z) − c with c the half-space Hertz guess's contact point
    (:func:`~viscoforce.fitting.curve_models.hertz_grid`); a fit on the layer cannot go deeper
    than :attr:`LayeredTip.max_indentation` (it bounds the contact point), so without this check
    a too-deep curve would be fitted with a contact point forced shallow. Nothing for a tip that
    is not a :class:`LayeredTip`, or an approach with no contact point.

    Raises
    ------
    ParameterError
        :func:`~viscoforce.physics.bottom_effect.force_factor`'s message: the deepest accepted
        indentation at that ``sample_height`` (fit only the shallower part).
    """
    if not isinstance(tip, LayeredTip):
        return
    from viscoforce.fitting.curve_models import hertz_grid

    best = hertz_grid(tip.base, z, f)
    if best is not None:
        force_factor(tip.base, max(float(np.max(z)) - float(best[0]), 0.0), tip.sample_height,
                     bonded=tip.bonded)
