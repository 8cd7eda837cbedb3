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


def log_slope(problem: ContactProblem, sol: NewtonResult, slope: FloatArray) -> FloatArray | None:
    """(ds/dE)/s on the ``active`` nodes: how the state's s = −p′(h) moves with E_inf [1/Pa].

    ds/dE = −p″(h) dh/dE along ``slope`` = dh/dE (:func:`~viscoforce.solvers.static.
    modulus_slope`), by a central difference of p′ along it with gap changes of 1e-5 of the
    smaller of the decay length and the least gap (the laws have no p″: truncation ≈ 1e-10
    relative). None when a node where s = 0 would start to carry a force derivative (a law
    with a cut-off: the modal form leaves those nodes out, so the caller differences k*). The
    active nodes are those of :func:`_active` (s ≠ 0).
    """
    law = problem.surface_force
    h = sol.gap
    s = -law.pressure_derivative(h)
    active = s != 0.0
    scale = float(np.abs(slope).max())
    if not scale > 0.0:
        return np.zeros(int(active.sum()))
    step = 1e-5 * min(float(law.decay_length), float(h.min())) / scale  # [Pa]
    ds = (law.pressure_derivative(h - step * slope)
          - law.pressure_derivative(h + step * slope)) / (2.0 * step)
    if np.any(ds[~active] != 0.0):
        return None
    return ds[active] / s[active]


def adjoint_matrix(dec: Decomposition, ratio: FloatArray) -> np.ndarray:
    """H with ∂k*/∂E_inf(c) = gᵀ H g, g = 1/(1 + cλ) (:func:`modal_sensitivities`).

    With x = (I + cM′)⁻¹ q = V (g ⊙ u), u = V⁻¹q, and y = (I + cM′)⁻ᵀ 2πl = V⁻ᵀ (g ⊙ v),
    v = 2πVᵀl, in the balanced form (M′ = q (A W⁻¹) q sign(D) = VΛV⁻¹, l = sign(D) q,
    :class:`Decomposition`; M′ = Q M Q⁻¹, so x_n y_n is the same product in M's coordinates),
    Σ_n r_n x_n y_n = Σ_ij g_i g_j u_i v_j (V⁻¹ diag(r) V)_ji: H_ij = u_i v_j (V⁻¹ r V)_ji,
    formed once per state (``ratio`` = r, :func:`log_slope`'s). Real when V is.
    """
    inverse = lu_solve(dec.lu, np.eye(dec.vec.shape[0]))
    toward = 2.0 * np.pi * (np.copysign(dec.q, dec.d) @ dec.vec)  # v = 2π Vᵀ l
    return dec.unit_modes[:, None] * (inverse @ (ratio[:, None] * dec.vec)).T * toward[None, :]


def modal_slope(dec: Decomposition, compliance: np.ndarray, adjoint: np.ndarray) -> np.ndarray:
    """∂k*/∂E_inf at fixed c [N/m/Pa] alone (:func:`modal_sensitivities`' third part)."""
    g = 1.0 / (1.0 + compliance[None, :] * dec.lam[:, None])
    return (g * times(adjoint, g)).sum(axis=0)


def modal_value(dec: Decomposition, compliance: np.ndarray,
                adjoint: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """k*(c) [N/m] and ∂k*/∂E_inf at fixed c [N/m/Pa]: :func:`modal_sensitivities` without dk*/dc.

    What a first-order step in E_inf needs for k* alone (a fit's best-fit curve).
    """
    beta = 2.0 * np.pi * (np.copysign(dec.q, dec.d) @ dec.vec) * dec.unit_modes
    g = 1.0 / (1.0 + compliance[None, :] * dec.lam[:, None])  # (modes, values)
    return beta @ g, (g * times(adjoint, g)).sum(axis=0)


def modal_sensitivities(dec: Decomposition, compliance: np.ndarray,
                        adjoint: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """k*(c) [N/m], dk*/dc [N/m · Pa] and ∂k*/∂E_inf at fixed c [N/m/Pa] from a decomposition.

    k* = Σ β_j g_j and dk*/dc = −Σ β_j λ_j g_j² (g = 1/(1 + cλ), β the modal weights); since
    only s = −p′(h) on the nodes moves with E_inf (M = A diag(s), w = 2π W s), the adjoint
    y = (I + cM)⁻ᵀ w turns dwᵀx − c yᵀ dM x (x = (I + cM)⁻¹ 1) into ∂k*/∂E =
    Σ_n (ds_n/dE / s_n) x_n y_n = gᵀ H g with ``adjoint`` = H (:func:`adjoint_matrix`): one
    N × N product with the values' columns. ``compliance`` is 1-D, checked by the caller.
    """
    beta = 2.0 * np.pi * (np.copysign(dec.q, dec.d) @ dec.vec) * dec.unit_modes
    g = 1.0 / (1.0 + compliance[None, :] * dec.lam[:, None])  # (modes, values)
    return beta @ g, -((beta * dec.lam) @ (g * g)), (g * times(adjoint, g)).sum(axis=0)


def direct_sensitivities(problem: ContactProblem, sol: NewtonResult, compliance: np.ndarray,
                         ratio: FloatArray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`modal_sensitivities` by direct solves (a few values, no decomposition).

    x = (I + cM)⁻¹ 1 and y = (I + cM)⁻ᵀ w per value: k* = wᵀx, dk*/dc = −yᵀ M x and
    ∂k*/∂E = Σ_n (ds_n/dE / s_n) x_n y_n.
    """
    _, _, area, d, kernel = _active(problem, sol)
    matrix = kernel * (d / area)[None, :]  # A·diag(s)
    n = matrix.shape[0]
    if not compliance.imag.any():  # an elastic c (the relaxed level): real solves, same sums
        k, dk_dc, dk_de = direct_sensitivities_real(matrix, d, compliance.real, ratio)
        return k.astype(complex), dk_dc.astype(complex), dk_de.astype(complex)
    systems = compliance[:, None, None] * matrix[None, :, :]
    systems[:, np.arange(n), np.arange(n)] += 1.0
    w = 2.0 * np.pi * d
    x = np.linalg.solve(systems, np.ones((compliance.size, n, 1), dtype=complex))[..., 0]
    y = np.linalg.solve(np.swapaxes(systems, 1, 2),
                        np.broadcast_to(w[None, :, None], (compliance.size, n, 1)))[..., 0]
    return x @ w, -np.einsum("vi,ij,vj->v", y, matrix, x), (x * y) @ ratio


def direct_sensitivities_real(matrix: FloatArray, d: FloatArray, compliance: FloatArray,
                              ratio: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """:func:`direct_sensitivities` for real c: M = ``matrix`` and D = ``d`` on the active nodes.

    One real LU per value, x and y from its two solves (plain and transposed).
    """
    n, w = matrix.shape[0], 2.0 * np.pi * d
    out = np.empty((3, compliance.size))
    for i, c in enumerate(compliance.tolist()):
        system = c * matrix
        system[np.arange(n), np.arange(n)] += 1.0
        lu, piv, info = DGETRF(system, overwrite_a=True)
        if info != 0:  # pragma: no cover - I + cM of a passive material is nonsingular
            raise np.linalg.LinAlgError(f"LAPACK dgetrf reported {info}")
        x, _ = DGETRS(lu, piv, np.ones(n))
        y, _ = DGETRS(lu, piv, w, trans=1)
        out[:, i] = x @ w, -(y @ (matrix @ x)), (x * y) @ ratio
    return out[0], out[1], out[2]


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


#: LAPACK's real LU factorisation and solve (what scipy.linalg.lu_factor/lu_solve call).
DGETRF, DGETRS = scipy.linalg.lapack.get_lapack_funcs(("getrf", "getrs"), (np.empty((1, 1)),))


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
