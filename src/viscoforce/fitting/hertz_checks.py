"""The hertz model's checks of its own data: an indentation at all, its direction, E over depth.

:func:`hertz_checks` checks a Hertz fit of an approach against its own data (the significance of
the indentation, the direction the force rises in, E against the depth, the baseline before
contact) and says where E is not determined; :func:`hertz_verdict` and :func:`depth_check` are
the same verdicts without warnings (a map's pixels). Its grids of contact points are
:func:`~viscoforce.fitting.curve_models.hertz_grid`'s, and the depth check's refit is the same
scan carried to its minimum (:func:`~viscoforce.fitting._hertz_scan.hertz_least_squares`): each
candidate contact point solved in closed form, coarse then local
(:mod:`viscoforce.fitting._hertz_scan`, issue 41 item 4).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import (
    DataWarning,
    GoodnessOfFitWarning,
    ParameterError,
    ViscoforceError,
)
from viscoforce.fitting._hertz_scan import hertz_least_squares, hertz_screen, unchecked_shape
from viscoforce.fitting.curve_models import HERTZ_GUESS_POINTS, contact_window, hertz_grid
from viscoforce.fitting.data import FitData
from viscoforce.fitting.outcome import ascending_order
from viscoforce.fitting.report import carry
from viscoforce.fitting.verdict import CHECKED_ATTR, listed_names

#: Fraction of the maximum contact force up to which the Hertz depth check refits.
DEPTH_CHECK_FRACTION = 0.5
#: Shift of E (in standard errors of the difference, :func:`depth_check`) beyond which the
#: depth check warns.
DEPTH_CHECK_SIGMA = 2.0
#: Relative change of E over the depth below which the depth check sees no failure of the
#: tip's law: added in quadrature to the statistical standard error of the difference
#: (:func:`depth_check`). The tip's ideal shape (a sphere, a cone, Bilodeau's pyramid), its
#: calibrated radius or angle and the detector's linearity over a factor 2 of force are not
#: known better than this; with it a shift of x % is at most x standard errors (20 for 20 %),
#: however many samples and however little noise the curve has.
DEPTH_CHECK_RESOLUTION = 0.01
#: Rise of the fitted baseline before contact (fraction of the contact force) that warns.
PRECONTACT_RISE_WARN = 0.2
#: Significance [σ] the indentation must reach for the approach to hold one: √Δχ² of the Hertz
#: term (E, contact point) over the baseline alone, in noise variances (a 5σ test, the k·σ of
#: :func:`viscoforce.experiments.modulation.find_contact_point`'s contact rise).
SIGNAL_SIGMA = 5.0
#: Fewest samples before the contact point whose residuals give the baseline noise (fewer: all
#: the residuals give it).
SIGNAL_BASELINE_POINTS = 10
#: Δχ² (in noise variances, AR(1)-corrected) by which the approach described along −z must beat
#: the approach along z as recorded to call the tip position's sign flipped: SIGNAL_SIGMA², a
#: 5σ difference.
FLIP_DELTA_CHI2 = SIGNAL_SIGMA**2
#: Δχ² below :data:`FLIP_DELTA_CHI2` within which the direction check's screen hands over to
#: the whole grid (:func:`approach_direction`): 10 noise variances, 50 times the largest
#: difference between the two on the real approaches of the tests (0.18).
SCREEN_MARGIN = 10.0


def _law(tip: Any, delta: np.ndarray) -> np.ndarray:
    """``tip.force_shape`` of ``delta`` = max(z − c, 0), which it overwrites.

    Unchecked (:func:`~viscoforce.fitting._hertz_scan.unchecked_shape`) where ``delta`` is
    finite (a maximum with 0 is ≥ 0); checked, raising the tip's error, otherwise.
    """
    if np.isfinite(delta).all():
        return unchecked_shape(tip)(delta)
    return np.asarray(tip.force_shape(delta), dtype=float)


def _hertz_force(z: np.ndarray, values: dict[str, float], tip: Any) -> np.ndarray:
    """The Hertz model's force [N] (:func:`viscoforce.fitting.curve_models._hertz_model`)."""
    c = values["contact_point"]
    return (values["baseline"] + values["baseline_slope"] * (z - c)
            + values["E"] * _law(tip, np.maximum(z - c, 0.0)))


def _hertz_residual(z: np.ndarray, f: np.ndarray, values: dict[str, float], tip: Any
                    ) -> np.ndarray:
    """F − the Hertz model at ``values`` [N]."""
    return f - _hertz_force(z, values, tip)


def _noise_variance(residual: np.ndarray, z: np.ndarray, n_free: int) -> float:
    """Residual variance [N²] times (1 + ρ1)/(1 − ρ1) for a lag-1 autocorrelation ρ1 > 0.

    The variance of a sum of AR(1) residuals over a stretch, per sample: what a Δχ² between two
    fits of the same samples is measured in (as the fits' stderr correction).
    """
    rho = _lag1(residual, z)
    factor = (1.0 + rho) / (1.0 - rho) if 0.0 < rho < 1.0 else 1.0
    return float(residual @ residual) / max(residual.size - n_free, 1) * factor


def _lag1(residual: np.ndarray, z: np.ndarray) -> float:
    """:func:`~viscoforce.fitting.outcome.residual_lag1`, its sort of z made once per approach.

    The checks take the lag-1 autocorrelation of several residuals over the same z: the order
    of the last z (:func:`~viscoforce.fitting.outcome.ascending_order`, as ``residual_lag1``) is
    kept, and reused while the same z comes again.
    """
    kept_z, order = _LAST_ORDER[0]
    if not (kept_z.shape == z.shape and np.array_equal(kept_z, z)):
        order = ascending_order(z)  # numpy.argsort's order, None where z ascends strictly
        _LAST_ORDER[0] = (z.copy(), order)  # one assignment: threads see a pair or the other
    return _lag1_sorted(residual if order is None else residual[order])


#: The last z of :func:`_lag1` and its order (None: ascending).
_LAST_ORDER: list[tuple[np.ndarray, np.ndarray | None]] = [(np.empty(0), None)]


def _lag1_sorted(r: np.ndarray) -> float:
    """Lag-1 autocorrelation of residuals already in order (as ``residual_lag1``)."""
    if r.size < 3:
        return 0.0
    r = r - r.mean()
    denom = float(r @ r)
    return float(r[:-1] @ r[1:]) / denom if denom > 0 else 0.0


def _line_sse(z: np.ndarray, f: np.ndarray) -> float:
    """Sum of squares [N²] of the straight line through (z, F) by least squares."""
    zc, fc = z - z.mean(), f - f.mean()
    szz = float(zc @ zc)
    rest = fc - zc * (float(zc @ fc) / szz) if szz > 0 else fc
    return float(rest @ rest)


def hertz_sse(z: np.ndarray, f: np.ndarray, residual: np.ndarray, tip: Any) -> float:
    """The Hertz fit's sum of squares [N²]: its own, or its start grid's where that is lower.

    (:func:`~viscoforce.fitting.curve_models.hertz_grid`: a fit stuck off its best contact
    point then does not pass for a worse description than the model gives.)
    """
    sse = float(residual @ residual)
    try:
        grid = hertz_grid(tip, z, f)
    except ParameterError:
        return sse
    return sse if grid is None else min(sse, grid[1])


def indentation_signal(z: np.ndarray, f: np.ndarray, values: dict[str, float], tip: Any,
                       sse: float, *, residual: np.ndarray | None = None) -> dict[str, float]:
    """How clearly an approach (z [m], F [N]) holds the indentation of its Hertz fit ``values``.

    ``signal`` [σ]: √Δχ², Δχ² the drop of the sum of squares from the straight baseline alone
    (least squares) to the Hertz fit's ``sse`` (:func:`hertz_sse`), in noise variances
    (:func:`_noise_variance` of the Hertz residuals): the likelihood-ratio significance of the
    Hertz term, which counts every sample in contact. Under noise alone the contact point
    roams over the approach to where the noise rises most, so Δχ² exceeds its χ²₁ value; a
    5σ rule (:data:`SIGNAL_SIGMA`) leaves that margin.

    Also, for the user's eye: ``rise`` [N], the fitted Hertz force at the deepest indentation,
    E·shape(max z − contact point), and ``noise`` [N], 1.4826 × the median absolute deviation
    of the residuals before the contact point (of all residuals where fewer than
    :data:`SIGNAL_BASELINE_POINTS` lie before it), as
    :func:`viscoforce.experiments.modulation.find_contact_point` measures it.
    ``residual``: the Hertz residuals at ``values``, where the caller has them.
    """
    c = values["contact_point"]
    rise = values["E"] * float(np.asarray(tip.force_shape(
        np.array([max(float(np.max(z)) - c, 0.0)]))).reshape(-1)[0])
    if residual is None:
        residual = _hertz_residual(z, f, values, tip)
    base = residual[z <= c]
    if base.size < SIGNAL_BASELINE_POINTS:
        base = residual
    noise = 1.4826 * float(np.median(np.abs(base - np.median(base))))
    drop = max(_line_sse(z, f) - sse, 0.0)
    variance = _noise_variance(residual, z, 4)
    signal = math.sqrt(drop / variance) if variance > 0 else (math.inf if drop > 0 else 0.0)
    return {"rise": rise, "noise": noise, "signal": signal}


def approach_direction(z: np.ndarray, f: np.ndarray, sse: float, tip: Any
                       ) -> tuple[float, dict[str, float] | None]:
    """How much better the approach is described with the tip position's sign flipped.

    Contact is where the force rises with the indentation, wherever the samples' order puts it
    (a retract-ordered array reads the same). The Hertz model along −z (each contact point
    linear in E, baseline and tilt) against ``sse``, the Hertz fit's along z
    (:func:`hertz_sse`): Δχ² = (sse − SSE₋)/σ², σ² the noise variance of the residuals along −z
    (:func:`_noise_variance`). SSE₋ is first screened
    (:func:`~viscoforce.fitting._hertz_scan.hertz_screen`: the guess's quantile grid on a
    subsample, its best three candidates on every sample; its SSE₋ is never below the grid's
    best, and its Δχ² differs from the grid's by at most 0.18 on the 17 real approaches of
    tests/fitting/test_hertz_fast_path.py); where that Δχ² comes within
    :data:`SCREEN_MARGIN` of :data:`FLIP_DELTA_CHI2`, the guess's whole grid decides
    (:func:`~viscoforce.fitting.curve_models.hertz_grid`). An approach recorded the right way
    lies far below the threshold (−6 to −240 on the real ones): the screen saves the direction
    check's scan of nearly every sample for every candidate (issue 41 item 4, ≈ 0.45 ms of a
    4.4 ms fit).

    Returns
    -------
    delta_chi2 : float
        Positive where −z describes the approach better (NaN: not checked, too few samples).
    mirrored : dict or None
        E [Pa], the contact point [m, on the recorded axis] and ``rise`` [N], the model's force
        at the lowest z less its force at that contact point (> 0: the force rises toward −z
        in contact, baseline tilt included), along −z (None: no contact point along −z gives
        E > 0).
    """
    delta, c, coef = math.nan, math.nan, None
    for search in ("screen", "grid"):
        try:
            flipped = (hertz_screen(tip, -z, f, contact_window(tip, -z),
                                    points=HERTZ_GUESS_POINTS) if search == "screen"
                       else hertz_grid(tip, -z, f))
        except ParameterError:
            return math.nan, None
        if flipped is None:
            return -math.inf, None
        c, sse_flipped, coef = flipped
        residual = _hertz_residual(-z, f, {"E": coef[0], "contact_point": c,
                                           "baseline": coef[1], "baseline_slope": coef[2]}, tip)
        variance = _noise_variance(residual, z, 4)
        delta = (sse - sse_flipped) / variance if variance > 0 else math.inf
        if not delta > FLIP_DELTA_CHI2 - SCREEN_MARGIN:
            break  # far below the threshold: the screen's (low) Δχ² stands
    deepest = max(-float(np.min(z)) - c, 0.0)
    rise = float(coef[0] * np.asarray(tip.force_shape(np.array([deepest]))).reshape(-1)[0]
                 + coef[2] * deepest)
    return delta, {"E": float(coef[0]), "contact_point": -c, "rise": rise}


def _flipped_reason(z: np.ndarray, values: dict[str, float], tip: Any, delta: float,
                    mirrored: dict[str, float] | None, found: dict[str, float]) -> str | None:
    """Why the force rises toward negative indentation (the tip position's sign flipped?), or None.

    Either the approach is described better along −z by more than :data:`FLIP_DELTA_CHI2`
    noise variances with a force that rises toward −z in that contact
    (:func:`approach_direction`: a curve in contact throughout, convex and rising with z, is
    described along either direction and is not called flipped by this), or the fit holds an
    indentation (:data:`SIGNAL_SIGMA`) while its force is highest at the lowest tip position,
    by more than :data:`SIGNAL_SIGMA` noise levels: an approach ends at its largest force, in
    contact.
    """
    if delta > FLIP_DELTA_CHI2 and mirrored is not None and mirrored["rise"] > 0:
        return (f"along the tip position reversed (-z) the approach is described better by "
                f"{delta:.3g} noise variances of chi-square (E ~ {mirrored['E']:.3g} Pa, contact "
                f"at tip position {mirrored['contact_point']:.4g} m) than along z as recorded")
    low, high = _hertz_force(np.array([np.min(z), np.max(z)]), values, tip)
    if found["signal"] >= SIGNAL_SIGMA and low - high > SIGNAL_SIGMA * found["noise"]:
        return (f"the fitted force is highest at the lowest tip position ({low:.3g} N, against "
                f"{high:.3g} N at the deepest), where an approach ends at its largest force")
    return None


def _not_determined(ds: xr.Dataset, names: tuple[str, ...], why: str) -> None:
    """Set the identifiability of ``names`` to not determined (3) because ``why``, in place.

    The names join ``attrs[CHECKED_ATTR]``, so that :func:`~.verdict.warn_fit`'s nuisance rule
    (:func:`~.verdict.settle_nuisance_codes`) leaves them not determined.
    """
    codes = np.array(ds["identifiability"].values, copy=True)
    params = [str(n) for n in ds["param_i"].values]
    for name in names:
        codes[params.index(name)] = 3  # IDENTIFIABILITY[3]: "not_determined"
    ds["identifiability"] = ds["identifiability"].copy(data=codes)
    method = str(ds.attrs.get("identifiability_method", ""))
    ds.attrs["identifiability_method"] = (
        f"{method}; {', '.join(names)} not determined by the hertz checks ({why})".lstrip("; "))
    ds.attrs[CHECKED_ATTR] = ", ".join(dict.fromkeys([*listed_names(ds, CHECKED_ATTR), *names]))


def hertz_verdict(z: np.ndarray, f: np.ndarray, values: dict[str, float], tip: Any
                  ) -> dict[str, Any]:
    """Whether a Hertz fit ``values`` of an approach (z [m], F [N]) measured an indentation.

    No warnings (:func:`hertz_checks` issues them; a map's pixels can take the same verdict).

    Returns
    -------
    dict
        ``indentation_signal`` [σ], ``indentation_rise`` [N], ``baseline_noise`` [N]
        (:func:`indentation_signal`), ``direction_delta_chi2`` (:func:`approach_direction`),
        ``approach_direction`` (text), ``flipped`` (why the tip position's sign looks flipped,
        :func:`_flipped_reason`, or None) and ``no_signal`` (True below :data:`SIGNAL_SIGMA`).
    """
    residual = _hertz_residual(z, f, values, tip)
    sse = hertz_sse(z, f, residual, tip)
    delta, mirrored = approach_direction(z, f, sse, tip)
    found = indentation_signal(z, f, values, tip, sse, residual=residual)
    flipped = _flipped_reason(z, values, tip, delta, mirrored, found)
    direction = (f"reversed? {flipped}" if flipped is not None else
                 "as recorded (the approach along -z is not described better by more than "
                 f"{FLIP_DELTA_CHI2:g} noise variances, and its force is not highest at the "
                 "lowest tip position)")
    return {"indentation_signal": found["signal"], "indentation_rise": found["rise"],
            "baseline_noise": found["noise"], "direction_delta_chi2": delta,
            "approach_direction": direction, "flipped": flipped,
            "no_signal": not found["signal"] >= SIGNAL_SIGMA}


def hertz_checks(ds: xr.Dataset, data: FitData, tip: Any, *, copy: bool = True) -> xr.Dataset:
    """Check a Hertz fit against its own data: an indentation at all, its direction, E over depth.

    * **Direction**: where the force rises toward negative indentation
      (:func:`_flipped_reason`: the approach described better along −z,
      :func:`approach_direction`, or the fitted force highest at the lowest tip position), the
      tip position's sign looks flipped: a :class:`DataWarning` says so, and E and the contact
      point are not determined (``attrs["approach_direction"]``, ``direction_delta_chi2``).
    * **Signal**: the significance of the Hertz term over the baseline alone
      (:func:`indentation_signal`; ``attrs["indentation_signal"]`` [σ], with the fitted force
      at the deepest indentation ``indentation_rise`` and the baseline residuals' noise
      ``baseline_noise`` [N]); below :data:`SIGNAL_SIGMA` the approach holds no detectable
      indentation: a :class:`DataWarning` says so, and E and the contact point are not
      determined.
    * **Depth** (where there is an indentation the right way): :func:`_depth_checks`.

    The first two are :func:`hertz_verdict`'s. The checks are written on a copy of ``ds``
    (``copy=False``: on ``ds`` itself, for a caller that made it and keeps no other).
    """
    z, f = np.asarray(data.x, dtype=float), np.asarray(data.y, dtype=float)
    values = {n: float(ds.variables[n].values) for n in ("E", "contact_point", "baseline",
                                                          "baseline_slope")}
    out = carry(ds, ds.copy()) if copy else ds
    verdict = hertz_verdict(z, f, values, tip)
    flipped = verdict.pop("flipped")
    no_signal = verdict.pop("no_signal")
    out.attrs.update(verdict)
    if flipped is not None:
        warnings.warn(
            f"hertz: the force rises toward negative indentation: is the height sign flipped? "
            f"{flipped[0].upper()}{flipped[1:]}. The tip position must grow toward the sample "
            "(tip_position = -height - deflection, up to an offset): check the sign of the "
            "height channel or of its conversion. E and the contact point fitted here are not "
            "determined", DataWarning, stacklevel=3)
        _not_determined(out, ("E", "contact_point"), "the tip position's sign looks flipped")
        out.attrs["depth_check"] = "not made (the tip position's sign looks flipped)"
        return out
    if no_signal:
        warnings.warn(
            f"hertz: no detectable indentation: the Hertz term improves on the baseline alone "
            f"by {verdict['indentation_signal']:.2g} sigma, below {SIGNAL_SIGMA:g} (its force "
            f"at the deepest indentation, {verdict['indentation_rise']:.3g} N, against "
            f"{verdict['baseline_noise']:.3g} N of noise in the baseline residuals). The "
            "approach holds no contact this model can measure (noise only, no contact reached, "
            "the wrong segment, or a force that does not rise with the tip position): E and "
            "the contact point are not determined", DataWarning, stacklevel=3)
        _not_determined(out, ("E", "contact_point"), "no detectable indentation")
        out.attrs["depth_check"] = "not made (no detectable indentation)"
        return out
    return _depth_checks(out, z, f, values, tip)


def _e_variance_factor(jacobian: np.ndarray) -> float:
    """((JᵀJ)⁻¹)_EE [Pa²/N²]: E's variance per unit noise variance (E is column 0 of J).

    The columns are scaled to unit norm first (E, a contact point, a force and a slope differ
    by many orders of magnitude): JᵀJ over the outer product of the column norms (their
    squares are its diagonal). NaN where JᵀJ is singular.
    """
    gram = jacobian.T @ jacobian
    norm = np.sqrt(np.diag(gram))
    if not np.all(norm > 0):
        return math.nan
    try:
        inverse = np.linalg.inv(gram / np.outer(norm, norm))
    except np.linalg.LinAlgError:
        return math.nan
    return float(inverse[0, 0]) / float(norm[0]) ** 2


def _hertz_jacobian(z: np.ndarray, values: dict[str, float], tip: Any) -> np.ndarray:
    """∂F/∂(E, contact point, baseline, baseline slope) of the Hertz model at ``values``.

    dF/dδ = E·``tip.contact_stiffness_factor``(δ) (the tip's S = (1/E) dF/dδ; equal to the
    derivative of ``force_shape`` to 1e-9 for every tip shape).
    """
    delta = np.maximum(z - values["contact_point"], 0.0)
    stiffness = np.asarray(tip.contact_stiffness_factor(delta), dtype=float).reshape(z.shape)
    return np.column_stack([
        _law(tip, delta).reshape(z.shape),  # after the stiffness: it overwrites delta
        -values["E"] * stiffness - values["baseline_slope"],
        np.ones_like(z),
        z - values["contact_point"]])


def depth_check(z: np.ndarray, f: np.ndarray, values: dict[str, float], e_err: float,
                tip: Any) -> dict[str, Any]:
    """E refitted on the shallow part of an approach, against the full fit ``values`` (no warning).

    The approach (z [m], F [N]) is refitted up to :data:`DEPTH_CHECK_FRACTION` of its maximum
    contact force: the hertz model's least squares over those samples, by variable projection
    (:func:`~viscoforce.fitting._hertz_scan.hertz_least_squares`: the contact-point scan of the
    fit's guess, then the minimum of its closed-form sum of squares over the contact point; what
    the fitting engine reaches from that guess, to its tolerance, without a second fit's
    machinery). The shallow samples are a subset of the full fit's, so the two E share
    their noise: under a law that describes the curve the variance of their difference is
    σ²·(A_shallow − A_full), A = ((JᵀJ)⁻¹)_EE with the model's Jacobian J over each fit's
    samples, both at the full fit's values (:func:`_hertz_jacobian`; for a linear model this is
    exactly var(E_shallow) − var(E_full) at one noise level, and it is never negative). σ² is
    the noise variance of the shallow fit's residuals, AR(1)-corrected
    (:func:`_noise_variance`): the deep samples, where a law that fails departs most, do not
    inflate it (each fit's own stderr scale with its own residuals, so the full fit's could
    exceed the shallow fit's and their difference vanish: the shifts of thousands of standard
    errors of issue 37). Added in quadrature, :data:`DEPTH_CHECK_RESOLUTION` × E: the change
    over depth below which the check sees no failure of the tip's law.

    Parameters
    ----------
    z, f : numpy.ndarray
        The approach: tip position [m], force [N].
    values : dict
        The full Hertz fit: ``E``, ``contact_point``, ``baseline``, ``baseline_slope``.
    e_err : float
        The full fit's stderr of E [Pa] (not finite: no check).
    tip : Tip
        The tip of the fit.

    Returns
    -------
    dict
        ``made`` (bool) and ``text`` (what was found, or why no check was made); where made
        also ``E`` [Pa] (the shallow refit's), ``relative`` (E_shallow/E − 1), ``shift`` (the
        difference in its standard errors) and ``warn`` (|shift| > :data:`DEPTH_CHECK_SIGMA`).
    """
    c, b, slope, e = (values[n] for n in ("contact_point", "baseline", "baseline_slope", "E"))
    excess = f - (b + slope * (z - c))
    contact = z > c
    peak = float(np.max(excess[contact])) if contact.any() else 0.0
    keep = ~contact | (excess <= DEPTH_CHECK_FRACTION * peak)
    if peak <= 0 or int(np.sum(contact & keep)) < 8 or not math.isfinite(e_err) or e_err <= 0:
        return {"made": False,
                "text": "not made (too few contact points, or E without stderr)"}
    zk, fk = z[keep], f[keep]
    try:
        shallow = hertz_least_squares(tip, zk, fk, contact_window(tip, zk),
                                      points=HERTZ_GUESS_POINTS)
    except (ViscoforceError, ValueError, ArithmeticError) as exc:
        return {"made": False, "text": f"not made: the shallow refit failed ({exc})"}
    if shallow is None:
        return {"made": False, "text": "not made: the shallow refit failed (no contact point "
                                       "gives a positive modulus)"}
    c_half, _, coef = shallow
    own = {"E": float(coef[0]), "contact_point": c_half, "baseline": float(coef[1]),
           "baseline_slope": float(coef[2])}
    e_half = own["E"]
    jacobian = _hertz_jacobian(z, values, tip)
    # the rows kept: np.compress gives jacobian[keep] (the same C-ordered copy) at a tenth of
    # the boolean index's cost over rows of a 2-D array
    excess_factor = (_e_variance_factor(np.compress(keep, jacobian, axis=0))
                     - _e_variance_factor(jacobian))
    noise = _noise_variance(_hertz_residual(zk, fk, own, tip), zk, 4)
    statistical = noise * max(excess_factor, 0.0) if math.isfinite(excess_factor) else 0.0
    spread = math.sqrt(statistical + (DEPTH_CHECK_RESOLUTION * e) ** 2)
    shift = (e_half - e) / spread
    relative = e_half / e - 1.0
    return {"made": True, "E": e_half, "relative": relative, "shift": shift,
            "warn": abs(shift) > DEPTH_CHECK_SIGMA,
            "text": (f"E refitted up to {100 * DEPTH_CHECK_FRACTION:.0f} % of the maximum "
                     f"contact force: {e_half:.4g} Pa, {100 * relative:+.1f} % from the full "
                     f"fit's {e:.4g} Pa ({shift:+.1f} standard errors of the difference)")}


def _depth_checks(out: xr.Dataset, z: np.ndarray, f: np.ndarray, values: dict[str, float],
                  tip: Any) -> xr.Dataset:
    """E against the depth, the baseline before contact (of :func:`hertz_checks`), in ``out``.

    * **Depth** (:func:`depth_check`): ``attrs["depth_check"]`` (the text),
      ``depth_check_E``, ``depth_check_relative`` (E_shallow/E − 1) and
      ``depth_check_shift`` (in standard errors of the difference). A law that describes the
      curve gives the same E within that error; beyond :data:`DEPTH_CHECK_SIGMA` a
      :class:`GoodnessOfFitWarning` says that the stderr cover the noise only, not the model
      error (a map's pixel gets the quality code ``depth_dependent`` on the same rule).
    * **Baseline**: the rise of the tilted baseline from the start of the approach to the
      contact point, as a fraction of the contact force (``attrs["precontact_rise"]``); above
      :data:`PRECONTACT_RISE_WARN` a :class:`DataWarning` says the approach is not a free
      cantilever before contact.
    """
    c, b, slope = values["contact_point"], values["baseline"], values["baseline_slope"]
    e = values["E"]
    excess = f - (b + slope * (z - c))
    contact = z > c
    peak = float(np.max(excess[contact])) if contact.any() else 0.0
    if peak > 0:
        rise = abs(slope) * max(c - float(np.min(z)), 0.0) / peak
        out.attrs["precontact_rise"] = rise
        if rise > PRECONTACT_RISE_WARN:
            warnings.warn(
                f"hertz: the fitted baseline rises by {100 * rise:.0f} % of the contact force "
                "before the contact point: the approach is not a free cantilever there (a "
                "long-range repulsion, a soft layer, or contact from the start of the "
                "approach), so the contact point and E rest on the tilted baseline",
                DataWarning, stacklevel=4)
    found = depth_check(z, f, values, float(out.variables["E_stderr"].values), tip)
    out.attrs["depth_check"] = found["text"]
    if not found["made"]:
        return out
    out.attrs.update(depth_check_E=found["E"], depth_check_relative=found["relative"],
                     depth_check_shift=found["shift"])
    if found["warn"]:
        warnings.warn(
            f"hertz: E depends on the indentation depth: up to "
            f"{100 * DEPTH_CHECK_FRACTION:.0f} % of the maximum contact force E = "
            f"{found['E']:.4g} Pa, {100 * found['relative']:+.1f} % from the full fit's "
            f"{e:.4g} Pa ({found['shift']:+.1f} standard errors of the difference). The tip's "
            "elastic law does not describe this approach (viscoelasticity, a finite thickness, "
            "the wrong tip, or the contact point), and the stderr cover the noise only: report "
            "E with its depth range", GoodnessOfFitWarning, stacklevel=4)
    return out
