"""``hertz``: the approach of a force curve, elastic contact of the tip's shape, baseline and tilt."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from viscoforce.fitting import _params as P
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
from viscoforce.fitting.models._inputs import CONTACT_WINDOW, TIP
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.segments import approach_data


def _hertz_model(spec: ModelSpec) -> FitModel:
    """F(z) = b + s·(z − c) + E·shape(max(z − c, 0)) over the tip position z toward the sample.

    ``E`` the paper's modulus, ``contact_point`` c [m], ``baseline`` b [N] (the free-cantilever
    force at contact) and ``baseline_slope`` s [N/m] (a tilted baseline, kept in contact); the
    tip's ``force_shape`` (:mod:`viscoforce.physics.tips`) gives the indentation law.
    """
    (tip,) = need(spec, "tip")
    window = spec.fixed.get("contact_window")

    def function(z: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        z = np.asarray(z, dtype=float)
        delta = np.maximum(z - v["contact_point"], 0.0)
        return (v["baseline"] + v["baseline_slope"] * (z - v["contact_point"])
                + v["E"] * tip.force_shape(delta))

    def guesser(f: np.ndarray, z: np.ndarray) -> dict[str, float]:
        return hertz_start(tip, np.asarray(z, dtype=float), np.asarray(f, dtype=float))

    def windows(z: np.ndarray, f: np.ndarray | None = None) -> dict[str, tuple[float, float]]:
        out = {"contact_point": window if window is not None else contact_window(tip, z)}
        if f is not None:
            out.update(baseline_windows(f, z))
        return out

    layout: list[P.Item] = [P.Chain(("E",)), P.Bounded("contact_point", -1.0, 1.0),
                            P.Bounded("baseline", -1.0, 1.0),
                            P.Bounded("baseline_slope", -1.0, 1.0)]
    return FitModel(spec, function, layout, "z", guesser, bounded_windows=windows)


ENTRY = register(ModelEntry(
    name="hertz", data="curve",
    summary="the approach: contact point, tilted baseline, Hertz/Sneddon law of the tip",
    build=_hertz_model, inputs=(TIP, CONTACT_WINDOW),
    parameters=lambda modes, material: ["E", "contact_point", "baseline", "baseline_slope"],
    cut=approach_data,
    validity="elastic contact of the tip's shape on a half-space (Sneddon/Hertz/Bilodeau): "
             "valid for indentations small against the sample's thickness, with no adhesion; a "
             "viscoelastic sample's E is an effective modulus at the approach speed",
    autocorrelated=True))
