"""The cheapest adequate method for a scene: error estimates of every approximation and the chooser.

This module holds the estimates, :class:`Choice` and the stepper choice of ``simulate``
(:func:`choose_simulation`); the spectrum choice (which needs static solves) is
:func:`viscoforce.experiments.choice.choose_spectrum` and the fit-model choice
``viscoforce.fitting.fit_spectrum(..., "auto")``.

Each approximation in viscoforce has an error estimate that can be evaluated before (or without)
the exact computation; ``method="auto"`` (spectra), ``stepper="auto"`` (simulations) and
``model="auto"`` (fits) rank the methods by cost and take the cheapest whose estimate meets the
required accuracy (a relative error of the force or complex stiffness, default
:data:`DEFAULT_ACCURACY`). Every choice carries a one-paragraph explanation naming the
estimates it compared.

The estimates (measured in ``studies/validity_maps/validity_maps.py`` and
``studies/speed_accuracy/speed_accuracy.py``, whose scenes the tests check them on):

* **finite amplitude** — the first harmonic of an exponential force F ∝ e^{−κh} driven by
  h̄0 + η sin ωt is κF̄·2I₁(κη)/(κη), so a small-amplitude (linear) stiffness is off by
  2I₁(x)/x − 1 ≈ (κη)²/8 with x = κη (:func:`amplitude_error`, the rigid estimate). For the
  deformable system the spectrum choice solves the leading correction exactly, by third-order
  harmonic balance about the static state
  (:func:`viscoforce.experiments.finite_amplitude.amplitude_bias`, × 1.1): 5.5e-4 at Fig. 3 and
  3.7e-3 at −5 nm, κη = 0.1, against 5.5e-4 and 3.5e-3 measured (the soft wall makes the bias
  in contact 2.8× the rigid estimate);
* **SVDA** — max over ω of |k*_SVDA/k*_exact − 1| = 0.585 κ|u0| (u0 the relaxed SVDA central
  deformation) to within 1 % for κ|u0| ≤ 0.03, smaller above, over R 1–100 µm, E 0.1–10 GPa,
  1/κ 0.3–3 nm, E0/E_inf 3–100 (:func:`viscoforce.svda.svda_error_estimate`, coefficient 0.6);
* **Hertz contact** — k* = √(Rδ0)/C*(ω) ignores the compliance of the surface-force layer,
  whose stiffness is ≈ F̄κ with the Hertz load F̄ = (2/3)E_inf√R δ0^{3/2}; the relative error is
  ≈ |E*(ω)|√(Rδ0)/(F̄κ) = 1.5 (|E*(ω_max)|/E_inf)/(κδ0) at the highest frequency; the
  measured error is 0.24–0.67× it for 1/κ ≥ 1 nm but up to 1.4× at 1/κ = 0.3 nm and δ0 = 600 nm
  (it falls like δ0^−0.7, not 1/δ0), so twice it is used (:func:`contact_error`);
* **exact, default grid** — ≤ 1e-10 on the study's spectra and static loads (grid × 0.5 vs × 4
  refined); :data:`GRID_ERROR` states 1e-8;
* **time-domain spectrum** — lock-in + stepper at the defaults (4 periods, 64 samples, tol 1e-5η):
  7.6e-5 from the finest setting at Fig. 4, error ∝ tol^0.7 (:data:`SWEEP_ERROR`);
* **time stepping** (exponential trapezoidal, adaptive) — error ≈ 4.1e-5 (tol/default)^0.56 on
  the Fig. 1 step and the Fig. 5 loop for tol/default in [0.1, 1000] (:data:`STEPPER_ERROR`).

Each estimate is used with a safety factor (:data:`SAFETY`, 2, unless stated) where it was
measured, not derived.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.special import i1e

from viscoforce._validation import require_instance, require_positive
from viscoforce.exceptions import ParameterError
from viscoforce.physics.surface_forces import DoubleLayer, LennardJones, SumOfLaws
from viscoforce.problem import ContactProblem
from viscoforce.svda import SVDA_ERROR_COEFFICIENT, svda_static_deformation

#: Relative error required when none is given.
DEFAULT_ACCURACY = 1e-3
#: Accepted range of the required accuracy: below 1e-4 the error–tolerance relations of the
#: steppers and the time-domain spectrum would be extrapolated beyond the measured tol range;
#: above 0.1 nothing is an approximation worth the name.
ACCURACY_RANGE = (1e-4, 0.1)
#: Estimated error above which an approximation warns (ModelValidityWarning).
WARN_ERROR = 1e-2
#: Factor applied to the estimates that are measured rather than derived.
SAFETY = 2.0
#: Error of the exact solvers on their default grid (measured ≤ 1e-10; stated with margin).
GRID_ERROR = 1e-8
#: Time-domain spectrum at the default settings, the exponent of its tol dependence and the
#: measured tol range (× the default 1e-5 η, :data:`DEFAULT_SWEEP_TOL`).
SWEEP_ERROR, SWEEP_EXPONENT, SWEEP_TOL_FACTORS = 7.6e-5, 0.7, (0.1, 10.0)
DEFAULT_SWEEP_TOL = 1e-5
#: The adaptive steppers' default tol, in decay lengths (solvers.simulate.DEFAULT_TOL).
DEFAULT_STEPPER_TOL = 1e-5
#: Adaptive exponential stepper at the default tol, the exponent of tol/default, its range.
STEPPER_ERROR, STEPPER_EXPONENT, STEPPER_TOL_FACTORS = 4.1e-5, 0.56, (0.1, 1000.0)



@dataclass(frozen=True)
class Choice:
    """A method chosen for a scene.

    Attributes
    ----------
    method : str
        The route or stepper chosen.
    options : dict
        Keyword arguments for it (e.g. ``tol``).
    estimated_error : float
        Its estimated relative error.
    accuracy : float
        The accuracy asked for.
    explanation : str
        Why: the estimates compared, in words.
    considered : tuple of (str, float, str)
        Every candidate: method, its number (``score``; inf if not applicable), verdict.
    score : str
        What the number of ``considered`` is: ``"estimated error"`` (the theory's choosers,
        by model error) or ``"BIC"``/``"AIC"`` above the best candidate's (the fit choosers by
        criterion, :mod:`viscoforce.fitting.selection`).
    """

    method: str
    options: dict[str, Any]
    estimated_error: float
    accuracy: float
    explanation: str
    considered: tuple[tuple[str, float, str], ...] = field(default=())
    score: str = "estimated error"


def require_accuracy(accuracy: Any) -> float:
    """Return ``accuracy`` as a float in :data:`ACCURACY_RANGE`, or raise ParameterError."""
    lo, hi = ACCURACY_RANGE
    try:
        value = require_positive("accuracy", accuracy)
    except ParameterError:
        value = math.nan
    if not lo <= value <= hi:
        raise ParameterError(f"accuracy must be a number in [{lo:g}, {hi:g}] (relative error), "
                             f"got {accuracy!r}")
    return value


def amplitude_error(eta: float, decay_length: float) -> float:
    """Relative difference of the first-harmonic stiffness at drive ``eta`` from the linear one.

    2I₁(x)/x − 1 with x = η/decay_length: exact for a rigid exponential force, an upper
    estimate where the deformation softens the force law.
    """
    x = float(eta) / float(decay_length)
    if x < 1e-4:
        return x * x / 8.0
    if x > 700.0:
        return math.inf
    return float(2.0 * i1e(x) * math.exp(x) / x - 1.0)


def double_layer(problem: ContactProblem) -> DoubleLayer | None:
    """The one DoubleLayer term of the problem's law (None if there is none or several)."""
    law = problem.surface_force
    layers = [t for t in (law.terms if isinstance(law, SumOfLaws) else (law,))
              if isinstance(t, DoubleLayer)]
    return layers[0] if len(layers) == 1 else None


def svda_error(problem: ContactProblem, position: float) -> tuple[float, str]:
    """Estimated SVDA error at ``position`` and a reason (inf where the SVDA does not apply)."""
    material = problem.material
    if material.prony().n_modes != 1:
        return math.inf, f"needs one relaxation time (the material has {material.prony().n_modes})"
    dl = double_layer(problem)
    if dl is None:
        return math.inf, "needs exactly one DoubleLayer term"
    e_inf, radius = material.relaxed_modulus, problem.sphere.radius
    u0 = float(svda_static_deformation(position, e_inf, radius, dl.P, dl.debye_length))
    if position - u0 < dl.debye_length:
        return math.inf, (f"in contact (central gap {(position - u0) * 1e9:.3g} nm below 1/kappa "
                          f"= {dl.debye_length * 1e9:.3g} nm)")
    return SVDA_ERROR_COEFFICIENT * abs(u0) / dl.debye_length, (  # svda_error_estimate
        f"0.6 kappa|u0| with u0 = {u0 * 1e9:.3g} nm")


def hertz_error(material: Any, depth: float, decay_length: float,
                omega_max: float) -> tuple[float, str]:
    """Estimated Hertz-contact error at indentation ``depth`` [m] > 0 up to ``omega_max``."""
    ratio = 1.0 / (abs(complex(material.complex_compliance(np.array([omega_max]))[0]))
                   * material.relaxed_modulus)
    kappa_depth = depth / decay_length
    return SAFETY * 1.5 * ratio / kappa_depth, (
        f"{SAFETY:g} x 1.5 |E*(omega_max)|/E_inf / (kappa delta0) with kappa delta0 = "
        f"{kappa_depth:.3g}")


def contact_error(problem: ContactProblem, position: float, omega_max: float) -> tuple[float, str]:
    """Estimated Hertz-contact error at indentation −``position`` up to ``omega_max``."""
    depth = -float(position)
    if not depth > 0:
        return math.inf, "needs an indentation (h0 < 0)"
    return hertz_error(problem.material, depth, problem.surface_force.decay_length, omega_max)


def meets(accuracy: float) -> float:
    """The largest estimate that meets ``accuracy`` (an estimate set to it exactly does)."""
    return accuracy * (1.0 + 1e-9)


def finish(kind: str, candidates: list[tuple[str, float, str, dict[str, Any]]],
            accuracy: float, preamble: str) -> Choice:
    """The first candidate whose estimate meets ``accuracy`` (or the most accurate one)."""
    limit = meets(accuracy)
    chosen = next((c for c in candidates if c[1] <= limit), None)
    if chosen is None:
        chosen = min(candidates, key=lambda c: math.inf if math.isnan(c[1]) else c[1])
    rows = []
    for name, error, reason, _ in candidates:
        verdict = ("chosen" if name == chosen[0] else
                   "not evaluated" if math.isnan(error) else
                   "not applicable" if math.isinf(error) else
                   "too inaccurate" if error > limit else "costlier")
        rows.append((name, float(error), f"{verdict}: {reason}"))
    shown = "; ".join(
        f"{name} {'n/a' if math.isinf(err) else '-' if math.isnan(err) else f'~{err:.1e}'} "
        f"({note})" for name, err, note in rows)
    met = chosen[1] <= limit
    lead = (f"{chosen[0]} is the cheapest {kind} meeting the accuracy {accuracy:g}"
            if met else
            f"no {kind} is estimated to meet the accuracy {accuracy:g}; {chosen[0]} is the "
            "most accurate")
    explanation = (f"{preamble}{lead} (estimated error {chosen[1]:.1e}); candidates by cost: "
                   f"{shown}")
    return Choice(chosen[0], dict(chosen[3]), float(chosen[1]), accuracy, explanation,
                  tuple(rows))


def stepper_tol_factor(accuracy: float) -> tuple[float, float]:
    """The adaptive tol (× the default) meeting ``accuracy`` and the error estimated there."""
    lo, hi = STEPPER_TOL_FACTORS
    budget = accuracy - GRID_ERROR
    factor = (budget / (SAFETY * STEPPER_ERROR)) ** (1.0 / STEPPER_EXPONENT)
    factor = min(max(factor, lo), hi)
    return factor, SAFETY * STEPPER_ERROR * factor ** STEPPER_EXPONENT


#: Local tolerance of the adhesive march, in decay lengths (z0)
#: (:data:`viscoforce.solvers.adhesive_dynamics.ADHESIVE_TOL`).
ADHESIVE_STEPPER_TOL = 1e-4


def choose_simulation(problem: ContactProblem, drive: Any, *,
                      accuracy: float = DEFAULT_ACCURACY) -> Choice:
    """The stepper and tolerance of :func:`~viscoforce.solvers.simulate.simulate` for ``accuracy``.

    The adaptive exponential trapezoidal stepper is the cheapest at every accuracy measured
    (first-order exponential Euler and the paper's explicit Euler need 5–10× the time at 1e-3);
    its tolerance is loosened or tightened from the measured error–tolerance relation. Where the
    whole drive stays before contact and the SVDA estimate meets the accuracy, the explanation
    says that the SVDA ODE (:func:`~viscoforce.solvers.svda_ode.solve_svda`) would do too.

    Returns
    -------
    Choice
        ``method`` a stepper name, ``options`` the ``tol`` [m] for simulate.
    """
    require_instance("problem", problem, ContactProblem)
    accuracy = require_accuracy(accuracy)
    factor, error = stepper_tol_factor(accuracy)
    law = problem.surface_force
    terms = law.terms if isinstance(law, SumOfLaws) else (law,)
    if any(isinstance(t, LennardJones) for t in terms):
        # adhesive regime (issue 39): jumps are fast transients (or instantaneous glassy jumps)
        # that only an adaptive implicit stepper resolves; euler and fixed steps are refused
        tol = ADHESIVE_STEPPER_TOL * law.decay_length
        return Choice("exponential", {"tol": tol}, error + GRID_ERROR, accuracy,
                      f"adhesive (Lennard-Jones) law: exponential, adaptive (tol = {tol:.3g} m), "
                      "shrinking its step through jump-in/jump-out, instantaneous glassy jumps "
                      "where the E0 equilibrium folds; euler and fixed steps cannot resolve a "
                      "jump", ())
    default_tol = DEFAULT_STEPPER_TOL * law.decay_length
    deepest = float(drive.extent()[0])
    svda, svda_note = svda_error(problem, deepest)
    candidates = [
        ("exponential", error + GRID_ERROR,
         f"second order, adaptive, tol = {factor:.3g} x the default "
         f"({factor * default_tol:.3g} m)", {"tol": factor * default_tol}),
        ("exponential-euler", math.nan,
         "first order: 5-20x the time of exponential at equal error (study)", {}),
        ("euler", math.nan,
         "the paper's explicit Euler, step-limited: 10-20x the time at equal error (study)", {}),
    ]
    preamble = f"drive down to h0 = {deepest * 1e9:.4g} nm: "
    choice = finish("stepper", candidates, accuracy, preamble)
    if svda + error <= meets(accuracy):
        note = (f"; the SVDA ODE (solve_svda) would also meet it here (SVDA error ~{svda:.1e}, "
                f"{svda_note})")
    else:
        note = f"; the SVDA is not adequate ({svda_note}{'' if math.isinf(svda) else f', ~{svda:.1e}'})"
    return Choice(choice.method, choice.options, choice.estimated_error, accuracy,
                  choice.explanation + note, choice.considered)
