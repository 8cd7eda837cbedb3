"""Reading netCDF files with a bound: the declared sizes are checked before anything is loaded.

A netCDF file states each variable's shape in its header; HDF5 (netCDF4) files store unwritten
chunks as nothing, so an 87 kB file can declare 8 GB of data that a whole read would allocate.
:func:`open_netcdf` sums the declared sizes from the header alone (h5py for netCDF4/HDF5, SciPy's
memory-mapped reader for netCDF3), refuses a file beyond :data:`~viscoforce._limits.MAX_MEMORY_BYTES`
with the estimate in the message (:class:`~viscoforce.exceptions.EffortError`), and only then
opens it with xarray (which loads index coordinates as it opens) and loads it.
"""

from __future__ import annotations

import os
from typing import Any

from viscoforce._limits import MAX_MEMORY_BYTES, check_effort
from viscoforce.exceptions import ParameterError

__all__ = ["declared_bytes", "open_netcdf"]

#: First bytes of an HDF5 file (netCDF4) and of a netCDF3 file.
_HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
_NETCDF3_MAGIC = b"CDF"
#: Bytes counted per element of a variable-length type (strings, object arrays): a pointer, the
#: least such an element takes once read.
_VLEN_BYTES = 16


def _hdf5_bytes(path: str | os.PathLike[str]) -> int:
    import h5py

    total = 0

    def visit(_name: str, obj: Any) -> None:
        nonlocal total
        if isinstance(obj, h5py.Dataset):
            n = 1
            for size in obj.shape or ():
                n *= int(size)
            itemsize = obj.dtype.itemsize if obj.dtype.kind not in "OSUV" or (
                h5py.check_string_dtype(obj.dtype) is None
                and h5py.check_vlen_dtype(obj.dtype) is None) else _VLEN_BYTES
            total += n * max(int(itemsize), 1)

    with h5py.File(path, "r") as handle:
        handle.visititems(visit)
    return total


def _netcdf3_bytes(path: str | os.PathLike[str]) -> int:
    from scipy.io import netcdf_file

    with netcdf_file(path, "r", mmap=True) as handle:
        shapes = [(v.shape, int(v.itemsize())) for v in handle.variables.values()]
        handle.variables.clear()  # the memory map closes only when no array refers to it
    total = 0
    for shape, itemsize in shapes:
        n = 1
        for size in shape:
            n *= int(size)
        total += n * itemsize
    return total


def declared_bytes(path: str | os.PathLike[str]) -> int:
    """The bytes a netCDF file's variables take once read, from its header alone.

    Parameters
    ----------
    path : path
        A netCDF4 (HDF5) or netCDF3 file.

    Returns
    -------
    int
        The sum over variables of elements × element size (variable-length elements count
        16 bytes).

    Raises
    ------
    ParameterError
        The file is neither netCDF4/HDF5 nor netCDF3.
    OSError
        It cannot be read.
    """
    with open(path, "rb") as handle:
        magic = handle.read(8)
    if magic == _HDF5_MAGIC:
        return _hdf5_bytes(path)
    if magic[:3] == _NETCDF3_MAGIC:
        return _netcdf3_bytes(path)
    raise ParameterError(f"{os.fspath(path)} is not a netCDF file (neither netCDF4/HDF5 nor "
                         "netCDF3: its first bytes are " f"{magic!r})")


def open_netcdf(path: str | os.PathLike[str], *, limit: float = MAX_MEMORY_BYTES) -> Any:
    """A netCDF file read whole into memory, refused up front if it declares more than ``limit``.

    Parameters
    ----------
    path : path
        The file.
    limit : float
        Largest declared size read [bytes] (default :data:`~viscoforce._limits.MAX_MEMORY_BYTES`).

    Returns
    -------
    xarray.Dataset
        The file's dataset, loaded (the file is closed).

    Raises
    ------
    EffortError
        The variables declare more than ``limit`` bytes (the estimate is in the message).
    ParameterError
        Not a netCDF file.
    OSError, ValueError
        The file cannot be read or decoded.
    """
    import xarray as xr

    size = declared_bytes(path)
    check_effort(f"reading {os.fspath(path)}", size, limit, unit="bytes",
                 hint="the file's variables declare this much data; read a part of it with "
                      "xarray.open_dataset and .isel before loading")
    with xr.open_dataset(path) as ds:
        return ds.load()
