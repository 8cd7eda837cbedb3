r"""Which height signal the phase of a modulation spectrum refers to: sensor, piezo or a delay.

The indentation δ = −height − deflection of :mod:`viscoforce.experiments.modulation` is built
from the calibrated height *sensor* where the file has one. A sensor measures where the scanner
is, but it may report it late (its electronics filter it). A delay τ_d of the sensor turns its first
harmonic by e^{−iωτ_d}, so the phase of the force over δ grows by about ωτ_d·|ĥ|/|δ̂| (the
share of the height in δ), an error that grows with frequency. The piezo ``height`` record (the
drive as applied) is not delayed by the sensor, but its amplitude is not the calibrated one
(on the real map it is 1/0.87 of the sensor's) and, in open loop, it misses the piezo's creep.

``phase_reference`` chooses how the height's first harmonic ĥ enters δ̂ = −ĥ − d̂ (d̂ the
deflection's, as measured), per modulation segment:

* ``"sensor"``: ĥ of the height channel as recorded (what every version before this did);
* ``"piezo"``: the sensor's amplitude with the piezo's phase, ĥ → |ĥ|·e^{i arg ĥ_p};
* ``"delay"``: the sensor advanced by one delay τ_d fitted per map (shared by all curves),
  ĥ → ĥ·e^{iωτ_d}.

The sensor–piezo phase difference φ = arg(ĥ/ĥ_p) of every segment, with its standard error
σ_φ (the residual-spectrum errors of both records, their correlation kept), is fitted by
φ = −ωτ_d in weighted least squares (weights 1/σ_φ²): τ_d = −Σwωφ/Σwω², statistical stderr
(Σwω²)^{−1/2}. Where the pure delay does not describe the differences within their errors
(χ²/dof > 1) that stderr is multiplied by the Birge ratio √(χ²/dof) (:class:`SensorDelay`).

Errors. F̂, δ̂, ĥ and ĥ_p are demodulated over one window, and the residual band around the
drive gives the covariance C of their errors (:func:`~viscoforce.experiments._demodulation.
_covariances`). The relative error of k* = F̂/δ̂′ per component is ρ² = c·C·c^H with
c = (1/F̂, −1/δ̂′, −a/δ̂′, −b/δ̂′) for δ̂′ = δ̂ + a·ĥ + b·ĥ_p (piezo: a = 1, b = −|ĥ|/|ĥ_p|;
delay: a = 1 − e^{iωτ_d}, b = 0, the drive frequency standing for the band's), plus one term
along ĥ′: the error of the amplitude ratio |ĥ|/|ĥ_p| (piezo) or of τ_d (delay: ω|ĥ|σ_τ,
common to every point of the map), given whole to both components (conservative: it lies
mostly along one of them). ``drive_amplitude`` = |δ̂′| and its error likewise. In ``"sensor"``
mode every number is the one :mod:`viscoforce.experiments.modulation` always gave.

Default (``phase_reference`` None or ``"auto"``), said in ``attrs["phase_reference_choice"]``:
``"sensor"`` where the height channel is not a sensor, where the data hold no piezo record (a
curves dataset without ``piezo_height``), or where a hard-surface reference spectrum is given
(it measures the lag against the sensor itself); else the delay is fitted and the default is
``"delay"`` when the sensor lags the piezo significantly (τ_d > 3 stderr, the stderr with its
Birge ratio), ``"sensor"`` otherwise. Why ``"delay"`` rather than ``"piezo"``: a sensor's lag
is causal and vanishes as ω → 0, while the part of the difference that does not vanish at low
frequency is the piezo's (open-loop creep: on the real map the sensor trails the piezo by
1.1–1.5° at 1–10 Hz and its amplitude ratio rises there, as creep makes it, where a lag of the
sensor would lower it); ``"piezo"`` would put that part into the phase, the fitted delay
(weighted by ω², so by the fast segments) leaves it out. And one τ_d for the map adds no
noise of its own per segment. ``"piezo"`` stays available to ask for.

On the real modulation map (``data_examples/real/modulation-map.jpk-force-map``, 16 curves, 1–300
Hz; ``tests/measured/test_phase_reference.py``) the sensor trails the piezo by 1.1, 1.5, 1.2,
2.1, 5.2 and 14.1° at 1, 3, 10, 30, 100 and 300 Hz, the same on every curve (±0.03–0.24°), and
its amplitude is 0.885, 0.889, 0.869, 0.866, 0.857, 0.854 of the piezo's. The pure delay
fitted to the 96 segments is τ_d = 0.139 ± 0.0027 ms (statistical 0.00011 ms × Birge ratio
24: χ²/dof = 5.6e4/95, the low-frequency part is not a delay; mean misfit at most 1.3°, at
3 Hz), 52 stderr from zero: the default is ``"delay"``. The 300 Hz phases fall from
104.5–109.8° (sensor) to 91.8–98.0° (delay; piezo 92.6–98.7°), still flagged, and the 300 Hz
stiffness rises by about 30 % (|δ̂| at 300 Hz is a small difference of height and deflection,
|d̂|/|ĥ| ≈ 0.8 there, so a 14° turn of ĥ changes it a lot). With ``tip="sphere:5um"`` the
measured-data chooser passes the χ² test (p ≥ 1e-3) on 15 of 16 curves with ``"delay"`` or
``"piezo"``, on 8 with ``"sensor"``; the structural damping exponent α of each curve is
0.082–0.177 (delay; piezo 0.077–0.172), and structural damping alone passes on 13 of 16.
A delay of the deflection detection chain, not seen by either height record, is not corrected.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.io.quality import SENSOR_CHANNELS, phase_basis

__all__ = ["PIEZO_VARIABLE", "REFERENCES", "SensorDelay", "check_phase_reference",
           "choose_reference", "fit_sensor_delay", "referred"]

#: The phase references one can ask for (besides None / "auto": the evidence decides).
REFERENCES = ("sensor", "piezo", "delay")
#: The variable of a curves dataset holding the piezo height record beside a sensor ``height``.
PIEZO_VARIABLE = "piezo_height"
#: Significance the sensor's delay needs to be the default (in its stderr, Birge ratio included).
SIGNIFICANCE = 3.0

def check_phase_reference(value: Any) -> str | xr.Dataset:
    """``phase_reference`` as used: ``"auto"`` (for None), a mode of :data:`REFERENCES`, or a dataset.

    Raises
    ------
    ParameterError
        Anything else (a path is read by :func:`viscoforce.measured.open_data`, not here).
    """
    if value is None:
        return "auto"
    if isinstance(value, xr.Dataset):
        return value
    if isinstance(value, str) and value in ("auto", *REFERENCES):
        return value
    raise ParameterError(f"phase_reference must be None, 'auto', 'sensor', 'piezo', 'delay' or a "
                         f"hard-surface spectrum dataset, got {value!r}")


@dataclass(frozen=True)
class SensorDelay:
    """The sensor's delay behind the piezo, fitted per map (:func:`fit_sensor_delay`).

    Attributes
    ----------
    delay : float
        τ_d [s] (> 0: the sensor lags the piezo).
    stderr : float
        Its standard error [s]: ``stderr_statistical`` times the Birge ratio when χ²/dof > 1.
    stderr_statistical : float
        (Σwω²)^{−1/2} [s], from the segments' errors alone.
    chi2, dof : float, int
        χ² of the pure delay and its degrees of freedom (segments − 1).
    pvalue : float
        P(χ² ≥ ``chi2``): whether a pure delay describes the differences within their errors.
    zero_chi2, zero_pvalue : float
        The same for no difference at all (φ = 0; ``segments`` dof).
    segments : int
        Segments fitted (finite difference and error).
    misfit : float
        The largest |weighted mean residual| of one frequency over the curves [degree].
    misfit_frequency : float
        Where [Hz].
    """

    delay: float
    stderr: float
    stderr_statistical: float
    chi2: float
    dof: int
    pvalue: float
    zero_chi2: float
    zero_pvalue: float
    segments: int
    misfit: float
    misfit_frequency: float

    @property
    def significance(self) -> float:
        """τ_d / stderr (inf for an exact, nonzero delay; 0 for none)."""
        if self.stderr > 0:
            return self.delay / self.stderr
        return 0.0 if self.delay == 0 else math.copysign(math.inf, self.delay)

    def label(self) -> str:
        """``delay: 0.142 ms ± 0.004 ms``: the attrs' name of the reference."""
        return f"delay: {self.delay * 1e3:.3g} ms ± {self.stderr * 1e3:.2g} ms"

    def text(self) -> str:
        """One sentence: the fit, its consistency and its comparison with zero."""
        birge = self.stderr / self.stderr_statistical if self.stderr_statistical > 0 else 1.0
        return (f"sensor - piezo phase of {self.segments} segments fitted by -omega*tau_d "
                f"(weighted least squares): tau_d = {self.delay * 1e3:.4g} ms +- "
                f"{self.stderr * 1e3:.2g} ms (statistical {self.stderr_statistical * 1e3:.2g} "
                f"ms x Birge ratio {birge:.3g}); pure delay chi2/dof = {self.chi2:.4g}/"
                f"{self.dof} (p = {self.pvalue:.2g}; largest mean misfit {self.misfit:.2g} "
                f"degree at {self.misfit_frequency:g} Hz); no delay chi2 = {self.zero_chi2:.4g} "
                f"(p = {self.zero_pvalue:.2g})")

    def as_attrs(self) -> dict[str, Any]:
        """``sensor_delay``, ``sensor_delay_stderr`` [s] and the sentence ``sensor_delay_fit``."""
        return {"sensor_delay": float(self.delay), "sensor_delay_stderr": float(self.stderr),
                "sensor_delay_fit": self.text()}


def _quad(c: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """c·C·c^H per point: ``c`` (..., R) complex, ``cov`` (..., R, R) Hermitian."""
    return np.einsum("...i,...ij,...j->...", c, cov, c.conj()).real


def _phase_difference(h: np.ndarray, hp: np.ndarray, cov: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """φ = arg(ĥ/ĥ_p) [rad] and its stderr σ_φ (per component of ĥ/ĥ_p relative, [rad])."""
    zero = np.zeros_like(h)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.stack([zero, zero, 1.0 / h, -1.0 / hp], axis=-1)
        return np.angle(h / hp), np.sqrt(np.maximum(_quad(u, cov), 0.0))


def fit_sensor_delay(frequency: np.ndarray, h: np.ndarray, hp: np.ndarray, cov: np.ndarray
                     ) -> SensorDelay:
    """The sensor's delay τ_d from the sensor and piezo harmonics of every segment (module text).

    Parameters
    ----------
    frequency : ndarray
        Modulation frequencies f [Hz], the last axis of the others.
    h, hp : ndarray
        First harmonics of the sensor and the piezo height [m] over (curve, frequency).
    cov : ndarray
        Error covariance of (F̂, δ̂, ĥ, ĥ_p) per point, (curve, frequency, 4, 4).

    Returns
    -------
    SensorDelay

    Raises
    ------
    ParameterError
        Fewer than two segments with a finite phase difference and a positive error.
    """
    omega = np.broadcast_to(2.0 * math.pi * np.asarray(frequency, dtype=float), h.shape)
    phi, sigma = _phase_difference(h, hp, cov)
    ok = np.isfinite(phi) & np.isfinite(sigma) & (sigma > 0)
    n = int(ok.sum())
    if n < 2:
        raise ParameterError(f"the sensor's delay needs two or more modulation segments with a "
                             f"finite sensor - piezo phase and error, got {n}")
    w = np.where(ok, 1.0 / np.where(ok, sigma, 1.0) ** 2, 0.0)
    phi = np.where(ok, phi, 0.0)
    sww = float((w * omega**2).sum())
    delay = -float((w * omega * phi).sum()) / sww
    resid = phi + omega * delay
    chi2 = float((w * resid**2).sum())
    zero = float((w * phi**2).sum())
    stat = 1.0 / math.sqrt(sww)
    from scipy.special import gammaincc  # chi2.sf(x, k) = Q(k/2, x/2): no scipy.stats (~0.7 s)

    mean_resid = np.degrees((w * resid).sum(axis=0) / np.where(w.sum(axis=0) > 0,
                                                               w.sum(axis=0), np.inf))
    j = int(np.argmax(np.abs(mean_resid)))
    return SensorDelay(delay=delay, stderr=stat * max(1.0, math.sqrt(chi2 / (n - 1))),
                       stderr_statistical=stat, chi2=chi2, dof=n - 1,
                       pvalue=float(gammaincc(0.5 * (n - 1), 0.5 * chi2)), zero_chi2=zero,
                       zero_pvalue=float(gammaincc(0.5 * n, 0.5 * zero)), segments=n,
                       misfit=float(abs(mean_resid[j])),
                       misfit_frequency=float(np.asarray(frequency, dtype=float)[j]))


def choose_reference(requested: str | xr.Dataset, *, channel: str | None, has_piezo: bool,
                     fit: SensorDelay | None) -> tuple[str, str]:
    """The reference used and why: ``(mode, sentence)`` (the default rule of the module text).

    Parameters
    ----------
    requested : str or xarray.Dataset
        As :func:`check_phase_reference` returns it.
    channel : str or None
        The height channel behind δ (``attrs["height_channel"]``).
    has_piezo : bool
        Whether every modulation segment has a piezo record.
    fit : SensorDelay or None
        The sensor's delay (needed for ``"delay"`` and for the default with a piezo record).

    Raises
    ------
    ParameterError
        ``"piezo"`` or ``"delay"`` asked where the height channel is not a sensor or there is
        no piezo record.
    """
    sensor = channel in SENSOR_CHANNELS
    if isinstance(requested, xr.Dataset):
        return "sensor", ("sensor: a hard-surface phase_reference is given, which measures the "
                          "instrument lag against the sensor itself")
    if requested in ("piezo", "delay"):
        if not sensor:
            raise ParameterError(
                f"phase_reference {requested!r} refers the calibrated sensor's height to the "
                f"piezo; the height channel here is {channel!r}, not a sensor: leave "
                "phase_reference unset, or read the file with its sensor as height_channel")
        if not has_piezo:
            raise ParameterError(
                f"phase_reference {requested!r} needs the piezo height record beside the "
                f"sensor: a JPK archive with a 'height' channel, or a curves dataset with "
                f"'{PIEZO_VARIABLE}' [m] over 'sample'; these data have none")
        return requested, f"{requested}: asked for"
    if requested == "sensor":
        return "sensor", "sensor: asked for"
    if not sensor:
        return "sensor", (f"sensor (as recorded): the height channel {channel!r} is not a "
                          "calibrated sensor, so there is no sensor to refer to the piezo")
    if not has_piezo or fit is None:
        return "sensor", ("sensor: no piezo height record beside the sensor, so its delay "
                          "cannot be measured")
    z = fit.significance
    if fit.delay > 0 and z > SIGNIFICANCE:
        consistent = ("a pure delay describes the differences within their errors"
                      if fit.pvalue >= 1e-3 else
                      "not all of the difference is a delay (p < 1e-3: a frequency-independent "
                      "part, the open-loop piezo's creep, stays out of the phase)")
        return "delay", (f"delay: the sensor lags the piezo by tau_d = {fit.delay * 1e3:.3g} ms, "
                         f"{z:.3g} stderr (> {SIGNIFICANCE:g}); {consistent}; one delay for "
                         "the map rather than the piezo's phase per segment, which would also "
                         "carry the piezo's own creep")
    why = (f"tau_d = {fit.delay * 1e3:.3g} ms is {z:.3g} stderr: the sensor leads the piezo, "
           "which no delay of the sensor explains" if z < -SIGNIFICANCE
           else f"tau_d = {fit.delay * 1e3:.3g} ms is {z:.3g} stderr, within "
                f"+-{SIGNIFICANCE:g}")
    return "sensor", f"sensor: no significant sensor delay ({why})"


def reference_basis(mode: str, channel: str | None, fit: SensorDelay | None,
                    hard: xr.Dataset | None) -> str:
    """``attrs["phase_reference"]``: its name (``sensor``, ``piezo``, ``delay: …``) and what it means."""
    basis = phase_basis(channel)
    if hard is not None:
        name = str(hard.attrs.get("file", "spectrum"))
        return f"hard-surface reference {name}; {basis}"
    if mode == "piezo":
        return ("piezo; force against delta = -|h| exp(i arg h_piezo) - deflection: the amplitude "
                f"of the calibrated height sensor {channel}, the phase of the piezo height "
                "record (the sensor's own delay kept out)")
    if mode == "delay" and fit is not None:
        return (f"{fit.label()}; force against delta = -{channel} exp(i omega tau_d) - "
                f"deflection: the calibrated height sensor {channel} advanced by its fitted "
                "delay behind the piezo")
    name = "sensor" if channel in SENSOR_CHANNELS else ("piezo" if channel == "height"
                                                        else "unknown")
    return f"{name}; {basis}"


def referred(mode: str, force: np.ndarray, indentation: np.ndarray, h: np.ndarray,
             hp: np.ndarray, cov: np.ndarray, omega: np.ndarray,
             fit: SensorDelay | None) -> dict[str, np.ndarray]:
    """k*, |δ̂′|, ρ and σ_|δ̂′| with the height's phase referred to ``mode`` (module text).

    Parameters
    ----------
    mode : {"piezo", "delay"}
        The reference.
    force, indentation, h, hp : ndarray
        F̂ [N], δ̂ [m], ĥ (sensor) and ĥ_p (piezo) [m], complex, over (curve, frequency).
    cov : ndarray
        Their error covariance per point (curve, frequency, 4, 4): the residual-spectrum or the
        white-noise one.
    omega : ndarray
        ω [rad/s] per frequency.
    fit : SensorDelay or None
        τ_d and its stderr (``"delay"``).

    Returns
    -------
    dict
        ``k`` k* = F̂/δ̂′ [N/m], ``eta`` |δ̂′| [m], ``rho`` the relative error of k* per
        component, ``eta_se`` the error of |δ̂′| per component [m].
    """
    zero, one = np.zeros_like(indentation), np.ones_like(indentation)
    with np.errstate(divide="ignore", invalid="ignore"):
        if mode == "piezo":
            gain = np.abs(h) / np.abs(hp)
            a, b = one, -gain
            u = np.stack([zero, zero, 1.0 / h, -1.0 / hp], axis=-1)
            along = np.abs(h) ** 2 * _quad(u, cov)   # the amplitude ratio's error, along ĥ′ [m²]
        elif mode == "delay" and fit is not None:
            a, b = 1.0 - np.exp(1j * omega * fit.delay) * one, zero
            along = (omega * np.abs(h) * fit.stderr) ** 2   # τ_d's error, along iωĥ′ [m²]
        else:
            raise ParameterError(f"referred() takes mode 'piezo' or 'delay' (with its fit), got "
                                 f"{mode!r}")
        d_new = indentation + a * h + b * hp
        c = np.stack([1.0 / force, -1.0 / d_new, -a / d_new, -b / d_new], axis=-1)
        rho2 = _quad(c, cov) + along / np.abs(d_new) ** 2
        var_d = _quad(np.stack([zero, one, a, b], axis=-1), cov) + along
        return {"k": force / d_new, "eta": np.abs(d_new), "rho": np.sqrt(np.maximum(rho2, 0.0)),
                "eta_se": np.sqrt(np.maximum(var_d, 0.0))}


def phase_difference(h: np.ndarray, hp: np.ndarray, cov: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The sensor − piezo phase per point and its stderr [degree] (the evidence of the choice)."""
    phi, sigma = _phase_difference(h, hp, cov)
    return np.degrees(phi), np.degrees(sigma)
