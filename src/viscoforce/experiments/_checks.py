"""Argument checks shared by the spectroscopy entry points (sweep, linear_response, svda_*).

Each check raises :class:`~viscoforce.exceptions.ParameterError` naming the parameter, the value
and the allowed range, whatever is wrong with it (None, a string, NaN/inf, out of range).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from viscoforce._validation import as_float_1d
from viscoforce.exceptions import ParameterError
from viscoforce.problem import ContactProblem

__all__ = ["require_problem", "require_number", "require_frequencies", "require_progress"]


def require_problem(problem: Any) -> ContactProblem:
    """Return ``problem``, raising unless it is a :class:`~viscoforce.problem.ContactProblem`."""
    if not isinstance(problem, ContactProblem):
        raise ParameterError(
            "problem must be a ContactProblem (ContactProblem.create(sphere=..., "
            f"surface_force=..., material=..., deepest_position=...)), got {problem!r:.80}")
    return problem


def require_number(name: str, value: Any, check: Callable[[str, Any], float],
                   allowed: str) -> float:
    """Apply a :mod:`viscoforce._validation` check; on failure state the whole allowed range.

    Parameters
    ----------
    name : str
        Parameter name.
    value : object
        The value given.
    check : callable
        ``check(name, value) -> float``, e.g. ``require_positive``.
    allowed : str
        What is allowed, completing "``name`` must be ...", e.g. ``"> 0 [m] (finite)"``.

    Returns
    -------
    float
        The checked value.

    Raises
    ------
    ParameterError
        ``"{name} must be {allowed}, got {value!r}"``.
    """
    try:
        return check(name, value)
    except ParameterError:
        raise ParameterError(f"{name} must be {allowed}, got {value!r}") from None


def require_frequencies(omega: Any, *, allow_zero: bool) -> NDArray[np.float64]:
    """Return ``omega`` [rad/s] as a non-empty finite 1-D array, all > 0 (or >= 0).

    Parameters
    ----------
    omega : array_like
        Angular frequencies [rad/s].
    allow_zero : bool
        Accept ω = 0 (the frequency-domain routes) or require ω > 0 (the time-domain sweeps,
        whose drive period 2π/ω must be finite).

    Returns
    -------
    numpy.ndarray
        The frequencies, float64, 1-D.

    Raises
    ------
    ParameterError
        If ``omega`` is not a non-empty 1-D array of finite reals in the allowed range.
    """
    bound = ">= 0" if allow_zero else "> 0"
    try:
        w = as_float_1d("omega", omega)
    except ParameterError as exc:
        raise ParameterError(
            f"omega must be a non-empty 1-D array of finite angular frequencies {bound} rad/s: "
            f"{exc}") from None
    bad = np.flatnonzero(w < 0 if allow_zero else w <= 0)
    if bad.size:
        i = int(bad[0])
        raise ParameterError(f"omega must be {bound} rad/s; entry {i} is {float(w[i])!r}")
    return w


def require_progress(progress: Any) -> bool | None:
    """Return ``progress``, raising unless it is True, False or None (automatic)."""
    if progress is not None and not isinstance(progress, bool | np.bool_):
        raise ParameterError(
            f"progress must be True, False or None (bar only when stderr is a terminal), "
            f"got {progress!r}")
    return None if progress is None else bool(progress)
