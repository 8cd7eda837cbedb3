"""One static elastic adhesive equilibrium, on the branch a quasi-static approach or retraction reaches.

With an attractive (Lennard-Jones) law the equilibria at one position h0 are not unique between
the jump-in and the jump-out (:mod:`viscoforce.solvers.continuation`): the far branch, the
unstable branch and the contact branch coexist there, and Newton from the undeformed gap finds
whichever it falls into — or none just inside the jump-in, where only the contact branch exists.
Here the branch is chosen by the history that leads to h0, quasi-statically:

``"approach"``
    far apart, then down to h0: the far branch above the jump-in, the contact branch below it;
``"retract"``
    deep contact, then up to h0: the contact branch below the jump-out, the far branch above it.

Both come from one approach path (:func:`~viscoforce.solvers.continuation.equilibrium_path`)
traced past every fold; the chosen crossing of h0 is polished by Newton (the static solver's tolerance). The
load includes the rigid tail beyond the grid (:func:`~viscoforce.solvers.continuation.load_with_tail`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from viscoforce._validation import require_finite, require_instance, require_positive
from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.problem import ContactProblem
from viscoforce.solvers.continuation import (
    Fold,
    equilibrium_path,
    lennard_jones_term,
    load_with_tail,
)
from viscoforce.solvers.newton import NewtonResult, solve_gap
from viscoforce.solvers.static import STATIC_XTOL, equilibrium_dataset

#: The quasi-static histories that choose a branch (see the module docstring).
BRANCHES = ("approach", "retract")
#: The approach starts this many decay lengths (plus 2 per unit of Tabor's parameter) out.
_FAR_GAP = 12.0
#: The path ends this many z0 below min(h0, 0), past every fold.
_PAST = 1.0
#: The Newton polish may move the interpolated gaps by at most this many decay lengths.
_POLISH_LIMIT = 0.1


@dataclass(frozen=True)
class BranchEquilibrium:
    """A static adhesive equilibrium and how it was reached (:func:`branch_equilibrium`).

    Attributes
    ----------
    solution : NewtonResult
        Nodal gaps and pressures at exactly ``position``.
    position : float
        h0 [m].
    branch : str
        ``"approach"`` or ``"retract"``: the history that chose the branch.
    on : str
        ``"far"`` or ``"contact"`` (the branch the state is on), or ``"unique"`` where the path
        has no fold (Tabor's parameter below ~0.7: one equilibrium at every h0).
    jump_in, jump_out : Fold or None
        The path's jump-in and jump-out (position [m], force [N]; None without folds).
    pull_off : float or None
        The path's pull-off force [N] (−min F on the contact branch).
    force : float
        Load [N] with the rigid tail beyond the grid.
    """

    solution: NewtonResult
    position: float
    branch: str
    on: str
    jump_in: Fold | None
    jump_out: Fold | None
    pull_off: float | None
    force: float

    def attrs(self) -> dict:
        """The state's history as netCDF-safe attributes.

        ``branch``, ``on_branch``, ``force_includes_tail``, and those the path found of
        ``jump_in_position``/``_force``, ``jump_out_position``/``_force`` and ``pull_off``.
        """
        out: dict = {"branch": self.branch, "on_branch": self.on, "force_includes_tail": 1}
        for name, fold in (("jump_in", self.jump_in), ("jump_out", self.jump_out)):
            if fold is not None:
                out[f"{name}_position"] = fold.position
                out[f"{name}_force"] = fold.force
        if self.pull_off is not None:
            out["pull_off"] = self.pull_off
        return out


def branch_equilibrium(problem: ContactProblem, position: float, *, branch: str = "approach",
                       modulus: float | None = None) -> BranchEquilibrium:
    """The static elastic equilibrium at ``position`` [m] on the branch ``branch`` reaches.

    One approach path from far apart to below ``position`` (and below h0 = 0, past every fold)
    is traced; its stable crossings of ``position`` are the candidates: an approach takes the
    first, a retraction the last. The crossing is polished by Newton from the gaps interpolated
    between its two path points.

    Parameters
    ----------
    problem : ContactProblem
        System with an attractive (Lennard-Jones) law, on a grid reaching ``position``
        (:func:`~viscoforce.solvers.continuation.adhesion_grid`).
    position : float
        h0 [m].
    branch : {"approach", "retract"}
        The quasi-static history (module docstring).
    modulus : float, optional
        E [Pa]; default the material's relaxed modulus E_inf.

    Returns
    -------
    BranchEquilibrium

    Raises
    ------
    ParameterError
        A law without attraction, an unknown branch, or a grid too small for the path.
    ConvergenceError
        The continuation or the final Newton polish failed, or the polish left the branch.
    """
    require_instance("problem", problem, ContactProblem)
    position = require_finite("position (h0)", position)
    if branch not in BRANCHES:
        raise ParameterError(f"branch must be one of {list(BRANCHES)}, got {branch!r}")
    lj = lennard_jones_term(problem.surface_force)
    if lj is None:
        raise ParameterError("branch_equilibrium needs an attractive (Lennard-Jones) surface "
                             "force; use static_equilibrium for a repulsive law")
    modulus = (problem.material.relaxed_modulus if modulus is None
               else require_positive("modulus (E)", modulus))
    ell = problem.surface_force.decay_length
    mu = lj.tabor_parameter(problem.sphere.radius, modulus)
    far = max(position + ell, (_FAR_GAP + 2.0 * mu) * lj.z0)
    path = equilibrium_path(problem, far, min(position, 0.0) - _PAST * lj.z0, modulus=modulus)
    h = path.position - position
    crossings = [i for i in range(h.size - 1)
                 if h[i] * h[i + 1] <= 0 and h[i] != h[i + 1] and path.stable[i]
                 and path.stable[i + 1]]
    if not crossings:  # pragma: no cover - the approach path always crosses position stably
        raise ConvergenceError(f"no stable equilibrium on the path at h0 = {position:.4g} m")
    i = crossings[0] if branch == "approach" else crossings[-1]
    w = h[i] / (h[i] - h[i + 1])
    guess = (1.0 - w) * path.gap[i] + w * path.gap[i + 1]
    sol = solve_gap(problem, problem.undeformed_gap(position), 2.0 / modulus,
                    np.maximum(guess, 1e-3 * ell), xtol=STATIC_XTOL * ell)
    if np.max(np.abs(sol.gap - guess)) > _POLISH_LIMIT * ell:
        raise ConvergenceError(
            f"the Newton polish at h0 = {position:.4g} m left the {branch} branch (its gaps moved "
            f"by {np.max(np.abs(sol.gap - guess)) / ell:.3g} decay lengths from the path's); "
            "refine the grid (adhesion_grid resolution) or use equilibrium_path")
    if not path.folds:
        on = "unique"
    else:
        arc = (1.0 - w) * path.arclength[i] + w * path.arclength[i + 1]
        on = "far" if arc < path.folds[0].arclength else "contact"
    return BranchEquilibrium(solution=sol, position=position, branch=branch, on=on,
                             jump_in=path.jump_in, jump_out=path.jump_out,
                             pull_off=path.pull_off, force=load_with_tail(problem, sol.gap))


def adhesive_equilibrium(problem: ContactProblem, position: float, *, branch: str = "approach",
                         modulus: float | None = None,
                         contact_threshold: float | None = None) -> xr.Dataset:
    """:func:`~viscoforce.solvers.static.static_equilibrium` for an attractive law.

    Parameters
    ----------
    problem, position, branch, modulus
        As :func:`branch_equilibrium`.
    contact_threshold : float, optional
        Gap [m] defining the contact radius; default the law's decay length.

    Returns
    -------
    xarray.Dataset
        The equilibrium (profiles over ``r``); ``force`` includes the rigid tail beyond the grid
        (``attrs["force_includes_tail"] = 1``); attrs add those of
        :meth:`BranchEquilibrium.attrs` (branch, on_branch, the path's folds and pull-off).
    """
    state = branch_equilibrium(problem, position, branch=branch, modulus=modulus)
    modulus = (problem.material.relaxed_modulus if modulus is None else modulus)
    threshold = (problem.surface_force.decay_length if contact_threshold is None
                 else require_positive("contact_threshold", contact_threshold))
    ds = equilibrium_dataset(problem, state.position, modulus, state.solution, threshold)
    ds["force"] = ds["force"].copy(data=state.force)
    ds.attrs.update(state.attrs())
    return ds
