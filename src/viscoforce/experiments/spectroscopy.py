"""Force spectroscopy: sinusoidal drive, simulation to steady state, lock-in, Spectrum dataset.

Four routes to the same Spectrum (SPEC convention: ``phase`` χ = lead of the force over the
compression, ``stiffness`` = |F1|/η, ``amplitude`` a = |F1|/F̄):

* :func:`sweep` — time domain: h0(t) = h̄0 + η sin ωt from the static E_inf state, simulated with
  the exact solver for a settling time and then ``periods`` whole periods, demodulated by
  :func:`viscoforce.lockin.demodulate`. Valid at any η (it includes the nonlinear response).
* :func:`~viscoforce.experiments.linear_response.linear_response` — exact small-η response in the
  frequency domain (one complex solve per ω).
* :func:`svda_spectrum` — the SVDA closed forms (paper Eqs. 23–26, Eq. 24 corrected), valid before
  contact.
* :func:`svda_sweep` — the SVDA ODE (Eqs. 17–18) driven by the same sine
  (:class:`~viscoforce.experiments.drives.Sinusoid`) and demodulated by the same lock-in as
  :func:`sweep`: the time-domain check of :func:`svda_spectrum`, nonlinear in η.

The time-domain routes estimate their work before computing and refuse requests beyond
:mod:`viscoforce._limits` (:class:`~viscoforce.exceptions.EffortError`, with the estimate).
"""

from __future__ import annotations

import math
import sys
import warnings
from concurrent.futures import ProcessPoolExecutor

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
from viscoforce.choice import double_layer
from viscoforce.exceptions import ApproximationWarning, ParameterError
from viscoforce.experiments._checks import (
    require_frequencies,
    require_number,
    require_problem,
    require_progress,
)
from viscoforce.experiments.contact_spectrum import contact_spectrum
from viscoforce.experiments.drives import STEPS_PER_PERIOD, Sinusoid
from viscoforce.experiments.linear_response import linear_response
from viscoforce.lockin import demodulate
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_spectrum
from viscoforce.solvers.base import TimeStepper
from viscoforce.solvers.simulate import EULER_DEFAULT_FRACTION, simulate
from viscoforce.solvers.steppers import METHODS
from viscoforce.solvers.svda_ode import check_ode_settings, solve_svda
from viscoforce.svda import svda_harmonic_response, svda_static_deformation, warn_svda_error

#: Settling time before demodulation, in units of the longest creep time.
DEFAULT_SETTLE_TAUS = 10.0
#: Local error tolerance of the time-domain sweep, as a fraction of η.
DEFAULT_SWEEP_TOL = 1e-5
#: Settling time of the SVDA ODE sweep, in creep times τ (the linearised SVDA transient decays at
#: least as fast as e^{−t/τ}).
SVDA_SETTLE_TAUS = 20.0


def _settling_periods(settle: float, omega: NDArray[np.float64]) -> NDArray[np.float64]:
    """Whole drive periods covering ``settle`` [s] at each ω (the same rounding as the runs)."""
    return np.ceil(settle * omega / (2.0 * math.pi) - 1e-9)


def _one_frequency(problem: ContactProblem, position: float, eta: float, omega: float,
                   periods: int, settle: float, samples: int, tol: float,
                   stepper: str | type[TimeStepper],
                   steps_per_period: int | None) -> tuple[complex, float, int]:
    period = 2.0 * math.pi / omega
    n_settle = math.ceil(settle / period - 1e-9)
    drive = Sinusoid(position, eta, omega, periods=float(n_settle + periods))
    t0 = n_settle * period
    t_eval = t0 + period * np.arange(periods * samples + 1) / samples
    dt = None if steps_per_period is None else period / steps_per_period
    ds = simulate(problem, drive, t_end=drive.duration, t_eval=t_eval, tol=tol, stepper=stepper,
                  dt=dt, progress=False, output_kinks=False)
    force, time = ds.force.values, ds.time.values
    first = complex(demodulate(force, time, omega))
    mean = float(np.real(demodulate(force, time, omega, harmonic=0)))
    # h0 − h̄0 = η sin ωt = Re[−iη e^{iωt}], compression D̂ = iη; k* = F̂/D̂
    return first / (1j * eta), mean, int(ds.attrs["steps"])


def _stepper_class(stepper: object) -> type[TimeStepper]:
    if isinstance(stepper, str) and stepper in METHODS:
        return METHODS[stepper]
    if isinstance(stepper, type) and issubclass(stepper, TimeStepper):
        return stepper
    raise ParameterError(
        f"stepper must be one of {sorted(METHODS)} or a TimeStepper subclass, got {stepper!r}")


def _sweep_steps(problem: ContactProblem, stepper: type[TimeStepper], omega: NDArray[np.float64],
                 periods: int, settle: float, samples: int,
                 steps_per_period: int | None) -> tuple[NDArray[np.float64], str]:
    """Lower-bound estimate of the time steps of each frequency's run, and its basis (text).

    Every settling and demodulated period is stepped; steps also land on every output
    (``samples`` per demodulated period). Between them a fixed-step run takes
    ``steps_per_period`` (or explicit Euler's default dt), an adaptive one at least
    :data:`~viscoforce.experiments.drives.STEPS_PER_PERIOD` (8) per period — the drives' lower
    bound (:meth:`~viscoforce.experiments.drives.Sinusoid.min_steps`), not a prediction: on the
    paper's Fig. 3 and 4 systems at ω = 1e2–1e5 rad/s the exponential stepper takes 20–260 steps
    per period at the default tol (and Radau on the SVDA ODE at rtol = 1e-10 about 1200–2000
    right-hand-side evaluations per period).
    """
    n_settle = _settling_periods(settle, omega)
    if steps_per_period is not None:
        per_period = np.full(omega.shape, float(steps_per_period))
        basis = f"steps_per_period = {steps_per_period}"
    elif stepper.adaptive:
        per_period = np.full(omega.shape, float(STEPS_PER_PERIOD))
        basis = f"at least {STEPS_PER_PERIOD} steps per period"
    else:  # simulate's default fixed step (explicit Euler): 0.1 τ_min E_inf/E0, or t_end/1000
        material = problem.material
        taus = material.prony().taus
        if taus:
            dt = (EULER_DEFAULT_FRACTION * min(taus) * material.relaxed_modulus
                  / material.instantaneous_modulus)
            per_period = (2.0 * math.pi / omega) / dt
            basis = f"the {stepper.name} stepper's default dt = {dt:.3g} s"
        else:
            per_period = 1000.0 / (n_settle + periods)
            basis = f"the {stepper.name} stepper's default dt = t_end/1000"
    return n_settle * per_period + periods * np.maximum(per_period, samples), basis


def _check_sweep_effort(what: str, steps: NDArray[np.float64], basis: str, samples: int,
                        periods: int, n_omega: int, hint: str) -> None:
    """Refuse a sweep whose output samples or (lower-bound) time steps exceed the limits."""
    frequencies = f"{n_omega} frequenc{'y' if n_omega == 1 else 'ies'}"
    check_effort(f"output samples of {what} ({frequencies} x {periods * samples + 1})",
                 float(n_omega) * (periods * samples + 1), MAX_SAMPLES,
                 hint="fewer frequencies, periods or samples_per_period")
    check_effort(f"time steps of {what} ({frequencies}, settling and demodulated periods, "
                 f"{basis})", float(np.sum(steps)), MAX_STEPS, hint=hint)


def sweep(problem: ContactProblem, position: float, eta: float, omega: ArrayLike, *,
          periods: int = 4, settle: float | None = None, samples_per_period: int = 64,
          tol: float | None = None, stepper: str | type[TimeStepper] = "exponential",
          steps_per_period: int | None = None, n_jobs: int = 1,
          progress: bool | None = None) -> xr.Dataset:
    """Time-domain force spectroscopy: simulate each ω to steady state and demodulate.

    Parameters
    ----------
    problem : ContactProblem
        System, material, grid (must reach ``position − eta``).
    position : float
        Mean position h̄0 [m], finite.
    eta : float
        Drive amplitude η [m], > 0.
    omega : array_like
        Angular frequencies [rad/s], > 0 (non-empty, 1-D).
    periods : int
        Whole periods demodulated after settling (≥ 1).
    settle : float, optional
        Settling time [s] before demodulation, ≥ 0 (rounded up to whole periods); default
        10 τ_max (the transient from the resting start decays as e^{−t/τ} or faster).
    samples_per_period : int
        Output samples per period fed to the lock-in (≥ 8).
    tol : float, optional
        Local error tolerance of the stepper [m], > 0; default 1e-5·η.
    stepper : str or TimeStepper subclass
        Time stepper (see :func:`~viscoforce.solvers.simulate.simulate`).
    steps_per_period : int, optional
        Fixed time step of period/``steps_per_period`` (≥ 1; default: adaptive, or explicit
        Euler's default step); steps also land on every output, so a step coarser than
        period/``samples_per_period`` needs a matching ``samples_per_period``.
    n_jobs : int
        Worker processes for the frequencies (≥ 1; 1: serial).
    progress : bool, optional
        Progress bar over the frequencies (default: when stderr is a terminal).

    Returns
    -------
    xarray.Dataset
        Spectrum with ``method = "time-domain"`` and the per-ω step counts in ``steps``.

    Raises
    ------
    ParameterError
        If an argument is missing or out of range (the message names it and the range).
    EffortError
        If the estimated time steps (settling + demodulated periods, summed over ω) exceed
        :data:`~viscoforce._limits.MAX_STEPS` or the output samples exceed
        :data:`~viscoforce._limits.MAX_SAMPLES`; refused before any simulation.
    """
    problem = require_problem(problem)
    position = require_number("position", position, require_finite,
                              "finite [m] (h0, the undeformed apex separation)")
    eta = require_number("eta", eta, require_positive, "> 0 [m] (finite)")
    omega = require_frequencies(omega, allow_zero=False)
    periods = require_int("periods", periods, 1)
    samples = require_int("samples_per_period", samples_per_period, 8)
    n_jobs = require_int("n_jobs", n_jobs, 1)
    stepper_class = _stepper_class(stepper)
    taus = problem.material.prony().taus
    if settle is None:
        settle = DEFAULT_SETTLE_TAUS * (max(taus) if taus else 0.0)
    else:
        settle = require_number("settle", settle, require_nonnegative,
                                ">= 0 [s] (finite; None for 10 tau_max)")
    tol = (DEFAULT_SWEEP_TOL * eta if tol is None
           else require_number("tol", tol, require_positive, "> 0 [m] (finite; None for 1e-5 eta)"))
    if steps_per_period is not None:
        steps_per_period = require_int("steps_per_period", steps_per_period, 1)
    show = require_progress(progress)
    steps, basis = _sweep_steps(problem, stepper_class, omega, periods, settle, samples,
                                steps_per_period)
    _check_sweep_effort(
        "the time-domain sweep", steps, basis, samples, periods, omega.size,
        hint="fewer or lower frequencies, a shorter settle or fewer periods; the small-amplitude "
             "spectrum needs no time stepping (method 'linear')")
    problem.check_covers(position - eta)
    args = [(problem, position, eta, float(w), periods, settle, samples, tol, stepper,
             steps_per_period) for w in omega]
    show = sys.stderr.isatty() if show is None else show
    if n_jobs > 1 and len(omega) > 1:
        with ProcessPoolExecutor(max_workers=n_jobs) as pool:
            results = list(_track(pool.map(_one_frequency, *zip(*args, strict=True)),
                                  len(args), show))
    else:
        results = list(_track((_one_frequency(*a) for a in args), len(args), show))
    k = np.array([r[0] for r in results])
    mean = np.array([r[1] for r in results])
    attrs = dict(problem.parameters())
    attrs.update({"method": "time-domain", "position": position, "eta": eta,
                  "periods": periods, "settle": settle, "samples_per_period": samples,
                  "tol": tol, "stepper": stepper_class.name,
                  "steps_per_period": 0 if steps_per_period is None else steps_per_period})
    ds = make_spectrum(omega, k, mean, eta, attrs=attrs)
    ds["steps"] = xr.DataArray(np.array([r[2] for r in results]), dims="omega",
                               attrs={"units": "1", "long_name": "time steps taken"})
    return ds


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


#: Spectrum routes: name → function(problem, position, eta, omega, **options).
SPECTRUM_METHODS = {"linear": linear_response, "time-domain": sweep, "svda": svda_spectrum,
                    "svda-ode": svda_sweep, "contact": contact_spectrum}
#: Options of the time-domain route that ``method="auto"`` sets itself.
_AUTO_CHOOSES = {"tol", "stepper", "steps_per_period"}
#: Routes that take options (the time-domain ones).
_WITH_OPTIONS = ("time-domain", "svda-ode")


def spectrum(problem: ContactProblem, position: float, eta: float, omega: ArrayLike, *,
             method: str = "auto", accuracy: float | None = None,
             **options: object) -> xr.Dataset:
    """Force spectrum by any route; ``method="auto"`` picks the cheapest adequate one.

    Parameters
    ----------
    problem : ContactProblem
        System, material, grid.
    position : float
        Mean position h̄0 [m].
    eta : float
        Drive amplitude η [m], > 0.
    omega : array_like
        Angular frequencies [rad/s], > 0.
    method : {"auto", "linear", "time-domain", "svda", "svda-ode", "contact"}
        The route (see :data:`SPECTRUM_METHODS`); ``"auto"`` uses
        :func:`~viscoforce.experiments.choice.choose_spectrum` and stores its reason in
        ``attrs["explanation"]`` and its estimate in ``attrs["estimated_error"]``.
    accuracy : float, optional
        Required relative error of ``"auto"`` (default 1e-3); only with ``"auto"``.
    **options
        Passed to the time-domain routes (:func:`sweep`: ``periods``, ``n_jobs``,
        ``progress``, ...; :func:`svda_sweep`); ``"auto"`` passes on those its route takes.

    Returns
    -------
    xarray.Dataset
        Spectrum; ``attrs["method"]`` is the route used.

    Raises
    ------
    ParameterError
        Unknown method, or an argument of the route missing or out of range.
    EffortError
        A time-domain request beyond the effort limits (refused before computing).
    TypeError
        Options given to a route that takes none.

    Warns
    -----
    ModelValidityWarning
        An explicit approximate route whose estimated error exceeds 1 % (the SVDA inside
        ~6 nm with the paper's parameters, Hertz contact, a linear spectrum at κη ≳ 0.3).
    """
    from viscoforce.experiments.choice import DEFAULT_ACCURACY, choose_spectrum, coarsened

    if not isinstance(method, str) or (method != "auto" and method not in SPECTRUM_METHODS):
        raise ParameterError(
            f"method must be 'auto' or one of {sorted(SPECTRUM_METHODS)}, got {method!r}")
    if accuracy is not None and method != "auto":
        raise ParameterError(f"accuracy applies to method 'auto' only, not {method!r}")
    choice = None
    if method == "auto" and set(options) & _AUTO_CHOOSES:
        raise TypeError(f"method 'auto' chooses {', '.join(sorted(set(options) & _AUTO_CHOOSES))} "
                        "itself; name the route (e.g. method='time-domain') to set them")
    if method == "auto":
        choice = choose_spectrum(problem, position, eta, omega,
                                 accuracy=DEFAULT_ACCURACY if accuracy is None else accuracy)
        method = choice.method
        options = {**options, **choice.options} if method in _WITH_OPTIONS else {}
        options.pop("grid_factor", None)
        if method == "svda-ode":  # sweep's stepper options do not apply to the SVDA ODE
            options = {k: v for k, v in options.items() if k in ("periods", "progress")}
    if options and method not in _WITH_OPTIONS:
        raise TypeError(f"method {method!r} takes no options, got {sorted(options)}")
    if choice is None:
        ds = SPECTRUM_METHODS[method](problem, position, eta, omega, **options)
    else:
        if "grid_factor" in choice.options:  # a coarser grid meets the accuracy
            problem = coarsened(problem, choice.options["grid_factor"])
        with warnings.catch_warnings():  # the choice weighed the approximations' estimates
            warnings.simplefilter("ignore", ApproximationWarning)
            ds = SPECTRUM_METHODS[method](problem, position, eta, omega, **options)
        ds.attrs["explanation"] = choice.explanation
        ds.attrs["estimated_error"] = choice.estimated_error
        ds.attrs["accuracy"] = choice.accuracy
    return ds
