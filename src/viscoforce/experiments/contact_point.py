"""Contact point of an approach curve and the ``attrs["contact_point"]`` text of a spectrum.

Contact point and mean indentation (:func:`find_contact_point`, on each curve's approach
segment, force F against tip position z = ``tip_position``):

1. Baseline: a straight line F = a + b·z fitted to the first ``baseline_fraction`` (default 30 %)
   of the approach samples (a line, so a tilted free-cantilever baseline — virtual deflection,
   drag — is removed); noise σ = 1.4826·MAD of its residuals (robust to outliers/spikes).
2. Rise: r = F − baseline over the whole approach. The contact must give r(end) > ``k_sigma``·σ
   (default k = 5); the first estimate z₁ is the last sample at or below k·σ (after it the force
   stays above the threshold up to the end of the approach). z₁ must lie after the baseline
   window, and the baseline window must not curve upward significantly (t-statistic of the x²
   term of a quadratic fit > 8: a convex rise); else the baseline is contaminated and no
   contact is reported.
3. Refinement: least squares of r = A·max(z − z_c, 0)^p (p = ``exponent``, default 1.5, Hertz
   sphere; 1 for a linear contact) over all samples after the baseline window, for z_c between
   the baseline window end and z₁ (A > 0 in closed form for each z_c; grid over the sample
   positions, then bounded scalar refinement).

Indentation δ = z − z_c (tip displacement into the sample past contact, > 0 in contact); the
``mean_indentation`` of a modulation point is δ at the mean tip position of its lock-in window.
Limits: the method needs a free (non-contact) baseline in the first ``baseline_fraction`` of the
approach and a monotonic-ish rise ending at least k·σ above it; long-range forces (double-layer,
adhesion snap-in, hydrodynamics that are not linear in z) shift z_c; the power law is a local
model, so for very deep or non-Hertzian indentation the refined z_c is biased by a fraction of
the fitted range; creep of the sample between the approach and the modulation is included in δ
(the mean tip position is measured, not assumed). Where no contact is found the curve's
``mean_indentation`` is NaN and ``attrs["contact_point"]`` says so; when none is found on any
curve the variable is left out.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from viscoforce.exceptions import ParameterError

__all__ = ["contact_point_summary", "find_contact_point"]

_CONVEX_T = 8.0  # t-statistic of the baseline's x² term above which the window holds a contact
_FIT_CHUNK = 1 << 20  # matrix entries per chunk of the vectorised contact-point grid search


def find_contact_point(position: np.ndarray, force: np.ndarray, *,
                       baseline_fraction: float = 0.3, k_sigma: float = 5.0,
                       exponent: float = 1.5, min_points: int = 5) -> dict[str, Any] | None:
    """Contact point of an approach curve, force against tip position (method in the module doc).

    Parameters
    ----------
    position : ndarray
        Tip position z [m] (displacement toward the sample, ``tip_position``), in time order.
    force : ndarray
        Force F [N] (repulsion > 0), same length.
    baseline_fraction : float
        Fraction of the samples (from the start) fitted by the baseline line, in (0, 0.8].
    k_sigma : float
        Threshold in baseline-noise units for the rise, > 0.
    exponent : float
        Exponent p of the post-contact model A·(z − z_c)^p, > 0 (1.5 Hertz sphere, 1 linear).
    min_points : int
        Least number of samples in the baseline window and after contact, >= 3.

    Returns
    -------
    dict or None
        ``z_contact`` [m], ``z_threshold`` [m] (the k·σ crossing z₁), ``sigma`` [N] (baseline
        noise), ``baseline`` (a [N], b [N/m]), ``amplitude`` A [N/m^p], ``rise`` (final rise /
        σ); None when no contact is found (too few samples, no rise above k·σ, a rise inside the
        baseline window or a convex baseline, or a non-positive fit).
    """
    if not (isinstance(baseline_fraction, int | float) and 0 < baseline_fraction <= 0.8):
        raise ParameterError(f"baseline_fraction must be in (0, 0.8], got {baseline_fraction!r}")
    if not (isinstance(k_sigma, int | float) and k_sigma > 0 and math.isfinite(k_sigma)):
        raise ParameterError(f"k_sigma must be > 0 and finite, got {k_sigma!r}")
    if not (isinstance(exponent, int | float) and exponent > 0 and math.isfinite(exponent)):
        raise ParameterError(f"exponent must be > 0 and finite, got {exponent!r}")
    if isinstance(min_points, bool) or not isinstance(min_points, int) or min_points < 3:
        raise ParameterError(f"min_points must be an integer >= 3, got {min_points!r}")
    z = np.asarray(position, dtype=float)
    f = np.asarray(force, dtype=float)
    if z.shape != f.shape or z.ndim != 1:
        raise ParameterError(f"position and force must be 1-D of one length, got {z.shape} and "
                             f"{f.shape}")
    ok = np.isfinite(z) & np.isfinite(f)
    z, f = z[ok], f[ok]
    nb = int(baseline_fraction * z.size)
    if nb < min_points or z.size - nb < min_points:
        return None
    zb, fb = z[:nb], f[:nb]
    if np.ptp(zb) <= 0:
        return None
    b, a = np.polyfit(zb, fb, 1)
    xb = (zb - zb.mean()) / np.ptp(zb)
    design = np.column_stack([np.ones(nb), xb, xb**2])
    coef = np.linalg.lstsq(design, fb, rcond=None)[0]
    rq = fb - design @ coef
    cov2 = float(rq @ rq) / max(nb - 3, 1) * np.linalg.inv(design.T @ design)[2, 2]
    if cov2 > 0 and coef[2] / math.sqrt(cov2) > _CONVEX_T:
        return None  # a significantly convex (rising) baseline: contact inside the window
    r = f - (a + b * z)
    rb = r[:nb]
    sigma = 1.4826 * float(np.median(np.abs(rb - np.median(rb))))
    if not sigma > 0:
        sigma = float(np.std(rb))
    if not sigma > 0:
        return None
    thr = k_sigma * sigma
    if not r[-1] > thr:
        return None
    below = np.flatnonzero(r <= thr)
    j = int(below[-1]) if below.size else 0
    if j < nb or z.size - j - 1 < min_points:
        return None
    zs, rs = z[nb:], r[nb:]
    lo, hi = float(np.max(z[:nb])), float(z[j])
    if not hi > lo:
        return None
    p = float(exponent)

    def sse(zc: float) -> float:
        return float(_power_law_fits(zs, rs, np.array([zc]), p)[0][0])

    grid = np.unique(np.clip(zs[(zs >= lo) & (zs <= hi)], lo, hi))
    grid = np.concatenate([[lo], grid, [hi]])
    if grid.size > 400:
        grid = np.linspace(lo, hi, 400)
    costs = _power_law_fits(zs, rs, grid, p)[0]
    i = int(np.argmin(costs))
    a_lo, a_hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    zc = float(grid[i])
    if a_hi > a_lo:
        opt = minimize_scalar(sse, bounds=(a_lo, a_hi), method="bounded",
                              options={"xatol": 1e-6 * (hi - lo) + 1e-15})
        if opt.fun <= costs[i]:
            zc = float(opt.x)
    amp = float(_power_law_fits(zs, rs, np.array([zc]), p)[1][0])
    if not amp > 0:
        return None
    return {"z_contact": zc, "z_threshold": hi, "sigma": sigma, "baseline": (float(a), float(b)),
            "amplitude": amp, "rise": float(r[-1] / sigma)}


def _power_law_fits(z: np.ndarray, r: np.ndarray, z_contact: np.ndarray, exponent: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Least squares of r = A·max(z − z_c, 0)^p for each candidate z_c, all at once.

    Returns the sums of squared residuals and the amplitudes A (closed form; 0 where the model
    vanishes on every sample), one per entry of ``z_contact``. The candidates are processed in
    chunks of about :data:`_FIT_CHUNK` matrix entries, so memory stays bounded for long curves;
    the powers 1, 1.5 and 2 are taken as products and square roots (the power function is the
    cost of the search).
    """
    costs = np.empty(z_contact.size)
    amps = np.empty(z_contact.size)
    step = max(1, _FIT_CHUNK // max(z.size, 1))
    for k in range(0, z_contact.size, step):
        g = z - z_contact[k:k + step, None]
        np.maximum(g, 0.0, out=g)
        if exponent == 1.5:
            g *= np.sqrt(g)
        elif exponent == 2.0:
            g *= g
        elif exponent != 1.0:
            np.power(g, exponent, out=g)
        gg = np.einsum("ij,ij->i", g, g)
        amp = np.divide(g @ r, gg, out=np.zeros_like(gg), where=gg > 0)
        g *= -amp[:, None]
        g += r
        costs[k:k + step] = np.einsum("ij,ij->i", g, g)
        amps[k:k + step] = amp
    return costs, amps


def contact_point_summary(z_contact: np.ndarray, curves: Any, source: str,
                          options: Mapping[str, Any] | None) -> tuple[str, bool]:
    """``attrs["contact_point"]`` of a spectrum and whether its ``mean_indentation`` is kept.

    ``z_contact``: the contact position per curve (NaN where none was found), ``curves`` their
    numbers, ``options`` those of :func:`find_contact_point` (None: not estimated). The
    indentation is kept when some curve has a contact point, and every curve of a simulation.
    """
    n_contact = int(np.isfinite(z_contact).sum())
    keep = n_contact > 0 and (n_contact == z_contact.size or source != "simulation")
    if options is None:
        return "not estimated (contact_point=False)", keep
    missing = [int(c) for c, z in zip(np.asarray(curves).tolist(), z_contact, strict=True)
               if not math.isfinite(z)]
    opts = ", ".join(f"{k}={v!r}" for k, v in sorted(options.items())) or "defaults"
    return ("approach baseline line + k*sigma rise + power-law refinement "
            f"(viscoforce.experiments.modulation.find_contact_point, {opts}); found on "
            f"{n_contact} of {z_contact.size} curves"
            + (f"; none on curves {missing} (mean_indentation NaN there)" if missing and keep
               else "")
            + ("; mean_indentation left out" if not keep else "")), keep
