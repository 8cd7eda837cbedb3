"""Starting values from the data alone: spectrum features, moduli from the levels, τ windows.

Every model's :meth:`~viscoforce.fitting.base.FitModel.guess` starts here: the low- and
high-frequency levels and the phase peak of a spectrum (:class:`SpectrumFeatures`), the moduli
whose relaxed and glassy stiffness match them (:func:`moduli_from_levels`), and the windows a
relaxation time may take over the measured frequencies or times.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from viscoforce.fitting.base import MODULUS_BOUNDS, TAU_MARGIN_DECADES, moduli_names, tau_names


@dataclass(frozen=True)
class SpectrumFeatures:
    """What a guess reads off a spectrum: low/high-frequency |k*|, the phase peak, the window."""

    k_low: float
    k_high: float
    omega_low: float
    omega_high: float
    omega_peak: float

    @classmethod
    def of(cls, k: np.ndarray, omega: np.ndarray) -> SpectrumFeatures:
        """Features of k*(ω) (the phase peak by a parabola in log ω through the top three)."""
        order = np.argsort(omega)
        w, k = omega[order], k[order]
        mag, phase = np.abs(k), np.angle(k)
        n_end = max(1, w.size // 10)
        i = int(np.argmax(phase))
        peak = float(w[i])
        if 0 < i < w.size - 1:  # parabola through the peak in log ω
            x0, x1, x2 = (math.log(v) for v in w[i - 1:i + 2].tolist())
            y0, y1, y2 = phase[i - 1:i + 2].tolist()
            if x0 < x1 < x2:  # a repeated frequency defines no parabola: the peak point
                left, right = (y1 - y0) / (x1 - x0), (y2 - y1) / (x2 - x1)
                if right < left:  # concave: the vertex is between the outer two points
                    vertex = 0.5 * (x0 + x1) - left * (x2 - x0) / (2.0 * (right - left))
                    peak = min(max(math.exp(vertex), float(w[i - 1])), float(w[i + 1]))
        return cls(_median(mag[:n_end]), _median(mag[-n_end:]), float(w[0]), float(w[-1]), peak)

    def sls_tau(self) -> float:
        """τ of a one-mode transfer (1 + iωτ)/(a + iωτ b): its phase peaks at ωτ = √(a/b)."""
        ratio = max(self.k_high / self.k_low, 1.0 + 1e-6) if self.k_low > 0 else 2.0
        return math.sqrt(ratio) / self.omega_peak


def _median(values: np.ndarray) -> float:
    """np.median of a few values without its array machinery (NaN in, NaN out, as numpy)."""
    if not np.isfinite(values).all():
        return float(np.median(values))
    return statistics.median(values.tolist())


def spread(center: float, modes: int, window: tuple[float, float]) -> list[float]:
    """``modes`` values log-spaced around ``center`` within ``window`` (a decade apart at most)."""
    if modes == 1:
        return [center]
    lo, hi = math.log10(window[0]), math.log10(window[1])
    step = min(1.0, (hi - lo) / (modes + 1))
    c = min(max(math.log10(center), lo + step * (modes - 1) / 2), hi - step * (modes - 1) / 2)
    return [10 ** (c + step * (i - (modes - 1) / 2)) for i in range(modes)]


def geometric(high: float, low: float, modes: int) -> list[float]:
    """E0 … E_inf: ``modes`` + 1 values from ``high`` down to ``low``, geometric."""
    high = max(high, low * (1 + 1e-3))
    return [high * (low / high) ** (i / modes) for i in range(modes + 1)]


def material_guess(e_high: float, e_low: float, tau: float, modes: int,
                   window: tuple[float, float]) -> dict[str, float]:
    """Moduli geometric from ``e_high`` down to ``e_low`` and times spread around ``tau``."""
    out = dict(zip(moduli_names(modes), geometric(e_high, e_low, modes), strict=True))
    out.update(zip(tau_names(modes), spread(tau, modes, window), strict=True))
    return out


def omega_window(omega: np.ndarray) -> tuple[float, float]:
    """Bounds of a creep or relaxation time measured over ``omega`` [s]."""
    margin = 10 ** TAU_MARGIN_DECADES
    return 1.0 / (np.max(omega) * margin), margin / np.min(omega)


def time_window(t: np.ndarray) -> tuple[float, float]:
    """Bounds of a relaxation time measured at times ``t`` [s]: finest step to whole span."""
    steps = np.diff(np.sort(t))
    dt = float(np.min(steps[steps > 0])) if np.any(steps > 0) else 1e-6
    span = float(np.ptp(t)) or dt
    margin = 10 ** TAU_MARGIN_DECADES
    return dt / margin, span * margin


def solve_modulus(stiffness: Callable[[float], float], target: float, start: float) -> float:
    """E with stiffness(E) = target by a secant in log–log (stiffness grows like a power of E)."""
    lo_bound, hi_bound = MODULUS_BOUNDS
    e1, k1 = start, stiffness(start)
    e2 = start * 2.0
    k2 = stiffness(e2)
    for _ in range(12):
        slope = math.log(k2 / k1) / math.log(e2 / e1) if k2 != k1 else 1.0
        slope = min(max(slope, 0.05), 2.0)
        e_new = e2 * (target / k2) ** (1.0 / slope)
        e_new = min(max(e_new, lo_bound * 10), hi_bound / 10)
        e1, k1, e2 = e2, k2, e_new
        k2 = stiffness(e2)
        if abs(math.log(k2 / target)) < 1e-3:
            break
    return e2


def moduli_from_levels(function: Callable[[np.ndarray, dict[str, float]], np.ndarray],
                        feats: SpectrumFeatures, start: float) -> tuple[float, float]:
    """E_inf and E0 whose relaxed and glassy |k*| match the spectrum's low and high levels."""
    slow, fast = 1e-4 / feats.omega_high, 1e4 / feats.omega_low

    def relaxed(e: float) -> float:
        return float(abs(function(np.array([feats.omega_low]), {
            "E_inf": e, "E0": 1.001 * e, "tau": slow})[0]))

    e_inf = solve_modulus(relaxed, feats.k_low, start)

    def glassy(e: float) -> float:
        return float(abs(function(np.array([feats.omega_high]), {
            "E_inf": e_inf, "E0": max(e, 1.0001 * e_inf), "tau": fast})[0]))

    e0 = solve_modulus(glassy, max(feats.k_high, feats.k_low * 1.01), 2 * e_inf)
    return e_inf, max(e0, 1.05 * e_inf)
