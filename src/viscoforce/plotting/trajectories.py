"""Trajectory plots: force and contact-radius loops, surface profiles, force against time.

Each takes the ``xarray.Dataset`` returned by :func:`viscoforce.solvers.simulate.simulate`
(paper Figs. 1, 5–8); positions and gaps are shown in nm.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from viscoforce._typing import FloatArray
from viscoforce._validation import as_float_1d, describe_value, require_finite
from viscoforce.exceptions import ParameterError, SchemaError
from viscoforce.plotting._common import (
    _FORCE_UNITS,
    _LENGTH_UNITS,
    _NM,
    _TIME_UNITS,
    ForceUnit,
    LengthUnit,
    PlotHandle,
    TimeUnit,
    _display_limit,
    _new_or_given_axes,
    _plot,
    _require_flag,
    _require_text,
    _unit,
)
from viscoforce.schema import validate_trajectory

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

#: Linestyles that tell the branches apart: approach (loading) and retraction (unloading).
LOADING_STYLE = "-"
UNLOADING_STYLE = "--"
#: Markers of the static curves, in the order the ``statics`` mapping is given (paper Fig. 5:
#: triangles for E_inf, crosses for E0).
STATIC_MARKERS = ("^", "x", "s", "o", "v", "+", "D")
_POSITION_LABEL = "position $h_0$ [nm]"


def _require_trajectory(trajectory: Any, names: Sequence[str], function: str) -> xr.Dataset:
    """The variables ``names`` a plot needs, then the trajectory contract (units, dims)."""
    import xarray as xr

    if not isinstance(trajectory, xr.Dataset):
        raise ParameterError(
            f"trajectory must be the xarray.Dataset returned by simulate(), got "
            f"{type(trajectory).__name__}")
    missing = [n for n in names if n not in trajectory.variables]
    if missing:
        raise SchemaError(
            f"{function} needs the trajectory variables {list(names)}; missing {missing}"
            + (" (run simulate(..., profiles=N) to store profiles)"
               if "gap" in missing or "profile_time" in missing else ""))
    try:
        validate_trajectory(trajectory, require=("time", *names))
    except SchemaError as exc:
        raise SchemaError(f"{function}: {exc}") from None
    if trajectory.sizes.get("time", 0) < 2:
        raise SchemaError(f"{function} needs at least 2 output times, got "
                          f"{trajectory.sizes.get('time', 0)}")
    return trajectory


def _values(trajectory: xr.Dataset, name: str) -> FloatArray:
    return np.asarray(trajectory[name].values, dtype=float)


def _line_kw(line_kw: Mapping[str, Any] | None) -> dict[str, Any]:
    if line_kw is not None and not isinstance(line_kw, Mapping):
        raise ParameterError(
            f"line_kw must be a mapping of matplotlib line properties (e.g. {{'color': 'r'}}) or "
            f"None, got {describe_value(line_kw)}")
    kw = {} if line_kw is None else dict(line_kw)
    bad = [k for k in kw if not isinstance(k, str)]
    if bad:
        raise ParameterError(f"line_kw keys must be property names (strings), got {bad[0]!r}")
    clash = {"linestyle", "ls", "label"} & set(kw)
    if clash:
        raise ParameterError(
            f"line_kw must not set {sorted(clash)}: the linestyle tells loading from unloading "
            "and the label has its own argument")
    return kw


def _curve(name: str, curve: Any, *, finite_y: bool = True) -> tuple[FloatArray, FloatArray]:
    """Validate a reference curve (x [SI], y [SI]) of equal lengths."""
    try:
        x_raw, y_raw = curve
    except (TypeError, ValueError):
        raise ParameterError(
            f"{name} must be a pair (positions [m], values), got {curve!r}") from None
    x = as_float_1d(f"{name} positions", x_raw)
    try:
        y = np.atleast_1d(np.asarray(y_raw, dtype=float))
    except (TypeError, ValueError):
        raise ParameterError(f"{name} values must be real numbers, got {y_raw!r}") from None
    if y.shape != x.shape:
        raise ParameterError(
            f"{name} positions and values must have the same length, got {x.size} and {y.size}")
    if finite_y and not np.all(np.isfinite(y)):
        raise ParameterError(f"{name} values must be finite")
    if not finite_y and np.any(np.isnan(y)):
        raise ParameterError(f"{name} values must not be NaN (inf is allowed and dropped)")
    return x, y


def _branches(position: FloatArray) -> list[tuple[int, int, bool]]:
    """Split a path into monotone runs (start, stop inclusive, loading?).

    Loading is approach (position decreasing); a hold continues the run it interrupts (a leading
    hold joins the first move; a path that never moves counts as loading).
    """
    direction = np.sign(np.diff(position))
    moving = np.flatnonzero(direction != 0)
    if moving.size == 0:
        return [(0, position.size - 1, True)]
    filled = direction.copy()
    filled[: moving[0]] = direction[moving[0]]
    for i in range(moving[0] + 1, filled.size):
        if filled[i] == 0:
            filled[i] = filled[i - 1]
    runs = []
    start = 0
    for i in range(1, filled.size + 1):
        if i == filled.size or filled[i] != filled[start]:
            runs.append((start, i, bool(filled[start] < 0)))
            start = i
    return runs


def _draw_branches(ax: Axes, x: FloatArray, y: FloatArray, runs: list[tuple[int, int, bool]],
                   label: str | None, kw: dict[str, Any]) -> list[Artist]:
    lines: list[Artist] = []
    color = kw.pop("color", None)
    for k, (start, stop, loading) in enumerate(runs):
        style = LOADING_STYLE if loading else UNLOADING_STYLE
        line = _plot(ax, x[start:stop + 1], y[start:stop + 1], linestyle=style, color=color,
                     label=label if k == 0 and label is not None else "_nolegend_", **kw)
        color = line.get_color()
        lines.append(line)
        _direction_arrow(ax, x[start:stop + 1], y[start:stop + 1], color)
    return lines


def _direction_arrow(ax: Axes, x: FloatArray, y: FloatArray, color: Any) -> None:
    """An arrowhead half-way along a branch, pointing the way the drive went."""
    ok = np.flatnonzero(np.isfinite(x) & np.isfinite(y))
    if ok.size < 3:
        return
    middle = 0.5 * (np.min(x[ok]) + np.max(x[ok]))  # half-way along the position axis
    k = int(np.argmin(np.abs(x[ok] - middle)))
    i, j = ok[max(k - 1, 0)], ok[min(k + 1, ok.size - 1)]
    if (x[i], y[i]) == (x[j], y[j]):
        return
    ax.annotate("", xy=(x[j], y[j]), xytext=(x[i], y[i]),
                arrowprops={"arrowstyle": "-|>", "color": color, "lw": 0, "mutation_scale": 16})


def _branch_key(ax: Axes) -> None:
    """A corner note on what the linestyles mean (the arrows show the way the drive went)."""
    ax.text(0.99, 0.01, "solid: loading (approach)   dashed: unloading (retraction)",
            transform=ax.transAxes, ha="right", va="bottom", fontsize="x-small", color="0.35")


def _static_curves(statics: Mapping[str, Any] | None) -> list[tuple[str, FloatArray, FloatArray]]:
    if statics is None:
        return []
    if not isinstance(statics, Mapping):
        raise ParameterError(
            f"statics must be a mapping label -> (positions [m], values), got "
            f"{type(statics).__name__}")
    return [(str(name), *_curve(f"statics[{name!r}]", curve)) for name, curve in statics.items()]


def _draw_statics(ax: Axes, curves: list[tuple[str, FloatArray, FloatArray]],
                  scale: float) -> list[Artist]:
    lines: list[Artist] = []
    for k, (name, x, y) in enumerate(curves):
        marker = STATIC_MARKERS[k % len(STATIC_MARKERS)]
        (line,) = ax.plot(x / _NM, y / scale, linestyle="none", marker=marker, color="k",
                          markerfacecolor="none", markersize=6, label=name)
        lines.append(line)
    return lines


def _max_finite(*arrays: FloatArray) -> float:
    finite = [a[np.isfinite(a)] for a in arrays]
    return max((float(a.max()) for a in finite if a.size), default=0.0)



def hysteresis_plot(trajectory: xr.Dataset, *, ax: Axes | None = None,
                    statics: Mapping[str, tuple[ArrayLike, ArrayLike]] | None = None,
                    rigid: tuple[ArrayLike, ArrayLike] | None = None, label: str | None = None,
                    force_unit: ForceUnit = "uN", log: bool = False,
                    line_kw: Mapping[str, Any] | None = None) -> PlotHandle:
    """Force against position: the loading/unloading loop of a triangular drive (paper Fig. 5).

    Approach (position decreasing, loading) is drawn solid, retraction (unloading) dashed, in
    one colour per trajectory.

    Parameters
    ----------
    trajectory : xarray.Dataset
        Result of ``simulate`` with ``position`` [m] and ``force`` [N] over ``time``.
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; default a new figure.
    statics : mapping of str to (array_like, array_like), optional
        Static reference curves, label → (positions [m], forces [N]), drawn as open black markers
        (in order: triangles, crosses, squares, ...), as the paper's E_inf and E0 equilibria.
    rigid : (array_like, array_like), optional
        Rigid-particle load (positions [m], forces [N]), drawn as a bold black line. Infinite
        loads (h0 <= 0) are dropped, and the curve is cut at 1.2 × the largest trajectory or
        static force so that its near-vertical rise does not swamp the axes.
    label : str, optional
        Legend label of the trajectory (given to its first branch only).
    force_unit : {"N", "mN", "uN", "nN", "pN"}
        Display unit of the force.
    log : bool
        Logarithmic force axis (non-positive forces are not drawn), as the paper's Fig. 8 inset.
    line_kw : mapping, optional
        Extra matplotlib line properties of the trajectory (e.g. ``color``, ``linewidth``);
        ``linestyle`` and ``label`` are reserved.

    Returns
    -------
    PlotHandle
        Figure, axes and the lines: trajectory branches, then statics, then the rigid curve.

    Raises
    ------
    ParameterError
        Bad unit, axes, line properties or reference curves.
    SchemaError
        The trajectory lacks ``position`` or ``force``.
    """
    scale, unit = _unit("force_unit", force_unit, _FORCE_UNITS)
    label = _require_text("label", label)
    log = _require_flag("log", log)
    ds = _require_trajectory(trajectory, ("position", "force"), "hysteresis_plot")
    kw = _line_kw(line_kw)
    curves = _static_curves(statics)
    rigid_curve = None if rigid is None else _curve("rigid", rigid, finite_y=False)
    figure, axes = _new_or_given_axes(ax, (6.0, 4.5))
    position = _values(ds, "position")
    force = _values(ds, "force")
    y = np.where(force > 0, force, np.nan) if log else force
    lines = _draw_branches(axes, position / _NM, y / scale, _branches(position), label, kw)
    lines += _draw_statics(axes, curves, scale)
    if rigid_curve is not None:
        x_r, f_r = rigid_curve
        cap = 1.2 * _max_finite(force, *(y_s for _, _, y_s in curves))
        keep = np.isfinite(f_r) & (f_r <= cap) & ((f_r > 0) | (not log))
        (line,) = axes.plot(x_r[keep] / _NM, f_r[keep] / scale, color="k", linewidth=2.5,
                            label="rigid")
        lines.append(line)
    if log:
        axes.set_yscale("log")
    axes.set_xlabel(_POSITION_LABEL)
    axes.set_ylabel(f"force $F$ [{unit}]")
    _branch_key(axes)
    return PlotHandle(figure, (axes,), tuple(lines))


def contact_radius_plot(trajectory: xr.Dataset, *, ax: Axes | None = None,
                        statics: Mapping[str, tuple[ArrayLike, ArrayLike]] | None = None,
                        label: str | None = None, radius_unit: LengthUnit = "nm",
                        line_kw: Mapping[str, Any] | None = None) -> PlotHandle:
    """Contact radius against position: the loop of a triangular drive (paper Fig. 6).

    Approach (loading) is drawn solid, retraction (unloading) dashed. The contact radius is the
    one ``simulate`` stored (largest radius where the gap is below its contact threshold,
    ``trajectory.attrs["contact_threshold"]``, by default 1/κ).

    Parameters
    ----------
    trajectory : xarray.Dataset
        Result of ``simulate`` with ``position`` [m] and ``contact_radius`` [m].
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; default a new figure.
    statics : mapping of str to (array_like, array_like), optional
        Static reference curves, label → (positions [m], contact radii [m]), drawn as open
        black markers.
    label : str, optional
        Legend label of the trajectory.
    radius_unit : {"m", "um", "nm"}
        Display unit of the contact radius.
    line_kw : mapping, optional
        Extra matplotlib line properties (``linestyle`` and ``label`` are reserved).

    Returns
    -------
    PlotHandle
        Figure, axes and the lines (trajectory branches, then statics).

    Raises
    ------
    ParameterError
        Bad unit, axes, line properties or reference curves.
    SchemaError
        The trajectory lacks ``position`` or ``contact_radius``.
    """
    scale, unit = _unit("radius_unit", radius_unit, _LENGTH_UNITS)
    label = _require_text("label", label)
    ds = _require_trajectory(trajectory, ("position", "contact_radius"), "contact_radius_plot")
    kw = _line_kw(line_kw)
    curves = _static_curves(statics)
    figure, axes = _new_or_given_axes(ax, (6.0, 4.5))
    position = _values(ds, "position")
    radius = _values(ds, "contact_radius")
    lines = _draw_branches(axes, position / _NM, radius / scale, _branches(position), label, kw)
    lines += _draw_statics(axes, curves, scale)
    axes.set_xlabel(_POSITION_LABEL)
    axes.set_ylabel(f"contact radius $a$ [{unit}]")
    _branch_key(axes)
    return PlotHandle(figure, (axes,), tuple(lines))


def _profile_axes(ax: Any) -> tuple[Figure, tuple[Axes, ...]]:
    from matplotlib.axes import Axes

    if ax is None:
        import matplotlib.pyplot as plt

        figure, pair = plt.subplots(1, 2, figsize=(10.0, 4.5), sharey=True, layout="constrained")
        return figure, (pair[0], pair[1])
    if isinstance(ax, Axes):
        return ax.figure, (ax,)
    if isinstance(ax, Sequence) and len(ax) == 2 and all(isinstance(a, Axes) for a in ax):
        return ax[0].figure, (ax[0], ax[1])
    raise ParameterError(
        f"ax must be None, one matplotlib Axes or a pair of Axes (loading, unloading), got {ax!r}")


def profile_plot(trajectory: xr.Dataset, *, ax: Axes | Sequence[Axes] | None = None,
                 r_max: float | None = None, gap_max: float | None = None,
                 radius_unit: LengthUnit = "nm", cmap: str = "viridis") -> PlotHandle:
    """Local gap h(r) at the stored profile times, coloured by position (paper Fig. 7).

    The profiles are split at the deepest position: those up to it are loading, those from it
    on are unloading (the turning-point profile belongs to both). With two panels (``ax`` None
    or a pair) loading goes left and unloading right, both drawn solid; on a single axes
    unloading is drawn dashed. A colour bar gives the position h0 of each profile.

    Parameters
    ----------
    trajectory : xarray.Dataset
        Result of ``simulate(..., profiles=N)``: ``gap`` [m] over (``profile_time``, ``r``),
        plus ``position`` [m] over ``time``.
    ax : matplotlib Axes or pair of Axes, optional
        Where to draw; default a new figure with two panels (loading, unloading).
    r_max : float, optional
        Largest radius shown [m], > 0; default the whole grid.
    gap_max : float, optional
        Largest gap shown [m], > 0; default autoscaled.
    radius_unit : {"m", "um", "nm"}
        Display unit of the radial coordinate.
    cmap : str
        Matplotlib colormap name for the position.

    Returns
    -------
    PlotHandle
        Figure, the axes (one or two) and the profile lines (loading, then unloading), then the
        colour bar.

    Raises
    ------
    ParameterError
        Bad unit, axes, limits or colormap.
    SchemaError
        The trajectory holds no profiles.
    """
    import matplotlib as mpl

    r_scale, r_unit = _unit("radius_unit", radius_unit, _LENGTH_UNITS)
    ds = _require_trajectory(trajectory, ("position", "gap", "profile_time", "r"),
                             "profile_plot")
    r_limit = _display_limit("r_max", r_max, r_scale, r_unit)
    h_limit = _display_limit("gap_max", gap_max, _NM, "nm")
    if not isinstance(cmap, str) or cmap not in mpl.colormaps:
        raise ParameterError(
            f"cmap must be a matplotlib colormap name (e.g. 'viridis'), got {describe_value(cmap)}")
    figure, panels = _profile_axes(ax)
    time = _values(ds, "time")
    position = _values(ds, "position")
    profile_time = _values(ds, "profile_time")
    r = _values(ds, "r")
    gap = _values(ds, "gap")
    profile_position = np.interp(profile_time, time, position)
    t_turn = time[int(np.argmin(position))]
    norm = mpl.colors.Normalize(vmin=float(profile_position.min()) / _NM,
                                vmax=float(profile_position.max()) / _NM)
    colormap = mpl.colormaps[cmap]
    shown = r <= r_limit if r_limit is not None else np.ones(r.shape, dtype=bool)
    lines: list[Artist] = []
    branches = ((profile_time <= t_turn, panels[0], LOADING_STYLE, "loading (approach)"),
                (profile_time >= t_turn, panels[-1],
                 UNLOADING_STYLE if len(panels) == 1 else LOADING_STYLE,
                 "unloading (retraction)"))
    for select, panel, style, title in branches:
        for k in np.flatnonzero(select):
            (line,) = panel.plot(r[shown] / r_scale, gap[k, shown] / _NM, linestyle=style,
                                 color=colormap(norm(profile_position[k] / _NM)), linewidth=1.2)
            lines.append(line)
        if len(panels) == 2:
            panel.set_title(title)
    for panel in panels:
        panel.set_xlabel(f"radius $r$ [{r_unit}]")
        if r_limit is not None:
            panel.set_xlim(0.0, r_limit / r_scale)
        if h_limit is not None:
            panel.set_ylim(0.0, h_limit / _NM)
    panels[0].set_ylabel("local gap $h(r)$ [nm]")
    bar = figure.colorbar(mpl.cm.ScalarMappable(norm=norm, cmap=colormap), ax=list(panels))
    bar.set_label(_POSITION_LABEL)
    return PlotHandle(figure, panels, (*lines, bar))


def force_time_plot(trajectory: xr.Dataset, *, ax: Axes | None = None, log: bool = False,
                    reference: float | None = None, t_start: float = 0.0,
                    label: str | None = None, force_unit: ForceUnit = "uN",
                    time_unit: TimeUnit = "ms",
                    line_kw: Mapping[str, Any] | None = None) -> PlotHandle:
    """Force against time, e.g. the load relaxation after a step (paper Fig. 1).

    Parameters
    ----------
    trajectory : xarray.Dataset
        Result of ``simulate`` with ``force`` [N] over ``time`` [s].
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; default a new figure.
    log : bool
        Logarithmic force axis. With ``reference`` it shows |F − F*| (the paper's Fig. 1 inset,
        whose slope gives the relaxation time); non-positive values are not drawn.
    reference : float, optional
        Force F* [N] subtracted from the force (typically the relaxed load).
    t_start : float
        Time [s] shown as 0 (e.g. the start of the step).
    label : str, optional
        Legend label.
    force_unit : {"N", "mN", "uN", "nN", "pN"}
        Display unit of the force.
    time_unit : {"s", "ms", "us"}
        Display unit of the time.
    line_kw : mapping, optional
        Extra matplotlib line properties (``linestyle`` and ``label`` are reserved).

    Returns
    -------
    PlotHandle
        Figure, axes and the one force line.

    Raises
    ------
    ParameterError
        Bad unit, axes, line properties, ``reference`` or ``t_start``.
    SchemaError
        The trajectory lacks ``force``.
    """
    f_scale, f_unit = _unit("force_unit", force_unit, _FORCE_UNITS)
    t_scale, t_unit = _unit("time_unit", time_unit, _TIME_UNITS)
    log = _require_flag("log", log)
    label = _require_text("label", label)
    ds = _require_trajectory(trajectory, ("force",), "force_time_plot")
    f_ref = None if reference is None else require_finite("reference", reference)
    t0 = require_finite("t_start", t_start)
    kw = _line_kw(line_kw)
    figure, axes = _new_or_given_axes(ax, (6.0, 4.5))
    time = _values(ds, "time")
    force = _values(ds, "force")
    y = force if f_ref is None else force - f_ref
    if log:
        y = np.abs(y) if f_ref is not None else y
        y = np.where(y > 0, y, np.nan)
    line = _plot(axes, (time - t0) / t_scale, y / f_scale, label=label or "_nolegend_", **kw)
    if log:
        axes.set_yscale("log")
    if f_ref is None:
        quantity = "force $F$"
    elif log:
        quantity = "$|F - F^*|$"
    else:
        quantity = "$F - F^*$"
    axes.set_xlabel(f"time $t$ [{t_unit}]")
    axes.set_ylabel(f"{quantity} [{f_unit}]")
    return PlotHandle(figure, (axes,), (line,))
