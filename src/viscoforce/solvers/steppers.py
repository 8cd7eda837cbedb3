"""Concrete time steppers for the viscoelastic dynamics (see :mod:`viscoforce.solvers.base`).

* :class:`ExponentialTrapezoidal` (``"exponential"``, the default): the memory equations
  τ_i dw_i/dt = −w_i − c_i q are integrated EXACTLY for a forcing q(t) that varies linearly over the
  step, and the instantaneous part is implicit: the new gap solves the static-like equation
  h = b + c_eff·A p(h) by Newton (the same solver as the statics). Second order, unconditionally
  stable, exact for stiff modes (dt ≫ τ_i gives w_i = −c_i q) and therefore exactly the static E_inf
  equilibrium at rest, for any number of modes. Its local error is estimated from the second
  difference of q, which drives the adaptive step control in :func:`~viscoforce.solvers.simulate.simulate`.
* :class:`ExponentialEuler` (``"exponential-euler"``): the same with a forcing held at its new value
  (first order, L-stable); kept to measure orders against.
* :class:`ExplicitEuler` (``"euler"``): the paper's scheme — solve the linear integral equation for
  u̇ at the current state (Eqs. 5, 7, 12) and step u += dt·u̇. First order and only conditionally
  stable: dt·(E0/E_inf)/τ < 2 in contact. Kept for comparison. Multi-mode: the last mode's memory is
  recomputed from u at every step (w_n = u + c_g q − Σ_{i<n} w_i), so that the modes cannot drift
  away from u and the relaxed state is the static E_inf equilibrium (stepping each mode of Eq. 12
  independently lets that error accumulate).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import scipy.linalg

from viscoforce._typing import FloatArray, SeparationHistory
from viscoforce.exceptions import GapClosureError, StabilityError
from viscoforce.solvers.base import State, StepOutcome, Tangent, TimeStepper
from viscoforce.solvers.newton import solve_gap


def _phi(x: FloatArray) -> FloatArray:
    """φ(x) = (1 − e^{−x})/x, accurate for small x."""
    return np.where(x > 1e-300, -np.expm1(-x) / np.where(x > 1e-300, x, 1.0), 1.0)


def _dphi(x: FloatArray) -> FloatArray:
    """φ′(x) = ((1 + x) e^{−x} − 1)/x² (≈ −1/2 + x/3 − x²/8 + x³/30 − x⁴/144 for small x)."""
    small = x < 1e-2
    xs = np.where(small, x, 0.0)
    series = -0.5 + xs / 3.0 - xs**2 / 8.0 + xs**3 / 30.0 - xs**4 / 144.0
    big = np.where(small, 1.0, x)
    return np.where(small, series, ((1.0 + big) * np.exp(-big) - 1.0) / big**2)


def _psi(x: FloatArray) -> FloatArray:
    """ψ(x) = ∫₀^x e^{−(x−y)} y (x − y) dy = x − 2 + (x + 2) e^{−x} (≈ x³/6 for small x)."""
    small = x < 1e-2
    xs = np.where(small, x, 0.0)
    series = xs**3 / 6.0 - xs**4 / 12.0 + xs**5 / 40.0
    big = np.where(small, 1.0, x)
    return np.where(small, series, big - 2.0 + (big + 2.0) * np.exp(-big))


class _Exponential(TimeStepper):
    """Exponential integrators of (†) with an implicit instantaneous response.

    Subclasses set :meth:`weights`: the new memory is
    w_i ← e^{−x_i} w_i − c_i (a_i q_new + b_i q_old), x_i = dt/τ_i.
    """

    adaptive: ClassVar[bool] = True

    @staticmethod
    def weights(x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(a, b): weights of the new and old forcing for decay x = dt/τ."""
        raise NotImplementedError

    @staticmethod
    def weight_slopes(x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(da/dx, db/dx) of :meth:`weights` (for the sensitivities to τ)."""
        raise NotImplementedError

    def error_estimate(self, state: State, q_new: FloatArray, dt: float, x: FloatArray) -> float:
        """Local error [m] of the memory update from the curvature of the forcing q(t)."""
        if self.c_modes.size == 0:
            return 0.0
        if state.history is None or self.order == 1:
            # distance between the held-forcing and the linear-forcing updates: the first-order
            # error (an upper bound for the second-order method right after a start or kink)
            gap = np.abs(_phi(x) - np.exp(-x))
            return float(np.max(np.abs(q_new - state.response)) * np.sum(self.c_modes * gap))
        t_prev, q_prev, _ = state.history
        dt_prev = state.time - t_prev
        curvature = 2.0 * ((q_new - state.response) / dt
                           - (state.response - q_prev) / dt_prev) / (dt + dt_prev)
        return float(0.5 * np.max(np.abs(curvature))
                     * np.sum(self.c_modes * self.taus**2 * _psi(x)))

    def step(self, state: State, drive: SeparationHistory, dt: float) -> StepOutcome:
        """One implicit exponential step of length ``dt`` [s]."""
        dt = self.check_step(state, drive, dt)
        problem = self.problem
        n = problem.grid.size
        t_new = state.time + dt
        position = float(drive.position(t_new))
        x = dt / self.taus
        decay = np.exp(-x)
        a, b = self.weights(x)
        c_eff = self.c_glassy + float(np.sum(self.c_modes * a))
        carry = (decay[:, None] * state.memory
                 - (self.c_modes * b)[:, None] * state.response[None, :]).sum(axis=0)
        base = problem.undeformed_gap(position) - carry[:n]
        initial = state.gap
        if state.history is not None:
            t_prev, _, gap_prev = state.history
            slope = (state.gap - gap_prev) * (dt / (state.time - t_prev))
            initial = np.maximum(state.gap + slope, 0.5 * state.gap)
        if self.gap_guess is not None:
            guess = self.gap_guess(t_new)
            initial = initial if guess is None else guess
        sol = solve_gap(problem, base, c_eff, initial, xtol=self.xtol, time=t_new)
        q_new = self.response(sol.pressure)
        memory = (decay[:, None] * state.memory
                  - (self.c_modes * a)[:, None] * q_new[None, :]
                  - (self.c_modes * b)[:, None] * state.response[None, :])
        deformation = -self.c_glassy * q_new + memory.sum(axis=0)
        error = self.error_estimate(state, q_new, dt, x)
        tangent = None
        if state.tangent is not None and not error / self.tangent_tol > 1.0:  # the march's test
            tangent = self._step_tangent(state, sol.gap, q_new, sol.factor, x, (decay, a, b))
        new = State(t_new, position, sol.gap, sol.pressure, q_new, memory, deformation,
                    history=(state.time, state.response, state.gap), tangent=tangent)
        return StepOutcome(new, error, sol.iterations)

    def _step_tangent(self, state: State, gap: FloatArray, q_new: FloatArray, factor: tuple,
                      x: FloatArray, coefficients: tuple[FloatArray, FloatArray, FloatArray]
                      ) -> Tangent:
        """The step's map differentiated with respect to ρ = (c_g, c_i, ln τ_i) (see Tangent).

        With the step's own coefficients: ∂h solves the step's linearised equilibrium with the
        right-hand side −∂(carry) + ∂c_eff · A p; then ∂q = A_aug ∂p and the memory update
        w ← e^{−x} w − c a q_new − c b q_old differentiated term by term (∂x_i/∂ln τ_i = −x_i).
        """
        decay, a, b = coefficients
        tan = state.tangent
        m, n, k = self.c_modes.size, self.problem.grid.size, self.n_sensitivities
        c = self.c_modes
        da_dx, db_dx = self.weight_slopes(x)
        modes, logs = np.arange(1, 1 + m), np.arange(1 + m, 1 + 2 * m)
        d_decay = np.zeros((k, m))  # ∂e^{−x_i}/∂ρ
        d_decay[logs, np.arange(m)] = x * decay
        d_ca = np.zeros((k, m))  # ∂(c_i a_i)/∂ρ
        d_ca[modes, np.arange(m)] = a
        d_ca[logs, np.arange(m)] = -c * da_dx * x
        d_cb = np.zeros((k, m))  # ∂(c_i b_i)/∂ρ
        d_cb[modes, np.arange(m)] = b
        d_cb[logs, np.arange(m)] = -c * db_dx * x
        d_coupling = d_ca.sum(axis=1)
        d_coupling[0] += 1.0
        q_old, w_old = state.response, state.memory
        # ∂(Σ_i e^{−x_i} w_i − c_i b_i q_old) and the memory terms that do not involve ∂q_new
        kept = (d_decay[:, :, None] * w_old[None] + decay[None, :, None] * tan.memory
                - d_cb[:, :, None] * q_old[None, None, :]
                - (c * b)[None, :, None] * tan.response[:, None, :])
        rhs = -kept.sum(axis=1)[:, :n] + d_coupling[:, None] * q_new[None, :n]
        dgap, pressure = self.solve_tangent(factor, gap, rhs)
        response = pressure @ self.influence_aug.T
        memory = (kept - d_ca[:, :, None] * q_new[None, None, :]
                  - (c * a)[None, :, None] * response[:, None, :])
        return Tangent(dgap, pressure, response, memory)


class ExponentialTrapezoidal(_Exponential):
    """Second-order exponential integrator (forcing linear over the step); the default."""

    name: ClassVar[str] = "exponential"
    order: ClassVar[int] = 2

    @staticmethod
    def weights(x):
        """A = 1 − φ(x), b = φ(x) − e^{−x}."""
        phi = _phi(x)
        return 1.0 - phi, phi - np.exp(-x)

    @staticmethod
    def weight_slopes(x):
        """Da/dx = −φ′(x), db/dx = φ′(x) + e^{−x}."""
        dphi = _dphi(x)
        return -dphi, dphi + np.exp(-x)


class ExponentialEuler(_Exponential):
    """First-order exponential integrator (forcing held at its new value)."""

    name: ClassVar[str] = "exponential-euler"
    order: ClassVar[int] = 1

    @staticmethod
    def weights(x):
        """A = 1 − e^{−x}, b = 0."""
        return -np.expm1(-x), np.zeros_like(x)

    @staticmethod
    def weight_slopes(x):
        """Da/dx = e^{−x}, db/dx = 0."""
        return np.exp(-x), np.zeros_like(x)


#: Largest change of the gap in one explicit Euler step, in decay lengths of the surface force.
MAX_GAP_JUMP = 0.5


class ExplicitEuler(TimeStepper):
    """The paper's explicit Euler on Eq. 5 / Eq. 12 (conditionally stable, first order)."""

    name: ClassVar[str] = "euler"
    order: ClassVar[int] = 1
    adaptive: ClassVar[bool] = False

    def stability_limit(self, state: State) -> float:
        """Largest stable dt [s] at ``state`` (a bound from the row-sum norm of A|p'|)."""
        if self.taus.size == 0:
            return np.inf
        dpdh = np.abs(self.problem.surface_force.pressure_derivative(state.gap))
        mu = float(np.max(np.abs(self.problem.influence) @ dpdh))
        ratio = 1.0 + float(np.sum(self.c_modes)) * mu / (1.0 + self.c_glassy * mu)
        return 2.0 * float(np.min(self.taus)) / ratio

    def step(self, state: State, drive: SeparationHistory, dt: float) -> StepOutcome:
        """One explicit step of length ``dt`` [s]."""
        dt = self.check_step(state, drive, dt)
        problem = self.problem
        n = problem.grid.size
        limit = self.stability_limit(state)
        if dt > limit:
            raise StabilityError(
                f"explicit Euler is unstable at t = {state.time:.6g} s: dt = {dt:.3g} s exceeds "
                f"the stability limit {limit:.3g} s (≈ 2τ·E_inf/E0 in contact); use dt < "
                f"{limit:.3g} s or the default method 'exponential'")
        velocity = float(drive.velocity(state.time))
        stiff = -problem.surface_force.pressure_derivative(state.gap)  # −p′
        q = state.response
        memory = state.memory.copy()
        if memory.shape[0]:
            memory[-1] = (state.deformation + self.c_glassy * q
                          - memory[:-1].sum(axis=0))
        memory_rate = -(memory + self.c_modes[:, None] * q[None, :]) / self.taus[:, None]
        forcing = memory_rate.sum(axis=0)
        coupled = self.c_glassy * self.influence_aug * stiff[None, :]
        jac = coupled[:n].copy()
        jac.flat[:: n + 1] += 1.0
        rate = np.empty(n + 1)
        rate[:n] = scipy.linalg.solve(jac, coupled[:n] @ np.full(n, velocity) + forcing[:n],
                                      check_finite=False)
        rate[n] = coupled[n] @ (velocity - rate[:n]) + forcing[n]
        deformation = state.deformation + dt * rate
        error = self._local_error(state, drive, rate, dt)
        t_new = state.time + dt
        position = float(drive.position(t_new))
        gap = problem.undeformed_gap(position) - deformation[:n]
        if np.any(gap <= 0) or not np.all(np.isfinite(gap)):
            raise GapClosureError(
                f"explicit Euler drove the gap through zero at t = {t_new:.6g} s "
                f"(dt = {dt:.3g} s); use a smaller dt or the default method 'exponential'",
                time=t_new)
        # The rate equation is linearised in the gap over the step: once the gap moves by a
        # sizeable part of the force's decay length in one step, the step is no longer an
        # approximation but a divergence (the row-sum limit above does not bound it: a fast
        # drive gives 1e3-fold forces at dt below it). Refuse rather than return such a curve.
        jump = float(np.max(np.abs(gap - state.gap)))
        allowed = MAX_GAP_JUMP * problem.surface_force.decay_length
        if jump > allowed:
            raise StabilityError(
                f"explicit Euler is unstable at t = {t_new:.6g} s: the gap changed by "
                f"{jump:.3g} m in one step of dt = {dt:.3g} s (> {MAX_GAP_JUMP:g} x the force's "
                f"decay length {problem.surface_force.decay_length:.3g} m); use dt < "
                f"{dt * allowed / jump:.2g} s (about) or the default method 'exponential'")
        pressure = problem.surface_force.pressure(gap)
        new = State(t_new, position, gap, pressure, self.response(pressure),
                    memory + dt * memory_rate, deformation,
                    history=(state.time, state.response, state.gap))
        return StepOutcome(new, error, 1)

    def _local_error(self, state: State, drive: SeparationHistory, rate: np.ndarray,
                     dt: float) -> float:
        """Local truncation error (dt²/2)|u''| [m] from the change of the rate since the last step.

        The previous rate follows from ``state.history`` (Euler: u_n = u_{n−1} + dt·rate_{n−1});
        the march clears the history at drive kinks (the velocity jumps there and the step lands
        on the kink, so the jump itself is integrated exactly), so the first step and the first
        step after a kink have no estimate (0).
        """
        if state.history is None:
            return 0.0
        t_prev, _, gap_prev = state.history
        n = self.problem.grid.size
        u_prev = self.problem.undeformed_gap(float(drive.position(t_prev))) - gap_prev
        rate_prev = (state.deformation[:n] - u_prev) / (state.time - t_prev)
        curvature = np.max(np.abs(rate[:n] - rate_prev)) / (state.time - t_prev)
        return 0.5 * dt * dt * float(curvature)


#: Registry of the built-in steppers (users may also pass a TimeStepper subclass).
METHODS: dict[str, type[TimeStepper]] = {
    cls.name: cls for cls in (ExponentialTrapezoidal, ExponentialEuler, ExplicitEuler)
}
DEFAULT_METHOD = ExponentialTrapezoidal.name
