"""The static state's balanced eigen-decomposition and the real-pair algebra on it.

What :class:`~viscoforce.experiments.linear_response.LinearizedState` (the modal stiffness) and
:mod:`viscoforce.experiments.finite_amplitude` (the finite-amplitude check) share: one static
E_inf solve and one eigen-decomposition per state (:func:`decomposition`, cached), solves with
V's LU factors, real matrix products on complex columns viewed as (re, im) pairs, and the bounded
thread-safe cache (:class:`StateCache`) both keep their states in. The balancing and the choice of
eigensolver are explained in :mod:`viscoforce.experiments.linear_response`.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from viscoforce._typing import FloatArray
from viscoforce.exceptions import ParameterError
from viscoforce.problem import ContactProblem
from viscoforce.solvers.newton import NewtonResult
from viscoforce.solvers.static import equilibrium_gap

#: Most static states each cache of the linear response keeps.
STATE_CACHE_SIZE = 32


@dataclass(frozen=True)
class Decomposition:
    """A static solution and the eigen-decomposition of its balanced linearisation.

    On the nodes where s = −p′ ≠ 0 (``active``), D = W s (``d``), q = |D|^½ and
    M' = q (A W⁻¹) q sign(D) = V Λ V⁻¹ (``lam``, ``vec``): what
    :class:`~viscoforce.experiments.linear_response.LinearizedState` (the modal stiffness) and
    the modes of :mod:`~viscoforce.experiments.finite_amplitude` (the finite-amplitude check)
    both need, so a cold :func:`~viscoforce.experiments.linear_response.linear_response` solves and
    decomposes once.
    """

    sol: NewtonResult
    #: p′ [Pa/m] at every node (the finite-amplitude check needs it too).
    d1: FloatArray
    active: NDArray[np.intp]
    d: FloatArray
    q: FloatArray
    lam: NDArray[np.complex128]
    #: Eigenvectors: real when every eigenvalue is (scipy's convention), else complex.
    vec: NDArray[np.complex128] | FloatArray
    #: LU factors of ``vec`` (scipy.linalg.lu_factor): V⁻¹ applied without forming it.
    lu: tuple[NDArray[np.complex128] | FloatArray, NDArray[np.intc]]
    #: V⁻¹ q, the modal coordinates of the unit drive (both users need it).
    unit_modes: NDArray[np.complex128] | FloatArray


def _active(problem: ContactProblem, sol: NewtonResult) -> tuple[
        FloatArray, NDArray[np.intp], FloatArray, FloatArray, FloatArray]:
    """p′, the nodes where it is nonzero, their area weights W, D = W s and A on them."""
    d1 = problem.surface_force.pressure_derivative(sol.gap)
    stiff = -d1  # s = −p′ (> 0 where repulsive)
    area = problem.grid.area_weights
    active = np.flatnonzero(stiff != 0.0)
    if active.size == 0:
        closest = float(np.min(sol.gap))
        decay = float(problem.surface_force.decay_length)
        raise ParameterError(
            f"position must be where the surfaces interact: at the closest gap, {closest:.3g} m "
            f"({closest / decay:.3g} decay lengths of {decay:.3g} m), the surface force's "
            "derivative p'(h) is 0 at every node of the grid, so the linear response (stiffness "
            "and phase) is undefined there; give a position within a few decay lengths of "
            "contact")
    if active.size == stiff.size:  # every node (the paper's law): no copies by index
        return d1, active, area, area * stiff, problem.influence
    area = area[active]
    return d1, active, area, area * stiff[active], problem.influence[np.ix_(active, active)]


def direct_stiffness(problem: ContactProblem, sol: NewtonResult,
                     compliance: np.ndarray) -> np.ndarray:
    """k*(c) = wᵀ (I + cM)⁻¹ 1 [N/m] by one complex solve per value of c = 2C*(ω) [1/Pa].

    The modal form's definition evaluated directly (M = A·diag(s) on the active nodes,
    w = 2π W s): cheaper than an eigen-decomposition for a few values (an N = 88 solve costs
    about a twelfth of ``eig``), and equal to the modal sum to rounding (≈ 1e-15 relative).
    ``compliance`` is 1-D and checked by the caller.
    """
    _, _, area, d, kernel = _active(problem, sol)
    matrix = kernel * (d / area)[None, :]  # A·diag(s)
    n = matrix.shape[0]
    systems = compliance[:, None, None] * matrix[None, :, :]
    systems[:, np.arange(n), np.arange(n)] += 1.0
    x = np.linalg.solve(systems, np.ones((compliance.size, n, 1), dtype=complex))[..., 0]
    return 2.0 * np.pi * (x @ d)


def refined_stiffness(problem: ContactProblem, sol: NewtonResult, base: Decomposition,
                      inverse_vec: np.ndarray, compliance: np.ndarray, *, rtol: float = 1e-14,
                      max_iter: int = 8) -> np.ndarray | None:
    """k*(c) [N/m] of the state ``sol`` by iteration preconditioned with a nearby state's modes.

    In balanced form k*(c) = 2π lᵀ x with (I + cM′) x = q, l = sign(D) q, M′ = q (A W⁻¹) q
    sign(D). The iteration x ← x + P(q − (I + cM′)x), P = V (I + cΛ)⁻¹ V⁻¹ of ``base`` (another
    modulus at the same position), contracts by about twice the relative change of q per step
    (1e-4 for a finite-difference step in E_inf): it stops when the residual's max-norm is below
    ``rtol`` of q's (k* then equals the modal sum to ≈ 1e-13), or returns None after
    ``max_iter`` steps, or when the active nodes or signs of D differ from ``base``'s (the
    caller decomposes instead). ``inverse_vec`` is V⁻¹ of ``base`` (formed once by the caller:
    two products per step instead of a triangular solve); ``compliance`` is 1-D and checked by
    the caller.
    """
    _, active, area, d, kernel = _active(problem, sol)
    if active.size != base.active.size or np.any(np.signbit(d) != np.signbit(base.d)):
        return None
    q = np.sqrt(np.abs(d))
    left = np.copysign(q, d)
    coupling = kernel / area[None, :]  # A W⁻¹
    inverse = 1.0 / (1.0 + compliance[None, :] * base.lam[:, None])  # (modes, values)

    def precondition(r: np.ndarray) -> np.ndarray:
        return times(base.vec, times(inverse_vec, r) * inverse)

    rhs = np.broadcast_to(q[:, None], (q.size, compliance.size)).astype(complex)
    x = precondition(rhs)
    limit = rtol * float(q.max())
    for _ in range(max_iter):
        residual = rhs - x - compliance[None, :] * (q[:, None] * times(coupling,
                                                                       left[:, None] * x))
        if float(np.abs(residual).max()) <= limit:
            return 2.0 * np.pi * (left @ x)
        x += precondition(residual)
    return None


def refine_near(problem: ContactProblem, static: Callable[[], NewtonResult], modulus: float,
                compliance: np.ndarray, decomposed: dict[float, Decomposition],
                inverses: dict[float, np.ndarray], span: float) -> np.ndarray | None:
    """:func:`refined_stiffness` from the decomposed state nearest ``modulus`` within ``span``.

    ``static()`` gives the state at ``modulus``; ``decomposed`` maps E_inf to decompositions at
    the same position, ``inverses`` keeps their V⁻¹ (formed here once). None: no state within
    ``span`` (relative), or the iteration did not converge.
    """
    near = [e for e in decomposed if abs(modulus - e) <= span * e]
    if not near:
        return None
    base = min(near, key=lambda e: abs(modulus - e))
    dec = decomposed[base]
    if base not in inverses:
        inverses[base] = scipy.linalg.lu_solve(dec.lu, np.eye(dec.lu[0].shape[0]),
                                               check_finite=False)
    return refined_stiffness(problem, static(), dec, inverses[base], compliance)


def decompose(problem: ContactProblem, sol: NewtonResult) -> Decomposition:
    """The :class:`Decomposition` of the static solution ``sol`` of ``problem``."""
    d1, active, area, d, kernel = _active(problem, sol)
    # D = W s on the nodes that carry a force derivative, and M' = q (A W⁻¹) q sign(D), built
    # in place in LAPACK's (Fortran) order so that eig overwrites it without a copy
    q = np.sqrt(np.abs(d))
    balanced = np.divide(kernel, area[None, :], order="F")
    balanced *= q[:, None]
    balanced *= np.copysign(q, d)[None, :]
    lam, vec = scipy.linalg.eig(balanced, overwrite_a=True, check_finite=False)
    # scipy returns real eigenvectors when every eigenvalue is real (a repulsive law: M' is
    # similar to a symmetric-definite matrix up to the kernel's small asymmetry); they stay real,
    # so that V's factors and every product with them run in real arithmetic (times)
    lu = scipy.linalg.lu_factor(vec, check_finite=False)
    return Decomposition(sol=sol, d1=d1, active=active, d=d, q=q,
                          lam=np.asarray(lam, dtype=complex), vec=vec, lu=lu,
                          unit_modes=lu_solve(lu, q))


def pairs(z: np.ndarray) -> np.ndarray:
    """A complex 1-D or 2-D array as real rows of interleaved (re, im) pairs (a view)."""
    z = np.ascontiguousarray(z, dtype=complex)
    return z.view(float).reshape(z.shape[0], -1)


def from_pairs(real: np.ndarray, rows: int, tail: tuple[int, ...]) -> np.ndarray:
    """The complex array of ``rows`` × ``tail`` whose (re, im) pairs are ``real``'s rows."""
    return np.ascontiguousarray(real).view(complex).reshape(rows, *tail)


def times(matrix: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``matrix @ z`` for a real matrix and complex 1-D or 2-D ``z``: one real product on pairs.

    NumPy would promote the real matrix to complex and multiply by its zero imaginary parts
    (4× the work); viewing z's columns as interleaved real pairs gives the same sums.
    """
    if np.iscomplexobj(matrix) or not np.iscomplexobj(z) or z.ndim > 2:
        return matrix @ z
    return from_pairs(matrix @ pairs(z), matrix.shape[0], z.shape[1:])


def lu_solve(lu: tuple[np.ndarray, np.ndarray], b: np.ndarray) -> np.ndarray:
    """``scipy.linalg.lu_solve`` with real factors: LAPACK directly (complex ``b`` as pairs)."""
    if np.iscomplexobj(lu[0]) or b.ndim > 2:
        return scipy.linalg.lu_solve(lu, b, check_finite=False)
    paired = np.iscomplexobj(b)  # real and imaginary parts: one real solve
    out, info = DGETRS(lu[0], lu[1], pairs(b) if paired else b)  # no lu_solve argument layer
    if info != 0:  # pragma: no cover - factors of a nonsingular V
        raise np.linalg.LinAlgError(f"LAPACK dgetrs reported illegal argument {-info}")
    return from_pairs(out, b.shape[0], b.shape[1:]) if paired else out


#: LAPACK's real LU solve (what scipy.linalg.lu_solve calls for float64 factors).
DGETRS = scipy.linalg.lapack.get_lapack_funcs("getrs", (np.empty((1, 1)),))


# ── the bounded cache of static states ───────────────────────────────────────────────────────────

class StateCache:
    """Least-recently-used map of static states by key (thread-safe), at most ``maxsize``.

    What it holds (a :class:`~viscoforce.experiments.linear_response.LinearizedState`, a
    :class:`Decomposition`, the finite-amplitude modes) is built from the key's static state.
    The key is everything the static state depends on: the sphere, the surface-force law, the
    grid (all frozen, hashable dataclasses), E_inf and the position or load. The material
    itself is not part of it, so varying τ or E0 reuses the state. A state holds O(N) numbers,
    not the problem or its influence matrix. Unhashable keys (a user's mutable law) bypass it.
    """

    def __init__(self, maxsize: int):
        self.maxsize = maxsize
        self._data: OrderedDict[tuple, Any] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0

    def get(self, key: tuple, build: Callable[[], Any]) -> Any:
        """The entry of ``key``, built by ``build()`` (and kept) when it is missing."""
        try:
            hash(key)
        except TypeError:  # a user's law or grid that is not hashable: no caching
            return build()
        with self._lock:
            if key in self._data:
                self._data.move_to_end(key)
                self.hits += 1
                return self._data[key]
            self.misses += 1
        state = build()  # outside the lock: two threads may build the same state once each
        with self._lock:
            self._data[key] = state
            self._data.move_to_end(key)
            while len(self._data) > self.maxsize:
                self._data.popitem(last=False)
        return state

    def clear(self) -> None:
        with self._lock:
            self._data.clear()
            self.hits = self.misses = 0

    def info(self) -> dict[str, int]:
        with self._lock:
            return {"hits": self.hits, "misses": self.misses, "maxsize": self.maxsize,
                    "currsize": len(self._data)}


#: The last few decompositions (O(N²) each), shared by the state and the finite-amplitude check.
DECOMPOSITIONS = StateCache(4)


def decomposition(problem: ContactProblem, position: float, modulus: float) -> Decomposition:
    """The cached :class:`Decomposition` of the static E_inf state at ``position``."""
    key = (problem.sphere, problem.surface_force, problem.grid, float(modulus), float(position))
    return DECOMPOSITIONS.get(key, lambda: decompose(
        problem, equilibrium_gap(problem, position, modulus)))
