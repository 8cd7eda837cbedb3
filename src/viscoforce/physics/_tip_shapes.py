"""The tip shapes of :mod:`viscoforce.physics.tips`: the :class:`Tip` protocol and its shapes.

:class:`RigidSphere` (also ``Sphere``), :class:`Paraboloid`, :class:`Cone`, :class:`Pyramid` and
:class:`Flat`, with their contact laws; the conventions, the text form and the references are told in
:mod:`viscoforce.physics.tips`, the public module that re-exports everything here.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from viscoforce._limits import TIP_HALF_ANGLE_RANGE, TIP_RADIUS_RANGE
from viscoforce._validation import (
    as_float_array,
    describe_value,
    require_finite,
    require_positive,
    shown,
)
from viscoforce.exceptions import ParameterError
from viscoforce.physics.moduli import _out
from viscoforce.units import format_quantity

FloatArray = NDArray[np.float64]

#: Bilodeau's (1992) coefficient of the four-sided pyramid: F = 0.7453·E_star·tanθ·δ², θ the
#: semi-angle from the axis to a face. An approximate solution, 1.04 % above the exact one
#: (:data:`PYRAMID_EXACT_COEFFICIENT`); kept as the pyramid's law (see :class:`Pyramid`).
BILODEAU_COEFFICIENT = 0.7453
#: The exact coefficient of the rigid frictionless four-sided pyramid on an elastic half-space,
#: F = 0.7376·E_star·tanθ·δ² (±1e-4), from a boundary-element solve (``tests/theory/test_tips.py``).
PYRAMID_EXACT_COEFFICIENT = 0.7376

#: The shape names of :func:`~viscoforce.physics.tips.parse_tip` and the ``tip_shape`` attribute.
TIP_SHAPES: tuple[str, ...] = ("sphere", "paraboloid", "cone", "pyramid", "flat")

_RADIANS = tuple(math.radians(a) for a in TIP_HALF_ANGLE_RANGE)
#: Degrees a half-angle may lie beyond its range by rounding (a radian → degree round trip).
_ANGLE_SLACK = 1e-9

#: Taylor coefficients of f(s) = (1 + tanh²s)·s − tanh s = Σ c_k s^k (odd k = 3 … 15), used for
#: s < _SERIES_BELOW where the closed form cancels (its relative rounding error is ~ eps/s²).
_SPHERE_SERIES = (4 / 3, -4 / 5, 136 / 315, -124 / 567, 5528 / 51975, -43688 / 868725,
                  14873104 / 638512875)
_SERIES_BELOW = 0.1


# ── inputs ────────────────────────────────────────────────────────────────────────────────────


def _as_depth(delta: ArrayLike) -> FloatArray:
    """Indentation δ [m] as a float array, raising unless every entry is finite and >= 0."""
    d = as_float_array("delta (indentation)", delta)
    if (d < 0).any():
        i = int(np.flatnonzero(d.ravel() < 0)[0])
        raise ParameterError(
            f"delta (indentation) must be >= 0 m (0 is first contact, > 0 into the sample); "
            f"entry {i} is {float(d.ravel()[i])!r}")
    return d


# ── the protocol ─────────────────────────────────────────────────────────────────────────────


class Tip(ABC):
    """An indenter shape pressed into an elastic half-space by δ [m] (δ ≥ 0 into the sample).

    Subclasses are frozen dataclasses implementing :meth:`force_shape`,
    :meth:`contact_stiffness_factor`, :meth:`contact_radius`, :meth:`describe` and
    :meth:`as_attrs`; they name their ``shape`` (one of :data:`TIP_SHAPES`). Every method is
    vectorised over ``delta`` (array_like, finite, ≥ 0; a scalar gives a scalar) and raises
    :class:`~viscoforce.exceptions.ParameterError` for anything else. Contract:
    d(force_shape)/dδ == contact_stiffness_factor, and force_shape(0) == 0.

    ``E`` is always the paper's modulus, E = 2·E_star = 2Y/(1 − ν²) for a rigid tip on a sample
    of Young's modulus Y (see :mod:`viscoforce.units`).
    """

    shape: ClassVar[str]

    @abstractmethod
    def force_shape(self, delta: ArrayLike) -> FloatArray:
        """F/E [m²] at indentation ``delta`` [m]: the load per unit (paper) modulus.

        Parameters
        ----------
        delta : float or array_like
            Indentation δ [m], finite, ≥ 0.

        Returns
        -------
        float or ndarray
            F(δ)/E [m²], 0 at δ = 0.
        """

    @abstractmethod
    def contact_stiffness_factor(self, delta: ArrayLike) -> FloatArray:
        """S(δ) = (dF/dδ)/E [m], so that k*(ω) = E*(ω)·S(δ0) at operating indentation δ0.

        Parameters
        ----------
        delta : float or array_like
            Indentation δ [m], finite, ≥ 0.

        Returns
        -------
        float or ndarray
            S(δ) [m]; equal to the contact radius a(δ) for an axisymmetric punch.
        """

    @abstractmethod
    def contact_radius(self, delta: ArrayLike) -> FloatArray:
        """Contact radius a(δ) [m] at indentation ``delta`` [m].

        Parameters
        ----------
        delta : float or array_like
            Indentation δ [m], finite, ≥ 0.

        Returns
        -------
        float or ndarray
            a(δ) [m].
        """

    @abstractmethod
    def describe(self) -> str:
        """Short human text, e.g. ``"sphere R = 10 µm"`` or ``"cone half-angle = 20°"``."""

    @abstractmethod
    def as_attrs(self) -> dict[str, str | float]:
        """NetCDF-safe dataset attrs: ``tip_shape`` and ``tip_radius`` [m] or ``tip_half_angle`` [degree].

        Returns
        -------
        dict
            ``{"tip_shape": str, "tip_radius": float}`` or
            ``{"tip_shape": str, "tip_half_angle": float}``; :meth:`from_attrs` reads it back.
        """

    def _shape(self, depth: FloatArray, work: FloatArray | None = None) -> FloatArray:
        """The law over ``depth`` (float64, ≥ 0, unchecked; ``work``: scratch), in place: fast path."""
        depth[...] = self.force_shape(depth)
        return depth

    def force(self, delta: ArrayLike, E: float) -> FloatArray:  # noqa: N803
        """Load F(δ) [N] of an elastic sample of paper modulus ``E`` at indentation ``delta``.

        Parameters
        ----------
        delta : float or array_like
            Indentation δ [m], finite, ≥ 0.
        E : float
            The paper's modulus [Pa], > 0: E = 2Y/(1 − ν²) for a sample of Young's modulus Y
            (:func:`~viscoforce.physics.moduli.paper_from_young`).

        Returns
        -------
        float or ndarray
            F(δ) = E·force_shape(δ) [N], > 0 for δ > 0 (repulsion), 0 at δ = 0.

        Raises
        ------
        ParameterError
            If ``E`` is not a finite number > 0, or ``delta`` is not finite and ≥ 0.
        """
        modulus = require_positive("E", E)
        return modulus * self.force_shape(delta)

    @classmethod
    def from_attrs(cls, attrs: Mapping[str, Any]) -> Tip:
        """Rebuild a tip from the attrs :meth:`as_attrs` wrote (other keys are ignored).

        ``Tip.from_attrs`` returns whichever shape the attrs name; on a subclass
        (``Sphere.from_attrs``) the attrs must name that shape.

        Parameters
        ----------
        attrs : mapping
            Holds ``tip_shape`` (one of :data:`TIP_SHAPES`) and ``tip_radius`` [m] (sphere,
            paraboloid, flat) or ``tip_half_angle`` [degree] (cone, pyramid).

        Returns
        -------
        Tip
            The tip.

        Raises
        ------
        ParameterError
            If ``attrs`` is not a mapping, lacks a key, names an unknown shape (or another shape
            than the subclass it is called on), or holds a value out of range.
        """
        if not isinstance(attrs, Mapping):
            raise ParameterError(f"attrs must be a mapping (dataset attrs), got {describe_value(attrs)}")
        shape = attrs.get("tip_shape")
        if shape is None:
            raise ParameterError(f"attrs lack 'tip_shape' (one of {', '.join(TIP_SHAPES)}); "
                                 f"got keys {sorted(map(str, attrs))}")
        kind = _CLASSES.get(shape) if isinstance(shape, str) else None
        if kind is None:
            raise ParameterError(f"tip_shape must be one of {', '.join(TIP_SHAPES)}, got "
                                 f"{describe_value(shape)}")
        if cls is not Tip and not issubclass(kind, cls):
            raise ParameterError(f"{cls.__name__}.from_attrs needs tip_shape {cls.shape!r}, got "
                                 f"{shape!r} (use Tip.from_attrs for any shape)")
        key = "tip_half_angle" if issubclass(kind, _AngledTip) else "tip_radius"
        if key not in attrs:
            raise ParameterError(f"attrs with tip_shape {shape!r} lack {key!r} "
                                 f"({'[degree]' if key == 'tip_half_angle' else '[m]'})")
        if issubclass(kind, _AngledTip):
            return kind.from_degrees(attrs[key])
        return kind(attrs[key])


# ── tips described by a length ──────────────────────────────────────────────────────────────


@dataclass(frozen=True)
class _RadiusTip(Tip):
    """A tip whose one parameter is a radius [m] > 0."""

    radius: float

    _label: ClassVar[str] = "R"

    def __post_init__(self):
        radius = require_positive("radius", self.radius)
        low, high = TIP_RADIUS_RANGE
        if not low <= radius <= high:
            raise ParameterError(
                f"radius must be within the plausible range [{low:g}, {high:g}] m (1 nm to 1 m: "
                f"a sharp tip's apex to a macroscopic sphere), got {shown(self.radius)!r} m")
        object.__setattr__(self, "radius", radius)

    def describe(self) -> str:
        """Short human text, e.g. ``"sphere R = 10 µm"``."""
        return f"{self.shape} {self._label} = {format_quantity(self.radius, 'length')}"

    def as_attrs(self) -> dict[str, str | float]:
        """NetCDF-safe attrs ``{"tip_shape": ..., "tip_radius": radius [m]}``."""
        return {"tip_shape": self.shape, "tip_radius": float(self.radius)}


@dataclass(frozen=True)
class RigidSphere(_RadiusTip):
    """Rigid sphere of radius R, Sneddon's exact solution (not the paraboloid of Hertz).

    The contact radius a < R follows from δ = (a/2)·ln((R + a)/(R − a)) and the load is
    F = (E_star/2)·[(a² + R²)·ln((R + a)/(R − a)) − 2aR] (Sneddon 1965, §6;
    E_star = E/2). With a = R·tanh s both read δ = R·s·tanh s and
    F = E_star·R²·[(1 + tanh²s)·s − tanh s], which is how they are evaluated (s by a safeguarded
    Newton iteration, a Taylor series for small s). For δ ≪ R it tends to Hertz
    (:class:`Paraboloid`): F_sphere/F_Hertz = 1 − δ/(10R) − δ²/(840R²) + … The stiffness is
    dF/dδ = 2E_star·a = E·a.

    Every finite δ has a < R in exact arithmetic, but a → R exponentially
    (R − a ≈ 2R·e^{−2δ/R}); beyond δ = :attr:`MAX_DEPTH_RATIO`·R (18 R), R − a is below double
    precision and the call raises. (Strains that large are far outside linear elasticity anyway.)

    Parameters
    ----------
    radius : float
        Sphere radius R [m], > 0.

    References
    ----------
    Sneddon, Int. J. Eng. Sci. 3, 47 (1965), §6 (the spherical punch).
    """

    shape: ClassVar[str] = "sphere"
    #: Largest δ/R accepted (R − a ≈ 2R·e^{−36} ≈ 5e-16 R there).
    MAX_DEPTH_RATIO: ClassVar[float] = 18.0

    @property
    def max_indentation(self) -> float:
        """Deepest indentation accepted, MAX_DEPTH_RATIO·R [m]."""
        return self.MAX_DEPTH_RATIO * self.radius

    def _s(self, delta: ArrayLike) -> FloatArray:
        """The parameter s ≥ 0 of a = R·tanh s solving s·tanh s = δ/R."""
        d = _as_depth(delta)
        x = d / self.radius
        too_deep = x > self.MAX_DEPTH_RATIO
        if too_deep.any():
            i = int(np.flatnonzero(too_deep.ravel())[0])
            raise ParameterError(
                f"delta (indentation) must be <= {self.MAX_DEPTH_RATIO:g}·R = "
                f"{format_quantity(self.max_indentation, 'length')} for a sphere of radius "
                f"R = {format_quantity(self.radius, 'length')} (Sneddon's sphere needs contact "
                f"radius a < R; beyond {self.MAX_DEPTH_RATIO:g} R, R − a is below double "
                f"precision); entry {i} is {float(d.ravel()[i])!r}")
        return _solve_s_tanh_s(x)

    def force_shape(self, delta: ArrayLike) -> FloatArray:
        """F/E = (R²/2)·[(1 + tanh²s)·s − tanh s] [m²] with s·tanh s = δ/R (see the class)."""
        s = self._s(delta)
        small = s < _SERIES_BELOW
        s2 = s * s
        series = np.zeros_like(s)
        for c in reversed(_SPHERE_SERIES):
            series = series * s2 + c
        series *= s2 * s
        t = np.tanh(s)
        closed = (1.0 + t * t) * s - t
        f = np.where(small, series, closed)
        return _out(0.5 * self.radius**2 * f)

    def contact_stiffness_factor(self, delta: ArrayLike) -> FloatArray:
        """S = a(δ) = R·tanh s [m] with s·tanh s = δ/R."""
        return self.contact_radius(delta)

    def contact_radius(self, delta: ArrayLike) -> FloatArray:
        """Contact radius a(δ) = R·tanh s [m] (< R) with s·tanh s = δ/R."""
        return _out(self.radius * np.tanh(self._s(delta)))


def _solve_s_tanh_s(x: FloatArray) -> FloatArray:
    """Solve s·tanh s = x ≥ 0 elementwise for s ≥ 0 (safeguarded Newton; exact at x = 0).

    The root lies in [max(x, √x), x + 1] (since tanh s ≤ min(1, s) and s·(1 − tanh s) < 1).
    The start is the series s² = x + x²/3 + 4x³/45 (x < 1) or s = x/tanh x; a Newton step that
    leaves the bracket becomes a bisection, so it always converges (in ≤ 6 steps in practice).
    """
    shape = np.shape(x)
    x = np.atleast_1d(x)
    lo = np.maximum(x, np.sqrt(x))
    hi = x + 1.0
    with np.errstate(divide="ignore", invalid="ignore"):
        start = np.where(x < 1.0, np.sqrt(x * (1.0 + x * (1.0 / 3.0 + x * (4.0 / 45.0)))),
                         x / np.tanh(x))
    s = np.clip(start, lo, hi)
    active = x > 0
    for _ in range(100):
        if not active.any():
            break
        t = np.tanh(s)
        g = s * t - x
        lo = np.where(g < 0, s, lo)
        hi = np.where(g > 0, s, hi)
        slope = t + s * (1.0 - t * t)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = s - g / slope
        inside = (newton >= lo) & (newton <= hi) & np.isfinite(newton)
        new = np.where(active, np.where(inside, newton, 0.5 * (lo + hi)), s)
        converged = (np.abs(new - s) <= 4 * np.finfo(float).eps * new) | (g == 0)
        active &= ~converged
        s = new
    return np.where(x > 0, s, 0.0).reshape(shape)


#: The earlier name of :class:`RigidSphere` (``viscoforce.physics.tips.Sphere``, ``--tip sphere:R``).
Sphere = RigidSphere


@dataclass(frozen=True)
class Paraboloid(_RadiusTip):
    """Paraboloid of apex radius R: Hertz contact (Johnson 1985, §4.2, Eqs. 4.22–4.23).

    F = (4/3)·E_star·√R·δ^{3/2} = (2/3)·E·√R·δ^{3/2}, a = √(Rδ), and S = dF/dδ / E = √(Rδ) — the
    contact stiffness the viscoforce contact model uses. It is the small-δ limit of
    :class:`RigidSphere`.

    Parameters
    ----------
    radius : float
        Apex radius of curvature R [m], > 0.

    References
    ----------
    Johnson, Contact Mechanics (1985), §4.2, Eqs. 4.22–4.23; Sneddon (1965), §6.
    """

    shape: ClassVar[str] = "paraboloid"

    def force_shape(self, delta: ArrayLike) -> FloatArray:
        """F/E = (2/3)·√R·δ^{3/2} [m²]."""
        return _out(self._shape(_as_depth(delta).copy()))

    def _shape(self, depth: FloatArray, work: FloatArray | None = None) -> FloatArray:
        root = np.sqrt(depth, out=work)
        return np.multiply(np.multiply(depth, (2.0 / 3.0) * np.sqrt(self.radius), out=depth),
                           root, out=depth)

    def contact_stiffness_factor(self, delta: ArrayLike) -> FloatArray:
        """S = a = √(Rδ) [m]."""
        return self.contact_radius(delta)

    def contact_radius(self, delta: ArrayLike) -> FloatArray:
        """Contact radius a = √(Rδ) [m]."""
        return _out(np.sqrt(self.radius * _as_depth(delta)))


@dataclass(frozen=True)
class Flat(_RadiusTip):
    """Flat cylindrical punch of radius a (Boussinesq; Sneddon 1965, §6; Johnson 1985, ch. 5).

    F = 2·E_star·a·δ = E·a·δ, linear in δ; the contact radius is the punch radius at every δ, and
    S = a (also at δ = 0, the right-hand derivative).

    Parameters
    ----------
    radius : float
        Punch radius a [m], > 0.

    References
    ----------
    Sneddon (1965), §6 (the flat-ended punch); Johnson, Contact Mechanics (1985), ch. 5.
    """

    shape: ClassVar[str] = "flat"

    def describe(self) -> str:
        """Short human text, e.g. ``"flat punch radius = 5 µm"``."""
        return f"flat punch radius = {format_quantity(self.radius, 'length')}"

    def force_shape(self, delta: ArrayLike) -> FloatArray:
        """F/E = a·δ [m²]."""
        return _out(self._shape(_as_depth(delta).copy()))

    def _shape(self, depth: FloatArray, work: FloatArray | None = None) -> FloatArray:
        return np.multiply(depth, self.radius, out=depth)

    def contact_stiffness_factor(self, delta: ArrayLike) -> FloatArray:
        """S = a [m] at every δ ≥ 0."""
        return self.contact_radius(delta)

    def contact_radius(self, delta: ArrayLike) -> FloatArray:
        """Contact radius a [m] (the punch radius) at every δ ≥ 0."""
        return _out(np.full_like(_as_depth(delta), self.radius))


# ── tips described by an angle ──────────────────────────────────────────────────────────────


@dataclass(frozen=True)
class _AngledTip(Tip):
    """A self-similar tip whose one parameter is a half-angle θ in (0, π/2) [rad]."""

    half_angle: float

    _angle_note: ClassVar[str] = ""

    def __post_init__(self):
        theta = require_finite("half_angle", self.half_angle)
        if not 0.0 < theta < 0.5 * math.pi:
            hint = ""
            if 1.0 <= theta < 90.0:
                hint = (f"; half_angle is in radians — for {shown(self.half_angle)!r}° use "
                        f"{type(self).__name__}.from_degrees({shown(self.half_angle)!r})")
            raise ParameterError(
                f"half_angle must be in (0, π/2) rad = (0°, 90°), got {shown(self.half_angle)!r} rad"
                f"{hint}")
        low, high = TIP_HALF_ANGLE_RANGE
        if not _RADIANS[0] <= theta <= _RADIANS[1]:
            raise ParameterError(
                f"half_angle must be within the plausible range [{_RADIANS[0]:.4g}, "
                f"{_RADIANS[1]:.4g}] rad = [{low:g}°, {high:g}°], got {shown(self.half_angle)!r} "
                f"rad = {math.degrees(theta):.4g}°")
        object.__setattr__(self, "half_angle", theta)

    @classmethod
    def from_degrees(cls, half_angle_deg: float) -> _AngledTip:
        """Build the tip from its half-angle in degrees.

        Parameters
        ----------
        half_angle_deg : float
            Half-angle θ [degree], in :data:`~viscoforce._limits.TIP_HALF_ANGLE_RANGE`
            ([0.1, 89.9]).

        Returns
        -------
        Cone or Pyramid
            The tip, with ``half_angle`` in radians.

        Raises
        ------
        ParameterError
            If the angle is not a finite number in that range.
        """
        deg = require_finite("half_angle (degree)", half_angle_deg)
        low, high = TIP_HALF_ANGLE_RANGE
        if not low - _ANGLE_SLACK <= deg <= high + _ANGLE_SLACK:  # slack: attrs round trips
            raise ParameterError(f"half_angle (degree) must be in [{low:g}, {high:g}], got "
                                 f"{shown(half_angle_deg)!r}")
        return cls(min(max(math.radians(deg), _RADIANS[0]), _RADIANS[1]))

    @property
    def half_angle_degrees(self) -> float:
        """The half-angle θ [degree]."""
        return math.degrees(self.half_angle)

    def describe(self) -> str:
        """Short human text, e.g. ``"cone half-angle = 20°"``."""
        return f"{self.shape} half-angle = {self.half_angle_degrees:.4g}°{self._angle_note}"

    def as_attrs(self) -> dict[str, str | float]:
        """NetCDF-safe attrs ``{"tip_shape": ..., "tip_half_angle": θ [degree]}``."""
        return {"tip_shape": self.shape, "tip_half_angle": self.half_angle_degrees}


@dataclass(frozen=True)
class Cone(_AngledTip):
    """Rigid cone of half-angle θ (axis to flank), Sneddon (1965), §6.

    F = (2/π)·E_star·tanθ·δ² = (E/π)·tanθ·δ², a = 2δ·tanθ/π, S = a = (2/π)·tanθ·δ.

    Parameters
    ----------
    half_angle : float
        Half-angle θ between the axis and the flank [rad], in (0, π/2) (use
        :meth:`from_degrees` for degrees).

    References
    ----------
    Sneddon, Int. J. Eng. Sci. 3, 47 (1965), §6 (the conical punch); Johnson, Contact Mechanics
    (1985), ch. 5.
    """

    shape: ClassVar[str] = "cone"

    def force_shape(self, delta: ArrayLike) -> FloatArray:
        """F/E = tanθ·δ²/π [m²]."""
        return _out(self._shape(_as_depth(delta).copy()))

    def _shape(self, depth: FloatArray, work: FloatArray | None = None) -> FloatArray:
        return np.multiply(depth, np.multiply(depth, math.tan(self.half_angle) / math.pi,
                                              out=work), out=depth)

    def contact_stiffness_factor(self, delta: ArrayLike) -> FloatArray:
        """S = a = (2/π)·tanθ·δ [m]."""
        return self.contact_radius(delta)

    def contact_radius(self, delta: ArrayLike) -> FloatArray:
        """Contact radius a = 2δ·tanθ/π [m]."""
        return _out(2.0 * math.tan(self.half_angle) / math.pi * _as_depth(delta))


@dataclass(frozen=True)
class Pyramid(_AngledTip):
    """Regular four-sided pyramid, Bilodeau (1992): F = 0.7453·E_star·tanθ·δ².

    θ is Bilodeau's angle: the **face** semi-angle, between the pyramid's axis and the midline of
    a face (not the edge; a pyramid with face semi-angle θ has edge semi-angle arctan(√2·tanθ)).
    The coefficient lies, as it must, between those of the inscribed cone (half-angle θ,
    2/π = 0.6366) and the circumscribed cone (0.6366·√2 = 0.9003). In paper units
    F = 0.37265·E·tanθ·δ², so S = dF/dδ / E = 0.7453·tanθ·δ [m]; :meth:`contact_radius` is the
    *equivalent* contact radius defined by dF/dδ = 2E_star·a (a pyramid's contact is not a disc).

    Accuracy: 0.7453 is Bilodeau's approximate solution of the punch problem. The exact rigid,
    frictionless pyramid on an elastic half-space gives 0.7376 (:data:`PYRAMID_EXACT_COEFFICIENT`,
    ±1e-4: a boundary-element solve on square pixels with the contact area free, 0.7382, 0.7377
    and 0.73767 at 64, 160 and 240 pixels across, converging from above; the same solver gives the
    cone's 2/π to 1e-5). So this law is 1.04 % too stiff, and a modulus fitted with it is 1.03 %
    low: E_exact = E·0.7453/0.7376. It is kept because it is the constant the AFM literature and
    software such as nanite report pyramid moduli with, so that moduli compare; 1 % is below what
    the tip's real face angle and apex add (±1° at 20° is ±5 % in tanθ); and the bottom-effect
    correction's equivalent cone (:mod:`viscoforce.physics.bottom_effect`) shares it.

    Parameters
    ----------
    half_angle : float
        Face semi-angle θ [rad], in (0, π/2) (use :meth:`from_degrees` for degrees).

    References
    ----------
    G. G. Bilodeau, "Regular pyramid punch problem", J. Appl. Mech. 59, 519–523 (1992).
    """

    shape: ClassVar[str] = "pyramid"
    _angle_note: ClassVar[str] = " (face)"

    def force_shape(self, delta: ArrayLike) -> FloatArray:
        """F/E = (0.7453/2)·tanθ·δ² [m²]."""
        return _out(self._shape(_as_depth(delta).copy()))

    def _shape(self, depth: FloatArray, work: FloatArray | None = None) -> FloatArray:
        factor = 0.5 * BILODEAU_COEFFICIENT * math.tan(self.half_angle)
        return np.multiply(depth, np.multiply(depth, factor, out=work), out=depth)

    def contact_stiffness_factor(self, delta: ArrayLike) -> FloatArray:
        """S = 0.7453·tanθ·δ [m] (Bilodeau's dF/dδ over the paper's E)."""
        return self.contact_radius(delta)

    def contact_radius(self, delta: ArrayLike) -> FloatArray:
        """Equivalent contact radius a = 0.7453·tanθ·δ [m], from dF/dδ = 2E_star·a."""
        return _out(BILODEAU_COEFFICIENT * math.tan(self.half_angle) * _as_depth(delta))


_CLASSES: dict[str, type[Tip]] = {
    "sphere": RigidSphere, "paraboloid": Paraboloid, "cone": Cone, "pyramid": Pyramid, "flat": Flat}
