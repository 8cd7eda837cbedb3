"""The finite-amplitude check of a small-amplitude spectrum: the first harmonic's bias b(ω) η².

A sinusoidal drive of amplitude η measures the first harmonic k1(η) = k*(1 + b η² + O(η⁴)) of
a nonlinear force law, not the small-amplitude k*. :func:`amplitude_bias` computes b(ω) by
harmonic balance to third order about the static E_inf state (modal: one eigen-decomposition
per state, shared with :func:`~viscoforce.experiments.linear_response.linearized_state`, and
every frequency a column of the same products; cached per state, material and frequencies);
:func:`finite_amplitude_error` turns it into the relative error η² max|b| that
:func:`~viscoforce.experiments.linear_response.linear_response` warns about
(:func:`warn_large_eta`) and the model chooser (:mod:`viscoforce.experiments.choice`) weighs.
"""

from __future__ import annotations

import threading
import warnings
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from viscoforce._typing import FloatArray
from viscoforce.choice import WARN_ERROR, amplitude_error
from viscoforce.exceptions import ApproximationWarning, ConvergenceError, ParameterError
from viscoforce.experiments._modal import (
    STATE_CACHE_SIZE,
    StateCache,
    decomposition,
    lu_solve,
    times,
)
from viscoforce.physics.surface_forces import SumOfLaws
from viscoforce.problem import ContactProblem

__all__ = ["amplitude_bias", "bias_frequencies", "finite_amplitude_error", "warn_large_eta"]

#: Factor on the rigid finite-amplitude estimate 2I₁(κη)/κη − 1: the measured bias is up to
#: 2.4× it in contact (−5 nm, the soft wall); the pre-screen of :func:`warn_large_eta`.
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


def warn_large_eta(problem: ContactProblem, position: float, eta: float,
                   omega: np.ndarray) -> None:
    """Warn when ``eta`` is too large for a small-amplitude spectrum (bias above 1 %).

    Cheap pre-screen: 2.5 × the rigid estimate; if that exceeds 1 %, the harmonic-balance bias
    (:func:`amplitude_bias`) at the given frequencies decides. The warning points at the caller
    of the function that calls this one (``stacklevel=3``: the user's call of
    :func:`~viscoforce.experiments.linear_response.linear_response`).
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

    The nodes are ordered active first (s ≠ 0, as
    :class:`~viscoforce.experiments.linear_response.LinearizedState`), then inactive.
    With D = W s and the balanced M' = |D|^½ (A W⁻¹) |D|^½ sign(D) = V Λ V⁻¹ on the active
    nodes, every solve of the harmonic balance but the first, x = (I + cM)⁻¹ c A y for a nodal
    y, has modal coordinates z = c G y / (1 + cΛ) with G = V⁻¹ |D|^½ A_a: (V's LU solve done
    once, here), active part x_a = P z with P = |D|^-½ V, and inactive part
    x_i = c A_i: y − c A_ia s_a P z. The first order's right-hand side 1 has z = g / (1 + cΛ),
    g = V⁻¹ |D|^½ 1 (:attr:`~viscoforce.experiments._modal.Decomposition.unit_modes`). The load
    integral of p′x is ρ z with ρ = (L p′)_a P (p′ = 0 off the active nodes), so the third order
    is never formed at the nodes. Per frequency, each order is a column of one or two real matrix
    products.
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
        dec = decomposition(problem, position, e_inf)  # shared with linearized_state
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
        project = lu_solve(dec.lu, q[:, None] * a[:n_a])  # G
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
        x = times(self.expand, z)
        n_a = self.lam.size
        if x.shape[0] > n_a:  # inactive nodes: 1 − c A_ia s_a x_a
            x[n_a:] = 1.0 - c * x[n_a:]
        return x, z

    def solve(self, c: np.ndarray | float, y: np.ndarray) -> np.ndarray:
        """(I + cM)⁻¹ c A y at the ordered nodes (c: one value per column of y, or one for all)."""
        n_a = self.lam.size
        proj = times(self.project, y)
        x = times(self.expand, c * proj[:n_a] / (1.0 + self.lam[:, None] * c))
        if x.shape[0] > n_a:
            x[n_a:] = c * (proj[n_a:] - x[n_a:])
        return x

    def load_of_solve(self, c: np.ndarray, y: np.ndarray) -> np.ndarray:
        """L(p′x) for x = (I + cM)⁻¹ c A y: ρ z, without forming x."""
        n_a = self.lam.size
        z = c * times(self.project[:n_a], y) / (1.0 + self.lam[:, None] * c)
        return self.load_modes @ z


#: The finite-amplitude modes of a static state (at most ``STATE_CACHE_SIZE``).
_BIAS_MODES = StateCache(STATE_CACHE_SIZE)
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
    :func:`~viscoforce.experiments.linear_response.linearized_state`, keyed on sphere, law,
    grid, E_inf and position), and every frequency is a column of the same matrix products;
    the results are cached per (state, material, frequencies).

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
