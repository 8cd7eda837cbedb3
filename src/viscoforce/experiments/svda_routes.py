"""The SVDA routes of force spectroscopy: the closed forms and the SVDA ODE driven by a sine.

:func:`svda_spectrum` — the SVDA closed forms (paper Eqs. 23–26, Eq. 24 corrected), valid before
contact; :func:`svda_sweep` — the SVDA ODE (Eqs. 17–18) driven by the same sine
(:class:`~viscoforce.experiments.drives.Sinusoid`) and demodulated by the same lock-in as
:func:`viscoforce.experiments.spectroscopy.sweep`: the time-domain check of :func:`svda_spectrum`,
nonlinear in η. Both are reached through :mod:`viscoforce.experiments.spectroscopy`.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from viscoforce._limits import MAX_SAMPLES, MAX_STEPS, check_effort
from viscoforce._validation import (
    require_finite,
    require_int,
    require_nonnegative,
    require_positive,
)
from viscoforce.choice import (
    double_layer,
)
from viscoforce.exceptions import ParameterError
from viscoforce.experiments._checks import (
    require_frequencies,
    require_number,
    require_problem,
    require_progress,
)
from viscoforce.experiments.drives import STEPS_PER_PERIOD, Sinusoid
from viscoforce.lockin import demodulate
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_spectrum
from viscoforce.solvers.svda_ode import check_ode_settings, solve_svda
from viscoforce.svda import svda_harmonic_response, svda_static_deformation, warn_svda_error

__all__ = ["svda_spectrum", "svda_sweep"]

#: Settling time of the SVDA ODE sweep, in creep times τ (the linearised SVDA transient decays at
#: least as fast as e^{−t/τ}).
SVDA_SETTLE_TAUS = 20.0


def _settling_periods(settle: float, omega: NDArray[np.float64]) -> NDArray[np.float64]:
    """Whole drive periods covering ``settle`` [s] at each ω (the same rounding as the runs)."""
    return np.ceil(settle * omega / (2.0 * math.pi) - 1e-9)


def _check_sweep_effort(what: str, steps: NDArray[np.float64], basis: str, samples: int,
                        periods: int | NDArray[np.int64], n_omega: int, hint: str) -> None:
    """Refuse a sweep whose output samples or (lower-bound) time steps exceed the limits."""
    frequencies = f"{n_omega} frequenc{'y' if n_omega == 1 else 'ies'}"
    per = np.broadcast_to(np.asarray(periods) * samples + 1, (n_omega,))
    each = f"x {per[0]}" if np.all(per == per[0]) else f"{per.sum()} in all"
    check_effort(f"output samples of {what} ({frequencies} {each})", float(per.sum()),
                 MAX_SAMPLES, hint="fewer frequencies, periods or samples_per_period")
    check_effort(f"time steps of {what} ({frequencies}, settling and demodulated periods, "
                 f"{basis})", float(np.sum(steps)), MAX_STEPS, hint=hint)


def _track(iterable, total: int, show: bool):
    if not show:
        return iterable
    from tqdm.auto import tqdm

    return tqdm(iterable, total=total, desc="spectrum", unit="ω", leave=False)


def _svda_parameters(problem: ContactProblem) -> dict[str, float]:
    """The SVDA inputs of ``problem``: one creep time and exactly one double-layer term.

    Returns the keyword arguments ``E0, E_inf, tau, radius, P, debye_length`` of the SVDA closed
    forms and of :func:`~viscoforce.solvers.svda_ode.solve_svda`.
    """
    material = problem.material
    prony = material.prony()
    if prony.n_modes != 1:
        raise ParameterError(
            f"the SVDA closed form needs a single-relaxation-time material, got {prony.n_modes} "
            "modes; use method 'linear'")
    dl = double_layer(problem)
    if dl is None:
        raise ParameterError("the SVDA closed form needs exactly one DoubleLayer term")
    return {"E0": material.instantaneous_modulus, "E_inf": material.relaxed_modulus,
            "tau": prony.taus[0], "radius": problem.sphere.radius, "P": dl.P,
            "debye_length": dl.debye_length}


def _svda_inputs(problem: object, position: object, eta: object,
                 omega: object, *, allow_zero: bool
                 ) -> tuple[ContactProblem, dict[str, float], float, float, NDArray[np.float64]]:
    """Check the common arguments of the SVDA routes; refuse positions in contact."""
    problem = require_problem(problem)
    params = _svda_parameters(problem)
    position = require_number("position", position, require_finite,
                              "finite [m] (h0, the undeformed apex separation)")
    eta = require_number("eta", eta, require_positive, "> 0 [m] (finite)")
    omega = require_frequencies(omega, allow_zero=allow_zero)
    u0 = float(svda_static_deformation(position, params["E_inf"], params["radius"], params["P"],
                                       params["debye_length"]))
    central_gap = position - u0
    if central_gap < params["debye_length"]:
        raise ParameterError(
            f"the SVDA closed form holds before contact only: at position {position:.3g} m its "
            f"central gap {central_gap:.3g} m is below the Debye length "
            f"{params['debye_length']:.3g} m; use method 'linear' (exact) here")
    return problem, params, position, eta, omega


def svda_spectrum(problem: ContactProblem, position: float, eta: float,
                  omega: ArrayLike) -> xr.Dataset:
    """SVDA closed-form spectrum (paper Eqs. 23–26, Eq. 24 corrected; pre-contact only).

    Requires a standard linear solid and a double-layer law (the soft wall is ignored by the SVDA).

    Parameters
    ----------
    problem : ContactProblem
        System: one-mode material, exactly one :class:`~viscoforce.physics.surface_forces.DoubleLayer`.
    position : float
        Mean position h̄0 [m], finite, before contact (central gap ≥ the Debye length).
    eta : float
        Drive amplitude η [m], > 0 (scales ``force_amplitude`` and ``amplitude`` only).
    omega : array_like
        Angular frequencies [rad/s], ≥ 0 (non-empty, 1-D).

    Returns
    -------
    xarray.Dataset
        Spectrum with ``method = "svda"`` and the SVDA ``svda_c``, ``svda_u0`` in attrs.

    Raises
    ------
    ParameterError
        If an argument is missing or out of range, the material or law is not the SVDA's, or
        the position is in contact.
    """
    problem, params, position, eta, omega = _svda_inputs(problem, position, eta, omega,
                                                         allow_zero=False)
    resp = svda_harmonic_response(omega, position, eta, **params)
    k = resp.stiffness * np.exp(1j * np.radians(resp.phase))
    attrs = dict(problem.parameters())
    attrs.update({"method": "svda", "position": position, "eta": eta,
                  "svda_c": float(resp.c), "svda_u0": float(resp.u0)})
    return make_spectrum(omega, k, resp.mean_force, eta, attrs=attrs)


def _svda_one_frequency(params: dict[str, float], position: float, eta: float, omega: float,
                        periods: int, settle: float, samples: int, ode_method: str, rtol: float,
                        atol: float) -> tuple[complex, float, complex, float, int]:
    period = 2.0 * math.pi / omega
    n_settle = math.ceil(settle / period - 1e-9)
    drive = Sinusoid(position, eta, omega, periods=float(n_settle + periods))
    t_eval = n_settle * period + period * np.arange(periods * samples + 1) / samples
    t_eval[-1] = min(t_eval[-1], drive.duration)
    run = solve_svda(drive, **params, t_eval=t_eval, ode_method=ode_method, rtol=rtol, atol=atol)
    force_hat = complex(demodulate(run.force, run.time, omega))
    mean_force = float(np.real(demodulate(run.force, run.time, omega, harmonic=0)))
    u_hat = complex(demodulate(run.deformation, run.time, omega))
    mean_u = float(np.real(demodulate(run.deformation, run.time, omega, harmonic=0)))
    # drive h0 − h̄0 = Re[−iη e^{iωt}], compression D̂ = iη: k* = F̂/D̂, ν̂/η = Û/(−iη)
    return force_hat / (1j * eta), mean_force, u_hat / (-1j * eta), mean_u, run.nfev


def svda_sweep(problem: ContactProblem, position: float, eta: float, omega: ArrayLike, *,
               periods: int = 4, settle: float | None = None, samples_per_period: int = 64,
               ode_method: str = "Radau", rtol: float = 1e-10, atol: float | None = None,
               progress: bool | None = None) -> xr.Dataset:
    """SVDA spectrum in the time domain: the ODE (Eqs. 17–18) under a sine, then lock-in.

    For each ω the drive :class:`~viscoforce.experiments.drives.Sinusoid` h0(t) = h̄0 + η sin ωt
    starts from the E_inf static SVDA state at h̄0, runs a whole number of settling periods (at
    least ``settle``) and then ``periods`` more, sampled uniformly and demodulated by
    :func:`viscoforce.lockin.demodulate` — the same drive and lock-in as :func:`sweep`, with
    :func:`~viscoforce.solvers.svda_ode.solve_svda` in place of the exact solver. At small η it
    reproduces :func:`svda_spectrum`; at finite η it includes the SVDA's nonlinear response.

    Parameters
    ----------
    problem : ContactProblem
        System: one-mode material, exactly one :class:`~viscoforce.physics.surface_forces.DoubleLayer`
        (its grid is not used).
    position : float
        Mean position h̄0 [m], finite, before contact (central gap ≥ the Debye length).
    eta : float
        Drive amplitude η [m], > 0.
    omega : array_like
        Angular frequencies [rad/s], > 0 (non-empty, 1-D).
    periods : int
        Whole periods demodulated after settling (≥ 1).
    settle : float, optional
        Settling time [s], ≥ 0 (rounded up to whole periods); default 20τ
        (:data:`SVDA_SETTLE_TAUS`).
    samples_per_period : int
        Output samples per period fed to the lock-in (≥ 8).
    ode_method : {"Radau", "BDF", "LSODA"}
        ``solve_ivp`` method (:data:`~viscoforce.solvers.svda_ode.ODE_METHODS`).
    rtol : float
        Relative tolerance of ``solve_ivp``, in [1e-13, 0.1].
    atol : float, optional
        Absolute tolerance on u [m], > 0; default 1e-12·debye_length.
    progress : bool, optional
        Progress bar over the frequencies (default: when stderr is a terminal).

    Returns
    -------
    xarray.Dataset
        Spectrum with ``method = "svda-ode"``, plus over ``omega``: ``deformation_amplitude`` ν
        [m] and ``deformation_phase`` φ [degree] of the central deformation
        u(t) ≈ ū + ν sin(ωt + φ) (the paper's ν and φ; φ ≤ 0, u lags the drive),
        ``mean_deformation`` ū [m] and ``nfev`` (right-hand-side evaluations).

    Raises
    ------
    ParameterError
        If an argument is missing or out of range, the material or law is not the SVDA's, or
        the position is in contact.
    EffortError
        If the estimated ODE steps (at least
        :data:`~viscoforce.experiments.drives.STEPS_PER_PERIOD` per period, settling included,
        summed over ω) exceed :data:`~viscoforce._limits.MAX_STEPS` or the output samples exceed
        :data:`~viscoforce._limits.MAX_SAMPLES`; refused before integrating.
    ConvergenceError
        If the time integration fails.
    """
    problem, params, position, eta, omega = _svda_inputs(problem, position, eta, omega,
                                                         allow_zero=False)
    periods = require_int("periods", periods, 1)
    samples = require_int("samples_per_period", samples_per_period, 8)
    if settle is None:
        settle = SVDA_SETTLE_TAUS * params["tau"]
    else:
        settle = require_number("settle", settle, require_nonnegative,
                                ">= 0 [s] (finite; None for 20 tau)")
    rtol, atol = check_ode_settings(ode_method, rtol, atol, params["debye_length"])
    show = require_progress(progress)
    n_settle = _settling_periods(settle, omega)
    steps = n_settle * STEPS_PER_PERIOD + periods * max(STEPS_PER_PERIOD, samples)
    _check_sweep_effort("the SVDA ODE sweep", steps,
                        f"at least {STEPS_PER_PERIOD} steps per period", samples, periods,
                        omega.size,
                        hint="fewer or lower frequencies, a shorter settle or fewer periods; "
                             "the closed form svda_spectrum needs no time stepping")
    show = sys.stderr.isatty() if show is None else show
    results = list(_track((_svda_one_frequency(params, position, eta, float(w), periods, settle,
                                               samples, ode_method, rtol, atol) for w in omega),
                          omega.size, show))
    k = np.array([r[0] for r in results])
    mean = np.array([r[1] for r in results])
    nu_rel = np.array([r[2] for r in results])
    attrs = dict(problem.parameters())
    attrs.update({"method": "svda-ode", "position": position, "eta": eta, "periods": periods,
                  "settle": settle, "samples_per_period": samples, "ode_method": ode_method,
                  "rtol": rtol, "atol": atol})
    ds = make_spectrum(omega, k, mean, eta, attrs=attrs)

    def over_omega(values: NDArray, units: str, long_name: str) -> xr.DataArray:
        return xr.DataArray(values, dims="omega", attrs={"units": units, "long_name": long_name})

    ds["deformation_amplitude"] = over_omega(eta * np.abs(nu_rel), "m",
                                             "central deformation amplitude nu")
    ds["deformation_phase"] = over_omega(np.degrees(np.angle(nu_rel)), "degree",
                                         "phase of the central deformation relative to the drive")
    ds["mean_deformation"] = over_omega(np.array([r[3] for r in results]), "m",
                                        "mean central deformation")
    ds["nfev"] = over_omega(np.array([r[4] for r in results]), "1",
                            "right-hand-side evaluations")
    warn_svda_error(position, params["E_inf"], params["radius"], params["P"],
                    params["debye_length"])
    return ds
