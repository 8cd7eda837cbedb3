"""Time-stepper contract and the state the steppers advance.

The viscoelastic deformation is written in the canonical creep Prony form of the material
(:mod:`viscoforce.physics.materials`): with q = A p the elastic response of the current pressure
(A the influence matrix, u = −2J·A p for an elastic body of compliance J),

    u = −c_g q + Σ_i w_i,          τ_i dw_i/dt = −w_i − c_i q,                         (†)

where c_g = 2/E0 (glassy) and c_i = 2ΔJ_i (mode i). This is the paper's Eqs. 3–12 in internal-
variable form: for one mode, w = u − u_∞ + … reproduces Eq. 5, and at rest every w_i = −c_i q so
that u = −(2/E_inf) A p exactly, the static E_inf equilibrium. The w_i (and u) are carried at the
grid nodes plus one extra entry for the centre r = 0.

Subclass contract (in the spirit of scipy's OdeSolver):

* implement :meth:`TimeStepper.step` ``(state, drive, dt) -> StepOutcome`` that advances ONE step
  from ``state.time`` to ``state.time + dt``; never loop over time (the only time loop is
  :func:`viscoforce.solvers.simulate.simulate`);
* set the class attributes ``name``, ``order`` (local error O(dt^{order+1})) and ``adaptive``
  (whether ``StepOutcome.error`` is a usable local-error estimate [m]);
* raise :class:`~viscoforce.exceptions.StabilityError` or
  :class:`~viscoforce.exceptions.GapClosureError` instead of returning a non-finite state;
* optionally carry :attr:`State.tangent` (forward sensitivities to the Prony data, used by fits:
  :func:`~viscoforce.solvers.simulate.simulate_force`); the exponential steppers do, explicit
  Euler returns states without it.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np
import scipy.linalg
import scipy.linalg.lapack

from viscoforce._typing import FloatArray, SeparationHistory
from viscoforce._validation import require_finite, require_instance, require_positive
from viscoforce.exceptions import ConvergenceError
from viscoforce.problem import ContactProblem
from viscoforce.solvers.static import equilibrium_gap


@dataclass(frozen=True)
class State:
    """Everything a stepper needs to continue from time ``time``.

    Attributes
    ----------
    time : float
        t [s].
    position : float
        h0(t) [m].
    gap : ndarray, shape (N,)
        Nodal gaps h [m].
    pressure : ndarray, shape (N,)
        p(h) [Pa].
    response : ndarray, shape (N + 1,)
        q = A p at the nodes and (last entry) at r = 0 [m·Pa].
    memory : ndarray, shape (n_modes, N + 1)
        Internal deformations w_i of (†) [m].
    deformation : ndarray, shape (N + 1,)
        u at the nodes and at r = 0 [m].
    history : tuple or None
        (time [s], response, gap) of the previous accepted state on the same smooth piece of the
        drive, for multi-point predictors and error estimates; None at the start and after a kink.
    tangent : Tangent or None
        Forward sensitivities of this state to the material's Prony data (steppers that support
        them carry it along; None: not tracked).
    """

    time: float
    position: float
    gap: FloatArray
    pressure: FloatArray
    response: FloatArray
    memory: FloatArray
    deformation: FloatArray
    history: tuple[float, FloatArray, FloatArray] | None = None
    tangent: Tangent | None = None

    def without_history(self) -> State:
        """The same state with the history forgotten (used at drive kinks)."""
        return replace(self, history=None)

    @property
    def u_center(self) -> float:
        """Central deformation u(0) [m]."""
        return float(self.deformation[-1])


@dataclass(frozen=True)
class Tangent:
    """Forward sensitivities of a :class:`State` to the material's Prony data.

    The k = 1 + 2m parameters, in this order, are ρ = (c_g, c_1 … c_m, ln τ_1 … ln τ_m): the
    glassy and mode compliances of (†) [1/Pa] and the log creep times. Each array holds
    ∂(quantity)/∂ρ_j along its first axis, along the same time steps as the state (the exact
    derivative of the discrete scheme, up to the Newton tolerance).

    Attributes
    ----------
    gap : ndarray, shape (k, N)
        ∂h/∂ρ [m per unit of ρ].
    pressure : ndarray, shape (k, N)
        ∂p/∂ρ [Pa per unit of ρ].
    response : ndarray, shape (k, N + 1)
        ∂q/∂ρ.
    memory : ndarray, shape (k, n_modes, N + 1)
        ∂w_i/∂ρ.
    """

    gap: FloatArray
    pressure: FloatArray
    response: FloatArray
    memory: FloatArray


@dataclass(frozen=True)
class StepOutcome:
    """Result of one step: the new state, a local error estimate [m] and Newton iterations."""

    state: State
    error: float
    iterations: int


class TimeStepper(ABC):
    """One-step method for (†); see the module docstring for the subclass contract.

    Parameters
    ----------
    problem : ContactProblem
        System, material and grid.
    """

    name: ClassVar[str]
    order: ClassVar[int]
    adaptive: ClassVar[bool]

    def __init__(self, problem: ContactProblem):
        self.problem = require_instance("problem", problem, ContactProblem)
        prony = problem.material.prony()
        self.c_glassy = 2.0 * prony.glassy_compliance
        self.c_modes = 2.0 * np.asarray(prony.delta_compliances, dtype=float)
        self.taus = np.asarray(prony.taus, dtype=float)
        self.influence_aug = np.vstack([problem.influence, problem.center_row[None, :]])
        self.xtol = 1e-6 * problem.surface_force.decay_length
        #: Optional Newton start by time, ``gap_guess(t) -> gaps or None`` (a fit passes the
        #: previous evaluation's solution moved along its sensitivities); None: the stepper's own.
        self.gap_guess: Callable[[float], FloatArray | None] | None = None
        #: Error tolerance [m] of the adaptive march: a step whose error estimate exceeds it will
        #: be rejected, so its sensitivities are not computed (inf: always computed).
        self.tangent_tol = math.inf

    def response(self, pressure: FloatArray) -> FloatArray:
        """Q = A p at the nodes and the centre [m·Pa]."""
        return self.influence_aug @ pressure

    @property
    def n_sensitivities(self) -> int:
        """Number k = 1 + 2m of the Prony data ρ = (c_g, c_i, ln τ_i) of :class:`Tangent`."""
        return 1 + 2 * self.c_modes.size

    def relaxed_state(self, time: float, position: float, *, tangent: bool = False) -> State:
        """Static E_inf equilibrium at ``position`` [m]: every mode at rest.

        ``tangent=True`` adds its sensitivities to the Prony data (:class:`Tangent`).
        """
        time = require_finite("time", time)
        position = require_finite("position (h0)", position)
        e_inf = self.problem.material.relaxed_modulus
        sol = equilibrium_gap(self.problem, position, e_inf)
        q = self.response(sol.pressure)
        memory = -self.c_modes[:, None] * q[None, :]
        deformation = -(2.0 / e_inf) * q
        sens = self._relaxed_tangent(sol.factor, sol.gap, q) if tangent else None
        return State(time, position, sol.gap, sol.pressure, q, memory, deformation,
                     tangent=sens)

    def _relaxed_tangent(self, factor: tuple, gap: FloatArray, q: FloatArray) -> Tangent:
        """Sensitivities of the E_inf equilibrium: (I − c_∞ A p′) ∂h = ∂c_∞ · A p, w_i = −c_i q."""
        m, n = self.c_modes.size, self.problem.grid.size
        d_modes = np.zeros((self.n_sensitivities, m))  # ∂c_i/∂ρ
        d_modes[1:1 + m] = np.eye(m)
        d_coupling = np.zeros(self.n_sensitivities)
        d_coupling[:1 + m] = 1.0  # c_∞ = c_g + Σ c_i
        dgap, pressure = self.solve_tangent(factor, gap, d_coupling[:, None] * q[None, :n])
        response = pressure @ self.influence_aug.T
        memory = (-d_modes[:, :, None] * q[None, None, :]
                  - self.c_modes[None, :, None] * response[:, None, :])
        return Tangent(dgap, pressure, response, memory)

    def solve_tangent(self, factor: tuple, gap: FloatArray, rhs: FloatArray
                      ) -> tuple[FloatArray, FloatArray]:
        """(∂h, ∂p = p′(h) ∂h) with (I − c A diag p′(h)) ∂h = rhs for each row of ``rhs`` (k, N).

        The linearisation of the equilibrium h = b + c A p(h) of :mod:`viscoforce.solvers.newton`
        at its solution ``gap``, by back-substitution with ``factor``, the LU factors of Newton's
        last Jacobian (``NewtonResult.factor``, taken within the Newton tolerance of ``gap``: the
        sensitivities are exact to that tolerance, ~1e-6 relative).
        """
        slope = self.problem.surface_force.pressure_derivative(gap)
        dgap, info = scipy.linalg.lapack.dgetrs(*factor, rhs.T)  # lu_solve without its wrapper
        if info != 0:
            raise ConvergenceError(f"sensitivity back-substitution failed (LAPACK info {info})")
        return dgap.T, slope[None, :] * dgap.T

    @abstractmethod
    def step(self, state: State, drive: SeparationHistory, dt: float) -> StepOutcome:
        """Advance ``state`` by ``dt`` [s] along ``drive``."""

    @staticmethod
    def check_step(state: State, drive: SeparationHistory, dt: float) -> float:
        """Validate ``state`` and ``dt`` of :meth:`step`; return ``dt`` [s] as a float > 0.

        The drive is not checked here (a protocol check costs ~20 µs a step): :func:`simulate`
        checks it once.
        """
        require_instance("state", state, State)
        return require_positive("dt", dt)
