"""What the force-curve models share (the builders live with their models).

The exponential relaxation/creep builder, Hertz's guesses and windows, the step response of a
measured drive.

The builders themselves live with their models, one module each in
:mod:`viscoforce.fitting.models` (``relaxation``, ``creep``, ``hertz``, ``step``); build a model
with :func:`viscoforce.fitting.models.make_model`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from viscoforce.exceptions import ParameterError
from viscoforce.fitting import _params as P
from viscoforce.fitting._hertz_scan import hertz_least_squares, hertz_scan
from viscoforce.fitting.base import (
    MODULUS_BOUNDS,
    FitModel,
    ModelSpec,
    material_from,
)
from viscoforce.fitting.guesses import spread, time_window
from viscoforce.problem import ContactProblem


def _exponential_model(spec: ModelSpec, level: str, step: str) -> FitModel:
    """``level`` + Σ ``step``_i e^{−t/τ_i}: the relaxation (F_inf, dF_i) and creep (z_inf, dz_i)."""
    modes = spec.modes
    dfs = [f"{step}_{i}" for i in range(1, modes + 1)]
    taus = [f"tau_{i}" for i in range(1, modes + 1)]

    def function(t: np.ndarray, v: Mapping[str, float]) -> np.ndarray:
        f = np.full(np.shape(t), v[level], dtype=float)
        for df, tau in zip(dfs, taus, strict=True):
            f += v[df] * np.exp(-t / v[tau])
        return f

    def guesser(f: np.ndarray, t: np.ndarray) -> dict[str, float]:
        order = np.argsort(t)
        t, f = t[order], np.asarray(f, dtype=float)[order]
        n_end = max(2, t.size // 20)
        f_inf, f_start = float(np.median(f[-n_end:])), float(np.median(f[:max(2, t.size // 200)]))
        excess = f - f_inf
        target = (f_start - f_inf) / math.e
        crossed = np.flatnonzero(np.sign(excess - target) != np.sign(f_start - f_inf - target))
        t0 = float(t[crossed[0]] - t[0]) if crossed.size else float(np.ptp(t)) / 3
        tau = max(t0, float(np.ptp(t)) / t.size)
        out = {level: f_inf, **{df: (f_start - f_inf) / modes for df in dfs}}
        out.update(zip(taus, spread(tau, modes, time_window(t)), strict=True))
        return out

    layout: list[P.Item] = [P.Signed(level), *(P.Signed(df) for df in dfs),
                            P.Chain(tuple(taus))]
    return FitModel(spec, function, layout, "t", guesser, time_window)


def baseline_windows(f: np.ndarray, z: np.ndarray) -> dict[str, tuple[float, float]]:
    """Bounds of ``baseline`` [N] and ``baseline_slope`` [N/m] from the force span and the tip travel.

    Wide (2 force spans beyond the data, 10 spans over the travel): they only give the bounded
    parameters an O(1) internal scale for the optimiser's finite differences.
    """
    f = np.asarray(f, dtype=float)
    span = float(np.ptp(f)) or float(np.max(np.abs(f))) or 1e-12
    z_span = float(np.ptp(z)) or 1e-9
    return {"baseline": (float(np.min(f)) - 2 * span, float(np.max(f)) + 2 * span),
            "baseline_slope": (-10 * span / z_span, 10 * span / z_span)}


def contact_window(tip: Any, z: np.ndarray) -> tuple[float, float]:
    """Where a contact point may lie [m]: within the approach, no deeper than the tip allows."""
    lo, hi = float(np.min(z)), float(np.max(z))
    deepest = getattr(tip, "max_indentation", None)
    if deepest is not None:
        lo = max(lo, hi - 0.99 * float(deepest))
    return lo, hi


#: Contact points tried by the Hertz guess (each with a linear least-squares E and baseline).
HERTZ_GUESS_POINTS = 64


def hertz_linear(tip: Any, z: np.ndarray, f: np.ndarray, contact: float
                 ) -> tuple[np.ndarray, float]:
    """(E, baseline, slope) by linear least squares at a given contact point, and the SSE."""
    delta = np.maximum(z - contact, 0.0)
    design = np.column_stack([tip.force_shape(delta), np.ones_like(z), z - contact])
    scale = np.max(np.abs(design), axis=0)
    scale[scale == 0] = 1.0
    coef, *_ = np.linalg.lstsq(design / scale, f, rcond=None)
    coef = coef / scale
    return coef, float(np.sum((design @ coef - f) ** 2))


def hertz_grid(tip: Any, z: np.ndarray, f: np.ndarray, *, coarse: bool = True
               ) -> tuple[float, float, np.ndarray] | None:
    """The best (contact point, SSE, (E, baseline, slope)) of a grid of contact points.

    Given the contact point the model is linear in (E, baseline, slope); the grid spans the
    contact window (:func:`contact_window`): :data:`HERTZ_GUESS_POINTS` quantiles of the samples
    in it, then 21 points within one median grid step of the best. Only contact points with
    E > 0 count; None when there is none (the force does not rise with z beyond any of them).
    The candidates are solved all at once in closed form
    (:func:`~viscoforce.fitting._hertz_scan.hertz_scan`; ``coarse``: the quantiles on a subsample
    first, then on every sample near its best; False: every candidate on every sample); they
    equal :func:`hertz_linear` at each candidate to rounding.
    """
    return hertz_scan(tip, z, f, contact_window(tip, z), points=HERTZ_GUESS_POINTS,
                      coarse=coarse)


def _clipped_modulus(e: float) -> float:
    return min(max(float(e), MODULUS_BOUNDS[0] * 10), MODULUS_BOUNDS[1] / 10)


def hertz_guess(tip: Any, z: np.ndarray, f: np.ndarray) -> dict[str, float]:
    """A start for the Hertz fit: the best of a grid of contact points (:func:`hertz_grid`).

    Raises
    ------
    ParameterError
        No contact point gives E > 0 (the force does not rise with the tip position).
    """
    best = hertz_grid(tip, z, f)
    if best is None:
        raise ParameterError("no contact point in the approach gives a positive modulus: the "
                             "force does not rise with the tip position (is this the approach "
                             "segment of a repulsive contact?)")
    return _grid_start(best)


def _grid_start(best: tuple[float, float, np.ndarray]) -> dict[str, float]:
    c, _, coef = best
    return {"E": _clipped_modulus(coef[0]), "contact_point": c, "baseline": float(coef[1]),
            "baseline_slope": float(coef[2])}


def hertz_start(tip: Any, z: np.ndarray, f: np.ndarray) -> dict[str, float]:
    """The hertz model's start: its least squares by variable projection, else one without contact.

    The grid of :func:`hertz_grid` carried to the minimum of its closed-form sum of squares over
    the contact point (:func:`~viscoforce.fitting._hertz_scan.hertz_least_squares`: E, baseline
    and slope are linear given it), so that the fit's Levenberg–Marquardt starts at the
    minimum it converges to and stops within a few evaluations (issue 41 item 4; from the
    grid's best point it took 20–45).

    An approach whose force rises with z beyond no contact point (noise only, or the tip
    position's sign flipped) still gets a fit, so that it can be reported as what it is (E not
    determined, :func:`viscoforce.fitting.hertz_checks.hertz_checks` says why) rather than
    refused: the straight baseline, the contact point at the deep end of the contact window and
    the smallest modulus of the guess's range.
    """
    window = contact_window(tip, z)
    best = hertz_least_squares(tip, np.asarray(z, dtype=float), np.asarray(f, dtype=float),
                               window, points=HERTZ_GUESS_POINTS)
    if best is not None:
        return _grid_start(best)
    lo, hi = window
    c = lo + 0.98 * (hi - lo)
    slope, baseline = np.polyfit(z - c, f, 1)
    return {"E": _clipped_modulus(0.0), "contact_point": float(c), "baseline": float(baseline),
            "baseline_slope": float(slope)}


#: A sample of a position trace lying within this fraction of the trace's largest |h0| of the
#: straight line through its neighbours is not a corner (:func:`corners`).
COLLINEAR_RTOL = 1e-12


def corners(t: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The samples of a piecewise-linear trace (t, h0) where it bends, and its two ends.

    A sample on the straight line through the kept sample before it and the sample after it (to
    :data:`COLLINEAR_RTOL` of max |h0|, i.e. to rounding) is dropped: the piecewise-linear
    interpolant of what is kept is the same function h0(t). A simulated step or triangle keeps
    its corners only; a measured (noisy) trace keeps every sample. The time loop then restarts
    its step history only where the drive really has a kink (at each sample of the full trace it
    restarts at every one: more rejected steps and Newton iterations for the same drive).
    """
    t, h = np.asarray(t, dtype=float), np.asarray(h, dtype=float)
    if t.size < 3:
        return t, h
    tol = COLLINEAR_RTOL * float(np.max(np.abs(h)))
    keep = [0]
    for i in range(1, t.size - 1):
        a = keep[-1]
        line = h[a] + (h[i + 1] - h[a]) * ((t[i] - t[a]) / (t[i + 1] - t[a]))
        if abs(h[i] - line) > tol:
            keep.append(i)
    keep.append(t.size - 1)
    return t[keep], h[keep]


class StepResponse:
    """The step model's force along one drive, with its exact sensitivities, last run kept.

    Each run integrates the force and its forward sensitivities to the material together
    (:func:`viscoforce.solvers.simulate.simulate_force`: the force of ``simulate(...,
    output_kinks=False)``, the sensitivities by back-substitution with each step's Newton
    factorisation). A least-squares fit asks for the residual and then the Jacobian at the same
    parameters: the second comes from the kept run, so an iteration costs one simulation instead
    of one per parameter plus one (finite differences). Each run's Newton solves start from the
    previous run's gaps moved along their sensitivities (first order in the parameter change),
    which changes where Newton starts, not the converged force.

    Parameters
    ----------
    problem : ContactProblem
        System and grid (its material is replaced by each evaluation's).
    drive : SeparationHistory
        The measured or simulated position history h0(t) [m].
    tol : float, optional
        Local error tolerance of the adaptive steps [m] (default that of ``simulate``).
    """

    #: Largest change of ln E0, ln E_inf or ln τ from where the kept step grid was chosen over
    #: which a run repeats that grid (otherwise the steps are chosen afresh).
    REGRID = 0.05
    #: Largest such change over which the last run's gaps, moved along their sensitivities, are
    #: better Newton starts than the stepper's own extrapolation in time.
    WARM = 0.3

    def __init__(self, problem: ContactProblem, drive: Any, *, tol: float | None = None):
        self.problem, self.drive, self.tol = problem, drive, tol
        #: Repeat the step grid of the last adaptive run near its parameters (see class doc).
        self.reuse_grid = True
        #: Simulations run (adaptive, on a kept grid) and Newton iterations (bookkeeping).
        self.runs = self.grid_runs = self.newton = 0
        self._kept: dict[str, Any] | None = None
        self._grid: tuple[np.ndarray, np.ndarray] | None = None  # (step times, ln SPEC)

    def forget(self) -> None:
        """Drop the kept result and grid: the next evaluation is a fresh adaptive simulation.

        Only the Newton starts (the last run's gaps and their sensitivities) are kept.
        """
        self._grid = None
        if self._kept is not None:
            self._kept = {k: v for k, v in self._kept.items() if k in self._WARM}

    def warm_from(self, other: StepResponse) -> None:
        """Take the Newton starts of ``other``'s last run (same drive; e.g. the search stage's)."""
        if other._kept is not None:
            self._kept = {k: other._kept[k] for k in self._WARM}

    _WARM = ("rho", "logs", "step_time", "step_gap", "dgap")

    @staticmethod
    def _prony(values: Mapping[str, float]) -> np.ndarray:
        """ρ = (c_g, c_1, ln τ) = (2/E0, 2/E_inf − 2/E0, ln τ) of an SLS."""
        e0, e_inf, tau = float(values["E0"]), float(values["E_inf"]), float(values["tau"])
        return np.array([2.0 / e0, 2.0 / e_inf - 2.0 / e0, math.log(tau)])

    def _run(self, t: np.ndarray, values: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        from viscoforce.exceptions import ConvergenceError, GapClosureError
        from viscoforce.solvers.simulate import simulate_force

        key = (float(values["E0"]), float(values["E_inf"]), float(values["tau"]))
        kept = self._kept
        same_t = kept is not None and "t" in kept and np.array_equal(kept["t"], t)
        if same_t and kept["key"] == key:
            return kept["force"], kept["log_gradient"]
        rho, logs = self._prony(values), np.log(key)
        warm = grid = None
        if kept is not None and np.max(np.abs(logs - kept["logs"])) <= self.WARM:
            # Newton starts by step time (the outputs need not be the same)
            moved = kept["step_gap"] + np.einsum("j,ijn->in", rho - kept["rho"], kept["dgap"])
            warm = (kept["step_time"], np.maximum(moved, 0.5 * kept["step_gap"]))
            if (same_t and self.reuse_grid and self._grid is not None
                    and np.max(np.abs(logs - self._grid[1])) <= self.REGRID):
                grid = self._grid[0]
        problem = self.problem.with_material(material_from(values, 1))
        options = {"t_end": float(t[-1]), "t_eval": t, "tol": self.tol, "sensitivities": True}
        run = None
        if grid is not None:
            try:
                run = simulate_force(problem, self.drive, warm_start=warm, grid=grid, **options)
                self.grid_runs += 1
            except (ConvergenceError, GapClosureError):
                run = None  # the kept grid is too coarse here: choose the steps afresh
        if run is None:
            run = simulate_force(problem, self.drive, warm_start=warm, **options)
            self.runs += 1
            self._grid = (run.step_time, logs)
        self.newton += run.newton
        e0, e_inf, _ = key
        # ∂F/∂(ln E0, ln E_inf, ln τ) from ∂F/∂ρ
        d_cg, d_c1, d_tau = run.sensitivity.T
        log_grad = np.column_stack([(d_c1 - d_cg) * (2.0 / e0), -d_c1 * (2.0 / e_inf), d_tau])
        self._kept = {"key": key, "t": np.array(t), "force": run.force, "log_gradient": log_grad,
                      "rho": rho, "logs": logs, "step_time": run.step_time,
                      "step_gap": run.step_gap,
                      "dgap": run.step_gap_sensitivity}
        return run.force, log_grad

    def force(self, t: np.ndarray, values: Mapping[str, float]) -> np.ndarray:
        """F(t) [N] for the SLS of ``values`` (``E0``, ``E_inf``, ``tau``)."""
        return self._run(np.asarray(t, dtype=float), values)[0]

    def log_gradient(self, t: np.ndarray, values: Mapping[str, float]) -> dict[str, np.ndarray]:
        """∂F/∂ln(name) [N] at ``t`` for each SPEC name (exact for the discrete scheme)."""
        grad = self._run(np.asarray(t, dtype=float), values)[1]
        return dict(zip(("E0", "E_inf", "tau"), grad.T, strict=True))


