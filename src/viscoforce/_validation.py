"""Input checks shared by every public entry point.

Each check names the parameter, shows the offending value and states the allowed range, so that
the message alone tells the user what to change.
"""

from __future__ import annotations

import math
import os
import reprlib
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from viscoforce.exceptions import ParameterError


def describe_value(value: Any) -> str:
    """Short text for a rejected value in a message: ``None``, ``str 'abc'``, ``ndarray array([...])``."""
    if value is None:
        return "None"
    return f"{type(value).__name__} {reprlib.repr(shown(value))}"


def shown(value: Any) -> Any:
    """``value`` with numpy scalars as plain Python numbers (``-1e-10``, not ``np.float64(-1e-10)``)."""
    return value.item() if isinstance(value, np.generic) else value


def require_instance(name: str, value: Any, cls: type | tuple[type, ...], *,
                     what: str | None = None) -> Any:
    """Return ``value`` unchanged, raising unless it is an instance of ``cls``.

    ``what`` names the expected kind in the message (default the class name), e.g.
    ``"sphere must be a Sphere, got None"``.
    """
    if not isinstance(value, cls):
        if what is None:
            names = [c.__name__ for c in (cls if isinstance(cls, tuple) else (cls,))]
            what = " or ".join(names)
        raise ParameterError(f"{name} must be a {what}, got {describe_value(value)}")
    return value


def require_path(name: str, value: Any) -> Path:
    """Return ``value`` as a :class:`~pathlib.Path`, raising unless it is a non-empty str or path."""
    if isinstance(value, bytes) or not isinstance(value, str | os.PathLike) or not str(value):
        raise ParameterError(
            f"{name} must be a file path (str or pathlib.Path), got {describe_value(value)}")
    return Path(value)


def _is_complex(value: Any) -> bool:
    """True for complex numbers and arrays (False for anything numpy cannot read as an array)."""
    if isinstance(value, complex | np.complexfloating):
        return True
    try:
        return bool(np.iscomplexobj(value))
    except (TypeError, ValueError):
        return False


def _as_real_float(name: str, value: Any) -> float:
    if isinstance(value, float):  # fast path (also numpy float64)
        return float(value)
    if isinstance(value, bool | str | bytes | np.bool_) or _is_complex(value):
        # text is refused, not parsed: "1e9" may be a quantity without its unit (the CLI parses)
        raise ParameterError(f"{name} must be a real number, got {shown(value)!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a real number, got {shown(value)!r}") from None
    return x


def require_finite(name: str, value: Any) -> float:
    """Return ``value`` as a float, raising if it is not a finite real number."""
    x = _as_real_float(name, value)
    if not math.isfinite(x):
        raise ParameterError(f"{name} must be finite, got {shown(value)!r}")
    return x


def require_positive(name: str, value: Any) -> float:
    """Return ``value`` as a float, raising unless it is finite and > 0."""
    x = require_finite(name, value)
    if x <= 0:
        raise ParameterError(f"{name} must be > 0, got {shown(value)!r}")
    return x


def require_nonnegative(name: str, value: Any) -> float:
    """Return ``value`` as a float, raising unless it is finite and >= 0."""
    x = require_finite(name, value)
    if x < 0:
        raise ParameterError(f"{name} must be >= 0, got {shown(value)!r}")
    return x


def require_in_range(name: str, value: Any, low: float, high: float, *,
                     inclusive: tuple[bool, bool] = (True, True)) -> float:
    """Return ``value`` as a float, raising unless ``low <= value <= high`` (bounds as given)."""
    x = require_finite(name, value)
    lo_ok = x >= low if inclusive[0] else x > low
    hi_ok = x <= high if inclusive[1] else x < high
    if not (lo_ok and hi_ok):
        lb = "[" if inclusive[0] else "("
        rb = "]" if inclusive[1] else ")"
        raise ParameterError(f"{name} must be in {lb}{low:g}, {high:g}{rb}, got {shown(value)!r}")
    return x


def require_plausible(name: str, value: Any, bounds: tuple[float, float], unit: str, *,
                      why: str = "") -> float:
    """Return ``value`` as a float, raising unless it is finite and within ``bounds`` (inclusive).

    For a physical quantity with a plausible range (:mod:`viscoforce._limits`): the message
    reads ``"radius must be within the plausible range [1e-09, 1] m (why), got 1e+300 m"``.
    """
    x = require_finite(name, value)
    low, high = bounds
    if not low <= x <= high:
        note = f" ({why})" if why else ""
        raise ParameterError(f"{name} must be within the plausible range [{low:g}, {high:g}] "
                             f"{unit}{note}, got {shown(value)!r} {unit}")
    return x


def require_int(name: str, value: Any, minimum: int) -> int:
    """Return ``value`` as an int, raising unless it is an integer >= ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ParameterError(f"{name} must be an integer >= {minimum}, got {shown(value)!r}")
    if value < minimum:
        raise ParameterError(f"{name} must be an integer >= {minimum}, got {shown(value)!r}")
    return int(value)


def _has_bool_or_text(values: Any) -> bool:
    """True for a bool or text array, or a sequence holding bools or text.

    True is not 1 rad/s, and "100" may be a quantity without its unit.
    """
    if isinstance(values, np.ndarray):
        return values.dtype == np.bool_ or values.dtype.kind in "USO" and any(
            isinstance(v, bool | str | bytes) for v in values.ravel())
    if isinstance(values, list | tuple):
        return any(isinstance(v, bool | np.bool_ | str | bytes) or _has_bool_or_text(v)
                   for v in values)
    return False


def as_real_array(name: str, values: Any, kind: str = "a number or an array") -> NDArray[np.float64]:
    """Return ``values`` as a float64 array of any shape (NaN and ±inf pass).

    Raise for None, complex, text or other non-numbers. A float64 ndarray is returned as is (no
    copy, ~0.3 µs).
    """
    if type(values) is np.ndarray and values.dtype == np.float64:
        return values
    if values is None or isinstance(values, dict | str | bytes) or _is_complex(values):
        raise ParameterError(f"{name} must be {kind} of real numbers, got {describe_value(values)}")
    if isinstance(values, bool | np.bool_) or _has_bool_or_text(values):
        raise ParameterError(f"{name} must be {kind} of real numbers, got "
                             f"{describe_value(values)}")
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(
            f"{name} must be {kind} of real numbers, got {describe_value(values)}") from None
    return arr


def as_float_array(name: str, values: ArrayLike, *, allow_inf: bool = False,
                   size: int | None = None) -> NDArray[np.float64]:
    """Return ``values`` as a float64 array of any shape without NaN (and without ±inf by default).

    ``size`` requires the last axis to have that many entries (e.g. one value per grid node).
    A float64 ndarray is returned as is (no copy); the checks cost a few µs on the solver's hot
    path.
    """
    arr = as_real_array(name, values)
    if size is not None and (arr.ndim == 0 or arr.shape[-1] != size):
        raise ParameterError(
            f"{name} must have {size} values along its last axis (one per node), got shape "
            f"{arr.shape}")
    if not (not np.isnan(arr).any() if allow_inf else np.isfinite(arr).all()):
        bad = np.isnan(arr) if allow_inf else ~np.isfinite(arr)
        flat = arr.ravel()
        i = int(np.flatnonzero(bad.ravel())[0])
        what = "must not be NaN" if allow_inf else "must be finite"
        raise ParameterError(f"{name} {what}; entry {i} is {float(flat[i])!r}")
    return arr


def as_float_1d(name: str, values: ArrayLike, *, min_size: int = 1) -> NDArray[np.float64]:
    """Return ``values`` as a finite 1-D float64 array with at least ``min_size`` entries."""
    arr = np.atleast_1d(as_real_array(name, values, "a 1-D array"))
    if arr.ndim != 1:
        raise ParameterError(f"{name} must be 1-D, got shape {arr.shape}")
    if arr.size < min_size:
        raise ParameterError(f"{name} needs at least {min_size} values, got {arr.size}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.flatnonzero(~np.isfinite(arr))[0])
        raise ParameterError(f"{name} must be finite; entry {bad} is {float(arr[bad])!r}")
    return arr


def require_increasing(name: str, values: ArrayLike, *, strict: bool = True) -> NDArray[np.float64]:
    """Return ``values`` as a 1-D float array, raising unless it increases (strictly by default)."""
    arr = as_float_1d(name, values)
    d = np.diff(arr)
    bad = np.flatnonzero(d <= 0) if strict else np.flatnonzero(d < 0)
    if bad.size:
        i = int(bad[0])
        word = "strictly increasing" if strict else "non-decreasing"
        raise ParameterError(
            f"{name} must be {word}; entry {i + 1} ({float(arr[i + 1])!r}) follows "
            f"{float(arr[i])!r}")
    return arr


def require_sls_moduli(E0: Any, E_inf: Any, tau: Any) -> tuple[float, float, float]:  # noqa: N803
    """Validate the standard linear solid (E0 > E_inf > 0, tau > 0); the one rule everywhere.

    E0 = E_inf is not a standard linear solid (nothing relaxes, τ is undefined): use an elastic
    material with E instead.
    """
    e0 = require_positive("E0", E0)
    e_inf = require_positive("E_inf", E_inf)
    t = require_positive("tau", tau)
    if not e0 > e_inf:
        raise ParameterError(
            f"E0 (instantaneous modulus) must be > E_inf (relaxed modulus) [Pa], got E0={E0!r}, "
            f"E_inf={E_inf!r}; for a purely elastic material use Elastic(E) (--E)")
    return e0, e_inf, t
