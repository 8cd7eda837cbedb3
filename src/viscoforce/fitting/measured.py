"""``fit_spectrum(..., "auto")`` on measured data: the contact material the data support.

A measured spectrum in contact (a ``mean_indentation`` from the contact point, or an
``indentation`` given) has no position h̄0 of the theory's system, so the theory chooser
(svda → contact → exact by model error) does not apply. This chooser fits the contact model
k* = E*(ω)·√(Rδ0) + iωB with each material family and compares them by the information
criterion (BIC by default; AIC with ``criterion="aic"``):

- ``sls`` (3 parameters) and ``prony n`` (2n + 1; n = 2, 3, … while the criterion improves, at
  most :data:`~viscoforce.fitting.base.MAX_AUTO_MODES`, leaving at least :data:`MIN_DOF`
  degrees of freedom);
- ``power-law``: the paper's liquid-like creep C(t) = 1/E0 + C1 t^m (3), and ``power-law+mu``
  with a Newtonian viscosity in parallel (4);
- ``structural``: power-law rheology with a Newtonian term, E* = E_ref (iω/ω_ref)^α + iωμ (3).

Rule: the candidate with the lowest criterion is the best; the one kept is the SIMPLEST (fewest
parameters; then the lowest criterion) whose criterion is within :data:`MARGIN` of the best.
ΔBIC = 6 is "strong" evidence on the Kass–Raftery scale (a Bayes factor of ≈ 20): a richer
model must beat a simpler one by that much to be kept. With ``criterion="aic"`` the same margin
is used on the AIC scale, a heuristic (ΔAIC 6: the simpler model is e^−3 ≈ 5 % as likely). The
explanation lists every candidate with its criterion, reduced χ² and p-value (when the data
carry stderr).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ConvergenceError, ModelValidityError, ParameterError
from viscoforce.fitting.base import MAX_AUTO_MODES
from viscoforce.fitting.data import _data_indentation, spectrum_data
from viscoforce.fitting.fit import AUTO_CHOOSERS, _check_modes, result_dataset
from viscoforce.fitting.model_error import validity_note, warn_contact_bias
from viscoforce.fitting.models import check_fixed, make_model
from viscoforce.fitting.outcome import Outcome
from viscoforce.fitting.report import carry
from viscoforce.fitting.selection import Candidate, check_criterion, compare, explain, keep
from viscoforce.fitting.verdict import warn_fit

#: Criterion margin of the measured-data chooser: a richer candidate is kept only when its
#: criterion beats every simpler one by more than this (ΔBIC 6: strong evidence).
MARGIN = 6.0
#: Fewest degrees of freedom a candidate must leave (a χ² test needs some).
MIN_DOF = 2
#: Material families compared (``material=`` restricts the comparison to one).
FAMILIES = ("sls", "prony", "power-law", "structural")
#: Inputs the measured-data chooser takes.
INPUTS = ("radius", "tip", "indentation", "drag", "material", "reference_frequency",
          "debye_length", "sample_height", "sample_base")


def _candidates(family: str, modes: int | str) -> list[tuple[str, int, dict[str, Any]]]:
    """(label, modes, model inputs) of one family, in order of size (sls is prony 1)."""
    if family in ("sls", "prony"):
        counts = range(1, MAX_AUTO_MODES + 1) if modes == "auto" else [int(modes)]
        if family == "sls":
            counts = [n for n in counts if n == 1]
        return [("sls" if n == 1 else f"prony {n}", n, {"material": "prony" if n > 1 else "sls"})
                for n in counts]
    if family == "power-law":
        return [("power-law", 1, {"material": "power-law"}),
                ("power-law+mu", 1, {"material": "power-law", "newtonian": True})]
    return [("structural", 1, {"material": "structural"})]


def fit_measured_auto(spectrum: xr.Dataset, *, modes: int | str = "auto", criterion: str = "bic",
                      weights: str | None = None, profile: bool | str = "auto",
                      **fixed: Any) -> xr.Dataset:
    """Fit the contact material the data support best (module docstring).

    Parameters
    ----------
    spectrum : xarray.Dataset
        One measured spectrum over ``omega`` in contact.
    modes : int or "auto"
        Modes of the Prony family (1: sls only); default "auto" (1, 2, … by the criterion).
    criterion : {"bic", "aic"}
        The information criterion.
    weights : {"stderr", "relative"}, optional
        Residual weights (:func:`viscoforce.fitting.data.spectrum_data`).
    profile : bool or "auto"
        Limits and identifiability of the kept fit (:data:`viscoforce.fitting.fit.PROFILE_CHOICES`).
    **fixed
        ``tip`` (a :class:`viscoforce.physics.tips.Tip` or its text) or ``radius`` [m] (the
        paper's sphere; one is required), ``indentation`` [m] (default: the data's median
        ``mean_indentation``), ``drag`` [N·s/m], ``material`` (one family only: sls, prony,
        power-law, structural), ``reference_frequency`` [Hz] (structural), ``debye_length`` [m]
        (the Hertz validity estimate of the kept fit).

    Returns
    -------
    xarray.Dataset
        The kept fit's result; ``attrs["explanation"]`` lists the candidates, ``attrs["material"]``
        and ``attrs["candidate"]`` name the one kept; ``selection_label``, ``selection_bic``,
        ``selection_aic``, ``selection_redchi``, ``selection_pvalue`` and ``selection_parameters``
        over ``candidate``.

    Raises
    ------
    TypeError
        An input this chooser cannot honour (e.g. ``problem``, ``newtonian``): it names them.
    ParameterError
        No radius, a bad material, modes or criterion.
    ModelValidityError
        No indentation (pre-contact data: give position or mean_force for the theory chooser).
    """
    unknown = sorted(set(fixed) - set(INPUTS))
    if unknown:
        raise TypeError(
            f"model 'auto' on measured data (no position or mean_force) takes "
            f"{', '.join(INPUTS)}; it cannot honour {', '.join(unknown)} (give position or "
            "mean_force for the theory chooser, or name the model)")
    check_criterion(criterion)
    if fixed.get("radius") is None and fixed.get("tip") is None:
        raise ParameterError("model 'auto' on measured data needs the tip: tip= (--tip "
                             "sphere:R | paraboloid:R | cone:ANGLE | pyramid:ANGLE | flat:RADIUS) "
                             "or radius= (--R, the paper's sphere)")
    material = fixed.pop("material", None)
    if material is not None and material not in FAMILIES:
        raise ParameterError(f"material must be one of {', '.join(FAMILIES)} (or None: all), "
                             f"got {material!r}")
    modes = _check_modes("contact", modes)
    if modes != "auto" and modes > 1 and material not in (None, "prony"):
        raise ParameterError(f"modes={modes} applies to the prony family; material "
                             f"{material!r} has one")
    decay = fixed.pop("debye_length", None)
    base = check_fixed("contact", {k: v for k, v in fixed.items() if v is not None})
    data = spectrum_data(spectrum, weights=weights)
    if base.get("indentation") is None:
        base["indentation"] = _data_indentation(spectrum, data)
    families = (material,) if material else ("prony", "power-law", "structural")
    tried = compare(
        [[Candidate(label, lambda n=n, inputs=inputs: make_model("contact", n, **base, **inputs),
                    inputs) for label, n, inputs in _candidates(family, modes)]
         for family in families],
        data, criterion, min_dof=MIN_DOF, on_failure="skip",
        failures=(ConvergenceError, ModelValidityError, ParameterError))
    if not any(t.outcome for t in tried):
        raise ConvergenceError("model 'auto' could fit no contact material: " + "; ".join(
            f"{t.label} {t.note}" for t in tried))
    chosen = keep(tried, criterion, MARGIN)
    label, outcome, inputs = chosen.label, chosen.outcome, chosen.inputs
    kept = [(t.label, t.outcome, t.inputs) for t in tried if t.outcome is not None]
    choice = explain(tried, chosen, criterion, MARGIN, "measured data: contact materials")
    ds = result_dataset(outcome, data, profile=profile)
    ds = _with_selection(ds, kept, criterion)
    ds.attrs.update(material=str(inputs["material"]), candidate=label, criterion=criterion,
                    selection_margin=MARGIN, explanation=choice.explanation)
    if inputs.get("newtonian"):
        ds.attrs["newtonian"] = 1
    warn_contact_bias(ds, {**base, **inputs}, data.x, decay)  # the paper's 1 nm if not given
    ds.attrs["validity"] = validity_note("contact", ds)
    ds = _near_ties(ds, tried, chosen, criterion)
    warn_fit(ds, stacklevel=5)
    return ds


def _near_ties(ds: xr.Dataset, tried, chosen, criterion: str) -> xr.Dataset:
    """The budget's ``model`` source: the other candidates within :data:`MARGIN` of the best.

    Their values of the parameters they share with the kept one, as shifts (the largest in size
    per parameter over the near-ties); the data do not settle the choice among them.
    """
    from viscoforce.fitting.budget import add_budget

    best = min(t.score(criterion) for t in tried if t.outcome is not None and t.robust)
    ties = [t for t in tried if t.outcome is not None and t is not chosen
            and t.score(criterion) <= best + MARGIN]
    shifts: dict[str, float] = {}
    for t in ties:
        for name, value in t.outcome.values.items():
            if name in chosen.outcome.values:
                shift = float(value) - float(chosen.outcome.values[name])
                if abs(shift) > abs(shifts.get(name, 0.0)):
                    shifts[name] = shift
    if not shifts:
        return ds
    return add_budget(ds, {"model": shifts}, {"model": "the candidates within "
                      f"{criterion.upper()} {MARGIN:g} of the best: "
                      + ", ".join(t.label for t in ties)})


def _with_selection(ds: xr.Dataset, kept: list[tuple[str, Outcome, dict[str, Any]]],
                    criterion: str) -> xr.Dataset:
    def column(values: list[Any], unit: str, long_name: str) -> tuple[str, Any, dict[str, str]]:
        return ("candidate", np.asarray(values), {"units": unit, "long_name": long_name})

    return carry(ds, ds.assign(
        selection_label=("candidate", np.asarray([k[0] for k in kept], dtype=str),
                         {"long_name": "candidate material (and modes)"}),
        selection_modes=column([k[1].model.spec.modes for k in kept], "1",
                               "modes of the candidate"),
        selection_parameters=column([k[1].n_free for k in kept], "1",
                                    "free parameters of the candidate"),
        selection_aic=column([k[1].criterion["aic"] for k in kept], "1", "AIC of the candidate"),
        selection_bic=column([k[1].criterion["bic"] for k in kept], "1", "BIC of the candidate"),
        selection_redchi=column([float(k[1].result.redchi) for k in kept], "1",
                                "reduced chi-square of the candidate"),
        selection_pvalue=column([k[1].pvalue for k in kept], "1",
                                "chi-square p-value of the candidate (NaN: stderr unknown)")))


AUTO_CHOOSERS["measured"] = fit_measured_auto  # fit_spectrum(model="auto") reaches it here
