"""lmfit models of the SPEC's Models table.

svda, exact, contact, prony, relaxation, step, hertz and creep.

Each model is an :class:`lmfit.Model` over plain functions of the project's physics whose
parameters carry the SPEC's exact names (``tau``, ``E0``, ``E_inf``; ``E_1``…, ``tau_1``…;
``k_inf``, ``dk_i``; ``F_inf``, ``dF_i``; ``C1``, ``m``; ``E``, ``contact_point``; ``z_inf``,
``dz_i``). The spectrum models return the complex stiffness k*(ω) = F̂/δ̂ [N/m] (phase = lead of
the force over the indentation); the curve models a force [N] over time (relaxation, step), a
force [N] over the tip position (hertz) or a tip position [m] over time (creep).
:meth:`FitModel.guess` derives a start from the data alone, with the ordering constraints of
:mod:`viscoforce.fitting._params`.

Build a model with :func:`make_model`; the ``spec`` (name, modes, fixed inputs) is what travels to
dask workers, which rebuild the model there (closures over a problem do not pickle cheaply).
"""

from __future__ import annotations

import inspect
import math
import statistics
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import lmfit
import numpy as np
from scipy.special import gamma

from viscoforce.exceptions import ModelValidityError, ParameterError
from viscoforce.fitting import _params as P
from viscoforce.physics.materials import PronySeries, StandardLinearSolid, ViscoelasticMaterial
from viscoforce.problem import ContactProblem

#: Model names of the SPEC table (``--model``).
MODEL_NAMES = ("svda", "exact", "contact", "prony", "relaxation", "step", "hertz", "creep",
               "ting")
#: Materials of the ``contact`` model (``--material``).
CONTACT_MATERIALS = ("sls", "prony", "power-law", "structural")
#: Reference frequency f_ref [Hz] of the structural material's E_ref (default of the fixed input).
REFERENCE_FREQUENCY = 1.0
#: Window of the power-law exponents (alpha, m): open (0, 1), kept off the singular ends.
EXPONENT_BOUNDS = (1e-3, 0.999)
#: Models whose data are spectra (the others fit force curves over time).
SPECTRUM_MODELS = ("svda", "exact", "contact", "prony")
#: Models with a number of relaxation modes (``--modes``).
MODAL_MODELS = ("exact", "contact", "prony", "relaxation", "creep", "ting")
#: Models of force curves measured on an instrument (a curves dataset: one segment of a curve).
CURVE_MODELS = ("relaxation", "hertz", "creep", "ting")
#: Largest number of modes tried by ``modes="auto"``.
MAX_AUTO_MODES = 4

#: Decades beyond the measured window that a relaxation time may reach (its bounds).
TAU_MARGIN_DECADES = 3.0
#: Modulus window [Pa] of every fit (a soft gel to diamond).
MODULUS_BOUNDS = (1.0, 1e13)


@dataclass(frozen=True)
class ModelSpec:
    """What defines a model: its name, number of modes and fixed inputs (SI).

    ``fixed`` holds e.g. ``position`` or ``mean_force``, ``radius``, ``indentation``, ``drag``,
    ``material``, ``segment``; ``problem`` (a ContactProblem) for the exact and step models.
    """

    name: str
    modes: int = 1
    fixed: Mapping[str, Any] = field(default_factory=dict)


class FitModel(lmfit.Model):
    """An lmfit Model with a SPEC parameter layout and a data-driven :meth:`guess`.

    Attributes
    ----------
    spec : ModelSpec
        Name, modes and fixed inputs.
    layout : list
        The parameter layout (:mod:`viscoforce.fitting._params`).
    independent : str
        ``"omega"`` (spectrum models) or ``"t"`` (curve models).
    """

    def __init__(self, spec: ModelSpec, function: Callable[..., np.ndarray],
                 layout: Sequence[P.Item], independent: str,
                 guesser: Callable[[np.ndarray, np.ndarray], dict[str, float]],
                 tau_window: Callable[[np.ndarray], tuple[float, float]] | None = None,
                 bounded_windows: Callable[..., dict[str, tuple[float, float]]] | None = None):
        self.spec = spec
        self._bounded_windows = bounded_windows
        self.layout = list(layout)
        self.independent = independent
        self._guesser = guesser
        self._tau_window = tau_window
        #: ``raw(x, values)``: the model function on a mapping of SPEC values (no signature
        #: binding: what the fit loop calls).
        self.raw = function
        names = P.reported_names(layout)
        super().__init__(_signed(function, independent, names), independent_vars=[independent],
                         name=spec.name)

    @property
    def names(self) -> list[str]:
        """The SPEC parameter names, in layout order."""
        return P.reported_names(self.layout)

    def parameters_from(self, values: Mapping[str, float], x: np.ndarray, *,
                        expressions: bool = True, y: np.ndarray | None = None
                        ) -> lmfit.Parameters:
        """Parameters starting at ``values`` (SPEC names), with the bounds for data over ``x``.

        ``expressions=False``: the internal parameters only (see
        :func:`viscoforce.fitting._params.build_parameters`). ``y``: the data, for models whose
        bounded parameters take their window from it (hertz: baseline, slope).
        """
        return P.build_parameters(self._fitted_layout(x, y), values, expressions=expressions)

    def _fitted_layout(self, x: np.ndarray, y: np.ndarray | None) -> list[P.Item]:
        """The layout with the windows that data over ``x`` (and ``y``) give its parameters."""
        layout = self.layout
        if self._bounded_windows is not None:
            windows = self._bounded_windows(x, y)
            layout = [P.Bounded(i.name, *windows[i.name]) if isinstance(i, P.Bounded)
                      and i.name in windows else i for i in layout]
        if self._tau_window is not None:
            window = self._tau_window(x)
            layout = [P.Chain(i.names, window) if isinstance(i, P.Chain) and i.names[0].startswith(
                "tau") else i for i in layout]
        return [P.Chain(i.names, MODULUS_BOUNDS) if isinstance(i, P.Chain) and i.names[0] in (
            "E_inf", "E0", "E") else i for i in layout]

    def guess(self, data: np.ndarray, x: np.ndarray | None = None, **kws: Any) -> lmfit.Parameters:
        """Starting parameters from the data alone (complex k* over ω, or F over t)."""
        if x is None:
            x = kws.get(self.independent)
        if x is None:
            raise ParameterError(f"guess needs the independent variable {self.independent!r}")
        x = np.asarray(x, dtype=float)
        return self.parameters_from(self._guesser(np.asarray(data), x), x, y=np.asarray(data))

    def internal_guess(self, data: np.ndarray, x: np.ndarray) -> P.InternalParameters:
        """The internal (``log_…``) parameters of :meth:`guess`, without the expressions.

        What the fitting engine varies (``.to_lmfit()`` for lmfit's own minimiser).
        """
        x = np.asarray(x, dtype=float)
        y = np.asarray(data)
        guess = self._guesser(y, x)  # first: its errors name the data's problem
        return P.internal_parameters(self._fitted_layout(x, y), guess)


def _signed(function: Callable[..., np.ndarray], independent: str,
            names: Sequence[str]) -> Callable[..., np.ndarray]:
    """``function(x, **params)`` with an explicit signature, which lmfit reads for the names."""

    def model(*args: Any, **kwargs: Any) -> np.ndarray:
        bound = signature.bind(*args, **kwargs)
        values = dict(bound.arguments)
        return function(values.pop(independent), values)

    par = inspect.Parameter
    signature = inspect.Signature(
        [par(independent, par.POSITIONAL_OR_KEYWORD)]
        + [par(n, par.POSITIONAL_OR_KEYWORD, default=1.0) for n in names])
    model.__signature__ = signature  # type: ignore[attr-defined]
    model.__name__ = "viscoforce_model"
    return model


# ── parameter names ─────────────────────────────────────────────────────────────────────────────

def moduli_names(modes: int) -> list[str]:
    """E0, E_1 … E_{n−1}, E_inf (descending moduli) of an n-mode material."""
    return ["E0", *(f"E_{i}" for i in range(1, modes)), "E_inf"]


def tau_names(modes: int, *, single: str = "tau") -> list[str]:
    """``tau`` for one mode (``single``), else tau_1 … tau_n (ascending)."""
    return [single] if modes == 1 and single else [f"tau_{i}" for i in range(1, modes + 1)]


def _material_layout(modes: int) -> list[P.Item]:
    return [P.Chain(tuple(reversed(moduli_names(modes)))), P.Chain(tuple(tau_names(modes)))]


def material_from(values: Mapping[str, float], modes: int) -> ViscoelasticMaterial:
    """The Prony material of an n-mode parameter set (SPEC names)."""
    if modes == 1:
        return StandardLinearSolid(values["E0"], values["E_inf"], values["tau"])
    moduli = [values[n] for n in moduli_names(modes)]
    return PronySeries.from_moduli(moduli, [values[n] for n in tau_names(modes)])


# ── guesses from the data ───────────────────────────────────────────────────────────────────────

@dataclass(frozen=True)
class SpectrumFeatures:
    """What a guess reads off a spectrum: low/high-frequency |k*|, the phase peak, the window."""

    k_low: float
    k_high: float
    omega_low: float
    omega_high: float
    omega_peak: float

    @classmethod
    def of(cls, k: np.ndarray, omega: np.ndarray) -> SpectrumFeatures:
        """Features of k*(ω) (the phase peak by a parabola in log ω through the top three)."""
        order = np.argsort(omega)
        w, k = omega[order], k[order]
        mag, phase = np.abs(k), np.angle(k)
        n_end = max(1, w.size // 10)
        i = int(np.argmax(phase))
        peak = float(w[i])
        if 0 < i < w.size - 1:  # parabola through the peak in log ω
            x0, x1, x2 = (math.log(v) for v in w[i - 1:i + 2].tolist())
            y0, y1, y2 = phase[i - 1:i + 2].tolist()
            left, right = (y1 - y0) / (x1 - x0), (y2 - y1) / (x2 - x1)
            if right < left:  # concave: the vertex is between the outer two points
                vertex = 0.5 * (x0 + x1) - left * (x2 - x0) / (2.0 * (right - left))
                peak = min(max(math.exp(vertex), float(w[i - 1])), float(w[i + 1]))
        return cls(statistics.median(mag[:n_end].tolist()),
                   statistics.median(mag[-n_end:].tolist()), float(w[0]), float(w[-1]), peak)

    def sls_tau(self) -> float:
        """τ of a one-mode transfer (1 + iωτ)/(a + iωτ b): its phase peaks at ωτ = √(a/b)."""
        ratio = max(self.k_high / self.k_low, 1.0 + 1e-6) if self.k_low > 0 else 2.0
        return math.sqrt(ratio) / self.omega_peak


def _spread(center: float, modes: int, window: tuple[float, float]) -> list[float]:
    """``modes`` values log-spaced around ``center`` within ``window`` (a decade apart at most)."""
    if modes == 1:
        return [center]
    lo, hi = math.log10(window[0]), math.log10(window[1])
    step = min(1.0, (hi - lo) / (modes + 1))
    c = min(max(math.log10(center), lo + step * (modes - 1) / 2), hi - step * (modes - 1) / 2)
    return [10 ** (c + step * (i - (modes - 1) / 2)) for i in range(modes)]


def _geometric(high: float, low: float, modes: int) -> list[float]:
    """E0 … E_inf: ``modes`` + 1 values from ``high`` down to ``low``, geometric."""
    high = max(high, low * (1 + 1e-3))
    return [high * (low / high) ** (i / modes) for i in range(modes + 1)]


def _material_guess(e_high: float, e_low: float, tau: float, modes: int,
                    window: tuple[float, float]) -> dict[str, float]:
    out = dict(zip(moduli_names(modes), _geometric(e_high, e_low, modes), strict=True))
    out.update(zip(tau_names(modes), _spread(tau, modes, window), strict=True))
    return out


def _omega_window(omega: np.ndarray) -> tuple[float, float]:
    """Bounds of a creep or relaxation time measured over ``omega`` [s]."""
    margin = 10 ** TAU_MARGIN_DECADES
    return 1.0 / (np.max(omega) * margin), margin / np.min(omega)


def _time_window(t: np.ndarray) -> tuple[float, float]:
    steps = np.diff(np.sort(t))
    dt = float(np.min(steps[steps > 0])) if np.any(steps > 0) else 1e-6
    span = float(np.ptp(t)) or dt
    margin = 10 ** TAU_MARGIN_DECADES
    return dt / margin, span * margin


def _solve_modulus(stiffness: Callable[[float], float], target: float, start: float) -> float:
    """E with stiffness(E) = target by a secant in log–log (stiffness grows like a power of E)."""
    lo_bound, hi_bound = MODULUS_BOUNDS
    e1, k1 = start, stiffness(start)
    e2 = start * 2.0
    k2 = stiffness(e2)
    for _ in range(12):
        slope = math.log(k2 / k1) / math.log(e2 / e1) if k2 != k1 else 1.0
        slope = min(max(slope, 0.05), 2.0)
        e_new = e2 * (target / k2) ** (1.0 / slope)
        e_new = min(max(e_new, lo_bound * 10), hi_bound / 10)
        e1, k1, e2 = e2, k2, e_new
        k2 = stiffness(e2)
        if abs(math.log(k2 / target)) < 1e-3:
            break
    return e2


def _moduli_from_levels(function: Callable[[np.ndarray, dict[str, float]], np.ndarray],
                        feats: SpectrumFeatures, start: float) -> tuple[float, float]:
    """E_inf and E0 whose relaxed and glassy |k*| match the spectrum's low and high levels."""
    slow, fast = 1e-4 / feats.omega_high, 1e4 / feats.omega_low

    def relaxed(e: float) -> float:
        return float(abs(function(np.array([feats.omega_low]), {
            "E_inf": e, "E0": 1.001 * e, "tau": slow})[0]))

    e_inf = _solve_modulus(relaxed, feats.k_low, start)

    def glassy(e: float) -> float:
        return float(abs(function(np.array([feats.omega_high]), {
            "E_inf": e_inf, "E0": max(e, 1.0001 * e_inf), "tau": fast})[0]))

    e0 = _solve_modulus(glassy, max(feats.k_high, feats.k_low * 1.01), 2 * e_inf)
    return e_inf, max(e0, 1.05 * e_inf)


# ── spectrum models ─────────────────────────────────────────────────────────────────────────────

def _need(spec: ModelSpec, *names: str) -> list[Any]:
    missing = [n for n in names if spec.fixed.get(n) is None]
    if missing:
        raise ParameterError(f"model {spec.name!r} needs {', '.join(missing)}")
    return [spec.fixed[n] for n in names]


def _position_choice(spec: ModelSpec) -> tuple[float | None, float | None]:
    position, mean_force = spec.fixed.get("position"), spec.fixed.get("mean_force")
    if (position is None) == (mean_force is None):
        raise ParameterError(
            f"model {spec.name!r} needs the mean position: give h0 (--h0) or the mean force "
            "(--mean-force, the static E_inf load of the setpoint), not "
            + ("both" if position is not None else "neither"))
    return position, mean_force


def svda_position(mean_force: float, E_inf: float, radius: float, P: float,  # noqa: N803
                  debye_length: float) -> float:
    """h̄0 [m] whose static SVDA (E_inf) load is ``mean_force`` [N] (explicit for p = P e^{−κh}).

    The Derjaguin load F = (2πRP/κ) e^{−κg} gives the centre gap g, and the static Eq. 18
    u0 = −√(8πR/κ)(P/E_inf) e^{−κg} the deformation: h̄0 = g + u0.
    """
    kappa = 1.0 / debye_length
    scale = 2.0 * math.pi * radius * P / kappa
    if not mean_force > 0:
        raise ParameterError(f"mean_force must be > 0 N for the svda model, got {mean_force!r}")
    gap = -math.log(mean_force / scale) / kappa
    u0 = -math.sqrt(8.0 * math.pi * radius / kappa) * (P / E_inf) * math.exp(-kappa * gap)
    return gap + u0


def _svda_model(spec: ModelSpec) -> FitModel:
    radius, p_amp, debye = _need(spec, "radius", "P", "debye_length")
    position, mean_force = _position_choice(spec)

    def mean_position(v: Mapping[str, float]) -> float:
        if position is not None:
            return float(position)
        return svda_position(mean_force, v["E_inf"], radius, p_amp, debye)

    from viscoforce.closed_form import require_exponential_law
    from viscoforce.svda import svda_stiffness_kernel

    radius, p_amp, kappa = require_exponential_law(radius, p_amp, debye)  # once, not per call

    def function(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        return svda_stiffness_kernel(np.asarray(omega, dtype=float), mean_position(v), v["E0"],
                                     v["E_inf"], v["tau"], radius, p_amp, kappa)

    def guesser(k: np.ndarray, omega: np.ndarray) -> dict[str, float]:
        feats = SpectrumFeatures.of(k, omega)
        e_inf, e0 = _moduli_from_levels(function, feats, 1e9)
        check_svda_precontact(mean_position({"E_inf": e_inf}), e_inf, radius, p_amp, debye)
        return {"E_inf": e_inf, "E0": e0, "tau": feats.sls_tau()}

    model = FitModel(spec, function, _material_layout(1), "omega", guesser, _omega_window)
    model.mean_position = mean_position  # type: ignore[attr-defined]
    return model


def check_svda_precontact(position: float, E_inf: float, radius: float, P: float,  # noqa: N803
                          debye_length: float) -> None:
    """Raise ModelValidityError if the SVDA mean state is in contact (centre gap < 1/κ)."""
    from viscoforce.svda import svda_static_deformation

    u0 = float(svda_static_deformation(position, E_inf, radius, P, debye_length))
    gap = position - u0
    if gap < debye_length:
        raise ModelValidityError(
            f"the svda model describes only pre-contact spectra: at h0 = {position:.3g} m with "
            f"E_inf = {E_inf:.3g} Pa the centre gap would be {gap:.3g} m < the contact threshold "
            f"1/kappa = {debye_length:.3g} m; use --model exact (any position) or contact")


def _exact_model(spec: ModelSpec) -> FitModel:
    (problem,) = _need(spec, "problem")
    position, mean_force = _position_choice(spec)
    modes = spec.modes

    def function(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        full = dict(v)
        if modes > 1 and "tau" in full:  # the level search passes one-mode names
            full = _expand_one_mode(full, modes)
        return exact_stiffness(problem, position, mean_force, material_from(full, modes), omega)

    def guesser(k: np.ndarray, omega: np.ndarray) -> dict[str, float]:
        feats = SpectrumFeatures.of(k, omega)
        e_inf, e0 = _moduli_from_levels(function, feats, problem.material.relaxed_modulus)
        return _material_guess(e0, e_inf, feats.sls_tau(), modes, _omega_window(omega))

    return FitModel(spec, function, _material_layout(modes), "omega", guesser, _omega_window)


def _expand_one_mode(v: Mapping[str, float], modes: int) -> dict[str, float]:
    """An n-mode parameter set equivalent to the one-mode ``v`` (all modes at ``tau``)."""
    moduli = _geometric(v["E0"], v["E_inf"], modes)
    out = dict(zip(moduli_names(modes), moduli, strict=True))
    out.update({n: v["tau"] * (1 + 1e-9 * i) for i, n in enumerate(tau_names(modes))})
    return out


def exact_stiffness(problem: ContactProblem, position: float | None, mean_force: float | None,
                    material: ViscoelasticMaterial, omega: np.ndarray) -> np.ndarray:
    """Exact small-amplitude k*(ω) [N/m] of ``material`` at h̄0 = ``position`` or at the load."""
    from viscoforce.experiments.linear_response import linearized_state

    e_inf = material.relaxed_modulus
    state = (linearized_state(problem, position, e_inf) if position is not None
             else linearized_state(problem, None, e_inf, load=mean_force))
    return state.stiffness(2.0 * np.asarray(material.complex_compliance(omega), dtype=complex))


def _contact_model(spec: ModelSpec) -> FitModel:
    (depth,) = _need(spec, "indentation")
    tip = contact_tip(spec.fixed.get("radius"), spec.fixed.get("tip"))
    drag = float(spec.fixed.get("drag") or 0.0)
    kind = spec.fixed.get("material", "sls")
    newtonian = bool(spec.fixed.get("newtonian") or False)
    f_ref = float(spec.fixed.get("reference_frequency") or REFERENCE_FREQUENCY)
    if kind not in CONTACT_MATERIALS:
        raise ParameterError(f"material must be one of {', '.join(CONTACT_MATERIALS)}, "
                             f"got {kind!r}")
    if spec.fixed.get("reference_frequency") is not None and kind != "structural":
        raise ParameterError(f"reference_frequency is the f_ref of material 'structural'; "
                             f"material {kind!r} has none")
    if newtonian and kind != "power-law":
        raise ParameterError(f"newtonian=True adds a viscosity to material 'power-law'; "
                             f"material {kind!r} has {'one' if kind == 'structural' else 'none'}")
    if not depth > 0:
        raise ModelValidityError(
            f"the contact model needs a positive operating indentation, got {depth!r} m: this "
            "spectrum is pre-contact (use --model svda or exact), or give --indentation D0")
    root = float(tip.contact_stiffness_factor(depth))  # S(δ0) = (dF/dδ)/E: √(Rδ0) for Hertz
    modes = spec.modes if kind == "prony" else 1
    moduli = _contact_modulus_function(kind, modes, newtonian, f_ref)

    def function(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        return root * moduli(omega, v) + 1j * omega * drag

    def guesser(k: np.ndarray, omega: np.ndarray) -> dict[str, float]:
        modulus = (k - 1j * omega * drag) / root
        return _contact_guess(kind, modes, newtonian, f_ref, modulus, omega)

    window = _omega_window if kind in ("sls", "prony") else None
    fixed = {**spec.fixed, "reference_frequency": f_ref} if kind == "structural" else dict(
        spec.fixed)
    fixed["tip"] = tip
    return FitModel(ModelSpec(spec.name, modes, fixed), function,
                    _contact_layout(kind, modes, newtonian), "omega", guesser, window)


def contact_tip(radius: float | None, tip: Any = None):
    """The tip of the contact model: ``tip``, or the paper's sphere of ``radius``.

    ``tip`` is a :class:`viscoforce.physics.tips.Tip` or its CLI text; ``radius`` stands for the
    paper's sphere (paraboloidal profile h0 + r²/2R: Hertz).

    Raises
    ------
    ParameterError
        Neither or both given.
    """
    from viscoforce.physics.tips import Paraboloid, tip_from

    if (radius is None) == (tip is None):
        raise ParameterError(
            "the contact model needs the tip: give tip= (--tip sphere:R | paraboloid:R | "
            "cone:ANGLE | pyramid:ANGLE | flat:RADIUS) or radius= (--R, the paper's sphere), "
            + ("not both" if radius is not None else "neither was given"))
    return Paraboloid(radius) if tip is None else tip_from(tip)


def _contact_modulus_function(kind: str, modes: int, newtonian: bool, f_ref: float
                              ) -> Callable[[np.ndarray, Mapping[str, float]], np.ndarray]:
    """E*(ω) [Pa] of a contact material from its SPEC values (the paper's E)."""
    from viscoforce.closed_form import (
        power_law_complex_modulus,
        prony_compliance_core,
        structural_complex_modulus,
    )

    if kind == "structural":
        return lambda omega, v: structural_complex_modulus(omega, v["E_ref"], v["alpha"],
                                                           v["mu"], f_ref)
    if kind == "power-law":
        return lambda omega, v: power_law_complex_modulus(
            omega, v["E0"], v["C1"], v["m"], v["mu"] if newtonian else 0.0)

    moduli, taus = moduli_names(modes), tau_names(modes)

    def prony(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        # the fit loop's values are ordered and positive by the layout: no material object
        # (its validation costs more than the closed form), C* = 1/E0 + Σ ΔJ_i/(1 + iωτ_i)
        full = _expand_one_mode(v, modes) if modes > 1 and "tau" in v else v
        e = np.array([full[n] for n in moduli])
        tau = np.array([full[n] for n in taus])
        compliance = prony_compliance_core(np.asarray(omega, dtype=float), 1.0 / e[0],
                                           1.0 / e[1:] - 1.0 / e[:-1], tau)
        return 1.0 / compliance

    return prony


def _contact_layout(kind: str, modes: int, newtonian: bool) -> list[P.Item]:
    if kind == "structural":
        return [P.Chain(("E_ref",), MODULUS_BOUNDS), P.Bounded("alpha", *EXPONENT_BOUNDS),
                P.Chain(("mu",))]
    if kind == "power-law":
        return [P.Chain(("E0",)), P.Chain(("C1",)), P.Bounded("m", *EXPONENT_BOUNDS),
                *([P.Chain(("mu",))] if newtonian else [])]
    return _material_layout(modes)


def _contact_guess(kind: str, modes: int, newtonian: bool, f_ref: float, modulus: np.ndarray,
                   omega: np.ndarray) -> dict[str, float]:
    """A start for a contact material from E*(ω) = (k* − iωB)/√(Rδ0) alone."""
    feats = SpectrumFeatures.of(modulus, omega)
    if kind == "structural":
        return structural_guess(modulus, omega, f_ref)
    if kind == "power-law":  # |E| falls like ω^−m … rises like ω^m: slope of log|E|
        slope = np.polyfit(np.log(omega), np.log(np.abs(modulus)), 1)[0]
        m = min(max(float(slope), 0.05), 0.95)
        c1 = 1.0 / (feats.k_low * gamma(m + 1)) * feats.omega_low ** m
        out = {"E0": 2.0 * feats.k_high, "C1": c1, "m": m}
        if newtonian:
            out["mu"] = _viscosity_guess(modulus, omega)
        return out
    e_inf, e0 = feats.k_low, max(feats.k_high, 1.05 * feats.k_low)
    return _material_guess(e0, e_inf, feats.sls_tau(), modes, _omega_window(omega))


def structural_guess(modulus: np.ndarray, omega: np.ndarray, reference_frequency: float
                     ) -> dict[str, float]:
    """E_ref, alpha, mu of E*(ω) = E_ref (iω/ω_ref)^α + iωμ by linear least squares on a grid of α.

    For fixed α the model is linear in (E_ref, μ); each is solved in closed form on the real and
    imaginary parts, weighted by 1/|E*| (a relative fit), and the α of the smallest residual
    is kept. Negative solutions are clipped to small positive values.
    """
    w = np.asarray(omega, dtype=float)
    e = np.asarray(modulus, dtype=complex)
    scale = 1.0 / np.abs(e)
    target = np.concatenate([e.real * scale, e.imag * scale])
    best: tuple[float, float, float, float] | None = None
    for alpha in np.linspace(0.02, 0.95, 94):
        z = (1j * w / (2.0 * math.pi * reference_frequency)) ** alpha
        design = np.column_stack([np.concatenate([z.real, z.imag]) * np.tile(scale, 2),
                                  np.concatenate([np.zeros_like(w), w]) * np.tile(scale, 2)])
        coef, *_ = np.linalg.lstsq(design, target, rcond=None)
        e_ref, mu = float(coef[0]), float(coef[1])
        if not e_ref > 0:
            continue
        mu = max(mu, 0.0)
        misfit = float(np.sum((design @ np.array([e_ref, mu]) - target) ** 2))
        if best is None or misfit < best[0]:
            best = (misfit, e_ref, float(alpha), mu)
    if best is None:  # no positive power law: start from the magnitude and the mean phase
        alpha = min(max(2.0 * float(np.median(np.angle(e))) / math.pi, 0.05), 0.9)
        return {"E_ref": float(np.median(np.abs(e))), "alpha": alpha,
                "mu": _viscosity_guess(e, w)}
    _, e_ref, alpha, mu = best
    floor = 1e-4 * float(np.max(np.abs(e)) / np.max(w))  # |iωμ| 1e-4 of |E*| at the top
    return {"E_ref": e_ref, "alpha": alpha, "mu": max(mu, floor)}


def _viscosity_guess(modulus: np.ndarray, omega: np.ndarray) -> float:
    """μ from the imaginary part at the highest frequency (a tenth of it), > 0."""
    i = int(np.argmax(omega))
    return max(0.1 * abs(float(modulus[i].imag)), 1e-6 * abs(modulus[i])) / float(omega[i])


def _prony_model(spec: ModelSpec) -> FitModel:
    modes = spec.modes
    dks = [f"dk_{i}" for i in range(1, modes + 1)]
    taus = [f"tau_{i}" for i in range(1, modes + 1)]

    def function(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        k = np.full(np.shape(omega), v["k_inf"], dtype=complex)
        for dk, tau in zip(dks, taus, strict=True):
            x = 1j * omega * v[tau]
            k += v[dk] * x / (1.0 + x)
        return k

    def guesser(k: np.ndarray, omega: np.ndarray) -> dict[str, float]:
        feats = SpectrumFeatures.of(k, omega)
        k_inf = feats.k_low
        total = max(feats.k_high - feats.k_low, 0.05 * feats.k_low)
        tau = 1.0 / (feats.omega_peak * math.sqrt(max(feats.k_high / feats.k_low, 1.0001)))
        out = {"k_inf": k_inf, **{dk: total / modes for dk in dks}}
        out.update(zip(taus, _spread(tau, modes, _omega_window(omega)), strict=True))
        return out

    layout: list[P.Item] = [P.Chain(("k_inf",)), *(P.Chain((dk,)) for dk in dks),
                            P.Chain(tuple(taus))]
    return FitModel(spec, function, layout, "omega", guesser, _omega_window)


# ── curve models ────────────────────────────────────────────────────────────────────────────────

def _exponential_model(spec: ModelSpec, level: str, step: str) -> FitModel:
    """``level`` + Σ ``step``_i e^{−t/τ_i}: the relaxation (F_inf, dF_i) and creep (z_inf, dz_i)."""
    modes = spec.modes
    dfs = [f"{step}_{i}" for i in range(1, modes + 1)]
    taus = [f"tau_{i}" for i in range(1, modes + 1)]

    def function(t: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        f = np.full(np.shape(t), v[level], dtype=float)
        for df, tau in zip(dfs, taus, strict=True):
            f += v[df] * np.exp(-t / v[tau])
        return f

    def guesser(f: np.ndarray, t: np.ndarray) -> dict[str, float]:
        order = np.argsort(t)
        t, f = t[order], np.asarray(f, dtype=float)[order]
        n_end = max(2, t.size // 20)
        f_inf, f_start = float(np.median(f[-n_end:])), float(np.median(f[:max(2, t.size // 200)]))
        excess = f - f_inf
        target = (f_start - f_inf) / math.e
        crossed = np.flatnonzero(np.sign(excess - target) != np.sign(f_start - f_inf - target))
        t0 = float(t[crossed[0]] - t[0]) if crossed.size else float(np.ptp(t)) / 3
        tau = max(t0, float(np.ptp(t)) / t.size)
        out = {level: f_inf, **{df: (f_start - f_inf) / modes for df in dfs}}
        out.update(zip(taus, _spread(tau, modes, _time_window(t)), strict=True))
        return out

    layout: list[P.Item] = [P.Signed(level), *(P.Signed(df) for df in dfs),
                            P.Chain(tuple(taus))]
    return FitModel(spec, function, layout, "t", guesser, _time_window)


def _relaxation_model(spec: ModelSpec) -> FitModel:
    return _exponential_model(spec, "F_inf", "dF")


def _creep_model(spec: ModelSpec) -> FitModel:
    return _exponential_model(spec, "z_inf", "dz")


def _hertz_model(spec: ModelSpec) -> FitModel:
    """F(z) = b + s·(z − c) + E·shape(max(z − c, 0)) over the tip position z toward the sample.

    ``E`` the paper's modulus, ``contact_point`` c [m], ``baseline`` b [N] (the free-cantilever
    force at contact) and ``baseline_slope`` s [N/m] (a tilted baseline, kept in contact); the
    tip's ``force_shape`` (:mod:`viscoforce.physics.tips`) gives the indentation law.
    """
    (tip,) = _need(spec, "tip")
    window = spec.fixed.get("contact_window")

    def function(z: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        z = np.asarray(z, dtype=float)
        delta = np.maximum(z - v["contact_point"], 0.0)
        return (v["baseline"] + v["baseline_slope"] * (z - v["contact_point"])
                + v["E"] * tip.force_shape(delta))

    def guesser(f: np.ndarray, z: np.ndarray) -> dict[str, float]:
        return hertz_guess(tip, np.asarray(z, dtype=float), np.asarray(f, dtype=float))

    def windows(z: np.ndarray, f: np.ndarray | None = None) -> dict[str, tuple[float, float]]:
        out = {"contact_point": window if window is not None else contact_window(tip, z)}
        if f is not None:
            out.update(baseline_windows(f, z))
        return out

    layout: list[P.Item] = [P.Chain(("E",)), P.Bounded("contact_point", -1.0, 1.0),
                            P.Bounded("baseline", -1.0, 1.0),
                            P.Bounded("baseline_slope", -1.0, 1.0)]
    return FitModel(spec, function, layout, "z", guesser, bounded_windows=windows)


def baseline_windows(f: np.ndarray, z: np.ndarray) -> dict[str, tuple[float, float]]:
    """Bounds of ``baseline`` [N] and ``baseline_slope`` [N/m] from the force span and the tip travel.

    Wide (2 force spans beyond the data, 10 spans over the travel): they only give the bounded
    parameters an O(1) internal scale for the optimiser's finite differences.
    """
    f = np.asarray(f, dtype=float)
    span = float(np.ptp(f)) or float(np.max(np.abs(f))) or 1e-12
    z_span = float(np.ptp(z)) or 1e-9
    return {"baseline": (float(np.min(f)) - 2 * span, float(np.max(f)) + 2 * span),
            "baseline_slope": (-10 * span / z_span, 10 * span / z_span)}


def contact_window(tip: Any, z: np.ndarray) -> tuple[float, float]:
    """Where a contact point may lie [m]: within the approach, no deeper than the tip allows."""
    lo, hi = float(np.min(z)), float(np.max(z))
    deepest = getattr(tip, "max_indentation", None)
    if deepest is not None:
        lo = max(lo, hi - 0.99 * float(deepest))
    return lo, hi


#: Contact points tried by the Hertz guess (each with a linear least-squares E and baseline).
HERTZ_GUESS_POINTS = 64


def hertz_linear(tip: Any, z: np.ndarray, f: np.ndarray, contact: float
                 ) -> tuple[np.ndarray, float]:
    """(E, baseline, slope) by linear least squares at a given contact point, and the SSE."""
    delta = np.maximum(z - contact, 0.0)
    design = np.column_stack([tip.force_shape(delta), np.ones_like(z), z - contact])
    scale = np.max(np.abs(design), axis=0)
    scale[scale == 0] = 1.0
    coef, *_ = np.linalg.lstsq(design / scale, f, rcond=None)
    coef = coef / scale
    return coef, float(np.sum((design @ coef - f) ** 2))


def hertz_guess(tip: Any, z: np.ndarray, f: np.ndarray) -> dict[str, float]:
    """A start for the Hertz fit: the best of a grid of contact points, each linear in the rest.

    Given the contact point the model is linear in (E, baseline, slope); the grid spans the
    contact window (:func:`contact_window`), then one refinement between its neighbours.
    """
    lo, hi = contact_window(tip, z)
    inner = np.sort(z[(z >= lo) & (z <= hi)])
    if inner.size < 4:
        raise ParameterError("the approach has fewer than 4 points where contact may lie")
    # candidates: quantiles of the data (dense where the data are), excluding the last points
    grid = np.quantile(inner, np.linspace(0.02, 0.98, HERTZ_GUESS_POINTS))
    best = None
    for _ in range(2):
        for c in grid:
            coef, sse = hertz_linear(tip, z, f, float(c))
            if coef[0] > 0 and (best is None or sse < best[1]):
                best = (float(c), sse, coef)
        if best is None:
            break
        step = float(np.median(np.diff(grid))) if grid.size > 1 else float(np.ptp(z)) / 10
        grid = np.linspace(best[0] - step, best[0] + step, 21)
        grid = grid[(grid >= lo) & (grid <= hi)]
    if best is None:
        raise ParameterError("no contact point in the approach gives a positive modulus: the "
                             "force does not rise with the tip position (is this the approach "
                             "segment of a repulsive contact?)")
    c, _, coef = best
    e = min(max(float(coef[0]), MODULUS_BOUNDS[0] * 10), MODULUS_BOUNDS[1] / 10)
    return {"E": e, "contact_point": c, "baseline": float(coef[1]),
            "baseline_slope": float(coef[2])}


#: A sample of a position trace lying within this fraction of the trace's largest |h0| of the
#: straight line through its neighbours is not a corner (:func:`corners`).
COLLINEAR_RTOL = 1e-12


def corners(t: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The samples of a piecewise-linear trace (t, h0) where it bends, and its two ends.

    A sample on the straight line through the kept sample before it and the sample after it (to
    :data:`COLLINEAR_RTOL` of max |h0|, i.e. to rounding) is dropped: the piecewise-linear
    interpolant of what is kept is the same function h0(t). A simulated step or triangle keeps
    its corners only; a measured (noisy) trace keeps every sample. The time loop then restarts
    its step history only where the drive really has a kink (at each sample of the full trace it
    restarts at every one: more rejected steps and Newton iterations for the same drive).
    """
    t, h = np.asarray(t, dtype=float), np.asarray(h, dtype=float)
    if t.size < 3:
        return t, h
    tol = COLLINEAR_RTOL * float(np.max(np.abs(h)))
    keep = [0]
    for i in range(1, t.size - 1):
        a = keep[-1]
        line = h[a] + (h[i + 1] - h[a]) * ((t[i] - t[a]) / (t[i + 1] - t[a]))
        if abs(h[i] - line) > tol:
            keep.append(i)
    keep.append(t.size - 1)
    return t[keep], h[keep]


class StepResponse:
    """The step model's force along one drive, with its exact sensitivities, last run kept.

    Each run integrates the force and its forward sensitivities to the material together
    (:func:`viscoforce.solvers.simulate.simulate_force`: the force of ``simulate(...,
    output_kinks=False)``, the sensitivities by back-substitution with each step's Newton
    factorisation). A least-squares fit asks for the residual and then the Jacobian at the same
    parameters: the second comes from the kept run, so an iteration costs one simulation instead
    of one per parameter plus one (finite differences). Each run's Newton solves start from the
    previous run's gaps moved along their sensitivities (first order in the parameter change),
    which changes where Newton starts, not the converged force.

    Parameters
    ----------
    problem : ContactProblem
        System and grid (its material is replaced by each evaluation's).
    drive : SeparationHistory
        The measured or simulated position history h0(t) [m].
    tol : float, optional
        Local error tolerance of the adaptive steps [m] (default that of ``simulate``).
    """

    #: Largest change of ln E0, ln E_inf or ln τ from where the kept step grid was chosen over
    #: which a run repeats that grid (otherwise the steps are chosen afresh).
    REGRID = 0.05
    #: Largest such change over which the last run's gaps, moved along their sensitivities, are
    #: better Newton starts than the stepper's own extrapolation in time.
    WARM = 0.3

    def __init__(self, problem: ContactProblem, drive: Any, *, tol: float | None = None):
        self.problem, self.drive, self.tol = problem, drive, tol
        #: Repeat the step grid of the last adaptive run near its parameters (see class doc).
        self.reuse_grid = True
        #: Simulations run (adaptive, on a kept grid) and Newton iterations (bookkeeping).
        self.runs = self.grid_runs = self.newton = 0
        self._kept: dict[str, Any] | None = None
        self._grid: tuple[np.ndarray, np.ndarray] | None = None  # (step times, ln SPEC)

    def forget(self) -> None:
        """Drop the kept result and grid: the next evaluation is a fresh adaptive simulation.

        Only the Newton starts (the last run's gaps and their sensitivities) are kept.
        """
        self._grid = None
        if self._kept is not None:
            self._kept = {k: v for k, v in self._kept.items() if k in self._WARM}

    def warm_from(self, other: StepResponse) -> None:
        """Take the Newton starts of ``other``'s last run (same drive; e.g. the search stage's)."""
        if other._kept is not None:
            self._kept = {k: other._kept[k] for k in self._WARM}

    _WARM = ("rho", "logs", "step_time", "step_gap", "dgap")

    @staticmethod
    def _prony(values: Mapping[str, float]) -> np.ndarray:
        """ρ = (c_g, c_1, ln τ) = (2/E0, 2/E_inf − 2/E0, ln τ) of an SLS."""
        e0, e_inf, tau = float(values["E0"]), float(values["E_inf"]), float(values["tau"])
        return np.array([2.0 / e0, 2.0 / e_inf - 2.0 / e0, math.log(tau)])

    def _run(self, t: np.ndarray, values: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        from viscoforce.exceptions import ConvergenceError, GapClosureError
        from viscoforce.solvers.simulate import simulate_force

        key = (float(values["E0"]), float(values["E_inf"]), float(values["tau"]))
        kept = self._kept
        same_t = kept is not None and "t" in kept and np.array_equal(kept["t"], t)
        if same_t and kept["key"] == key:
            return kept["force"], kept["log_gradient"]
        rho, logs = self._prony(values), np.log(key)
        warm = grid = None
        if kept is not None and np.max(np.abs(logs - kept["logs"])) <= self.WARM:
            # Newton starts by step time (the outputs need not be the same)
            moved = kept["step_gap"] + np.einsum("j,ijn->in", rho - kept["rho"], kept["dgap"])
            warm = (kept["step_time"], np.maximum(moved, 0.5 * kept["step_gap"]))
            if (same_t and self.reuse_grid and self._grid is not None
                    and np.max(np.abs(logs - self._grid[1])) <= self.REGRID):
                grid = self._grid[0]
        problem = self.problem.with_material(material_from(values, 1))
        options = {"t_end": float(t[-1]), "t_eval": t, "tol": self.tol, "sensitivities": True}
        run = None
        if grid is not None:
            try:
                run = simulate_force(problem, self.drive, warm_start=warm, grid=grid, **options)
                self.grid_runs += 1
            except (ConvergenceError, GapClosureError):
                run = None  # the kept grid is too coarse here: choose the steps afresh
        if run is None:
            run = simulate_force(problem, self.drive, warm_start=warm, **options)
            self.runs += 1
            self._grid = (run.step_time, logs)
        self.newton += run.newton
        e0, e_inf, _ = key
        # ∂F/∂(ln E0, ln E_inf, ln τ) from ∂F/∂ρ
        d_cg, d_c1, d_tau = run.sensitivity.T
        log_grad = np.column_stack([(d_c1 - d_cg) * (2.0 / e0), -d_c1 * (2.0 / e_inf), d_tau])
        self._kept = {"key": key, "t": np.array(t), "force": run.force, "log_gradient": log_grad,
                      "rho": rho, "logs": logs, "step_time": run.step_time,
                      "step_gap": run.step_gap,
                      "dgap": run.step_gap_sensitivity}
        return run.force, log_grad

    def force(self, t: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
        """F(t) [N] for the SLS of ``values`` (``E0``, ``E_inf``, ``tau``)."""
        return self._run(np.asarray(t, dtype=float), values)[0]

    def log_gradient(self, t: np.ndarray, values: Mapping[str, float]) -> dict[str, np.ndarray]:
        """∂F/∂ln(name) [N] at ``t`` for each SPEC name (exact for the discrete scheme)."""
        grad = self._run(np.asarray(t, dtype=float), values)[1]
        return dict(zip(("E0", "E_inf", "tau"), grad.T, strict=True))


def _step_model(spec: ModelSpec) -> FitModel:
    (problem, position_trace) = _need(spec, "problem", "position_trace")
    from viscoforce.experiments.drives import MeasuredTrace

    trace_t, trace_h = (np.asarray(a, dtype=float) for a in position_trace)
    response = StepResponse(problem, MeasuredTrace(*corners(trace_t, trace_h)),
                            tol=spec.fixed.get("tol"))

    def guesser(f: np.ndarray, t: np.ndarray) -> dict[str, float]:
        start = spec.fixed.get("start")
        if start is not None:
            return dict(start)
        from viscoforce.solvers.static import equilibrium_gap

        f = np.asarray(f, dtype=float)
        i_peak = int(np.argmax(np.abs(f - f[0])))
        end = float(np.interp(t[-1], trace_t, trace_h))
        peak_position = float(np.interp(t[i_peak], trace_t, trace_h))

        def load(position: float) -> Callable[[float], float]:
            return lambda e: abs(float(problem.load(problem.pressure(
                equilibrium_gap(problem, position, e).gap))))

        e_inf = _solve_modulus(load(end), max(abs(float(f[-1])), 1e-15), 1e9)
        e0 = _solve_modulus(load(peak_position), max(abs(float(f[i_peak])), 1e-15), 2 * e_inf)
        tail = np.abs(f[i_peak:] - f[-1])
        below = np.flatnonzero(tail < tail[0] / math.e)
        tau = float(t[i_peak + below[0]] - t[i_peak]) if below.size else float(np.ptp(t)) / 5
        return {"E_inf": e_inf, "E0": max(e0, 1.05 * e_inf), "tau": max(tau, 1e-9)}

    model = FitModel(spec, response.force, _material_layout(1), "t", guesser, _time_window)
    model.response = response  # type: ignore[attr-defined]
    return model


#: Most relaxation modes of one model (a fit needs several data points per mode).
MAX_MODES = 12

_FIXED: dict[str, tuple[str, ...]] = {
    "svda": ("position", "mean_force", "radius", "P", "debye_length"),
    "exact": ("position", "mean_force", "problem"),
    "contact": ("radius", "tip", "indentation", "drag", "material", "debye_length",
                "newtonian", "reference_frequency"),
    "prony": (), "relaxation": (), "step": ("problem", "position_trace", "tol", "start"),
    "hertz": ("tip", "contact_window"), "creep": (),
    "ting": ("tip", "position_trace", "material", "drag", "fit_drag", "contact_point",
             "contact_window", "reference_frequency", "newtonian")}


def check_fixed(name: str, fixed: Mapping[str, Any]) -> dict[str, Any]:
    """The fixed inputs of model ``name``, validated (None means not given).

    Raises
    ------
    TypeError
        An input the model does not take.
    ParameterError
        A value out of range (the message names it and the range).
    """
    from viscoforce._validation import (
        require_finite,
        require_instance,
        require_nonnegative,
        require_positive,
    )

    unknown = sorted(set(fixed) - set(_FIXED[name]))
    if unknown:
        raise TypeError(f"model {name!r} takes no input {', '.join(unknown)}; its inputs: "
                        f"{', '.join(_FIXED[name]) or 'none'}")
    checks: dict[str, Callable[[str, Any], Any]] = {
        "position": require_finite, "mean_force": require_positive, "radius": require_positive,
        "P": require_positive, "debye_length": require_positive, "indentation": require_finite,
        "drag": require_nonnegative,
        "problem": lambda n, v: require_instance(n, v, ContactProblem),
        "material": lambda n, v: v if v in CONTACT_MATERIALS else _bad_material(v),
        "newtonian": _require_bool, "reference_frequency": require_positive,
        "tip": lambda n, v: _as_tip(v), "contact_window": _window,
        "position_trace": lambda n, v: v, "fit_drag": _require_bool,
        "tol": require_positive, "start": _step_start,
        "contact_point": require_finite}
    return {k: (None if v is None else checks[k](k, v)) for k, v in fixed.items()}


def _step_start(name: str, value: Any) -> dict[str, float]:
    """A start of the step model: positive ``E0`` > ``E_inf`` and ``tau`` [SI]."""
    from viscoforce._validation import require_positive

    if not isinstance(value, Mapping) or set(value) != {"E0", "E_inf", "tau"}:
        raise ParameterError(f"{name} must map E0, E_inf and tau to values, got {value!r}")
    return {k: require_positive(f"{name}[{k!r}]", v) for k, v in value.items()}


def _as_tip(value: Any):
    from viscoforce.physics.tips import tip_from

    return tip_from(value)


def _window(name: str, value: Any) -> tuple[float, float]:
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be (low, high) tip positions [m], got {value!r}"
                             ) from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ParameterError(f"{name} must be finite (low, high) with low < high [m], got "
                             f"{value!r}")
    return lo, hi


def _require_bool(name: str, value: Any) -> bool:
    if not isinstance(value, bool | np.bool_):
        raise ParameterError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _bad_material(value: Any) -> None:
    raise ParameterError(f"material must be one of {', '.join(CONTACT_MATERIALS)}, "
                         f"got {value!r}")


def _ting_model(spec: ModelSpec) -> FitModel:
    from viscoforce.fitting.ting import ting_model

    return ting_model(spec)


_BUILDERS: dict[str, Callable[[ModelSpec], FitModel]] = {
    "svda": _svda_model, "exact": _exact_model, "contact": _contact_model,
    "prony": _prony_model, "relaxation": _relaxation_model, "step": _step_model,
    "hertz": _hertz_model, "creep": _creep_model, "ting": _ting_model}


def make_model(name: str, modes: int = 1, **fixed: Any) -> FitModel:
    """The lmfit model ``name`` (one of :data:`MODEL_NAMES`) with ``modes`` modes.

    Parameters
    ----------
    name : str
        ``svda``, ``exact``, ``contact``, ``prony``, ``relaxation``, ``step``, ``hertz`` or
        ``creep``.
    modes : int
        Relaxation modes (≥ 1; only the models in :data:`MODAL_MODELS` take more than one).
    **fixed
        Fixed inputs in SI: ``position`` or ``mean_force`` (svda, exact); ``radius``, ``P``,
        ``debye_length`` (svda); ``problem`` (exact, step); ``radius``, ``indentation``,
        ``drag``, ``material`` (contact: ``sls``, ``prony``, ``power-law``, ``structural``),
        ``newtonian`` (contact power-law: fit a viscosity ``mu`` too), ``reference_frequency``
        [Hz] (contact structural: f_ref of ``E_ref``, default 1 Hz), ``debye_length`` (contact:
        the validity estimate); ``position_trace`` = (t, h0) (step); ``tip`` (hertz: a
        :class:`~viscoforce.physics.tips.Tip` or its text, required) and ``contact_window`` =
        (low, high) [m] (hertz: where the contact point may lie; default the approach).

    Raises
    ------
    ParameterError
        Unknown model, bad modes, or a missing fixed input (the message names it).
    ModelValidityError
        The model cannot describe the scene (contact at no indentation).
    """
    if not isinstance(name, str) or name not in _BUILDERS:
        raise ParameterError(f"model must be one of {', '.join(MODEL_NAMES)}, got {name!r}")
    if isinstance(modes, bool) or not isinstance(modes, int | np.integer) or not (
            1 <= modes <= MAX_MODES):
        raise ParameterError(f"modes must be an integer in [1, {MAX_MODES}], got {modes!r}")
    fixed = check_fixed(name, fixed)
    if modes > 1 and name not in MODAL_MODELS:
        raise ParameterError(f"model {name!r} has one mode (modes=1), got modes={modes}; "
                             f"models with several: {', '.join(MODAL_MODELS)}")
    if name == "contact" and modes > 1 and fixed.get("material", "sls") != "prony":
        raise ParameterError("contact with modes > 1 needs material='prony' (--material prony)")
    return _BUILDERS[name](ModelSpec(name, int(modes), fixed))
