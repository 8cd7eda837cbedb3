"""The spectrum-route choice: :func:`choose_spectrum` (``spectrum(..., method="auto")``).

The estimates, :class:`~viscoforce.choice.Choice` and the stepper choice live in
:mod:`viscoforce.choice`; this module adds what needs the static solver: the quasi-static
finite-amplitude error of the elastic spring F_E(h).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._validation import as_float_1d, require_finite, require_instance, require_positive
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
from viscoforce.problem import ContactProblem
from viscoforce.solvers.static import equilibrium_gap

#: Drive phases of the quasi-static first harmonic (trapezoidal rule on a period: exact for
#: trigonometric polynomials of degree < 2·QUASI_STATIC_NODES − 1 in the phase).
QUASI_STATIC_NODES = 12
#: Relative step of the finite-difference linear stiffness (× η).
LINEAR_STEP = 1e-3
#: The rigid estimate above which the static refinement is not tried (× accuracy): measured
#: ratios refined/rigid are 0.44–0.77.
REFINE_UP_TO = 4.0


def quasi_static_amplitude_error(problem: ContactProblem, position: float, eta: float) -> float:
    """Largest |F1/(η F_E′) − 1| of the elastic springs F_E(h) at E = E_inf and E = E0.

    F1 is the first sine harmonic of F_E(h̄0 + η sin θ) over a period (trapezoidal rule in θ),
    F_E′ the stiffness at h̄0 (central difference, step 1e-3 η). Both moduli bound the
    viscoelastic response, whose instantaneous part is glassy and whose slow part relaxed.
    The grid must reach h̄0 − η.
    """
    problem.check_covers(position - eta)
    theta = 2.0 * math.pi * np.arange(2 * QUASI_STATIC_NODES) / (2 * QUASI_STATIC_NODES)
    material = problem.material
    worst = 0.0
    for modulus in (material.relaxed_modulus, material.instantaneous_modulus):
        def force(h: float, modulus: float = modulus) -> float:
            return float(problem.load(equilibrium_gap(problem, h, modulus).pressure))

        forces = np.array([force(position + eta * math.sin(t)) for t in theta])
        first = 2.0 * float(np.mean(forces * np.sin(theta)))
        step = LINEAR_STEP * eta
        slope = (force(position + step) - force(position - step)) / (2.0 * step)
        worst = max(worst, abs(first / (eta * slope) - 1.0))
    return worst


def amplitude_error_of(problem: ContactProblem, position: float, eta: float,
                       accuracy: float) -> tuple[float, str]:
    """The finite-amplitude error of a linear spectrum and how it was estimated."""
    decay = problem.surface_force.decay_length
    rigid = amplitude_error(eta, decay)
    note = f"finite amplitude kappa*eta = {eta / decay:.3g} -> {rigid:.1e} (rigid exponential)"
    if rigid <= accuracy or rigid > REFINE_UP_TO * accuracy:
        return rigid, note
    try:
        refined = quasi_static_amplitude_error(problem, position, eta)
    except (ConvergenceError, ParameterError):
        return rigid, note
    return refined, (f"finite amplitude kappa*eta = {eta / decay:.3g} -> {refined:.1e} "
                     f"(quasi-static elastic springs at E_inf and E0; rigid {rigid:.1e})")


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
    require_instance("problem", problem, ContactProblem)
    position = require_finite("position", position)
    eta = require_positive("eta", eta)
    omega = as_float_1d("omega", omega)
    if not np.all(omega > 0):
        raise ParameterError(f"omega must be > 0 [rad/s], got min {float(np.min(omega))!r}")
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
