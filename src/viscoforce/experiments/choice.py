"""The spectrum-route choice: :func:`choose_spectrum` (``spectrum(..., method="auto")``).

The estimates, :class:`~viscoforce.choice.Choice` and the stepper choice live in
:mod:`viscoforce.choice`; this module adds what needs the solver: the finite-amplitude bias of a
linear spectrum by harmonic balance
(:func:`~viscoforce.experiments.finite_amplitude.amplitude_bias`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._validation import require_finite, require_positive
from viscoforce.choice import (
    DEFAULT_ACCURACY,
    DEFAULT_SWEEP_TOL,
    GRID_ERROR,
    SAFETY,
    SWEEP_ERROR,
    SWEEP_EXPONENT,
    SWEEP_TOL_FACTORS,
    Choice,
    amplitude_error,
    contact_error,
    finish,
    meets,
    require_accuracy,
    svda_error,
)
from viscoforce.experiments._checks import require_frequencies, require_number, require_problem
from viscoforce.experiments.finite_amplitude import AMPLITUDE_SAFETY, finite_amplitude_error
from viscoforce.problem import ContactProblem
from viscoforce.radial_grid import RadialGrid

#: Factor on the harmonic-balance bias: its leading term is exact for small η; measured
#: (studies/validity_maps/validity_maps.py, time-domain lock-in) at 0.95–1.0× it for κη ≤ 0.1 (Fig. 3:
#: 5.5e-4 both; −5 nm: 3.5e-3 vs 3.7e-3), 0.78× at κη = 0.25 and 0.24× at κη = 1 (Fig. 4).
BIAS_SAFETY = 1.1
#: Coarser grids of the linear route: (node spacing × the problem's, measured max error over the
#: study's static loads, Fig. 3, Fig. 4 and deep spectra; studies/speed_accuracy/speed_accuracy.py). The
#: estimate used is SAFETY × that; the deep spectrum is 20× faster at × 4 (12 ms vs 0.24 s).
COARSE_GRIDS = ((4.0, 6.4e-5), (2.0, 2.7e-7))
#: The share of the accuracy a coarser grid's own error may take.
GRID_SHARE = 0.1
#: Grids with fewer nodes are not coarsened (their solve costs less than a new kernel build).
COARSEN_FROM_NODES = 128


def amplitude_error_of(problem: ContactProblem, position: float, eta: float,
                       omega: np.ndarray) -> tuple[float, str]:
    """The finite-amplitude error of a linear spectrum and how it was estimated.

    max over ``omega`` of |b(ω)| η² (:func:`amplitude_bias`, the leading term; the next is
    smaller by ≈ |b|η²/3 for an exponential law) × :data:`BIAS_SAFETY`; the rigid estimate
    × AMPLITUDE_SAFETY if the harmonic balance cannot be solved.
    """
    decay = problem.surface_force.decay_length
    error, harmonic = finite_amplitude_error(problem, position, eta, omega)
    if not harmonic:
        return error, (f"finite amplitude kappa*eta = {eta / decay:.3g} -> {error:.1e} "
                       f"({AMPLITUDE_SAFETY:g} x the rigid exponential estimate)")
    estimate = BIAS_SAFETY * error
    return estimate, (f"finite amplitude kappa*eta = {eta / decay:.3g} -> {estimate:.1e} "
                      "(third-order harmonic balance)")


def coarsened(problem: ContactProblem, factor: float) -> ContactProblem:
    """``problem`` on a grid ``factor`` × coarser (same outer radius and order)."""
    if factor == 1.0:
        return problem
    grid = problem.grid
    coarse = RadialGrid.from_spacing(grid.outer_radius, factor * grid.spacing, grid.order)
    return ContactProblem(problem.sphere, problem.surface_force, problem.material, coarse)


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
    decay = problem.surface_force.decay_length
    rigid = amplitude_error(eta, decay)  # before contact an upper bound (the deformation softens)
    rigid_note = f"finite amplitude kappa*eta = {eta / decay:.3g} -> {rigid:.1e} (rigid)"
    svda, svda_note = svda_error(problem, position)
    factor, grid_error = 1.0, GRID_ERROR
    for f, measured in COARSE_GRIDS:  # the coarsest grid whose own error leaves room
        if (problem.grid.size >= COARSEN_FROM_NODES
                and SAFETY * measured <= GRID_SHARE * accuracy):
            factor, grid_error = f, SAFETY * measured
            break
    grid_note = ("default grid" if factor == 1.0 else
                 f"grid {factor:g} x coarser (measured <= {grid_error / SAFETY:.1e})")
    linear_problem = coarsened(problem, factor)
    if svda + rigid <= meets(accuracy):  # the closed form will do: do not build the exact kernel
        amp, amp_note = math.nan, "not needed"
    else:
        amp, amp_note = amplitude_error_of(linear_problem, position, eta, omega)
    hertz, hertz_note = contact_error(problem, position, float(np.max(omega)))
    sweep_error = SAFETY * SWEEP_ERROR
    tol_factor = 1.0
    if sweep_error + GRID_ERROR > accuracy:  # tighten tol, within the measured range
        budget = accuracy - GRID_ERROR
        tol_factor = max((budget / sweep_error) ** (1.0 / SWEEP_EXPONENT), SWEEP_TOL_FACTORS[0])
        sweep_error = sweep_error * tol_factor ** SWEEP_EXPONENT
    sweep_options = {} if tol_factor == 1.0 else {"tol": tol_factor * DEFAULT_SWEEP_TOL * eta}
    candidates = [
        ("svda", svda + rigid, f"{svda_note}; {rigid_note}", {}),
        ("contact", hertz + amp, f"{hertz_note}; {amp_note}", {}),
        ("linear", grid_error + amp, f"{grid_note}; {amp_note}",
         {} if factor == 1.0 else {"grid_factor": factor}),
        ("svda-ode", svda + SAFETY * SWEEP_ERROR, svda_note, {}),
        ("time-domain", GRID_ERROR + sweep_error,
         "lock-in and stepper" + (f" at tol = {tol_factor:.2g} x the default"
                                  if tol_factor != 1.0 else " at the default settings"),
         sweep_options),
    ]
    return finish("spectrum route", candidates, accuracy,
                   f"h0 = {position * 1e9:.4g} nm, eta = {eta * 1e9:.3g} nm: ")

