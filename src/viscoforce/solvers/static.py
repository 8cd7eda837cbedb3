"""Static elastic equilibrium at a fixed position (paper Eq. 2 with Eq. 13)."""

from __future__ import annotations

import numpy as np
import xarray as xr

from viscoforce._validation import require_finite, require_positive
from viscoforce.problem import ContactProblem, contact_radius
from viscoforce.solvers.newton import NewtonResult, solve_gap

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
    """
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
    """Package one equilibrium as a Dataset (shared by the static and dynamic entry points)."""
    base = problem.undeformed_gap(position)
    deformation = base - sol.gap
    u_center = float(-(2.0 / modulus) * problem.center_row @ sol.pressure)
    h_center = position - u_center
    a = contact_radius(problem.grid, sol.gap, h_center, threshold)
    attrs = {k: v for k, v in problem.parameters().items()}
    attrs.update({"modulus": modulus, "contact_threshold": threshold,
                  "newton_iterations": sol.iterations, "newton_update_norm": sol.update_norm,
                  "sign_convention": "u < 0 is flattening; gap = h0 + r^2/2R - u; force > 0 repels"})
    r = xr.DataArray(problem.grid.r, dims="r", attrs={"units": "m", "long_name": "radial coordinate"})

    def prof(values, units, name):
        return xr.DataArray(values, dims="r", attrs={"units": units, "long_name": name})

    def scal(value, units, name):
        return xr.DataArray(value, attrs={"units": units, "long_name": name})

    return xr.Dataset(
        {
            "gap": prof(sol.gap, "m", "local surface separation h(r)"),
            "deformation": prof(deformation, "m", "surface deformation u(r)"),
            "pressure": prof(sol.pressure, "Pa", "surface pressure p(h(r))"),
            "undeformed_gap": prof(base, "m", "undeformed separation h0 + r^2/2R"),
            "position": scal(position, "m", "apex position h0"),
            "force": scal(float(problem.load(sol.pressure)), "N", "load F"),
            "force_rigid": scal(problem.rigid_load(position), "N", "load between rigid bodies"),
            "u_center": scal(u_center, "m", "central deformation u(0)"),
            "h_center": scal(h_center, "m", "central gap h(0)"),
            "contact_radius": scal(a, "m", f"radius where the gap < {threshold:g} m"),
        },
        coords={"r": r},
        attrs=attrs,
    )
