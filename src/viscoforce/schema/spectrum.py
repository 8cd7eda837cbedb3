"""Spectrum dataset: simulated or measured dynamic stiffness over ``omega`` (and any extra dims).

Amplitude and phase are stored as reals so that every netCDF engine round-trips the file; the
complex stiffness k* = stiffness·e^{iχ} is derived on demand (:func:`complex_stiffness`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from viscoforce.exceptions import SchemaError
from viscoforce.schema._core import (
    EXTRA,
    VariableSpec,
    as_flag,
    as_mapping,
    as_names,
    as_text,
    assemble,
    check_attrs,
    check_flags,
    check_present,
    check_variables,
    clean_attrs,
    coordinate,
    flag_attrs,
    index_values,
    per_point,
    require_dataset,
    require_values,
    variable,
)

#: The phase sign convention, written into every spectrum's ``attrs["phase_convention"]``.
PHASE_CONVENTION = ("phase = lead of the force over the compression (indentation), degrees; "
                    "> 0 for a viscoelastic sample")

_W = (EXTRA, "omega")

SPECTRUM_VARIABLES: dict[str, VariableSpec] = {
    "omega": VariableSpec("rad/s", "angular frequency", ("omega",)),
    "stiffness": VariableSpec("N/m", "dynamic stiffness |F1|/eta", _W),
    "phase": VariableSpec("degree", "phase lead of the force over the compression", _W),
    "mean_force": VariableSpec("N", "mean force", _W, broadcast=True),
    "force_amplitude": VariableSpec("N", "first-harmonic force amplitude |F1|", _W,
                                    required=False),
    "amplitude": VariableSpec("1", "relative force amplitude |F1|/mean force", _W,
                              required=False),
    "drive_amplitude": VariableSpec("m", "drive amplitude eta", _W, required=False,
                                    broadcast=True),
    "mean_indentation": VariableSpec("m", "mean indentation", _W, required=False,
                                     broadcast=True),
    "quality": VariableSpec("", "quality flag", _W, dtype="i", required=False, broadcast=True),
    "x": VariableSpec("m", "lateral position x", (EXTRA,), required=False, broadcast=True),
    "y": VariableSpec("m", "lateral position y", (EXTRA,), required=False, broadcast=True),
}

#: Codes of the ``quality`` flag variable (CF ``flag_values`` → ``flag_meanings``).
QUALITY_FLAGS: dict[int, str] = {0: "ok", 1: "phase_outside_passive_range", 2: "low_signal",
                                 3: "large_residual"}
#: Default CF ``comment`` of ``quality``: why a point is flagged (the point itself is kept).
QUALITY_COMMENT = (
    "phase_outside_passive_range: the phase is outside (0, 90) degrees, which a passive "
    "viscoelastic sample cannot give (an instrument phase lag: correct it with --phase-lag or a "
    "reference spectrum measured on a hard surface); low_signal: the force amplitude is not above "
    "the noise; large_residual: the lock-in residual is large (drift, nonlinearity or too few "
    "periods)")


def make_spectrum(omega: ArrayLike, complex_stiffness: ArrayLike, mean_force: ArrayLike,
                  eta: ArrayLike, *, attrs: Mapping[str, Any] | None = None,
                  dims: Iterable[str] | None = None, coords: Mapping[str, Any] | None = None,
                  stderr: Mapping[str, ArrayLike] | None = None,
                  quality: ArrayLike | None = None, quality_comment: str = QUALITY_COMMENT,
                  mean_indentation: ArrayLike | None = None, amplitude: bool | None = None,
                  source: str | None = None, check: bool = True) -> xr.Dataset:
    """Build a spectrum from k*(ω) = F̂/δ̂, force per unit compression (indentation) [N/m].

    Parameters
    ----------
    omega : array_like
        Angular frequencies [rad/s], > 0.
    complex_stiffness : array_like
        k* [N/m] over ``dims`` (``omega`` last); its argument is the phase χ, the lead of the
        force over the compression.
    mean_force : float or array_like
        F̄ [N], broadcast to every point. Finite, except in a measured spectrum (``source``
        names an instrument format, not ``"simulation"``), where NaN marks a point whose mean
        force is unknown (e.g. a spectrum CSV without it; ``fit --mean-force`` then supplies
        it). None and ±inf are always refused.
    eta : float or array_like
        Drive amplitude |δ̂| [m], finite and > 0: a scalar stays a scalar, an array is broadcast
        per point.
    attrs : mapping, optional
        Dataset attributes (parameters, method, provenance); ``phase_convention`` is set to
        :data:`PHASE_CONVENTION` unless given.
    dims : tuple or list of str, optional
        Dims of ``complex_stiffness``, ending with ``"omega"`` (e.g. ``("curve", "omega")``);
        default ``("omega",)``.
    coords : mapping, optional
        Extra coordinates, name → DataArray or (dims, values[, attrs]), e.g. ``x``, ``y`` [m]
        (their units are filled in when known).
    stderr : mapping, optional
        Standard errors, variable name → values, stored as ``<name>_stderr`` in the variable's
        units (used as fit weights), e.g. ``{"stiffness": ..., "phase": ...}``; >= 0, finite
        (NaN allowed in a measured spectrum).
    quality : array_like of int, optional
        Per-point codes of :data:`QUALITY_FLAGS`; stored as the CF flag variable ``quality``.
    quality_comment : str
        CF ``comment`` of ``quality`` explaining the flags.
    mean_indentation : float or array_like, optional
        Mean indentation δ̄ [m] where a contact point is known (NaN where unknown, in a measured
        spectrum only).
    amplitude : bool, optional
        Store a = |F1|/F̄. Default: only when every mean force is finite and nonzero; pass
        False for measured data whose mean force may be near zero (a would be meaningless).
    source : str, optional
        ``attrs["source"]``: "simulation" or the instrument format (which makes the spectrum a
        measured one: NaN may then mark unknown values, see ``mean_force``).
    check : bool
        Validate the dataset (:func:`validate_spectrum`). The solvers pass False for the spectra
        they build from their own checked arrays (``linear_response``);
        ``tests/schema/test_schema_assemble.py`` validates what they return.

    Returns
    -------
    xarray.Dataset
        Valid under :func:`validate_spectrum`.

    Raises
    ------
    SchemaError
        If an argument has the wrong type, shape or value (the message names it): e.g. a
        non-finite value in a computed spectrum, ``eta`` <= 0, ``attrs``/``coords``/``stderr``
        that are not mappings, ``dims`` that is not a sequence of names.
    """
    omega = coordinate("omega", omega)
    source = as_text("source", source, allow_none=True)
    quality_comment = as_text("quality_comment", quality_comment)
    amplitude = as_flag("amplitude", amplitude, allow_none=True)
    coords = as_mapping("coords", coords)
    stderr = as_mapping("stderr", stderr)
    measured = source is not None and source != "simulation"
    hint = "" if measured else (
        " (a computed spectrum must be finite everywhere; NaN marks an unknown value only in a "
        "measured spectrum, source=<instrument format>)")
    if complex_stiffness is None or isinstance(complex_stiffness, str | bytes | Mapping):
        raise SchemaError(f"complex_stiffness must be numbers, got {complex_stiffness!r}")
    try:
        k = np.asarray(complex_stiffness, dtype=complex)
    except (TypeError, ValueError):
        raise SchemaError(f"complex_stiffness must be numbers, got {complex_stiffness!r}") from None
    names = as_names("dims", dims)
    dims = ("omega",) if names is None else names
    if not dims or dims[-1] != "omega" or len(dims) != k.ndim or k.shape[-1] != omega.size:
        raise SchemaError(f"complex_stiffness of shape {k.shape} must span dims {dims} ending "
                          f"with 'omega' ({omega.size} frequencies); give dims= for extra dims")
    t = SPECTRUM_VARIABLES
    stiffness = require_values("complex_stiffness (its modulus)", np.abs(k), allow_nan=measured,
                               nan_hint=hint)
    mean, _ = per_point("mean_force", mean_force, k.shape, dims)
    require_values("mean_force", mean, allow_nan=measured, nan_hint=hint)
    eta_v, eta_dims = per_point("eta", eta, k.shape, dims, keep_scalar=True)
    require_values("eta", eta_v, minimum=0.0, strict=True)
    data = {"mean_force": mean, "force_amplitude": stiffness * eta_v, "stiffness": stiffness,
            "phase": np.degrees(np.angle(k))}
    known = bool(np.all(np.isfinite(mean) & (mean != 0)))
    if amplitude is None:
        amplitude = known
    if amplitude:
        if not known:
            raise SchemaError("amplitude |F1|/mean force needs a nonzero mean force everywhere "
                              "(finite, not NaN); pass amplitude=False")
        with np.errstate(over="ignore"):  # a tiny mean force gives a = inf, honestly
            data["amplitude"] = stiffness * eta_v / mean
    out = {name: variable(v, dims, t[name]) for name, v in data.items()}
    out["drive_amplitude"] = variable(eta_v, eta_dims, t["drive_amplitude"])
    if mean_indentation is not None:
        indentation, indentation_dims = per_point("mean_indentation", mean_indentation, k.shape,
                                                  dims, keep_scalar=True)
        require_values("mean_indentation", indentation, allow_nan=measured, nan_hint=hint)
        out["mean_indentation"] = variable(indentation, indentation_dims, t["mean_indentation"])
    if quality is not None:
        out["quality"] = _quality(quality, k.shape, dims, quality_comment)
    for name, values in stderr.items():
        if not isinstance(name, str) or name not in out:
            raise SchemaError(f"stderr given for {name!r}, which is not a variable of this "
                              f"spectrum {sorted(n for n in out if n != 'quality')}")
        spec = t[name]
        v, vdims = per_point(f"{name}_stderr", values, k.shape, dims, keep_scalar=spec.broadcast)
        require_values(f"{name}_stderr", v, allow_nan=measured, minimum=0.0, nan_hint=hint)
        out[f"{name}_stderr"] = variable(v, vdims, spec,
                                         long_name=f"standard error of {spec.long_name}")
    all_coords = {"omega": variable(omega, ("omega",), t["omega"])}
    for name, value in coords.items():
        if not isinstance(name, str) or name == "omega":
            raise SchemaError(f"coords names must be strings other than 'omega', got "
                              f"{name!r}")
        all_coords[name] = value
    meta = clean_attrs(attrs)
    meta.setdefault("phase_convention", PHASE_CONVENTION)
    if source is not None:
        meta["source"] = source
    try:
        ds = assemble(out, all_coords, meta, fresh={*out, "omega"})
    except (TypeError, ValueError, SchemaError) as exc:
        raise SchemaError(
            f"coords must map names to DataArrays or (dims, values[, attrs]) tuples over the "
            f"dims {dims}: {exc}") from None
    for name in coords:
        if name in t and t[name].units:
            ds[name].attrs.setdefault("units", t[name].units)
            ds[name].attrs.setdefault("long_name", t[name].long_name)
    return validate_spectrum(ds) if as_flag("check", check) else ds


def _quality(quality: ArrayLike, shape: tuple[int, ...], dims: tuple[str, ...],
             comment: str) -> xr.Variable:
    raw = np.asarray(quality)
    if raw.dtype.kind not in "iu":
        raise SchemaError(f"quality must be integer codes of {QUALITY_FLAGS}, got {raw.dtype}")
    try:
        codes = np.broadcast_to(raw, shape).astype(np.int8)
    except ValueError:
        raise SchemaError(f"quality of shape {raw.shape} does not broadcast to {shape}") from None
    bad = np.setdiff1d(codes, list(QUALITY_FLAGS))
    if bad.size:
        raise SchemaError(f"quality codes {bad.tolist()} are not among {QUALITY_FLAGS}")
    return xr.Variable(dims, codes, {"long_name": "quality flag", **flag_attrs(QUALITY_FLAGS),
                                     "comment": comment})


def phase_quality(phase: ArrayLike) -> np.ndarray:
    """Quality codes from the phase [degree]: 1 (phase_outside_passive_range) outside (0°, 90°).

    NaN phases are left 0; combine with other checks by taking the first nonzero code.
    """
    phase = np.asarray(phase, dtype=float)
    with np.errstate(invalid="ignore"):
        outside = (phase <= 0) | (phase >= 90)
    return np.where(outside, 1, 0).astype(np.int8)


def validate_spectrum(ds: xr.Dataset, *, require: Iterable[str] | None = None) -> xr.Dataset:
    """Return ``ds`` if it is a spectrum, else raise :class:`SchemaError` naming the defect.

    Parameters
    ----------
    ds : xarray.Dataset
        Dataset to check.
    require : iterable of str, optional
        Variables that must be present (default ``omega``, ``stiffness``, ``phase``,
        ``mean_force``). Every known variable present is checked for units, dtype and dims
        (``omega`` last, the same dims for ``stiffness``, ``phase``, ``force_amplitude`` and
        ``amplitude``; ``mean_force``, ``drive_amplitude``, ``mean_indentation``, ``quality``
        and every ``<name>_stderr`` may span any subset of them, as xarray broadcasts;
        ``<name>_stderr`` in the units of ``<name>``); ``omega`` must be finite and > 0;
        ``quality`` must be a CF flag.
    """
    require_dataset(ds, "spectrum")
    if "omega" not in ds.coords:
        raise SchemaError("spectrum has no 'omega' coordinate [rad/s]")
    check_present(ds, "spectrum", SPECTRUM_VARIABLES, require)
    extra: tuple[str, ...] = ()
    for name in ("stiffness", "phase", "amplitude", "mean_force"):
        if name in ds.variables:
            dims = ds.variables[name].dims
            if name == "mean_force" and (not dims or dims[-1] != "omega"):
                continue  # broadcast (scalar or per pixel): it does not give the extra dims
            if not dims or dims[-1] != "omega":
                raise SchemaError(f"spectrum: '{name}' must have 'omega' as its last dim, got {dims}")
            extra = tuple(str(d) for d in dims[:-1])
            break
    check_variables(ds, "spectrum", SPECTRUM_VARIABLES, extra)
    w = index_values(ds, "omega")
    if not np.all(np.isfinite(w) & (w > 0)):
        raise SchemaError(f"spectrum: 'omega' must be finite and > 0 rad/s, got min {w.min()!r}")
    if "quality" in ds.variables:
        check_flags(ds, "spectrum", "quality")
    check_attrs(ds, "spectrum")
    return ds


def complex_stiffness(ds: xr.Dataset) -> xr.DataArray:
    """k* = stiffness·e^{iχ} [N/m] of a spectrum (χ = ``phase`` in degrees)."""
    validate_spectrum(ds, require=("stiffness", "phase"))
    k = ds["stiffness"] * np.exp(1j * np.radians(ds["phase"]))
    k.attrs = {"units": "N/m", "long_name": "complex stiffness k*"}
    return k
