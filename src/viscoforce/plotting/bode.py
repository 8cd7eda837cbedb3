"""Bode plot: magnitude and phase χ of spectra against a log frequency axis, data against fit.

Measured points get error bars from their ``<name>_stderr`` variables, points whose ``quality``
flag is non-zero are ringed in red (the legend gives the flag's meaning), and a fit result
(:func:`viscoforce.schema.make_fit_result`, what ``fit --out`` writes) adds its best-fit curve,
drawn over its own (usually denser) ``omega`` grid, and a box of its parameters ± stderr.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from viscoforce._typing import FloatArray
from viscoforce._validation import describe_value
from viscoforce.exceptions import ParameterError, SchemaError
from viscoforce.plotting._common import (
    PlotHandle,
    _new_or_given_axes,
    _require_choice,
    _require_flag,
    _require_text,
)
from viscoforce.plotting._parameter_text import _parameter_text
from viscoforce.schema import validate_fit_result, validate_spectrum

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes

FrequencyUnit = Literal["auto", "rad/s", "Hz"]
Magnitude = Literal["stiffness", "amplitude"]
_MAGNITUDE_LABELS = {"stiffness": "stiffness $|F_1|/\\eta$ [N/m]",
                     "amplitude": "relative amplitude $a = |F_1|/\\bar F$"}
#: Style of the ring drawn around flagged points (``quality`` != 0).
FLAGGED_STYLE: dict[str, Any] = {"linestyle": "none", "marker": "o", "markersize": 9,
                                 "markerfacecolor": "none", "markeredgecolor": "tab:red",
                                 "markeredgewidth": 1.5}
#: Style of the best-fit curve.
FIT_STYLE: dict[str, Any] = {"color": "k", "linewidth": 1.5}
#: Points of one curve above which error bars are drawn as one NaN-broken line and legends
#: are placed in a fixed corner: matplotlib draws an error bar as one path per point and
#: places a ``loc="best"`` legend by testing every point (a 1e6-point spectrum took 206 s).
DENSE_POINTS = 2000

def _spectrum_items(spectra: Any, magnitude: str) -> list[tuple[str, xr.Dataset]]:
    """(label, spectrum) pairs, each validated (:func:`viscoforce.schema.validate_spectrum`)."""
    import xarray as xr

    if isinstance(spectra, xr.Dataset):  # itself a Mapping, so test it first
        pairs: list[tuple[str | None, Any]] = [(None, spectra)]
    elif isinstance(spectra, Mapping):
        pairs = [(str(label), ds) for label, ds in spectra.items()]
    elif isinstance(spectra, Sequence) and not isinstance(spectra, str | bytes):
        pairs = [(None, ds) for ds in spectra]
    else:
        raise ParameterError(
            "spectra must be a spectrum Dataset, a mapping label -> Dataset or a sequence of "
            f"Datasets, got {type(spectra).__name__}")
    if not pairs:
        raise ParameterError("spectra must contain at least one spectrum")
    items = []
    for i, (given, ds) in enumerate(pairs):
        label = given if given is not None else (
            "spectrum" if isinstance(spectra, xr.Dataset) else f"spectrum {i + 1}")
        if isinstance(ds, xr.Dataset):
            label = given if given is not None else str(ds.attrs.get("method", label))
            for name in ("omega", magnitude, "phase"):
                if name not in ds.variables:
                    raise SchemaError(f"bode_plot: spectrum {label!r} has no '{name}'")
        try:
            validate_spectrum(ds, require=("omega", magnitude, "phase"))
        except SchemaError as exc:
            raise SchemaError(f"bode_plot: spectrum {label!r}: {exc}") from None
        items.append((label, ds))
    return items


def _selection(select: Any) -> dict[str, int]:
    if select is None:
        return {}
    if not isinstance(select, Mapping):
        raise ParameterError(
            f"select must be a mapping dim -> index (e.g. {{'curve': 0}}) or None, got "
            f"{describe_value(select)}")
    out = {}
    for dim, index in select.items():
        if not isinstance(dim, str):
            raise ParameterError(f"select keys must be dim names (strings), got {dim!r}")
        if dim == "omega":
            raise ParameterError("select must not pick along 'omega' (the frequency axis)")
        if isinstance(index, bool) or not isinstance(index, int | np.integer):
            raise ParameterError(
                f"select[{dim!r}] must be an integer index, got {describe_value(index)}")
        out[dim] = int(index)
    return out


def _pick(ds: xr.Dataset, picks: Mapping[str, int], what: str, extra: Sequence[str]) -> xr.Dataset:
    """``ds.isel(picks)`` over the dims it has; raise if extra dims other than ``omega`` remain."""
    here = {d: i for d, i in picks.items() if d in ds.dims}
    for dim, index in here.items():
        size = ds.sizes[dim]
        if not -size <= index < size:
            raise ParameterError(
                f"select[{dim!r}] = {index} is out of range: {what} has {size} entries along "
                f"{dim!r}")
    ds = ds.isel(here) if here else ds
    left = [d for d in extra if d not in here]
    if left:
        raise ParameterError(
            f"bode_plot draws one spectrum per entry; {what} also spans {left}: select one, "
            f"e.g. ds.isel({left[0]}=0) or select={{{left[0]!r}: 0}}")
    return ds


def _fit_result(fit: Any, magnitude: str) -> xr.Dataset | None:
    """The fit result, validated, with its best-fit spectrum (``fit_stiffness``, ``fit_phase``)."""
    import xarray as xr

    if fit is None:
        return None
    if not isinstance(fit, xr.Dataset):
        raise ParameterError(
            "fit must be a fit-result Dataset (viscoforce.schema.make_fit_result, what "
            f"'fit --out' writes) or None, got {describe_value(fit)}")
    try:
        validate_fit_result(fit)
    except SchemaError as exc:
        raise SchemaError(f"bode_plot: fit: {exc}") from None
    missing = [n for n in ("fit_stiffness", "fit_phase") if n not in fit.variables]
    if missing:
        raise ParameterError(
            f"fit has no best-fit spectrum: it lacks {missing} over 'omega' (a relaxation or "
            "step fit holds fit_force over time; refit the spectrum, or pass fit=None)")
    if magnitude != "stiffness":
        raise ParameterError(
            f"fit draws the best-fit stiffness: use magnitude='stiffness' with fit=, got "
            f"magnitude={magnitude!r}")
    return fit


def _flag_meanings(quality: xr.DataArray, codes: FloatArray) -> str:
    """The CF ``flag_meanings`` of the ``codes`` present, spaces for underscores."""
    values = [int(v) for v in np.atleast_1d(quality.attrs.get("flag_values", []))]
    meanings = str(quality.attrs.get("flag_meanings", "")).split()
    table = dict(zip(values, meanings, strict=False))
    return ", ".join(table.get(int(c), f"code {int(c)}").replace("_", " ")
                     for c in np.unique(codes))


def _error_bars(ax: Axes, x: FloatArray, y: FloatArray, yerr: FloatArray, **style: Any) -> Artist:
    """``ax.errorbar(x, y, yerr, capsize=2, **style)``, or one path for many points.

    Beyond :data:`DENSE_POINTS` points: the data as one line and the bars as ONE line broken by
    NaN (x, y−e; x, y+e; NaN), where an error-bar container is one path per point. Returns what
    the legend shows.
    """
    if x.size <= DENSE_POINTS:
        return ax.errorbar(x, y, yerr=yerr, capsize=2, **style)
    (line,) = ax.plot(x, y, **style)
    bars = np.full((x.size, 3, 2), np.nan)
    bars[:, :2, 0] = x[:, None]
    bars[:, 0, 1], bars[:, 1, 1] = y - yerr, y + yerr
    ax.plot(bars[..., 0].reshape(-1), bars[..., 1].reshape(-1), color=line.get_color(),
            alpha=0.35, linewidth=0.8, label="_stderr")
    return line


def _draw_spectrum(axes: tuple[Axes, Axes], ds: xr.Dataset, label: str, magnitude: str,
                   scale: float, markers: bool | None, flag_label: str) -> list[Artist]:
    """Magnitude and phase of one spectrum (error bars where stderr is stored), then its flags."""
    drawn: list[Artist] = []
    x = np.asarray(ds["omega"].values, dtype=float) * scale
    show_markers = markers if markers is not None else x.size <= 30
    style = {"marker": "o", "markersize": 4} if show_markers else {}
    for panel, name in ((axes[0], magnitude), (axes[1], "phase")):
        y = np.asarray(ds[name].values, dtype=float)
        err = ds.get(f"{name}_stderr")
        if err is not None:
            yerr = np.broadcast_to(np.asarray(err.values, dtype=float), y.shape)
            art = _error_bars(panel, x, y, yerr, label=label,
                              linestyle="none" if show_markers else "-", **style)
        else:
            (art,) = panel.plot(x, y, label=label, **style)
        drawn.append(art)
    if "quality" in ds.variables:
        codes = np.broadcast_to(np.asarray(ds["quality"].values), x.shape)
        flagged = codes != 0
        if flagged.any():
            text = f"{flag_label}flagged: {_flag_meanings(ds['quality'], codes[flagged])}"
            for panel, name in ((axes[0], magnitude), (axes[1], "phase")):
                y = np.asarray(ds[name].values, dtype=float)
                (ring,) = panel.plot(x[flagged], y[flagged], label=text, **FLAGGED_STYLE)
                drawn.append(ring)
    return drawn


def _parameter_box(ax: Axes, fit: xr.Dataset, handles: Any = ()) -> Artist:
    """The parameter text as a legend's title: placed where it covers the least data.

    ``handles``: lines listed under the text (default none: an empty legend). Returns the
    title (a Text); an existing legend of ``ax`` stays.
    """
    existing = ax.get_legend()
    box = ax.legend(handles=list(handles), title=_parameter_text(fit), loc=_legend_loc(ax),
                    fontsize="small", title_fontsize="small", framealpha=0.85, alignment="left")
    box.get_title().set_family("monospace")
    if existing is not None:
        ax.add_artist(existing)
    return box.get_title()


def _draw_fit(axes: tuple[Axes, Axes], fit: xr.Dataset, scale: float) -> list[Artist]:
    """The best-fit stiffness and phase over the fit's omega grid, then the parameter box."""
    x = np.asarray(fit["omega"].values, dtype=float) * scale
    label = f"fit ({' '.join(str(fit.attrs[k]) for k in ('model', 'candidate') if k in fit.attrs)})"
    drawn: list[Artist] = []
    for panel, name in ((axes[0], "fit_stiffness"), (axes[1], "fit_phase")):
        (line,) = panel.plot(x, np.asarray(fit[name].values, dtype=float), label=label,
                             **FIT_STYLE)
        drawn.append(line)
    drawn.append(_parameter_box(axes[1], fit))
    return drawn


def _draw_residuals(ax: Axes, ds: xr.Dataset, fit: xr.Dataset, scale: float) -> list[Artist]:
    """Residuals of Re and Im k* at the unflagged data points (÷ stderr, or ÷ |k*_fit|)."""
    omega = np.asarray(ds["omega"].values, dtype=float)
    k = np.asarray(ds["stiffness"].values, dtype=float) * np.exp(
        1j * np.radians(np.asarray(ds["phase"].values, dtype=float)))
    w_fit = np.asarray(fit["omega"].values, dtype=float)
    log_s = np.interp(np.log(omega), np.log(w_fit),
                      np.log(np.asarray(fit["fit_stiffness"].values, dtype=float)))
    phase = np.interp(np.log(omega), np.log(w_fit),
                      np.unwrap(np.radians(np.asarray(fit["fit_phase"].values, dtype=float))))
    k_fit = np.exp(log_s) * np.exp(1j * phase)
    keep = np.isfinite(k)
    if "quality" in ds.variables:
        keep &= np.broadcast_to(np.asarray(ds["quality"].values), keep.shape) == 0
    diff = k - k_fit
    if "stiffness_stderr" in ds.variables and "phase_stderr" in ds.variables:
        s_err = np.broadcast_to(np.asarray(ds["stiffness_stderr"].values, dtype=float), k.shape)
        p_err = np.broadcast_to(np.radians(np.asarray(ds["phase_stderr"].values, dtype=float)),
                                k.shape)
        stiff, chi = np.abs(k), np.angle(k)
        sig_re = np.hypot(np.cos(chi) * s_err, stiff * np.sin(chi) * p_err)
        sig_im = np.hypot(np.sin(chi) * s_err, stiff * np.cos(chi) * p_err)
        with np.errstate(divide="ignore", invalid="ignore"):
            r_re, r_im = diff.real / sig_re, diff.imag / sig_im
        label = "residual / stderr"
    else:
        r_re, r_im = diff.real / np.abs(k_fit), diff.imag / np.abs(k_fit)
        label = "residual / |k*$_{fit}$|"
    x = omega[keep] * scale
    (re,) = ax.plot(x, r_re[keep], "o", ms=4, label="Re k*")
    (im,) = ax.plot(x, r_im[keep], "s", ms=4, mfc="none", label="Im k*")
    ax.axhline(0.0, color="0.3", lw=0.8)
    ax.set_ylabel(label)
    ax.legend(fontsize="small", ncol=2, loc=_legend_loc(ax))
    return [re, im]


def _draw_modulus(ax: Axes, ds: xr.Dataset, scale: float) -> list[Artist]:
    """Young's storage and loss moduli E′, E″ [Pa] with error bars, unflagged points."""
    x = np.asarray(ds["omega"].values, dtype=float) * scale
    keep = np.ones(x.shape, dtype=bool)
    if "quality" in ds.variables:
        keep &= np.broadcast_to(np.asarray(ds["quality"].values), x.shape) == 0
    drawn: list[Artist] = []
    for name, label, face in (("E_storage", "E′ (storage)", None), ("E_loss", "E″ (loss)", "none")):
        y = np.asarray(ds[name].values, dtype=float)
        err = ds.get(f"{name}_stderr")
        yerr = None if err is None else np.broadcast_to(np.asarray(err.values, float), y.shape)[keep]
        art = (ax.errorbar(x[keep], y[keep], marker="o", linestyle="none", mfc=face,
                           label=label) if yerr is None else
               _error_bars(ax, x[keep], y[keep], yerr, marker="o", linestyle="none", mfc=face,
                           label=label))
        drawn.append(art)
    ax.set_yscale("log")
    nu = ds.attrs.get("poisson", 0.5)
    ax.set_ylabel(f"Young's modulus [Pa] (ν = {float(nu):g})")
    ax.legend(fontsize="small", title=str(ds.attrs.get("tip", "")), title_fontsize="small",
              loc=_legend_loc(ax))
    return drawn


def _legend_loc(ax: Axes, dense: str = "upper left") -> str:
    """``"best"``, or ``dense`` where ``ax`` holds more than :data:`DENSE_POINTS` points per line."""
    counts = [np.size(line.get_xdata()) for line in ax.get_lines()]
    return dense if counts and max(counts) > DENSE_POINTS else "best"


def _on(artist: Artist, ax: Axes) -> bool:
    """Whether ``artist`` (a line, text or error-bar container) was drawn on ``ax``."""
    from matplotlib.container import Container

    first = artist[0] if isinstance(artist, Container) else artist
    return first.axes is ax and not str(artist.get_label()).startswith("_")


def bode_plot(spectra: xr.Dataset | Mapping[str, xr.Dataset] | Sequence[xr.Dataset], *,
              fit: xr.Dataset | None = None, ax: Sequence[Axes] | None = None,
              magnitude: Magnitude = "stiffness", frequency_unit: FrequencyUnit = "auto",
              markers: bool | None = None, select: Mapping[str, int] | None = None,
              title: str | None = None, residuals: bool = False,
              modulus: bool = False) -> PlotHandle:
    """Bode plot: magnitude and phase χ against a log frequency axis (data, methods, fits).

    Parameters
    ----------
    spectra : Dataset, mapping label → Dataset, or sequence of Datasets
        Spectra over ``omega`` [rad/s] with ``stiffness`` or ``amplitude`` and ``phase`` [degree]
        (:mod:`viscoforce.schema`). Several are overlaid; a sequence is labelled by each
        dataset's ``method`` attribute. ``<name>_stderr`` variables become error bars; points
        whose ``quality`` flag is non-zero are ringed in red, labelled with the flag meanings.
    fit : Dataset, optional
        A fit result (:func:`viscoforce.schema.make_fit_result`, ``fit --out``) holding the
        best-fit ``fit_stiffness`` [N/m] and ``fit_phase`` [degree] over its own ``omega``
        grid: drawn as a black line, with a box of the parameters (value ± stderr in a unit
        suited to the value) and the reduced chi-square. Needs ``magnitude="stiffness"``.
    ax : pair of Axes, optional
        (magnitude, phase) axes to draw on; default a new two-row figure.
    magnitude : {"stiffness", "amplitude"}
        Upper panel: |F1|/η [N/m] or a = |F1|/F̄. Its axis is logarithmic when every value
        drawn there is positive, else linear.
    frequency_unit : {"auto", "rad/s", "Hz"}
        Display unit of the frequency axis (ω stays in rad/s inside). "auto" (default): Hz
        when every spectrum is measured (its ``source`` attribute names an instrument, not
        ``"simulation"``), as the instrument ran; rad/s for simulated spectra, as the theory.
    markers : bool, optional
        Draw markers (default: with a fit, or for spectra with ≤ 30 points, as measured data
        usually are).
    select : mapping of str to int, optional
        Index along each extra dim (e.g. ``{"curve": 3}``) picked from every spectrum, and from
        the fit result, that has the dim. Spectra (and a fit over a map) with extra dims
        besides ``omega`` need it.
    title : str, optional
        Figure title.
    modulus : bool
        One spectrum carrying ``E_storage``, ``E_loss`` (:func:`viscoforce.experiments.moduli.
        add_complex_modulus`, ``load --tip``): a panel of Young's storage and loss moduli [Pa].
    residuals : bool
        With ``fit`` and one spectrum: a third panel of the residuals of the real and
        imaginary parts of k*, in units of their stderr (the χ² terms), or relative to |k*_fit|
        when the data carry no stderr.

    Returns
    -------
    PlotHandle
        ``axes = (magnitude_axes, phase_axes)`` (plus the residual axes with ``residuals``);
        ``lines``: per spectrum its magnitude and phase artists (an ``ErrorbarContainer`` where
        stderr is stored, else a line), then its flagged-point rings (magnitude, phase) if
        any; then, with ``fit``, the best-fit magnitude and phase lines and the parameter text
        box (and the Re/Im residual markers with ``residuals``).

    Raises
    ------
    ParameterError
        Bad option or axes; ``spectra`` neither a Dataset, a mapping nor a sequence; a spectrum
        or fit with extra dims besides ``omega`` that ``select`` does not pick, a ``select``
        index out of range or naming a dim nothing has; ``fit`` not a Dataset, without a
        best-fit spectrum, or with ``magnitude="amplitude"``.
    SchemaError
        An entry is not a spectrum (:func:`viscoforce.schema.validate_spectrum`): not a Dataset,
        no magnitude or phase, wrong units or dims; ``fit`` is not a valid fit result
        (:func:`viscoforce.schema.validate_fit_result`).
    """
    import matplotlib.pyplot as plt
    from matplotlib.axes import Axes

    _require_choice("magnitude", magnitude, tuple(_MAGNITUDE_LABELS))
    _require_choice("frequency_unit", frequency_unit, ("auto", "rad/s", "Hz"))
    markers = _require_flag("markers", markers, allow_none=True)
    title = _require_text("title", title)
    picks = _selection(select)
    if ax is not None and not (isinstance(ax, Sequence) and not isinstance(ax, str | bytes)
                               and len(ax) == 2 and all(isinstance(a, Axes) for a in ax)):
        raise ParameterError(
            f"ax must be None or a pair of matplotlib Axes (magnitude axes, phase axes), got "
            f"{describe_value(ax)}")
    items = _spectrum_items(spectra, magnitude)
    fit_ds = _fit_result(fit, magnitude)
    known = {str(d) for _, ds in items for d in ds.dims}
    known |= set() if fit_ds is None else {str(d) for d in fit_ds["success"].dims}
    unknown = sorted(set(picks) - known)
    if unknown:
        raise ParameterError(f"select names dims {unknown} that neither the spectra nor the "
                             f"fit have (they have {sorted(known - {'omega'})})")
    items = [(label, _pick(ds, picks, f"spectrum {label!r}",
                           [str(d) for d in ds[magnitude].dims if d != "omega"]))
             for label, ds in items]
    if fit_ds is not None:
        fit_ds = _pick(fit_ds, picks, "the fit result", [str(d) for d in fit_ds["success"].dims])
        if markers is None:
            markers = True
        if len(items) == 1 and items[0][0] == "spectrum":
            items = [("data", items[0][1])]
    residuals = _require_flag("residuals", residuals)
    if residuals and (fit_ds is None or len(items) != 1 or ax is not None):
        raise ParameterError("residuals=True needs a fit, exactly one spectrum and no ax")
    modulus = _require_flag("modulus", modulus)
    if modulus and (len(items) != 1 or ax is not None or "E_storage" not in items[0][1]):
        raise ParameterError("modulus=True needs exactly one spectrum with E_storage and E_loss "
                             "(load --tip, or viscoforce.experiments.moduli.add_complex_modulus) "
                             "and no ax")
    if ax is None:
        ratios = [3, 3] + [2] * residuals + [3] * modulus
        figure, axes = plt.subplots(len(ratios), 1, sharex=True,
                                    figsize=(6.4, 5.6 + 1.8 * residuals + 2.6 * modulus),
                                    layout="constrained", gridspec_kw={"height_ratios": ratios})
    else:
        axes = tuple(ax)
        figure = axes[0].figure
    if frequency_unit == "auto":
        measured = all(str(ds.attrs.get("source", "simulation")) != "simulation"
                       for _, ds in items)
        frequency_unit = "Hz" if measured else "rad/s"
    scale = 1.0 if frequency_unit == "rad/s" else 1.0 / (2.0 * np.pi)
    drawn: list[Artist] = []
    for label, ds in items:
        drawn += _draw_spectrum((axes[0], axes[1]), ds, label, magnitude, scale, markers,
                                f"{label} " if len(items) > 1 else "")
    if fit_ds is not None:
        drawn += _draw_fit((axes[0], axes[1]), fit_ds, scale)
    if residuals:
        drawn += _draw_residuals(axes[2], items[0][1], fit_ds, scale)
    if modulus:
        drawn += _draw_modulus(axes[-1], items[0][1], scale)
    shown = [np.asarray(ds[magnitude].values, dtype=float) for _, ds in items]
    if fit_ds is not None:
        shown.append(np.asarray(fit_ds["fit_stiffness"].values, dtype=float))
    values = np.concatenate([v[np.isfinite(v)] for v in shown])
    axes[0].set_xscale("log")
    if values.size and np.all(values > 0):
        axes[0].set_yscale("log")
    axes[0].set_ylabel(_MAGNITUDE_LABELS[magnitude])
    axes[1].set_ylabel("phase $\\chi$ [deg] (force leads compression)")
    sym = "$\\omega$ [rad/s]" if frequency_unit == "rad/s" else "$f = \\omega/2\\pi$ [Hz]"
    axes[-1].set_xlabel(f"frequency {sym}")
    axes[0].legend(handles=[a for a in drawn if _on(a, axes[0])], fontsize="small",
                   loc=_legend_loc(axes[0]))
    for a in axes:
        a.grid(True, which="both", alpha=0.3)
    if title:
        figure.suptitle(title)
    return PlotHandle(figure, tuple(axes), tuple(drawn))


def fit_curve_plot(fit: xr.Dataset, *, data: tuple[Any, Any] | None = None,
                   ax: Axes | None = None, title: str | None = None) -> PlotHandle:
    """A force-curve fit: data and best fit against time or tip position.

    relaxation, step: force vs time; hertz: force vs tip position, the contact point marked;
    creep: tip position vs time.

    Parameters
    ----------
    fit : xarray.Dataset
        Fit result with ``fit_force`` over ``time``, ``fit_approach_force`` over
        ``tip_position`` or ``fit_tip_position`` over ``time`` (:mod:`viscoforce.schema.fit`).
    data : (x, y), optional
        The fitted samples on the fit's axes: time [s] or tip position [m], and force [N] or
        tip position [m].
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; default a new figure.
    title : str, optional
        Axes title.

    Returns
    -------
    PlotHandle
        Figure, axes (with ``data`` and no ``ax``: the fit and, below, the residual data − fit)
        and the data line, the fit line, the parameter box (and the residual points).
    """
    import xarray as xr

    if not isinstance(fit, xr.Dataset):
        raise ParameterError(f"fit must be a fit-result Dataset, got {type(fit).__name__}")
    validate_fit_result(fit)
    axes_of = {"fit_force": "time", "fit_approach_force": "tip_position",
               "fit_tip_position": "time"}
    y_name = next((n for n in axes_of if n in fit.variables), None)
    if y_name is None:
        raise ParameterError("fit has no best-fit curve ('fit_force' or 'fit_tip_position' over "
                             "'time', 'fit_approach_force' over 'tip_position'): it is not a "
                             "relaxation, step, hertz or creep fit")
    x_name = axes_of[y_name]
    residual_axes = None
    if ax is None and data is not None:  # data, fit and the residual below
        import matplotlib.pyplot as plt

        figure, (axes, residual_axes) = plt.subplots(
            2, 1, figsize=(6.4, 5.2), sharex=True, layout="constrained",
            gridspec_kw={"height_ratios": (3, 1)})
    else:
        figure, axes = _new_or_given_axes(ax, (6.4, 4.2))
    x = np.asarray(fit[x_name].values, dtype=float)
    if x_name == "time":
        scale, unit = (1e3, "ms") if np.ptp(x) < 1.0 else (1.0, "s")
        x_label = f"time from the start of the segment [{unit}]"
        shift = 0.0
    else:  # µm from the contact point
        scale, shift = 1e6, float(fit["contact_point"]) if "contact_point" in fit else 0.0
        x_label = "tip position toward the sample from the contact point [µm]"
    y_scale, y_label = ((1e9, "tip position toward the sample [nm]") if y_name ==
                        "fit_tip_position" else (1e9, "force [nN]"))
    drawn: list[Artist] = []
    if data is not None:
        dx, dy = (np.asarray(a, dtype=float) for a in data)
        (points,) = axes.plot((dx - shift) * scale, dy * y_scale, ".", ms=2, color="0.45",
                              label="data")
        drawn.append(points)
    (line,) = axes.plot((x - shift) * scale, np.asarray(fit[y_name].values) * y_scale,
                        label=f"fit ({fit.attrs['model']})", **FIT_STYLE)
    drawn.append(line)
    if x_name == "tip_position":
        drawn.append(axes.axvline(0.0, color="0.6", lw=0.8, ls=":", label="contact point"))
    axes.set_ylabel(y_label)
    # one box: the lines' legend under the parameters (Young's first), placed off the data
    drawn.append(_parameter_box(axes, fit, handles=drawn))
    if title:
        axes.set_title(title)
    if residual_axes is None:
        axes.set_xlabel(x_label)
        return PlotHandle(figure, (axes,), tuple(drawn))
    order = np.argsort(x)
    fitted = np.interp(dx, x[order], np.asarray(fit[y_name].values, dtype=float)[order])
    (res,) = residual_axes.plot((dx - shift) * scale, (dy - fitted) * y_scale, ".", ms=2,
                                color="0.45")
    residual_axes.axhline(0.0, color="0.3", lw=0.8)
    residual_axes.set_ylabel(f"data − fit [{y_label.rsplit('[', 1)[-1]}")
    residual_axes.set_xlabel(x_label)
    drawn.append(res)
    return PlotHandle(figure, (axes, residual_axes), tuple(drawn))
