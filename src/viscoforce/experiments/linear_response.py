"""Exact small-amplitude response in the frequency domain (beyond the paper).

Linearise the viscoelastic equations about the static E_inf equilibrium at h̄0. With the
e^{+iωt} convention, u(t) = −2∫C(t − t') A ṗ(t') dt' becomes δu = −2 C*(ω) A δp, and
δp = p'(h̄)(δh0 − δu), so that per unit drive

    (I − 2C*(ω) A p') δu = −2C*(ω) A p' δh0,         δF = 2π Σ_j W_j p'_j (δh0 − δu_j),

one complex linear system per frequency for any Prony material. The complex stiffness per unit
compression (compression = −δh0) is k*(ω) = −δF/δh0; its argument is the phase χ by which the
force leads the compression (SPEC convention), and |k*| the stiffness |F1|/η.

Modal form (:class:`LinearizedState`). Write c = 2C*(ω) (a complex scalar), s = −p'(h̄) and
M = A·diag(s), w = 2π W s. The system is (I + cM) δu = cM·1 per unit compression, so
1 − δu = (I + cM)⁻¹ 1 and

    k*(c) = wᵀ (I + cM)⁻¹ 1 = Σ_j β_j / (1 + c λ_j) = Σ_j w_j − c Σ_j α_j / (1 + c λ_j),

with M = V Λ V⁻¹, β_j = (wᵀV)_j (V⁻¹1)_j, Σ β_j = Σ w_j and α_j = β_j λ_j. The static state and
(λ, β) depend on the material only through E_inf, so one eigen-decomposition serves every
τ, E0 (and every frequency): O(N³) once, then O(N) per frequency.

Which eigensolver. A W⁻¹ (A divided by the area weights of its columns) would be symmetric for a
nodal quadrature of the symmetric kernel, and M would then be similar to a symmetric matrix.
The product-integration kernel is not: A W⁻¹ is asymmetric by 1.2e-3 of its largest entry
(measured on the default grid), and eigh of the symmetrised matrix errs by 4e-11 (h̄0 = 2 nm) to
1e-9 (−5 nm) in k*. So the general ``eig`` is used, on the diagonally balanced matrix
M' = |D|^{1/2} (A W⁻¹) |D|^{1/2} sign(D), D = W s, which is similar to M and nearly symmetric: its
eigenvectors are nearly orthogonal (condition number 1.2), and k* agrees with the direct solve to
1e-15. Nodes with s = 0 (no force derivative) contribute nothing and are left out.
"""

from __future__ import annotations

import threading
import warnings
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from viscoforce._limits import MAX_SAMPLES, check_effort
from viscoforce._typing import FloatArray
from viscoforce._validation import require_finite, require_instance, require_positive
from viscoforce.choice import WARN_ERROR, amplitude_error
from viscoforce.exceptions import ApproximationWarning, ConvergenceError, ParameterError
from viscoforce.experiments._checks import require_frequencies, require_number, require_problem
from viscoforce.physics.materials import ViscoelasticMaterial
from viscoforce.physics.surface_forces import SumOfLaws
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_spectrum
from viscoforce.solvers.newton import NewtonResult
from viscoforce.solvers.static import equilibrium_at_load, equilibrium_gap

__all__ = ["LinearizedState", "linearized_state", "linear_stiffness", "linear_response"]

#: Complex elements of one batch of the modal sum (≈ 64 MB).
_BATCH_ELEMENTS = 4_000_000
#: Most static states :func:`linearized_state` keeps.
STATE_CACHE_SIZE = 32
#: Relative mismatch of E_inf between a material and a state tolerated by ``stiffness_for``.
_MODULUS_RTOL = 1e-12


@dataclass(frozen=True, eq=False)
class LinearizedState:
    """The static E_inf state at h̄0 and the modes of its linearisation (module docstring).

    Build it with :meth:`at` (a position) or :meth:`at_load` (a mean force), or get a cached one
    from :func:`linearized_state`. It holds no reference to the problem; its arrays are
    read-only.

    Attributes
    ----------
    position : float
        Mean position h̄0 [m].
    relaxed_modulus : float
        E_inf [Pa] of the static state.
    mean_force : float
        Static load at ``position`` [N].
    gap : ndarray
        Static nodal gaps [m].
    eigenvalues : ndarray
        λ_j [Pa] of M = A·diag(−p') (complex dtype; real for the laws measured so far).
    weights : ndarray
        β_j [N/m], with k*(c) = Σ β_j / (1 + c λ_j).
    total_weight : float
        Σ_j w_j = 2π Σ W_j (−p'_j) [N/m]: k* of a rigid body (c = 0).
    """

    position: float
    relaxed_modulus: float
    mean_force: float
    gap: FloatArray
    eigenvalues: NDArray[np.complex128]
    weights: NDArray[np.complex128]
    total_weight: float

    @classmethod
    def at(cls, problem: ContactProblem, position: float,
           relaxed_modulus: float | None = None) -> LinearizedState:
        """Solve the static state at ``position`` and decompose its linearisation (no cache).

        Parameters
        ----------
        problem : ContactProblem
            System and grid (must reach ``position``); its material is not used.
        position : float
            Mean position h̄0 [m], finite.
        relaxed_modulus : float, optional
            E_inf [Pa], > 0; default the problem material's relaxed modulus.

        Returns
        -------
        LinearizedState

        Raises
        ------
        ParameterError
            If an argument is missing or out of range (the message names it and the range).
        ConvergenceError
            The static solve failed.
        """
        problem = require_problem(problem)
        position = require_number("position", position, require_finite,
                                  "finite [m] (h0, the undeformed apex separation)")
        modulus = _relaxed_modulus(problem, relaxed_modulus)
        problem.check_covers(position)
        return cls._from_decomposition(problem, position, modulus, _decompose(
            problem, equilibrium_gap(problem, position, modulus)))

    @classmethod
    def at_load(cls, problem: ContactProblem, load: float,
                relaxed_modulus: float | None = None) -> LinearizedState:
        """As :meth:`at`, at the position whose static E_inf load is ``load`` [N] (> 0).

        The position is found by :func:`~viscoforce.solvers.static.position_at_load`
        (to 1e-6 decay lengths); ``mean_force`` is the load there (≈ ``load``).

        Raises
        ------
        ParameterError
            ``load`` ≤ 0 or not finite, or another argument out of range.
        ConvergenceError
            The load cannot be bracketed within the grid, or a static solve failed.
        """
        problem = require_problem(problem)
        modulus = _relaxed_modulus(problem, relaxed_modulus)
        position, sol = equilibrium_at_load(problem, load, modulus)
        return cls._from_decomposition(problem, position, modulus, _decompose(problem, sol))

    @classmethod
    def _from_decomposition(cls, problem: ContactProblem, position: float, modulus: float,
                            dec: _Decomposition) -> LinearizedState:
        """The state of a decomposed linearisation: its modes and their load weights."""
        left = np.copysign(dec.q, dec.d)
        weights = 2.0 * np.pi * (left @ dec.vec) * dec.unit_modes  # real when V is
        gap = np.array(dec.sol.gap, dtype=float)
        gap.flags.writeable = False
        lam = np.array(dec.lam, dtype=complex)
        weights = np.asarray(weights, dtype=complex)
        lam.flags.writeable = False
        weights.flags.writeable = False
        return cls(position=float(position), relaxed_modulus=float(modulus),
                   mean_force=float(problem.load(dec.sol.pressure)), gap=gap, eigenvalues=lam,
                   weights=weights, total_weight=float(2.0 * np.pi * np.sum(dec.d)))

    @property
    def residues(self) -> NDArray[np.complex128]:
        """α_j = β_j λ_j [N/m · Pa]: k*(c) = Σ w − c Σ α_j / (1 + c λ_j)."""
        return self.weights * self.eigenvalues

    @property
    def modes(self) -> int:
        """Number of modes (the nodes with a nonzero force derivative)."""
        return int(self.eigenvalues.size)

    def stiffness(self, compliance: ArrayLike) -> np.ndarray:
        """k*(c) [N/m] for values c = 2C*(ω) [1/Pa] (twice the complex compliance).

        Parameters
        ----------
        compliance : array_like
            c = 2 C*(ω) [1/Pa], complex, finite, Re c > 0 (a passive material), any shape, at
            most :data:`viscoforce._limits.MAX_SAMPLES` values.

        Returns
        -------
        numpy.ndarray
            Complex stiffness per unit compression [N/m], shaped like ``compliance``.

        Raises
        ------
        ParameterError
            If ``compliance`` is not finite with a positive real part.
        EffortError
            If more than ``MAX_SAMPLES`` values are given (refused before computing).
        """
        c = _require_compliance(compliance)
        check_effort(f"compliance values of LinearizedState.stiffness ({c.size} given)", c.size,
                     MAX_SAMPLES, hint="give fewer values")
        flat = c.ravel()
        out = np.empty(flat.size, dtype=complex)
        chunk = max(1, _BATCH_ELEMENTS // max(1, self.modes))
        for start in range(0, flat.size, chunk):
            part = flat[start:start + chunk, None]
            out[start:start + chunk] = (self.weights / (1.0 + part * self.eigenvalues)).sum(axis=1)
        return out.reshape(c.shape)

    def stiffness_for(self, material: ViscoelasticMaterial, omega: ArrayLike) -> np.ndarray:
        """k*(ω) [N/m] of ``material`` at angular frequencies ``omega`` [rad/s].

        Parameters
        ----------
        material : ViscoelasticMaterial
            Any Prony material whose relaxed modulus is this state's (to 1e-12 relative): the
            state is the static equilibrium for E_inf only.
        omega : array_like
            Angular frequencies [rad/s], ≥ 0, 1-D, at most ``MAX_SAMPLES``.

        Returns
        -------
        numpy.ndarray
            Complex stiffness per unit compression [N/m], shaped like ``omega``.

        Raises
        ------
        ParameterError
            Bad ``omega``, a non-material, or a material with a different E_inf.
        EffortError
            If more than ``MAX_SAMPLES`` frequencies are requested (refused before computing).
        """
        require_instance("material", material, ViscoelasticMaterial)
        omega = require_frequencies(omega, allow_zero=True)
        check_effort(f"frequencies of LinearizedState.stiffness_for ({omega.size} requested)",
                     omega.size, MAX_SAMPLES, hint="request fewer frequencies")
        e_inf = material.relaxed_modulus
        if abs(e_inf - self.relaxed_modulus) > _MODULUS_RTOL * self.relaxed_modulus:
            raise ParameterError(
                f"material relaxed modulus E_inf = {e_inf:.6g} Pa differs from the state's "
                f"{self.relaxed_modulus:.6g} Pa: the state is the static equilibrium for its "
                "E_inf only; build one for this material (linearized_state(problem, position, "
                "material.relaxed_modulus))")
        return self._stiffness_of(material, omega)

    def _stiffness_of(self, material: ViscoelasticMaterial, omega: FloatArray) -> np.ndarray:
        """:meth:`stiffness_for` of a material and frequencies the caller has checked."""
        return self.stiffness(2.0 * np.asarray(material.complex_compliance(omega), dtype=complex))


def _relaxed_modulus(problem: ContactProblem, relaxed_modulus: Any) -> float:
    """``relaxed_modulus`` checked (> 0 [Pa]), or the problem material's E_inf if None."""
    if relaxed_modulus is None:
        return float(problem.material.relaxed_modulus)
    return require_number("relaxed_modulus", relaxed_modulus, require_positive,
                          "> 0 [Pa] (finite; E_inf of the static state)")


def _require_compliance(compliance: Any) -> NDArray[np.complex128]:
    """``compliance`` as a finite complex array with Re > 0, else ParameterError."""
    allowed = "finite complex values 2C*(ω) [1/Pa] with real part > 0"
    try:
        c = np.asarray(compliance, dtype=complex)
    except (TypeError, ValueError):
        raise ParameterError(f"compliance must be {allowed}, got {compliance!r:.80}") from None
    if c.size == 0:
        raise ParameterError(f"compliance must be {allowed} (at least one), got an empty array")
    bad = ~(np.isfinite(c) & (c.real > 0))
    if np.any(bad):
        i = int(np.flatnonzero(bad.ravel())[0])
        raise ParameterError(f"compliance must be {allowed}; entry {i} is {c.ravel()[i]!r}")
    return c


@dataclass(frozen=True)
class _Decomposition:
    """A static solution and the eigen-decomposition of its balanced linearisation.

    On the nodes where s = −p′ ≠ 0 (``active``), D = W s (``d``), q = |D|^½ and
    M' = q (A W⁻¹) q sign(D) = V Λ V⁻¹ (``lam``, ``vec``): what :class:`LinearizedState`
    (the modal stiffness) and :class:`_BiasModes` (the finite-amplitude check) both need, so a
    cold :func:`linear_response` solves and decomposes once.
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


def _decompose(problem: ContactProblem, sol: NewtonResult) -> _Decomposition:
    d1 = problem.surface_force.pressure_derivative(sol.gap)
    stiff = -d1  # s = −p′ (> 0 where repulsive)
    area = problem.grid.area_weights
    active = np.flatnonzero(stiff != 0.0)
    if active.size == stiff.size:  # every node (the paper's law): no copies by index
        d, kernel = area * stiff, problem.influence
    else:
        area = area[active]
        d, kernel = area * stiff[active], problem.influence[np.ix_(active, active)]
    # D = W s on the nodes that carry a force derivative, and M' = q (A W⁻¹) q sign(D), built
    # in place in LAPACK's (Fortran) order so that eig overwrites it without a copy
    q = np.sqrt(np.abs(d))
    balanced = np.divide(kernel, area[None, :], order="F")
    balanced *= q[:, None]
    balanced *= np.copysign(q, d)[None, :]
    lam, vec = scipy.linalg.eig(balanced, overwrite_a=True, check_finite=False)
    # scipy returns real eigenvectors when every eigenvalue is real (a repulsive law: M' is
    # similar to a symmetric-definite matrix up to the kernel's small asymmetry); they stay real,
    # so that V's factors and every product with them run in real arithmetic (_times)
    lu = scipy.linalg.lu_factor(vec, check_finite=False)
    return _Decomposition(sol=sol, d1=d1, active=active, d=d, q=q,
                          lam=np.asarray(lam, dtype=complex), vec=vec, lu=lu,
                          unit_modes=_lu_solve(lu, q))


def _pairs(z: np.ndarray) -> np.ndarray:
    """A complex 1-D or 2-D array as real rows of interleaved (re, im) pairs (a view)."""
    z = np.ascontiguousarray(z, dtype=complex)
    return z.view(float).reshape(z.shape[0], -1)


def _from_pairs(pairs: np.ndarray, rows: int, tail: tuple[int, ...]) -> np.ndarray:
    """The complex array of ``rows`` × ``tail`` whose (re, im) pairs are ``pairs``' rows."""
    return np.ascontiguousarray(pairs).view(complex).reshape(rows, *tail)


def _times(matrix: np.ndarray, z: np.ndarray) -> np.ndarray:
    """``matrix @ z`` for a real matrix and complex 1-D or 2-D ``z``: one real product on pairs.

    NumPy would promote the real matrix to complex and multiply by its zero imaginary parts
    (4× the work); viewing z's columns as interleaved real pairs gives the same sums.
    """
    if np.iscomplexobj(matrix) or not np.iscomplexobj(z) or z.ndim > 2:
        return matrix @ z
    return _from_pairs(matrix @ _pairs(z), matrix.shape[0], z.shape[1:])


def _lu_solve(lu: tuple[np.ndarray, np.ndarray], b: np.ndarray) -> np.ndarray:
    """``scipy.linalg.lu_solve`` with real factors: LAPACK directly (complex ``b`` as pairs)."""
    if np.iscomplexobj(lu[0]) or b.ndim > 2:
        return scipy.linalg.lu_solve(lu, b, check_finite=False)
    pairs = np.iscomplexobj(b)  # real and imaginary parts: one real solve
    out, info = _DGETRS(lu[0], lu[1], _pairs(b) if pairs else b)  # no lu_solve argument layer
    if info != 0:  # pragma: no cover - factors of a nonsingular V
        raise np.linalg.LinAlgError(f"LAPACK dgetrs reported illegal argument {-info}")
    return _from_pairs(out, b.shape[0], b.shape[1:]) if pairs else out


#: LAPACK's real LU solve (what scipy.linalg.lu_solve calls for float64 factors).
_DGETRS = scipy.linalg.lapack.get_lapack_funcs("getrs", (np.empty((1, 1)),))


# ── the bounded cache of static states ───────────────────────────────────────────────────────────

class _StateCache:
    """Least-recently-used map of :class:`LinearizedState` by static-state key (thread-safe).

    The key is everything the static state depends on: the sphere, the surface-force law, the
    grid (all frozen, hashable dataclasses), E_inf and the position or load. The material
    itself is not part of it, so varying τ or E0 reuses the state. A state holds O(N) numbers,
    not the problem or its influence matrix. Unhashable keys (a user's mutable law) bypass it.
    """

    def __init__(self, maxsize: int):
        self.maxsize = maxsize
        self._data: OrderedDict[tuple, LinearizedState] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0

    def get(self, key: tuple, build) -> LinearizedState:
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


_STATES = _StateCache(STATE_CACHE_SIZE)
#: The last few decompositions (O(N²) each), shared by the state and the finite-amplitude check.
_DECOMPOSITIONS = _StateCache(4)


def _decomposition(problem: ContactProblem, position: float, modulus: float) -> _Decomposition:
    """The cached :class:`_Decomposition` of the static E_inf state at ``position``."""
    key = (problem.sphere, problem.surface_force, problem.grid, float(modulus), float(position))
    return _DECOMPOSITIONS.get(key, lambda: _decompose(
        problem, equilibrium_gap(problem, position, modulus)))


def linearized_state(problem: ContactProblem, position: float | None = None,
                     relaxed_modulus: float | None = None, *,
                     load: float | None = None) -> LinearizedState:
    """The :class:`LinearizedState` at a position or a load, from a bounded cache.

    The last ``STATE_CACHE_SIZE`` (32) states are kept, keyed on (sphere, surface force, grid,
    E_inf, position or load), not on the material: a fit that varies τ or E0 at a fixed E_inf
    decomposes once. ``linearized_state.cache_info()`` reports hits, misses and size;
    ``linearized_state.cache_clear()`` empties it.

    Parameters
    ----------
    problem : ContactProblem
        System and grid.
    position : float, optional
        Mean position h̄0 [m]; give exactly one of ``position`` and ``load``.
    relaxed_modulus : float, optional
        E_inf [Pa], > 0; default the problem material's.
    load : float, optional
        Mean (static E_inf) force [N], > 0 (:meth:`LinearizedState.at_load`).

    Returns
    -------
    LinearizedState

    Raises
    ------
    ParameterError
        Neither or both of ``position`` and ``load``, or an argument out of range.
    ConvergenceError
        The static solve (or the load bracketing) failed.
    """
    problem = require_problem(problem)
    if (position is None) == (load is None):
        raise ParameterError("give exactly one of position [m] and load [N] (mean force), got "
                             f"position={position!r}, load={load!r}")
    modulus = _relaxed_modulus(problem, relaxed_modulus)
    base = (problem.sphere, problem.surface_force, problem.grid, modulus)
    if load is None:
        position = require_number("position", position, require_finite,
                                  "finite [m] (h0, the undeformed apex separation)")
        def build() -> LinearizedState:
            problem.check_covers(position)
            return LinearizedState._from_decomposition(
                problem, position, modulus, _decomposition(problem, position, modulus))

        return _STATES.get((*base, "position", position), build)
    load = require_number("load", load, require_positive, "> 0 [N] (finite; the mean force)")
    return _STATES.get((*base, "load", load),
                       lambda: LinearizedState.at_load(problem, load, modulus))


linearized_state.cache_info = _STATES.info  # type: ignore[attr-defined]
linearized_state.cache_clear = _STATES.clear  # type: ignore[attr-defined]


def linear_stiffness(problem: ContactProblem, position: float, omega: ArrayLike) -> tuple[
        np.ndarray, float]:
    """k*(ω) [N/m] about the static E_inf state at ``position`` [m], and its mean force [N].

    Evaluated through the cached :func:`linearized_state` (one eigen-decomposition per static
    state, then O(N) per frequency); equal to the direct complex solve per frequency to ≈ 1e-15.

    Parameters
    ----------
    problem : ContactProblem
        System, any Prony material, grid (must reach ``position``).
    position : float
        Mean position h̄0 [m].
    omega : array_like
        Angular frequencies [rad/s], ≥ 0, at most :data:`viscoforce._limits.MAX_SAMPLES`.

    Returns
    -------
    k : numpy.ndarray
        Complex stiffness k* = F̂/D̂ per unit compression [N/m], shaped like ``omega``.
    mean_force : float
        Static E_inf load at ``position`` [N].

    Raises
    ------
    ParameterError
        If an argument is missing or out of range (the message names it and the range).
    EffortError
        If more than ``MAX_SAMPLES`` frequencies are requested (refused before solving).
    """
    problem = require_problem(problem)
    position = require_number("position", position, require_finite,
                              "finite [m] (h0, the undeformed apex separation)")
    return _linear_stiffness(problem, position, require_frequencies(omega, allow_zero=True))


def _linear_stiffness(problem: ContactProblem, position: float, omega: FloatArray) -> tuple[
        np.ndarray, float]:
    """:func:`linear_stiffness` of a checked problem, position [m] and frequencies [rad/s]."""
    check_effort(f"frequencies of linear_stiffness ({omega.size} requested)", omega.size,
                 MAX_SAMPLES, hint="request fewer frequencies")
    material = problem.material
    state = linearized_state(problem, position, material.relaxed_modulus)
    # the problem's own material, the state built for its E_inf: stiffness_for's checks hold
    return state._stiffness_of(material, omega), state.mean_force


def linear_response(problem: ContactProblem, position: float, eta: float,
                    omega: ArrayLike) -> xr.Dataset:
    """Spectrum of the exact small-amplitude response (dim ``omega``).

    Parameters
    ----------
    problem : ContactProblem
        System and grid.
    position : float
        Mean position h̄0 [m].
    eta : float
        Drive amplitude η [m], > 0 (only scales ``force_amplitude`` and ``amplitude``).
    omega : array_like
        Angular frequencies [rad/s], ≥ 0.

    Returns
    -------
    xarray.Dataset
        Spectrum (see :mod:`viscoforce.schema`) with ``method = "linear"``.

    Raises
    ------
    ParameterError
        If an argument is missing or out of range (the message names it and the range).
    EffortError
        If more than ``MAX_SAMPLES`` frequencies are requested (refused before solving).

    Warns
    -----
    ModelValidityWarning
        If η is too large for the small-amplitude limit: the bias of the finite drive's first
        harmonic (:func:`amplitude_bias`, η² |b(ω)|) exceeds 1 %.
    """
    problem = require_problem(problem)
    eta = require_number("eta", eta, require_positive, "> 0 [m] (finite)")
    omega = require_frequencies(omega, allow_zero=False)
    position = require_number("position", position, require_finite,
                              "finite [m] (h0, the undeformed apex separation)")
    k, mean = _linear_stiffness(problem, position, omega)
    _warn_large_eta(problem, float(position), eta, omega)
    attrs = dict(problem.parameters())
    attrs.update({"method": "linear", "position": float(position), "eta": eta})
    return make_spectrum(omega, k, mean, eta, attrs=attrs, check=False)


#: Factor on the rigid finite-amplitude estimate 2I₁(κη)/κη − 1: the measured bias is up to
#: 2.4× it in contact (−5 nm, the soft wall); the pre-screen of :func:`linear_response`'s warning.
AMPLITUDE_SAFETY = 2.5
#: Step of the finite differences of p′ (× the shortest decay length of the law).
FD_STEP = 1e-3
#: Frequencies at which the bias is solved (a subsample of longer lists).
MAX_BIAS_FREQUENCIES = 32


def bias_frequencies(omega: ArrayLike) -> np.ndarray:
    """At most :data:`MAX_BIAS_FREQUENCIES` of ``omega`` [rad/s] (sorted, both ends kept)."""
    omega = np.sort(np.asarray(omega, dtype=float))
    if omega.size <= MAX_BIAS_FREQUENCIES:
        return omega
    pick = np.unique(np.linspace(0, omega.size - 1, MAX_BIAS_FREQUENCIES).round().astype(int))
    return omega[pick]


def _warn_large_eta(problem: ContactProblem, position: float, eta: float,
                    omega: np.ndarray) -> None:
    """Warn when ``eta`` is too large for a small-amplitude spectrum (bias above 1 %).

    Cheap pre-screen: 2.5 × the rigid estimate; if that exceeds 1 %, the harmonic-balance bias
    (:func:`amplitude_bias`) at the given frequencies decides.
    """
    decay = problem.surface_force.decay_length
    if AMPLITUDE_SAFETY * amplitude_error(eta, decay) <= WARN_ERROR:
        return
    error, harmonic = finite_amplitude_error(problem, position, eta, omega)
    how = "third-order harmonic balance" if harmonic else "2.5 x rigid exponential"
    if error > WARN_ERROR:
        warnings.warn(
            f"kappa*eta = {eta / decay:.3g}: the finite-amplitude first harmonic differs from "
            f"the small-amplitude spectrum by ~{100 * error:.2g} % (estimate: {how}, the "
            "leading term, an overestimate at kappa*eta ~ 1); use method 'time-domain' or a "
            "smaller eta", ApproximationWarning, stacklevel=3)


def finite_amplitude_error(problem: ContactProblem, position: float, eta: float,
                           omega: ArrayLike) -> tuple[float, bool]:
    """η² max |b(ω)| of :func:`amplitude_bias` (True), or 2.5 × the rigid estimate (False).

    The rigid fallback is taken when the harmonic balance cannot be solved (no static state, a
    singular system); the flag says which estimate it is.
    """
    try:
        bias = float(np.max(np.abs(amplitude_bias(problem, position, bias_frequencies(omega)))))
    except (ConvergenceError, ParameterError, np.linalg.LinAlgError):
        decay = problem.surface_force.decay_length
        return AMPLITUDE_SAFETY * amplitude_error(eta, decay), False
    return bias * eta * eta, True


def _pressure_derivatives(problem: ContactProblem, gap: np.ndarray, d0: np.ndarray | None = None
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """p′, p″, p‴ at the nodal gaps (p″, p‴ by central differences of p′; ``d0``: p′ if known)."""
    law = problem.surface_force
    terms = law.terms if isinstance(law, SumOfLaws) else (law,)
    step = FD_STEP * min(t.decay_length for t in terms)
    d0 = law.pressure_derivative(gap) if d0 is None else d0
    up, down = law.pressure_derivative(gap + step), law.pressure_derivative(gap - step)
    return d0, (up - down) / (2.0 * step), (up - 2.0 * d0 + down) / (step * step)


@dataclass(frozen=True, eq=False)
class _BiasModes:
    """The static E_inf state of :func:`amplitude_bias` and the modes of M = A·diag(s), s = −p′.

    The nodes are ordered active first (s ≠ 0, as :class:`LinearizedState`), then inactive.
    With D = W s and the balanced M' = |D|^½ (A W⁻¹) |D|^½ sign(D) = V Λ V⁻¹ on the active
    nodes, every solve of the harmonic balance but the first, x = (I + cM)⁻¹ c A y for a nodal
    y, has modal coordinates z = c G y / (1 + cΛ) with G = V⁻¹ |D|^½ A_a: (V's LU solve done
    once, here), active part x_a = P z with P = |D|^-½ V, and inactive part
    x_i = c A_i: y − c A_ia s_a P z. The first order's right-hand side 1 has z = g / (1 + cΛ),
    g = V⁻¹ |D|^½ 1 (:attr:`_Decomposition.unit_modes`). The load integral of p′x is ρ z with
    ρ = (L p′)_a P (p′ = 0 off the active nodes), so the third order is never formed at the
    nodes. Per frequency, each order is a column of one or two real matrix products.
    """

    #: p′, p″, p‴ [Pa/m, Pa/m², Pa/m³] at the ordered nodes.
    d1: FloatArray
    d2: FloatArray
    d3: FloatArray
    #: Load weights 2π W [m²] at the ordered nodes.
    load_weights: FloatArray
    #: Λ [Pa]: real when V is.
    lam: NDArray[np.complex128] | FloatArray
    #: g = V⁻¹ |D|^½ 1.
    unit_modes: NDArray[np.complex128] | FloatArray
    #: Rows G, then A_i: (columns in node order): c times it gives z and the inactive c A y.
    project: NDArray[np.complex128] | FloatArray
    #: Rows P, then A_ia s_a P: x_a and the coupling of the inactive nodes, from z.
    expand: NDArray[np.complex128] | FloatArray
    #: ρ = (L p′)_a P: the load integral of p′x from z.
    load_modes: NDArray[np.complex128] | FloatArray

    @classmethod
    def build(cls, problem: ContactProblem, position: float, e_inf: float) -> _BiasModes:
        dec = _decomposition(problem, position, e_inf)  # shared with linearized_state
        d1, d2, d3 = _pressure_derivatives(problem, dec.sol.gap, dec.d1)
        active, q, vec = dec.active, dec.q, dec.vec
        inactive = np.flatnonzero(d1 == 0.0)
        load_weights = 2.0 * np.pi * np.asarray(problem.grid.area_weights, dtype=float)
        if inactive.size:  # active nodes first
            order = np.concatenate([active, inactive])
            a = problem.influence[np.ix_(order, order)]
            d1, d2, d3, load_weights = d1[order], d2[order], d3[order], load_weights[order]
        else:
            a = problem.influence
        n_a = active.size
        left = vec / q[:, None]  # P
        project = _lu_solve(dec.lu, q[:, None] * a[:n_a])  # G
        expand = left
        if inactive.size:
            project = np.concatenate([project, a[n_a:]])
            expand = np.concatenate([left, (a[n_a:, :n_a] * (-d1[:n_a])[None, :]) @ left])
        lam = dec.lam if np.iscomplexobj(vec) else dec.lam.real
        return cls(d1=d1, d2=d2, d3=d3, load_weights=load_weights, lam=lam,
                   unit_modes=dec.unit_modes, project=project, expand=expand,
                   load_modes=(load_weights[:n_a] * d1[:n_a]) @ left)

    def first_order(self, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """ĥ1 = (I + cM)⁻¹ 1 at the ordered nodes (one column per value c) and its modes z."""
        z = self.unit_modes[:, None] / (1.0 + self.lam[:, None] * c)
        x = _times(self.expand, z)
        n_a = self.lam.size
        if x.shape[0] > n_a:  # inactive nodes: 1 − c A_ia s_a x_a
            x[n_a:] = 1.0 - c * x[n_a:]
        return x, z

    def solve(self, c: np.ndarray | float, y: np.ndarray) -> np.ndarray:
        """(I + cM)⁻¹ c A y at the ordered nodes (c: one value per column of y, or one for all)."""
        n_a = self.lam.size
        proj = _times(self.project, y)
        x = _times(self.expand, c * proj[:n_a] / (1.0 + self.lam[:, None] * c))
        if x.shape[0] > n_a:
            x[n_a:] = c * (proj[n_a:] - x[n_a:])
        return x

    def load_of_solve(self, c: np.ndarray, y: np.ndarray) -> np.ndarray:
        """L(p′x) for x = (I + cM)⁻¹ c A y: ρ z, without forming x."""
        n_a = self.lam.size
        z = c * _times(self.project[:n_a], y) / (1.0 + self.lam[:, None] * c)
        return self.load_modes @ z


_BIAS_MODES = _StateCache(STATE_CACHE_SIZE)
#: Most finite-amplitude results kept, by (state, material, frequencies).
BIAS_CACHE_SIZE = 256
_BIAS_RESULTS: OrderedDict[tuple, np.ndarray] = OrderedDict()
_BIAS_LOCK = threading.Lock()


def amplitude_bias(problem: ContactProblem, position: float, omega: ArrayLike) -> np.ndarray:
    """Leading finite-amplitude correction of the first-harmonic stiffness: k1(η) = k*(1 + b η²).

    Harmonic balance to third order in the drive about the static E_inf state at h̄0, on the
    nodes: the gap obeys h = h0(r) + D(t) + 2C*A p(h) (D the drive), so with
    M(ν) = I − 2C*(ν) A diag(p′) the first order is ĥ1 = M(ω)⁻¹·1; the second order at 0 and 2ω,
    M(ν) ĥ2(ν) = 2C*(ν) A p″ q(ν) with q(0) = |ĥ1|²/4, q(2ω) = ĥ1²/4 (the ν = 0 term, with the
    relaxed compliance, is the rectified mean state); the third order at ω,
    q̂3 = p″(ĥ1 ĥ2(0) + ĥ1* ĥ2(2ω)/2) + p‴|ĥ1|²ĥ1/8 and M(ω) ĥ3 = 2C*(ω) A q̂3. Then
    b = L(p′ĥ3 + q̂3)/L(p′ĥ1), L the load integral. For a rigid exponential force b = κ²/8.
    Exact in the limit of small η (error O(η⁴)).

    Modal: the state and one eigen-decomposition of its linearisation are cached (like
    :func:`linearized_state`, keyed on sphere, law, grid, E_inf and position), and every
    frequency is a column of the same matrix products; the results are cached per (state,
    material, frequencies).

    Returns
    -------
    numpy.ndarray
        b(ω) [1/m²], complex, one per frequency.
    """
    material = problem.material
    e_inf = material.relaxed_modulus
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    key = (problem.sphere, problem.surface_force, problem.grid, float(e_inf), float(position))
    try:
        result_key: tuple | None = (*key, material, w.tobytes())
        hash(result_key)
    except TypeError:
        result_key = None
    if result_key is not None:
        with _BIAS_LOCK:
            if result_key in _BIAS_RESULTS:
                _BIAS_RESULTS.move_to_end(result_key)
                return _BIAS_RESULTS[result_key].copy()
    modes = _BIAS_MODES.get(key, lambda: _BiasModes.build(problem, position, e_inf))
    f = w.size
    compliance = np.asarray(material.complex_compliance(np.concatenate([w, 2.0 * w])),
                            dtype=complex)
    c_w, c_2w = 2.0 * compliance[:f], 2.0 * compliance[f:]
    # p″/4 and p‴/8 as columns: scaling by a power of 2 is exact, so folding it into them
    # changes no value and spares an operation on each (node × frequency) array
    d2, d2_4, d3_8 = modes.d2[:, None], modes.d2[:, None] / 4.0, modes.d3[:, None] / 8.0
    h1, z1 = modes.first_order(c_w)
    mag2 = np.abs(h1) ** 2
    h2_0 = modes.solve(2.0 / e_inf, d2_4 * mag2)  # real: the relaxed compliance
    h2_2 = modes.solve(c_2w, d2_4 * h1 ** 2)
    q3 = d2 * (h1 * h2_0 + np.conj(h1) * h2_2 / 2.0) + d3_8 * mag2 * h1
    out = (modes.load_of_solve(c_w, q3) + modes.load_weights @ q3) / (modes.load_modes @ z1)
    if result_key is not None:
        with _BIAS_LOCK:
            _BIAS_RESULTS[result_key] = out.copy()
            while len(_BIAS_RESULTS) > BIAS_CACHE_SIZE:
                _BIAS_RESULTS.popitem(last=False)
    return out
