"""The options of :func:`~viscoforce.measured.open.open_data`: their checks and their errors.

Every refusal is an :class:`OptionError` (a :class:`~viscoforce.exceptions.ParameterError`)
whose message names the parameters involved; the command line tells the same message with its
flags instead (:meth:`OptionError.told`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from viscoforce.exceptions import ParameterError

__all__ = ["OptionError", "expand_phase_lag", "has_modulation", "literal"]

#: How a parameter is named in the library's own messages, where not by its name.
_LIBRARY_NAMES = {"raw": "raw=True", "path": ""}


class _Names(dict):
    """Names for a message template: those given, else the library's (:data:`_LIBRARY_NAMES`)."""

    def __missing__(self, key: str) -> str:
        return _LIBRARY_NAMES.get(key, key)


class OptionError(ParameterError):
    """An option of :func:`~viscoforce.measured.open.open_data`, or a combination, that fails.

    The message names the parameters (``phase_lag 3Hz: the file has no modulation at that
    frequency (it has 1, 10 Hz)``). :attr:`template` holds it with each name as ``{name}``, so
    that a front end can tell it in its own terms: :meth:`told`.
    """

    def __init__(self, template: str):
        self.template = template
        super().__init__(self.told())

    def __reduce__(self):  # pickled with its template (the message is made again from it)
        return (type(self), (self.template,))

    def told(self, names: Mapping[str, str] | None = None) -> str:
        """The message with ``names`` (parameter → what to call it) for the parameters it names."""
        return self.template.format_map(_Names(names or {}))


def literal(value: Any) -> str:
    """``str(value)`` for a message template (braces doubled, so they stay as they are)."""
    return str(value).replace("{", "{{").replace("}", "}}")


def has_modulation(ds: Any) -> bool:
    """Whether a curves dataset has sine-modulation segments (``segment_name`` "modulation")."""
    names = ds.get("segment_name")
    return names is not None and bool((names.values == "modulation").any())


def _number(value: Any) -> bool:
    return isinstance(value, int | float | np.integer | np.floating) and not isinstance(
        value, bool | np.bool_)


def check_options(*, path: Any, raw: Any, drag: Any, drag_heights: Any, phase_lag: Any,
                  phase_reference: Any, tip: Any, poisson: Any) -> tuple[Any, Any]:
    """Refuse what needs no file to refuse; return ``(tip, drag_heights)`` as used.

    ``tip`` becomes a :class:`~viscoforce.physics.tips.Tip`, ``drag_heights`` a list of
    (height [m], path) pairs; ``poisson`` is checked against [0, 0.5].
    """
    from viscoforce.physics.tips import tip_from, young_from_paper

    if not isinstance(path, str | PathLike):
        raise ParameterError(f"path must be a str or Path, got {type(path).__name__}")
    if not isinstance(raw, bool | np.bool_):
        raise ParameterError(f"raw must be True or False, got {raw!r}")
    if drag is not None and drag_heights is not None:
        raise OptionError("give {drag} or {drag_heights}, not both")
    if phase_lag is not None and not _number(phase_lag) and not isinstance(phase_lag, Mapping):
        raise OptionError("{phase_lag} must be degrees for every frequency (a number) or a "
                          "mapping frequency [Hz] -> degrees, got "
                          f"{literal(type(phase_lag).__name__)}")
    if isinstance(phase_lag, Mapping) and not all(
            _number(f) and _number(v) for f, v in phase_lag.items()):
        raise OptionError("{phase_lag} maps frequencies [Hz] to degrees (numbers), got "
                          f"{literal(dict(phase_lag))}")
    if phase_reference is not None and not isinstance(phase_reference, str | PathLike):
        import xarray as xr

        if not isinstance(phase_reference, xr.Dataset):
            raise OptionError("{phase_reference} must be a path or a spectrum dataset (a "
                              "hard-surface reference), or one of 'auto', 'sensor', 'piezo', "
                              f"'delay', got {literal(type(phase_reference).__name__)}")
    if poisson is not None:
        if not _number(poisson):
            raise OptionError("{poisson} must be a number in [0, 0.5], got "
                              f"{literal(repr(poisson))}")
        if tip is None:
            raise OptionError("{poisson} needs {tip} (the moduli need the tip's contact size)")
        young_from_paper(1.0, float(poisson))  # ν in [0, 0.5], refused by its own message
    return tip_from(tip), _heights(drag_heights)


def _heights(items: Any) -> list[tuple[float, str | PathLike]] | None:
    """``drag_heights`` as (height [m], path) pairs."""
    if items is None:
        return None
    bad = OptionError("{drag_heights} must be (height [m], path) pairs, e.g. [(1e-6, "
                      "'free1.jpk-force'), (2e-6, 'free2.jpk-force'), (4e-6, "
                      "'free4.jpk-force')], got " + literal(repr(items)))
    if isinstance(items, str | PathLike) or not isinstance(items, Sequence):
        raise bad
    pairs = []
    for item in items:
        if (isinstance(item, str | PathLike) or not isinstance(item, Sequence) or len(item) != 2
                or not _number(item[0]) or not isinstance(item[1], str | PathLike)):
            raise bad
        pairs.append((float(item[0]), item[1]))
    return pairs


def expand_phase_lag(value: Any, data: Any) -> float | dict[float, float] | None:
    """One lag [deg] for all frequencies, or {Hz: deg} over every frequency of ``data``.

    A mapping names some frequencies of the file (those it does not name get 0); one it names
    that the file does not have is refused with the ones it has.
    """
    if value is None:
        return None
    if not isinstance(value, Mapping):
        return float(value)
    if "omega" in data.dims:  # a spectrum already made (a CSV, a netCDF from load)
        present = np.unique(np.asarray(data["omega"].values, dtype=float) / (2 * np.pi))
    elif "segment_frequency" in data:
        present = np.unique(data["segment_frequency"].values)
    else:
        present = []
    present = [float(f) for f in present if np.isfinite(f)]
    lags = {float(f): float(v) for f, v in value.items()}
    for f in lags:
        if not any(abs(f - p) <= 1e-9 * p for p in present):
            raise OptionError("{phase_lag} " + f"{f:g}Hz: the file has no modulation at that "
                              f"frequency (it has {', '.join(f'{p:g}' for p in present)} Hz)")
    return {p: next((v for f, v in lags.items() if abs(f - p) <= 1e-9 * p), 0.0) for p in present}


def is_netcdf(path: Any, fmt: Any) -> bool:
    """Whether ``path`` is read as a netCDF file (``*.nc`` and no format given)."""
    return fmt is None and Path(path).suffix.lower() == ".nc"

