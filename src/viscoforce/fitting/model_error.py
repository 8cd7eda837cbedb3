"""The model error of a spectrum fit: estimated where the theory allows, said why where not.

An svda fit's bias comes from the SVDA's stiffness error over the moduli's sensitivity
(:func:`svda_bias`); a contact fit's from Hertz contact's error against the exact model
(:func:`contact_bias`), with the surface force's decay length given or, where none is, the
paper's (:func:`warn_contact_bias`, as the CLI's ``--debye-length`` default). Above 1 % the fit
warns; :func:`validity_note` is the sentence each result carries in ``attrs["validity"]``
(where no estimate is made, the model entry's
:attr:`~viscoforce.fitting.registry.ModelEntry.validity`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.choice import WARN_ERROR, hertz_error
from viscoforce.exceptions import ApproximationWarning, ModelValidityError
from viscoforce.fitting.base import material_from
from viscoforce.fitting.registry import MODELS
from viscoforce.fitting.verdict import scalar_value
from viscoforce.physics.paper import PAPER
from viscoforce.schema import index_values, parameter_names
from viscoforce.svda import (
    SVDA_ERROR_COEFFICIENT,
    svda_deformation_kernel,
    svda_stiffness_kernel,
)

#: Decay length [m] of a contact fit's bias estimate where none is given: the paper's double
#: layer (1/κ = 1 nm), the CLI's ``--debye-length`` default (:func:`warn_contact_bias`).
DEFAULT_DECAY_LENGTH = PAPER.debye_length
#: Relative step of the moduli sensitivity of an svda fit (its bias estimate).
SENSITIVITY_STEP = 1e-4
#: Smallest moduli sensitivity |dln k*/dln E| of an svda fit that can determine a modulus: below
#: it (far from the surface) a relative change of E moves k* by less than float64 resolves.
MIN_SENSITIVITY = 1e-10


def validity_note(model: str, ds: xr.Dataset) -> str:
    """One sentence on the model error of a fit: the estimate made, or why there is none."""
    if "validity" in ds.attrs:
        return str(ds.attrs["validity"])
    if "estimated_model_error" in ds.attrs:
        return (f"estimated model error {float(ds.attrs['estimated_model_error']):.2g} "
                f"(relative, on the moduli)")
    known = MODELS.get(model)
    return known.validity if known is not None else "not estimated"


def svda_bias(ds: xr.Dataset, spectrum: xr.Dataset, position: float, radius: float,
              P: float, debye_length: float) -> tuple[float, str]:  # noqa: N803
    """Estimated relative bias of an svda fit's moduli and the reason.

    A stiffness error δ (0.6 κ|u0| at the fitted E_inf, :func:`viscoforce.svda.svda_error_estimate`)
    biases the moduli by ≈ δ / s, s = |∂ln k*/∂ln E| (E0, E_inf scaled together), which is small
    before contact: the SVDA error is O(κ|u0|) and so is s.
    """
    values = {n: scalar_value(ds, n) for n in ("E0", "E_inf", "tau")}
    # svda_error_estimate's 0.6 κ|u0| on the fit's checked inputs (its kernel checks none)
    u0 = svda_deformation_kernel(position, values["E_inf"], radius, P, 1.0 / debye_length)
    error = SVDA_ERROR_COEFFICIENT * abs(u0) / debye_length
    omega = np.asarray(index_values(spectrum, "omega"), dtype=float)
    kernel = (position, values["E0"], values["E_inf"], values["tau"], radius, P)
    k = svda_stiffness_kernel(omega, *kernel, 1.0 / debye_length)
    scaled = (position, *(v * (1 + SENSITIVITY_STEP) for v in kernel[1:3]), *kernel[3:])
    k_up = svda_stiffness_kernel(omega, *scaled, 1.0 / debye_length)
    with np.errstate(invalid="ignore", divide="ignore"):
        sensitivity = float(np.max(np.abs(k_up / k - 1.0))) / SENSITIVITY_STEP
    if not sensitivity > MIN_SENSITIVITY:  # also NaN: k* underflows far from the surface
        raise ModelValidityError(
            f"at h0 = {position:.3g} m the svda stiffness does not depend on the moduli "
            f"(|dln k*/dln E| = {sensitivity:.2g} at E_inf = {values['E_inf']:.3g} Pa): the "
            f"surfaces are {position / debye_length:.3g} decay lengths apart and do not deform, "
            "so no modulus can be measured there; give the position of the measurement (--h0), "
            "closer to contact, or fit --model prony (no geometry)")
    return error / sensitivity, (
        f"stiffness error 0.6 kappa|u0| ~{error:.1e} over the moduli sensitivity "
        f"|dln k*/dln E| = {sensitivity:.2g} at the fitted E_inf = {values['E_inf']:.3g} Pa")


def contact_bias(ds: xr.Dataset, fixed: Mapping[str, Any], omega: np.ndarray,
                 decay_length: float) -> tuple[float, str]:
    """Estimated relative bias of a contact fit against the exact model, and the reason.

    :func:`viscoforce.choice.hertz_error` at the fitted material: 2 × 1.5 |E*(ω_max)|/E_inf /
    (κδ0), measured for materials with a relaxed modulus (SLS, Prony). The power-law and
    structural materials have none (E → 0 as ω → 0): their bias is not estimated (NaN, with the
    reason), rather than extrapolated.
    """
    modes = int(ds.variables["modes"].values)
    kind = str(ds.attrs.get("material", fixed.get("material") or "sls"))
    if kind not in ("sls", "prony"):
        return math.nan, (f"not estimated: the Hertz-contact estimate needs a relaxed modulus, "
                          f"which material {kind} does not have")
    values = {n: scalar_value(ds, n) for n in parameter_names(ds)}
    return hertz_error(material_from(values, modes), float(fixed["indentation"]), decay_length,
                       float(np.max(omega)))


def warn_contact_bias(ds: xr.Dataset, fixed: Mapping[str, Any], omega: np.ndarray,
                      decay_length: float | None) -> None:
    """Estimate a contact fit's bias (:func:`contact_bias`) and warn above 1 %, in ``ds.attrs``.

    Without ``decay_length`` the estimate is made with :data:`DEFAULT_DECAY_LENGTH`, the
    paper's double layer (what the CLI's ``--debye-length`` defaults to), and says so in its
    reason and in ``attrs["validity"]``: a fit at a few decay lengths of indentation is biased
    by tens of % (issue 37: E0 −57 % at 5 nm, the paper's system), and leaving the estimate out
    because no length was given left that bias silent. Where the surface force is another
    (no double layer, another salt), give its decay length.
    """
    if decay_length is not None:
        _warn_model_bias(ds, "contact", *contact_bias(ds, fixed, omega, float(decay_length)),
                         stacklevel=4)
        return
    bias, reason = contact_bias(ds, fixed, omega, DEFAULT_DECAY_LENGTH)
    system = f"the paper's double layer of decay length {DEFAULT_DECAY_LENGTH:g} m"
    _warn_model_bias(ds, "contact", bias, reason, assumed=f"{system} (debye_length not given)",
                     stacklevel=4)
    if not math.isnan(bias):
        ds.attrs["validity"] = (f"estimated model error {bias:.2g} (relative, on the moduli) "
                                f"with {system}: debye_length was not given")


def _warn_model_bias(ds: xr.Dataset, model: str, bias: float, reason: str, *,
                     assumed: str | None = None, stacklevel: int = 3) -> None:
    """Warn (ApproximationWarning) when a fit's estimated model bias exceeds 1 %.

    A NaN bias (no estimate possible) is recorded in ``attrs["validity"]`` with its reason.
    ``assumed``: the system the estimate assumed where the caller gave none (a contact fit
    without ``debye_length``: the warning is conditional on it and says how to give it).
    """
    if math.isnan(bias):
        ds.attrs["validity"] = reason
        return
    ds.attrs["estimated_model_error"] = bias
    if bias > WARN_ERROR:
        lead = "the SVDA is about" if model == "svda" else "Hertz contact is about"
        fix = ("use model 'exact' (or 'auto')" if model == "svda" else
               "if the surface force is the double layer of that decay length, use model "
               "'exact' with --h0 or --mean-force (or 'auto' with them)")
        if assumed is not None:
            lead = f"with {assumed}, {lead}"
            fix = (f"give debye_length, the decay length of these data's surface force, for "
                   f"an estimate of their own; {fix}")
        warnings.warn(
            f"{lead} {100 * bias:.2g} % off as a model of these data: the fitted moduli are "
            f"biased by about that much ({reason}); {fix}", ApproximationWarning,
            stacklevel=stacklevel)
