"""The ``ting`` fit of one approach–retract curve: modes by the criterion, Ting's reported forms.

The model itself — the force by Ting's hereditary integral, its materials (``sls``, ``prony``,
``structural``), the contact point, baseline and drag, the data it fits (:func:`ting_data`) and
its guess — is :mod:`viscoforce.fitting.ting_model`; :func:`fit_ting` fits it (one mode or
``modes="auto"``), corrects the stderr for the residuals' autocorrelation, and
:func:`add_ting_forms` reports the structural material as Ting's power law E(t) = E0 (t/t0)^(−β)
(``ting_E0``, ``beta`` at t0 = :data:`TING_T0`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from scipy.special import digamma, gamma

from viscoforce._validation import (
    require_int,
    require_positive,
)
from viscoforce.exceptions import ParameterError
from viscoforce.fitting.base import (
    MAX_AUTO_MODES,
    MAX_MODES,
    REFERENCE_FREQUENCY,
    ModelSpec,
)
from viscoforce.fitting.curves import required_tip
from viscoforce.fitting.fit import result_dataset
from viscoforce.fitting.moduli import add_derived_moduli
from viscoforce.fitting.outcome import Outcome, residual_lag1
from viscoforce.fitting.report import carry
from viscoforce.fitting.selection import (
    Candidate,
    Tried,
    check_criterion,
    compare,
    explain,
    keep,
    mode_robustness,
)
from viscoforce.fitting.ting_model import (
    TING_FIXED,
    TING_MATERIALS,
    TING_T0,
    VELOCITY_WINDOW,
    TingData,
    ting_data,
    ting_kernel,
    ting_model,
)
from viscoforce.fitting.verdict import warn_fit
from viscoforce.physics.ting import (
    ting_error,
)

__all__ = [
    "TING_FIXED",
    "TING_MATERIALS",
    "TING_T0",
    "TingData",
    "add_ting_forms",
    "fit_ting",
    "ting_data",
    "ting_kernel",
    "ting_model",
]

# ── fitting one curve ───────────────────────────────────────────────────────────────────────


def _select(data: TingData, modes: int | str, criterion: str, fixed: Mapping[str, Any]
            ) -> tuple[Tried, list[Tried]]:
    """The kept fit and the candidates (``modes="auto"``: 1, 2, … prony modes by ``criterion``).

    The loop and rule are :mod:`viscoforce.fitting.selection`'s (the lowest criterion), each fit
    with the AR(1) stderr correction before it is scored.
    """
    check_criterion(criterion)
    if modes == "auto":
        if fixed.get("material") != "prony":
            raise ParameterError("modes='auto' needs material='prony'")
        counts: Sequence[int] = range(1, MAX_AUTO_MODES + 1)
    else:
        counts = [require_int("modes", modes, 1)]
        if counts[0] > MAX_MODES:
            raise ParameterError(f"modes must be an integer in [1, {MAX_MODES}] or 'auto', got "
                                 f"{modes!r}")
    family = [Candidate(f"{n} mode{'s' if n > 1 else ''}",
                        lambda n=n: ting_model(ModelSpec("ting", n, fixed))) for n in counts]

    def corrected(outcome: Outcome) -> None:
        if not math.isfinite(outcome.lag1) and not getattr(outcome.model, "autocorrelated",
                                                            False):
            _autocorrelation(outcome)

    tried = compare([family], data, criterion, after=corrected, robust=mode_robustness)
    return keep(tried, criterion), tried


def _autocorrelation(outcome: Outcome) -> None:
    """The AR(1) stderr correction of measured curve fits (as ``hertz``), in place."""
    outcome.lag1 = residual_lag1(np.asarray(outcome.result.residual, dtype=float),
                                 outcome.data.x)
    if outcome.covariance is not None:
        outcome.covariance = outcome.covariance * outcome.stderr_factor ** 2


def fit_ting(curves: xr.Dataset, *, curve: int = 0, segment: int | None = None,
             tip: Any = None, material: str = "sls", modes: int | str = 1,
             criterion: str = "bic", drag: float | None = None, fit_drag: bool = False,
             contact_point: float | None = None, reference_frequency: float | None = None,
             newtonian: bool | None = None, poisson: float | None = None,
             profile: bool = False, sample_height: float | None = None,
             sample_base: str | None = None) -> xr.Dataset:
    """Fit Ting's model to the approach and retract of one measured force curve.

    Parameters
    ----------
    curves : xarray.Dataset
        A curves dataset (:mod:`viscoforce.schema.curves`).
    curve : int
        The curve (pixel), from 0.
    segment : int, optional
        One segment only (e.g. the approach); default approach through retract
        (:func:`ting_data`).
    tip : Tip or str, optional
        The tip (``"paraboloid:5um"``); default the file's own when it records one.
    material : {"sls", "prony", "structural"}
        The material (module docstring).
    modes : int or "auto"
        Prony modes (material ``prony``).
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.
    drag : float, optional
        Fixed viscous drag B [N·s/m] (default 0).
    fit_drag : bool
        Fit the drag instead (parameter ``drag``; the fit-result schema must know its unit).
    contact_point : float, optional
        Fixed contact point [m] (tip position); default fitted.
    reference_frequency : float, optional
        f_ref [Hz] of ``E_ref`` (structural; default 1 Hz).
    newtonian : bool, optional
        Structural: fit the Newtonian μ (default True; False: Ting's pure power law).
    poisson : float, optional
        Poisson's ratio of ``<name>_young`` / ``<name>_shear`` (default 0.5).
    sample_height : float, optional
        The sample's thickness [m] on its rigid support: Ting's integral over the layer's law
        (:mod:`viscoforce.fitting.ting_model`); ``attrs["bottom_effect_factor"]`` is the force
        factor at the deepest fitted indentation.
    sample_base : {"bonded", "sliding"}, optional
        With ``sample_height``: the layer bonded to (default) or sliding on its support.
    profile : bool
        Profile-likelihood identifiability (slow: hundreds of model evaluations); default the
        local test.

    Returns
    -------
    xarray.Dataset
        The fit result: parameters with stderr (AR(1)-corrected), ``fit_force`` over ``time``,
        Young's and shear moduli, and for ``structural`` Ting's ``ting_E0`` and ``beta``
        (:func:`add_ting_forms`); attrs ``ting_error`` (the discretisation error estimate of
        :func:`viscoforce.physics.ting.ting_error` at the best fit, max over the curve [N]) and
        ``contact_time``, ``turning_time`` [s].

    Raises
    ------
    ParameterError
        No tip, no approach, bad options.
    ConvergenceError
        No start converged.
    """
    tip = required_tip(curves, tip, "ting")
    data = ting_data(curves, curve=curve, segment=segment)
    fixed: dict[str, Any] = {"tip": tip, "position_trace": data.position_trace,
                             "material": material, "drag": drag, "fit_drag": fit_drag or None,
                             "contact_point": contact_point,
                             "reference_frequency": reference_frequency,
                             "newtonian": newtonian, "sample_height": sample_height,
                             "sample_base": sample_base}
    fixed = {k: v for k, v in fixed.items() if v is not None}
    kept, tried = _select(data, modes, criterion, fixed)
    best = kept.outcome
    selection = [{"modes": t.modes, **t.outcome.criterion} for t in tried if t.outcome]
    ds = result_dataset(best, data, selection=selection if modes == "auto" else None,
                        profile=profile)
    if modes == "auto":
        ds.attrs["criterion"] = criterion
        ds.attrs["explanation"] = explain(tried, kept, criterion, 0.0,
                                          "modes of model 'ting'").explanation
    ds = _describe(ds, best, data)
    if sample_height is not None:
        from viscoforce.physics.bottom_effect import force_factor
        from viscoforce.physics.tips import tip_from

        plain = tip_from(tip)
        deepest = max(float(np.max(data.position)) - float(ds["contact_point"] if
                      "contact_point" in ds else contact_point), 0.0)
        ds.attrs["bottom_effect_factor"] = 1.0 if deepest <= 0 else float(
            force_factor(plain, deepest, sample_height, bonded=sample_base != "sliding"))
    warn_fit(ds)
    ds = add_derived_moduli(ds, poisson)
    return add_ting_forms(ds) if material == "structural" else ds


def _describe(ds: xr.Dataset, best: Outcome, data: TingData) -> xr.Dataset:
    """Attrs of the contact (times), the discretisation error and what the model assumes."""
    model, values = best.model, best.values
    fixed = model.spec.fixed
    t, z = data.position_trace
    c = values.get("contact_point", fixed.get("contact_point"))
    kernel = ting_kernel(fixed["material"], values, model.spec.modes,
                         reference_frequency=float(fixed.get("reference_frequency", 1.0)))
    err = ting_error(t, z, c, fixed["tip"], kernel)
    out = carry(ds, ds.copy())
    turning = int(np.argmax(z))
    contact = np.flatnonzero(z[:turning + 1] > c)
    out.attrs.update(
        ting_error=float(np.max(err)), turning_time=float(t[turning]),
        contact_time=float(t[contact[0]]) if contact.size else math.nan,
        max_indentation=float(max(z[turning] - c, 0.0)),
        validity=("Ting's hereditary integral: a linear viscoelastic half-space, no adhesion or "
                  "surface forces, one loading-unloading cycle; ting_error is its "
                  "discretisation error estimate [N] (max over the curve)"),
        velocity_method=f"Savitzky-Golay derivative (order 2, {VELOCITY_WINDOW} samples) of the "
                        "tip position")
    return out


# ── Ting's power-law form ───────────────────────────────────────────────────────────────────


def add_ting_forms(ds: xr.Dataset, *, t0: float = TING_T0) -> xr.Dataset:
    """Ting's E0 (at t0) and β of a structural fit: E(t) = E0 (t/t0)^(−β) with β = α.

    E0 = E_ref/(Γ(1 − α)(2π f_ref t0)^α); its stderr from those of E_ref and α and their
    correlation (∂ln E0/∂α = ψ(1 − α) − ln(2π f_ref t0)). Adds ``ting_E0`` [Pa] (paper
    convention), ``ting_E0_young`` (Young's, with ``attrs["poisson"]``, default 0.5) and
    ``beta``, each with ``_stderr``. Works on a single fit or a map (elementwise).

    Parameters
    ----------
    ds : xarray.Dataset
        A ``ting`` (or ``contact``) fit with material structural (``E_ref``, ``alpha``).
    t0 : float
        Ting's reference time [s], > 0 (default 1 s).

    Returns
    -------
    xarray.Dataset
        ``ds`` with the variables above and ``attrs["ting_t0"]``.

    Raises
    ------
    ParameterError
        ``ds`` lacks ``E_ref`` or ``alpha``, or ``t0`` is not > 0.
    """
    from viscoforce.physics.tips import DEFAULT_POISSON, young_from_paper

    t0 = require_positive("t0", t0)
    if "E_ref" not in ds.variables or "alpha" not in ds.variables:
        raise ParameterError("add_ting_forms needs a structural fit (E_ref and alpha)")
    f_ref = float(ds.attrs.get("reference_frequency", REFERENCE_FREQUENCY))
    e_ref = np.asarray(ds["E_ref"].values, dtype=float)
    alpha = np.asarray(ds["alpha"].values, dtype=float)
    s_e = np.asarray(ds["E_ref_stderr"].values, dtype=float)
    s_a = np.asarray(ds["alpha_stderr"].values, dtype=float)
    names = [str(n) for n in ds["param_i"].values]
    rho = np.asarray(ds["correlation"].isel(param_i=names.index("E_ref"),
                                            param_j=names.index("alpha")).values, dtype=float)
    rho = np.where(np.isfinite(rho), rho, 0.0)
    x = 2.0 * math.pi * f_ref * t0
    e0 = e_ref / (gamma(1.0 - alpha) * x**alpha)
    dlog_a = digamma(1.0 - alpha) - math.log(x)
    rel = np.sqrt(np.maximum((s_e / e_ref) ** 2 + (dlog_a * s_a) ** 2
                             + 2.0 * rho * (s_e / e_ref) * dlog_a * s_a, 0.0))
    nu = float(ds.attrs.get("poisson", DEFAULT_POISSON))
    dims = ds["E_ref"].dims

    def var(values: np.ndarray, unit: str, text: str) -> xr.DataArray:
        return xr.DataArray(values if values.ndim else float(values), dims=dims,
                            attrs={"units": unit, "long_name": text})

    out = ds.assign(
        ting_E0=var(e0, "Pa", f"Ting's E0 = E(t0 = {t0:g} s) of E(t) = E0 (t/t0)^-beta (paper "
                              "convention)"),
        ting_E0_stderr=var(e0 * rel, "Pa", "standard error of ting_E0"),
        ting_E0_young=var(young_from_paper(e0, nu), "Pa",
                          f"Young's Ting E0 (nu = {nu:g})"),
        ting_E0_young_stderr=var(young_from_paper(e0 * rel, nu), "Pa",
                                 "standard error of ting_E0_young"),
        beta=var(alpha.copy(), "1", "Ting's power-law exponent beta = alpha"),
        beta_stderr=var(s_a.copy(), "1", "standard error of beta"))
    out.attrs["ting_t0"] = t0
    return carry(ds, out)
