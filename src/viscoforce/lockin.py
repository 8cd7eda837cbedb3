"""Lock-in demodulation of oscillatory traces (measured or simulated).

Two ways to extract the complex amplitude of harmonic ``n`` of a drive at angular frequency ω:

* :func:`demodulate` (and :func:`harmonics`) — a block average over the largest whole number of
  drive periods that fits after a settling time, i.e. a single-bin Fourier coefficient computed with
  a spectrally accurate quadrature. This is what the spectroscopy sweep uses.
* :func:`lockin_filter` — what an analogue/digital lock-in amplifier does: mix with e^{−inωt} and
  low-pass with a cascade of RC stages; :func:`settling_time` says when the output may be read.

Complex-amplitude convention (e^{+iωt}, as everywhere in viscoforce)::

    x(t) ≈ mean + Re[X̂ e^{i n ω t}],    X̂ = (2/T) ∫_window x(t) e^{−i n ω t} dt,

with ``t`` the absolute time of the samples (not the time since the window start), so that
``A cos(ωt + φ)`` demodulates to ``A e^{iφ}``. Harmonic 0 is the mean (1/T)∫x dt, not twice it.
The spectroscopy convention of the SPEC writes the first harmonic with a sine,
x = mean + |X̂| sin(ωt + ψ), which is the same as X̂ = |X̂| e^{i(ψ − π/2)}; :func:`sin_phase`
converts X̂ to ψ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from viscoforce._validation import (
    describe_value,
    require_in_range,
    require_increasing,
    require_int,
    require_nonnegative,
    require_positive,
)
from viscoforce.exceptions import ParameterError

__all__ = ["demodulate", "harmonics", "sin_phase", "amplitude_phase_from_complex",
           "demodulate_dataarray", "lockin_filter", "settling_time", "transient_leakage"]

Detrend = Literal["linear"] | None

#: Fraction of a period by which the record may fall short of a whole number of periods and still
#: count as having it (absorbs rounding in ``time``).
_PERIOD_SLACK = 1e-9
#: Samples closer than this fraction of the node spacing to the quadrature nodes are used as-is.
_ALIGN_RTOL = 1e-8
#: Relative spread of the sampling interval tolerated by :func:`lockin_filter`.
_UNIFORM_RTOL = 1e-6


@dataclass(frozen=True)
class _Window:
    """Signal resampled on a uniform grid spanning exactly ``periods`` drive periods.

    ``values`` has the time axis last; ``nodes`` [s] run from the window start to the last sample;
    ``weights`` [s] are the trapezoid weights; ``duration`` = periods·2π/ω [s].
    """

    values: NDArray[np.float64]
    nodes: NDArray[np.float64]
    weights: NDArray[np.float64]
    duration: float
    periods: int
    per_period: int


def _signal_last_axis(name: str, signal: ArrayLike, n_time: int, axis: int) -> NDArray[np.float64]:
    """Return ``signal`` as a float array with ``axis`` moved last, after checking it."""
    arr = np.asarray(signal)
    if np.iscomplexobj(arr):
        raise ParameterError(f"{name} must be real, got dtype {arr.dtype}")
    try:
        arr = arr.astype(float, copy=False)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be an array of real numbers, got dtype {arr.dtype}"
                             ) from None
    if arr.ndim == 0:
        raise ParameterError(f"{name} must have a time axis, got a scalar")
    if isinstance(axis, bool) or not isinstance(axis, int | np.integer):
        raise ParameterError(f"axis must be an integer, got {axis!r}")
    if not -arr.ndim <= axis < arr.ndim:
        raise ParameterError(
            f"axis must be in [{-arr.ndim}, {arr.ndim - 1}] for a {arr.ndim}-D {name}, "
            f"got {axis}")
    arr = np.moveaxis(arr, axis, -1)
    if arr.shape[-1] != n_time:
        raise ParameterError(
            f"{name} has {arr.shape[-1]} samples along axis {axis} but time has {n_time}; "
            "they must match")
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ParameterError(
            f"{name} must be finite (no NaN/inf); found {arr[tuple(bad)]!r} at sample "
            f"{int(bad[-1])} along the time axis")
    return arr


def _check_detrend(detrend: object) -> Detrend:
    """Return ``detrend``, raising unless it is None or the string ``"linear"``."""
    if detrend is not None and not (isinstance(detrend, str) and detrend == "linear"):
        raise ParameterError(
            f"detrend must be None or 'linear', got {describe_value(detrend)}")
    return detrend


def _as_complex_amplitude(amplitude: ArrayLike) -> NDArray[np.complex128]:
    """Return ``amplitude`` as a complex array, raising unless it holds finite numbers."""
    kinds = "iufc"  # integers, floats, complex (not bool, text or objects)
    if amplitude is None or isinstance(amplitude, str | bytes | dict):
        arr = None
    else:
        try:
            arr = np.asarray(amplitude)
        except (TypeError, ValueError):
            arr = None
    if arr is None or arr.dtype.kind not in kinds:
        raise ParameterError(
            f"amplitude must be a complex number or an array of complex numbers, got "
            f"{describe_value(amplitude)}")
    z = arr.astype(complex, copy=False)
    if not np.all(np.isfinite(z)):
        bad = int(np.flatnonzero(~np.isfinite(z.ravel()))[0])
        raise ParameterError(
            f"amplitude must be finite (no NaN/inf); entry {bad} is {complex(z.ravel()[bad])!r}")
    return z


def _window(signal: ArrayLike, time: ArrayLike, omega: float, *, settle: float, axis: int,
            detrend: Detrend, max_harmonic: int) -> _Window:
    """Select the whole-period window, resample it on a uniform grid and optionally detrend it."""
    omega = require_positive("omega", omega)
    settle = require_nonnegative("settle", settle)
    detrend = _check_detrend(detrend)
    t = require_increasing("time", time)
    if t.size < 2:
        raise ParameterError(f"time needs at least 2 samples, got {t.size}")
    x = _signal_last_axis("signal", signal, t.size, axis)

    period = 2.0 * math.pi / omega
    available = t[-1] - (t[0] + settle)
    periods = math.floor(available / period + _PERIOD_SLACK) if available > 0 else 0
    if periods < 1:
        raise ParameterError(
            f"the record is {t[-1] - t[0]:.6g} s long; after settle = {settle:.6g} s only "
            f"{max(available, 0.0):.6g} s remain, less than one period 2π/omega = {period:.6g} s "
            "(record longer, settle less or raise omega)")
    if detrend == "linear" and periods < 2:
        raise ParameterError(
            f"detrend='linear' needs at least 2 whole periods after settle (one period is "
            f"{period:.6g} s, {available:.6g} s available); the trend is estimated from the "
            "change of the per-period means")
    duration = periods * period
    t_end = t[-1]
    t_start = t_end - duration

    # Samples from the last one at or before the window start onwards.
    first = max(int(np.searchsorted(t, t_start, side="right")) - 1, 0)
    per_period = max(round(period / float(np.median(np.diff(t[first:])))), 1)
    if per_period <= 2 * max_harmonic:
        raise ParameterError(
            f"sampling too coarse for harmonic {max_harmonic}: about {per_period} samples per "
            f"period, more than {2 * max_harmonic} are needed (Nyquist); sample faster")
    n_nodes = periods * per_period + 1
    spacing = period / per_period
    nodes = t_end - spacing * np.arange(n_nodes - 1, -1, -1)

    start = t.size - n_nodes
    if start >= 0 and np.max(np.abs(t[start:] - nodes)) <= _ALIGN_RTOL * spacing:
        nodes = t[start:]
        values = x[..., start:]
    else:
        from scipy.interpolate import CubicSpline

        spline = CubicSpline(t[first:], x[..., first:], axis=-1)
        values = spline(nodes)

    weights = np.full(n_nodes, spacing)
    weights[[0, -1]] = 0.5 * spacing

    if detrend == "linear":
        # Per-period means are exact for periodic content of any harmonic order plus a line, so
        # their slope is the drift alone (a least-squares line through the raw samples would also
        # pick up the oscillation's own projection on t and bias X̂).
        # trapezoid mean of each period: full weight inside, half weight on its two end nodes
        inner = values[..., :-1].reshape(*values.shape[:-1], periods, per_period).sum(axis=-1)
        ends = values[..., ::per_period]
        means = (inner - 0.5 * ends[..., :-1] + 0.5 * ends[..., 1:]) * (spacing / period)
        mids = t_start + (np.arange(periods) + 0.5) * period
        centred = mids - mids.mean()
        slope = (means @ centred) / (centred @ centred)
        values = values - slope[..., np.newaxis] * (nodes - 0.5 * (t_start + t_end))

    return _Window(values=values, nodes=nodes, weights=weights, duration=duration,
                   periods=periods, per_period=per_period)


def _project(win: _Window, omega: float, orders: NDArray[np.int_]) -> NDArray[np.complex128]:
    """Complex amplitudes of the given harmonic orders; the harmonic axis is last."""
    # The real signal against the real and imaginary parts of e^{-inωt} (no complex copy of the
    # signal); order 0 is the plain weighted sum (cos 0 = 1, sin 0 = 0: no trigonometry).
    weights = win.weights[:, np.newaxis]
    cos = np.repeat(weights, orders.size, axis=1)
    sin = np.zeros_like(cos)
    moving = np.flatnonzero(orders != 0)
    if moving.size:
        phase = np.outer(win.nodes * omega, orders[moving])
        cos[:, moving] = weights * np.cos(phase)
        sin[:, moving] = weights * np.sin(phase)
    projected = win.values @ cos - 1j * (win.values @ sin)
    scale = np.where(orders == 0, 1.0, 2.0) / win.duration
    return projected * scale


def demodulate(signal: ArrayLike, time: ArrayLike, omega: float, *, harmonic: int = 1,
               settle: float = 0.0, axis: int = -1, detrend: Detrend = None
               ) -> NDArray[np.complex128] | np.complex128:
    r"""Complex amplitude of harmonic ``n`` over the whole drive periods after a settling time.

    The window is the largest whole number ``m`` of periods 2π/ω of the fundamental that fits
    between ``time[0] + settle`` and the last sample, and it ends at the last sample. Over it,

    .. math:: \hat X_n = \frac{2}{T}\int_{t_e - T}^{t_e} x(t)\, e^{-i n \omega t}\, dt,
              \qquad T = 2\pi m/\omega,

    so that ``x(t) ≈ mean + Re[X̂ e^{inωt}]`` and ``A cos(nωt + φ)`` gives ``A e^{iφ}``. ``t`` is the
    absolute time, not the time since the window start. Harmonic 0 returns the mean
    (1/T)∫x dt (not twice it).

    Quadrature: the integral is taken with the trapezoid rule on a uniform grid of ``q`` nodes per
    period (``q`` = period / median sampling interval, rounded) spanning exactly the window. When
    the samples already sit on that grid (to 1e-8 of a sampling interval), they are used as they
    are and the result is exact to rounding for any trigonometric polynomial below the Nyquist
    frequency. Otherwise the samples are resampled on the grid with a not-a-knot cubic spline
    (which also handles non-uniform sampling); the error for a pure sinusoid is then at most
    ≈ (ωΔt)⁴/500 relative, e.g. 5e-7 at 50 samples per period (2e-5 at 20). Only samples from
    the last one at or before the window start onwards are used.

    Parameters
    ----------
    signal : array_like
        Real samples x(t_k), any unit [u]; N-D allowed, time along ``axis``.
    time : array_like
        Sample times t_k [s], 1-D, strictly increasing, same length as ``signal`` along ``axis``.
    omega : float
        Fundamental (drive) angular frequency ω [rad/s], > 0.
    harmonic : int, optional
        Harmonic order n ≥ 0 [1]; 1 is the fundamental, 0 the mean.
    settle : float, optional
        Time after ``time[0]`` to discard before the window may start [s], ≥ 0.
    axis : int, optional
        Axis of ``signal`` that runs along ``time``.
    detrend : {None, "linear"}, optional
        ``"linear"`` removes a linear drift before demodulating. The drift's slope is the
        least-squares slope of the per-period means (exact for a line plus any periodic signal;
        needs m ≥ 2); the line through the window centre is subtracted, so the mean (harmonic 0)
        is unchanged. Without it a drift c·t biases harmonic n by 2ic e^{−inωt_s}/(nω), t_s the
        window start.

    Returns
    -------
    numpy.ndarray or numpy.complex128
        X̂_n [u], complex, of shape ``signal.shape`` without ``axis`` (a complex scalar for a 1-D
        signal).

    Raises
    ------
    ParameterError
        If omega ≤ 0, harmonic is not an integer ≥ 0, settle < 0, time is not strictly increasing
        or finite, the signal is complex, not finite or does not match ``time``, fewer than one
        whole period (two with ``detrend``) remains after ``settle``, or there are no more than
        2n samples per period.
    """
    harmonic = require_int("harmonic", harmonic, 0)
    win = _window(signal, time, omega, settle=settle, axis=axis, detrend=detrend,
                  max_harmonic=harmonic)
    out = _project(win, float(omega), np.array([harmonic]))[..., 0]
    return out[()]


def harmonics(signal: ArrayLike, time: ArrayLike, omega: float, n_max: int, *,
              settle: float = 0.0, axis: int = -1, detrend: Detrend = None
              ) -> NDArray[np.complex128]:
    """Complex amplitudes of harmonics 0, 1, …, ``n_max`` over the same window.

    Same window, quadrature and conventions as :func:`demodulate` (entry 0 is the mean), computed
    from a single resampling of the signal.

    Parameters
    ----------
    signal : array_like
        Real samples x(t_k) [u]; N-D allowed, time along ``axis``.
    time : array_like
        Sample times [s], 1-D, strictly increasing.
    omega : float
        Fundamental angular frequency ω [rad/s], > 0.
    n_max : int
        Highest harmonic order [1], ≥ 0; needs more than 2·n_max samples per period.
    settle : float, optional
        Time after ``time[0]`` to discard [s], ≥ 0.
    axis : int, optional
        Axis of ``signal`` that runs along ``time``.
    detrend : {None, "linear"}, optional
        See :func:`demodulate`.

    Returns
    -------
    numpy.ndarray
        Complex array [u] of shape ``signal.shape`` without ``axis`` plus a trailing axis of
        length ``n_max + 1`` indexed by the harmonic order.

    Raises
    ------
    ParameterError
        As :func:`demodulate`, with ``n_max`` in place of ``harmonic``.
    """
    n_max = require_int("n_max", n_max, 0)
    win = _window(signal, time, omega, settle=settle, axis=axis, detrend=detrend,
                  max_harmonic=n_max)
    return _project(win, float(omega), np.arange(n_max + 1))


def transient_leakage(omega: ArrayLike, time_constant: ArrayLike, start: ArrayLike,
                      periods: ArrayLike) -> NDArray[np.float64]:
    """|X̂₁| that a decaying transient x(t) = e^{−t/θ} leaks into :func:`demodulate`.

    Over ``m`` whole periods from ``start`` (T = 2πm/ω; exact for the integral; broadcasting),
    |X̂₁| = (2θ/T) e^{−t_s/θ} (1 − e^{−T/θ}) / √(1 + (ωθ)²): more periods help where T ≳ θ.

    Parameters
    ----------
    omega : array_like
        Drive angular frequency ω [rad/s], > 0.
    time_constant : array_like
        Decay time θ of the transient [s], > 0.
    start : array_like
        Window start t_s, counted from the transient's start [s], ≥ 0.
    periods : array_like
        Whole periods m demodulated, ≥ 1.

    Returns
    -------
    numpy.ndarray
        |X̂₁| per unit transient amplitude [1].

    Raises
    ------
    ParameterError
        If an argument is not finite or out of its range (the message names it).
    """
    w, theta, t0, m = np.broadcast_arrays(*(np.asarray(v, dtype=float)
                                            for v in (omega, time_constant, start, periods)))
    for name, v, ok, limit in (("omega", w, w > 0, "> 0 [rad/s]"), ("periods", m, m >= 1, ">= 1"),
                               ("time_constant", theta, theta > 0, "> 0 [s]"),
                               ("start", t0, t0 >= 0, ">= 0 [s]")):
        if not np.all(good := ok & np.isfinite(v)):
            raise ParameterError(f"{name} must be finite and {limit}, got {float(v[~good][0])!r}")
    ratio = 2.0 * math.pi * m / (w * theta)  # T/θ
    return 2.0 * np.exp(-t0 / theta) * -np.expm1(-ratio) / (ratio * np.hypot(1.0, w * theta))


def sin_phase(amplitude: ArrayLike) -> NDArray[np.float64] | np.float64:
    """Phase ψ of the sine convention x = mean + |X̂| sin(nωt + ψ) [rad], in (−π, π].

    Since sin θ = Re e^{i(θ − π/2)}, the complex amplitude of :func:`demodulate` is
    X̂ = |X̂| e^{i(ψ − π/2)}, hence ψ = arg X̂ + π/2 (wrapped). This is the ψ of the SPEC's
    spectroscopy convention F ≈ F̄ + |F1| sin(ωt + ψ).

    Parameters
    ----------
    amplitude : array_like
        Complex amplitude(s) X̂ from :func:`demodulate` [any unit].

    Returns
    -------
    numpy.ndarray or numpy.float64
        ψ [rad] in (−π, π], same shape as ``amplitude``.

    Raises
    ------
    ParameterError
        If ``amplitude`` is not numeric (None, text, objects) or holds NaN or ±inf.
    """
    return np.angle(1j * _as_complex_amplitude(amplitude))[()]


def amplitude_phase_from_complex(amplitude: ArrayLike
                                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Modulus |X̂| and sine-convention phase ψ of complex amplitude(s).

    x = mean + |X̂| sin(nωt + ψ) ⇔ X̂ = |X̂| e^{i(ψ − π/2)}; see :func:`sin_phase`.

    Parameters
    ----------
    amplitude : array_like
        Complex amplitude(s) X̂ [u].

    Returns
    -------
    modulus : numpy.ndarray
        |X̂| [u].
    phase : numpy.ndarray
        ψ [rad] in (−π, π].

    Raises
    ------
    ParameterError
        If ``amplitude`` is not numeric (None, text, objects) or holds NaN or ±inf.
    """
    z = _as_complex_amplitude(amplitude)
    return np.abs(z), np.angle(1j * z)


def _demodulate_blocks(signal: NDArray[np.float64], time: NDArray[np.float64],
                       omega: float | NDArray[np.float64], *, harmonic: int, settle: float,
                       detrend: Detrend) -> NDArray[np.complex128]:
    """Core for :func:`demodulate_dataarray`: time last; ``time`` and ``omega`` broadcastable."""
    t = np.asarray(time)
    t = t[(0,) * (t.ndim - 1)]
    w = np.asarray(omega, dtype=float)
    if w.size == 1:
        return np.asarray(demodulate(signal, t, float(w.reshape(())), harmonic=harmonic,
                                     settle=settle, detrend=detrend))
    w = np.broadcast_to(w, signal.shape[:-1])
    out = np.empty(signal.shape[:-1], dtype=complex)
    for idx in np.ndindex(out.shape):
        out[idx] = demodulate(signal[idx], t, float(w[idx]), harmonic=harmonic, settle=settle,
                              detrend=detrend)
    return out


def demodulate_dataarray(da: xr.DataArray, omega: float | xr.DataArray, *, dim: str = "time",
                         harmonic: int = 1, settle: float = 0.0, detrend: Detrend = None
                         ) -> xr.DataArray:
    """Labelled wrapper of :func:`demodulate` over dimension ``dim`` of a DataArray.

    Vectorises over every other dimension (e.g. ``x``, ``y``, ``omega`` of a spectrum) through
    :func:`xarray.apply_ufunc`; dask-backed arrays stay lazy (``dim`` is rechunked into one chunk).

    Parameters
    ----------
    da : xarray.DataArray
        Real signal [u] with a numeric coordinate ``dim`` holding the sample times [s].
    omega : float or xarray.DataArray
        Fundamental angular frequency [rad/s], > 0: a scalar, or a DataArray without ``dim``
        broadcast against the other dimensions of ``da`` (e.g. one ω per spectrum point).
    dim : str, optional
        Name of the time dimension.
    harmonic : int, optional
        Harmonic order n ≥ 0 [1]; 0 gives the mean.
    settle : float, optional
        Time after the first sample to discard [s], ≥ 0.
    detrend : {None, "linear"}, optional
        See :func:`demodulate`.

    Returns
    -------
    xarray.DataArray
        Complex amplitudes X̂ [u] with the dims of ``da`` minus ``dim``; attrs ``harmonic`` and
        (if ``da`` has one) ``units``.

    Raises
    ------
    ParameterError
        If ``da`` is not a DataArray, ``dim`` is not one of its dimensions or has no coordinate,
        omega is not positive and finite or a DataArray omega carries ``dim``; otherwise as
        :func:`demodulate`.
    """
    if not isinstance(da, xr.DataArray):
        raise ParameterError(f"da must be an xarray.DataArray, got {type(da).__name__}")
    if not isinstance(dim, str) or dim not in da.dims:
        raise ParameterError(
            f"dim must be one of the dimensions {tuple(da.dims)}, got {describe_value(dim)}")
    if dim not in da.coords:
        raise ParameterError(f"da needs a coordinate {dim!r} holding the sample times [s]")
    harmonic = require_int("harmonic", harmonic, 0)
    settle = require_nonnegative("settle", settle)
    detrend = _check_detrend(detrend)
    if isinstance(omega, xr.DataArray):
        if dim in omega.dims:
            raise ParameterError(f"omega must not vary along {dim!r}, got dims {omega.dims}")
        values = np.asarray(omega.values, dtype=float)
        if not np.all(np.isfinite(values) & (values > 0)):
            raise ParameterError("omega must be > 0 and finite everywhere")
    else:
        omega = require_positive("omega", omega)
    if da.chunks is not None:
        da = da.chunk({dim: -1})
    result = xr.apply_ufunc(
        _demodulate_blocks, da, da[dim], omega,
        kwargs={"harmonic": harmonic, "settle": settle, "detrend": detrend},
        input_core_dims=[[dim], [dim], []], output_core_dims=[[]],
        dask="parallelized", output_dtypes=[complex])
    result.attrs = {"long_name": f"complex amplitude of harmonic {harmonic}",
                    "harmonic": harmonic}
    if "units" in da.attrs:
        result.attrs["units"] = da.attrs["units"]
    return result.rename(da.name)


def lockin_filter(signal: ArrayLike, time: ArrayLike, omega: float, *, time_constant: float,
                  order: int = 4, harmonic: int = 1, axis: int = -1) -> NDArray[np.complex128]:
    """Lock-in amplifier output at every sample: mix down, then low-pass with RC stages.

    The signal is mixed with 2 e^{−inωt} (1 for n = 0) and passed through ``order`` cascaded
    first-order RC stages of time constant τ, each discretised exactly for uniform sampling
    Δt as y_k = y_{k−1} + (1 − e^{−Δt/τ})(z_k − y_{k−1}), starting from y = 0. A clean
    ``A cos(nωt + φ)`` gives A e^{iφ} after :func:`settling_time` up to a ripple at 2nω reduced
    by about (1 + (2nωτ)²)^{−order/2}; white noise is reduced by the filter's equivalent noise
    bandwidth.

    Parameters
    ----------
    signal : array_like
        Real samples [u]; N-D allowed, time along ``axis``.
    time : array_like
        Uniformly spaced, strictly increasing sample times [s] (relative spread of Δt ≤ 1e-6).
    omega : float
        Reference angular frequency ω [rad/s], > 0.
    time_constant : float
        RC time constant τ of each stage [s], > 0.
    order : int, optional
        Number of cascaded RC stages [1], ≥ 1 (filter slope 6·order dB/octave).
    harmonic : int, optional
        Harmonic order n ≥ 0 [1] of the reference.
    axis : int, optional
        Axis of ``signal`` that runs along ``time``.

    Returns
    -------
    numpy.ndarray
        Complex filtered output X̂(t_k) [u], same shape as ``signal``.

    Raises
    ------
    ParameterError
        If omega or time_constant ≤ 0, order < 1, harmonic < 0, time is not strictly increasing
        and uniform, or the signal is complex, not finite or does not match ``time``.
    """
    from scipy.signal import lfilter

    omega = require_positive("omega", omega)
    time_constant = require_positive("time_constant", time_constant)
    order = require_int("order", order, 1)
    harmonic = require_int("harmonic", harmonic, 0)
    t = require_increasing("time", time)
    if t.size < 2:
        raise ParameterError(f"time needs at least 2 samples, got {t.size}")
    steps = np.diff(t)
    dt = float(steps.mean())
    if np.max(np.abs(steps - dt)) > _UNIFORM_RTOL * dt:
        raise ParameterError(
            f"time must be uniformly spaced for lockin_filter (relative spread ≤ "
            f"{_UNIFORM_RTOL:g}); intervals range from {steps.min():.6g} to {steps.max():.6g} s")
    x = _signal_last_axis("signal", signal, t.size, axis)
    gain = 1.0 if harmonic == 0 else 2.0
    y = gain * x * np.exp(-1j * harmonic * omega * t)
    alpha = -math.expm1(-dt / time_constant)
    for _ in range(order):
        y = lfilter([alpha], [1.0, alpha - 1.0], y, axis=-1)
    return np.moveaxis(y, -1, axis)


def settling_time(time_constant: float, order: int, accuracy: float = 1e-3) -> float:
    """Time after which a cascade of RC stages has settled to within ``accuracy`` of a step.

    The step response of ``order`` identical stages is the gamma CDF
    1 − Σ_{k<order} e^{−x} x^k/k!, x = t/τ; the returned time solves
    Σ_{k<order} e^{−x} x^k/k! = accuracy (``scipy.special.gammainccinv``). For one stage it is
    τ ln(1/accuracy); for 4 stages and 1e-3, 13.06 τ.

    Parameters
    ----------
    time_constant : float
        Time constant τ of each stage [s], > 0.
    order : int
        Number of stages [1], ≥ 1.
    accuracy : float, optional
        Remaining relative error of the step response [1], in (0, 1).

    Returns
    -------
    float
        Settling time [s].

    Raises
    ------
    ParameterError
        If time_constant ≤ 0, order < 1 or accuracy is outside (0, 1).
    """
    from scipy.special import gammainccinv

    time_constant = require_positive("time_constant", time_constant)
    order = require_int("order", order, 1)
    accuracy = require_in_range("accuracy", accuracy, 0.0, 1.0, inclusive=(False, False))
    return time_constant * float(gammainccinv(order, accuracy))
