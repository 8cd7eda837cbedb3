"""The small-amplitude spectrum of an adhesive (Lennard-Jones) contact, about a chosen branch.

The linear response of :mod:`viscoforce.experiments.linear_response` (the modal decomposition of
M = A·diag(−p′), k*(ω) = Σ β_j/(1 + 2C*(ω) λ_j)) holds about any *stable* static state; with
an attractive law the state at h̄0 is not unique between jump-in and jump-out, so it is taken
from :func:`~viscoforce.solvers.adhesive_static.branch_equilibrium` (the branch a quasi-static
approach or retraction reaches). Two additions over the repulsive case:

* the rigid tail of the attraction beyond the grid (the load of
  :func:`~viscoforce.solvers.continuation.load_with_tail`): mean force 2πR·W(h_edge) and
  stiffness −dF/dh̄0 = 2πR·p(h_edge), real (no deformation beyond the grid);
* the amplitude check: the law's local length scale is z0/9 (the (z0/h)⁹ wall's logarithmic
  slope at h = z0), far shorter than z0; the rigid estimate of the first harmonic's bias
  (:func:`~viscoforce.choice.amplitude_error`) at that scale, × 2.5 as for the repulsive law,
  must stay below 1 % or a warning says so.
"""

from __future__ import annotations

import warnings

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from viscoforce._validation import require_positive
from viscoforce.choice import WARN_ERROR, amplitude_error
from viscoforce.exceptions import ApproximationWarning
from viscoforce.experiments._checks import require_frequencies, require_number, require_problem
from viscoforce.experiments._modal import decompose
from viscoforce.experiments.finite_amplitude import AMPLITUDE_SAFETY
from viscoforce.experiments.linear_response import LinearizedState
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_spectrum
from viscoforce.solvers.adhesive_static import branch_equilibrium
from viscoforce.solvers.continuation import edge_gap, lennard_jones_term

#: The local length scale of a Lennard-Jones law in units of z0: the wall (z0/h)⁹ at h = z0.
LOCAL_SCALE = 1.0 / 9.0


def tail_stiffness(problem: ContactProblem, gap: np.ndarray) -> float:
    """−dF_tail/dh̄0 [N/m] of the rigid tail 2πR·W(h_edge) beyond the grid at nodal ``gap``."""
    edge = edge_gap(problem, gap)
    return float(2.0 * np.pi * problem.sphere.radius * problem.surface_force.pressure(edge))


def adhesive_linear_response(problem: ContactProblem, position: float, eta: float,
                             omega: ArrayLike, *, branch: str = "approach") -> xr.Dataset:
    """Spectrum of the exact small-amplitude response about the ``branch`` equilibrium.

    Parameters
    ----------
    problem : ContactProblem
        System with an attractive (Lennard-Jones) law on an
        :func:`~viscoforce.solvers.continuation.adhesion_grid` reaching ``position``.
    position : float
        Mean position h̄0 [m].
    eta : float
        Drive amplitude η [m], > 0 (scales ``force_amplitude`` and ``amplitude`` only).
    omega : array_like
        Angular frequencies [rad/s], > 0.
    branch : {"approach", "retract"}
        The quasi-static history that chooses the static state
        (:func:`~viscoforce.solvers.adhesive_static.branch_equilibrium`).

    Returns
    -------
    xarray.Dataset
        Spectrum with ``method = "linear"``; attrs add those of
        :meth:`~viscoforce.solvers.adhesive_static.BranchEquilibrium.attrs` (``branch``,
        ``on_branch``, ``force_includes_tail = 1``, the path's folds and pull-off).

    Warns
    -----
    ApproximationWarning
        η too large for the small-amplitude limit at the law's local scale z0/9 (module notes).
    """
    problem = require_problem(problem)
    eta = require_number("eta", eta, require_positive, "> 0 [m] (finite)")
    omega = require_frequencies(omega, allow_zero=False)
    lj = lennard_jones_term(problem.surface_force)
    state = branch_equilibrium(problem, position, branch=branch)
    modulus = float(problem.material.relaxed_modulus)
    linear = LinearizedState._from_decomposition(problem, state.position, modulus,
                                                 decompose(problem, state.solution))
    k = linear.stiffness_for(problem.material, omega) + tail_stiffness(problem,
                                                                       state.solution.gap)
    if lj is not None:
        error = AMPLITUDE_SAFETY * amplitude_error(eta, LOCAL_SCALE * lj.z0)
        if error > WARN_ERROR:
            warnings.warn(
                f"eta = {eta:.3g} m is {eta / lj.z0:.3g} z0: the first harmonic of the drive may "
                f"differ from the small-amplitude spectrum by up to ~{100 * error:.2g} % "
                "(estimate: 2.5 x the rigid exponential bias at the Lennard-Jones wall's length "
                "scale z0/9); use a smaller eta or simulate the drive", ApproximationWarning,
                stacklevel=3)
    attrs = dict(problem.parameters())
    attrs.update({"method": "linear", "position": float(position), "eta": eta})
    attrs.update(state.attrs())
    return make_spectrum(omega, k, np.full(omega.shape, state.force), eta, attrs=attrs,
                         check=False)
