"""The ``ting`` model itself: its data (:func:`ting_data`) and its builder (:func:`ting_model`).

The fit of a curve (modes, the drag's autocorrelation, Ting's forms) is :mod:`viscoforce.fitting.ting`.

Approach–retract force curves by Ting's hereditary integral.

The force on the tip over time is (:mod:`viscoforce.physics.ting`)

    F(t) = baseline + baseline_slope·(z(t) − contact_point) + F_Ting(t) + drag·dz/dt,

with z(t) the measured tip position toward the sample (the ``tip_position`` of a curves
dataset: the calibrated sensor height where the file has one, minus the deflection), the
indentation δ(t) = max(z(t) − contact_point, 0), and F_Ting Ting's load for the tip's shape
(``--tip``) and the material:

* ``sls`` — ``tau`` (the CREEP time of Eq. 3), ``E0``, ``E_inf``;
* ``prony`` — ``E0``, ``E_1`` … ``E_{n−1}``, ``E_inf``, ``tau_1`` … ``tau_n`` (creep times,
  ascending), as the ``exact`` model; modes by the criterion;
* ``structural`` — ``E_ref``, ``alpha``, ``mu``: E*(ω) = E_ref (iω/ω_ref)^α + iωμ,
  ω_ref = 2π f_ref (``reference_frequency``, default 1 Hz), i.e. Ting's power law
  E(t) = E0 (t/t0)^(−β) with β = α and E0 = E_ref/(Γ(1 − β)(2π f_ref t0)^β) at t0 = 1 s
  (reported as ``ting_E0`` and ``beta`` by :func:`add_ting_forms`), plus a Newtonian μ.

All moduli are the paper's (2/E = Σ(1 − ν²)/E_i; Young's Y = E(1 − ν²)/2). The contact point is
fitted within the approach (or given), ``baseline`` and ``baseline_slope`` are the free-cantilever
force and tilt as in ``hertz``, and the viscous drag B [N·s/m] is fixed (``drag``, default 0)
or fitted (``fit_drag``). The drag velocity is the Savitzky–Golay derivative of the trace
(:data:`VELOCITY_WINDOW`), so that the sensor noise does not enter the model.

A finite sample thickness (``sample_height`` h, ``sample_base`` bonded or sliding) makes the
tip's elastic law the layer's, F = E·g(δ)·f(δ, h) with the bottom-effect factor f of
:mod:`viscoforce.physics.bottom_effect` (:class:`~viscoforce.physics.layered_tip.LayeredTip`),
and Ting's integral runs over that law: F(t) = ∫ E(t − s) d/ds[g(δ(s))·f(δ(s), h)] ds while the
contact grows, and up to t₁ while it shrinks. This is the correspondence principle applied to the
layer's elastic solution, term by term of the series (each power of δ convolved with E(t)
with its own weight, the form of the bottom-effect corrected power-law force curves of Garcia's
group; the series assumes ν = 0.5, a time-independent ν, so the correspondence holds): it is
exact while the contact grows, and on the retract it keeps
Ting's half-space condition for t₁, an approximation. The cruder alternative, the half-space
Ting force times f(δ(t)) at the current depth, agrees with it in the elastic limit only (on a
power-law ramp the first-order terms differ by the ratio of their Gamma-function weights, e.g.
4.7 % of that term at β = 0.2). A flat punch's factor does not depend on δ: its Ting load is
multiplied by it. The fitted contact point is bounded so that no depth exceeds the series'
accepted range, and a curve deeper than that is refused before the fit (the message names
``sample_height`` and the deepest accepted indentation).

The data (:func:`ting_data`) are the approach and everything after it up to the end of the first
retract that follows (pauses included: a hold at the deepest point is part of Ting's loading
branch), as force over time; the tip-position trace travels with them
(:attr:`TingData.position_trace`) and is the model's fixed ``position_trace``. The guess fits
Hertz to the approach (E, contact point, baseline), estimates the drag from the gap between the
approach and retract baselines, and chooses the material's time scale (``tau`` or ``alpha``) by
the best linear fit of Ting's curve shape to the whole approach–retract loop (the retract's
hysteresis is what measures the dissipation).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from scipy.signal import savgol_filter

from viscoforce._validation import (
    describe_value,
    require_finite,
    require_nonnegative,
    require_positive,
)
from viscoforce.exceptions import ParameterError
from viscoforce.fitting import _params as P
from viscoforce.fitting._layer import layer_window, layered, require_layer_depth
from viscoforce.fitting.base import (
    EXPONENT_BOUNDS,
    MODULUS_BOUNDS,
    REFERENCE_FREQUENCY,
    FitModel,
    ModelSpec,
    material_layout,
    moduli_names,
    tau_names,
)
from viscoforce.fitting.curve_models import baseline_windows, contact_window, hertz_guess, hertz_linear
from viscoforce.fitting.data import FitData
from viscoforce.fitting.guesses import material_guess, time_window
from viscoforce.fitting.segments import _segment_types, _source, segment_runs
from viscoforce.physics.bottom_effect import force_factor
from viscoforce.physics.layered_tip import LayeredTip, layer_attrs
from viscoforce.physics.ting import (
    PowerLawRelaxation,
    PronyRelaxation,
    RelaxationKernel,
    relaxation_from_creep,
    ting_force,
)
from viscoforce.physics.tips import Flat, tip_from
from viscoforce.schema import select_curve, validate_curves

__all__ = ["TING_FIXED", "TING_MATERIALS", "TING_T0", "TingData", "ting_data", "ting_kernel",
           "ting_model"]

#: Materials of the ``ting`` model (``--material``).
TING_MATERIALS = ("sls", "prony", "structural")
#: Fixed inputs of the ``ting`` model (``make_model("ting", **fixed)``).
TING_FIXED = ("tip", "position_trace", "material", "drag", "fit_drag", "contact_point",
              "contact_window", "reference_frequency", "newtonian", "sample_height",
              "sample_base")
#: Ting's reference time t0 [s] of the reported power law E(t) = E0 (t/t0)^(−β).
TING_T0 = 1.0
#: Samples of the Savitzky–Golay window (order 2) whose derivative is the drag velocity.
VELOCITY_WINDOW = 21
#: Creep times tried by the guess, as multiples of the contact time (loading + unloading).
_TAU_FACTORS = (0.03, 0.1, 0.3, 1.0, 3.0)
#: E0/E_inf ratios tried by the guess.
_RATIOS = (1.5, 3.0, 10.0)
#: Power-law exponents tried by the guess.
_ALPHAS = (0.03, 0.08, 0.15, 0.25, 0.35, 0.5, 0.7)


@dataclass(frozen=True)
class TingData(FitData):
    """Force over time of an approach–retract curve, with its tip-position trace.

    ``x`` is the time [s] from the first sample, ``y`` the force [N] and ``position`` the tip
    position z [m] toward the sample at each ``x``.
    """

    position: np.ndarray | None = None

    @property
    def position_trace(self) -> tuple[np.ndarray, np.ndarray]:
        """(t [s], z [m]): the ``position_trace`` fixed input of the ``ting`` model."""
        if self.position is None:
            raise ParameterError("these data carry no tip-position trace")
        return self.x, self.position


# ── data ────────────────────────────────────────────────────────────────────────────────────


def ting_data(curves: xr.Dataset, *, curve: int = 0, segment: int | None = None) -> TingData:
    """Time, force and tip position of the approach and retract of one curve.

    Parameters
    ----------
    curves : xarray.Dataset
        A curves dataset (:mod:`viscoforce.schema.curves`).
    curve : int
        The curve (pixel), from 0.
    segment : int, optional
        Fit only this segment of the curve (from 0, file order; e.g. the approach alone).
        Default: the first approach and every segment after it up to and including the first
        retract (pauses included); the approach alone where no retract follows.

    Returns
    -------
    TingData
        ``x`` time [s] from the first sample, ``y`` force [N] as recorded (the model fits its
        baseline), ``position`` tip position [m]; ``source`` names the segments.

    Raises
    ------
    ParameterError
        No approach (or ``segment`` out of range), too few finite samples, no tip position
        (a file without a height channel), or a time that does not increase.
    """
    one = select_curve(validate_curves(curves), curve)
    runs = segment_runs(one)
    listing = ", ".join(r[2] for r in runs) or "none"
    if segment is not None:
        if isinstance(segment, bool) or not isinstance(segment, int | np.integer) or not (
                0 <= segment < len(runs)):
            raise ParameterError(f"segment must be an integer in [0, {len(runs) - 1}] (the "
                                 f"curve has {len(runs)} segments: {listing}), got {segment!r}")
        chosen = [runs[int(segment)]]
    else:
        first = next((i for i, r in enumerate(runs) if r[2] == "approach"), None)
        if first is None:
            raise ParameterError(f"the ting model fits an approach (and its retract); this "
                                 f"curve's segments are {listing}: give --segment N")
        last = next((i for i in range(first + 1, len(runs)) if runs[i][2] == "retract"), first)
        chosen = runs[first:last + 1]
    start, stop = chosen[0][0], chosen[-1][1]
    t = np.asarray(one["time"].values[start:stop], dtype=float)
    f = np.asarray(one["force"].values[start:stop], dtype=float)
    z = np.asarray(one["tip_position"].values[start:stop], dtype=float)
    ok = np.isfinite(t) & np.isfinite(f) & np.isfinite(z)
    if ok.sum() < 8:
        note = str(one.attrs.get("tip_position_channel", ""))  # the reader's why, if it says
        missing = "" if np.isfinite(z).any() else (
            f" ({note})" if note.startswith("unavailable") else " (the file gives no tip position)")
        raise ParameterError(f"the approach-retract has {int(ok.sum())} finite samples of time, "
                             f"force and tip position; need >= 8{missing}")
    notes: tuple[str, ...] = ()
    if not ok.all():
        notes = (f"{int((~ok).sum())} samples without a finite time, force or tip position "
                 "were left out",)
    t, f, z = t[ok], f[ok], z[ok]
    if np.any(np.diff(t) <= 0):
        raise ParameterError("the time of the approach-retract must increase strictly (the "
                             "segments do not follow each other in time)")
    source = _source(curves, one, chosen[0], t.size, curve)
    source["segments"] = ", ".join(r[2] for r in chosen)
    types = _segment_types(one)
    if types is not None:
        seg = np.asarray(one["segment"].values)
        source["segment_type"] = ", ".join(str(types[int(seg[r[0]])]) for r in chosen)
    source["tip_position_reference"] = str(curves.attrs.get(
        "tip_position_convention", "tip position toward the sample"))
    return TingData(t - t[0], f, None, source, notes=notes, position=z)


# ── the model ───────────────────────────────────────────────────────────────────────────────


def ting_kernel(material: str, values: Mapping[str, float], modes: int = 1, *,
                reference_frequency: float = REFERENCE_FREQUENCY) -> RelaxationKernel:
    """The relaxation modulus of a ``ting`` parameter set (SPEC names, SI).

    Parameters
    ----------
    material : {"sls", "prony", "structural"}
        The material.
    values : mapping
        ``tau``, ``E0``, ``E_inf`` (sls); ``E0``, ``E_i``, ``E_inf``, ``tau_i`` (prony);
        ``E_ref``, ``alpha`` and optionally ``mu`` (structural).
    modes : int
        Modes of a prony material.
    reference_frequency : float
        f_ref [Hz] of ``E_ref``.

    Returns
    -------
    RelaxationKernel
        :class:`~viscoforce.physics.ting.PronyRelaxation` (creep → relaxation) or
        :class:`~viscoforce.physics.ting.PowerLawRelaxation` at t0 = :data:`TING_T0`.

    Raises
    ------
    ParameterError
        Unknown material or out-of-range values.
    """
    if material == "structural":
        return PowerLawRelaxation.from_structural(values["E_ref"], values["alpha"],
                                                  values.get("mu", 0.0), reference_frequency,
                                                  TING_T0)
    if material not in TING_MATERIALS:
        raise ParameterError(f"material must be one of {', '.join(TING_MATERIALS)}, got "
                             f"{material!r}")
    if modes == 1 and "tau" in values:
        e = np.array([values["E0"], values["E_inf"]])
        taus = np.array([values["tau"]])
    else:
        e = np.array([values[n] for n in moduli_names(modes)])
        taus = np.array([values[n] for n in tau_names(modes, single="")])
    return _prony_relaxation(tuple(float(v) for v in e), tuple(float(v) for v in taus))


@functools.lru_cache(maxsize=16)
def _prony_relaxation(moduli: tuple[float, ...], taus: tuple[float, ...]) -> PronyRelaxation:
    """The relaxation series of creep moduli (E0, E1, ..., E_inf) and creep times ``taus``.

    Kept (16 entries): a fit's finite-difference columns in the contact point and baseline, and
    the refits that hold the material, ask for the same series again.
    """
    e = np.array(moduli)
    e_inf, rel, times = relaxation_from_creep(1.0 / e[0], 1.0 / e[1:] - 1.0 / e[:-1],
                                              np.array(taus))
    return PronyRelaxation(e_inf, tuple(rel), tuple(times))


def _trace(value: Any) -> tuple[np.ndarray, np.ndarray]:
    try:
        t, z = (np.asarray(a, dtype=float) for a in value)
    except (TypeError, ValueError):
        raise ParameterError(f"position_trace must be (t [s], z [m]) arrays, got "
                             f"{describe_value(value)}") from None
    if t.ndim != 1 or t.shape != z.shape or t.size < 8:
        raise ParameterError(f"position_trace must be two 1-D arrays of the same length >= 8, "
                             f"got shapes {t.shape} and {z.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(z)) and np.all(np.diff(t) > 0)):
        raise ParameterError("position_trace must be finite with strictly increasing times")
    return t, z


def _checked(spec: ModelSpec) -> dict[str, Any]:
    """The fixed inputs of a ting spec, validated (the message names the input and its range)."""
    fixed = dict(spec.fixed)
    unknown = sorted(set(fixed) - set(TING_FIXED))
    if unknown:
        raise TypeError(f"model 'ting' takes no input {', '.join(unknown)}; its inputs: "
                        f"{', '.join(TING_FIXED)}")
    if fixed.get("tip") is None:
        raise ParameterError("model 'ting' needs tip (--tip sphere:R | paraboloid:R | "
                             "cone:ANGLE | pyramid:ANGLE | flat:RADIUS)")
    if fixed.get("position_trace") is None:
        raise ParameterError("model 'ting' needs position_trace = (t, z), the tip-position trace "
                             "of the curve (TingData.position_trace)")
    out: dict[str, Any] = {"tip": tip_from(fixed["tip"]),
                           "position_trace": _trace(fixed["position_trace"])}
    material = fixed.get("material") or "sls"
    if material not in TING_MATERIALS:
        raise ParameterError(f"material must be one of {', '.join(TING_MATERIALS)} for the ting "
                             f"model, got {material!r}")
    out["material"] = material
    out["drag"] = 0.0 if fixed.get("drag") is None else require_nonnegative("drag",
                                                                            fixed["drag"])
    for flag in ("fit_drag", "newtonian"):
        value = fixed.get(flag)
        if value is not None and not isinstance(value, bool | np.bool_):
            raise ParameterError(f"{flag} must be True or False, got {value!r}")
    out["fit_drag"] = bool(fixed.get("fit_drag") or False)
    if out["fit_drag"] and fixed.get("drag") is not None:
        raise ParameterError("give drag (fixed) or fit_drag=True, not both")
    newtonian = fixed.get("newtonian")
    if newtonian is not None and material != "structural":
        raise ParameterError(f"newtonian sets the viscosity mu of material 'structural'; "
                             f"material {material!r} has none")
    out["newtonian"] = True if newtonian is None else bool(newtonian)
    f_ref = fixed.get("reference_frequency")
    if f_ref is not None and material != "structural":
        raise ParameterError(f"reference_frequency is the f_ref of material 'structural'; "
                             f"material {material!r} has none")
    out["reference_frequency"] = (REFERENCE_FREQUENCY if f_ref is None else
                                  require_positive("reference_frequency", f_ref))
    c = fixed.get("contact_point")
    out["contact_point"] = None if c is None else require_finite("contact_point", c)
    window = fixed.get("contact_window")
    if window is not None:
        try:
            lo, hi = (float(v) for v in window)
        except (TypeError, ValueError):
            raise ParameterError(f"contact_window must be (low, high) tip positions [m], got "
                                 f"{window!r}") from None
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ParameterError(f"contact_window must be finite (low, high) with low < high "
                                 f"[m], got {window!r}")
        window = (lo, hi)
    if window is not None and c is not None:
        raise ParameterError("give contact_point (fixed) or contact_window (fitted), not both")
    out["contact_window"] = window
    out["layer"] = layered(out["tip"], fixed)
    if spec.modes > 1 and material != "prony":
        raise ParameterError(f"ting with modes > 1 needs material='prony' (--material prony), "
                             f"got material {material!r}")
    return out


def _velocity(t: np.ndarray, z: np.ndarray) -> np.ndarray:
    """dz/dt [m/s]: Savitzky–Golay (order 2) on a uniform grid, central differences otherwise."""
    steps = np.diff(t)
    window = min(VELOCITY_WINDOW, t.size - (1 - t.size % 2))
    if window >= 5 and float(np.ptp(steps)) <= 1e-6 * float(np.mean(steps)):
        return savgol_filter(z, window, 2, deriv=1, delta=float(np.mean(steps)))
    return np.gradient(z, t)


def ting_model(spec: ModelSpec) -> FitModel:
    """The ``ting`` lmfit model of ``spec`` (name, modes, fixed inputs).

    Parameters
    ----------
    spec : ModelSpec
        ``modes`` (prony), and ``fixed``: ``tip`` (a Tip or its text, required),
        ``position_trace`` = (t, z) (required; :attr:`TingData.position_trace`), ``material``
        (``sls`` default, ``prony``, ``structural``), ``drag`` B [N·s/m] (fixed, default 0) or
        ``fit_drag`` True, ``contact_point`` [m] (fixed) or ``contact_window`` = (low, high) [m]
        (fitted; default the approach's range), ``reference_frequency`` [Hz] (structural, default
        1 Hz), ``newtonian`` (structural: fit μ, default True; False is Ting's pure power law),
        ``sample_height`` h [m] and ``sample_base`` (``"bonded"`` default, ``"sliding"``): the
        bottom-effect correction (module docstring).

    Returns
    -------
    FitModel
        Independent variable ``t`` [s]; parameters: the material's, ``contact_point`` (unless
        fixed), ``baseline``, ``baseline_slope`` and ``drag`` (when fitted).

    Raises
    ------
    ParameterError
        A missing or out-of-range input (the message names it), or (with ``sample_height``) a
        fixed contact point deeper than the bottom-effect series accepts.
    TypeError
        An input the model does not take.
    """
    fixed = _checked(spec)
    plain, tip, material = fixed["tip"], fixed["layer"], fixed["material"]
    trace_t, trace_z = fixed["position_trace"]
    # a flat punch keeps Ting's constant-radius form (physics.ting switches on Flat): its
    # layer factor does not depend on δ, so it scales the load
    hereditary, scale = tip, 1.0
    if isinstance(tip, LayeredTip) and isinstance(plain, Flat):
        hereditary, scale = plain, float(force_factor(plain, 0.0, tip.sample_height,
                                                      bonded=tip.bonded))
    velocity = _velocity(trace_t, trace_z)
    modes, f_ref = spec.modes, fixed["reference_frequency"]
    newtonian = material != "structural" or fixed["newtonian"]
    given_c, drag, fit_drag = fixed["contact_point"], fixed["drag"], fixed["fit_drag"]
    turning = int(np.argmax(trace_z))
    if given_c is not None and isinstance(tip, LayeredTip):  # refused now, not in the fit
        tip.force_shape(max(float(np.max(trace_z)) - given_c, 0.0))

    def kernel(v: Mapping[str, float]) -> RelaxationKernel:
        return ting_kernel(material, v, modes, reference_frequency=f_ref)

    def function(t: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        c = given_c if given_c is not None else v["contact_point"]
        b = v["drag"] if fit_drag else drag
        if scale == 1.0:
            load = ting_force(trace_t, trace_z, c, hereditary, kernel(v), drag=b,
                              velocity=velocity)
        else:
            load = scale * ting_force(trace_t, trace_z, c, hereditary, kernel(v)) + b * velocity
        force = v["baseline"] + v["baseline_slope"] * (trace_z - c) + load
        t = np.asarray(t, dtype=float)
        if t.shape == trace_t.shape and np.array_equal(t, trace_t):
            return force
        return np.interp(t, trace_t, force)

    def guesser(f: np.ndarray, t: np.ndarray) -> dict[str, float]:
        t, f = np.asarray(t, dtype=float), np.asarray(f, dtype=float)
        if t.shape != trace_t.shape or not np.array_equal(t, trace_t):
            # a subset of the samples (the split-half check's halves): the guess reads the
            # whole trace, so the force is taken onto it
            f = np.interp(trace_t, t, f)
        if given_c is None:
            require_layer_depth(tip, trace_z[:turning + 1],
                                np.asarray(f, dtype=float)[:turning + 1])
        return _guess(np.asarray(f, dtype=float), trace_t, trace_z, velocity, hereditary, material,
                      modes, f_ref, newtonian, given_c, drag, fit_drag, turning)

    def windows(t: np.ndarray, f: np.ndarray | None = None) -> dict[str, tuple[float, float]]:
        given = fixed["contact_window"]
        out = {"contact_point": layer_window(tip, trace_z, given) if given is not None
               else contact_window(tip, trace_z[:turning + 1])}
        if f is not None:
            out.update(baseline_windows(f, trace_z))
            span = float(np.ptp(f)) or float(np.max(np.abs(f))) or 1e-12
            out["drag"] = (0.0, 10 * span / max(float(np.max(np.abs(velocity))), 1e-30))
        return out

    layout = _layout(material, modes, newtonian)
    if given_c is None:
        layout.append(P.Bounded("contact_point", -1.0, 1.0))
    layout += [P.Bounded("baseline", -1.0, 1.0), P.Bounded("baseline_slope", -1.0, 1.0)]
    if fit_drag:
        layout.append(P.Bounded("drag", 0.0, 1.0))
    stored = {**{k: v for k, v in spec.fixed.items() if v is not None}, "tip": plain,
              "material": material}
    if isinstance(tip, LayeredTip):
        stored.update(layer_attrs(tip))
    if material == "structural":
        stored.update(reference_frequency=f_ref, newtonian=bool(newtonian))
    if not fit_drag:
        stored["drag"] = drag
    return FitModel(ModelSpec(spec.name, modes, stored), function, layout, "t", guesser,
                    tau_window=time_window if material != "structural" else None,
                    bounded_windows=windows)


def _layout(material: str, modes: int, newtonian: bool) -> list[P.Item]:
    if material == "structural":
        return [P.Chain(("E_ref",), MODULUS_BOUNDS), P.Bounded("alpha", *EXPONENT_BOUNDS),
                *([P.Chain(("mu",))] if newtonian else [])]
    return material_layout(modes)


# ── the guess ───────────────────────────────────────────────────────────────────────────────


def _guess(f: np.ndarray, t: np.ndarray, z: np.ndarray, velocity: np.ndarray, tip: Any,
           material: str, modes: int, f_ref: float, newtonian: bool, given_c: float | None,
           drag: float, fit_drag: bool, turning: int) -> dict[str, float]:
    """Hertz on the approach, the drag from the baselines, the time scale from the loop."""
    approach = slice(0, turning + 1)
    if given_c is None:
        hz = hertz_guess(tip, z[approach], f[approach])
        c = hz["contact_point"]
    else:
        c = given_c
        coef, _ = hertz_linear(tip, z[approach], f[approach], c)
        hz = {"E": float(coef[0])}
    e_hertz = min(max(float(hz["E"]), MODULUS_BOUNDS[0] * 10), MODULUS_BOUNDS[1] / 10)
    b = drag
    if fit_drag:
        b = _drag_guess(f, z, velocity, c, turning)
    out: dict[str, float] = {} if given_c is not None else {"contact_point": c}
    if fit_drag:
        out["drag"] = b
    contact = np.flatnonzero(z[approach] > c)
    loop_time = 2.0 * (t[turning] - t[contact[0]]) if contact.size else float(np.ptp(t)) / 2
    loop_time = max(loop_time, 10 * float(np.min(np.diff(t))))
    target = f - b * velocity
    best: tuple[float, dict[str, float], np.ndarray] | None = None
    for shape in _shapes(material, loop_time, f_ref):
        unit = ting_force(t, z, c, tip, ting_kernel(material, shape, 1,
                                                    reference_frequency=f_ref))
        design = np.column_stack([unit, np.ones_like(t), z - c])
        scale = np.max(np.abs(design), axis=0)
        scale[scale == 0] = 1.0
        coef, *_ = np.linalg.lstsq(design / scale, target, rcond=None)
        coef = coef / scale
        sse = float(np.sum((design @ coef - target) ** 2))
        if coef[0] > 0 and (best is None or sse < best[0]):
            best = (sse, shape, coef)
    if best is None:  # no shape rises with the indentation: start from Hertz
        best = (math.inf, next(iter(_shapes(material, loop_time, f_ref))),
                np.array([e_hertz / 2, float(np.median(f)), 0.0]))
    _, shape, coef = best
    amplitude = float(coef[0])
    out.update(baseline=float(coef[1]), baseline_slope=float(coef[2]))
    if material == "structural":
        out.update(E_ref=_clip_modulus(amplitude), alpha=shape["alpha"])
        if newtonian:  # |iωμ| a hundredth of E_ref at the loop's frequency
            out["mu"] = 0.01 * out["E_ref"] * loop_time / (2 * math.pi)
        return out
    e_inf = _clip_modulus(amplitude)
    e0 = _clip_modulus(amplitude * shape["E0"])
    out.update(material_guess(e0, e_inf, shape["tau"], modes,
                               time_window(t)) if modes > 1 else
               {"E0": e0, "E_inf": e_inf, "tau": shape["tau"]})
    return out


def _clip_modulus(value: float) -> float:
    return min(max(value, MODULUS_BOUNDS[0] * 10), MODULUS_BOUNDS[1] / 10)


def _shapes(material: str, loop_time: float, f_ref: float) -> list[dict[str, float]]:
    """Unit-modulus materials whose best scale the guess fits (E_inf or E_ref = 1 Pa)."""
    if material == "structural":
        return [{"E_ref": 1.0, "alpha": a} for a in _ALPHAS]
    return [{"E_inf": 1.0, "E0": r, "tau": k * loop_time} for k in _TAU_FACTORS for r in _RATIOS]


def _drag_guess(f: np.ndarray, z: np.ndarray, velocity: np.ndarray, c: float,
                turning: int) -> float:
    """B from the gap between the approach and retract baselines: ΔF = B (v_approach − v_retract)."""
    free = z < c - 0.1 * max(c - float(np.min(z)), 0.0)
    app = free & (np.arange(z.size) <= turning)
    ret = free & (np.arange(z.size) > turning)
    if app.sum() < 4 or ret.sum() < 4:
        return 0.0
    dv = float(np.median(velocity[app]) - np.median(velocity[ret]))
    if not dv > 0:
        return 0.0
    return max(float(np.median(f[app]) - np.median(f[ret])) / dv, 0.0)
