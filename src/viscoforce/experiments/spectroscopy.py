"""Force spectroscopy: sinusoidal drive, simulation to steady state, lock-in, Spectrum dataset.

Three routes to the same Spectrum (SPEC convention: ``phase`` χ = lead of the force over the
compression, ``stiffness`` = |F1|/η, ``amplitude`` a = |F1|/F̄):

* :func:`sweep` — time domain: h0(t) = h̄0 + η sin ωt from the static E_inf state, simulated with
  the exact solver for a settling time and then ``periods`` whole periods, demodulated by
  :func:`viscoforce.lockin.demodulate`. Valid at any η (it includes the nonlinear response).
* :func:`~viscoforce.experiments.linear_response.linear_response` — exact small-η response in the
  frequency domain (one complex solve per ω).
* :func:`svda_spectrum` — the SVDA closed forms (paper Eqs. 23–26, Eq. 24 corrected), valid before
  contact.
"""

from __future__ import annotations

import math
import sys
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from viscoforce import closed_form
from viscoforce._validation import as_float_1d, require_int, require_positive
from viscoforce.exceptions import ParameterError
from viscoforce.experiments.drives import Sinusoid
from viscoforce.experiments.linear_response import linear_response
from viscoforce.lockin import demodulate
from viscoforce.physics.surface_forces import DoubleLayer, SumOfLaws
from viscoforce.problem import ContactProblem
from viscoforce.schema import make_spectrum
from viscoforce.solvers.simulate import simulate

#: Settling time before demodulation, in units of the longest creep time.
DEFAULT_SETTLE_TAUS = 10.0
#: Local error tolerance of the time-domain sweep, as a fraction of η.
DEFAULT_SWEEP_TOL = 1e-5


def _one_frequency(problem: ContactProblem, position: float, eta: float, omega: float,
                   periods: int, settle: float, samples: int, tol: float,
                   stepper: str, steps_per_period: int | None) -> tuple[complex, float, int]:
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


def sweep(problem: ContactProblem, position: float, eta: float, omega: ArrayLike, *,
          periods: int = 4, settle: float | None = None, samples_per_period: int = 64,
          tol: float | None = None, stepper: str = "exponential",
          steps_per_period: int | None = None, n_jobs: int = 1,
          progress: bool | None = None) -> xr.Dataset:
    """Time-domain force spectroscopy: simulate each ω to steady state and demodulate.

    Parameters
    ----------
    problem : ContactProblem
        System, material, grid (must reach ``position − eta``).
    position : float
        Mean position h̄0 [m].
    eta : float
        Drive amplitude η [m], > 0.
    omega : array_like
        Angular frequencies [rad/s], > 0.
    periods : int
        Whole periods demodulated after settling (≥ 1).
    settle : float, optional
        Settling time [s] before demodulation (rounded up to whole periods); default
        10 τ_max (the transient from the resting start decays as e^{−t/τ} or faster).
    samples_per_period : int
        Output samples per period fed to the lock-in (≥ 8).
    tol : float, optional
        Local error tolerance of the stepper [m]; default 1e-5·η.
    stepper : str
        Time stepper (see :func:`~viscoforce.solvers.simulate.simulate`).
    steps_per_period : int, optional
        Fixed time step of period/``steps_per_period`` (default: adaptive, or explicit Euler's
        default step); steps also land on every output, so a step coarser than
        period/``samples_per_period`` needs a matching ``samples_per_period``.
    n_jobs : int
        Worker processes for the frequencies (1: serial).
    progress : bool, optional
        Progress bar over the frequencies (default: when stderr is a terminal).

    Returns
    -------
    xarray.Dataset
        Spectrum with ``method = "time-domain"`` and the per-ω step counts in ``steps``.
    """
    eta = require_positive("eta", eta)
    omega = as_float_1d("omega", omega)
    if np.any(omega <= 0):
        raise ParameterError(f"omega must be > 0 rad/s, got min {omega.min()!r}")
    periods = require_int("periods", periods, 1)
    samples = require_int("samples_per_period", samples_per_period, 8)
    n_jobs = require_int("n_jobs", n_jobs, 1)
    taus = problem.material.prony().taus
    if settle is None:
        settle = DEFAULT_SETTLE_TAUS * (max(taus) if taus else 0.0)
    settle = float(settle)
    if settle < 0:
        raise ParameterError(f"settle must be >= 0 s, got {settle!r}")
    tol = DEFAULT_SWEEP_TOL * eta if tol is None else require_positive("tol", tol)
    if steps_per_period is not None:
        steps_per_period = require_int("steps_per_period", steps_per_period, 1)
    problem.check_covers(position - eta)
    args = [(problem, position, eta, float(w), periods, settle, samples, tol, stepper,
             steps_per_period) for w in omega]
    show = sys.stderr.isatty() if progress is None else progress
    if n_jobs > 1 and len(omega) > 1:
        with ProcessPoolExecutor(max_workers=n_jobs) as pool:
            results = list(_track(pool.map(_one_frequency, *zip(*args, strict=True)),
                                  len(args), show))
    else:
        results = list(_track((_one_frequency(*a) for a in args), len(args), show))
    k = np.array([r[0] for r in results])
    mean = np.array([r[1] for r in results])
    attrs = dict(problem.parameters())
    attrs.update({"method": "time-domain", "position": float(position), "eta": eta,
                  "periods": periods, "settle": settle, "samples_per_period": samples,
                  "tol": tol, "stepper": stepper,
                  "steps_per_period": 0 if steps_per_period is None else steps_per_period,
                  "phase_convention": "force leads compression, degrees"})
    ds = make_spectrum(omega, k, mean, eta, attrs=attrs)
    ds["steps"] = xr.DataArray(np.array([r[2] for r in results]), dims="omega",
                               attrs={"units": "1", "long_name": "time steps taken"})
    return ds


def _track(iterable, total: int, show: bool):
    if not show:
        return iterable
    from tqdm.auto import tqdm

    return tqdm(iterable, total=total, desc="spectrum", unit="ω", leave=False)


def svda_spectrum(problem: ContactProblem, position: float, eta: float,
                  omega: ArrayLike) -> xr.Dataset:
    """SVDA closed-form spectrum (paper Eqs. 23–26, Eq. 24 corrected; pre-contact only).

    Requires a standard linear solid and a double-layer law (the soft wall is ignored by the SVDA).
    """
    material = problem.material
    prony = material.prony()
    if prony.n_modes != 1:
        raise ParameterError(
            f"the SVDA closed form needs a single-relaxation-time material, got {prony.n_modes} "
            "modes; use method 'linear'")
    law = problem.surface_force
    layers = [t for t in (law.terms if isinstance(law, SumOfLaws) else (law,))
              if isinstance(t, DoubleLayer)]
    if len(layers) != 1:
        raise ParameterError("the SVDA closed form needs exactly one DoubleLayer term")
    dl = layers[0]
    omega = as_float_1d("omega", omega)
    eta = require_positive("eta", eta)
    resp = closed_form.svda_harmonic_response(
        omega, position, eta, material.instantaneous_modulus, material.relaxed_modulus,
        prony.taus[0], problem.sphere.radius, dl.P, dl.debye_length)
    central_gap = position - float(resp.u0)
    if central_gap < dl.debye_length:
        raise ParameterError(
            f"the SVDA closed form holds before contact only: at position {position:.3g} m its "
            f"central gap {central_gap:.3g} m is below the Debye length {dl.debye_length:.3g} m; "
            "use method 'linear' (exact) here")
    k = resp.stiffness * np.exp(1j * np.radians(resp.phase))
    attrs = dict(problem.parameters())
    attrs.update({"method": "svda", "position": float(position), "eta": eta,
                  "svda_c": float(resp.c), "svda_u0": float(resp.u0),
                  "phase_convention": "force leads compression, degrees"})
    return make_spectrum(omega, k, resp.mean_force, eta, attrs=attrs)


SPECTRUM_METHODS = {"linear": linear_response, "time-domain": sweep, "svda": svda_spectrum}

#: κη at or below which the small-amplitude (linear) spectrum is used by ``method="auto"``.
LINEAR_KAPPA_ETA = 0.05


def choose_spectrum_method(problem: ContactProblem, eta: float) -> tuple[str, str]:
    """The cheapest adequate spectrum method for drive amplitude ``eta`` [m], with the reason.

    The nonlinear correction to the first-harmonic stiffness is O((κη)²), with κ the inverse decay
    length of the surface force: for κη ≤ :data:`LINEAR_KAPPA_ETA` the exact small-amplitude
    solve (``"linear"``) is used, otherwise each frequency is simulated (``"time-domain"``).

    Parameters
    ----------
    problem : ContactProblem
        System (its surface force sets κ).
    eta : float
        Drive amplitude η [m], > 0.

    Returns
    -------
    tuple of str
        The method name (a key of :data:`SPECTRUM_METHODS`) and a one-sentence explanation.
    """
    eta = require_positive("eta", eta)
    kappa_eta = eta / problem.surface_force.decay_length
    if kappa_eta <= LINEAR_KAPPA_ETA:
        return "linear", (f"kappa*eta = {kappa_eta:.3g} <= {LINEAR_KAPPA_ETA:g}: the nonlinear "
                          f"correction to the stiffness is O((kappa*eta)^2) ~ {kappa_eta ** 2:.1e}, "
                          "so the exact small-amplitude frequency-domain solve is used")
    return "time-domain", (f"kappa*eta = {kappa_eta:.3g} > {LINEAR_KAPPA_ETA:g}: the response is not "
                           "linear enough, so each frequency is simulated to steady state and "
                           "demodulated")


def spectrum(problem: ContactProblem, position: float, eta: float, omega: ArrayLike, *,
             method: str = "auto", **options: object) -> xr.Dataset:
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
    method : {"auto", "linear", "time-domain", "svda"}
        The route (see :data:`SPECTRUM_METHODS`); ``"auto"`` uses
        :func:`choose_spectrum_method` and stores its reason in ``attrs["explanation"]``.
    **options
        Passed to the time-domain :func:`sweep` (``periods``, ``n_jobs``, ``progress``, ...);
        only accepted when that route runs.

    Returns
    -------
    xarray.Dataset
        Spectrum; ``attrs["method"]`` is the route used.

    Raises
    ------
    ParameterError
        Unknown method.
    TypeError
        Options given to a route that takes none.
    """
    if method != "auto" and method not in SPECTRUM_METHODS:
        raise ParameterError(
            f"method must be 'auto' or one of {sorted(SPECTRUM_METHODS)}, got {method!r}")
    explanation = ""
    if method == "auto":
        method, explanation = choose_spectrum_method(problem, eta)
        if method != "time-domain":
            options = {}  # time-domain options do not apply to the route chosen
    if options and method != "time-domain":
        raise TypeError(f"method {method!r} takes no options, got {sorted(options)}")
    ds = SPECTRUM_METHODS[method](problem, position, eta, omega, **options)
    if explanation:
        ds.attrs["explanation"] = explanation
    return ds
