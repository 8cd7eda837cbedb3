"""Force-curve data for the ``relaxation`` and ``step`` models.

``relaxation`` fits the force on a hold (its τ_i are force-relaxation times at fixed position,
not creep times; F relative to the file's free-cantilever baseline where it has one): by
default the pause segment that follows the first approach of a curve (``segment=N`` picks the
curve's N-th segment, counted from 0 in the file's order), with t from the start of that
segment. ``step`` fits a trajectory (time, position, force:
what ``simulate`` writes): the position history is the drive of the exact model.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError
from viscoforce.fitting.fit import (
    FitData,
    add_derived_moduli,
    fit_data,
    validity_note,
    warn_fit,
)
from viscoforce.schema import select_curve, validate_curves, validate_trajectory


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


def hold_data(curves: xr.Dataset, *, curve: int = 0, segment: int | None = None) -> FitData:
    """T [s] from the start of the hold and F [N] on it, of curve ``curve``.

    Raises
    ------
    ParameterError
        No pause after an approach (or ``segment`` out of range), or too few finite samples.
    """
    one = select_curve(validate_curves(curves), curve)
    runs = segment_runs(one)
    if segment is not None:
        if isinstance(segment, bool) or not isinstance(segment, int | np.integer) or not (
                0 <= segment < len(runs)):
            raise ParameterError(f"segment must be an integer in [0, {len(runs) - 1}] (the "
                                 f"curve has {len(runs)} segments: "
                                 f"{', '.join(r[2] for r in runs)}), got {segment!r}")
        chosen = runs[int(segment)]
    else:
        after = [i for i, r in enumerate(runs) if r[2] == "approach"]
        pauses = [r for r in runs[after[0] + 1:] if r[2] == "pause"] if after else []
        if not pauses:
            raise ParameterError(
                "the relaxation model fits a hold (pause) segment after the approach; this "
                f"curve's segments are {', '.join(r[2] for r in runs) or 'none'}: give "
                "--segment N")
        chosen = pauses[0]
    start, stop, _ = chosen
    t = np.asarray(one["time"].values[start:stop], dtype=float)
    f = np.asarray(one["force"].values[start:stop], dtype=float)
    ok = np.isfinite(t) & np.isfinite(f)
    if ok.sum() < 4:
        raise ParameterError(f"the hold segment has {int(ok.sum())} finite samples; need >= 4")
    t, f = t[ok], f[ok]
    source = {"data_kind": "curves", "data_points": int(t.size), "segment_start": float(t[0]),
              "curve": int(curve)}
    baseline = _free_baseline(one, int(one["segment"].values[start]))
    if baseline is not None:
        f = f - baseline
        source.update(force_baseline=baseline, force_reference=(
            "F relative to the free-cantilever baseline recorded in the file for this segment "
            "(segment_baseline): F_inf and dF_i are forces on the sample"))
    else:
        source["force_reference"] = ("force as recorded: the file gives no free-cantilever "
                                     "baseline, so F_inf includes the cantilever's offset")
    if "source" in curves.attrs:
        source["data_source"] = str(curves.attrs["source"])
    return FitData(t - t[0], f, None, source)


def _free_baseline(one: xr.Dataset, row: int) -> float | None:
    """The file's free-cantilever force baseline [N] of segment-table row ``row``, if any."""
    if "segment_baseline" not in one.variables:
        return None
    values = np.asarray(one["segment_baseline"].values, dtype=float).reshape(-1)
    if not 0 <= row < values.size or not np.isfinite(values[row]):
        return None
    return float(values[row])


def fit_hold(curves: xr.Dataset, *, curve: int = 0, segment: int | None = None,
             modes: int | str = 1, criterion: str = "bic") -> xr.Dataset:
    """Fit F(t) = F_inf + Σ dF_i e^{−t/τ_i} to the hold of one curve (``relaxation`` model).

    The τ_i are force-relaxation times at fixed position (not the creep times of Eq. 3: for a
    standard linear solid the force decays with τ·E_inf/E0). F is taken relative to the file's
    free-cantilever baseline where it records one (``attrs["force_baseline"]``,
    ``attrs["force_reference"]``). The stderr are corrected for autocorrelated residuals
    (:mod:`viscoforce.fitting.fit`).

    Parameters
    ----------
    curves : xarray.Dataset
        A curves dataset (:mod:`viscoforce.schema.curves`).
    curve : int
        The curve (pixel) to fit, from 0.
    segment : int, optional
        The curve's segment to fit (from 0, file order); default the pause after the approach.
    modes : int or "auto"
        Relaxation modes.
    criterion : {"bic", "aic"}
        Information criterion of ``modes="auto"``.

    Returns
    -------
    xarray.Dataset
        The fit result (``F_inf``, ``dF_i``, ``tau_i`` [s]; ``attrs`` ``residual_lag1``,
        ``stderr_correction``, ``effective_samples``).
    """
    ds = fit_data(hold_data(curves, curve=curve, segment=segment), "relaxation", modes=modes,
                  criterion=criterion)
    ds.attrs["validity"] = validity_note("relaxation", ds)
    warn_fit(ds)
    return ds


def trajectory_data(trajectory: xr.Dataset) -> tuple[FitData, tuple[np.ndarray, np.ndarray]]:
    """(t, F) and the position history (t, h0) of a trajectory (the ``step`` model's data)."""
    validate_trajectory(trajectory)
    t = np.asarray(trajectory["time"].values, dtype=float)
    f = np.asarray(trajectory["force"].values, dtype=float)
    h = np.asarray(trajectory["position"].values, dtype=float)
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(h))):
        raise ParameterError("the trajectory's force and position must be finite")
    return (FitData(t, f, None, {"data_kind": "trajectory", "data_points": int(t.size)}),
            (t, h))


def fit_step(trajectory: xr.Dataset, *, problem: Any, poisson: float | None = None
             ) -> xr.Dataset:
    """Fit the exact model's response to the trajectory's drive (``step`` model: tau, E0, E_inf).

    Identifiability by the local test (a profile would cost a simulation per evaluation).
    """
    data, trace = trajectory_data(trajectory)
    ds = fit_data(data, "step", problem=problem, position_trace=trace, profile=False)
    ds.attrs["validity"] = validity_note("step", ds)
    warn_fit(ds)
    ds = add_derived_moduli(ds, poisson)
    return ds
