"""What a single fit says about itself: goodness of fit, identifiability and autocorrelation.

:func:`warn_fit` issues the warnings of one fit's result dataset (after
:func:`settle_nuisance_codes`: the nuisance parameters of a force curve are judged by
:data:`NUISANCE_RULE`, which maps share through :func:`settle_nuisance`); :func:`bound_text`
words a parameter the data bound on one side only ("E0 > 2.1e+04 Pa"). The hertz model's checks
of its own data are :mod:`viscoforce.fitting.hertz_checks`.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import (
    AccuracyWarning,
    DataWarning,
    GoodnessOfFitWarning,
)
from viscoforce.schema import parameter_names

#: χ² p-value below which a fit with known stderr warns that the model does not fit the data.
PVALUE_WARN = 1e-3
#: Lag-1 residual autocorrelation above which a curve fit warns (its stderr are corrected).
LAG1_WARN = 0.5


def scalar_value(ds: xr.Dataset, name: Any) -> float:
    """A scalar variable of ``ds`` as a float (read from the Variable: no DataArray is built)."""
    return float(ds.variables[str(name)].values)


def bound_text(ds: xr.Dataset, name: str) -> str | None:
    """How a parameter that is not determined should be reported (None when it is determined).

    ``"E0 > 2.1e+04 Pa"`` (lower bound only), ``"mu < 3.2 Pa s"``, ``"tau not determined"``.
    """
    if "identifiability" not in ds.variables:
        return None
    codes = dict(zip(parameter_names(ds),
                     np.asarray(ds["identifiability"].values).reshape(-1).tolist(), strict=True))
    code = int(codes.get(name, 0))
    unit = str(ds[name].attrs.get("units", ""))
    if code == 1 and f"{name}_lower" in ds.variables:
        return f"{name} > {scalar_value(ds, f'{name}_lower'):.3g} {unit}".rstrip()
    if code == 2 and f"{name}_upper" in ds.variables:
        return f"{name} < {scalar_value(ds, f'{name}_upper'):.3g} {unit}".rstrip()
    if code == 0:
        return None
    return f"{name} not determined"


#: Parameters that place a force curve rather than describe the material (hertz, ting): judged
#: by :data:`NUISANCE_RULE`, not by the local test's stderr > |value|
#: (:mod:`viscoforce.fitting.identify`'s docstring says why).
NUISANCE = ("contact_point", "baseline", "baseline_slope")
#: The rule of :func:`settle_nuisance`, in words (a map's ``quality_rule`` quotes it).
NUISANCE_RULE = (
    "a nuisance parameter (contact_point, baseline, baseline_slope) is determined when it has "
    "a finite stderr and did not end on a bound: stderr > |value| does not apply to it, since "
    "its value counts from an arbitrary zero or is naturally 0, and its uncertainty is in the "
    "moduli's stderr already")


def settle_nuisance(codes: Mapping[str, int], stderr: Mapping[str, float | None],
                    at_bound: Sequence[str], keep: Sequence[str] = ()) -> dict[str, int]:
    """``codes`` with the local test's verdict on the :data:`NUISANCE` parameters replaced.

    A nuisance parameter with a finite stderr that did not end on a bound is determined (0);
    one without, or on a bound, not determined (3) (:data:`NUISANCE_RULE`). The other
    parameters, and those in ``keep`` (codes from the profile likelihood, or set by a check of
    the model's own), keep their codes.
    """
    out = {str(n): int(c) for n, c in codes.items()}
    for name in out:
        if name not in NUISANCE or name in keep:
            continue
        err = stderr.get(name)
        bounded = err is not None and math.isfinite(err) and name not in at_bound
        out[name] = 0 if bounded else 3
    return out


#: ``attrs`` of a fit result naming the parameters a check of the model's own set to not
#: determined (", "-joined; :func:`viscoforce.fitting.hertz_checks.hertz_checks`):
#: :func:`settle_nuisance_codes` leaves them so.
CHECKED_ATTR = "not_determined_by_checks"
#: :data:`NUISANCE_RULE` in a few words (``attrs["identifiability_method"]``).
NUISANCE_RULE_SHORT = "a finite stderr and not on a bound; stderr > |value| does not apply"


def listed_names(ds: xr.Dataset, key: str) -> list[str]:
    """The names of a ", "-joined attribute of ``ds`` ("none" or absent: none)."""
    return [n for n in str(ds.attrs.get(key, "")).split(", ") if n and n != "none"]


def settle_nuisance_codes(ds: xr.Dataset) -> None:
    """Judge a fit result's nuisance parameters by :data:`NUISANCE_RULE`, in place.

    The codes of the local test (not those of the profile likelihood, ``profiled`` = 1, nor
    those a check set, :data:`CHECKED_ATTR`) of the :data:`NUISANCE` parameters become
    :func:`settle_nuisance`'s; a change is added to ``attrs["identifiability_method"]``. The
    local test itself (:func:`viscoforce.fitting.fit.local_identifiability`) applies
    stderr > |value| to every parameter; the profile and the curvature's limits
    (:mod:`viscoforce.fitting.identify`) already judge a parameter that is not positive by
    whether it is bounded.
    """
    names = parameter_names(ds)
    if "identifiability" not in ds.variables or not any(n in NUISANCE for n in names):
        return
    codes = dict(zip(names, np.asarray(ds.variables["identifiability"].values).reshape(-1)
                     .tolist(), strict=True))
    profiled = (np.asarray(ds.variables["profiled"].values).reshape(-1).tolist()
                if "profiled" in ds.variables else [0] * len(names))
    keep = [*(n for n, p in zip(names, profiled, strict=True) if int(p)),
            *listed_names(ds, CHECKED_ATTR)]
    stderr = {n: scalar_value(ds, f"{n}_stderr") for n in names}
    settled = settle_nuisance(codes, stderr, listed_names(ds, "at_bound"), keep=keep)
    changed = [n for n in names if settled[n] != int(codes[n])]
    if not changed:
        return
    ds["identifiability"] = ds["identifiability"].copy(
        data=np.array([settled[n] for n in names], dtype=ds["identifiability"].dtype))
    method = str(ds.attrs.get("identifiability_method", ""))
    ds.attrs["identifiability_method"] = (
        f"{method}; {', '.join(changed)} by the nuisance rule ({NUISANCE_RULE_SHORT})"
        .lstrip("; "))


def warn_unidentified(ds: xr.Dataset, *, stacklevel: int = 3) -> list[str]:
    """Warn (AccuracyWarning) about fitted parameters the data do not determine; return them.

    With the profile likelihood (``identifiability``): a parameter bounded on one side only is
    reported as that bound (e.g. "E0 > 2e4 Pa": the likelihood is flat towards larger values),
    one flat on both sides as not determined. Without it, the local test: stderr above the
    value, or none (the covariance is singular); for the nuisance parameters
    (:data:`NUISANCE_RULE`) no stderr only.
    """
    names = parameter_names(ds)
    if "identifiability" in ds.variables:
        codes = np.asarray(ds.variables["identifiability"].values).reshape(-1)
        bad = [n for n, c in zip(names, codes, strict=True) if int(c) != 0]
    else:
        bad = [n for n in names
               if not np.isfinite(scalar_value(ds, f"{n}_stderr")) or (
                   n not in NUISANCE
                   and abs(scalar_value(ds, f"{n}_stderr")) > abs(scalar_value(ds, n)))]
    if bad:
        shown = "; ".join(
            f"{bound_text(ds, n) or n} (fitted {scalar_value(ds, n):.4g} ± "
            f"{scalar_value(ds, f'{n}_stderr'):.3g})" for n in bad)
        warnings.warn(
            f"the data do not determine {', '.join(bad)}: {shown}; report the bound, fix the "
            "parameter, fit fewer parameters, or measure where the spectrum depends on it",
            AccuracyWarning, stacklevel=stacklevel)
    return bad


def warn_goodness(ds: xr.Dataset, *, stacklevel: int = 3) -> bool:
    """Warn (GoodnessOfFitWarning) when the χ² p-value is below :data:`PVALUE_WARN`."""
    p = scalar_value(ds, "chi2_pvalue") if "chi2_pvalue" in ds.variables else math.nan
    if math.isfinite(p) and p < PVALUE_WARN:
        warnings.warn(
            f"the model does not describe these data: chi-square {ds.attrs.get('chisqr', math.nan):.4g}"
            f"{_calibrated_text(ds)} for {ds.attrs.get('dof', '?')} degrees of freedom (redchi "
            f"{scalar_value(ds, 'redchi'):.3g}), p = {p:.2g} < {PVALUE_WARN:g}; its stderr assume it "
            "does. Try another model or material (--model auto), or check the data's stderr",
            GoodnessOfFitWarning, stacklevel=stacklevel)
        return True
    return False


def _calibrated_text(ds: xr.Dataset) -> str:
    calibrated = float(ds.attrs.get("chisqr_calibrated", math.nan))
    if math.isfinite(calibrated) and not math.isclose(calibrated, float(ds.attrs["chisqr"])):
        return f" ({calibrated:.4g} with the residuals' stderr-dof calibration)"
    return ""


def warn_fit(ds: xr.Dataset, *, stacklevel: int = 4) -> None:
    """The warnings of a single fit: autocorrelated residuals, goodness of fit, identifiability.

    First the nuisance parameters' codes are settled (:func:`settle_nuisance_codes`, in
    place): an untilted baseline's slope, 0 within its stderr, is no reason to warn.
    """
    settle_nuisance_codes(ds)
    rho = float(ds.attrs.get("residual_lag1", math.nan))
    if math.isfinite(rho) and rho > LAG1_WARN:
        warnings.warn(
            f"the residuals are strongly autocorrelated (lag-1 {rho:.3g}): the stderr are "
            f"multiplied by sqrt((1+rho)/(1-rho)) = {float(ds.attrs['stderr_correction']):.3g} "
            f"(effective sample size {float(ds.attrs['effective_samples']):.4g} of "
            f"{int(ds.attrs.get('data_points', 0))}); they hold for AR(1) noise only. The model "
            "may miss structure in the data (drift, more modes): compare windows or replicas",
            DataWarning, stacklevel=stacklevel)
    warn_goodness(ds, stacklevel=stacklevel)
    warn_unidentified(ds, stacklevel=stacklevel)
