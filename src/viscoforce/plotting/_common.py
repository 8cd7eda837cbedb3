"""What every plot shares: the returned handle, option checks, display units and new axes.

Nothing here draws data; matplotlib is imported only inside the functions (and for type checking).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from viscoforce._typing import FloatArray
from viscoforce._validation import describe_value, require_positive
from viscoforce.exceptions import ParameterError

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.colorbar import Colorbar
    from matplotlib.figure import Figure

ForceUnit = Literal["N", "mN", "uN", "nN", "pN"]
TimeUnit = Literal["s", "ms", "us"]
LengthUnit = Literal["m", "um", "nm"]

#: Display units: option name → (size of the unit in SI, label text).
_FORCE_UNITS: dict[str, tuple[float, str]] = {
    "N": (1.0, "N"), "mN": (1e-3, "mN"), "uN": (1e-6, "µN"), "nN": (1e-9, "nN"),
    "pN": (1e-12, "pN"),
}
_TIME_UNITS: dict[str, tuple[float, str]] = {"s": (1.0, "s"), "ms": (1e-3, "ms"),
                                             "us": (1e-6, "µs")}
_LENGTH_UNITS: dict[str, tuple[float, str]] = {"m": (1.0, "m"), "um": (1e-6, "µm"),
                                               "nm": (1e-9, "nm")}
_NM = 1e-9

@dataclass(frozen=True)
class PlotHandle:
    """What a plot function drew.

    Attributes
    ----------
    figure : matplotlib.figure.Figure
        The figure holding the axes.
    axes : tuple of matplotlib.axes.Axes
        The axes drawn on (one, or two for the two-panel :func:`profile_plot`).
    lines : tuple of matplotlib.artist.Artist or matplotlib.colorbar.Colorbar
        What was drawn, in drawing order: trajectory branches first, then reference curves (and,
        for :func:`profile_plot`, the colour bar last).
    """

    figure: Figure
    axes: tuple[Axes, ...]
    lines: tuple[Artist | Colorbar, ...]

    @property
    def ax(self) -> Axes:
        """The first (main) axes."""
        return self.axes[0]


# ── helpers: validation and unit conversion ─────────────────────────────────────────────────────


def _require_choice(name: str, value: Any, choices: Sequence[str] | Mapping[str, Any]) -> str:
    """Return ``value``, raising unless it is one of the strings ``choices``.

    The ``isinstance`` test comes first: ``value in choices`` would raise for an unhashable
    value (list, dict) or be ambiguous for an array.
    """
    if not isinstance(value, str) or value not in choices:
        listed = ", ".join(repr(c) for c in (sorted(choices) if isinstance(choices, Mapping)
                                             else choices))
        raise ParameterError(f"{name} must be one of {listed}, got {describe_value(value)}")
    return value


def _require_flag(name: str, value: Any, *, allow_none: bool = False) -> bool | None:
    """Return ``value`` as a bool, raising unless it is True or False (or None if allowed)."""
    if value is None and allow_none:
        return None
    if not isinstance(value, bool | np.bool_):
        allowed = "True, False or None" if allow_none else "True or False"
        raise ParameterError(f"{name} must be {allowed}, got {describe_value(value)}")
    return bool(value)


def _require_text(name: str, value: Any) -> str | None:
    """Return ``value``, raising unless it is a string or None (a label or title)."""
    if value is not None and not isinstance(value, str):
        raise ParameterError(f"{name} must be a string or None, got {describe_value(value)}")
    return value


def _display_limit(name: str, value: Any, scale: float, unit: str) -> float | None:
    """Validate an axis limit [SI] (> 0, or None) that is shown in ``unit`` (= ``scale`` SI)."""
    if value is None:
        return None
    limit = require_positive(name, value)
    if not np.isfinite(limit / scale):
        raise ParameterError(
            f"{name} must be at most {np.finfo(float).max * scale:.3g} m to be shown in {unit}, "
            f"got {value!r}")
    return limit


def _unit(name: str, value: str, table: Mapping[str, tuple[float, str]]) -> tuple[float, str]:
    return table[_require_choice(name, value, table)]


def _plot(ax: Axes, x: FloatArray, y: FloatArray, **kw: Any) -> Artist:
    """``ax.plot`` of one line; a bad matplotlib property in ``line_kw`` raises ParameterError."""
    try:
        (line,) = ax.plot(x, y, **kw)
    except (AttributeError, TypeError, ValueError) as exc:
        raise ParameterError(f"line_kw holds an invalid matplotlib line property: {exc}") from None
    return line



def _new_or_given_axes(ax: Any, figsize: tuple[float, float]) -> tuple[Figure, Axes]:
    from matplotlib.axes import Axes

    if ax is None:
        import matplotlib.pyplot as plt

        figure, new_ax = plt.subplots(figsize=figsize, layout="constrained")
        return figure, new_ax
    if not isinstance(ax, Axes):
        raise ParameterError(f"ax must be a matplotlib Axes or None, got {type(ax).__name__}")
    return ax.figure, ax




# ── which modulus a person reads: Young's first (issue 38 item 3) ───────────────────────────────


def _main_variable(result: Any) -> str | None:
    """The variable a map shows by default: Young's modulus of the main modulus where present.

    The first fitted parameter (``param_i``) with a derived ``<name>_young`` gives
    ``<name>_young``; without one, the first fitted parameter; None without ``param_i``.
    """
    if "param_i" not in result.coords:
        return None
    names = [str(n) for n in result["param_i"].values]
    young = [n for n in names if f"{n}_young" in result.variables]
    return f"{young[0]}_young" if young else (names[0] if names else None)


def _mapped_variables(result: Any) -> list[str]:
    """The fitted parameters with their derived moduli, Young's before the paper's, then shear.

    Per fitted parameter ``<name>``: ``<name>_young`` (where present), ``<name>``,
    ``<name>_shear`` (where present).
    """
    names = [str(n) for n in result["param_i"].values] if "param_i" in result.coords else []
    return [v for n in names for v in (f"{n}_young", n, f"{n}_shear")
            if v == n or v in result.variables]


def _what(result: Any, name: str) -> str:
    """What a variable is, for a person: Young's, shear or the paper's modulus; else ''.

    ``E_young`` → ``"Young's modulus"``; ``E`` (with ``E_young`` beside it) → ``"paper's E,
    2 E_young/(1 − ν²)"``; ``mu_young`` → ``"Young's viscosity"``.
    """
    for suffix, what in (("_young", "Young's"), ("_shear", "shear")):
        base = name.removesuffix(suffix)
        if base != name and name in result.variables:
            kind = "viscosity" if base == "mu" else "modulus"
            return f"{what} {kind}"
    if f"{name}_young" in result.variables:
        return f"paper's {name} = 2 {name}_young/(1 − ν²)"
    return ""


def _variable_label(result: Any, name: str, unit: str) -> str:
    """An axis or colour-bar label: ``"Young's modulus E_young [kPa]"``, ``"tau [ms]"``."""
    what = _what(result, name)
    if what.startswith("paper's"):
        text = f"{name} (paper's convention: 2 {name}_young/(1 − ν²))"
    else:
        text = f"{what} {name}" if what else name
    return f"{text} [{unit}]" if unit and unit != "1" else text
