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

The decomposition and its cache live in :mod:`viscoforce.experiments._modal`, shared with the
finite-amplitude check (:mod:`viscoforce.experiments.finite_amplitude`) that
:func:`linear_response` runs.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from viscoforce._limits import MAX_SAMPLES, MEAN_FORCE_RANGE, check_effort
from viscoforce._typing import FloatArray
from viscoforce._validation import (
    require_finite,
    require_instance,
    require_plausible,
    require_positive,
)
from viscoforce.exceptions import ParameterError
from viscoforce.experiments._checks import require_frequencies, require_number, require_problem
from viscoforce.experiments._modal import (
    STATE_CACHE_SIZE,
    Decomposition,
    StateCache,
    decompose,
    decomposition,
)
from viscoforce.experiments._modulus_states import (
    _COUNTS,
    _FAMILIES,
    ModulusStates,
    _require_compliance,
    modulus_states,
)
from viscoforce.experiments.finite_amplitude import warn_large_eta
from viscoforce.physics.materials import ViscoelasticMaterial
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_spectrum
from viscoforce.solvers.static import equilibrium_at_load, equilibrium_gap

__all__ = ["LinearizedState", "ModulusStates", "linearized_state", "modulus_states",
           "linear_stiffness", "linear_response"]

#: Complex elements of one batch of the modal sum (≈ 64 MB).
_BATCH_ELEMENTS = 4_000_000
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
        return cls._from_decomposition(problem, position, modulus, decompose(
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
            ``load`` ≤ 0, not finite or outside :data:`~viscoforce._limits.MEAN_FORCE_RANGE`,
            or another argument out of range.
        ConvergenceError
            The load cannot be bracketed within the grid, or a static solve failed.
        """
        problem = require_problem(problem)
        modulus = _relaxed_modulus(problem, relaxed_modulus)
        position, sol = equilibrium_at_load(problem, _mean_force(load), modulus)
        return cls._from_decomposition(problem, position, modulus, decompose(problem, sol))

    @classmethod
    def _from_decomposition(cls, problem: ContactProblem, position: float, modulus: float,
                            dec: Decomposition) -> LinearizedState:
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
        return self._stiffness_checked(c.ravel()).reshape(c.shape)

    def _stiffness_checked(self, flat: np.ndarray) -> np.ndarray:
        """:meth:`stiffness` of 1-D compliances the caller has checked."""
        out = np.empty(flat.size, dtype=complex)
        chunk = max(1, _BATCH_ELEMENTS // max(1, self.modes))
        for start in range(0, flat.size, chunk):
            part = flat[start:start + chunk, None]
            out[start:start + chunk] = (self.weights / (1.0 + part * self.eigenvalues)).sum(axis=1)
        return out

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


#: The static states of :func:`linearized_state` (at most ``STATE_CACHE_SIZE``).
_STATES = StateCache(STATE_CACHE_SIZE)


def _mean_force(load: Any) -> float:
    """The mean force [N], > 0 and within :data:`~viscoforce._limits.MEAN_FORCE_RANGE`.

    A subnormal load (5e-320 N) made the load bracketing divide by zero.
    """
    value = require_number("load", load, require_positive, "> 0 [N] (finite; the mean force)")
    return require_plausible("load", value, MEAN_FORCE_RANGE, "N")


ModulusStates.state_type = LinearizedState  # the form its states are kept as (no import cycle)


def linearized_state(problem: ContactProblem, position: float | None = None,
                     relaxed_modulus: float | None = None, *,
                     load: float | None = None) -> LinearizedState:
    """The :class:`LinearizedState` at a position or a load, from a bounded cache.

    The last ``STATE_CACHE_SIZE`` (32) states are kept, keyed on (sphere, surface force, grid,
    E_inf, position or load), not on the material: a fit that varies τ or E0 at a fixed E_inf
    decomposes once. ``linearized_state.cache_info()`` reports hits, misses (with those of
    :func:`modulus_states`' static states) and size; ``linearized_state.cache_clear()`` empties
    both.

    Parameters
    ----------
    problem : ContactProblem
        System and grid.
    position : float, optional
        Mean position h̄0 [m]; give exactly one of ``position`` and ``load``.
    relaxed_modulus : float, optional
        E_inf [Pa], > 0; default the problem material's.
    load : float, optional
        Mean (static E_inf) force [N], > 0, within
        :data:`~viscoforce._limits.MEAN_FORCE_RANGE` (:meth:`LinearizedState.at_load`).

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
                problem, position, modulus, decomposition(problem, position, modulus))

        return _STATES.get((*base, "position", position), build)
    load = _mean_force(load)
    return _STATES.get((*base, "load", load),
                       lambda: LinearizedState.at_load(problem, load, modulus))


def _clear_states() -> None:
    """Empty the caches of :func:`linearized_state` and :func:`modulus_states`."""
    _STATES.clear()
    _FAMILIES.clear()
    _COUNTS.update(hits=0, misses=0)


def _cache_info() -> dict[str, int]:
    """The state caches' counts: :func:`linearized_state`'s plus the states of the families."""
    info = _STATES.info()
    return {**info, "hits": info["hits"] + _COUNTS["hits"],
            "misses": info["misses"] + _COUNTS["misses"]}


linearized_state.cache_info = _cache_info  # type: ignore[attr-defined]
linearized_state.cache_clear = _clear_states  # type: ignore[attr-defined]


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
        harmonic (:func:`~viscoforce.experiments.finite_amplitude.amplitude_bias`, η² |b(ω)|)
        exceeds 1 %.
    """
    problem = require_problem(problem)
    eta = require_number("eta", eta, require_positive, "> 0 [m] (finite)")
    omega = require_frequencies(omega, allow_zero=False)
    position = require_number("position", position, require_finite,
                              "finite [m] (h0, the undeformed apex separation)")
    k, mean = _linear_stiffness(problem, position, omega)
    warn_large_eta(problem, float(position), eta, omega)
    attrs = dict(problem.parameters())
    attrs.update({"method": "linear", "position": float(position), "eta": eta})
    return make_spectrum(omega, k, mean, eta, attrs=attrs, check=False)
