r"""Hydrodynamic drag on the cantilever, from spectra measured at several heights (Alcaraz 2002).

What it gives: the drag coefficient at contact b(0) [N·s/m], with its standard error, to subtract
from a spectrum measured in contact as iω·b(0) (``modulation_spectrum(..., drag=b0)``,
``correct_spectrum(..., drag=b0)``, ``load --drag``).

Out of contact, at a height h of the tip above the surface, the force on the oscillated
cantilever in the liquid is viscous, k*(ω) ≈ iω·b(h) (the cantilever's own stiffness does not
enter: the deflection measures the force). So per spectrum point

.. math:: b(h) = \frac{\operatorname{Im} k^*(ω)}{ω} = \operatorname{Re}\frac{k^*(ω)}{iω}

(:func:`drag_coefficient`: pooled over the spectrum's frequencies and curves). The drag grows as
the tip approaches the surface (squeeze flow under the cantilever). Alcaraz et al. scaled the
drag of a sphere of radius a approaching a wall at a small gap h, 6πηa²/h (Taylor's lubrication
limit of Brenner's result), to the cantilever and tip:

.. math:: b(h) = \frac{6π η\, a_\mathrm{eff}^2}{h + h_\mathrm{eff}}

with η the liquid's viscosity, a_eff the effective radius and h_eff the effective height of the
cantilever–tip (of the order of the tip height): the "scaled spherical model" of J. Alcaraz,
L. Buscemi, M. Puig-de-Morales, J. Colchero, A. Baró and D. Navajas, "Correction of
microrheological measurements of soft samples with atomic force microscopy for the hydrodynamic
drag on the cantilever", Langmuir 18, 716–721 (2002), doi:10.1021/la0110850 (the same form as
PyFMRheo's ``DragSphereModel``). At contact b(0) = 6πη a_eff²/h_eff.

Fit (:func:`drag_from_heights`): least squares in c = 6πη a_eff² and h_eff, parametrised as
ln c and ln h_eff (both stay > 0), started from the straight line 1/b = (h + h_eff)/c. With
``drag_stderr`` the residuals are (b_model − b)/σ and the covariance is not rescaled (``redchi``
tests the errors); without, a constant relative error is assumed (residuals (b_model − b)/b) and
the covariance is scaled by the reduced χ² (as lmfit and curve_fit do). Standard errors of
a_eff, h_eff and b(0) follow to first order from the covariance of (ln c, ln h_eff); a_eff
scales as η^(−1/2), so give the viscosity of the liquid (b(0) and h_eff do not depend on it).

Intervals (:meth:`DragFit.interval`): when the covariance is scaled by the reduced χ², the error
is estimated from the n − 2 residuals of n heights, so (estimate − truth)/stderr follows
Student's t with ν = n − 2 degrees of freedom, not a Gaussian: at 5 heights its rms is
√(ν/(ν − 2)) = 1.7 and ±1 stderr covers 61 %, ±1.96 stderr 85 % (at 3 heights, ν = 1, a Cauchy
law: 49 % and 68 %). The interval is therefore ln b(0) ± t_ν((1 + level)/2)·stderr/b(0) (the fit
is linear in ln b(0) = ln c − ln h_eff), and ``DragFit.dof`` and ``distribution`` say which law
holds; with given errors (``drag_stderr`` or spectra) the covariance is not rescaled and the
Gaussian quantile is used.

Limits: the model is the low-Reynolds, quasi-static drag (no frequency dependence: pool only
frequencies where Im k*/ω is flat, e.g. ``spectrum.sel(omega=...)``); the spectra must be
corrected for the instrument phase lag first (a lag mixes the real and imaginary parts); the
extrapolation to h = 0 is only as good as the lowest heights measured (≲ h_eff).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from viscoforce._validation import as_float_1d, require_positive
from viscoforce.exceptions import ConvergenceError, ParameterError
from viscoforce.schema import validate_spectrum

__all__ = ["DEFAULT_VISCOSITY", "DragFit", "drag_coefficient", "drag_from_heights",
           "scaled_sphere_drag"]

#: Viscosity of water at 20 °C [Pa·s] (0.89e-3 at 25 °C, 0.69e-3 at 37 °C): the default η.
DEFAULT_VISCOSITY = 1.0e-3
#: Reference of the model, stored in :meth:`DragFit.as_attrs`.
REFERENCE = ("Alcaraz et al., Langmuir 18, 716-721 (2002), doi:10.1021/la0110850: "
             "b(h) = 6 pi eta a_eff^2/(h + h_eff)")
_MIN_HEIGHTS = 3


def scaled_sphere_drag(height: ArrayLike, a_eff: float, h_eff: float,
                       viscosity: float = DEFAULT_VISCOSITY) -> NDArray[np.float64]:
    """Drag coefficient b(h) = 6πη a_eff²/(h + h_eff) of the scaled spherical model [N·s/m].

    Parameters
    ----------
    height : float or array_like
        Height h of the tip above the surface [m], >= 0.
    a_eff : float
        Effective radius of the cantilever–tip [m], > 0.
    h_eff : float
        Effective height [m], > 0.
    viscosity : float
        Viscosity η of the liquid [Pa·s], > 0 (default water at 20 °C).

    Returns
    -------
    numpy.ndarray
        b(h) [N·s/m] (Alcaraz et al. 2002, module docstring).
    """
    return (6.0 * math.pi * viscosity * a_eff**2) / (np.asarray(height, dtype=float) + h_eff)


@dataclass(frozen=True, eq=False)
class DragFit:
    """Result of :func:`drag_from_heights` (every length in m, every drag in N·s/m).

    Attributes
    ----------
    drag_at_contact, drag_at_contact_stderr : float
        b(0) = 6πη a_eff²/h_eff and its standard error: subtract iω·b(0) in contact. With
        ``distribution == "student-t"`` ±1 stderr covers less than 68 %: use :meth:`interval`.
    a_eff, a_eff_stderr : float
        Effective radius and its standard error (depends on ``viscosity``).
    h_eff, h_eff_stderr : float
        Effective height and its standard error.
    correlation : float
        Correlation of the estimates of ln(6πη a_eff²) and ln h_eff.
    heights, drag, drag_stderr : numpy.ndarray
        The data fitted (``drag_stderr`` None when not given).
    viscosity : float
        η used [Pa·s].
    redchi : float
        Reduced χ² (of the relative residuals when no ``drag_stderr``); dof = n − 2.
    weighting : str
        ``"stderr"`` (absolute errors, covariance not rescaled) or ``"relative"``.
    dof : int
        Degrees of freedom of the residuals, n − 2 for n heights.
    distribution : str
        The law of (estimate − truth)/stderr: ``"student-t"`` (errors estimated from the
        residuals, ``weighting == "relative"``: ν = ``dof``) or ``"normal"`` (errors given).
    """

    drag_at_contact: float
    drag_at_contact_stderr: float
    a_eff: float
    a_eff_stderr: float
    h_eff: float
    h_eff_stderr: float
    correlation: float
    heights: NDArray[np.float64]
    drag: NDArray[np.float64]
    drag_stderr: NDArray[np.float64] | None
    viscosity: float
    redchi: float
    weighting: str
    dof: int
    distribution: str

    def coverage_factor(self, level: float = 0.6826894921370859) -> float:
        """The number of stderr that cover ``level`` (two-sided): Student-t or Gaussian quantile.

        Parameters
        ----------
        level : float
            Coverage probability in (0, 1) (default one Gaussian σ, 68.3 %).

        Returns
        -------
        float
            t_ν((1 + level)/2) for ``distribution == "student-t"`` (1.84 at ν = 1, 1.32 at
            ν = 2, 1.20 at ν = 3 for 68.3 %), else the Gaussian quantile (1 at 68.3 %).
        """
        if not (isinstance(level, int | float) and 0.0 < level < 1.0):
            raise ParameterError(f"level must be a probability in (0, 1), got {level!r}")
        p = 0.5 * (1.0 + float(level))
        from scipy import stats  # ~1 s to import: `viscoforce load` never needs it

        if self.distribution == "student-t":
            return float(stats.t.ppf(p, self.dof))  # not a frozen law: 0.05 against 0.8 ms
        return float(stats.norm.ppf(p))

    def interval(self, level: float = 0.6826894921370859) -> tuple[float, float]:
        """Interval of b(0) [N·s/m] covering ``level``: ln b(0) ± q·stderr/b(0).

        Parameters
        ----------
        level : float
            Coverage probability in (0, 1) (default 68.3 %).

        Returns
        -------
        tuple of float
            (low, high), q = :meth:`coverage_factor` (module docstring).
        """
        half = self.coverage_factor(level) * self.drag_at_contact_stderr / self.drag_at_contact
        return self.drag_at_contact * math.exp(-half), self.drag_at_contact * math.exp(half)

    def model(self, height: ArrayLike) -> NDArray[np.float64]:
        """The fitted b(h) [N·s/m] at ``height`` [m] (:func:`scaled_sphere_drag`)."""
        return scaled_sphere_drag(height, self.a_eff, self.h_eff, self.viscosity)

    def as_attrs(self) -> dict[str, Any]:
        """Dataset attrs describing the drag subtracted (numbers and text only).

        ``drag``, ``drag_stderr`` and the fit's terms, ``drag_dof``, ``drag_stderr_distribution``
        and the 68.3 % and 95 % intervals of b(0) ``drag_interval_68``, ``drag_interval_95``.
        """
        return {"drag": self.drag_at_contact, "drag_stderr": self.drag_at_contact_stderr,
                "drag_model": REFERENCE, "drag_a_eff": self.a_eff,
                "drag_a_eff_stderr": self.a_eff_stderr, "drag_h_eff": self.h_eff,
                "drag_h_eff_stderr": self.h_eff_stderr, "drag_viscosity": self.viscosity,
                "drag_heights": self.heights.copy(), "drag_redchi": self.redchi,
                "drag_weighting": self.weighting, "drag_dof": self.dof,
                "drag_stderr_distribution": self.distribution,
                "drag_interval_68": np.array(self.interval()),
                "drag_interval_95": np.array(self.interval(0.95)),
                "drag_interval": ("ln b(0) +- q*stderr/b(0), q the Student-t quantile with "
                                  "drag_dof degrees of freedom (errors from the residuals) or "
                                  "the Gaussian one (errors given)")}


def drag_coefficient(spectrum: xr.Dataset) -> tuple[float, float]:
    """Drag coefficient b = Im k*/ω [N·s/m] of one out-of-contact spectrum, with its error.

    Parameters
    ----------
    spectrum : xarray.Dataset
        A valid spectrum (``stiffness`` [N/m], ``phase`` [degree] over ``omega``, any extra dims)
        measured at one height, already corrected for the instrument phase lag. Every finite
        point is pooled (select the frequencies first where the drag is not flat).

    Returns
    -------
    tuple of float
        b and its standard error. With ``stiffness_stderr`` and ``phase_stderr``: the
        inverse-variance weighted mean, σ(Im k*)² = (sin χ·σ_s)² + (s·cos χ·σ_χ)², its error the
        larger of the internal one and the scatter of the points (Birge); without: the mean and
        the standard error of the mean.

    Raises
    ------
    ParameterError
        Not a dataset, fewer than 2 finite points without standard errors.
    SchemaError
        Not a valid spectrum.
    """
    if not isinstance(spectrum, xr.Dataset):
        raise ParameterError(f"drag_coefficient needs a spectrum dataset, got "
                             f"{type(spectrum).__name__}")
    ds = validate_spectrum(spectrum)
    stiffness, phase = xr.broadcast(ds["stiffness"], ds["phase"])
    dims = stiffness.dims

    def full(name: str) -> np.ndarray:
        return ds[name].broadcast_like(stiffness).transpose(*dims).values

    omega = full("omega")
    chi = np.radians(phase.transpose(*dims).values)
    s = stiffness.values
    b = s * np.sin(chi) / omega
    if "stiffness_stderr" in ds.variables and "phase_stderr" in ds.variables:
        es = full("stiffness_stderr")
        ep = np.radians(full("phase_stderr"))
        sigma = np.hypot(np.sin(chi) * es, s * np.cos(chi) * ep) / omega
        ok = np.isfinite(b) & np.isfinite(sigma) & (sigma > 0)
        if ok.any():
            w = 1.0 / sigma[ok] ** 2
            mean = float(np.sum(w * b[ok]) / np.sum(w))
            internal = math.sqrt(1.0 / float(np.sum(w)))
            n = int(ok.sum())
            external = (math.sqrt(float(np.sum(w * (b[ok] - mean) ** 2)) / ((n - 1)
                                                                         * float(np.sum(w))))
                        if n > 1 else 0.0)
            return mean, max(internal, external)
    ok = np.isfinite(b)
    if ok.sum() < 2:
        raise ParameterError(f"drag_coefficient needs stiffness_stderr and phase_stderr, or at "
                             f"least 2 finite points to estimate an error; got {int(ok.sum())}")
    return float(np.mean(b[ok])), float(np.std(b[ok], ddof=1) / math.sqrt(ok.sum()))


def drag_from_heights(data: Sequence[xr.Dataset] | ArrayLike, heights: ArrayLike, *,
                      drag_stderr: ArrayLike | None = None,
                      viscosity: float = DEFAULT_VISCOSITY) -> DragFit:
    """Fit b(h) = 6πη a_eff²/(h + h_eff) to drags at several heights; extrapolate b(0).

    Parameters
    ----------
    data : sequence of xarray.Dataset or array_like
        One spectrum per height, measured out of contact and corrected for the phase lag
        (:func:`drag_coefficient` makes b and its error of each), or the drag coefficients b(h)
        [N·s/m] themselves, > 0.
    heights : array_like
        Height h of the tip above the surface for each entry [m]: at least 3 distinct values,
        each > 0 and finite.
    drag_stderr : array_like, optional
        Standard errors of b [N·s/m], > 0, one per height (with spectra they come from the
        spectra and must not be given). Without them a constant relative error is assumed.
    viscosity : float
        Viscosity η of the liquid [Pa·s], > 0 (default :data:`DEFAULT_VISCOSITY`, water at
        20 °C); only a_eff depends on it.

    Returns
    -------
    DragFit
        b(0) with its standard error, a_eff, h_eff, their errors and correlation, the data.

    Raises
    ------
    ParameterError
        Fewer than 3 heights, a height that is not > 0 and finite, repeated heights, a
        length mismatch, a drag or error that is not > 0 and finite, a drag that does not
        fall with height (1/b must grow with h), or a fit whose h_eff runs to 0 (b ∝ 1/h:
        b(0) diverges; measure closer to the surface).
    ConvergenceError
        The least-squares fit did not converge.
    """
    viscosity = require_positive("viscosity", viscosity)
    h = as_float_1d("heights", heights, min_size=_MIN_HEIGHTS)
    if np.any(h <= 0):
        i = int(np.flatnonzero(h <= 0)[0])
        raise ParameterError(f"heights must be > 0 m (above the surface, out of contact); entry "
                             f"{i} is {float(h[i])!r}")
    if np.unique(h).size != h.size:
        raise ParameterError(f"heights must be distinct, got {h.tolist()}")
    if _is_spectra(data):
        if drag_stderr is not None:
            raise ParameterError("drag_stderr comes from the spectra; give it only with drag "
                                 "coefficients")
        pairs = [drag_coefficient(ds) for ds in data]
        b = np.asarray([p[0] for p in pairs])
        err: NDArray[np.float64] | None = np.asarray([p[1] for p in pairs])
        if not np.all(err > 0):
            err = None
    else:
        b = as_float_1d("drag", data, min_size=_MIN_HEIGHTS)
        err = None if drag_stderr is None else as_float_1d("drag_stderr", drag_stderr)
        if err is not None and err.size != b.size:
            raise ParameterError(f"drag_stderr needs one value per drag ({b.size}), got "
                                 f"{err.size}")
        if err is not None and np.any(err <= 0):
            i = int(np.flatnonzero(err <= 0)[0])
            raise ParameterError(f"drag_stderr must be > 0 N*s/m; entry {i} is {float(err[i])!r}")
    if b.size != h.size:
        raise ParameterError(f"one drag (or spectrum) per height: got {b.size} drags and "
                             f"{h.size} heights")
    if not np.all(np.isfinite(b) & (b > 0)):
        i = int(np.flatnonzero(~(np.isfinite(b) & (b > 0)))[0])
        raise ParameterError(
            f"drag must be > 0 and finite N*s/m at every height; at h = {h[i]:g} m it is "
            f"{float(b[i])!r} (Im k*/omega of an out-of-contact spectrum: check the phase lag)")
    order = np.argsort(h)
    h, b = h[order], b[order]
    err = None if err is None else err[order]
    slope, intercept = np.polyfit(h, 1.0 / b, 1)   # 1/b = h/c + h_eff/c
    if not slope > 0:
        raise ParameterError(
            "the drag does not fall with height (1/b must grow with h): not the squeeze-flow "
            f"drag of the scaled spherical model; b = {b.tolist()} N*s/m at h = {h.tolist()} m")
    c0 = 1.0 / slope
    h0 = intercept / slope if intercept > 0 else 0.1 * float(h[0])
    sigma = b if err is None else err

    def residual(x: np.ndarray) -> np.ndarray:
        return (math.exp(x[0]) / (h + math.exp(x[1])) - b) / sigma

    def jacobian(x: np.ndarray) -> np.ndarray:
        he = math.exp(x[1])
        model = math.exp(x[0]) / (h + he)
        return np.column_stack([model, -model * he / (h + he)]) / sigma[:, None]

    fit = least_squares(residual, np.array([math.log(c0), math.log(h0)]), jac=jacobian,
                        method="lm", xtol=1e-12, ftol=1e-12, gtol=1e-12, max_nfev=2000)
    if not fit.success:
        raise ConvergenceError(f"the b(h) fit did not converge: {fit.message}",
                               iterations=int(fit.nfev),
                               residual_norm=float(np.max(np.abs(fit.fun))))
    ln_c, ln_h = (float(v) for v in fit.x)
    h_eff = math.exp(ln_h)
    if h_eff < 1e-6 * float(h[0]):
        raise ParameterError(
            f"h_eff fitted to {h_eff:.3g} m, far below the lowest height {h[0]:g} m: b(h) "
            "follows 1/h there and b(0) diverges; measure closer to the surface")
    dof = h.size - 2
    redchi = float(fit.fun @ fit.fun) / dof
    jac = fit.jac
    try:
        cov = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        raise ParameterError("a_eff and h_eff cannot both be determined from these heights "
                             "(singular fit); measure over a wider range of heights") from None
    if err is None:
        cov = cov * redchi
    var_c, var_h, cov_ch = float(cov[0, 0]), float(cov[1, 1]), float(cov[0, 1])
    c = math.exp(ln_c)
    a_eff = math.sqrt(c / (6.0 * math.pi * viscosity))
    b0 = math.exp(ln_c - ln_h)
    return DragFit(
        drag_at_contact=b0,
        drag_at_contact_stderr=b0 * math.sqrt(max(var_c + var_h - 2.0 * cov_ch, 0.0)),
        a_eff=a_eff, a_eff_stderr=0.5 * a_eff * math.sqrt(var_c),
        h_eff=h_eff, h_eff_stderr=h_eff * math.sqrt(var_h),
        correlation=cov_ch / math.sqrt(var_c * var_h) if var_c > 0 and var_h > 0 else math.nan,
        heights=h, drag=b, drag_stderr=err, viscosity=viscosity, redchi=redchi,
        weighting="relative" if err is None else "stderr", dof=dof,
        distribution="student-t" if err is None else "normal")


def _is_spectra(data: Any) -> bool:
    """Whether ``data`` is a sequence of datasets (else it is read as numbers)."""
    if isinstance(data, xr.Dataset):
        raise ParameterError("drag_from_heights needs one spectrum per height (a list), got a "
                             "single dataset")
    if isinstance(data, list | tuple) and data and all(isinstance(d, xr.Dataset) for d in data):
        return True
    if isinstance(data, list | tuple) and any(isinstance(d, xr.Dataset) for d in data):
        raise ParameterError("drag_from_heights: give spectra (datasets) or numbers, not a mix")
    return False
