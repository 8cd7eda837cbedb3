"""Bottom-effect corrections: a tip indenting an elastic layer of thickness h on a rigid support.

The half-space contact laws of :mod:`viscoforce.physics.tips` assume an infinitely thick sample.
A cell (2–10 µm) or a gel film on glass is a layer: the rigid support stiffens the response, so a
half-space fit overestimates the modulus. For a layer that is thick compared with the contact
radius, the load is the half-space load times a series in the ratio contact size / thickness::

    F_layer(δ) = F_half-space(δ) · f(x),    f(x) = 1 + c1·x + c2·x² + c3·x³ + c4·x⁴

with x = √(Rδ)/h (paraboloid and sphere, the published χ), x = tanθ·δ/h (cone) or x = a/h (flat
punch of radius a). The factor is geometric: it multiplies the load in any modulus convention, and
by the correspondence principle (an elastic–viscoelastic analogy, exact when ν does not depend on
time) it multiplies the complex contact stiffness of a viscoelastic layer too.

* :func:`force_factor` — f = F_layer/F_half-space at indentation δ [m] and sample height h [m];
* :func:`stiffness_factor` — g = (dF/dδ)_layer/(dF/dδ)_half-space, derived analytically from the
  same series: g = f(x) + (d ln x/d ln δ)·(F/(δ·S))·x·f′(x), with S = dF/dδ of the half-space
  (g = f + x·f′/3 for a paraboloid, f + x·f′/2 for a cone, f for a flat punch). The contact
  model's k*(ω) = E*(ω)·S(δ0) becomes E*(ω)·S(δ0)·g(δ0);
* :func:`corrected_modulus` — the modulus of the layer from an apparent (half-space) one;
* :func:`max_depth` — the deepest indentation the chosen series is accepted for;
* :func:`bottom_effect_series` — the series (coefficients, variable, validity, reference) used.

Series (``series=``)
--------------------
``"garcia"`` — Garcia & Garcia (2018), bonded layer, incompressible (ν = 0.5): paraboloid
(1.133, 1.497, 1.469, 0.755) in χ = √(Rδ)/h, cone (0.721, 0.650, 0.491, 0.225) in tanθ·δ/h, flat
punch (1.133, 1.283, 0.598, −0.291) in a/h.

``"dimitriadis"`` — Dimitriadis et al. (2002), paraboloid only, bonded or not, any ν in [0, 0.5]:
f = 1 − (2α0/π)χ + (4α0²/π²)χ² − (8/π³)(α0³ + 4π²β0/15)χ³ + (16α0/π⁴)(α0³ + 3π²β0/5)χ⁴ with, bonded,
α0 = −(1.2876 − 1.4678ν + 1.3442ν²)/(1 − ν), β0 = (0.6387 − 1.0277ν + 1.5164ν²)/(1 − ν); not
bonded, α0 = −0.347(3 − 2ν)/(1 − ν), β0 = 0.056(5 − 2ν)/(1 − ν). At ν = 0.5 this gives
(1.133, 1.283, 0.769, −0.0975) bonded and (0.884, 0.781, 0.386, 0.0048) not bonded. The paper's
printed ν = 0.5 bonded series has +0.0975χ⁴: the sign disagrees with its own general expression
(the non-bonded one agrees); the general expression is used here. Inside the accepted range
below (χ ≤ 0.2) the two differ by at most 2·0.0975·0.2⁴ = 3.1e-4.

Default (``series=None``): ``"garcia"`` for a bonded incompressible layer (every shape), else
``"dimitriadis"`` for a paraboloid or sphere. A cone, pyramid or flat punch on a non-bonded or
compressible layer is refused naming ``bonded`` or ``poisson``: no published series covers it, and
none is guessed.

Checked against an exact solution
---------------------------------
Every series was compared with a numerical solution of the layer problem (the Lebedev–Ufliand
Fredholm equation with the exact layer kernels, ``tests/theory/_layer_solve.py``; see
``docs/bottom_effect.md``). Each series is accepted up to the x where either its force factor or
its stiffness factor first departs from that solution by :data:`ACCURACY` (2 %):

=========================  ==================  ====================================
series, shape              accepted            largest error inside (force, stiff.)
=========================  ==================  ====================================
garcia, paraboloid/sphere  χ ≤ 0.5             0.7 %, 1.6 %
garcia, cone/pyramid       tanθ·δ/h ≤ 0.85     0.3 %, 1.5 %
garcia, flat punch         a/h ≤ 0.8           1.9 % (force = stiffness)
dimitriadis, bonded        χ ≤ 0.2             1.1 %, 1.9 % (worst ν: 0.5)
dimitriadis, not bonded    χ ≤ 0.1             1.4 %, 1.9 % (worst ν: 0.5)
=========================  ==================  ====================================

Beyond, the functions raise :class:`~viscoforce.exceptions.ParameterError` naming ``depth`` and
``sample_height`` and the deepest accepted indentation. The exact solution also shows why the
Dimitriadis series fades early: its χ² coefficient 4α0²/π² is the flat punch's, while the
paraboloid's is (7/6)·(2α0/π)² (the contact radius grows with the extra load; Garcia & Garcia's
1.497 is this value), and its non-bonded α0 depends on ν although the frictionless-base layer's
kernel does not (in E_star units).

Tips
----
:class:`~viscoforce.physics.tips.Paraboloid` uses the paraboloid series;
:class:`~viscoforce.physics.tips.RigidSphere` multiplies Sneddon's sphere load by the same factor
(χ = √(Rδ)/h, valid for δ ≪ R, as in both papers). :class:`~viscoforce.physics.tips.Cone` uses the
cone series; :class:`~viscoforce.physics.tips.Pyramid` its *equivalent cone*, the one with the same
half-space load F = 0.7453·E_star·tanθ·δ² (Bilodeau): tanθ_cone = (π/2)·0.7453·tanθ_face. That
cone has the same load and the same equivalent contact radius, hence the same first- and
second-order bottom effect (which depend on the load alone); the face–edge shape enters at
third order. :class:`~viscoforce.physics.tips.Flat` uses the flat-punch series (its factor does
not depend on δ).

References
----------
* E. K. Dimitriadis, F. Horkay, J. Maresca, B. Kachar, R. S. Chadwick, "Determination of elastic
  moduli of thin layers of soft material using the atomic force microscope", Biophys. J. 82,
  2798–2810 (2002): the general series and α0(ν), β0(ν), and the ν = 0.5 series (Eqs. 11–12 as
  cited by PyFMRheo; the equation numbers were not checked against the paper here).
* P. D. Garcia, R. Garcia, "Determination of the elastic moduli of a single cell cultured on a
  rigid support by force microscopy", Biophys. J. 114, 2923–2932 (2018): the bottom-effect
  corrected paraboloid, cone and flat-punch laws (coefficients as implemented by PyFMRheo, MIT).
* N. Gavara, R. S. Chadwick, "Determination of the elastic moduli of thin samples and adherent
  cells using conical atomic force microscope tips", Nat. Nanotechnol. 7, 733–736 (2012).
* W. C. Hayes, L. M. Keer, G. Herrmann, L. F. Mockros, "A mathematical analysis for indentation
  tests of articular cartilage", J. Biomech. 5, 541–551 (1972): the layer formulation of the check.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._limits import SAMPLE_HEIGHT_RANGE
from viscoforce._typing import FloatArray
from viscoforce._validation import as_float_array, as_real_array, describe_value, require_in_range
from viscoforce.exceptions import ParameterError
from viscoforce.physics.moduli import DEFAULT_POISSON, _out
from viscoforce.physics.tips import (
    BILODEAU_COEFFICIENT,
    Cone,
    Flat,
    Paraboloid,
    Pyramid,
    RigidSphere,
    Tip,
)
from viscoforce.units import format_quantity

__all__ = [
    "ACCURACY",
    "SERIES",
    "BottomEffectSeries",
    "bottom_effect_series",
    "corrected_modulus",
    "force_factor",
    "max_depth",
    "stiffness_factor",
]

#: Largest departure from the exact layer solution (force or stiffness factor) inside the range
#: each series is accepted for.
ACCURACY = 0.02

#: The series names accepted by ``series=``.
SERIES: tuple[str, ...] = ("garcia", "dimitriadis")

_GARCIA = "P. D. Garcia & R. Garcia, Biophys. J. 114, 2923 (2018)"
_DIMITRIADIS = "E. K. Dimitriadis et al., Biophys. J. 82, 2798 (2002)"

#: Garcia & Garcia (2018) coefficients (c1..c4) of the bonded incompressible layer, per shape.
_GARCIA_COEFFICIENTS: dict[str, tuple[float, float, float, float]] = {
    "paraboloid": (1.133, 1.497, 1.469, 0.755),
    "cone": (0.721, 0.650, 0.491, 0.225),
    "flat": (1.133, 1.283, 0.598, -0.291),
}

#: Largest accepted x per (series, shape, bonded): where the series meets ACCURACY against the
#: exact layer solve (force and stiffness factors; Dimitriadis: the worst ν in [0, 0.5]).
_LIMITS: dict[tuple[str, str, bool], float] = {
    ("garcia", "paraboloid", True): 0.5,
    ("garcia", "cone", True): 0.85,
    ("garcia", "flat", True): 0.8,
    ("dimitriadis", "paraboloid", True): 0.2,
    ("dimitriadis", "paraboloid", False): 0.1,
}

_VARIABLES = {"paraboloid": "χ = √(Rδ)/h", "cone": "tanθ·δ/h", "flat": "a/h"}
_TITLES = {"garcia": "Garcia & Garcia (2018)", "dimitriadis": "Dimitriadis et al. (2002)"}


@dataclass(frozen=True)
class BottomEffectSeries:
    """One bottom-effect series f(x) = 1 + c1·x + c2·x² + c3·x³ + c4·x⁴ and where it holds.

    Made by :func:`bottom_effect_series`; a frozen record, no state.

    Parameters
    ----------
    name : str
        ``"garcia"`` or ``"dimitriadis"`` (:data:`SERIES`).
    shape : str
        The shape the series is written for: ``"paraboloid"``, ``"cone"`` or ``"flat"``.
    bonded : bool
        True for a layer bonded to its rigid support, False for one free to slide on it.
    poisson : float
        The layer's Poisson's ratio ν the coefficients are for.
    coefficients : tuple of float
        c1, c2, c3, c4.
    max_variable : float
        Largest x accepted (see the module's table).
    variable : str
        What x is: ``"χ = √(Rδ)/h"``, ``"tanθ·δ/h"`` or ``"a/h"``.
    reference : str
        The publication.
    """

    name: str
    shape: str
    bonded: bool
    poisson: float
    coefficients: tuple[float, float, float, float]
    max_variable: float
    variable: str
    reference: str

    def factor(self, x: ArrayLike) -> FloatArray:
        """f(x) = 1 + Σ c_k x^k (dimensionless), vectorised over ``x`` ≥ 0."""
        x = np.asarray(x, dtype=float)
        c1, c2, c3, c4 = self.coefficients
        return 1.0 + x * (c1 + x * (c2 + x * (c3 + x * c4)))

    def slope(self, x: ArrayLike) -> FloatArray:
        """f′(x) = Σ k·c_k x^(k−1) (dimensionless), vectorised over ``x`` ≥ 0."""
        x = np.asarray(x, dtype=float)
        c1, c2, c3, c4 = self.coefficients
        return c1 + x * (2.0 * c2 + x * (3.0 * c3 + x * 4.0 * c4))


# ── inputs ────────────────────────────────────────────────────────────────────────────────────


def _shape_of(tip: Any) -> str:
    """The series shape of a tip, refusing anything that is not one of the five tip classes."""
    if isinstance(tip, Paraboloid | RigidSphere):
        return "paraboloid"
    if isinstance(tip, Cone | Pyramid):
        return "cone"
    if isinstance(tip, Flat):
        return "flat"
    raise ParameterError(
        f"tip must be a viscoforce.physics.tips Paraboloid, RigidSphere, Cone, Pyramid or Flat "
        f"(a bottom-effect series exists for those shapes only), got {describe_value(tip)}")


def _dimitriadis_coefficients(poisson: float, bonded: bool) -> tuple[float, float, float, float]:
    """c1..c4 of Dimitriadis et al. (2002) from their α0(ν), β0(ν)."""
    nu = poisson
    if bonded:
        alpha = -(1.2876 - 1.4678 * nu + 1.3442 * nu * nu) / (1.0 - nu)
        beta = (0.6387 - 1.0277 * nu + 1.5164 * nu * nu) / (1.0 - nu)
    else:
        alpha = -0.347 * (3.0 - 2.0 * nu) / (1.0 - nu)
        beta = 0.056 * (5.0 - 2.0 * nu) / (1.0 - nu)
    pi = math.pi
    return (-2.0 * alpha / pi,
            4.0 * alpha * alpha / pi**2,
            -8.0 / pi**3 * (alpha**3 + 4.0 * pi**2 / 15.0 * beta),
            16.0 * alpha / pi**4 * (alpha**3 + 3.0 * pi**2 / 5.0 * beta))


def bottom_effect_series(tip: Tip, *, poisson: float = DEFAULT_POISSON, bonded: bool = True,
                         series: str | None = None) -> BottomEffectSeries:
    """The bottom-effect series used for ``tip`` on a layer with Poisson's ratio ``poisson``.

    Parameters
    ----------
    tip : Tip
        A :class:`~viscoforce.physics.tips.Paraboloid`, ``RigidSphere``, ``Cone``, ``Pyramid`` or
        ``Flat``.
    poisson : float, optional
        The layer's Poisson's ratio ν, in [0, 0.5] (default 0.5, incompressible).
    bonded : bool, optional
        True (default): the layer is bonded to its rigid support (a cell spread on glass); False:
        it slides on it without friction.
    series : {None, "garcia", "dimitriadis"}, optional
        None (default) picks ``"garcia"`` for a bonded layer with ν = 0.5 and for every cone,
        pyramid or flat punch, else ``"dimitriadis"``.

    Returns
    -------
    BottomEffectSeries
        Coefficients, variable, accepted range and reference.

    Raises
    ------
    ParameterError
        If ``tip`` is not one of the five shapes, ``poisson`` is outside [0, 0.5], ``bonded`` is
        not a bool, ``series`` is unknown, or no published series covers the combination:
        ``"garcia"`` needs ``bonded=True`` and ``poisson=0.5``; ``"dimitriadis"`` covers the
        paraboloid and the sphere only.
    """
    shape = _shape_of(tip)
    nu = require_in_range("poisson", poisson, 0.0, 0.5)
    if not isinstance(bonded, bool | np.bool_):
        raise ParameterError(f"bonded must be True (layer bonded to its support) or False (free "
                             f"to slide), got {describe_value(bonded)}")
    bonded = bool(bonded)
    if series is not None and series not in SERIES:
        raise ParameterError(f"series must be None (automatic) or one of {', '.join(SERIES)}, "
                             f"got {describe_value(series)}")
    name = series or ("garcia" if shape != "paraboloid" or (bonded and nu == 0.5)
                      else "dimitriadis")
    if name == "dimitriadis" and shape != "paraboloid":
        raise ParameterError(
            f"series 'dimitriadis' covers a paraboloid or sphere only, not a {tip.describe()} "
            f"(series='garcia' or None for a bonded incompressible layer)")
    if name == "garcia":
        if not bonded:
            raise ParameterError(
                f"bonded must be True for series 'garcia' (Garcia & Garcia 2018 treat a layer "
                f"bonded to its support only){_other(shape)}")
        if nu != 0.5:
            raise ParameterError(
                f"poisson must be 0.5 for series 'garcia' (Garcia & Garcia 2018 treat an "
                f"incompressible layer only), got {nu:g}{_other(shape)}")
        coefficients = _GARCIA_COEFFICIENTS[shape]
        reference = _GARCIA
    else:
        coefficients = _dimitriadis_coefficients(nu, bonded)
        reference = _DIMITRIADIS
    return BottomEffectSeries(name=name, shape=shape, bonded=bonded, poisson=nu,
                              coefficients=coefficients, max_variable=_LIMITS[name, shape, bonded],
                              variable=_VARIABLES[shape], reference=reference)


def _other(shape: str) -> str:
    """Where to turn when Garcia & Garcia's series does not apply."""
    if shape == "paraboloid":
        return "; series='dimitriadis' covers a paraboloid or sphere on any layer"
    return f"; no published series covers a {shape} on such a layer, so none is guessed"


def _heights(sample_height: ArrayLike) -> FloatArray:
    h = as_float_array("sample_height", sample_height)
    low, high = SAMPLE_HEIGHT_RANGE
    bad = (h < low) | (h > high)
    if bad.any():
        i = int(np.flatnonzero(bad.ravel())[0])
        raise ParameterError(
            f"sample_height must be within the plausible range [{low:g}, {high:g}] m (a layer "
            f"a nanometre to a metre thick); entry {i} is {float(h.ravel()[i])!r} m")
    return h


def _depths(depth: ArrayLike) -> FloatArray:
    d = as_float_array("depth (indentation)", depth)
    if (d < 0).any():
        i = int(np.flatnonzero(d.ravel() < 0)[0])
        raise ParameterError(f"depth (indentation) must be >= 0 m (0 is first contact); entry {i} "
                             f"is {float(d.ravel()[i])!r} m")
    return d


def _scale(tip: Tip, shape: str) -> float:
    """x·h per δ (cone: tanθ; pyramid: its equivalent cone's), per √δ (paraboloid: √R), or a (flat)."""
    if isinstance(tip, Pyramid):
        return 0.5 * math.pi * BILODEAU_COEFFICIENT * math.tan(tip.half_angle)
    if shape == "cone":
        return math.tan(tip.half_angle)
    return math.sqrt(tip.radius) if shape == "paraboloid" else tip.radius


def _variable(tip: Tip, s: BottomEffectSeries, depth: FloatArray, height: FloatArray) -> FloatArray:
    """The series variable x at (depth, height), refusing depths beyond the series' range."""
    scale = _scale(tip, s.shape)
    if s.shape == "flat":
        x = np.broadcast_to(scale / height, np.broadcast_shapes(depth.shape, height.shape))
    elif s.shape == "cone":
        x = scale * depth / height
    else:
        x = scale * np.sqrt(depth) / height
    too_thin = depth >= height
    if too_thin.any():
        i = int(np.flatnonzero(np.broadcast_to(too_thin, x.shape).ravel())[0])
        d, h = (float(np.broadcast_to(v, x.shape).ravel()[i]) for v in (depth, height))
        raise ParameterError(
            f"depth (indentation) must be < sample_height (the tip cannot reach the support); "
            f"entry {i} has depth {d!r} m at sample_height {h!r} m")
    over = x > s.max_variable * (1.0 + 1e-12)      # max_depth itself is accepted after rounding
    if over.any():
        i = int(np.flatnonzero(over.ravel())[0])
        d, h = (float(np.broadcast_to(v, x.shape).ravel()[i]) for v in (depth, height))
        raise ParameterError(_range_message(tip, s, d, h, float(x.ravel()[i]), i))
    return x


def _range_message(tip: Tip, s: BottomEffectSeries, depth: float, height: float, x: float,
                   i: int) -> str:
    why = (f"the {_TITLES[s.name]} series is accepted for {s.variable} <= "
           f"{s.max_variable:g}, where it agrees with an exact layer solution within "
           f"{ACCURACY:.0%}")
    if s.shape == "flat":
        need = format_quantity(tip.radius / s.max_variable, "length")
        return (f"sample_height must be >= {need} for a {tip.describe()} ({why}); entry {i} is "
                f"{height!r} m (a/h = {x:.3g})")
    deepest = format_quantity(_deepest(tip, s, height), "length")
    return (f"depth (indentation) must be <= {deepest} at sample_height "
            f"{format_quantity(height, 'length')} for a {tip.describe()} ({why}); entry {i} has "
            f"depth {depth!r} m ({s.variable.split(' =')[0]} = {x:.3g}); fit only the shallower "
            f"part (max_depth gives the limit)")


def _deepest(tip: Tip, s: BottomEffectSeries, height: ArrayLike) -> FloatArray:
    scale = _scale(tip, s.shape)
    if s.shape == "cone":
        return s.max_variable * np.asarray(height) / scale
    return (s.max_variable * np.asarray(height) / scale) ** 2


# ── the factors ───────────────────────────────────────────────────────────────────────────────


def force_factor(tip: Tip, depth: ArrayLike, sample_height: ArrayLike, *,
                 poisson: float = DEFAULT_POISSON, bonded: bool = True,
                 series: str | None = None) -> FloatArray:
    """F_layer/F_half-space: the load on a layer of height h over the half-space load at depth δ.

    Fit ``F = E·tip.force_shape(δ)·force_factor(tip, δ, h)`` to a force curve to get the layer's
    modulus (the factor depends on δ, so it belongs inside the fit, not after it).

    Parameters
    ----------
    tip : Tip
        A :class:`~viscoforce.physics.tips.Paraboloid`, ``RigidSphere``, ``Cone``, ``Pyramid`` or
        ``Flat``.
    depth : float or array_like
        Indentation δ [m], finite, ≥ 0 and < ``sample_height``.
    sample_height : float or array_like
        Thickness h [m] of the layer at the indented point, in
        :data:`~viscoforce._limits.SAMPLE_HEIGHT_RANGE`; broadcasts against ``depth``.
    poisson : float, optional
        The layer's Poisson's ratio ν, in [0, 0.5] (default 0.5).
    bonded : bool, optional
        True (default): bonded to its rigid support; False: free to slide on it.
    series : {None, "garcia", "dimitriadis"}, optional
        Which published series (default: see :func:`bottom_effect_series`).

    Returns
    -------
    float or ndarray
        f ≥ 1 (dimensionless); 1 at δ = 0 except for a flat punch (whose contact radius is fixed).

    Raises
    ------
    ParameterError
        For an input outside its range (named), a combination no series covers, ``depth`` ≥
        ``sample_height``, or a depth beyond the series' accepted range (the message gives the
        deepest accepted indentation at that height).
    """
    s = bottom_effect_series(tip, poisson=poisson, bonded=bonded, series=series)
    x = _variable(tip, s, _depths(depth), _heights(sample_height))
    return _out(np.asarray(s.factor(x), dtype=float))


def stiffness_factor(tip: Tip, depth: ArrayLike, sample_height: ArrayLike, *,
                     poisson: float = DEFAULT_POISSON, bonded: bool = True,
                     series: str | None = None) -> FloatArray:
    """(dF/dδ)_layer/(dF/dδ)_half-space: the contact-stiffness correction at depth δ.

    From the force series analytically: with F_layer = F·f(x) and x ∝ δ^m,
    g = f(x) + m·(F/(δ·S))·x·f′(x), S = dF/dδ of the half-space tip (g = f + x·f′/3 for a
    paraboloid, f + x·f′/2 for a cone or pyramid, g = f for a flat punch). The small-amplitude
    contact stiffness at operating indentation δ0 becomes k*(ω) = E*(ω)·S(δ0)·g(δ0, h).

    Parameters
    ----------
    tip : Tip
        A :class:`~viscoforce.physics.tips.Paraboloid`, ``RigidSphere``, ``Cone``, ``Pyramid`` or
        ``Flat``.
    depth : float or array_like
        Indentation δ [m] (the operating indentation δ0), finite, ≥ 0 and < ``sample_height``.
    sample_height : float or array_like
        Thickness h [m] of the layer, in :data:`~viscoforce._limits.SAMPLE_HEIGHT_RANGE`.
    poisson : float, optional
        The layer's Poisson's ratio ν, in [0, 0.5] (default 0.5).
    bonded : bool, optional
        True (default): bonded to its rigid support; False: free to slide on it.
    series : {None, "garcia", "dimitriadis"}, optional
        Which published series (default: see :func:`bottom_effect_series`).

    Returns
    -------
    float or ndarray
        g ≥ 1 (dimensionless).

    Raises
    ------
    ParameterError
        As :func:`force_factor`.
    """
    s = bottom_effect_series(tip, poisson=poisson, bonded=bonded, series=series)
    d = _depths(depth)
    x = _variable(tip, s, d, _heights(sample_height))
    g = s.factor(x)
    if s.shape != "flat":
        exponent = 1.0 if s.shape == "cone" else 0.5       # x ∝ δ^exponent
        d = np.broadcast_to(d, x.shape)
        inside = d > 0
        safe = np.where(inside, d, 1.0)
        ratio = tip.force_shape(safe) / (safe * tip.contact_stiffness_factor(safe))  # F/(δS)
        g = g + np.where(inside, exponent * ratio * x * s.slope(x), 0.0)
    return _out(np.asarray(g, dtype=float))


def max_depth(tip: Tip, sample_height: ArrayLike, *, poisson: float = DEFAULT_POISSON,
              bonded: bool = True, series: str | None = None) -> FloatArray:
    """The deepest indentation [m] the series is accepted for at sample height h.

    Use it to cut a force curve before a bottom-effect corrected fit.

    Parameters
    ----------
    tip : Tip
        As :func:`force_factor`.
    sample_height : float or array_like
        Thickness h [m] of the layer, in :data:`~viscoforce._limits.SAMPLE_HEIGHT_RANGE`.
    poisson, bonded, series
        As :func:`force_factor`.

    Returns
    -------
    float or ndarray
        δ_max [m], below ``sample_height``: (x_max·h)²/R for a paraboloid or sphere,
        x_max·h/tanθ for a cone (tanθ of the equivalent cone for a pyramid), ``inf`` for a flat
        punch (its factor does not depend on δ; :func:`force_factor` refuses a too-thin layer).
        Where the series' own limit lies deeper than the layer, δ_max is the largest double below
        ``sample_height`` (the tip cannot reach the support).

    Raises
    ------
    ParameterError
        As :func:`bottom_effect_series`, or ``sample_height`` out of range.
    """
    s = bottom_effect_series(tip, poisson=poisson, bonded=bonded, series=series)
    h = _heights(sample_height)
    if s.shape == "flat":
        return _out(np.full_like(h, np.inf))
    return _out(np.minimum(_deepest(tip, s, h), np.nextafter(h, 0.0)))


def corrected_modulus(modulus: ArrayLike, factor: ArrayLike) -> FloatArray:
    """The layer's modulus from an apparent (half-space) one: modulus/factor.

    An apparent modulus from one indentation δ (a pointwise Hertz modulus) is corrected with
    :func:`force_factor` at that δ; an apparent contact-model modulus E*(ω) at operating
    indentation δ0 (storage and loss parts alike: the loss tangent is unchanged) with
    :func:`stiffness_factor` at δ0. A Hertz fit over a range of δ needs the factor inside the
    fit instead (:func:`force_factor`).

    Parameters
    ----------
    modulus : float, complex or array_like
        Apparent modulus [Pa] in any convention (the paper's E, Young's, shear; complex
        E′ + iE″ allowed); NaN passes through (a failed fit stays NaN).
    factor : float or array_like
        The correction factor (dimensionless), finite and > 0 (≥ 1 from this module);
        broadcasts against ``modulus``.

    Returns
    -------
    float, complex or ndarray
        modulus/factor [Pa].

    Raises
    ------
    ParameterError
        If ``factor`` is not finite and > 0, or ``modulus`` is not numeric or holds ±inf.
    """
    f = as_float_array("factor (bottom-effect correction)", factor)
    if (f <= 0).any():
        i = int(np.flatnonzero(f.ravel() <= 0)[0])
        raise ParameterError(f"factor (bottom-effect correction) must be > 0; entry {i} is "
                             f"{float(f.ravel()[i])!r}")
    if np.iscomplexobj(modulus):
        m = np.asarray(modulus, dtype=complex)
    else:
        m = as_real_array("modulus", modulus)
    if np.isinf(m).any():
        i = int(np.flatnonzero(np.isinf(m).ravel())[0])
        raise ParameterError(f"modulus must be finite (NaN passes through); entry {i} is "
                             f"{m.ravel()[i]!r}")
    result = m / f
    return result[()] if result.ndim == 0 else result
