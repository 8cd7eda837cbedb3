"""Brent's bounded minimisation of a scalar function, started from points already evaluated.

The 1-D search of the Hertz least squares (:func:`viscoforce.fitting._hertz_scan.hertz_least_squares`):
scipy's ``minimize_scalar(method="bounded")`` with its tolerance, but starting from the best
point and two neighbours whose costs the caller knows, so that the first step can be a parabola.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

#: The golden section's smaller part, (3 − √5)/2.
_GOLDEN = 0.3819660112501051
#: √(machine epsilon): Brent's relative tolerance in the abscissa.
_SQRT_EPS = float(np.sqrt(np.finfo(float).eps))


def brent(cost: Callable[[float], float], lo: float, hi: float, x: float, fx: float,
          known: list[tuple[float, float]], xatol: float) -> tuple[float, float]:
    """The minimum of ``cost`` on [lo, hi] by Brent's method, from ``x`` (cost ``fx``).

    Brent's bounded search (golden sections and parabolas, the tolerance of
    ``scipy.optimize.minimize_scalar(method="bounded")``: √eps·|x| + ``xatol``/3), started from
    the best point and, as its two previous points, the ``known`` (point, cost) pairs (the
    refinement grid's neighbours), so that its first step is a parabola through three points
    already evaluated.
    """
    a, b = lo, hi
    pts = sorted(known, key=lambda p: p[1])[:2]
    w, fw = pts[0] if pts else (x, fx)
    v, fv = pts[1] if len(pts) > 1 else (w, fw)
    d = e = (b - a) if pts else 0.0  # known points: the first steps may be parabolas
    for _ in range(500):
        middle = 0.5 * (a + b)
        tol1 = _SQRT_EPS * abs(x) + xatol / 3.0
        tol2 = 2.0 * tol1
        if abs(x - middle) <= tol2 - 0.5 * (b - a):
            break
        golden = True
        if abs(e) > tol1:
            r = (x - w) * (fx - fv)
            q = (x - v) * (fx - fw)
            p = (x - v) * q - (x - w) * r
            q = 2.0 * (q - r)
            if q > 0.0:
                p = -p
            q = abs(q)
            r, e = e, d
            if abs(p) < abs(0.5 * q * r) and q * (a - x) < p < q * (b - x):
                d = p / q
                if (x + d) - a < tol2 or b - (x + d) < tol2:
                    d = tol1 if x < middle else -tol1
                golden = False
        if golden:
            e = (a - x) if x >= middle else (b - x)
            d = _GOLDEN * e
        u = x + (d if abs(d) >= tol1 else math.copysign(tol1, d))
        fu = cost(u)
        if fu <= fx:
            if u >= x:
                a = x
            else:
                b = x
            v, fv, w, fw, x, fx = w, fw, x, fx, u, fu
        else:
            if u < x:
                a = u
            else:
                b = u
            if fu <= fw or w == x:
                v, fv, w, fw = w, fw, u, fu
            elif fu <= fv or v == x or v == w:
                v, fv = u, fu
    return x, fx
