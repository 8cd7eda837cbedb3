"""The ``creep`` model with a known tip: Lee–Radok's creep integral of the recorded force.

A rigid axisymmetric tip whose elastic load is F = E·g(δ) (``g`` = :meth:`Tip.force_shape
<viscoforce.physics.tips.Tip.force_shape>` [m²], E the paper's modulus) pressed into a linear
viscoelastic half-space of creep compliance C(t) by the load history F(t) indents it by δ(t)
with (Lee & Radok 1960, exact while the contact area grows)

    g(δ(t)) = ψ(t) = ∫ C(t − s) dF(s),

so that under a constant force F0 applied at t = 0, g(δ) = F0·C(t): δ^{3/2} ∝ C(t) for a
paraboloid, δ² for a cone or pyramid, δ itself only for a flat punch (Sneddon's exact shape for a
sphere). C(t) is the project's creep Prony series (:mod:`viscoforce.physics.materials`):

* one mode: C(t) = 1/E_inf + (1/E0 − 1/E_inf)·e^{−t/τ} — parameters ``tau`` (the creep time of
  Eq. 3), ``E0``, ``E_inf``;
* n modes: ``E0``, ``E_1`` … ``E_{n−1}``, ``E_inf``, ``tau_1`` … ``tau_n`` (creep times,
  ascending), mode i carrying 1/E_i − 1/E_{i−1}, as the ``exact`` model;

and the contact point ``contact_point`` z_c [m] (the tip position at contact), unless given. The
model is the tip position z(t) = z_c + g⁻¹(ψ(t)) (:func:`indentation_from_shape`), fitted to the
measured tip position, whose noise it is.

The data (:func:`lee_radok_data`) are the constant-force pause (as the phenomenological ``creep``
fit's, ``segments.creep_data``) and the loading ramp before it, times from the start of the pause:

* a first contact point comes from a Hertz grid fit of the approach
  (:func:`~viscoforce.fitting.curve_models.hertz_grid`); the force's zero is the free cantilever's
  mean force over one indentation depth just before ψ starts (not Hertz's fitted baseline, which
  an elastic fit of a viscoelastic loading biases by ~0.2 % of the load);
* ψ integrates the recorded force F − baseline, smoothed by a Savitzky–Golay filter
  (:data:`FORCE_WINDOW`), exactly as a piecewise-linear function of time from half an
  indentation depth before that contact (:data:`HISTORY_MARGIN`) to the end of the pause: the
  creep during loading and the controller's overshoot are in it as recorded;
* the fitted samples are the pause and the approach's samples whose force exceeds
  :data:`LOADING_FRACTION` of the held force: the loading ramp pins the contact point (on the pause
  alone z_c and the moduli are one combination for a flat punch, nearly so for curved tips), and
  the first part of contact, where g⁻¹ amplifies the force noise and adhesion and surface forces
  act, is left out;
* the contact point is then fitted (an additive parameter of z: ψ does not depend on it) within
  the history's tip positions (``contact_window`` to narrow it), or given (``contact_point``;
  required where no approach precedes the pause: the load is then a step at the start of the
  pause and creep during loading is neglected).

The stderr (:func:`propagated_covariance`) carry both noises: the tip position's, from the
residuals, and the recorded force's, which enters the model itself (σ_F estimated from the
force's second differences, propagated through the smoothing and the creep integral exactly).

References
----------
* E. H. Lee, J. R. M. Radok, "The contact problem for viscoelastic bodies", J. Appl. Mech. 27,
  438–444 (1960).
* T. C. T. Ting, "The contact stresses between a rigid indenter and a viscoelastic half-space",
  J. Appl. Mech. 33, 845–854 (1966): where the contact area shrinks the integral above no longer
  holds (:func:`contact_area_decrease` measures it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from viscoforce._validation import describe_value
from viscoforce.exceptions import ParameterError
from viscoforce.fitting import _params as P
from viscoforce.fitting.base import (
    MODULUS_BOUNDS,
    FitModel,
    ModelSpec,
    material_layout,
    moduli_names,
    need,
    tau_names,
)
from viscoforce.fitting.curve_models import contact_window, hertz_grid
from viscoforce.fitting.data import FitData
from viscoforce.fitting.guesses import material_guess, time_window
from viscoforce.fitting.segments import (
    _chosen_run,
    _free_baseline,
    _segment_types,
    _source,
    segment_runs,
)
from viscoforce.physics.lee_radok import (
    creep_integral,
    creep_integral_adjoint,
    indentation_from_shape,
    smoothing_matrix,
)
from viscoforce.physics.tips import tip_from
from viscoforce.schema import select_curve, validate_curves

__all__ = ["FORCE_WINDOW", "HISTORY_MARGIN", "LOADING_FRACTION", "CreepData", "check_history",
           "contact_area_decrease", "creep_compliances", "lee_radok_data", "lee_radok_model",
           "propagated_covariance"]

#: The approach's samples fitted: those whose force exceeds this fraction of the held force.
LOADING_FRACTION = 0.5
#: ψ starts this many indentation depths (of the approach, beyond the guessed contact) before it.
HISTORY_MARGIN = 0.5
#: Samples of the Savitzky–Golay filter (order 2) that smooths the recorded force before the creep
#: integral. The force noise σ_F enters the model through J_g·F(t) at every sample while E0 is
#: measured on the loading ramp alone, so least squares lean E0 up by ≈ 700 (σ_F/F)² (measured
#: on a 3000-sample pause with 100 loading samples: +0.27 % at σ_F/F = 0.2 %); the filter divides
#: σ_F² by ~9 and keeps ramps and the overshoot (it preserves quadratics). The noise left, slow
#: as well as fast, is propagated into the stderr (:func:`propagated_covariance`).
FORCE_WINDOW = 21
#: Creep times tried by the guess, log-spaced over the data's span.
_GUESS_TAUS = 31
#: Random force vectors of the trace estimates of :func:`propagated_covariance` (fixed seed).
_PROBES = 64


# ── the data ────────────────────────────────────────────────────────────────────────────────


@dataclass(frozen=True)
class CreepData(FitData):
    """The tip position to fit, with the force history of the creep integral.

    ``x`` are times [s] from the start of the pause (< 0 on the approach), ``y`` the tip position
    [m] there; ``history`` = (t [s], F [N], z [m]) from the start of the creep integral to the end
    of the pause, F relative to the free-cantilever baseline, z the tip position.
    """

    history: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
    #: σ_F [N]: the recorded force's noise (robust, from its second differences).
    force_noise: float = 0.0
    #: Samples of the Savitzky–Golay smoothing of the force (0: none).
    smoothing: int = 0


def check_history(name: str, value: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, F, z): three finite 1-D arrays of one length ≥ 4, t strictly increasing [s, N, m]."""
    try:
        t, f, z = (np.asarray(a, dtype=float) for a in value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be (t [s], force [N], tip position [m]) arrays, got "
                             f"{describe_value(value)}") from None
    if t.ndim != 1 or not t.shape == f.shape == z.shape or t.size < 4:
        raise ParameterError(f"{name} must be three 1-D arrays of one length >= 4, got shapes "
                             f"{t.shape}, {f.shape} and {z.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(f)) and np.all(np.isfinite(z))
            and np.all(np.diff(t) > 0)):
        raise ParameterError(f"{name} must be finite with strictly increasing times")
    return t, f, z


def lee_radok_data(curves: xr.Dataset, tip: Any, *, curve: int = 0, segment: int | None = None,
                   contact_point: float | None = None) -> CreepData:
    """The pause and its loading ramp of one curve, for the Lee–Radok creep fit (module doc).

    Parameters
    ----------
    curves : xarray.Dataset
        A curves dataset (:mod:`viscoforce.schema.curves`).
    tip : Tip or str
        The tip.
    curve : int
        The curve (pixel), from 0.
    segment : int, optional
        The pause to fit (from 0, file order); default the first constant-force pause after the
        approach. Its loading ramp is the last approach before it.
    contact_point : float, optional
        The contact point [m], given (instead of the Hertz grid's first one); with it the
        pause alone will do (the load is then a step at its start, a note says so).

    Returns
    -------
    CreepData
        ``source`` adds ``creep_force`` (the median held force [N] over the baseline),
        ``force_baseline`` [N] and how it was found (``force_reference``), ``contact_guess``
        [m], ``history_start`` [s], ``loading_points`` (approach samples fitted),
        ``force_noise`` σ_F [N] and ``force_smoothing``.

    Raises
    ------
    ParameterError
        No pause, too few samples, no approach and no contact point, or an approach whose
        force never rises (no contact in it).
    """
    tip = tip_from(tip)
    one = select_curve(validate_curves(curves), curve)
    pause = _chosen_run(one, segment, "creep")
    runs = segment_runs(one)
    before = [r for r in runs if r[1] <= pause[0] and r[2] == "approach"]
    start = before[-1][0] if before else pause[0]

    def grab(name: str) -> np.ndarray:
        return np.asarray(one[name].values[start:pause[1]], dtype=float)

    t, f, z = grab("time"), grab("force"), grab("tip_position")
    ok = np.isfinite(t) & np.isfinite(f) & np.isfinite(z)
    on_pause = np.arange(start, pause[1]) >= pause[0]
    if (ok & on_pause).sum() < 4:
        raise ParameterError(f"the creep segment has {int((ok & on_pause).sum())} finite samples "
                             "of time, force and tip position; need >= 4")
    t, f, z, on_pause = t[ok], f[ok], z[ok], on_pause[ok]
    if np.any(np.diff(t) <= 0):
        raise ParameterError("the time of the approach and pause must increase strictly")
    t = t - t[on_pause][0]
    source = _source(curves, one, pause, int(on_pause.sum()), curve)
    source["tip_position_reference"] = str(curves.attrs.get(
        "tip_position_convention", "tip position toward the sample"))
    approach = ~on_pause
    if approach.sum() < 8:  # no loading ramp to speak of: the pause alone
        t, f, z, on_pause = t[on_pause], f[on_pause], z[on_pause], on_pause[on_pause]
        approach = ~on_pause
    if contact_point is not None:
        guess = float(contact_point)
    elif approach.any():
        best = hertz_grid(tip, z[approach], f[approach])
        if best is None:
            raise ParameterError("the approach before the pause never presses on the sample (its "
                                 "force does not rise with the tip position): no contact point "
                                 "to start from; give contact_point (--contact-point)")
        guess = float(best[0])
    else:
        raise ParameterError("the Lee-Radok creep fit needs the approach before the pause (its "
                             "loading ramp pins the contact point) or contact_point "
                             "(--contact-point); this curve has no approach before the pause")
    depth = max(float(np.max(z)) - guess, 0.0)
    baseline = _baseline(z[approach], f[approach], guess, depth) if approach.any() else None
    how = ("the approach's mean force over one indentation depth before the creep integral "
           "starts (free cantilever)")
    if baseline is None:
        baseline = _free_baseline(one, int(one["segment"].values[pause[0]]))
        how = "the file's free-cantilever baseline (segment_baseline)"
    if baseline is None:
        baseline, how = 0.0, "nothing: the force as recorded (the file gives no baseline)"
    f = f - baseline
    first = 0
    if approach.any():  # the approach samples come first: from where it nears the contact
        near = np.maximum.accumulate(z[approach]) >= guess - HISTORY_MARGIN * depth
        first = int(np.argmax(near)) if near.any() else int(approach.sum()) - 1
    t, f, z, on_pause = t[first:], f[first:], z[first:], on_pause[first:]
    noise = _force_noise(f)
    held_raw = float(np.median(f[on_pause]))
    window = _smoothing_window(int((~on_pause).sum()),
                               int(((f >= 0.02 * held_raw) & ~on_pause).sum()))
    f = smoothing_matrix(f.size, window) @ f
    held = float(np.median(f[on_pause]))
    fitted = on_pause | (f >= LOADING_FRACTION * held)
    source.update(creep_force=held, creep_force_spread=float(np.std(f[on_pause])),
                  force_baseline=baseline, force_reference=f"F relative to {how}",
                  contact_guess=guess, history_start=float(t[0]),
                  loading_points=int((fitted & ~on_pause).sum()),
                  loading_fraction=LOADING_FRACTION, data_points=int(fitted.sum()),
                  force_noise=noise, force_smoothing=(
                      f"Savitzky-Golay, order 2, {window} samples" if window > 2 else "none"))
    types = _segment_types(one)
    if types is not None:
        source["segment_type"] = str(types[int(one["segment"].values[pause[0]])])
    notes: tuple[str, ...] = ()
    if on_pause.all():
        notes = ("no loading ramp before the pause: the load is a step at its start (creep "
                 "during loading is neglected)",)
    return CreepData(t[fitted], z[fitted], None, source, notes=notes, history=(t, f, z),
                     force_noise=noise, smoothing=window)


def _smoothing_window(n_approach: int, n_loading: int) -> int:
    """Samples of the force's Savitzky–Golay smoothing (odd; 0: none).

    :data:`FORCE_WINDOW`, at most a fifth of the loading ramp's samples and at least 5 (a
    shorter ramp: none); the whole window when there is no ramp (the pause alone).
    """
    if n_approach == 0:
        return FORCE_WINDOW
    w = min(FORCE_WINDOW, n_loading // 5)
    w -= 1 - w % 2
    return w if w >= 5 else 0


def _force_noise(f: np.ndarray) -> float:
    """σ [N] of white noise on a smooth force: 1.4826·median|Δ²F|/√6 (var Δ²ε = 6σ²)."""
    if f.size < 3:
        return 0.0
    return float(1.4826 * np.median(np.abs(np.diff(f, 2))) / math.sqrt(6.0))


def _baseline(z: np.ndarray, f: np.ndarray, contact: float, depth: float) -> float | None:
    """The free-cantilever force [N] beside the contact; None with fewer than 8 samples.

    The mean over the approach's tip positions within [contact − (1 + HISTORY_MARGIN)·depth,
    contact − HISTORY_MARGIN·depth], just before the creep integral starts (so that
    F − baseline starts at 0 there).

    Measured beside the contact rather than fitted with Hertz's shape: an elastic fit of a
    viscoelastic loading biases its baseline by ~0.2 % of the load, which biases the
    compliances by as much.
    """
    near = (z >= contact - (1.0 + HISTORY_MARGIN) * depth) & (z <= contact - HISTORY_MARGIN * depth)
    return float(np.mean(f[near])) if near.sum() >= 8 else None


# ── the creep integral and its noise ────────────────────────────────────────────────────────


def creep_compliances(values: Mapping[str, float], modes: int
                      ) -> tuple[float, np.ndarray, np.ndarray]:
    """(J_g = 1/E0, ΔJ_i = 1/E_i − 1/E_{i−1}, τ_i) of a parameter set (SPEC names), unchecked."""
    e = np.array([values[n] for n in moduli_names(modes)], dtype=float)
    taus = np.array([values[n] for n in tau_names(modes)], dtype=float)
    return 1.0 / e[0], 1.0 / e[1:] - 1.0 / e[:-1], taus


def contact_area_decrease(history: tuple[np.ndarray, np.ndarray, np.ndarray],
                          values: Mapping[str, float], modes: int, *, window: int = 21
                          ) -> float:
    """Largest fall of ψ (= the load shape g(δ)) below its running maximum, relative to it.

    Lee–Radok's integral holds while the contact area grows (ψ does not fall); where it falls
    (an overshoot released faster than the sample creeps) Ting's form applies instead. ψ is
    smoothed over ``window`` samples first, so that the force noise does not count as a fall,
    and counted once it has reached :data:`LOADING_FRACTION` of its peak (before contact it is
    the noise of the force alone).
    """
    t, f, _ = history
    psi = creep_integral(t, f, *creep_compliances(values, modes))
    if psi.size >= window:
        psi = np.convolve(psi, np.ones(window) / window, mode="valid")
    top = np.maximum.accumulate(psi)
    peak = float(top[-1])
    loaded = top >= LOADING_FRACTION * peak  # before contact ψ is the force noise only
    if not peak > 0 or not loaded.any():
        return 0.0
    return float(np.max((top[loaded] - psi[loaded]) / top[loaded]))


# ── the model ───────────────────────────────────────────────────────────────────────────────


def lee_radok_model(spec: ModelSpec) -> FitModel:
    """The ``creep`` model with a tip (module docstring): z(t) = z_c + g⁻¹(∫ C(t − s) dF(s)).

    Parameters
    ----------
    spec : ModelSpec
        ``modes`` and ``fixed``: ``tip`` (a Tip or its text), ``creep_history`` = (t, F, z)
        (:attr:`CreepData.history`), ``contact_point`` [m] (fixed) or ``contact_window`` =
        (low, high) [m] (where the fitted one may lie; default the history's tip positions).

    Returns
    -------
    FitModel
        Independent variable ``t`` [s] (from the start of the pause); parameters the material's
        and ``contact_point`` unless given.

    Raises
    ------
    ParameterError
        No tip or history, or both contact_point and contact_window.
    """
    if spec.fixed.get("creep_history") is None:
        raise ParameterError(
            "model 'creep' with a tip needs creep_history = (t, force, tip position) of its "
            "curve (CreepData.history; viscoforce.fitting.creep.fit_creep cuts it): the "
            "Lee-Radok fit is one curve at a time (a map: fit_creep(curves, curve=i, tip=...))")
    tip, history = need(spec, "tip", "creep_history")
    tip = tip_from(tip)
    t_h, f_h, z_h = check_history("creep_history", history)
    given = spec.fixed.get("contact_point")
    window = spec.fixed.get("contact_window")
    if given is not None and window is not None:
        raise ParameterError("give contact_point (fixed) or contact_window (fitted), not both")
    modes = spec.modes

    def psi(t: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        full = creep_integral(t_h, f_h, *creep_compliances(v, modes))
        t = np.asarray(t, dtype=float)
        if t.shape == t_h.shape and np.array_equal(t, t_h):
            return full
        return np.interp(t, t_h, full, left=0.0)

    def function(t: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        c = given if given is not None else v["contact_point"]
        return c + indentation_from_shape(tip, psi(t, v))

    def guesser(z: np.ndarray, t: np.ndarray) -> dict[str, float]:
        return _guess(tip, np.asarray(t, dtype=float), np.asarray(z, dtype=float), t_h, f_h,
                      z_h, given, modes)

    def windows(t: np.ndarray, z: np.ndarray | None = None) -> dict[str, tuple[float, float]]:
        return {"contact_point": window if window is not None else contact_window(tip, z_h)}

    layout = material_layout(modes)
    if given is None:
        layout.append(P.Bounded("contact_point", -1.0, 1.0))
    stored = {**{k: v for k, v in spec.fixed.items() if v is not None}, "tip": tip}
    model = FitModel(ModelSpec(spec.name, modes, stored), function, layout, "t", guesser,
                     tau_window=time_window, bounded_windows=windows)
    model.lee_radok = LeeRadok(tip, t_h, f_h, given, modes)  # type: ignore[attr-defined]
    return model


@dataclass(frozen=True)
class LeeRadok:
    """What a built Lee–Radok model integrates: its tip, force history and fixed contact."""

    tip: Any
    t: np.ndarray
    force: np.ndarray
    contact_point: float | None
    modes: int

    def gain(self, index: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
        """∂z/∂ψ = 1/g'(δ) = 1/a(δ) [1/m] at the history samples ``index`` (0 out of contact)."""
        psi = creep_integral(self.t, self.force, *creep_compliances(values, self.modes))
        depth = indentation_from_shape(self.tip, psi[index])
        radius = np.asarray(self.tip.contact_stiffness_factor(depth), dtype=float)
        return np.where((depth > 0) & (radius > 0), 1.0 / np.where(radius > 0, radius, 1.0), 0.0)


def _guess(tip: Any, t: np.ndarray, z: np.ndarray, t_h: np.ndarray, f_h: np.ndarray,
           z_h: np.ndarray, given: float | None, modes: int) -> dict[str, float]:
    """Contact point from a Hertz grid of the approach, then the SLS whose ψ best fits g(z − z_c).

    For each creep time of a log grid, g(z − z_c) = J_g·F + ΔJ·(F − h_τ) is linear in the
    compliances (least squares); the best positive pair gives E0, E_inf and τ.
    """
    approach = t_h < 0
    c = given
    if c is None:
        best = hertz_grid(tip, z_h[approach], f_h[approach]) if approach.sum() >= 8 else None
        c = float(best[0]) if best is not None else float(np.min(z)) - 0.1 * float(np.ptp(z))
    target = np.asarray(tip.force_shape(np.maximum(z - c, 0.0)), dtype=float)
    force = np.interp(t, t_h, f_h)
    dt = float(np.min(np.diff(t_h)))
    span = float(np.ptp(t_h))
    best_fit: tuple[float, float, float, float] | None = None
    for tau in np.geomspace(3 * dt, 3 * span, _GUESS_TAUS):  # slow = ∫ (1 − e^{−(t−s)/τ}) dF
        slow = np.interp(t, t_h, creep_integral(t_h, f_h, 0.0, np.ones(1), np.array([tau])))
        design = np.column_stack([force, slow])
        scale = np.max(np.abs(design), axis=0)
        scale[scale == 0] = 1.0
        coef, *_ = np.linalg.lstsq(design / scale, target, rcond=None)
        coef = coef / scale
        if coef[0] <= 0 or coef[1] <= 0:
            continue
        sse = float(np.sum((design @ coef - target) ** 2))
        if best_fit is None or sse < best_fit[0]:
            best_fit = (sse, float(coef[0]), float(coef[1]), float(tau))
    if best_fit is None:  # no positive pair: the elastic modulus of the held force
        held = float(np.median(f_h[t_h >= 0]))
        depth = float(np.median(z[t >= 0])) - c
        e = held / max(float(tip.force_shape(max(depth, 1e-12))), 1e-300)
        best_fit = (math.inf, 1.0 / (2 * e), 1.0 / e, span / 5)
    _, j_g, d_j, tau = best_fit
    lo, hi = MODULUS_BOUNDS[0] * 10, MODULUS_BOUNDS[1] / 10
    e0 = min(max(1.0 / j_g, lo), hi)
    e_inf = min(max(1.0 / (j_g + d_j), lo), e0 / 1.01)
    out = (material_guess(e0, e_inf, tau, modes, time_window(t)) if modes > 1 else
           {"E0": e0, "E_inf": e_inf, "tau": tau})
    if given is None:
        out["contact_point"] = float(c)
    return out


def propagated_covariance(model: FitModel, data: CreepData, values: Mapping[str, float]
                          ) -> tuple[np.ndarray | None, dict[str, float]]:
    """Covariance of a Lee–Radok fit with both noises propagated: tip position and force.

    The residual is ε_z − M ε_F + J Δθ: the tip position's own noise ε_z, and the recorded
    force's noise ε_F (white, σ_F = ``data.force_noise``) carried into the model through
    M = diag(1/a(δ)) K S (S the smoothing, K the creep integral's linear map; slow as well as fast,
    and weighted by J_inf at low frequency, so it cannot be absorbed in a per-sample scale). With
    A = (JᵀJ)⁻¹ (J the model's Jacobian over the SPEC parameters, central differences):

        Cov = c σ_z² A + σ_F² A (JᵀM)(JᵀM)ᵀ A,

    JᵀM by the adjoint of K (exact); σ_z² the residual variance less M's share σ_F² tr(MMᵀ)/n
    (trace by :data:`_PROBES` random force vectors, fixed seed), and c = (1 + ρ)/(1 − ρ) the
    project's AR(1) factor of the lag-1 autocorrelation ρ of the residual left once M's expected
    lag-1 covariance is taken out (drift or a model that misses structure; 1 for white noise).

    Returns
    -------
    covariance : numpy.ndarray or None
        Over ``model.names`` (None where JᵀJ is singular).
    info : dict
        ``tip_position_noise`` σ_z [m], ``force_noise`` σ_F [N], ``force_noise_share`` (M's
        share of the residual variance), ``residual_lag1`` ρ (beyond the force's noise) and
        ``stderr_correction`` √c.
    """
    parts: LeeRadok = model.lee_radok  # type: ignore[attr-defined]
    x, n = np.asarray(data.x, dtype=float), data.x.size
    index = np.searchsorted(parts.t, x)
    if np.any(index >= parts.t.size) or not np.array_equal(parts.t[index], x):
        raise ParameterError("the fitted times must be samples of the force history")
    names = model.names
    jac = np.empty((n, len(names)))
    for k, name in enumerate(names):
        if name == "contact_point":
            jac[:, k] = 1.0
            continue
        step = 1e-5 * abs(values[name])
        up, down = dict(values), dict(values)
        up[name], down[name] = values[name] + step, values[name] - step
        jac[:, k] = (model.raw(x, up) - model.raw(x, down)) / (2.0 * step)
    scale = np.linalg.norm(jac, axis=0)
    scale[scale == 0] = 1.0
    try:
        inner = np.linalg.inv((jac / scale).T @ (jac / scale))
    except np.linalg.LinAlgError:
        return None, {}
    a_inv = inner / np.outer(scale, scale)
    residual = np.asarray(data.y, dtype=float) - model.raw(x, values)
    gain = parts.gain(index, values)
    compliances = creep_compliances(values, parts.modes)
    smooth = smoothing_matrix(parts.t.size, data.smoothing)
    size = parts.t.size

    def forward(noise: np.ndarray) -> np.ndarray:  # M ε
        return gain * creep_integral(parts.t, smooth @ noise, *compliances)[index]

    def adjoint(w: np.ndarray) -> np.ndarray:  # Mᵀ w
        full = np.zeros(size)
        full[index] = gain * w
        return smooth.T @ creep_integral_adjoint(parts.t, full, *compliances)

    sigma_f = float(data.force_noise)
    b = np.array([adjoint(jac[:, k]) for k in range(len(names))])
    rng = np.random.default_rng(0)
    probes = [forward(rng.standard_normal(size)) for _ in range(_PROBES)]
    trace = float(np.mean([p @ p for p in probes]))
    lag_trace = float(np.mean([p[:-1] @ p[1:] for p in probes]))
    dof = max(n - len(names), 1)
    s2 = float(residual @ residual) / dof
    var_f = sigma_f ** 2 * trace / n
    var_z = max(s2 - var_f, 0.0)
    centred = residual - residual.mean()
    lag_cov = float(centred[:-1] @ centred[1:]) / n - sigma_f ** 2 * lag_trace / n
    rho = min(max(lag_cov / var_z, 0.0), 0.99) if var_z > 0 else 0.0
    factor = (1.0 + rho) / (1.0 - rho)
    cov = factor * var_z * a_inv + sigma_f ** 2 * (a_inv @ (b @ b.T) @ a_inv)
    return cov, {"tip_position_noise": math.sqrt(var_z), "force_noise": sigma_f,
                 "force_noise_share": var_f / (var_f + var_z) if var_f + var_z > 0 else 0.0,
                 "residual_lag1": rho, "stderr_correction": math.sqrt(factor)}
