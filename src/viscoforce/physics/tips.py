"""Tip shapes: indentation → load, contact stiffness and contact radius of an elastic half-space.

Every tip is a small frozen dataclass implementing :class:`Tip`: :class:`RigidSphere` (Sneddon's exact
sphere; ``Sphere`` is its earlier name, not the particle :class:`viscoforce.Particle`),
:class:`Paraboloid` (Hertz), :class:`Cone` (Sneddon), :class:`Pyramid` (four-sided,
Bilodeau) and :class:`Flat` (flat cylindrical punch). Each gives, vectorised over the indentation
δ [m] (array_like, finite, δ ≥ 0, δ > 0 into the sample):

* :meth:`Tip.force_shape` — F/E [m²], so that load fits are linear in E;
* :meth:`Tip.force` — the load F(δ) [N] on an elastic sample of (paper) modulus E;
* :meth:`Tip.contact_stiffness_factor` — S(δ) = (dF/dδ)/E [m]. The small-amplitude dynamic
  stiffness of a linear viscoelastic sample held at indentation δ0 is k*(ω) = E*(ω)·S(δ0) (plus
  iωB for a viscous drag B). For every axisymmetric punch dF/dδ = 2E_star·a(δ) = E·a(δ)
  (Sneddon 1965; Pharr, Oliver & Brotzen 1992), so S = a, the contact radius;
* :meth:`Tip.contact_radius` — a(δ) [m] (the pyramid's is an *equivalent* radius, see there).

Modulus convention
------------------
``E`` is the paper's modulus (see :mod:`viscoforce.units`): 2/E = (1 − ν1²)/E1 + (1 − ν2²)/E2,
i.e. E = 2·E_star with Johnson's contact modulus E_star. For a rigid tip on a sample of Young's
modulus Y and Poisson's ratio ν, E_star = Y/(1 − ν²) and E = 2Y/(1 − ν²). The textbook formulas
below are written with E_star; the code uses E_star = E/2. :func:`young_from_paper`,
:func:`paper_from_young` and :func:`shear_from_young` convert (they live in
:mod:`viscoforce.physics.moduli`).

Text form
---------
:func:`parse_tip` reads the command-line grammar ``sphere:R | paraboloid:R | cone:ANGLE |
pyramid:ANGLE | flat:RADIUS``: lengths with their unit as :func:`viscoforce.units.parse_quantity`
reads them (``sphere:10um``, ``flat:2.5 µm``; a bare number is refused: ``sphere:5`` is not a
5 m sphere), half-angles in degrees unless they carry ``rad`` (``cone:20``, ``pyramid:17.5deg``,
``cone:35°``, ``cone:0.35rad``). :meth:`Tip.as_attrs` / :meth:`Tip.from_attrs` store a tip in
netCDF-safe dataset attrs.

Plausible ranges
----------------
A radius lies in :data:`~viscoforce._limits.TIP_RADIUS_RANGE` (1 nm to 1 m) and a half-angle in
:data:`~viscoforce._limits.TIP_HALF_ANGLE_RANGE` (0.1° to 89.9°), whichever way the tip is made;
anything else is refused naming the parameter and the range (a subnormal radius or a 1e300 m
sphere would otherwise underflow or overflow the contact laws).

References
----------
* I. N. Sneddon, "The relation between load and penetration in the axisymmetric Boussinesq
  problem for a punch of arbitrary profile", Int. J. Eng. Sci. 3, 47–57 (1965).
* G. G. Bilodeau, "Regular pyramid punch problem", J. Appl. Mech. 59, 519–523 (1992).
* K. L. Johnson, *Contact Mechanics*, Cambridge University Press (1985), §4.2 (Hertz,
  Eqs. 4.22–4.23) and ch. 5 (flat punch, cone).
* G. M. Pharr, W. C. Oliver, F. R. Brotzen, "On the generality of the relationship among contact
  stiffness, contact area, and elastic modulus during indentation", J. Mater. Res. 7, 613–617
  (1992).

Sneddon's equations are cited by section (§6, the worked punch profiles), not by number.
"""

from __future__ import annotations

from viscoforce.physics._tip_shapes import (
    BILODEAU_COEFFICIENT,
    PYRAMID_EXACT_COEFFICIENT,
    TIP_SHAPES,
    Cone,
    Flat,
    Paraboloid,
    Pyramid,
    RigidSphere,
    Sphere,
    Tip,
)
from viscoforce.physics._tip_text import parse_tip, tip_from
from viscoforce.physics.moduli import (
    DEFAULT_POISSON,
    paper_from_young,
    shear_from_young,
    young_from_paper,
)

__all__ = [
    "BILODEAU_COEFFICIENT",
    "DEFAULT_POISSON",
    "PYRAMID_EXACT_COEFFICIENT",
    "TIP_SHAPES",
    "Cone",
    "Flat",
    "Paraboloid",
    "Pyramid",
    "RigidSphere",
    "Sphere",
    "Tip",
    "paper_from_young",
    "parse_tip",
    "shear_from_young",
    "tip_from",
    "young_from_paper",
]
