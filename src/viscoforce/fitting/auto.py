"""The theory's model choice for a spectrum at a known position or load (``model="auto"``).

:func:`fit_spectrum_auto` takes the cheapest of svda, contact and exact whose model error,
estimated at the fitted parameters, meets the required accuracy; the measured-data chooser
(no position) is :mod:`viscoforce.fitting.measured`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.choice import (
    DEFAULT_ACCURACY,
    GRID_ERROR,
    contact_error,
    double_layer,
    finish,
    meets,
    require_accuracy,
    svda_error,
)
from viscoforce.exceptions import ConvergenceError, ModelValidityError, ParameterError
from viscoforce.fitting.base import material_from
from viscoforce.fitting.data import FitData, spectrum_data
from viscoforce.fitting.fit import AUTO_CHOOSERS, fit_data
from viscoforce.fitting.model_error import svda_bias, validity_note
from viscoforce.fitting.models import check_fixed
from viscoforce.fitting.spectrum_models import svda_position
from viscoforce.fitting.verdict import scalar_value, warn_fit
from viscoforce.problem import ContactProblem


def _sls_of(ds: xr.Dataset):
    """The standard linear solid of a one-mode fit result."""
    return material_from({n: scalar_value(ds, n) for n in ("E0", "E_inf", "tau")}, 1)


#: The models ``model="auto"`` chooses from, in order of cost.
AUTO_MODELS = ("svda", "contact", "exact")


def _auto_candidate(spectrum: xr.Dataset, name: str, modes: int | str, criterion: str,
                    problem: ContactProblem, fixed: Mapping[str, Any],
                    data: FitData, profile: bool | str = False
                    ) -> tuple[xr.Dataset | None, float, str]:
    """Fit one candidate of ``model="auto"``: (result or None, estimated model error, reason).

    ``profile``: profile-likelihood identifiability (the kept candidate's refit only).
    """
    position, mean_force = fixed.get("position"), fixed.get("mean_force")
    radius = problem.sphere.radius
    if name == "svda":
        if modes != 1:
            return None, math.inf, f"one relaxation time only, modes={modes!r} asked"
        layer = double_layer(problem)
        if layer is None or problem.material.prony().n_modes != 1:
            return None, math.inf, "needs one relaxation time and exactly one DoubleLayer term"
        # applicability only (pre-contact); the value is re-estimated at the fitted moduli below
        error, reason = svda_error(problem, position) if position is not None else (0.0, "")
        if math.isinf(error):
            return None, error, reason
        try:
            ds = fit_data(data, "svda", profile=profile, position=position,
                          mean_force=mean_force, radius=radius, P=layer.P,
                          debye_length=layer.debye_length)
        except (ModelValidityError, ConvergenceError) as exc:
            return None, math.inf, f"fit failed: {str(exc).split(';')[0]}"
        e_inf = float(ds["E_inf"])
        h0 = position if position is not None else svda_position(
            mean_force, e_inf, radius, layer.P, layer.debye_length)
        return (ds, *svda_bias(ds, spectrum, h0, radius, layer.P, layer.debye_length))
    if name == "contact":
        depth = -position if position is not None else None
        if modes != 1:
            return None, math.inf, (f"one relaxation time here, modes={modes!r} asked (model "
                                    "'contact' with material='prony' fits more)")
        if depth is None or not depth > 0:
            return None, math.inf, "needs an indentation (a position h0 < 0)"
        try:
            ds = fit_data(data, "contact", radius=radius,
                          profile=profile, indentation=depth,
                          drag=fixed.get("drag"))
        except (ModelValidityError, ConvergenceError) as exc:
            return None, math.inf, f"fit failed: {str(exc).split(';')[0]}"
        error, reason = contact_error(problem.with_material(_sls_of(ds)), position,
                                      float(np.max(spectrum["omega"])))
        return ds, error, f"{reason} at the fitted moduli (k* proportional to E: bias = error)"
    ds = fit_data(data, "exact", modes=modes,
                  criterion=criterion, profile=profile,
                  problem=problem, position=position, mean_force=mean_force)
    return ds, GRID_ERROR, "the exact model on the default grid"


def fit_spectrum_auto(spectrum: xr.Dataset, *, modes: int | str = 1, criterion: str = "bic",
                      accuracy: float | None = None, weights: str | None = None,
                      profile: bool | str = "auto", **fixed: Any) -> xr.Dataset:
    """``fit_spectrum(..., "auto")``: the cheapest spectrum model adequate at the fitted values.

    Tries svda (pre-contact, one mode), contact (Hertz, h̄0 < 0, one mode) and exact in order
    of cost; each approximate fit is kept if its model error estimated at the fitted parameters
    (:func:`viscoforce.choice.svda_error`, :func:`viscoforce.choice.contact_error`), divided by
    the sensitivity of k* to the moduli (the bias it puts on E0, E_inf), meets ``accuracy``,
    otherwise the next is fitted. Before contact the SVDA's stiffness error and the
    sensitivity are both O(κ|u0|), so its moduli are biased by an O(1) fraction of the
    relative error at any position: ``auto`` keeps svda only at a loose accuracy.
    ``attrs["explanation"]`` says what was compared; ``attrs["estimated_model_error"]`` holds
    the estimate of the model kept. ``profile``
    (:data:`~viscoforce.fitting.fit.PROFILE_CHOICES`): the limits and identifiability of the
    kept fit.

    Raises
    ------
    ParameterError
        No ``problem`` (the exact fallback needs it), or neither ``position`` nor ``mean_force``.
    TypeError
        A fixed input none of the candidates takes.
    """
    accuracy = require_accuracy(DEFAULT_ACCURACY if accuracy is None else accuracy)
    allowed = {"problem", "position", "mean_force", "drag"}
    unknown = sorted(set(fixed) - allowed)
    if unknown:
        raise TypeError(f"model 'auto' takes no input {', '.join(unknown)}; its inputs: "
                        f"{', '.join(sorted(allowed))} (radius and the surface force come "
                        "from problem)")
    problem = fixed.get("problem")
    if not isinstance(problem, ContactProblem):
        raise ParameterError("model 'auto' needs problem= (a ContactProblem: the sphere, surface "
                             "force and grid of the exact model it may fall back to)")
    if fixed.get("position") is None and fixed.get("mean_force") is None:
        raise ParameterError("model 'auto' needs the mean position: give position (--h0) or "
                             "mean_force (--mean-force)")
    fixed = check_fixed("exact", {k: v for k, v in fixed.items() if k != "drag"}) | {
        "drag": fixed.get("drag")}
    data = spectrum_data(spectrum, weights=weights)  # its notes warn once
    rows: list[tuple[str, float, str, dict[str, Any]]] = []
    kept = None
    for name in AUTO_MODELS:
        ds, error, reason = _auto_candidate(spectrum, name, modes, criterion, problem, fixed,
                                            data)
        rows.append((name, error, reason, {}))
        if ds is not None and error <= meets(accuracy):
            # the kept one again, with its profile likelihood (the same fit: deterministic)
            kept = _auto_candidate(spectrum, name, modes, criterion, problem, fixed, data,
                                   profile=profile)[0] if profile else ds
            break
    choice = finish("fit model", rows, accuracy, "")
    if kept is None:  # exact fits or raises; keep the loop honest anyway
        raise ConvergenceError(f"model 'auto' kept no fit: {choice.explanation}")
    kept.attrs["explanation"] = choice.explanation
    kept.attrs["estimated_model_error"] = choice.estimated_error
    kept.attrs["accuracy"] = accuracy
    kept.attrs["validity"] = validity_note(str(kept.attrs["model"]), kept)
    warn_fit(kept, stacklevel=5)
    return kept


AUTO_CHOOSERS["theory"] = fit_spectrum_auto  # fit_spectrum(model="auto") reaches it here
