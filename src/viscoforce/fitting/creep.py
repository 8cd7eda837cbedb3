"""The ``creep`` fit of one constant-force pause: Lee–Radok with a tip, exponentials without.

With a tip (given, or the one the file records) :func:`fit_creep` fits Lee–Radok's creep integral
of the recorded force (:mod:`viscoforce.fitting.creep_model`): ``tau`` (the creep time of Eq. 3),
``E0``, ``E_inf`` (the paper's E; n modes as the ``exact`` model) and ``contact_point``, with
stderr that carry the tip position's noise and the recorded force's
(:func:`~viscoforce.fitting.creep_model.propagated_covariance`), Young's and shear moduli
(:func:`~viscoforce.fitting.moduli.add_derived_moduli`), and ``attrs["contact_area_decrease"]``
(where the contact shrinks, Lee–Radok no longer holds: a ModelValidityWarning above
:data:`AREA_DECREASE_WARN`).

Without a tip it keeps the phenomenological z_inf + Σ dz_i e^{−t/τ_i} of the tip position (the
names of old results), and says — ``attrs["validity"]`` and a
:class:`~viscoforce.exceptions.ModelValidityWarning` — that its τ_i are the creep times only for
a flat punch, biased for curved tips, and that giving the tip fixes it.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import DataWarning, ModelValidityWarning, ParameterError
from viscoforce.fitting.base import MAX_AUTO_MODES, MAX_MODES
from viscoforce.fitting.creep_model import (
    CreepData,
    contact_area_decrease,
    lee_radok_data,
    propagated_covariance,
)
from viscoforce.fitting.data import FitData
from viscoforce.fitting.fit import fit_data, result_dataset
from viscoforce.fitting.models import make_model
from viscoforce.fitting.models.creep import LEE_RADOK, PHENOMENOLOGICAL
from viscoforce.fitting.moduli import add_derived_moduli
from viscoforce.fitting.outcome import Outcome, fit_once
from viscoforce.fitting.segments import creep_data
from viscoforce.fitting.selection import (
    Candidate,
    Tried,
    check_criterion,
    compare,
    explain,
    keep,
    mode_robustness,
)
from viscoforce.fitting.verdict import warn_fit

__all__ = ["AREA_DECREASE_WARN", "fit_creep"]

#: How the Lee–Radok fit's stderr are found (``attrs["stderr_method"]``).
STDERR_METHOD = (
    "both noises propagated: the tip position's (residual variance less the force noise's "
    "share, times the AR(1) factor sqrt((1 + rho1)/(1 - rho1)) of the residuals' lag-1 "
    "autocorrelation beyond the force noise's) and the recorded force's (white noise "
    "force_noise, through the smoothing and the creep integral, by its adjoint)")
#: Relative fall of the load shape ψ below its running maximum above which the fit warns that
#: the contact area shrank (Lee–Radok's integral assumes it grows; the error is of this order).
AREA_DECREASE_WARN = 0.01


def _file_tip(curves: xr.Dataset) -> Any:
    """The tip the file records (``tip_shape`` attrs), or None (as ``curves.file_tip``)."""
    from viscoforce.physics.tips import Tip

    return Tip.from_attrs(curves.attrs) if "tip_shape" in curves.attrs else None


def _propagated(outcome: Outcome, data: CreepData) -> Outcome:
    """``outcome`` with the covariance of both noises (:func:`propagated_covariance`)."""
    outcome.covariance = propagated_covariance(outcome.model, data, outcome.values)[0]
    return outcome


def _select(data: CreepData, modes: int | str, criterion: str, fixed: dict[str, Any]
            ) -> tuple[Tried, list[Tried]]:
    """The kept Lee–Radok fit and the candidates (``modes="auto"``: 1, 2, … by ``criterion``).

    The loop, rule and robustness test of :mod:`viscoforce.fitting.selection`, as
    :func:`~viscoforce.fitting.fit.select_tried`, with every fit's covariance (the block halves'
    included) the propagated one, so that the robustness test judges the times by the stderr
    the result reports; the halves split the pause, each keeping the loading ramp (the
    halves' estimates then share its noise: the test is conservative).
    """
    check_criterion(criterion)
    if modes == "auto":
        counts: range | list[int] = range(1, MAX_AUTO_MODES + 1)
    elif isinstance(modes, bool) or not isinstance(modes, int) or not 1 <= modes <= MAX_MODES:
        raise ParameterError(f"modes must be an integer in [1, {MAX_MODES}] or 'auto', got "
                             f"{modes!r}")
    else:
        counts = [modes]
    family = [Candidate(f"{n} mode{'s' if n > 1 else ''}",
                        lambda n=n: make_model("creep", n, **fixed)) for n in counts]

    loading = np.asarray(data.x) < 0

    def robust(outcome: Outcome) -> str | None:
        def refit(half: FitData) -> Outcome:
            # each half keeps the whole loading ramp: it alone pins the contact point and E0
            # (a half without it is a different, ill-posed fit); the halves split the pause
            chosen = loading | np.isin(data.x, half.x)
            part = dataclasses.replace(data, x=data.x[chosen], y=data.y[chosen])
            return _propagated(fit_once(outcome.model, part, settle=False), part)

        return mode_robustness(outcome, refit)

    tried = compare([family], data, criterion, after=lambda o: _propagated(o, data),
                    robust=robust)
    return keep(tried, criterion), tried


def fit_creep(curves: xr.Dataset, *, curve: int = 0, segment: int | None = None,
              tip: Any = None, contact_point: float | None = None,
              contact_window: tuple[float, float] | None = None, modes: int | str = 1,
              criterion: str = "bic", poisson: float | None = None) -> xr.Dataset:
    """Fit the creep of the tip position on the constant-force pause of one curve.

    Parameters
    ----------
    curves : xarray.Dataset
        A curves dataset (:mod:`viscoforce.schema.curves`).
    curve : int
        The curve (pixel), from 0.
    segment : int, optional
        The pause (from 0, file order); default the first constant-force pause after the
        approach.
    tip : Tip or str, optional
        The tip (``"paraboloid:5um"``, ``"cone:20"``, ``"flat:1um"`` …); default the file's own.
        Without either, the phenomenological fit (module docstring).
    contact_point : float, optional
        The contact point [m] (tip position), fixed; default fitted (with a tip).
    contact_window : (float, float), optional
        Where the fitted contact point may lie [m]; default the tip positions of the data.
    modes : int or "auto"
        Creep modes (``"auto"``: by ``criterion``).
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.
    poisson : float, optional
        Poisson's ratio in [0, 0.5] of ``<name>_young`` / ``<name>_shear`` (default 0.5; with a
        tip only).

    Returns
    -------
    xarray.Dataset
        The fit result with ``fit_tip_position`` over ``time`` [s] from the start of the pause
        (< 0 on the loading ramp); ``attrs["creep_form"]`` ``"lee-radok"`` or
        ``"phenomenological"``, ``attrs["validity"]``; with a tip also ``creep_force``,
        ``force_baseline``, ``loading_points``, ``contact_area_decrease``.

    Raises
    ------
    ParameterError
        No pause, too few samples, bad options, contact inputs or poisson without a tip, or no
        approach and no contact point with a tip.
    """
    tip = tip if tip is not None else _file_tip(curves)
    if tip is None:
        given = [n for n, v in (("contact_point", contact_point),
                                ("contact_window", contact_window), ("poisson", poisson))
                 if v is not None]
        if given:
            raise ParameterError(f"{', '.join(given)} need the tip (tip=, --tip): without one "
                                 "the creep fit is phenomenological and reports no moduli")
        ds = fit_data(creep_data(curves, curve=curve, segment=segment), "creep", modes=modes,
                      criterion=criterion)
        ds.attrs.update(creep_form="phenomenological", validity=PHENOMENOLOGICAL)
        warnings.warn(f"creep without a tip: {PHENOMENOLOGICAL}", ModelValidityWarning,
                      stacklevel=2)
        warn_fit(ds, stacklevel=3)
        return ds
    from viscoforce.physics.tips import tip_from

    tip = tip_from(tip)
    data = lee_radok_data(curves, tip, curve=curve, segment=segment,
                          contact_point=contact_point)
    for note in data.notes:
        warnings.warn(note, DataWarning, stacklevel=2)
    fixed = {"tip": tip, "creep_history": data.history, "contact_point": contact_point,
             "contact_window": contact_window}
    kept, tried = _select(data, modes, criterion,
                          {k: v for k, v in fixed.items() if v is not None})
    best = kept.outcome
    _, noise = propagated_covariance(best.model, data, best.values)
    selection = [{"modes": t.modes, **t.outcome.criterion} for t in tried if t.outcome]
    ds = result_dataset(best, data, selection=selection if modes == "auto" else None,
                        profile=False)
    if modes == "auto":
        ds.attrs["criterion"] = criterion
        ds.attrs["explanation"] = explain(tried, kept, criterion, 0.0,
                                          "modes of model 'creep'").explanation
    if noise:
        ds.attrs.update(
            residual_lag1_total=ds.attrs.get("residual_lag1", math.nan), **noise,
            effective_samples=data.n_values * (1 - noise["residual_lag1"]) / (
                1 + noise["residual_lag1"]),
            stderr_method=STDERR_METHOD)
    decrease = contact_area_decrease(data.history, best.values, best.model.spec.modes)
    ds.attrs.update(creep_form="lee-radok", validity=LEE_RADOK,
                    contact_area_decrease=decrease)
    if decrease > AREA_DECREASE_WARN:
        warnings.warn(
            f"the contact area shrinks by {100 * decrease:.2g} % during the pause (the load "
            "falls faster than the sample creeps, e.g. the controller's overshoot released): "
            "Lee-Radok's creep integral assumes a growing contact (Ting's correction is not "
            "made), so take the fitted moduli and times as approximate to about that much",
            ModelValidityWarning, stacklevel=2)
    warn_fit(ds, stacklevel=3)
    return add_derived_moduli(ds, poisson)
