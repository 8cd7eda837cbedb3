"""Spectrum CSV/TSV tables (:func:`read_spectrum_csv`, the SPEC's "Spectrum CSV").

The columns, the rules, the quality flags and the messages are described in
:mod:`viscoforce.io.csv_formats`, which re-exports everything here; a ``phase (rad)`` column whose
values are evidently degrees is refused (:data:`RAD_PHASE_LIMIT`).

What :func:`viscoforce.io.csv_tables.write_spectrum_csv` writes reads back to the same spectrum:
``frequency (Hz)`` beside ``omega (rad/s)`` (omega is taken, the two must agree to 1e-9), the
per-curve coordinates ``x (m)``, ``y (m)``, ``row (1)``, ``column (1)`` (one value per curve), the
moduli ``E_storage``, ``E_loss``, ``G_storage``, ``G_loss`` [Pa] with their stderr, and the
``quality (1)`` codes (used as they are instead of flags recomputed from the phase); empty cells
of ``mean_indentation`` and the moduli are NaN (unknown).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from viscoforce.exceptions import ParameterError, UnitError
from viscoforce.io._csv_columns import _ANGLE, _curve_coord, _groups, _ignored, _option, _quantity
from viscoforce.io._csv_table import _read_table, _Table
from viscoforce.io.quality import (
    first_beyond,
    phase_basis,
    quality_notes,
    range_text,
    spectrum_quality,
)
from viscoforce.schema import make_spectrum, validate_spectrum

__all__ = ["RAD_PHASE_LIMIT", "SPECTRUM_COLUMNS", "read_spectrum_csv"]

#: Dimension of each spectrum column (``angle``: deg/rad, handled here).
SPECTRUM_COLUMNS: dict[str, str] = {
    "frequency": "frequency", "omega": "angular_frequency", "stiffness": "stiffness",
    "amplitude": "dimensionless", "force_amplitude": "force", "drive_amplitude": "length",
    "phase": "angle", "mean_force": "force", "mean_indentation": "length",
    "e_storage": "pressure", "e_loss": "pressure", "g_storage": "pressure", "g_loss": "pressure",
    "x": "length", "y": "length", "row": "dimensionless", "column": "dimensionless",
    "quality": "dimensionless",
}
#: The moduli columns (lower-case as read) -> variable name and long name.
_MODULI = {"e_storage": ("E_storage", "Young's storage modulus E'"),
           "e_loss": ("E_loss", "Young's loss modulus E''"),
           "g_storage": ("G_storage", "shear storage modulus G'"),
           "g_loss": ("G_loss", "shear loss modulus G''")}
#: Per-curve columns -> (units, long name, integer).
_PER_CURVE = {"x": ("m", "lateral position x", False), "y": ("m", "lateral position y", False),
              "row": ("1", "grid row of the curve (along y, from 0; -1: no position)", True),
              "column": ("1", "grid column of the curve (along x, from 0; -1: no position)",
                         True)}
#: Columns read here besides the magnitude, phase and frequency.
_EXTRA = (*_MODULI, *_PER_CURVE, "quality")


def _stderr_map(table: _Table) -> dict[str, np.ndarray]:
    out = {}
    for col in table.columns:
        if col.name.endswith("_stderr") and col.name.removesuffix("_stderr") in SPECTRUM_COLUMNS:
            base = col.name.removesuffix("_stderr")
            if base in _MODULI:
                continue  # read with the moduli
            if base in ("frequency", "omega", *_PER_CURVE, "quality"):
                raise ParameterError(f"{table.path}: column '{col.header}': a frequency has no "
                                     "standard error here (frequencies are exact)")
            out[base] = _quantity(table, col.name, SPECTRUM_COLUMNS, allow_missing=True)
            if np.any(out[base] < 0):
                raise ParameterError(f"{table.path}: column '{col.header}' has a negative "
                                     "standard error")
    return out


def _refuse_repeated_frequency(table: _Table, omega: np.ndarray, rows: np.ndarray,
                               label: str | None) -> None:
    """Refuse a frequency given twice within one curve, naming both rows."""
    o = np.argsort(omega[rows], kind="stable")
    same = np.flatnonzero(np.diff(omega[rows][o]) <= 0)
    if same.size:
        first, second = sorted((int(rows[o[same[0]]]), int(rows[o[same[0] + 1]])))
        where = f" in curve {label!r}" if label is not None else ""
        raise ParameterError(
            f"{table.path}: a frequency appears twice{where}: "
            f"{float(omega[first]) / (2 * math.pi):g} Hz at {table.where(first)} and "
            f"{table.where(second)} (a duplicated row or curve?); keep one row per frequency "
            "(give repeated measurements distinct curve labels)")


def _relative(pairs: list[tuple[np.ndarray, np.ndarray | None]]) -> np.ndarray | None:
    """Relative error of a product/quotient from (value, stderr) pairs (None if none known)."""
    known = [(v, e) for v, e in pairs if e is not None]
    if not known:
        return None
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sqrt(sum((e / np.abs(v)) ** 2 for v, e in known))


#: Largest |phase| a ``phase (rad)`` column may hold: 2π. Beyond it the values are degrees.
RAD_PHASE_LIMIT = 2.0 * math.pi


def _check_rad_phase(table: _Table, name: str) -> None:
    """Refuse a ``<name> (rad)`` column whose values are evidently degrees."""
    col = table.find(name)
    if col is None or col.unit is None or _ANGLE.get(col.unit) == 1.0:
        return
    raw = table.numbers(col, 1.0, allow_missing=True)
    finite = raw[np.isfinite(raw)]
    if finite.size == 0:
        return
    worst = float(np.max(np.abs(finite)))
    if worst > RAD_PHASE_LIMIT:
        raise UnitError(
            f"{table.path}: column '{col.header}' holds |values| up to {worst:g}, outside the "
            f"range a phase in radians can take, [-2*pi, 2*pi] = [-{RAD_PHASE_LIMIT:.4f}, "
            f"{RAD_PHASE_LIMIT:.4f}]: these are degrees; write the header '{name} (deg)'")
    if name == "phase" and finite.size >= 3 and np.all(finite > math.pi / 2):
        raise UnitError(
            f"{table.path}: column '{col.header}': every value lies in (pi/2, 2*pi] = "
            f"({math.pi / 2:.4f}, {RAD_PHASE_LIMIT:.4f}], which as radians puts every point "
            "outside the passive range (0, pi/2) and as degrees inside (0, 90): these are "
            f"degrees; write the header '{name} (deg)' (convert them first if they really are "
            "radians)")


def read_spectrum_csv(path: str | Path, *, drive_amplitude: float | str | None = None,
                      source: str = "csv-spectrum") -> xr.Dataset:
    """Read a spectrum CSV/TSV (see :mod:`viscoforce.io.csv_formats`) into a spectrum dataset.

    Parameters
    ----------
    path : str or Path
        The file (read-only).
    drive_amplitude : float or str, optional
        Drive amplitude |δ̂| [m] (``"1nm"`` accepted) for files without a ``drive_amplitude``
        column; needed to turn ``amplitude (1)`` into a stiffness.
    source : str
        ``attrs["source"]`` (makes it a measured spectrum: NaN mean force allowed).

    Returns
    -------
    xarray.Dataset
        Valid under :func:`viscoforce.schema.validate_spectrum`, over ``omega`` (sorted) or
        (``curve``, ``omega``). Without any drive amplitude, ``drive_amplitude`` and
        ``force_amplitude`` are absent (unknown). ``quality``
        (:func:`viscoforce.io.quality.spectrum_quality`) with the comment of
        :func:`~viscoforce.io.quality.quality_notes`, and attrs ``phase_lag`` = "none", ``drag``
        = 0 (nothing corrected here), ``phase_reference``
        (:func:`~viscoforce.io.quality.phase_basis`: unknown) and
        ``quality_summary``, as a JPK modulation spectrum has them.

    Raises
    ------
    UnitError
        A column without a unit, or with a unit unknown for its quantity; a ``phase (rad)`` or
        ``phase_stderr (rad)`` column holding degrees (a |value| above 2π, or, for the phase,
        three or more values all in (π/2, 2π]).
    ParameterError
        A missing or ambiguous column, a non-numeric cell, a value beyond its physical range (a
        stiffness that is 0 or above 1e10 N/m, derived ones included), a frequency repeated
        within a curve (both rows named), a line with a wrong number of fields, bad options.
    InstrumentFormatError
        The file is missing, empty, not a table or not UTF-8/Latin-1 text.
    EffortError
        A file above ``MAX_CSV_BYTES`` or a table above ``MAX_CSV_ROWS`` rows.
    """
    eta_option = _option("drive_amplitude", drive_amplitude, "length")
    table = _read_table(path, SPECTRUM_COLUMNS)
    p = table.path
    for name in ("phase", "phase_stderr"):
        _check_rad_phase(table, name)
    q = {name: _quantity(table, name, SPECTRUM_COLUMNS,
                         allow_missing=name in ("mean_force", "mean_indentation", *_MODULI))
         for name in SPECTRUM_COLUMNS if name not in _EXTRA}
    if q["frequency"] is None and q["omega"] is None:
        raise ParameterError(f"{p}: need exactly one frequency column, 'frequency (Hz)' or "
                             "'omega (rad/s)' (or both, agreeing)")
    omega = 2 * math.pi * q["frequency"] if q["omega"] is None else q["omega"]
    if q["frequency"] is not None and q["omega"] is not None:
        _check_same_frequency(table, q["frequency"], q["omega"])
    if np.any(omega <= 0):
        row = int(np.flatnonzero(omega <= 0)[0])
        name = "frequency" if q["omega"] is None else "omega"
        raise ParameterError(f"{p}: {name} at {table.where(row)} must be > 0 "
                             f"({range_text(name)}), got {float(q[name][row]):g}")
    if q["phase"] is None:
        raise ParameterError(f"{p}: no phase column 'phase (deg)' or 'phase (rad)'")
    err = _stderr_map(table)
    table.check_ranges()
    mean = q["mean_force"] if q["mean_force"] is not None else np.full(omega.shape, np.nan)
    eta = q["drive_amplitude"]
    if eta is None and eta_option is not None:
        eta = np.full(omega.shape, eta_option)
    if eta is not None and np.any(eta <= 0):
        row = int(np.flatnonzero(eta <= 0)[0])
        raise ParameterError(f"{p}: drive_amplitude at {table.where(row)} must be > 0 "
                             f"({range_text('drive_amplitude')}), got {float(eta[row]):g} m")
    stiff_err = err.get("stiffness")
    if q["stiffness"] is not None:
        stiffness, magnitude = q["stiffness"], "stiffness"
    elif q["force_amplitude"] is not None:
        if q["drive_amplitude"] is None:
            raise ParameterError(f"{p}: 'force_amplitude' needs a 'drive_amplitude (m)' column")
        stiffness, magnitude = q["force_amplitude"] / eta, "force_amplitude"
        rel = _relative([(q["force_amplitude"], err.get("force_amplitude")),
                         (eta, err.get("drive_amplitude"))])
        if stiff_err is None and rel is not None:
            stiff_err = rel * stiffness
    elif q["amplitude"] is not None:
        if q["mean_force"] is None:
            raise ParameterError(f"{p}: 'amplitude (1)' is relative (|F1|/mean force); it needs "
                                 "a 'mean_force (N)' column")
        if eta is None:
            raise ParameterError(f"{p}: 'amplitude (1)' needs a drive amplitude: a "
                                 "'drive_amplitude (m)' column or drive_amplitude='1nm'")
        if not np.all(np.isfinite(mean)):
            row = int(np.flatnonzero(~np.isfinite(mean))[0])
            raise ParameterError(f"{p}: 'amplitude (1)' needs the mean force at every row; "
                                 f"{table.where(row)} has none")
        stiffness, magnitude = q["amplitude"] * np.abs(mean) / eta, "amplitude"
        rel = _relative([(q["amplitude"], err.get("amplitude")), (mean, err.get("mean_force")),
                         (eta, err.get("drive_amplitude"))])
        if stiff_err is None and rel is not None:
            stiff_err = rel * stiffness
    else:
        raise ParameterError(f"{p}: no magnitude column: 'stiffness (N/m)', 'amplitude (1)' (with "
                             "'mean_force (N)') or 'force_amplitude (N)' with 'drive_amplitude (m)'")
    if np.any(stiffness < 0):
        row = int(np.flatnonzero(stiffness < 0)[0])
        raise ParameterError(f"{p}: the magnitude at {table.where(row)} is negative; give the "
                             "modulus and put the sign in the phase")
    if np.any(stiffness == 0):
        row = int(np.flatnonzero(stiffness == 0)[0])
        raise ParameterError(f"{p}: the magnitude at {table.where(row)} is 0 (allowed: "
                             f"{range_text('stiffness')}): a point without a force response "
                             "has no phase; drop the row")
    row = first_beyond("stiffness", stiffness)
    if row is not None:
        how = {"force_amplitude": "force_amplitude / drive_amplitude",
               "amplitude": "amplitude x |mean_force| / drive_amplitude"}.get(magnitude)
        raise ParameterError(f"{p}: the stiffness at {table.where(row)}"
                             + (f" ({how})" if how else "")
                             + f" is {float(stiffness[row]):g} N/m, beyond the physical range "
                             f"{range_text('stiffness')}; check the values and the header's units")
    per_row: dict[str, np.ndarray] = {"stiffness": stiffness, "phase": q["phase"],
                                      "mean_force": mean}
    if eta is not None:
        per_row["drive_amplitude"] = eta
    if q["mean_indentation"] is not None:
        per_row["mean_indentation"] = q["mean_indentation"]
    stderr_rows: dict[str, np.ndarray] = {}
    if stiff_err is not None:
        stderr_rows["stiffness"] = stiff_err
    for name in ("phase", "mean_force", "drive_amplitude", "mean_indentation",
                 "force_amplitude", "amplitude"):
        if name in err:
            stderr_rows[name] = err[name]
    unused = [n for n in stderr_rows if n not in per_row and n not in ("force_amplitude",
                                                                       "amplitude")]
    if unused:
        raise ParameterError(f"{p}: stderr columns for {unused} without their value columns")
    if eta is None:
        stderr_rows.pop("force_amplitude", None)
    if magnitude != "amplitude":
        stderr_rows.pop("amplitude", None)

    order, rows = _groups(table)
    for label, r in zip(order, rows, strict=True):
        _refuse_repeated_frequency(table, omega, r, label if len(order) > 1 else None)
    w_sorted = np.sort(omega[rows[0]])
    grids = []
    for label, r in zip(order, rows, strict=True):
        o = np.argsort(omega[r], kind="stable")
        if r.size != w_sorted.size or not np.array_equal(omega[r][o], w_sorted):
            raise ParameterError(f"{p}: curve {label!r} does not have the same frequencies as "
                                 f"curve {order[0]!r} (every curve needs the same set)")
        grids.append(r[o])
    take = np.stack(grids)  # (curve, omega) row indices

    def shape(values: np.ndarray) -> np.ndarray:
        return values[take] if len(order) > 1 else values[take[0]]

    k = shape(stiffness) * np.exp(1j * np.radians(shape(q["phase"])))
    dims = ("curve", "omega") if len(order) > 1 else ("omega",)
    coords: dict[str, Any] = {"curve": ("curve", _curve_coord(order), {
        "long_name": "curve label in the file"})} if len(order) > 1 else {}
    coords.update(_per_curve(table, take, dims[:-1]))
    attrs: dict[str, Any] = {"file": str(p), "delimiter": repr(table.delimiter),
                             "magnitude_column": magnitude,
                             "frequency_column": "omega" if q["omega"] is not None
                             else "frequency"}
    ignored = _ignored(table, SPECTRUM_COLUMNS)
    if ignored:
        attrs["ignored_columns"] = ", ".join(ignored)
    stderr = {n: shape(v) for n, v in stderr_rows.items()}
    if eta is None:
        stderr.pop("force_amplitude", None)
    # the flags and notes of a JPK modulation spectrum, by the same functions; nothing corrected
    phase = np.degrees(np.angle(k))
    quality = _file_quality(table, shape)
    if quality is None:
        quality = spectrum_quality(phase, np.abs(k), stderr.get("stiffness"))
    basis = phase_basis(None)
    notes = quality_notes(quality, phase, w_sorted / (2 * math.pi), corrections="none",
                          basis=basis)
    attrs.update({"phase_lag": "none", "drag": 0.0, "phase_reference": basis,
                  "quality_summary": notes["summary"]})
    ds = make_spectrum(w_sorted, k, shape(mean), shape(eta) if eta is not None else 1.0,
                       attrs=attrs, dims=dims, coords=coords, stderr=stderr,
                       quality=quality, quality_comment=notes["comment"],
                       mean_indentation=(shape(q["mean_indentation"])
                                         if q["mean_indentation"] is not None else None),
                       amplitude=magnitude == "amplitude", source=source)
    if eta is None:  # the placeholder drive amplitude is not data: drop what depends on it
        ds = ds.drop_vars([v for v in ("drive_amplitude", "force_amplitude",
                                       "force_amplitude_stderr") if v in ds.variables])
        ds.attrs["drive_amplitude_known"] = 0
    moduli = _moduli(table, shape, dims)
    if moduli:
        ds = ds.assign(moduli)
    table.check_ranges()  # the columns read since the first check (x, y)
    return validate_spectrum(ds)


def _check_same_frequency(table: _Table, frequency: np.ndarray, omega: np.ndarray) -> None:
    """Refuse ``frequency (Hz)`` and ``omega (rad/s)`` columns that disagree (to 1e-9)."""
    with np.errstate(invalid="ignore"):
        off = np.abs(2 * math.pi * frequency - omega) > 1e-9 * np.abs(omega)
    if np.any(off):
        row = int(np.flatnonzero(off)[0])
        raise ParameterError(
            f"{table.path}: 'frequency' and 'omega' disagree at {table.where(row)}: "
            f"{float(frequency[row]):g} Hz is {2 * math.pi * float(frequency[row]):g} rad/s, not "
            f"{float(omega[row]):g} rad/s; give exactly one frequency column (or two that "
            "agree)")


def _per_curve(table: _Table, take: np.ndarray, dims: tuple[str, ...]) -> dict[str, Any]:
    """Coordinates ``x``, ``y`` [m], ``row``, ``column`` of each curve, where the file has them.

    Each must hold one value per curve (the same on all of its rows); NaN (an empty cell) is
    an unknown position.
    """
    out: dict[str, Any] = {}
    for name, (units, long_name, integer) in _PER_CURVE.items():
        values = _quantity(table, name, SPECTRUM_COLUMNS, allow_missing=not integer)
        if values is None:
            continue
        per = values[take]  # (curve, omega)
        same = (per == per[:, :1]) | (np.isnan(per) & np.isnan(per[:, :1]))
        if not np.all(same):
            row = int(take[np.argwhere(~same)[0][0], np.argwhere(~same)[0][1]])
            raise ParameterError(f"{table.path}: column '{name}' must hold one value per curve; "
                                 f"{table.where(row)} differs from the curve's first row")
        first = per[:, 0]
        if integer:
            if np.any(first != np.round(first)):
                raise ParameterError(f"{table.path}: column '{name}' must hold integers")
            first = first.astype(np.int32)
        value = first if dims else first[0]
        out[name] = (dims, value, {"units": units, "long_name": long_name})
    return out


def _file_quality(table: _Table, shape: Any) -> np.ndarray | None:
    """The file's ``quality (1)`` codes (None without the column); refused when not a code."""
    from viscoforce.schema import QUALITY_FLAGS

    values = _quantity(table, "quality", SPECTRUM_COLUMNS)
    if values is None:
        return None
    bad = ~np.isin(values, list(QUALITY_FLAGS))
    if np.any(bad):
        row = int(np.flatnonzero(bad)[0])
        raise ParameterError(f"{table.path}: 'quality' at {table.where(row)} is "
                             f"{float(values[row]):g}, not one of the codes {QUALITY_FLAGS}")
    return shape(values).astype(np.int8)


def _moduli(table: _Table, shape: Any, dims: tuple[str, ...]) -> dict[str, Any]:
    """E_storage, E_loss, G_storage, G_loss [Pa] and their stderr, where the file has them."""
    out: dict[str, Any] = {}
    for column, (name, long_name) in _MODULI.items():
        for suffix in ("", "_stderr"):
            values = _quantity(table, column + suffix, SPECTRUM_COLUMNS, allow_missing=True)
            if values is None:
                continue
            what = long_name if not suffix else f"standard error of {long_name}"
            out[name + suffix] = (dims, shape(values), {"units": "Pa", "long_name": what})
    return out
