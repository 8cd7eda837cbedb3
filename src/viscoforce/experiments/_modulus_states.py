"""The static states of one system at one position over E_inf: what a fit of E_inf reuses.

Every trial E_inf of a fit of the exact model (:mod:`viscoforce.fitting.models.exact`) is a new
static state. :class:`ModulusStates` keeps those solved, starts each new Newton solve from the
nearest one, evaluates k*(c) by the cheapest exact route and gives its derivatives in c and
E_inf (issue 41 item 3): the fit's analytic Jacobian. :func:`modulus_states` caches one per
system, grid and position; ``linearized_state.cache_clear()``
(:mod:`viscoforce.experiments.linear_response`) empties them.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from viscoforce._limits import MAX_SAMPLES, check_effort
from viscoforce._typing import FloatArray
from viscoforce._validation import require_finite, require_positive
from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.experiments._checks import require_number, require_problem
from viscoforce.experiments._modal import (
    Decomposition,
    StateCache,
    _active,
    adjoint_matrix,
    decompose,
    direct_sensitivities,
    direct_stiffness,
    log_slope,
    modal_sensitivities,
    modal_slope,
    modal_value,
)
from viscoforce.problem import ContactProblem
from viscoforce.solvers.newton import NewtonResult
from viscoforce.solvers.static import equilibrium_gap, modulus_slope

#: Relative difference of two E_inf below which they share one static state: 1e-13, far below
#: what Newton's tolerance (1e-9 decay lengths) resolves; a parameter's round trip through its
#: log10 (the fit's internal value) moves it by ≈ 1e-15.
SAME_MODULUS_RTOL = 1e-13


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


class ModulusStates:
    """The static states of one system at one position over E_inf: what a fit of E_inf reuses.

    Every trial E_inf of a fit is a new static state; this keeps those solved and (issue 41)

    - starts each new Newton solve from the nearest solved E_inf: its gaps moved by the first
      order dh/dE (:func:`~viscoforce.solvers.static.modulus_slope`, one back-substitution)
      within ``PREDICT_SPAN`` (2 Newton iterations instead of 7 for a finite-difference step,
      3 for a 1 % step), its gaps unmoved farther away (a factor 2: 7 either way);
    - evaluates at most ``DIRECT_MAX`` compliances by direct solves
      (:func:`~viscoforce.experiments._modal.direct_stiffness`), an E_inf within the Taylor
      bound of a decomposed state to first order in ΔE from it (:meth:`_taylor`: no static
      solve), else by the modal form (one eigen-decomposition per state, kept);
    - gives k*, dk*/dc and ∂k*/∂E_inf at fixed c (:meth:`sensitivities`, :meth:`relaxed`):
      the fit's Jacobian from the modes, dh/dE and p″ along it, without a second state.

    E_inf within ``SAME_MODULUS_RTOL`` of a solved one share its state. Newton converges to a
    cold solve's tolerance (1e-9 decay lengths; measured: 1e-24 m apart). Holds the problem;
    thread-safe; at most ``maxsize`` states of each kind.
    """

    #: The class of the modal form a state is kept as (``LinearizedState``): set by
    #: :mod:`viscoforce.experiments.linear_response`, which imports this module (no cycle).
    state_type: Any = None
    #: Largest |ΔE/E| from the nearest solved state at which its gaps are moved by dh/dE.
    PREDICT_SPAN = 0.2
    #: Most compliance values evaluated by direct solves instead of the modal form.
    DIRECT_MAX = 4
    #: Largest |ΔE/E| from a decomposed state evaluated to first order in ΔE (:meth:`_taylor`).
    TAYLOR_SPAN = 1e-3
    #: Largest estimated relative second-order term of :meth:`_taylor` by default (a thousandth
    #: of the fitting grid's 1e-6); a caller passes its own (``taylor_rtol``: the exact model's
    #: share of its noise's tolerance).
    TAYLOR_RTOL = 1e-9

    def __init__(self, problem: ContactProblem, position: float, maxsize: int = 32):
        self.problem, self.position, self.maxsize = problem, float(position), maxsize
        self._solved: OrderedDict[float, NewtonResult] = OrderedDict()
        self._slopes: dict[float, np.ndarray] = {}
        self._ratios: dict[float, FloatArray | None] = {}
        self._states: OrderedDict[float, Any] = OrderedDict()
        self._decomposed: dict[float, Decomposition] = {}
        self._adjoints: dict[float, np.ndarray] = {}
        self._last: tuple[float, np.ndarray, float, tuple] | None = None  # the last Taylor answer
        self._lock = threading.RLock()

    def _key(self, modulus: float) -> float:
        """``modulus``, or the solved E_inf within ``SAME_MODULUS_RTOL`` of it."""
        if modulus in self._solved:
            return modulus
        for e in self._solved:
            if abs(e - modulus) <= SAME_MODULUS_RTOL * e:
                return e
        return modulus

    def static(self, modulus: float, initial: np.ndarray | None = None) -> NewtonResult:
        """The static E_inf = ``modulus`` [Pa] state, solved from the nearest one if new.

        ``initial``: the gaps [m] to start a new solve from instead (e.g. another grid's state
        interpolated onto this one's nodes); a cold start if Newton fails from them.
        """
        with self._lock:
            modulus = self._key(modulus)
            hit = modulus in self._solved
            _COUNTS["hits" if hit else "misses"] += 1
            if hit:
                self._solved.move_to_end(modulus)
                return self._solved[modulus]
            if initial is None and self._solved:
                near = min(self._solved, key=lambda e: abs(math.log(e / modulus)))
                base = self._solved[near]
                initial = base.gap
                if abs(modulus - near) <= self.PREDICT_SPAN * near:
                    moved = base.gap + self.slope(near) * (modulus - near)
                    initial = np.maximum(moved, 0.5 * base.gap)  # kept open: Newton needs > 0
            try:
                sol = equilibrium_gap(self.problem, self.position, modulus, initial=initial)
            except ConvergenceError:
                if initial is None:
                    raise
                sol = equilibrium_gap(self.problem, self.position, modulus)  # the cold start
            self._solved[modulus] = sol
            while len(self._solved) > self.maxsize:
                old = self._solved.popitem(last=False)[0]
                self._slopes.pop(old, None), self._ratios.pop(old, None)
            return sol

    def slope(self, modulus: float) -> np.ndarray:
        """dh/dE [m/Pa] of the solved state at ``modulus`` (solved if new), kept."""
        with self._lock:
            modulus = self._key(modulus)
            if modulus not in self._slopes:
                self._slopes[modulus] = modulus_slope(self.problem, self.position, modulus,
                                                      self.static(modulus))
            return self._slopes[modulus]

    def state(self, modulus: float):
        """The modal form (a ``LinearizedState``) at E_inf = ``modulus`` [Pa], kept.

        A :class:`~viscoforce.experiments.linear_response.LinearizedState`: the state is
        decomposed once.
        """
        if self.state_type is None:  # set by linear_response when it is imported
            raise RuntimeError("ModulusStates.state_type is unset: import "
                               "viscoforce.experiments.linear_response first")
        with self._lock:
            modulus = self._key(modulus)
            if modulus not in self._states:
                dec = decompose(self.problem, self.static(modulus))
                self._decomposed[modulus] = dec
                self._states[modulus] = self.state_type._from_decomposition(
                    self.problem, self.position, modulus, dec)
                while len(self._states) > self.maxsize:
                    old = self._states.popitem(last=False)[0]
                    self._decomposed.pop(old, None), self._adjoints.pop(old, None)
            self._states.move_to_end(modulus)
            return self._states[modulus]

    def stiffness(self, modulus: float, compliance: ArrayLike, *,
                  taylor_rtol: float | None = None) -> np.ndarray:
        """k*(c) [N/m] at E_inf = ``modulus`` [Pa] for c = 2C*(ω) (as :meth:`LinearizedState.stiffness`).

        ``taylor_rtol``: the largest estimated relative error of a first-order step from a
        decomposed state (:meth:`_taylor`; default ``TAYLOR_RTOL``). Raises ParameterError
        (``compliance`` not finite with a positive real part, or ``modulus`` ≤ 0) or
        EffortError (more than ``MAX_SAMPLES`` values).
        """
        modulus, c = self._checked(modulus, compliance, "stiffness")
        flat = c.ravel()
        with self._lock:
            modulus = self._key(modulus)
            if modulus not in self._states:
                near = self._taylor(modulus, flat, taylor_rtol, slope_only=True)
                if near is not None:
                    return near[0].reshape(c.shape)
            if c.size > self.DIRECT_MAX or modulus in self._states:
                return self.state(modulus)._stiffness_checked(flat).reshape(c.shape)
            return direct_stiffness(self.problem, self.static(modulus), flat).reshape(c.shape)

    def sensitivities(self, modulus: float, compliance: ArrayLike, *,
                      taylor_rtol: float | None = None) -> tuple[
            np.ndarray, np.ndarray, np.ndarray]:
        """k*(c) [N/m], dk*/dc [N/m · Pa] and ∂k*/∂E_inf at fixed c [N/m/Pa] at ``modulus``.

        From the state's modes (:func:`~viscoforce.experiments._modal.modal_sensitivities`;
        the state is decomposed if it was not), or direct solves for at most ``DIRECT_MAX``
        values of a state not decomposed, or within the Taylor bound of a decomposed state
        (:meth:`_taylor`) from that state. ∂k*/∂E_inf is the adjoint sum over the nodes with
        dh/dE (:meth:`slope`) and p″ along it; where a node without a force derivative would
        gain one (a law with a cut-off) it is the central difference of k* over ±1e-4 E_inf
        instead. The derivative of k*(ω) in a material parameter θ is then
        dk*/dc · 2 dC*/dθ, plus ∂k*/∂E_inf for θ = E_inf. ``taylor_rtol`` and raises as
        :meth:`stiffness`.
        """
        modulus, c = self._checked(modulus, compliance, "sensitivities")
        flat = c.ravel()
        with self._lock:
            modulus = self._key(modulus)
            near = (None if modulus in self._states
                    else self._taylor(modulus, flat, taylor_rtol))
            if near is not None:
                return tuple(a.reshape(c.shape) for a in near)  # type: ignore[return-value]
            ratio = self._ratio(modulus)
            sol = self.static(modulus)
            used = np.zeros(_active(self.problem, sol)[1].size) if ratio is None else ratio
            if flat.size <= self.DIRECT_MAX and modulus not in self._states:
                k, dk_dc, dk_de = direct_sensitivities(self.problem, sol, flat, used)
            else:
                self.state(modulus)
                k, dk_dc, dk_de = modal_sensitivities(self._decomposed[modulus], flat,
                                                      self._adjoint(modulus, used))
            if ratio is None:  # a cut-off: the central difference of k* instead
                step = 1e-4 * modulus
                dk_de = (self.stiffness(modulus + step, flat)
                         - self.stiffness(modulus - step, flat)) / (2.0 * step)
            return tuple(a.reshape(c.shape) for a in (k, dk_dc, dk_de))  # type: ignore[return-value]

    def _taylor(self, modulus: float, flat: np.ndarray, rtol: float | None = None, *,
                slope_only: bool = False) -> tuple[np.ndarray, np.ndarray | None,
                                                   np.ndarray] | None:
        """k*, dk*/dc, ∂k*/∂E at ``modulus`` to first order from the nearest decomposed state.

        k*(c; E) = k*(c; E_b) + ∂k*/∂E(c; E_b) (E − E_b), with no static solve, where the
        second-order term, estimated as ½|k*_EE| (E − E_b)² with k*_EE the difference quotient
        of ∂k*/∂E between the two decomposed states nearest E_b, is at most ``TAYLOR_RTOL`` of
        |k*| at every value, ``rtol`` (default ``TAYLOR_RTOL``), and |E − E_b| ≤
        ``TAYLOR_SPAN`` E_b: a fit's last steps (ΔE/E of 1e-5 and less: estimates of 1e-12; the
        paper's system at −5 nm: ≈ 0.75 (ΔE/E)²). The derivatives are E_b's (first order in
        the step, as a finite-difference Jacobian is). ``slope_only``: dk*/dc is not formed
        (None; k* alone is asked for). None: no such state (fewer than two decomposed, a
        cut-off law, or the estimate too large).
        """
        rtol = self.TAYLOR_RTOL if rtol is None else rtol
        last = self._last
        if (last is not None and last[0] == modulus and last[2] == rtol
                and (slope_only or last[3][1] is not None) and np.array_equal(last[1], flat)):
            return last[3]  # a fit asks for the Jacobian where it just evaluated
        near = [e for e in self._decomposed if abs(modulus - e) <= self.TAYLOR_SPAN * e]
        if not near or len(self._decomposed) < 2:
            return None
        base = min(near, key=lambda e: abs(modulus - e))
        other = min((e for e in self._decomposed if e != base), key=lambda e: abs(base - e))
        ratios = self._ratio(base), self._ratio(other)
        if ratios[0] is None or ratios[1] is None:
            return None
        adjoint = self._adjoint(base, ratios[0])
        dk_dc: np.ndarray | None = None
        if slope_only:
            k, dk_de = modal_value(self._decomposed[base], flat, adjoint)
        else:
            k, dk_dc, dk_de = modal_sensitivities(self._decomposed[base], flat, adjoint)
        second = (dk_de - modal_slope(self._decomposed[other], flat,
                                      self._adjoint(other, ratios[1]))) / (base - other)
        step = modulus - base
        if not float(np.max(0.5 * np.abs(second) * step * step / np.abs(k))) <= rtol:
            return None
        out = (k + dk_de * step, dk_dc, dk_de)
        self._last = (modulus, flat.copy(), rtol, out)
        return out

    def relaxed(self, modulus: float) -> tuple[float, float]:
        """The relaxed stiffness k*(2/E; E) [N/m] at E = ``modulus`` [Pa] and d ln k / d ln E.

        The static stiffness of the elastic state and its logarithmic slope in E: what a search
        of E_inf by the relaxed level needs (direct solves, or the modes of a decomposed state).
        """
        modulus = require_number("modulus", modulus, require_positive, "> 0 [Pa] (E_inf)")
        c = np.array([2.0 / modulus + 0j])
        k, dk_dc, dk_de = self.sensitivities(modulus, c)
        value = float(k[0].real)
        total = float((dk_dc[0] * (-2.0 / modulus**2) + dk_de[0]).real)
        return value, total * modulus / value

    def _adjoint(self, modulus: float, ratio: FloatArray) -> np.ndarray:
        """H of the decomposed state at ``modulus`` (``_modal.adjoint_matrix``), kept."""
        if modulus not in self._adjoints:
            self._adjoints[modulus] = adjoint_matrix(self._decomposed[modulus], ratio)
        return self._adjoints[modulus]

    def _ratio(self, modulus: float) -> FloatArray | None:
        """(ds/dE)/s on the active nodes of the state at ``modulus`` (None: a cut-off), kept."""
        if modulus not in self._ratios:
            self._ratios[modulus] = log_slope(self.problem, self.static(modulus),
                                              self.slope(modulus))
        return self._ratios[modulus]

    def _checked(self, modulus: Any, compliance: Any, method: str) -> tuple[
            float, NDArray[np.complex128]]:
        modulus = require_number("modulus", modulus, require_positive, "> 0 [Pa] (E_inf)")
        c = _require_compliance(compliance)
        check_effort(f"compliance values of ModulusStates.{method} ({c.size} given)", c.size,
                     MAX_SAMPLES, hint="give fewer values")
        return modulus, c


#: The :class:`ModulusStates` of :func:`modulus_states`, by system, grid and position.
_FAMILIES = StateCache(8)


def modulus_states(problem: ContactProblem, position: float) -> ModulusStates:
    """The cached :class:`ModulusStates` of ``problem`` at ``position`` [m] (a fit's E_inf).

    Keyed on (sphere, surface force, grid, position); ``linearized_state.cache_clear()``
    empties it too.

    Raises
    ------
    ParameterError
        A non-problem, a position that is not finite or that the grid does not cover.
    """
    problem = require_problem(problem)
    position = require_number("position", position, require_finite,
                              "finite [m] (h0, the undeformed apex separation)")
    problem.check_covers(position)
    return _FAMILIES.get((problem.sphere, problem.surface_force, problem.grid, position),
                         lambda: ModulusStates(problem, position))


#: Static states looked up in (hits) and solved by (misses) every :class:`ModulusStates`.
_COUNTS = {"hits": 0, "misses": 0}
