"""The complex modulus per frequency of a measured spectrum: E′, E″ (Young's) and G′, G″ (shear).

For a linear viscoelastic sample in contact at operating indentation δ0, the small-amplitude
dynamic stiffness is k*(ω) = E*(ω)·S(δ0) (+ iωB), with S = (dF/dδ)/E the tip's contact size
(:mod:`viscoforce.physics.tips`; √(Rδ0) for a Hertz sphere) and E* the paper's modulus
(2/E = Σ(1 − ν²)/E_i). So, point by point,

    E*(ω) = (k*(ω) − iωB)/S(δ0),   Y* = E*(1 − ν²)/2,   G* = Y*/(2(1 + ν)),

with δ0 the point's ``mean_indentation``. ``E_storage`` = Re Y*, ``E_loss`` = Im Y*,
``G_storage`` = Re G*, ``G_loss`` = Im G* [Pa] — what PyFMRheo and the cell-rheology literature
report. Their stderr come from ``stiffness_stderr`` σ_r and ``phase_stderr`` (σ_t = |k*|·
phase_stderr: the radial and tangential errors of k*, as the fits weight them) and their
correlation ρ (``stiffness_phase_correlation``, written when a drag was subtracted from a
spectrum whose radial and tangential errors differ, :mod:`viscoforce.experiments.corrections`;
0 without it): with χ = arg k*, C = ρσ_rσ_t,

    σ_Re² = cos²χ σ_r² + sin²χ σ_t² − 2 sinχ cosχ C,   σ_Im² = sin²χ σ_r² + cos²χ σ_t² + 2 sinχ cosχ C,

divided by S. The error of δ0 is not included (it enters S only as δ0^½ for a sphere and is
common to all frequencies of a curve). The hydrodynamic drag B is subtracted here only when given
and the spectrum's own ``attrs["drag"]`` is 0 (it is never subtracted twice); it moves k* but
not its error, so σ_Re and σ_Im are those of the spectrum's own k*.

A sample of finite thickness (``sample_height`` h on a rigid support, ``sample_base`` bonded or
sliding) stiffens the contact: k*(ω) = E*(ω)·S(δ0)·g(δ0, h) with the bottom-effect stiffness
factor g of :func:`viscoforce.physics.bottom_effect.stiffness_factor` (geometric, so by the
correspondence principle it divides E′ and E″ alike and leaves the loss tangent unchanged). With
``sample_height`` E*, its stderr and the derived moduli are divided by g at each point's δ0; the
series is chosen there for the sample's Poisson's ratio (Garcia & Garcia 2018 for a bonded
incompressible layer, else Dimitriadis et al. 2002, paraboloid or sphere only), and a δ0 beyond
the series' accepted range is refused before anything is computed.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import xarray as xr

from viscoforce._limits import DRAG_RANGE
from viscoforce._validation import require_plausible
from viscoforce.exceptions import ModelValidityError, ParameterError
from viscoforce.experiments.corrections import CORRELATION
from viscoforce.physics.bottom_effect import bottom_effect_series, max_depth, stiffness_factor
from viscoforce.physics.tips import DEFAULT_POISSON, Tip, tip_from, young_from_paper

__all__ = ["MODULUS_VARIABLES", "add_complex_modulus"]

#: The variables :func:`add_complex_modulus` writes (each also with ``_stderr``).
MODULUS_VARIABLES = ("E_storage", "E_loss", "G_storage", "G_loss")


def add_complex_modulus(spectrum: xr.Dataset, tip: Tip | str, *, poisson: float | None = None,
                        drag: float | None = None, sample_height: float | None = None,
                        sample_base: str | None = None) -> xr.Dataset:
    """The spectrum with E′, E″, G′, G″ [Pa] per point and their stderr (module docstring).

    Parameters
    ----------
    spectrum : xarray.Dataset
        A measured spectrum with ``stiffness``, ``phase`` and ``mean_indentation`` (the contact
        point known), any extra dims.
    tip : Tip or str
        The tip (:func:`viscoforce.physics.tips.tip_from`: a Tip or ``"sphere:5um"`` …).
    poisson : float, optional
        The sample's Poisson's ratio in [0, 0.5] (default 0.5).
    drag : float, optional
        Hydrodynamic drag B [N·s/m] to subtract (refused when the spectrum already had one
        subtracted).
    sample_height : float, optional
        The sample's thickness h [m] on its rigid support: the bottom-effect correction
        (module docstring); default none (a half-space).
    sample_base : {"bonded", "sliding"}, optional
        The layer bonded to (default) or sliding on its support; only with ``sample_height``.

    Returns
    -------
    xarray.Dataset
        ``spectrum`` with ``E_storage``, ``E_loss``, ``G_storage``, ``G_loss`` and their
        ``_stderr`` over the spectrum's dims (NaN where a point has no indentation > 0);
        ``attrs`` ``tip``, ``poisson``, ``complex_modulus``; with ``sample_height`` also
        ``sample_height`` [m], ``sample_base``, ``bottom_effect_series`` and the range of the
        stiffness factor over the points, ``bottom_effect_factor_min`` and
        ``bottom_effect_factor_max``.

    Raises
    ------
    ModelValidityError
        No ``mean_indentation`` (no contact point found).
    ParameterError
        A bad tip, Poisson's ratio, drag, sample height or base, a drag subtracted twice, a tip
        or Poisson's ratio no bottom-effect series covers, or an operating indentation beyond
        the series' accepted range (the message names ``sample_height``).
    """
    tip = tip_from(tip)
    if tip is None:
        raise ParameterError("tip must be a Tip or its text (e.g. 'sphere:5um'), got None")
    nu = DEFAULT_POISSON if poisson is None else poisson
    young = float(young_from_paper(1.0, nu))  # validates ν
    shear = young / (2.0 * (1.0 + float(nu)))
    if "mean_indentation" not in spectrum.variables:
        raise ModelValidityError(
            "the complex modulus needs the operating indentation: this spectrum has no "
            "mean_indentation (no contact point found on the approach)")
    already = float(spectrum.attrs.get("drag", 0.0) or 0.0)
    if drag is not None:
        if not (isinstance(drag, int | float) and math.isfinite(drag) and drag >= 0):
            raise ParameterError(f"drag must be >= 0 N*s/m and finite, got {drag!r}")
        require_plausible("drag", drag, DRAG_RANGE, "N*s/m", why="a hydrodynamic drag B")
        if already:
            raise ParameterError(f"this spectrum already had a drag of {already:g} N*s/m "
                                 "subtracted (load --drag); do not subtract it again")
    omega = spectrum["omega"]
    stiffness, phase = xr.broadcast(spectrum["stiffness"], spectrum["phase"])
    chi = np.radians(phase)
    k = stiffness * np.exp(1j * chi) - 1j * omega * float(drag or 0.0)
    depth = spectrum["mean_indentation"].broadcast_like(stiffness)
    layer = _layer(tip, float(nu), sample_height, sample_base)
    size = xr.apply_ufunc(_contact_size, depth, kwargs={"tip": tip})
    if layer is not None:
        bottom = xr.apply_ufunc(_stiffness_factor, spectrum["mean_indentation"],
                                kwargs={"tip": tip, **layer})
        size = size * bottom.broadcast_like(size)
    modulus = k / size  # the paper's E*(ω)
    s_err = _stderr(spectrum, "stiffness", stiffness)
    t_err = stiffness * np.radians(_stderr(spectrum, "phase", stiffness))
    cov = 0.0
    if CORRELATION in spectrum.variables:
        cov = spectrum[CORRELATION].broadcast_like(stiffness) * s_err * t_err
    cos, sin = np.cos(chi), np.sin(chi)
    sig_re = np.sqrt(cos**2 * s_err**2 + sin**2 * t_err**2 - 2 * sin * cos * cov) / size
    sig_im = np.sqrt(sin**2 * s_err**2 + cos**2 * t_err**2 + 2 * sin * cos * cov) / size
    out: dict[str, Any] = {}
    for name, factor, part, sigma, what in (
            ("E_storage", young, "real", sig_re, "Young's storage modulus E'"),
            ("E_loss", young, "imag", sig_im, "Young's loss modulus E''"),
            ("G_storage", shear, "real", sig_re, "shear storage modulus G'"),
            ("G_loss", shear, "imag", sig_im, "shear loss modulus G''")):
        attrs = {"units": "Pa", "long_name": f"{what} (nu = {nu:g}, {tip.describe()})"}
        out[name] = (getattr(modulus, part) * factor).assign_attrs(attrs)
        out[f"{name}_stderr"] = (sigma * factor).assign_attrs(
            {**attrs, "long_name": f"standard error of {what}"})
    result = spectrum.assign(out)
    result.attrs.update(tip.as_attrs())
    if layer is not None:
        g = np.asarray(bottom, dtype=float)
        g = g[np.isfinite(g)]
        series = bottom_effect_series(tip, poisson=float(nu), bonded=layer["bonded"])
        result.attrs.update(
            sample_height=float(layer["sample_height"]),
            sample_base="bonded" if layer["bonded"] else "sliding",
            bottom_effect_series=f"{series.name}: {series.reference}, accepted for "
                                 f"{series.variable} <= {series.max_variable:g}",
            bottom_effect_factor_min=float(g.min()) if g.size else math.nan,
            bottom_effect_factor_max=float(g.max()) if g.size else math.nan)
    result.attrs.update(
        tip=tip.describe(), poisson=float(nu),
        complex_modulus=("E* = (k* - i omega B)/S(mean_indentation), S = (dF/d delta)/E of the "
                         "tip" + ("" if layer is None else " times the bottom-effect stiffness "
                                  "factor g(mean_indentation, sample_height)") +
                         "; E_* = Young's Y* = E*(1 - nu^2)/2, G_* = Y*/(2(1 + nu)); "
                         f"drag subtracted here: {float(drag or 0.0):g} N*s/m"))
    return result


def _layer(tip: Tip, poisson: float, sample_height: float | None,
           sample_base: str | None) -> dict[str, Any] | None:
    """The bottom-effect keywords of the spectrum's layer (None: a half-space), checked."""
    if sample_height is None:
        if sample_base is not None:
            raise ParameterError("sample_base describes the layer of sample_height: give both")
        return None
    if sample_base not in (None, "bonded", "sliding"):
        raise ParameterError(f"sample_base must be 'bonded' or 'sliding', got {sample_base!r}")
    bonded = sample_base != "sliding"
    max_depth(tip, sample_height, poisson=poisson, bonded=bonded)  # refuses what no series covers
    return {"sample_height": sample_height, "poisson": poisson, "bonded": bonded}


def _stiffness_factor(depth: np.ndarray, *, tip: Tip, sample_height: float, poisson: float,
                      bonded: bool) -> np.ndarray:
    """g(δ0, h) where δ0 > 0, NaN elsewhere; all depths checked before any is used."""
    d = np.asarray(depth, dtype=float)
    ok = np.isfinite(d) & (d > 0)
    out = np.full(d.shape, np.nan)
    if ok.any():
        out[ok] = stiffness_factor(tip, d[ok], sample_height, poisson=poisson, bonded=bonded)
    return out


def _contact_size(depth: np.ndarray, *, tip: Tip) -> np.ndarray:
    """S(δ0) [m] where δ0 > 0, NaN elsewhere (no contact)."""
    d = np.asarray(depth, dtype=float)
    ok = np.isfinite(d) & (d > 0)
    out = np.full(d.shape, np.nan)
    if ok.any():
        out[ok] = tip.contact_stiffness_factor(d[ok])
    return out


def _stderr(spectrum: xr.Dataset, name: str, like: xr.DataArray) -> xr.DataArray:
    key = f"{name}_stderr"
    if key not in spectrum.variables:
        return xr.full_like(like, np.nan)
    return spectrum[key].broadcast_like(like)
