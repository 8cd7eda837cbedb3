"""Moduli conversions: the paper's modulus E ↔ Young's modulus Y ↔ shear modulus G.

``E`` is the paper's modulus (see :mod:`viscoforce.units`): 2/E = (1 − ν1²)/E1 + (1 − ν2²)/E2,
i.e. E = 2·E_star with Johnson's contact modulus E_star. For a rigid tip on a sample of Young's
modulus Y and Poisson's ratio ν, E_star = Y/(1 − ν²) and E = 2Y/(1 − ν²); an isotropic solid's
shear modulus is G = Y/(2(1 + ν)). :func:`young_from_paper`, :func:`paper_from_young` and
:func:`shear_from_young` convert, vectorised, with NaN passing through (a failed fit stays NaN).
They are also importable from :mod:`viscoforce.physics.tips`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._typing import FloatArray
from viscoforce._validation import as_real_array, require_in_range
from viscoforce.exceptions import ParameterError

__all__ = ["DEFAULT_POISSON", "paper_from_young", "shear_from_young", "young_from_paper"]

#: Poisson's ratio assumed when none is given: an incompressible sample (soft matter, cells).
DEFAULT_POISSON = 0.5


def _out(values: FloatArray) -> FloatArray:
    """Return ``values`` with a 0-d array as a numpy scalar (scalar in, scalar out)."""
    return values[()] if values.ndim == 0 else values


def _poisson(poisson: Any) -> float:
    return require_in_range("poisson", poisson, 0.0, 0.5)


def _modulus_array(name: str, values: ArrayLike) -> FloatArray:
    """A modulus [Pa] as a float array: NaN passes (a failed fit), ±inf and negatives raise."""
    arr = as_real_array(name, values)
    bad = np.isinf(arr) | (arr < 0)
    if bad.any():
        i = int(np.flatnonzero(bad.ravel())[0])
        raise ParameterError(f"{name} must be finite and >= 0 Pa (NaN passes through); "
                             f"entry {i} is {float(arr.ravel()[i])!r}")
    return arr


# ── modulus conversions ─────────────────────────────────────────────────────────────────────


def young_from_paper(E: ArrayLike, poisson: float = DEFAULT_POISSON) -> FloatArray:  # noqa: N803
    """Young's modulus Y = E·(1 − ν²)/2 [Pa] of a sample indented by a rigid tip.

    Parameters
    ----------
    E : float or array_like
        The paper's modulus [Pa], E = 2·E_star, finite and ≥ 0 (NaN passes through, so a failed
        fit stays NaN; the conversion is linear, so it also converts a stderr).
    poisson : float, optional
        The sample's Poisson's ratio ν, in [0, 0.5] (default :data:`DEFAULT_POISSON` = 0.5, where
        E = (8/3)·Y).

    Returns
    -------
    float or ndarray
        Y [Pa].

    Raises
    ------
    ParameterError
        If ``poisson`` is not in [0, 0.5], or ``E`` holds a negative or infinite value.
    """
    nu = _poisson(poisson)
    return _out(_modulus_array("E", E) * (1.0 - nu * nu) / 2.0)


def paper_from_young(Y: ArrayLike, poisson: float = DEFAULT_POISSON) -> FloatArray:  # noqa: N803
    """The paper's modulus E = 2Y/(1 − ν²) [Pa] of a sample of Young's modulus Y on a rigid tip.

    Parameters
    ----------
    Y : float or array_like
        Young's modulus [Pa], finite and ≥ 0 (NaN passes through).
    poisson : float, optional
        Poisson's ratio ν, in [0, 0.5] (default :data:`DEFAULT_POISSON`).

    Returns
    -------
    float or ndarray
        E [Pa] (the inverse of :func:`young_from_paper`).

    Raises
    ------
    ParameterError
        If ``poisson`` is not in [0, 0.5], or ``Y`` holds a negative or infinite value.
    """
    nu = _poisson(poisson)
    return _out(2.0 * _modulus_array("Y", Y) / (1.0 - nu * nu))


def shear_from_young(Y: ArrayLike, poisson: float = DEFAULT_POISSON) -> FloatArray:  # noqa: N803
    """Shear modulus G = Y/(2(1 + ν)) [Pa] of an isotropic solid.

    Parameters
    ----------
    Y : float or array_like
        Young's modulus [Pa], finite and ≥ 0 (NaN passes through).
    poisson : float, optional
        Poisson's ratio ν, in [0, 0.5] (default :data:`DEFAULT_POISSON`, where G = Y/3 and
        G = E/8 for the paper's E).

    Returns
    -------
    float or ndarray
        G [Pa].

    Raises
    ------
    ParameterError
        If ``poisson`` is not in [0, 0.5], or ``Y`` holds a negative or infinite value.
    """
    nu = _poisson(poisson)
    return _out(_modulus_array("Y", Y) / (2.0 * (1.0 + nu)))
