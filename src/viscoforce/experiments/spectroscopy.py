"""Force spectroscopy: sinusoidal drive, simulation to steady state, lock-in, Spectrum dataset.

Four routes to the same Spectrum (SPEC convention: ``phase`` χ = lead of the force over the
compression, ``stiffness`` = |F1|/η, ``amplitude`` a = |F1|/F̄):

* :func:`sweep` — time domain: h0(t) = h̄0 + η sin ωt from the static E_inf state, simulated with
  the exact solver for a settling time and then as many whole periods as the accuracy needs
  (:func:`lockin_error`), demodulated by :func:`viscoforce.lockin.demodulate`. Valid at any η
  (it includes the nonlinear response).
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

from viscoforce._limits import MAX_SAMPLES, check_effort
from viscoforce._validation import (
    require_finite,
    require_int,
    require_nonnegative,
    require_positive,
)
from viscoforce.choice import (
    DEFAULT_ACCURACY,
    DEFAULT_SWEEP_TOL,
    GRID_ERROR,
    SAFETY,
    SWEEP_ERROR,
    SWEEP_EXPONENT,
    SWEEP_TOL_FACTORS,
    require_accuracy,
)
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
from viscoforce.experiments.svda_routes import (  # noqa: F401 - SVDA_SETTLE_TAUS: public here
    SVDA_SETTLE_TAUS,
    _check_sweep_effort,
    _settling_periods,
    _svda_parameters,
    _track,
    svda_spectrum,
    svda_sweep,
)
from viscoforce.lockin import demodulate, transient_leakage
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_spectrum
from viscoforce.solvers.base import TimeStepper
from viscoforce.solvers.simulate import EULER_DEFAULT_FRACTION, simulate
from viscoforce.solvers.steppers import METHODS

#: Settling time before demodulation, in units of the longest creep time.
DEFAULT_SETTLE_TAUS = 10.0
#: Share of the accuracy that the lock-in's start-up transient may take (``sweep(periods=None)``).
LOCKIN_SHARE = 0.1
#: Most periods ``sweep(periods=None)`` demodulates (beyond: the settle is too short).
MAX_PERIODS = 64


#: Frequencies per block of :func:`lockin_error` (each a row of ~300 θ values).
_LOCKIN_BLOCK = 2048


def lockin_error(problem: ContactProblem, omega: ArrayLike, settle: float,
                 periods: ArrayLike) -> NDArray[np.float64]:
    """Bound on the relative error of k*(ω) that the start-up transient leaves in :func:`sweep`.

    From the relaxed static state at h̄0, each relaxation mode j (stiffness g_j, time θ_j) of
    the linear force response leaves −g_j η x/(1 + x²) e^{−t/θ_j} (x = ωθ_j), which leaks
    :func:`~viscoforce.lockin.transient_leakage` into F̂ over ``periods`` whole periods after
    ⌈settle ω/2π⌉ settling ones. With Σg_j ≤ (E0/E_inf − 1) k_inf (a series surface-force layer
    lowers the ratio), |F̂| ≥ k_inf η and θ_j ≤ τ_max (driven by position, the system relaxes
    no slower than its material creeps): ε = (E0/E_inf − 1) max_{θ ≤ τ_max} x/(1 + x²) ·
    leakage(ω, θ, t_s, N), on 40 points per decade of θ; 0 for an elastic material. Measured
    (tests/theory/test_spectrum_periods.py) 10–50× above the transient error at settle = 0.

    Parameters
    ----------
    problem : ContactProblem
        The system (its material's E0/E_inf and longest creep time τ_max).
    omega : array_like
        Angular frequencies [rad/s], > 0.
    settle : float
        Settling time [s], ≥ 0 (rounded up to whole periods, as :func:`sweep` does).
    periods : array_like
        Whole periods demodulated, ≥ 1 (broadcast against ``omega``).

    Returns
    -------
    numpy.ndarray
        ε per ω [1].
    """
    material = problem.material
    taus = material.prony().taus
    w, n = np.broadcast_arrays(np.asarray(omega, float), np.asarray(periods, float))
    if not taus:
        return np.zeros(w.shape)
    tau = max(taus)
    decades = 6.0 + max(0.0, math.log10(float(np.max(w)) * tau))
    theta = tau * 10.0 ** -np.linspace(0.0, decades, int(40 * decades) + 1)
    ratio = material.instantaneous_modulus / material.relaxed_modulus - 1.0
    out = np.empty(w.shape)
    flat_w, flat_n, flat_out = w.reshape(-1), n.reshape(-1), out.reshape(-1)
    for i in range(0, flat_w.size, _LOCKIN_BLOCK):  # bounded memory: a block × θ at a time
        wb, nb = flat_w[i:i + _LOCKIN_BLOCK, None], flat_n[i:i + _LOCKIN_BLOCK, None]
        x = wb * theta
        start = _settling_periods(settle, wb) * 2.0 * math.pi / wb
        leak = transient_leakage(wb, theta, start, nb)
        flat_out[i:i + _LOCKIN_BLOCK] = ratio * np.max(x / (1.0 + x * x) * leak, axis=-1)
    return out


def _choose_periods(problem: ContactProblem, omega: NDArray[np.float64], settle: float,
                    accuracy: float) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Per ω the fewest periods whose :func:`lockin_error` is ≤ LOCKIN_SHARE × ``accuracy``."""
    budget = LOCKIN_SHARE * accuracy
    periods = np.ones(omega.shape, dtype=np.int64)
    error = lockin_error(problem, omega, settle, periods)
    for n in range(2, MAX_PERIODS + 1):
        short = error > budget
        if not short.any():
            break
        periods[short] = n
        error[short] = lockin_error(problem, omega[short], settle, n)
    if np.any(error > budget):
        i = int(np.argmax(error))
        raise ParameterError(
            f"settle must be longer for accuracy = {accuracy:g}: settle = {settle:.3g} s leaves "
            f"a lock-in transient bound of {error[i]:.2g} at omega = {omega[i]:.4g} rad/s even "
            f"over {MAX_PERIODS} periods (allowed {budget:.2g}); use the default settle "
            "(10 tau_max), or give periods")
    return periods, error


def _stepper_error(stepper: type[TimeStepper], steps_per_period: int | None, tol: float,
                   eta: float) -> float | None:
    """Measured error of the adaptive exponential stepper and lock-in, × SAFETY (else None).

    :data:`viscoforce.choice.SWEEP_ERROR` at tol = 1e-5 η, ∝ tol^0.7 over the measured range
    (:data:`~viscoforce.choice.SWEEP_TOL_FACTORS`), plus the grid's own error.
    """
    factor = tol / (DEFAULT_SWEEP_TOL * eta)
    if (stepper is not METHODS["exponential"] or steps_per_period is not None
            or not SWEEP_TOL_FACTORS[0] <= factor <= SWEEP_TOL_FACTORS[1]):
        return None
    return GRID_ERROR + SAFETY * SWEEP_ERROR * factor ** SWEEP_EXPONENT


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
                 periods: int | NDArray[np.int64], settle: float, samples: int,
                 steps_per_period: int | None) -> tuple[NDArray[np.float64], str]:
    """Lower-bound estimate of the time steps of each frequency's run, and its basis (text).

    Every settling and demodulated period is stepped, landing on every output; between them a
    fixed-step run takes ``steps_per_period`` (or explicit Euler's default dt), an adaptive one
    at least :data:`~viscoforce.experiments.drives.STEPS_PER_PERIOD` (8) per period: a lower
    bound (the paper's Fig. 3 and 4 systems take 20–260 per period at the default tol).
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


def sweep(problem: ContactProblem, position: float, eta: float, omega: ArrayLike, *,
          periods: int | None = None, accuracy: float | None = None,
          settle: float | None = None, samples_per_period: int = 64, tol: float | None = None,
          stepper: str | type[TimeStepper] = "exponential", steps_per_period: int | None = None,
          n_jobs: int = 1, progress: bool | None = None) -> xr.Dataset:
    """Time-domain force spectroscopy: simulate each ω to steady state and demodulate.

    Periods: by default, per ω the fewest whole periods (≤ :data:`MAX_PERIODS`) whose lock-in
    transient bound :func:`lockin_error` is ≤ :data:`LOCKIN_SHARE` × ``accuracy``: after the
    default settle of 10 τ_max, 1 period at E0/E_inf = 10 for any accuracy ≥ 5e-4 (a lock-in
    over whole periods of the periodic steady state is exact for every harmonic; more periods
    only average the transient down). The stated error ``error_estimate`` = the stepper's
    measured error (:func:`_stepper_error`) + ``lockin_error``; ``tol`` sets the former,
    ``accuracy`` only the periods.

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
    periods : int, optional
        Whole periods demodulated after settling (≥ 1); default chosen per ω from ``accuracy``.
    accuracy : float, optional
        Relative error of k* the periods are chosen for, in [1e-4, 0.1] (default 1e-3); not
        with ``periods``.
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
        Spectrum with ``method = "time-domain"``; over ``omega``: ``steps`` (time steps),
        ``periods`` (demodulated), ``lockin_error`` and, for the adaptive exponential stepper
        at tol within 0.1–10 × 1e-5 η, ``error_estimate`` (relative error bounds of k*).

    Raises
    ------
    ParameterError
        If an argument is missing or out of range (the message names it and the range), both
        ``periods`` and ``accuracy`` are given, or ``settle`` is too short for ``accuracy``.
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
    if periods is not None:
        periods = require_int("periods", periods, 1)
        if accuracy is not None:
            raise ParameterError("give periods or accuracy (which chooses them), not both")
    accuracy = require_accuracy(DEFAULT_ACCURACY if accuracy is None else accuracy)
    samples = require_int("samples_per_period", samples_per_period, 8)
    n_jobs = require_int("n_jobs", n_jobs, 1)
    stepper_class = _stepper_class(stepper)
    plural = "frequency" if omega.size == 1 else "frequencies"
    if periods is None:  # before the chooser's lock-in bounds (one row of ~300 θ per frequency)
        check_effort(f"output samples of the time-domain sweep ({omega.size} {plural} x {samples} "
                     "samples_per_period, one period at least)",
                     omega.size * samples, MAX_SAMPLES,
                     hint="fewer frequencies or samples_per_period; the small-amplitude spectrum "
                          "needs no time stepping (method 'linear')")
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
    if periods is None:
        periods, bound = _choose_periods(problem, omega, settle, accuracy)
    else:
        periods, bound = np.full(omega.shape, periods), lockin_error(problem, omega, settle,
                                                                     periods)
    steps, basis = _sweep_steps(problem, stepper_class, omega, periods, settle, samples,
                                steps_per_period)
    _check_sweep_effort(
        "the time-domain sweep", steps, basis, samples, periods, omega.size,
        hint="fewer or lower frequencies, a shorter settle or fewer periods; the small-amplitude "
             "spectrum needs no time stepping (method 'linear')")
    problem.check_covers(position - eta)
    args = [(problem, position, eta, float(w), int(n), settle, samples, tol, stepper,
             steps_per_period) for w, n in zip(omega, periods, strict=True)]
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
    stepper_error = _stepper_error(stepper_class, steps_per_period, tol, eta)
    attrs.update({"method": "time-domain", "position": position, "eta": eta,
                  "accuracy": accuracy, "settle": settle, "samples_per_period": samples,
                  "tol": tol, "stepper": stepper_class.name,
                  "steps_per_period": 0 if steps_per_period is None else steps_per_period})
    ds = make_spectrum(omega, k, mean, eta, attrs=attrs)
    variables = {"steps": ([r[2] for r in results], "time steps taken"),
                 "periods": (periods, "whole periods demodulated"),
                 "lockin_error": (bound, "bound on the relative error of k* the start-up "
                                         "transient leaves in the lock-in (linear theory)")}
    if stepper_error is not None:
        variables["error_estimate"] = (stepper_error + bound, "estimated relative error of k*: "
                                       "the stepper's (measured, x 2) + lockin_error")
    for name, (values, long_name) in variables.items():
        ds[name] = xr.DataArray(np.asarray(values), dims="omega",
                                attrs={"units": "1", "long_name": long_name})
    return ds


#: Spectrum routes: name → function(problem, position, eta, omega, **options).
SPECTRUM_METHODS = {"linear": linear_response, "time-domain": sweep, "svda": svda_spectrum,
                    "svda-ode": svda_sweep, "contact": contact_spectrum}
#: Options of the time-domain route that ``method="auto"`` sets itself.
_AUTO_CHOOSES = {"tol", "stepper", "steps_per_period"}
#: Routes that take options (the time-domain ones).
_WITH_OPTIONS = ("time-domain", "svda-ode")


def spectrum(problem: ContactProblem, position: float, eta: float, omega: ArrayLike, *,
             method: str = "auto", accuracy: float | None = None, branch: str | None = None,
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
        Required relative error of ``"auto"`` (default 1e-3); with ``"time-domain"``, the one
        :func:`sweep` chooses its periods for; not with the other routes.
    branch : {"approach", "retract"}, optional
        With an attractive (Lennard-Jones) law only: the quasi-static history that chooses the
        static state at ``position`` (default "approach"); the spectrum is then the exact
        small-amplitude response about it
        (:func:`~viscoforce.experiments.adhesive_spectrum.adhesive_linear_response`), the one
        route for such a law ("linear", or "auto" choosing it).
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
    n_omega = int(np.size(omega))
    check_effort(f"frequencies of spectrum ({n_omega} requested)", n_omega, MAX_SAMPLES,
                 hint="request fewer frequencies")
    if _adhesive(problem):
        return _adhesive_spectrum(problem, position, eta, omega, method, accuracy, branch,
                                  options)
    if branch is not None:
        raise ParameterError("branch applies to an attractive (Lennard-Jones) law only: a "
                             f"repulsive law has one equilibrium at every h0, got {branch!r}")
    if accuracy is not None and method not in ("auto", "time-domain"):
        raise ParameterError(f"accuracy applies to method 'auto' only (and 'time-domain', whose "
                             f"periods it chooses), not {method!r}")
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
    if method == "time-domain" and options.get("periods") is None:
        options = {**options, "periods": None, "accuracy": accuracy if choice is None
                   else choice.accuracy}
    if choice is None:
        ds = SPECTRUM_METHODS[method](problem, position, eta, omega, **options)
    else:
        if "grid_factor" in choice.options:  # a coarser grid meets the accuracy
            problem = coarsened(problem, choice.options["grid_factor"])
        with warnings.catch_warnings():  # the choice weighed the approximations' estimates
            warnings.simplefilter("ignore", ApproximationWarning)
            ds = SPECTRUM_METHODS[method](problem, position, eta, omega, **options)
        ds.attrs["explanation"] = choice.explanation  # + the periods' lock-in bound, if any
        ds.attrs["estimated_error"] = choice.estimated_error + float(
            ds["lockin_error"].max()) if "lockin_error" in ds else choice.estimated_error
        ds.attrs["accuracy"] = choice.accuracy
    return ds


def _adhesive(problem: ContactProblem) -> bool:
    from viscoforce.solvers.continuation import lennard_jones_term

    return isinstance(problem, ContactProblem) and lennard_jones_term(
        problem.surface_force) is not None


def _adhesive_spectrum(problem: ContactProblem, position: float, eta: float, omega: ArrayLike,
                       method: str, accuracy: float | None, branch: str | None,
                       options: dict) -> xr.Dataset:
    """:func:`spectrum` of an attractive law: the linear response about the ``branch`` state."""
    from viscoforce.experiments.adhesive_spectrum import adhesive_linear_response

    if method not in ("auto", "linear"):
        raise ParameterError(
            f"method {method!r} is not available with an attractive (Lennard-Jones) law: its "
            "spectrum is the exact small-amplitude response about a static branch (method "
            "'linear' or 'auto'); for a finite amplitude simulate the sinusoidal drive "
            "(viscoforce.simulate) and demodulate it")
    if options:
        raise TypeError(f"method {method!r} takes no options, got {sorted(options)}")
    if accuracy is not None and method != "auto":
        raise ParameterError(f"accuracy applies to method 'auto' only, not {method!r}")
    ds = adhesive_linear_response(problem, position, eta, omega,
                                  branch="approach" if branch is None else branch)
    if method == "auto":
        ds.attrs["explanation"] = (
            f"attractive law: the exact small-amplitude response about the "
            f"{ds.attrs['branch']} history's static state ({ds.attrs['on_branch']} branch), the "
            "one route for an adhesive contact")
        ds.attrs["estimated_error"] = 0.0
    return ds
