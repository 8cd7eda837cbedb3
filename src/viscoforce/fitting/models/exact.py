"""``exact``: the exact small-amplitude response at any position, an n-mode Prony material.

The fitting grid (issue 41). At a position the model is evaluated on a grid with fewer
Gauss–Legendre panels than the problem's (same order and outer radius) when that grid is
accurate enough: its k* is compared, at the guess's E_inf (and again at any E_inf beyond a factor
``CHECK_SPAN`` of those checked; the check grid's Newton solve starts from the fitting grid's
gaps interpolated onto its nodes), with a grid of the same panels two orders lower at four
compliances spanning the relaxed to the glassy plateau (c = 2/E_inf × 1, 0.1, 0.01,
0.55 − 0.45i). The panel quadrature converges spectrally, so that difference bounds the fitting
grid's own error from above (on the paper's system at h̄0 = −5 nm, 11 panels of order 8:
half the panels, difference 4.5e-7, the fitting grid's error against a twice finer one 8.8e-9;
5 panels 1.4e-6 and 1.5e-8; 4 panels 2.5e-5 and 1.2e-6). A check above the tolerance moves to
the next finer candidate, and past half the panels to the problem's own grid. At a load, and
for a problem of one panel or order < 4, the problem's grid is used.

The tolerance follows the data's noise (issue 41 item 3, part 3; :func:`noise_tolerance`).
A model error ε_i at the points moves a fitted parameter θ_k of a weighted fit by at most
σ_k ‖ε/σ‖₂ (Cauchy–Schwarz on (JᵀJ)⁻¹Jᵀ: σ_k is its stderr), so a relative error δ at every
point moves every parameter by at most δ·√(Σ_i |k_i|² max(w_re,i, w_im,i)²) of its stderr
(w = 1/σ). Where the data carry their stderr the tolerance is the δ that makes this bound
``BIAS_STDERR`` (0.1 of a stderr), floored at ``FIT_GRID_RTOL`` (1e-6, the tolerance without
stderr: results no less accurate than before) and capped at ``FIT_GRID_RTOL_MAX`` (1e-4); on 20
points with 1 % noise 2.2e-4 → 1e-4, with 0.1 % 2.2e-5. Relative weights (no stderr): the fixed
``FIT_GRID_RTOL``. The candidates start ⌊log10(tolerance / 1e-6)⌋ panels below half the
problem's (at least 2): with 1e-6 half the panels, as before; on the paper's 11 panels 4 at 1 %
noise, 5 at 0.1 %. First-order steps in E_inf (below) take ``TAYLOR_SHARE`` of the tolerance.

The fit (issue 41 item 3, part 2). At a position the model carries its analytic Jacobian
(``model_jacobian``, which :func:`viscoforce.fitting.outcome.fit_once` hands to MINPACK's
``lmder``): dk*/dθ = dk*/dc · 2 dC*/dθ (:func:`compliance_derivatives`) plus ∂k*/∂E_inf at
fixed c from the state's modes, dh/dE and p″ along it
(:meth:`~viscoforce.experiments.linear_response.ModulusStates.sensitivities`), so that a fit
solves one static state per accepted step instead of one more per difference step; steps
within the Taylor bound of a decomposed state (≤ ``TAYLOR_SHARE`` × the tolerance relative,
estimated: 1e-8 without stderr) solve none. The
guess finds the levels on the fitting grid's states directly (:func:`_levels`).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping

import numpy as np

from viscoforce.exceptions import ParameterError
from viscoforce.experiments._modal import StateCache
from viscoforce.fitting._params import reported_names
from viscoforce.fitting.base import (
    MAX_MODES,
    MODULUS_BOUNDS,
    FitModel,
    ModelSpec,
    material_from,
    material_layout,
    material_names,
    moduli_names,
    need,
    tau_names,
)
from viscoforce.fitting.guesses import (
    SpectrumFeatures,
    material_guess,
    moduli_from_levels,
    omega_window,
    solve_modulus,
)
from viscoforce.fitting.models._inputs import MEAN_FORCE, POSITION, PROBLEM
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.spectrum_models import (
    _expand_one_mode,
    _position_choice,
    exact_stiffness,
)
from viscoforce.problem import ContactProblem
from viscoforce.radial_grid import RadialGrid, gauss_legendre_unit, lagrange_matrix

#: Largest relative k* error the fitting grid may add, as estimated, where the data carry no
#: stderr; the floor of the noise's tolerance (module docstring).
FIT_GRID_RTOL = 1e-6
#: The largest tolerance the data's noise may give (the check's two orders stay in the
#: quadrature's spectral range).
FIT_GRID_RTOL_MAX = 1e-4
#: The bound on how far the model error may move a parameter, in units of its stderr.
BIAS_STDERR = 0.1
#: The share of the tolerance a first-order step in E_inf may add (1e-8 at 1e-6).
TAYLOR_SHARE = 1e-2
#: A fit's E_inf farther than this factor from every checked one is checked again.
CHECK_SPAN = 4.0
#: Compliances of the check, in units of 2/E_inf: relaxed, towards glassy, one complex.
_CHECK_C = np.array([1.0, 0.1, 0.01, 0.55 - 0.45j])


def _coarser(problem: ContactProblem, panels: int, order: int) -> ContactProblem:
    grid = problem.grid
    return ContactProblem(problem.sphere, problem.surface_force, problem.material,
                          RadialGrid(grid.outer_radius, panels, order))


def noise_tolerance(data) -> float:
    """The relative k* error the fitting grid may add on ``data`` (module docstring).

    ``data``: a :class:`~viscoforce.fitting.data.FitData` of a spectrum. With the data's own
    stderr (``weighting == "stderr"``): ``BIAS_STDERR`` / √(Σ_i |k_i|² max(w_re,i, w_im,i)²),
    within [``FIT_GRID_RTOL``, ``FIT_GRID_RTOL_MAX``]; else ``FIT_GRID_RTOL``.
    """
    weights = getattr(data, "weights", None)
    if weights is None or not getattr(data, "sigma_known", False):
        return FIT_GRID_RTOL
    w = np.asarray(weights)
    largest = np.maximum(np.abs(w.real), np.abs(w.imag)) if np.iscomplexobj(w) else np.abs(w)
    norm = float(np.sqrt(np.sum((np.abs(np.asarray(data.y)) * largest) ** 2)))
    if not (math.isfinite(norm) and norm > 0.0):
        return FIT_GRID_RTOL
    return min(max(BIAS_STDERR / norm, FIT_GRID_RTOL), FIT_GRID_RTOL_MAX)


def _ladder(problem: ContactProblem, tolerance: float) -> list[int]:
    """The fitting grid's candidate panel counts for ``tolerance``, coarsest first.

    Up to half the problem's panels, from ⌊log10(tolerance / ``FIT_GRID_RTOL``)⌋ below it (at
    least 2); empty where the problem's grid is too coarse to coarsen (one panel, order < 4).
    """
    grid = problem.grid
    if grid.n_panels < 2 or grid.order < 4:
        return []
    half = (grid.n_panels + 1) // 2
    below = int(math.floor(math.log10(max(tolerance / FIT_GRID_RTOL, 1.0)) + 1e-9))
    return list(range(max(2, half - below), half + 1))


def _grids(problem: ContactProblem, panels: int) -> tuple[ContactProblem, ContactProblem,
                                                           np.ndarray]:
    """The fitting grid's problem of ``panels``, its check's (kernels kept), the map between them.

    The map interpolates panel by panel from the fitting grid's nodes onto the check grid's
    (the check's Newton start).
    """
    grid = problem.grid

    def build() -> tuple[ContactProblem, ContactProblem, np.ndarray]:
        fit, check = _coarser(problem, panels, grid.order), _coarser(problem, panels,
                                                                     grid.order - 2)
        local = lagrange_matrix(gauss_legendre_unit(grid.order)[0],
                                gauss_legendre_unit(grid.order - 2)[0])
        return fit, check, np.kron(np.eye(panels), local)

    return _COARSE.get((problem.sphere, problem.surface_force, grid, panels), build)


class FitGrid:
    """The problem a fit of the exact model at ``position`` evaluates on (module docstring).

    ``tolerance``: the relative k* error the fitting grid may add (:func:`noise_tolerance`;
    default ``FIT_GRID_RTOL``). ``error`` holds the estimated relative k* errors of the current
    fitting grid checked so far by E_inf; ``problem`` is the fitting grid's problem, or the
    given one once every candidate failed its check. ``taylor_rtol`` is the share of the
    tolerance a first-order step in E_inf may add.
    """

    def __init__(self, problem: ContactProblem, position: float,
                 tolerance: float = FIT_GRID_RTOL):
        self.given, self.position = problem, position
        self._states = None
        self._lock = threading.Lock()
        self.set_tolerance(tolerance)

    def set_tolerance(self, tolerance: float) -> None:
        """Choose the candidates anew for a new ``tolerance`` (relative, > 0; checks forgotten).

        The same tolerance again keeps the grid and its checks (a refit of the same data).
        """
        if not (math.isfinite(tolerance) and tolerance > 0.0):
            raise ParameterError(f"tolerance must be a finite relative error > 0, got "
                                 f"{tolerance!r}")
        if float(tolerance) == getattr(self, "tolerance", None):
            return
        with self._lock:
            self.tolerance, self.taylor_rtol = float(tolerance), TAYLOR_SHARE * float(tolerance)
            self._ladder = _ladder(self.given, self.tolerance)
            self._next()

    def _next(self) -> None:
        """Move to the next candidate (or the problem's own grid), its checks none yet."""
        self.error: dict[float, float] = {}
        if self._ladder:
            self.panels = self._ladder.pop(0)
            self.problem, self._check, self._onto_check = _grids(self.given, self.panels)
        else:
            self.panels = self.given.grid.n_panels
            self.problem, self._check, self._onto_check = self.given, None, None

    def unchecked(self):
        """The states of the current ``problem``, without a check (the guess's level search)."""
        from viscoforce.experiments.linear_response import modulus_states

        with self._lock:
            if self._states is None or self._states.problem is not self.problem:
                self._states = modulus_states(self.problem, self.position)
            return self._states

    def states(self, e_inf: float):
        """The states (:class:`~viscoforce.experiments.linear_response.ModulusStates`) of E_inf.

        The fitting grid is checked first at ``e_inf`` [Pa] if no check was near it: the check
        grid's Newton solve starts from the fitting grid's gaps interpolated onto its nodes; a
        failed check moves to the next candidate and checks it there.
        """
        from viscoforce.experiments.linear_response import modulus_states

        with self._lock:
            while self.problem is not self.given and not any(
                    abs(math.log(e / e_inf)) <= math.log(CHECK_SPAN) for e in self.error):
                c = _CHECK_C * (2.0 / e_inf)
                fitting = modulus_states(self.problem, self.position)
                fine = fitting.stiffness(e_inf, c)
                check = modulus_states(self._check, self.position)
                check.static(e_inf, initial=np.maximum(
                    self._onto_check @ fitting.static(e_inf).gap,
                    0.5 * float(fitting.static(e_inf).gap.min())))
                rough = check.stiffness(e_inf, c)
                error = float(np.max(np.abs(fine - rough) / np.abs(fine)))
                self.error[e_inf] = error
                if error > self.tolerance:
                    self._next()
        return self.unchecked()


#: The fitting and check problems (their kernels) by system and given grid.
_COARSE = StateCache(4)


def _exact_model(spec: ModelSpec) -> FitModel:
    (problem,) = need(spec, "problem")
    position, mean_force = _position_choice(spec)
    modes = spec.modes
    grid = FitGrid(problem, position) if position is not None else None
    layout = material_layout(modes)
    names = reported_names(layout)  # the Jacobian's columns: FitModel.names' order

    def function(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        full = dict(v)
        if modes > 1 and "tau" in full:  # the level search passes one-mode names
            full = _expand_one_mode(full, modes)
        material = material_from(full, modes)
        if grid is None:
            return exact_stiffness(problem, position, mean_force, material, omega)
        return exact_stiffness(problem, position, mean_force, material, omega,
                               states=grid.states(material.relaxed_modulus),
                               taylor_rtol=grid.taylor_rtol)

    def jacobian(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        # the fit evaluated ``function`` here first (its material checked): the closed form
        # of C* and its derivatives from the values directly
        e_inf = float(v["E_inf"])
        dc, c = compliance_derivatives(v, modes, omega, names)
        _, dk_dc, dk_de = grid.states(e_inf).sensitivities(  # type: ignore[union-attr]
            e_inf, 2.0 * c, taylor_rtol=grid.taylor_rtol)  # type: ignore[union-attr]
        out = (2.0 * dk_dc)[:, None] * dc
        out[:, names.index("E_inf")] += dk_de
        return out

    def guesser(k: np.ndarray, omega: np.ndarray) -> dict[str, float]:
        feats = SpectrumFeatures.of(k, omega)
        start = problem.material.relaxed_modulus
        e_inf, e0 = (moduli_from_levels(function, feats, start) if grid is None
                     else _levels(grid, feats, start))
        return material_guess(e0, e_inf, feats.sls_tau(), modes, omega_window(omega))

    model = FitModel(spec, function, layout, "omega", guesser, omega_window)
    if grid is not None:  # at a load the position moves with E_inf: differences, as before
        model.model_jacobian = jacobian  # type: ignore[attr-defined]
        # the fit's data set the fitting grid's tolerance (their stderr, if any) before the
        # guess: what fitting.outcome.fit_once calls a model's ``prepare`` with
        model.prepare = lambda data: grid.set_tolerance(  # type: ignore[attr-defined]
            noise_tolerance(data))
    return model


def compliance_derivatives(values: Mapping[str, float], modes: int, omega: np.ndarray,
                           names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """dC*(ω)/dθ [1/Pa per unit of θ] of the n-mode Prony material (one column per name), C*.

    C* = 1/E_0 + Σ_i (1/E_{i+1} − 1/E_i) g_i with g_i = 1/(1 + iωτ_i) (E_0 = E0 … E_n =
    E_inf, :meth:`~viscoforce.physics.materials.PronySeries.from_moduli`), so dC*/dE_k =
    −(δ_k0 + g_{k−1} − g_k)/E_k² (the terms that exist) and dC*/dτ_i = −iω ΔJ_i g_i².
    """
    moduli = np.array([values[n] for n in moduli_names(modes)])
    taus = np.array([values[n] for n in tau_names(modes)])
    g = 1.0 / (1.0 + 1j * omega[:, None] * taus[None, :])  # (ω, modes)
    delta = 1.0 / moduli[1:] - 1.0 / moduli[:-1]
    per_modulus = np.zeros((omega.size, modes + 1), dtype=complex)
    per_modulus[:, 0] = 1.0
    per_modulus[:, 1:] += g
    per_modulus[:, :-1] -= g
    per_modulus /= -(moduli**2)[None, :]
    per_tau = (-1j * omega[:, None]) * delta[None, :] * g * g
    columns = dict(zip(moduli_names(modes), per_modulus.T, strict=True))
    columns.update(zip(tau_names(modes), per_tau.T, strict=True))
    return np.stack([columns[n] for n in names], axis=1), 1.0 / moduli[0] + g @ delta


def _levels(grid: FitGrid, feats: SpectrumFeatures, start: float) -> tuple[float, float]:
    """E_inf and E0 whose relaxed and glassy |k*| match the spectrum's low and high levels.

    The levels of :func:`~viscoforce.fitting.guesses.moduli_from_levels`, found on the fitting
    grid's states: E_inf by :func:`_relaxed_level`, the grid checked there (again on the
    problem's grid if the check fails); then E0 by the secant on that state's modal sum
    (decomposed once; the fit starts there).
    """
    fitting = grid.unchecked()
    e_inf = _relaxed_level(fitting, feats.k_low, start)
    if grid.states(e_inf) is not fitting:  # the check failed: the problem's own grid
        e_inf = _relaxed_level(grid.unchecked(), feats.k_low, e_inf)
    state = grid.states(e_inf).state(e_inf)
    # the glassy level: a material relaxing far slower than the top frequency's period
    drive = 1j * feats.omega_high * 1e4 / feats.omega_low

    def glassy(e: float) -> float:
        e0 = max(e, 1.0001 * e_inf)
        c = 2.0 * (1.0 / e0 + (1.0 / e_inf - 1.0 / e0) / (1.0 + drive))
        return float(abs(state._stiffness_checked(np.array([c]))[0]))

    e0 = solve_modulus(glassy, max(feats.k_high, feats.k_low * 1.01), 2 * e_inf)
    return e_inf, max(e0, 1.05 * e_inf)


def _relaxed_level(states, target: float, start: float) -> float:
    """E_inf whose relaxed stiffness is ``target`` [N/m], from ``start`` [Pa].

    Newton's method in log–log on the relaxed stiffness with its exact slope
    (:meth:`~viscoforce.experiments.linear_response.ModulusStates.relaxed`; the secant it
    replaces took five states where this takes two or three), to 1e-3 in ln k as before,
    within the guess window (a decade inside the modulus bounds). A step of less than 5 %
    decomposes its state (likely the last: the fit starts there).
    """
    lo, hi = MODULUS_BOUNDS[0] * 10, MODULUS_BOUNDS[1] / 10
    e_inf = start
    for _ in range(12):
        k, slope = states.relaxed(e_inf)
        if abs(math.log(abs(k) / target)) < 1e-3:
            break
        factor = (target / abs(k)) ** (1.0 / min(max(slope, 0.05), 2.0))
        e_inf = min(max(e_inf * factor, lo), hi)
        if abs(math.log(factor)) < 0.05:
            states.state(e_inf)
    return e_inf


ENTRY = register(ModelEntry(
    name="exact", data="spectrum",
    summary="the exact small-amplitude response (any position, contact included)",
    build=_exact_model, inputs=(POSITION, MEAN_FORCE, PROBLEM), parameters=material_names,
    max_modes=MAX_MODES,
    validity="the exact small-amplitude model: its error is the fitting grid's, checked "
             "against a tolerance that moves no parameter by more than 0.1 of its stderr "
             "(0.1/sqrt(sum |k|^2/sigma^2) relative, within 1e-6 to 1e-4; 1e-6 where the data "
             "carry no stderr; else the problem's grid, ~1e-9 on the default grid), plus 1e-2 "
             "of that tolerance where a step is taken to first order in E_inf, and the "
             "finite-amplitude bias of the measurement"))
