"""``exact``: the exact small-amplitude response at any position, an n-mode Prony material.

The fitting grid (issue 41). At a position the model is evaluated on a grid with half the
problem's Gauss–Legendre panels (same order and outer radius) when that grid is accurate
enough: its k* is compared, at the first E_inf a fit evaluates (and again at any E_inf beyond
a factor ``CHECK_SPAN`` of those checked), with a grid of the same panels two orders lower at four
compliances spanning the relaxed to the glassy plateau (c = 2/E_inf × 1, 0.1, 0.01,
0.55 − 0.45i). The panel quadrature converges spectrally, so that difference bounds the fitting
grid's own error from above (on the paper's system at h̄0 = −5 nm: difference 4.5e-7, the
fitting grid's error against a twice finer one 8.8e-9, the problem's 2.9e-11). If it exceeds
``FIT_GRID_RTOL`` (1e-6 relative: a thousandth of a 0.1 % noise, where a parameter moves by
well under 0.01 of its stderr) the problem's own grid is used from then on. At a load, and for
a problem of one panel or order < 4, the problem's grid is used.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Mapping

import numpy as np

from viscoforce.experiments._modal import StateCache
from viscoforce.fitting.base import (
    MAX_MODES,
    FitModel,
    ModelSpec,
    material_from,
    material_layout,
    material_names,
    need,
)
from viscoforce.fitting.guesses import (
    SpectrumFeatures,
    material_guess,
    moduli_from_levels,
    omega_window,
)
from viscoforce.fitting.models._inputs import MEAN_FORCE, POSITION, PROBLEM
from viscoforce.fitting.registry import ModelEntry, register
from viscoforce.fitting.spectrum_models import (
    _expand_one_mode,
    _position_choice,
    exact_stiffness,
)
from viscoforce.problem import ContactProblem
from viscoforce.radial_grid import RadialGrid

#: Largest relative k* error the fitting grid may add, as estimated (module docstring).
FIT_GRID_RTOL = 1e-6
#: A fit's E_inf farther than this factor from every checked one is checked again.
CHECK_SPAN = 4.0
#: Compliances of the check, in units of 2/E_inf: relaxed, towards glassy, one complex.
_CHECK_C = np.array([1.0, 0.1, 0.01, 0.55 - 0.45j])


def _coarser(problem: ContactProblem, panels: int, order: int) -> ContactProblem:
    grid = problem.grid
    return ContactProblem(problem.sphere, problem.surface_force, problem.material,
                          RadialGrid(grid.outer_radius, panels, order))


def _grids(problem: ContactProblem) -> tuple[ContactProblem, ContactProblem] | None:
    """The fitting grid's problem and its check's (kernels kept), or None if too coarse."""
    grid = problem.grid
    if grid.n_panels < 2 or grid.order < 4:
        return None
    panels = (grid.n_panels + 1) // 2
    return _COARSE.get((problem.sphere, problem.surface_force, grid), lambda: (
        _coarser(problem, panels, grid.order), _coarser(problem, panels, grid.order - 2)))


class FitGrid:
    """The problem a fit of the exact model at ``position`` evaluates on (module docstring).

    ``error`` holds the estimated relative k* errors of the fitting grid checked so far by
    E_inf; ``problem`` is the fitting grid's problem, or the given one once a check failed.
    """

    def __init__(self, problem: ContactProblem, position: float):
        self.given, self.position = problem, position
        grids = _grids(problem)
        self.problem, self._check = grids if grids is not None else (problem, None)
        self.error: dict[float, float] = {}
        self._states = None
        self._lock = threading.Lock()

    def states(self, e_inf: float):
        """The states (:class:`~viscoforce.experiments.linear_response.ModulusStates`) of E_inf.

        The fitting grid is checked first at ``e_inf`` [Pa] if no check was near it.
        """
        from viscoforce.experiments.linear_response import modulus_states

        with self._lock:
            if self.problem is not self.given and not any(
                    abs(math.log(e / e_inf)) <= math.log(CHECK_SPAN) for e in self.error):
                c = _CHECK_C * (2.0 / e_inf)
                fine = modulus_states(self.problem, self.position).stiffness(e_inf, c)
                rough = modulus_states(self._check, self.position).stiffness(e_inf, c)
                self.error[e_inf] = float(np.max(np.abs(fine - rough) / np.abs(fine)))
                if self.error[e_inf] > FIT_GRID_RTOL:
                    self.problem = self.given
            if self._states is None or self._states.problem is not self.problem:
                self._states = modulus_states(self.problem, self.position)
            return self._states


#: The fitting and check problems (their kernels) by system and given grid.
_COARSE = StateCache(4)


def _exact_model(spec: ModelSpec) -> FitModel:
    (problem,) = need(spec, "problem")
    position, mean_force = _position_choice(spec)
    modes = spec.modes
    grid = FitGrid(problem, position) if position is not None else None

    def function(omega: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        full = dict(v)
        if modes > 1 and "tau" in full:  # the level search passes one-mode names
            full = _expand_one_mode(full, modes)
        material = material_from(full, modes)
        states = None if grid is None else grid.states(material.relaxed_modulus)
        return exact_stiffness(problem, position, mean_force, material, omega, states=states)

    def guesser(k: np.ndarray, omega: np.ndarray) -> dict[str, float]:
        feats = SpectrumFeatures.of(k, omega)
        e_inf, e0 = moduli_from_levels(function, feats, problem.material.relaxed_modulus)
        return material_guess(e0, e_inf, feats.sls_tau(), modes, omega_window(omega))

    return FitModel(spec, function, material_layout(modes), "omega", guesser, omega_window)


ENTRY = register(ModelEntry(
    name="exact", data="spectrum",
    summary="the exact small-amplitude response (any position, contact included)",
    build=_exact_model, inputs=(POSITION, MEAN_FORCE, PROBLEM), parameters=material_names,
    max_modes=MAX_MODES,
    validity="the exact small-amplitude model: its error is the fitting grid's (<= 1e-6 "
             "relative, checked; else the problem's grid, ~1e-9 on the default grid) and the "
             "finite-amplitude bias of the measurement"))
