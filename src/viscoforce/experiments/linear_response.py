"""Exact small-amplitude response in the frequency domain (beyond the paper).

Linearise the viscoelastic equations about the static E_inf equilibrium at h̄0. With the
e^{+iωt} convention, u(t) = −2∫C(t − t') A ṗ(t') dt' becomes δu = −2 C*(ω) A δp, and
δp = p'(h̄)(δh0 − δu), so that per unit drive

    (I − 2C*(ω) A p') δu = −2C*(ω) A p' δh0,         δF = 2π Σ_j W_j p'_j (δh0 − δu_j),

one complex linear solve per frequency for any Prony material. The complex stiffness per unit
compression (compression = −δh0) is k*(ω) = −δF/δh0; its argument is the phase χ by which the
force leads the compression (SPEC convention), and |k*| the stiffness |F1|/η.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from viscoforce._limits import MAX_SAMPLES, check_effort
from viscoforce._validation import require_finite, require_positive
from viscoforce.experiments._checks import require_frequencies, require_number, require_problem
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_spectrum
from viscoforce.solvers.static import equilibrium_gap

#: Complex matrix elements solved in one batch (≈ 64 MB).
_BATCH_ELEMENTS = 4_000_000


def linear_stiffness(problem: ContactProblem, position: float, omega: ArrayLike) -> tuple[
        np.ndarray, float]:
    """k*(ω) [N/m] about the static E_inf state at ``position`` [m], and its mean force [N].

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
    omega = require_frequencies(omega, allow_zero=True)
    check_effort(f"frequencies of linear_stiffness ({omega.size} requested)", omega.size,
                 MAX_SAMPLES, hint="request fewer frequencies")
    problem.check_covers(position)
    material = problem.material
    sol = equilibrium_gap(problem, position, material.relaxed_modulus)
    stiff = -problem.surface_force.pressure_derivative(sol.gap)  # −p′ (> 0 where repulsive)
    weights = 2.0 * np.pi * problem.grid.area_weights * stiff  # δF = −Σ weights (δh0 − δu)
    coupled = problem.influence * stiff[None, :]
    n = problem.grid.size
    compliance = 2.0 * np.asarray(material.complex_compliance(omega), dtype=complex)
    drive = coupled.sum(axis=1)
    k = np.empty(omega.size, dtype=complex)
    chunk = max(1, _BATCH_ELEMENTS // (n * n))  # bound the memory of the batched solve
    diag = np.arange(n)
    for start in range(0, omega.size, chunk):
        c = compliance[start:start + chunk]
        mats = c[:, None, None] * coupled[None, :, :]
        mats[:, diag, diag] += 1.0
        du = np.linalg.solve(mats, (c[:, None] * drive[None, :])[..., None])[..., 0]
        k[start:start + chunk] = (weights[None, :] * (1.0 - du)).sum(axis=1)  # −δF/δh0
    return k, float(problem.load(sol.pressure))


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
    """
    problem = require_problem(problem)
    eta = require_number("eta", eta, require_positive, "> 0 [m] (finite)")
    omega = require_frequencies(omega, allow_zero=True)
    k, mean = linear_stiffness(problem, position, omega)
    attrs = dict(problem.parameters())
    attrs.update({"method": "linear", "position": float(position), "eta": eta})
    return make_spectrum(omega, k, mean, eta, attrs=attrs)
