"""Damped Newton iteration for one equilibrium of the gap (static or one implicit time level).

Every equilibrium viscoforce solves has the form

    h = b + c · A p(h),                                                     (*)

with h the nodal gaps [m], b a known gap [m] (the undeformed gap minus any remembered deformation),
c = 2 J [1/Pa] twice an (effective) compliance and A the influence matrix [m] (u = −c A p). The
static elastic problem is c = 2/E, b = h0 + r²/2R; the implicit viscoelastic step is the same with an
effective compliance and the memory of the past in b. The Jacobian is I − c·A·p'(h) (= I + c·A·|p'|
for a repulsive law).

Damping: a fraction-to-boundary rule keeps every gap > 0 (a step may shrink a gap by at most a factor
5) and a backtracking line search on the max-norm of the residual of (*). Convergence: the full Newton
update is below ``xtol`` (max-norm). Otherwise :class:`ConvergenceError` (or
:class:`GapClosureError` when the line search cannot keep the gap open) is raised — never NaN.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from viscoforce._typing import FloatArray
from viscoforce._validation import as_float_array, require_instance, require_int, require_positive
from viscoforce.exceptions import ConvergenceError, GapClosureError, ParameterError
from viscoforce.problem import ContactProblem

#: LAPACK's LU factorisation and solve for float64 (what scipy.linalg.lu_factor/lu_solve call).
_GETRF, _GETRS = scipy.linalg.lapack.get_lapack_funcs(("getrf", "getrs"), (np.empty((1, 1)),))
#: Smallest factor by which one Newton step may shrink a gap.
_FRACTION_TO_BOUNDARY = 0.2
#: A gap below this many decay lengths means the surfaces have effectively touched.
_GAP_FLOOR = 1e-6


@dataclass(frozen=True)
class NewtonResult:
    """Converged gap and bookkeeping.

    Attributes
    ----------
    gap : ndarray
        Nodal gaps h [m].
    pressure : ndarray
        p(h) [Pa].
    iterations : int
        Newton iterations used.
    update_norm : float
        Max-norm of the last Newton update [m].
    factor : tuple or None
        LU factorisation (``scipy.linalg.lu_factor``) of the last Newton Jacobian, taken at the
        iterate before the last update (within ``xtol`` of ``gap``): sensitivities of the
        solution reuse it.
    """

    gap: FloatArray
    pressure: FloatArray
    iterations: int
    update_norm: float
    factor: tuple[FloatArray, FloatArray] | None = None


def solve_gap(problem: ContactProblem, base: FloatArray, coupling: float, initial: FloatArray, *,
              xtol: float, max_iter: int = 60, time: float | None = None) -> NewtonResult:
    """Solve h = base + coupling · A p(h) by damped Newton.

    Parameters
    ----------
    problem : ContactProblem
        Supplies A and p(h).
    base : ndarray
        b [m] at the nodes.
    coupling : float
        c = 2 J [1/Pa] (2/E for an elastic solve).
    initial : ndarray
        Starting gaps [m], all > 0.
    xtol : float
        Convergence tolerance on the max-norm of the Newton update [m].
    max_iter : int
        Iteration limit.
    time : float, optional
        Simulation time for error messages [s].

    Raises
    ------
    ConvergenceError
        No convergence within ``max_iter`` iterations.
    GapClosureError
        The line search cannot reduce the residual while keeping the gap open.
    ParameterError
        Inputs of the wrong type, shape or sign (non-finite gaps, coupling ≤ 0, ...).
    """
    require_instance("problem", problem, ContactProblem)
    n = problem.grid.size
    base = as_float_array("base", base, size=n)
    initial = as_float_array("initial", initial, size=n)
    if base.ndim != 1 or initial.ndim != 1:
        raise ParameterError(f"base and initial must be 1-D with {n} values (one per node), got "
                             f"shapes {base.shape} and {initial.shape}")
    coupling = require_positive("coupling", coupling)
    xtol = require_positive("xtol", xtol)
    max_iter = require_int("max_iter", max_iter, 1)
    law = problem.surface_force
    a_mat = problem.influence
    where = "" if time is None else f" at t = {time:.6g} s"
    if np.any(initial <= 0):
        raise GapClosureError(f"initial gap must be > 0 everywhere{where}", time=time)
    h = np.array(initial, dtype=float)
    gap_floor = _GAP_FLOOR * law.decay_length
    p = law.pressure(h)
    res = h - base - coupling * (a_mat @ p)
    norm = float(np.abs(res).max())
    step_norm = np.inf
    # the Jacobian is built in Fortran order, LAPACK's, so that getrf factors it in place
    a_fortran = np.asfortranarray(a_mat)
    for it in range(1, max_iter + 1):
        jac = np.multiply(a_fortran, (-coupling) * law.pressure_derivative(h),
                          out=np.empty((n, n), order="F"))
        np.einsum("ii->i", jac)[...] += 1.0  # the diagonal, a view in any memory order
        # LAPACK's getrf/getrs directly: scipy.linalg.lu_factor/lu_solve return the same
        # factors and solution through an argument layer that costs more than a small solve
        lu, piv, info = _GETRF(jac, overwrite_a=True)
        if info == 0:
            delta, info = _GETRS(lu, piv, -res)
        if info != 0:
            what = (f"diagonal number {info} is exactly zero. Singular matrix." if info > 0
                    else f"LAPACK reported an illegal value in argument {-info}")
            raise ConvergenceError(f"singular Newton Jacobian{where}: {what}", time=time,
                                   iterations=it, residual_norm=norm)
        factor = (lu, piv)
        step_norm = float(np.abs(delta).max())
        if not math.isfinite(step_norm):
            raise ConvergenceError(f"non-finite Newton update{where}", time=time,
                                   iterations=it, residual_norm=norm)
        alpha = 1.0
        limit = (_FRACTION_TO_BOUNDARY - 1.0) * h  # the most a step may shrink each gap
        if (delta < limit).any():  # else every ratio limit/delta of a shrinking gap is ≥ 1
            shrink = delta < 0
            alpha = min(1.0, float((limit[shrink] / delta[shrink]).min()))
        while True:
            h_new = h + alpha * delta if alpha != 1.0 else h + delta
            p_new = law.pressure(h_new)
            res_new = h_new - base - coupling * (a_mat @ p_new)
            norm_new = float(np.abs(res_new).max())
            if norm_new <= (1.0 - 1e-4 * alpha) * norm or alpha * step_norm <= xtol:
                break
            alpha *= 0.5
            if alpha < 1e-12:
                raise GapClosureError(
                    f"Newton line search failed{where}: the residual {norm:.3g} m cannot be "
                    "reduced while keeping the gap open; the surface force cannot support this "
                    "position (try a smaller step, a stiffer wall, or a shallower position)",
                    time=time, iterations=it, residual_norm=norm)
        h, p, res, norm = h_new, p_new, res_new, norm_new
        if h.min() < gap_floor:
            raise GapClosureError(
                f"the gap closes{where}: min gap {float(np.min(h)):.3g} m after {it} Newton "
                "iterations; the surface force cannot hold the surfaces apart at this position "
                "(add a short-range wall, or use a shallower position or a smaller time step)",
                time=time, iterations=it, residual_norm=norm)
        if alpha == 1.0 and step_norm <= xtol:
            return NewtonResult(h, p, it, step_norm, factor)
    raise ConvergenceError(
        f"Newton did not converge in {max_iter} iterations{where} (last update {step_norm:.3g} m, "
        f"tolerance {xtol:.3g} m); refine the grid or start closer to the solution",
        time=time, iterations=max_iter, residual_norm=norm)
