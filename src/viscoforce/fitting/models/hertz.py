"""``hertz``: the approach of a force curve, elastic contact of the tip's shape, baseline and tilt."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from viscoforce.fitting import _params as P
from viscoforce.fitting._hertz_scan import unchecked_shape
from viscoforce.fitting._layer import layer_window, layered, require_layer_depth
from viscoforce.fitting.base import (
    FitModel,
    ModelSpec,
    need,
)
from viscoforce.fitting.curve_models import (
    baseline_windows,
    contact_window,
    hertz_start,
)
from viscoforce.fitting.models._inputs import CONTACT_WINDOW, SAMPLE_BASE, SAMPLE_HEIGHT, TIP
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.segments import approach_data
from viscoforce.physics.layered_tip import LayeredTip, layer_attrs


def _hertz_model(spec: ModelSpec) -> FitModel:
    """F(z) = b + s·(z − c) + E·shape(max(z − c, 0)) over the tip position z toward the sample.

    ``E`` the paper's modulus, ``contact_point`` c [m], ``baseline`` b [N] (the free-cantilever
    force at contact) and ``baseline_slope`` s [N/m] (a tilted baseline, kept in contact); the
    tip's ``force_shape`` (:mod:`viscoforce.physics.tips`) gives the indentation law.

    With ``sample_height`` h (and ``sample_base``, default bonded) the law is the layer's,
    E·shape(δ)·f(δ, h) with the bottom-effect force factor f at each indentation
    (:class:`~viscoforce.physics.layered_tip.LayeredTip`), so the fitted
    ``E`` is the sample's, corrected. The contact point is then bounded so that no fitted depth
    exceeds the series' accepted range, and an approach whose half-space contact point lies
    deeper than that is refused before the fit
    (:func:`~viscoforce.fitting.ting_model.require_layer_depth`). The result's attrs carry
    ``sample_height``, ``sample_base``, ``bottom_effect_series`` and ``bottom_effect_max_depth``.
    """
    (tip,) = need(spec, "tip")
    law = layered(tip, spec.fixed)
    window = spec.fixed.get("contact_window")
    shape = unchecked_shape(law)  # the law without its checks: max(z − c, 0) is >= 0

    def function(z: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        z = np.asarray(z, dtype=float)
        delta = z - v["contact_point"]
        out = delta * v["baseline_slope"]  # in place from here: b + s·(z − c) + E·shape
        out += v["baseline"]
        np.maximum(delta, 0.0, out=delta)
        if not np.isfinite(delta).all():
            law.force_shape(delta)  # raises the law's ParameterError, naming the entry
        out += np.multiply(shape(delta), v["E"], out=delta)
        return out

    def guesser(f: np.ndarray, z: np.ndarray) -> dict[str, float]:
        z, f = np.asarray(z, dtype=float), np.asarray(f, dtype=float)
        require_layer_depth(law, z, f)
        return hertz_start(law, z, f)

    def windows(z: np.ndarray, f: np.ndarray | None = None) -> dict[str, tuple[float, float]]:
        out = {"contact_point": layer_window(law, z, window) if window is not None
               else contact_window(law, z)}
        if f is not None:
            out.update(baseline_windows(f, z))
        return out

    layout: list[P.Item] = [P.Chain(("E",)), P.Bounded("contact_point", -1.0, 1.0),
                            P.Bounded("baseline", -1.0, 1.0),
                            P.Bounded("baseline_slope", -1.0, 1.0)]
    if isinstance(law, LayeredTip):
        spec = ModelSpec(spec.name, spec.modes, {**spec.fixed, **layer_attrs(law)})
    return FitModel(spec, function, layout, "z", guesser, bounded_windows=windows)



ENTRY = register(ModelEntry(
    name="hertz", data="curve",
    summary="the approach: contact point, tilted baseline, Hertz/Sneddon law of the tip",
    build=_hertz_model, inputs=(TIP, CONTACT_WINDOW, SAMPLE_HEIGHT, SAMPLE_BASE),
    parameters=lambda modes, material: ["E", "contact_point", "baseline", "baseline_slope"],
    cut=approach_data,
    validity="elastic contact of the tip's shape on a half-space (Sneddon/Hertz/Bilodeau), or "
             "on a layer of sample_height (bottom-effect series, docs/bottom_effect.md): valid "
             "for indentations small against the sample's thickness, with no adhesion; a "
             "viscoelastic sample's E is an effective modulus at the approach speed",
    autocorrelated=True))
