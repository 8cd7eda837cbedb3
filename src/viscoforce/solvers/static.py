"""Static elastic equilibrium at a fixed position (paper Eq. 2 with Eq. 13)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from viscoforce._validation import require_finite, require_instance, require_positive
from viscoforce.problem import ContactProblem, check_half_space, contact_radius
from viscoforce.schema import SIGN_CONVENTION, make_equilibrium
from viscoforce.solvers.newton import NewtonResult, solve_gap
from viscoforce.units import format_quantity

#: Newton tolerance on the gap update, in units of the surface force's decay length.
STATIC_XTOL = 1e-9


def equilibrium_gap(problem: ContactProblem, position: float, modulus: float, *,
                    initial: np.ndarray | None = None) -> NewtonResult:
    """Nodal gaps of the elastic equilibrium h = h0(r) + (2/E) A p(h) at ``position`` [m].

    Parameters
    ----------
    problem : ContactProblem
        System and grid.
    position : float
        Apex position h0 [m].
    modulus : float
        Elastic modulus E [Pa] (paper convention).
    initial : ndarray, optional
        Starting gaps [m]; default max(h0(r), λ) with λ the decay length of the law.
    """
    require_instance("problem", problem, ContactProblem)
    modulus = require_positive("modulus (E)", modulus)
    base = problem.undeformed_gap(position)
    if initial is None:
        initial = np.maximum(base, problem.surface_force.decay_length)
    xtol = STATIC_XTOL * problem.surface_force.decay_length
    return solve_gap(problem, base, 2.0 / modulus, initial, xtol=xtol)


def static_equilibrium(problem: ContactProblem, position: float, *, modulus: float | None = None,
                       contact_threshold: float | None = None) -> xr.Dataset:
    """Static elastic equilibrium of the sphere at apex position ``position``.

    Parameters
    ----------
    problem : ContactProblem
        System and grid; the grid must reach far enough for ``position``
        (build it with ``ContactProblem.create(..., deepest_position=position)``).
    position : float
        Apex position h0 [m] (may be negative for deformable bodies).
    modulus : float, optional
        Elastic modulus E [Pa]; default the material's relaxed modulus E_inf.
    contact_threshold : float, optional
        Gap [m] below which the surfaces count as in contact; default the law's decay length (1/κ).

    Returns
    -------
    xarray.Dataset
        Profiles ``gap``, ``deformation``, ``pressure``, ``undeformed_gap`` over ``r`` [m]; scalars
        ``position``, ``force``, ``force_rigid``, ``u_center``, ``h_center``, ``contact_radius``;
        attrs hold every parameter, the Newton iteration count and the final update norm.

    Raises
    ------
    ParameterError
        Bad position/modulus or a grid too small for the position.
    ConvergenceError
        Newton failed (never returns a partial result).
    ModelValidityError
        The result lies far outside the half-space model (contact radius or deformation not small
        against R; :func:`~viscoforce.problem.check_half_space`).

    Warns
    -----
    ModelValidityWarning
        The contact radius or deformation approaches R (the model degrades).
    """
    require_instance("problem", problem, ContactProblem)
    position = require_finite("position (h0)", position)
    modulus = (problem.material.relaxed_modulus if modulus is None
               else require_positive("modulus (E)", modulus))
    threshold = (problem.surface_force.decay_length if contact_threshold is None
                 else require_positive("contact_threshold", contact_threshold))
    problem.check_covers(position)
    sol = equilibrium_gap(problem, position, modulus)
    return equilibrium_dataset(problem, position, modulus, sol, threshold)


def equilibrium_dataset(problem: ContactProblem, position: float, modulus: float,
                        sol: NewtonResult, threshold: float) -> xr.Dataset:
    """Package one equilibrium as a Dataset (:func:`viscoforce.schema.make_equilibrium`)."""
    base = problem.undeformed_gap(position)
    u_center = float(-(2.0 / modulus) * problem.center_row @ sol.pressure)
    h_center = position - u_center
    attrs = dict(problem.parameters())
    attrs.update({"modulus": modulus, "contact_threshold": threshold,
                  "newton_iterations": sol.iterations, "newton_update_norm": sol.update_norm,
                  "sign_convention": SIGN_CONVENTION})
    radius = contact_radius(problem.grid, sol.gap, h_center, threshold)
    check_half_space(problem.sphere.radius, u_center, radius,
                     where=f"at h0 = {format_quantity(position, 'length')}", stacklevel=4)
    return make_equilibrium(
        problem.grid.r, gap=sol.gap, deformation=base - sol.gap, pressure=sol.pressure,
        undeformed_gap=base, position=position, force=float(problem.load(sol.pressure)),
        force_rigid=problem.rigid_load(position), u_center=u_center, h_center=h_center,
        contact_radius=radius, contact_threshold=threshold, attrs=attrs)
