"""The segment a curve model fits, cut from a curves dataset (:mod:`viscoforce.schema.curves`).

``relaxation`` fits the force on a hold (the pause after the first approach that is not a
constant-force pause; F relative to the file's free-cantilever baseline where it has one),
``creep`` the tip position on a constant-force pause, ``hertz`` the approach (force over the tip
position), ``ting`` approach and retract (:func:`viscoforce.fitting.ting_model.ting_data`);
``segment=N`` picks the curve's N-th segment (from 0, in the file's order). Each model's entry
(:mod:`viscoforce.fitting.models`) names its function here as its ``cut``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.fitting.data import FitData
from viscoforce.schema import validate_curves
from viscoforce.schema.curves import curve_samples

__all__ = ["approach_data", "creep_data", "hold_data", "segment_runs"]


class _Curve:
    """One curve of a curves dataset, as :func:`~viscoforce.schema.select_curve` cuts it.

    ``one[name].values`` is a variable's values over the curve's samples (its entry, for a
    per-curve variable; whole otherwise), sliced from the dataset on first use: no selection of
    the whole dataset (which indexes every variable and costs more than a Hertz fit's scan).
    ``variables`` and ``attrs`` are the dataset's. The dataset is validated once, here: its
    structure, and the samples of this curve (:func:`~viscoforce.schema.validate_curves`).
    """

    def __init__(self, curves: xr.Dataset, curve: int):
        validate_curves(curves, curve=curve)  # the structure, and this curve's samples
        start, stop, index = curve_samples(curves, curve)
        self._cut = {"sample": slice(start, stop), "curve": slice(index, index + 1)}
        self.variables, self.attrs = curves.variables, curves.attrs
        self._read: dict[str, Any] = {}

    def __getitem__(self, name: str) -> Any:
        if name not in self._read:
            var = self.variables[name]
            key = {d: self._cut[d] for d in var.dims if d in self._cut}
            held = getattr(var, "_data", None)  # in memory: numpy's slice (a view, no copy)
            if isinstance(held, np.ndarray) and held.ndim == len(var.dims):
                self._read[name] = held[tuple(key.get(d, slice(None)) for d in var.dims)]
            else:  # lazily read: xarray reads the slice only
                self._read[name] = (var[key] if key else var).values
        return _Values(self._read[name])


class _Values:
    """``.values`` of one variable of a :class:`_Curve`."""

    __slots__ = ("values",)

    def __init__(self, values: np.ndarray):
        self.values = values


def segment_runs(curve: xr.Dataset) -> list[tuple[int, int, str]]:
    """(start, stop, name) of the consecutive segments of a one-curve dataset, in file order."""
    seg = np.asarray(curve["segment"].values)
    names = np.asarray(curve["segment_name"].values).astype(str)
    if seg.size == 0:
        return []
    edges = np.flatnonzero(np.diff(seg)) + 1
    starts = np.concatenate(([0], edges))
    stops = np.concatenate((edges, [seg.size]))
    return [(int(a), int(b), str(names[seg[a]])) for a, b in zip(starts, stops, strict=True)]


def _segment_types(one: Any) -> np.ndarray | None:
    if "segment_type" not in one.variables:
        return None
    return np.asarray(one["segment_type"].values).astype(str)


def _chosen_run(one: Any, segment: int | None, model: str
                ) -> tuple[int, int, str]:
    """The (start, stop, name) run a curve model fits: ``segment`` or the model's default.

    relaxation: the first pause after the approach that is not a constant-force pause; creep:
    the first constant-force pause after the approach (any pause when the file does not say);
    hertz: the first approach.
    """
    runs = segment_runs(one)
    if segment is not None:
        if isinstance(segment, bool) or not isinstance(segment, int | np.integer) or not (
                0 <= segment < len(runs)):
            raise ParameterError(f"segment must be an integer in [0, {len(runs) - 1}] (the "
                                 f"curve has {len(runs)} segments: "
                                 f"{', '.join(r[2] for r in runs)}), got {segment!r}")
        return runs[int(segment)]
    listing = ", ".join(r[2] for r in runs) or "none"
    if model == "hertz":
        approaches = [r for r in runs if r[2] == "approach"]
        if not approaches:
            raise ParameterError(f"the hertz model fits the approach segment; this curve's "
                                 f"segments are {listing}: give --segment N")
        return approaches[0]
    after = [i for i, r in enumerate(runs) if r[2] == "approach"]
    pauses = [r for r in runs[after[0] + 1:] if r[2] == "pause"] if after else []
    types = _segment_types(one)
    seg = np.asarray(one["segment"].values)

    def kind(run: tuple[int, int, str]) -> str:
        return "" if types is None else types[int(seg[run[0]])].lower()

    what = {"relaxation": "hold (pause) segment after the approach",
            "creep": "constant-force pause after the approach"}[model]
    # the file's own label decides where it has one: a constant-force pause creeps, a
    # constant-height pause relaxes
    refuse, other = (("constant-height", "relaxation (a constant-height pause: the force "
                      "relaxes)") if model == "creep" else
                     ("constant-force", "creep (a constant-force pause: the tip position "
                      "creeps)"))
    wanted = [r for r in pauses if refuse not in kind(r)]
    if not wanted:
        held = [f"{r[2]} ({kind(r)})" for r in pauses if kind(r)]
        hint = f"; its pause is {', '.join(held)}: fit it with --model {other}" if held else ""
        raise ParameterError(f"the {model} model fits a {what}; this curve's segments are "
                             f"{listing}{hint}; or give --segment N")
    return wanted[0]


def _segment_arrays(one: Any, run: tuple[int, int, str], x_name: str, y_name: str,
                    what: str) -> tuple[np.ndarray, np.ndarray]:
    start, stop, _ = run
    x = np.asarray(one[x_name].values[start:stop], dtype=float)
    y = np.asarray(one[y_name].values[start:stop], dtype=float)
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 4:
        note = str(one.attrs.get(f"{x_name}_channel", ""))  # the reader's why, if it says
        missing = "" if np.isfinite(one[x_name].values[start:stop]).any() else (
            f" ({note})" if note.startswith("unavailable") else
            f" (the file gives no {x_name.replace('_', ' ')})")
        raise ParameterError(f"the {what} segment has {int(ok.sum())} finite samples of "
                             f"{x_name} and {y_name}; need >= 4{missing}")
    return x[ok], y[ok]


def _source(curves: xr.Dataset, one: Any, run: tuple[int, int, str], n: int,
            curve: int) -> dict[str, Any]:
    source: dict[str, Any] = {"data_kind": "curves", "data_points": int(n), "curve": int(curve),
                              "segment_start": float(one["time"].values[run[0]])}
    types = _segment_types(one)
    if types is not None:
        source["segment_type"] = str(types[int(one["segment"].values[run[0]])])
    if "source" in curves.attrs:
        source["data_source"] = str(curves.attrs["source"])
    return source


def hold_data(curves: xr.Dataset, *, curve: int = 0, segment: int | None = None) -> FitData:
    """T [s] from the start of the hold and F [N] on it, of curve ``curve``.

    Raises
    ------
    ParameterError
        No pause after an approach (or ``segment`` out of range), or too few finite samples.
    """
    one = _Curve(curves, curve)
    chosen = _chosen_run(one, segment, "relaxation")
    t, f = _segment_arrays(one, chosen, "time", "force", "hold")
    source = _source(curves, one, chosen, t.size, curve)
    baseline = _free_baseline(one, int(one["segment"].values[chosen[0]]))
    if baseline is not None:
        f = f - baseline
        source.update(force_baseline=baseline, force_reference=(
            "F relative to the free-cantilever baseline recorded in the file for this segment "
            "(segment_baseline): F_inf and dF_i are forces on the sample"))
    else:
        source["force_reference"] = ("force as recorded: the file gives no free-cantilever "
                                     "baseline, so F_inf includes the cantilever's offset")
    return FitData(t - t[0], f, None, source)


def creep_data(curves: xr.Dataset, *, curve: int = 0, segment: int | None = None) -> FitData:
    """T [s] from the start of the constant-force pause and the tip position [m] on it.

    The tip position grows toward the sample (``tip_position`` of the curves schema: the
    calibrated sensor height where the file has one, up to an offset), so a creeping sample
    gives dz_i < 0 in z(t) = z_inf + Σ dz_i e^{−t/τ_i}.

    Raises
    ------
    ParameterError
        No constant-force pause after the approach (or ``segment`` out of range), or too few
        finite samples.
    """
    one = _Curve(curves, curve)
    chosen = _chosen_run(one, segment, "creep")
    t, z = _segment_arrays(one, chosen, "time", "tip_position", "creep")
    source = _source(curves, one, chosen, t.size, curve)
    f = np.asarray(one["force"].values[chosen[0]:chosen[1]], dtype=float)
    baseline = _free_baseline(one, int(one["segment"].values[chosen[0]]))
    held = float(np.nanmedian(f)) - (baseline or 0.0)
    source.update(creep_force=held, creep_force_spread=float(np.nanstd(f)),
                  tip_position_reference=str(curves.attrs.get(
                      "tip_position_convention", "tip position toward the sample")))
    return FitData(t - t[0], z, None, source)


def approach_data(curves: xr.Dataset, *, curve: int = 0, segment: int | None = None) -> FitData:
    """Tip position z [m] (toward the sample) and force F [N] over the approach of a curve.

    The force is as recorded (the hertz model fits its baseline and tilt).

    Raises
    ------
    ParameterError
        No approach segment (or ``segment`` out of range), or too few finite samples (files
        without a height channel have no tip position).
    """
    one = _Curve(curves, curve)
    chosen = _chosen_run(one, segment, "hertz")
    z, f = _segment_arrays(one, chosen, "tip_position", "force", "approach")
    source = _source(curves, one, chosen, z.size, curve)
    return FitData(z, f, None, source)


def _free_baseline(one: Any, row: int) -> float | None:
    """The file's free-cantilever force baseline [N] of segment-table row ``row``, if any."""
    if "segment_baseline" not in one.variables:
        return None
    values = np.asarray(one["segment_baseline"].values, dtype=float).reshape(-1)
    if not 0 <= row < values.size or not np.isfinite(values[row]):
        return None
    return float(values[row])
