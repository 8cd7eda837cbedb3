"""Surface-force laws: pressure p(h) between two parallel half-spaces at gap h (paper Eq. 13).

Every law is a small frozen dataclass implementing :class:`SurfaceForceLaw`: the pressure, its
derivative (for the Newton Jacobian), the interaction energy per unit area, a decay length and the
gap beyond which the pressure is negligible (used to size the radial grid). Laws add with ``+``.

Sign convention: p > 0 is repulsion; the gap h must stay > 0 for the soft wall.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._limits import SURFACE_FORCE_LENGTH_RANGE, SURFACE_PRESSURE_RANGE
from viscoforce._typing import FloatArray
from viscoforce._validation import (
    as_float_array,
    as_real_array,
    require_in_range,
    require_plausible,
    require_positive,
)
from viscoforce.exceptions import ParameterError

#: Largest exponent of e^x that stays finite in float64 (e^709.78 = 1.8e308), with a margin.
_MAX_EXPONENT = 700.0
#: Gaps beyond ± this many Debye lengths are clipped before e^{−h/λ} (the result is unchanged).
_CLIP_DECAY_LENGTHS = 1000.0
#: Gaps below this multiple of z0 may overflow (z0/h)^9 (or (z0/h)^9/h) in float64.
_OVERFLOW_RATIO = 1e-30


def _as_gap(gap: ArrayLike) -> FloatArray:
    """Gap [m] as a float array (NaN is caught by the laws' single reduction, see _reject_nan)."""
    return as_real_array("gap", gap)


def _reject_nan(h: FloatArray) -> None:
    """Raise the standard message if ``h`` holds a NaN (+inf is allowed: p(∞) = 0)."""
    as_float_array("gap", h, allow_inf=True)


def _length(name: str, value: float) -> float:
    """A decay length of a law [m]: > 0, in :data:`~viscoforce._limits.SURFACE_FORCE_LENGTH_RANGE`.

    A subnormal Debye length made 1/λ overflow (NaN pressures downstream); 1e300 m, a law that
    never decays (no grid can hold it).
    """
    return require_plausible(name, require_positive(name, value), SURFACE_FORCE_LENGTH_RANGE, "m")


def _pressure(name: str, value: float) -> float:
    """A pressure scale of a law [Pa]: > 0, in :data:`~viscoforce._limits.SURFACE_PRESSURE_RANGE`."""
    return require_plausible(name, require_positive(name, value), SURFACE_PRESSURE_RANGE, "Pa")


def _as_rtol(rtol: float) -> float:
    """Relative pressure level of :meth:`SurfaceForceLaw.negligible_gap`, in (0, 1)."""
    return require_in_range("rtol", rtol, 0.0, 1.0, inclusive=(False, False))


class SurfaceForceLaw(ABC):
    """A pressure law p(h) [Pa] of the local gap h [m].

    Subclasses implement :meth:`pressure`, :meth:`pressure_derivative`, :meth:`energy`,
    :meth:`negligible_gap` and the property :attr:`decay_length`. ``pressure == −d energy / dh``.
    """

    @abstractmethod
    def pressure(self, gap: ArrayLike) -> FloatArray:
        """Pressure p(h) [Pa] at gap ``gap`` [m] (> 0 is repulsive)."""

    @abstractmethod
    def pressure_derivative(self, gap: ArrayLike) -> FloatArray:
        """dp/dh [Pa/m] at gap ``gap`` [m]."""

    @abstractmethod
    def energy(self, gap: ArrayLike) -> FloatArray:
        """Interaction energy per unit area W(h) [J/m²], zero at infinite gap; p = −dW/dh."""

    @property
    @abstractmethod
    def decay_length(self) -> float:
        """Characteristic decay length of the law [m] (sets the radial grid scale)."""

    @abstractmethod
    def negligible_gap(self, rtol: float) -> float:
        """Gap [m] beyond which |p| < rtol × (the law's pressure scale)."""

    def __add__(self, other: SurfaceForceLaw) -> SumOfLaws:
        if not isinstance(other, SurfaceForceLaw):
            return NotImplemented
        left = self.terms if isinstance(self, SumOfLaws) else (self,)
        right = other.terms if isinstance(other, SumOfLaws) else (other,)
        return SumOfLaws(left + right)

    def values(self) -> dict[str, float]:
        """The law's own parameters in SI, by field name (``{"P": 1e7, "debye_length": 1e-9}``)."""
        return {k: float(v) for k, v in vars(self).items() if not k.startswith("_")}

    def parameters(self) -> dict[str, float | str]:
        """Flat dataset attrs: ``surface_force`` (:meth:`describe`) and the named values (SI)."""
        return {"surface_force": self.describe(), **self.values()}

    def describe(self) -> str:
        """The law and its parameters in SI, e.g. ``DoubleLayer(P=1e+07, debye_length=1e-09)``."""
        args = ", ".join(f"{k}={v:.6g}" for k, v in self.values().items())
        return f"{type(self).__name__}({args})"


@dataclass(frozen=True)
class DoubleLayer(SurfaceForceLaw):
    """Linearised electric double-layer repulsion p = P exp(−h/λ_D).

    Parameters
    ----------
    P : float
        Pressure scale P [Pa], > 0 (the paper's 1e7 Pa ≈ 85 mV surface potential), within
        :data:`~viscoforce._limits.SURFACE_PRESSURE_RANGE`.
    debye_length : float
        λ_D = 1/κ [m], > 0 (1 nm ≈ 0.1 M monovalent salt), within
        :data:`~viscoforce._limits.SURFACE_FORCE_LENGTH_RANGE`.
    """

    P: float = 1e7  # noqa: N815
    debye_length: float = 1e-9

    def __post_init__(self):
        object.__setattr__(self, "P", _pressure("P (double-layer pressure scale)", self.P))
        object.__setattr__(self, "debye_length", _length("debye_length", self.debye_length))
        object.__setattr__(self, "_minus_kappa", -1.0 / self.debye_length)

    def pressure(self, gap):
        """Pressure [Pa] at gap [m] (+inf where e^{−h/λ} overflows, h < −709 λ)."""
        h = _as_gap(gap)
        # NaN passes through to the one check below; gaps beyond ±1e299 m make h/λ overflow
        # quietly to ±inf and take the slow path (no clip on the solvers' hot path)
        with np.errstate(over="ignore"):
            x = h * self._minus_kappa
        if x.size and not x.max() <= _MAX_EXPONENT:  # one reduction: NaN, or overflowing e^x
            limit = _CLIP_DECAY_LENGTHS * self.debye_length
            x = np.clip(h, -limit, limit) * self._minus_kappa
            _reject_nan(h)
            with np.errstate(over="ignore"):  # absurdly overlapping bodies: an honest +inf
                return self.P * np.exp(x)
        return self.P * np.exp(x)

    def pressure_derivative(self, gap):
        """dp/dh [Pa/m] at gap [m]."""
        return -self.pressure(gap) / self.debye_length

    def energy(self, gap):
        """Energy per area [J/m²] at gap [m]."""
        return self.pressure(gap) * self.debye_length

    @property
    def decay_length(self) -> float:
        """The Debye length [m]."""
        return self.debye_length

    def negligible_gap(self, rtol: float) -> float:
        """Gap [m] where p = rtol × P, for 0 < rtol < 1."""
        return float(self.debye_length * np.log(1.0 / _as_rtol(rtol)))


@dataclass(frozen=True)
class SoftWall(SurfaceForceLaw):
    """Short-range soft wall p = P_w (z0/h)^9 (from a 1/r¹² repulsion).

    Parameters
    ----------
    Pw : float
        Wall pressure P_w [Pa], > 0, within :data:`~viscoforce._limits.SURFACE_PRESSURE_RANGE`.
    z0 : float
        Wall length z0 [m], > 0, within :data:`~viscoforce._limits.SURFACE_FORCE_LENGTH_RANGE`.
    """

    Pw: float = 1e7  # noqa: N815
    z0: float = 0.5e-9

    def __post_init__(self):
        object.__setattr__(self, "Pw", _pressure("Pw (soft-wall pressure)", self.Pw))
        object.__setattr__(self, "z0", _length("z0 (soft-wall length)", self.z0))

    def _evaluate(self, gap, formula: Callable[[FloatArray], FloatArray]) -> FloatArray:
        """``formula(h)`` for gaps [m] that must be > 0; overflow near h = 0 gives +inf quietly."""
        h = _as_gap(gap)
        if not h.size:
            return formula(h)
        low = h.min()
        if not low >= _OVERFLOW_RATIO * self.z0:  # one reduction: NaN, h ≤ 0 or overflow
            _reject_nan(h)
            if low <= 0:
                raise ParameterError(
                    f"gap must be > 0 for the soft wall, got min {float(low):g} m")
            with np.errstate(over="ignore"):  # (z0/h)^9 overflows: an honest +inf
                return formula(h)
        return formula(h)

    def pressure(self, gap):
        """Pressure [Pa] at gap [m] (> 0; +inf where (z0/h)^9 overflows)."""
        return self._evaluate(gap, lambda h: self.Pw * (self.z0 / h) ** 9)

    def pressure_derivative(self, gap):
        """dp/dh [Pa/m] at gap [m] (< 0)."""
        return self._evaluate(gap, lambda h: -9.0 * self.Pw * (self.z0 / h) ** 9 / h)

    def energy(self, gap):
        """Energy per area [J/m²] at gap [m] (> 0)."""
        return self._evaluate(gap, lambda h: self.Pw * self.z0 * (self.z0 / h) ** 8 / 8.0)

    @property
    def decay_length(self) -> float:
        """z0/9 [m]: the local decay length |p/p′| of the wall at h = z0."""
        return self.z0 / 9.0

    def negligible_gap(self, rtol: float) -> float:
        """Gap [m] where p = rtol × P_w, for 0 < rtol < 1."""
        return float(self.z0 * _as_rtol(rtol) ** (-1.0 / 9.0))


@dataclass(frozen=True)
class SumOfLaws(SurfaceForceLaw):
    """The sum of several laws (build it with ``+``)."""

    terms: tuple[SurfaceForceLaw, ...]

    def __post_init__(self):
        if (not isinstance(self.terms, tuple) or not self.terms
                or not all(isinstance(t, SurfaceForceLaw) for t in self.terms)):
            raise ParameterError("terms must be a non-empty tuple of SurfaceForceLaw, got "
                                 f"{self.terms!r}")
        flat = tuple(u for t in self.terms for u in (t.terms if isinstance(t, SumOfLaws) else (t,)))
        object.__setattr__(self, "terms", flat)

    def pressure(self, gap):
        """Pressure [Pa] at gap [m]."""
        h = _as_gap(gap)
        return sum(t.pressure(h) for t in self.terms)

    def pressure_derivative(self, gap):
        """dp/dh [Pa/m] at gap [m]."""
        h = _as_gap(gap)
        return sum(t.pressure_derivative(h) for t in self.terms)

    def energy(self, gap):
        """Energy per area [J/m²] at gap [m]."""
        h = _as_gap(gap)
        return sum(t.energy(h) for t in self.terms)

    @property
    def decay_length(self) -> float:
        """The longest decay length of the terms [m]."""
        return max(t.decay_length for t in self.terms)

    def negligible_gap(self, rtol: float) -> float:
        """The largest negligible gap of the terms [m], for 0 < rtol < 1."""
        rtol = _as_rtol(rtol)
        return max(t.negligible_gap(rtol) for t in self.terms)

    def values(self) -> dict[str, float]:
        """Parameters of every term (SI).

        A name that occurs in several terms (two double layers) is numbered by occurrence
        (``P_1``, ``debye_length_1``, ``P_2``, ...) so that no term is lost.
        """
        per_term = [t.values() for t in self.terms]
        counts: dict[str, int] = {}
        for params in per_term:
            for name in params:
                counts[name] = counts.get(name, 0) + 1
        out: dict[str, float] = {}
        seen: dict[str, int] = {}
        for params in per_term:
            for name, value in params.items():
                if counts[name] > 1:
                    seen[name] = seen.get(name, 0) + 1
                    name = f"{name}_{seen[name]}"
                out[name] = value
        return out

    def describe(self) -> str:
        """The terms, e.g. ``DoubleLayer(P=1e+07, debye_length=1e-09) + SoftWall(...)`` (SI)."""
        return " + ".join(t.describe() for t in self.terms)


# ── Lennard-Jones (adhesive) law: issue 39 ───────────────────────────────────────────────────────

#: Plausible Hamaker constants [J]: 1e-25 J (far below any real pair, ~1e-21 J for polymers in
#: water) to 1e-15 J (far above metals in vacuum, ~4e-19 J).
HAMAKER_RANGE = (1e-25, 1e-15)
#: 3^{1/6}: the gap h/z0 of the Lennard-Jones pressure minimum (the largest tensile stress).
_LJ_WELL = 3.0 ** (1.0 / 6.0)


def _hamaker(value: float) -> float:
    """The Hamaker constant A [J]: > 0, within :data:`HAMAKER_RANGE`."""
    return require_plausible("hamaker (Hamaker constant A)", require_positive(
        "hamaker (Hamaker constant A)", value), HAMAKER_RANGE, "J")


def lennard_jones_work_of_adhesion(hamaker: float, z0: float) -> float:
    """Δγ = A / (16 π z0²) [J/m²]: −W(z0) of the Lennard-Jones law (the depth of its well).

    Parameters
    ----------
    hamaker : float
        Hamaker constant A [J], within :data:`HAMAKER_RANGE`.
    z0 : float
        Equilibrium separation z0 [m] (p(z0) = 0), within
        :data:`~viscoforce._limits.SURFACE_FORCE_LENGTH_RANGE`.
    """
    return _hamaker(hamaker) / (16.0 * np.pi * _length("z0 (equilibrium separation)", z0) ** 2)


def tabor_parameter(radius: float, work_of_adhesion: float, modulus: float, z0: float) -> float:
    """Tabor's μ = (R Δγ² / (E*² z0³))^{1/3} with E* = E/2 (E in the paper's convention).

    μ → 0: rigid bodies, Bradley/DMT pull-off 2πRΔγ; μ ≳ 5: JKR, 1.5πRΔγ. Maugis' transition
    parameter is λ ≈ 1.16 μ.

    Parameters
    ----------
    radius : float
        Sphere radius R [m], > 0.
    work_of_adhesion : float
        Δγ [J/m²], > 0.
    modulus : float
        Elastic modulus E [Pa] in the paper's convention (2/E = Σ(1 − ν_i²)/E_i), > 0.
    z0 : float
        Equilibrium separation z0 [m], > 0.
    """
    radius = require_positive("radius (R)", radius)
    work = require_positive("work_of_adhesion", work_of_adhesion)
    e_star = 0.5 * require_positive("modulus (E)", modulus)
    z0 = require_positive("z0", z0)
    return float((radius * work**2 / (e_star**2 * z0**3)) ** (1.0 / 3.0))


@dataclass(frozen=True)
class LennardJones(SurfaceForceLaw):
    """Lennard-Jones (9-3) pressure p = A/(6π h³)·[(z0/h)⁶ − 1] between half-spaces.

    Attractive (p < 0) beyond z0, repulsive below; the most tensile pressure is
    −A/(9√3 π z0³) at h = 3^{1/6} z0; the energy per area W(h) = A/(12π h²)·[(z0/h)⁶/4 − 1]
    has its minimum −Δγ = −A/(16π z0²) at h = z0.

    Parameters
    ----------
    hamaker : float
        Hamaker constant A [J], > 0, within :data:`HAMAKER_RANGE`.
    z0 : float
        Equilibrium separation z0 [m] (p(z0) = 0), > 0, within
        :data:`~viscoforce._limits.SURFACE_FORCE_LENGTH_RANGE`.

    Notes
    -----
    The gap must stay > 0 (the (z0/h)⁹ wall keeps it so in any converged equilibrium).
    :attr:`decay_length` is z0: the pressure changes sign at h = z0 and its well spans a gap of
    order z0, so z0 sets the grid's interaction length sqrt(2 R z0) and the default contact
    threshold (gaps below z0 are repulsive). The attractive tail decays only as h⁻³:
    :meth:`negligible_gap` is correspondingly far out.
    """

    hamaker: float = 1e-20
    z0: float = 0.3e-9

    def __post_init__(self):
        object.__setattr__(self, "hamaker", _hamaker(self.hamaker))
        object.__setattr__(self, "z0", _length("z0 (equilibrium separation)", self.z0))
        object.__setattr__(self, "_scale", self.hamaker / (6.0 * np.pi))

    def _evaluate(self, gap, formula: Callable[[FloatArray], FloatArray]) -> FloatArray:
        """``formula(h)`` for gaps [m] that must be > 0; overflow near h = 0 gives +inf quietly."""
        h = _as_gap(gap)
        if not h.size:
            return formula(h)
        low = h.min()
        if not low >= _OVERFLOW_RATIO * self.z0:  # one reduction: NaN, h ≤ 0 or overflow
            _reject_nan(h)
            if low <= 0:
                raise ParameterError(
                    f"gap must be > 0 for the Lennard-Jones law, got min {float(low):g} m")
            with np.errstate(over="ignore"):
                return formula(h)
        return formula(h)

    def pressure(self, gap):
        """Pressure [Pa] at gap [m] (< 0 beyond z0: attraction)."""
        return self._evaluate(gap, lambda h: self._scale / h**3 * ((self.z0 / h) ** 6 - 1.0))

    def pressure_derivative(self, gap):
        """dp/dh [Pa/m] at gap [m] (> 0 beyond 3^{1/6} z0: the unstable, softening side)."""
        return self._evaluate(
            gap, lambda h: self._scale / h**4 * (3.0 - 9.0 * (self.z0 / h) ** 6))

    def energy(self, gap):
        """Energy per area W(h) [J/m²] at gap [m] (minimum −Δγ at h = z0)."""
        return self._evaluate(
            gap, lambda h: self._scale / (2.0 * h**2) * (0.25 * (self.z0 / h) ** 6 - 1.0))

    @property
    def decay_length(self) -> float:
        """z0 [m] (see the class notes)."""
        return self.z0

    @property
    def work_of_adhesion(self) -> float:
        """Δγ = A/(16π z0²) [J/m²]."""
        return lennard_jones_work_of_adhesion(self.hamaker, self.z0)

    @property
    def max_tensile_pressure(self) -> float:
        """The largest tensile pressure A/(9√3 π z0³) [Pa] (> 0), at h = 3^{1/6} z0."""
        return float(self.hamaker / (9.0 * np.sqrt(3.0) * np.pi * self.z0**3))

    def tabor_parameter(self, radius: float, modulus: float) -> float:
        """Tabor's μ of this law for a sphere of radius R [m] and modulus E [Pa] (paper's E)."""
        return tabor_parameter(radius, self.work_of_adhesion, modulus, self.z0)

    def negligible_gap(self, rtol: float) -> float:
        """Gap [m] beyond which |p| < rtol × the largest tensile pressure, for 0 < rtol < 1.

        The tail A/(6π h³) falls below rtol·A/(9√3 π z0³) at h = z0·(3√3/(2 rtol))^{1/3}.
        """
        rtol = _as_rtol(rtol)
        return float(max(self.z0 * (1.5 * np.sqrt(3.0) / rtol) ** (1.0 / 3.0), _LJ_WELL * self.z0))


def lennard_jones_pressure_law(hamaker: float, z0: float, *,
                               double_layer: DoubleLayer | None = None) -> SurfaceForceLaw:
    """The adhesive Lennard-Jones law, alone or added to a double layer (issue 39).

    Parameters
    ----------
    hamaker : float
        Hamaker constant A [J], within :data:`HAMAKER_RANGE` (e.g. 1e-20 J).
    z0 : float
        Equilibrium separation z0 [m] (e.g. 0.3e-9), within
        :data:`~viscoforce._limits.SURFACE_FORCE_LENGTH_RANGE`.
    double_layer : DoubleLayer, optional
        A double-layer repulsion to add (the CLI's ``--force-law both``). The Lennard-Jones
        (z0/h)⁹ term is then the short-range wall: no separate :class:`SoftWall` is added.

    Returns
    -------
    SurfaceForceLaw
        :class:`LennardJones`, or ``double_layer + LennardJones`` (:class:`SumOfLaws`).

    Examples
    --------
    >>> law = lennard_jones_pressure_law(1e-20, 0.3e-9)
    >>> round(law.work_of_adhesion * 1e3, 3)  # Δγ [mJ/m²]
    2.21
    """
    law = LennardJones(hamaker, z0)
    if double_layer is None:
        return law
    if not isinstance(double_layer, DoubleLayer):
        raise ParameterError(f"double_layer must be a DoubleLayer or None, got {double_layer!r}")
    return double_layer + law


def is_attractive(law: SurfaceForceLaw) -> bool:
    """Whether ``law`` has a Lennard-Jones term (an attractive well: jumps and pull-off)."""
    terms = law.terms if isinstance(law, SumOfLaws) else (law,)
    return any(isinstance(t, LennardJones) for t in terms)
