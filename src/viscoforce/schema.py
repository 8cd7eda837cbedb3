"""Dataset contracts: names, dimensions and units of what viscoforce reads and writes.

Spectrum (dim ``omega`` [rad/s], plus any extra dims):

=================  ==========  ============================================================
variable           units       meaning
=================  ==========  ============================================================
mean_force         N           F̄, the mean (zeroth harmonic) force
force_amplitude    N           |F1|, first-harmonic force amplitude
amplitude          1           a = |F1|/F̄ (the paper's relative amplitude)
stiffness          N/m         |F1|/η
phase              degree      χ: lead of the force over the compression (> 0 viscoelastic)
drive_amplitude    m           η (scalar or per point)
=================  ==========  ============================================================

Amplitude and phase are stored as reals so that every netCDF engine round-trips the file; the
complex stiffness k* = (|F1|/η)·e^{iχ} is derived on demand (:func:`complex_stiffness`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from viscoforce.exceptions import SchemaError

SPECTRUM_VARIABLES: dict[str, tuple[str, str]] = {
    "mean_force": ("N", "mean force"),
    "force_amplitude": ("N", "first-harmonic force amplitude |F1|"),
    "amplitude": ("1", "relative force amplitude |F1|/mean force"),
    "stiffness": ("N/m", "dynamic stiffness |F1|/eta"),
    "phase": ("degree", "phase lead of the force over the compression"),
    "drive_amplitude": ("m", "drive amplitude eta"),
}


def make_spectrum(omega: ArrayLike, complex_stiffness: ArrayLike, mean_force: ArrayLike,
                  eta: float, *, attrs: Mapping[str, object] | None = None) -> xr.Dataset:
    """Build a Spectrum dataset from k*(ω) = F̂/D̂ (force per unit compression) [N/m].

    Parameters
    ----------
    omega : array_like
        Angular frequencies [rad/s].
    complex_stiffness : array_like
        k*(ω) [N/m]; its argument is the phase χ (force leading the compression).
    mean_force : float or array_like
        F̄ [N].
    eta : float
        Drive amplitude η [m].
    attrs : mapping, optional
        Dataset attributes (parameters, method).
    """
    omega = np.asarray(omega, dtype=float)
    k = np.asarray(complex_stiffness, dtype=complex)
    stiffness = np.abs(k)
    mean = np.broadcast_to(np.asarray(mean_force, dtype=float), omega.shape)
    values = {
        "mean_force": mean,
        "force_amplitude": stiffness * eta,
        "amplitude": stiffness * eta / mean,
        "stiffness": stiffness,
        "phase": np.degrees(np.angle(k)),
    }
    data = {name: xr.DataArray(v, dims="omega",
                               attrs={"units": SPECTRUM_VARIABLES[name][0],
                                      "long_name": SPECTRUM_VARIABLES[name][1]})
            for name, v in values.items()}
    data["drive_amplitude"] = xr.DataArray(float(eta), attrs={
        "units": "m", "long_name": SPECTRUM_VARIABLES["drive_amplitude"][1]})
    coords = {"omega": xr.DataArray(omega, dims="omega",
                                    attrs={"units": "rad/s", "long_name": "angular frequency"})}
    return xr.Dataset(data, coords=coords, attrs=dict(attrs or {}))


def validate_spectrum(ds: xr.Dataset) -> xr.Dataset:
    """Raise :class:`SchemaError` naming the first missing variable or wrong unit; return ds."""
    if "omega" not in ds.coords:
        raise SchemaError("spectrum has no 'omega' coordinate [rad/s]")
    if ds["omega"].attrs.get("units") != "rad/s":
        raise SchemaError(f"'omega' must have units 'rad/s', got {ds['omega'].attrs.get('units')!r}")
    for name in ("stiffness", "phase", "mean_force"):
        if name not in ds:
            raise SchemaError(f"spectrum is missing '{name}' [{SPECTRUM_VARIABLES[name][0]}]")
        unit = ds[name].attrs.get("units")
        if unit != SPECTRUM_VARIABLES[name][0]:
            raise SchemaError(
                f"'{name}' must have units {SPECTRUM_VARIABLES[name][0]!r}, got {unit!r}")
    return ds


def complex_stiffness(ds: xr.Dataset) -> xr.DataArray:
    """k* = stiffness·e^{iχ} [N/m] of a Spectrum (χ = phase in degrees)."""
    validate_spectrum(ds)
    return ds["stiffness"] * np.exp(1j * np.radians(ds["phase"]))
