"""The spectrum-route choice: :func:`choose_spectrum` (``spectrum(..., method="auto")``).

The estimates, :class:`~viscoforce.choice.Choice` and the stepper choice live in
:mod:`viscoforce.choice`; this module adds what needs the static solver: the quasi-static
finite-amplitude error of the elastic spring F_E(h).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._validation import require_finite, require_positive
from viscoforce.choice import (
    DEFAULT_ACCURACY,
    GRID_ERROR,
    SAFETY,
    SWEEP_ERROR,
    SWEEP_EXPONENT,
    Choice,
    amplitude_error,
    contact_error,
    finish,
    require_accuracy,
    svda_error,
)
from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.experiments._checks import require_frequencies, require_number, require_problem
from viscoforce.experiments.linear_response import AMPLITUDE_SAFETY
from viscoforce.problem import ContactProblem
from viscoforce.solvers.newton import solve_gap
from viscoforce.solvers.static import equilibrium_gap

#: Drive phases of the quasi-static first harmonic (trapezoidal rule on a period: exact for
#: trigonometric polynomials of degree < 2·QUASI_STATIC_NODES − 1 in the phase).
QUASI_STATIC_NODES = 12
#: Relative step of the finite-difference linear stiffness (× η).
LINEAR_STEP = 1e-3
#: Factor on the finite-amplitude estimates (:data:`~viscoforce.experiments.linear_response.
#: AMPLITUDE_SAFETY`): the measured bias of the linear spectrum (max over ω of
#: |k1(η)/k*(ω) − 1|, benchmarks/validity_maps.py) is up to 2.4× the larger of the rigid and the
#: quasi-static estimates at h̄0 = −5 nm (κη = 0.1–0.25: the mean state rectifies between the
#: two limits), 1.1× at Fig. 4 (κη = 1), 0.44× at Fig. 3 (2 nm, κη = 0.1).
#: The quasi-static springs are solved when the rigid estimate × AMPLITUDE_SAFETY lies within
#: this factor below the accuracy (above it, the linear route is out anyway).
REFINE_BELOW = 10.0


def quasi_static_amplitude_error(problem: ContactProblem, position: float, eta: float) -> float:
    """Largest |F1/(η F′) − 1| of the two limiting springs of a sine drive about h̄0.

    ω → 0: the elastic E_inf spring (each phase at its static relaxed equilibrium); ω → ∞: the
    glassy spring about the relaxed mean state (the creep memory frozen at the E_inf state at
    h̄0, the instantaneous compliance 1/E0 acting on the pressure change):
    h = h0(r) + (2/E_inf − 2/E0) A p̄ + (2/E0) A p(h). F1 is the first sine harmonic of the
    spring's force over a period (trapezoidal rule in the phase), F′ its slope at h̄0 (central
    difference, step 1e-3 η). The grid must reach h̄0 − η.
    """
    problem.check_covers(position - eta)
    theta = 2.0 * math.pi * np.arange(2 * QUASI_STATIC_NODES) / (2 * QUASI_STATIC_NODES)
    material = problem.material
    e_inf, e0 = material.relaxed_modulus, material.instantaneous_modulus
    mean = equilibrium_gap(problem, position, e_inf)
    frozen = (2.0 / e_inf - 2.0 / e0) * (problem.influence @ mean.pressure)
    xtol = 1e-9 * problem.surface_force.decay_length

    def relaxed(h: float) -> float:
        return float(problem.load(equilibrium_gap(problem, h, e_inf).pressure))

    def glassy(h: float) -> float:
        base = problem.undeformed_gap(h) + frozen
        return float(problem.load(solve_gap(problem, base, 2.0 / e0, mean.gap,
                                            xtol=xtol).pressure))

    step = LINEAR_STEP * eta
    phases = position + eta * np.sin(theta)
    worst = 0.0
    for force in (relaxed, glassy):
        first = 2.0 * float(np.mean([force(h) * math.sin(t) for h, t in zip(phases, theta,
                                                                             strict=True)]))
        slope = (force(position + step) - force(position - step)) / (2.0 * step)
        worst = max(worst, abs(first / (eta * slope) - 1.0))
    return worst


def amplitude_error_of(problem: ContactProblem, position: float, eta: float,
                       accuracy: float) -> tuple[float, str]:
    """The finite-amplitude error of a linear spectrum and how it was estimated.

    :data:`AMPLITUDE_SAFETY` × the larger of the rigid-exponential estimate
    (:func:`~viscoforce.choice.amplitude_error`) and, when that is near the accuracy, the
    quasi-static springs' (:func:`quasi_static_amplitude_error`).
    """
    decay = problem.surface_force.decay_length
    rigid = amplitude_error(eta, decay)
    estimate, how = rigid, "rigid exponential"
    if accuracy / REFINE_BELOW <= AMPLITUDE_SAFETY * rigid <= accuracy:
        try:
            springs = quasi_static_amplitude_error(problem, position, eta)
        except (ConvergenceError, ParameterError):
            springs = math.inf
        if springs > rigid:
            estimate, how = springs, "quasi-static springs at E_inf and E0"
    estimate *= AMPLITUDE_SAFETY
    return estimate, (f"finite amplitude kappa*eta = {eta / decay:.3g} -> {estimate:.1e} "
                      f"({AMPLITUDE_SAFETY:g} x the {how} estimate)")


def choose_spectrum(problem: ContactProblem, position: float, eta: float, omega: ArrayLike, *,
                    accuracy: float = DEFAULT_ACCURACY) -> Choice:
    """The cheapest spectrum route (and settings) whose estimated error meets ``accuracy``.

    Candidates by cost: the SVDA closed form, Hertz contact, the exact small-amplitude solve
    (``linear``), the SVDA ODE + lock-in (``svda-ode``) and exact time stepping + lock-in
    (``time-domain``, its ``tol`` tightened when the accuracy asks for it).

    Parameters
    ----------
    problem : ContactProblem
        System, material, grid.
    position : float
        Mean position h̄0 [m].
    eta : float
        Drive amplitude η [m], > 0.
    omega : array_like
        Angular frequencies [rad/s], > 0.
    accuracy : float
        Required relative error of k*(ω), in :data:`ACCURACY_RANGE`.

    Returns
    -------
    Choice
        ``method`` is a key of :data:`viscoforce.experiments.spectroscopy.SPECTRUM_METHODS`.
    """
    problem = require_problem(problem)
    position = require_number("position", position, require_finite,
                              "finite [m] (h0, the undeformed apex separation)")
    eta = require_number("eta", eta, require_positive, "> 0 [m] (finite)")
    omega = require_frequencies(omega, allow_zero=False)
    accuracy = require_accuracy(accuracy)
    amp, amp_note = amplitude_error_of(problem, position, eta, accuracy)
    svda, svda_note = svda_error(problem, position)
    hertz, hertz_note = contact_error(problem, position, float(np.max(omega)))
    sweep_error = SAFETY * SWEEP_ERROR
    tol_factor = 1.0
    if sweep_error > accuracy:
        tol_factor = (accuracy / sweep_error) ** (1.0 / SWEEP_EXPONENT)
        sweep_error = accuracy
    sweep_options = {} if tol_factor == 1.0 else {"tol": tol_factor * 1e-5 * eta}
    candidates = [
        ("svda", svda + amp, f"{svda_note}; {amp_note}", {}),
        ("contact", hertz + amp, f"{hertz_note}; {amp_note}", {}),
        ("linear", GRID_ERROR + amp, amp_note, {}),
        ("svda-ode", svda + SAFETY * SWEEP_ERROR, svda_note, {}),
        ("time-domain", GRID_ERROR + sweep_error,
         "lock-in and stepper" + (f" at tol = {tol_factor:.2g} x the default"
                                  if tol_factor != 1.0 else " at the default settings"),
         sweep_options),
    ]
    return finish("spectrum route", candidates, accuracy,
                   f"h0 = {position * 1e9:.4g} nm, eta = {eta * 1e9:.3g} nm: ")
