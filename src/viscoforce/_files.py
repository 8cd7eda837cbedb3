"""Atomic file outputs: write beside the target, rename into place only when complete.

Every file viscoforce writes (netCDF, CSV, figures, JPK archives, the demo's JSON) goes through
:func:`atomic_output`: the data go to a temporary file in the target's own folder (same file
system, so the final :func:`os.replace` is atomic), which is flushed to disk and renamed over the
target only when the writer returned. A writer that fails (disk full, a file-size limit, an
exception) leaves the temporary file deleted and any previous file at the target untouched; two
processes writing one target each rename a complete file, so the survivor is whole (the last
rename wins), never a mixture or a truncated file.

netCDF files are made in memory first (:func:`write_netcdf`) and written with plain file I/O, so
that an I/O error is an ordinary :class:`OSError` and never reaches the HDF5 library mid-write.
Datasets too big to hold at once (the raw curves of a big map) are written chunk by chunk by
:func:`write_netcdf_stream` into the temporary file, renamed likewise only when complete.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from viscoforce.exceptions import ParameterError

#: Largest netCDF image built in memory before writing [bytes]; beyond it the engine writes the
#: temporary file itself (still renamed into place only when complete).
NETCDF_IN_MEMORY = 1 << 30


def _umask() -> int:
    current = os.umask(0)
    os.umask(current)
    return current


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether two existing paths are one file (same device and inode); False if either is absent."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def refuse_overwriting_inputs(output: str | os.PathLike[str],
                              inputs: Iterable[str | os.PathLike[str]], *,
                              name: str = "output") -> None:
    """Raise :class:`ParameterError` if ``output`` is one of ``inputs`` (same inode).

    Parameters
    ----------
    output : path
        The file about to be written.
    inputs : iterable of path
        Files the computation reads.
    name : str
        How the output is named in the message (e.g. ``"--out"``).
    """
    for source in inputs:
        if same_file(output, source):
            raise ParameterError(f"{name} {os.fspath(output)} is an input of this run "
                                 f"({os.fspath(source)}): writing it would destroy the data; "
                                 "give another file name")


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it to ``path``.

    The temporary file keeps ``path``'s suffix (writers that pick a format from it still do) and
    gets the permissions a new file would (the umask). Whatever the writer raises propagates,
    after the temporary file is removed; ``path`` is then exactly as before.

    Parameters
    ----------
    path : path
        The final file.

    Yields
    ------
    pathlib.Path
        Where to write (an empty file that exists).
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".part{target.suffix}",
                                    dir=folder)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        os.chmod(tmp, 0o666 & ~_umask())
        yield tmp
        with open(tmp, "rb+") as handle:  # on disk before the rename makes it visible
            os.fsync(handle.fileno())
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def write_bytes(path: str | os.PathLike[str], data: bytes | memoryview) -> None:
    """Write ``data`` to ``path`` atomically (:func:`atomic_output`)."""
    with atomic_output(path) as tmp, open(tmp, "wb") as handle:
        handle.write(data)


def write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_output`)."""
    write_bytes(path, text.encode("utf-8"))


def write_netcdf(ds: Any, path: str | os.PathLike[str], *, engine: str = "h5netcdf") -> None:
    """``ds.to_netcdf`` to ``path`` atomically; small datasets are built in memory first.

    Parameters
    ----------
    ds : xarray.Dataset
        What to write.
    path : path
        The netCDF file.
    engine : {"h5netcdf", "scipy"}
        netCDF4 (HDF5) or netCDF3.
    """
    if engine not in ("h5netcdf", "scipy"):
        raise ParameterError(f"engine must be 'h5netcdf' or 'scipy', got {engine!r}")
    if int(getattr(ds, "nbytes", 0)) <= NETCDF_IN_MEMORY:
        write_bytes(path, ds.to_netcdf(engine=engine))
        return
    with atomic_output(path) as tmp:
        ds.to_netcdf(tmp, engine=engine)


#: HDF5 chunk length along an appended dimension: at least, and at most (elements).
_STREAM_CHUNK = (1024, 1 << 16)


def _stream_encoding(ds: Any, append_dims: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    """HDF5 chunk shapes of the variables along ``append_dims`` (xarray's would be tiny)."""
    lengths = {d: min(max(_STREAM_CHUNK[0], int(ds.sizes[d])), _STREAM_CHUNK[1])
               for d in append_dims if d in ds.dims}
    return {str(name): {"chunksizes": tuple(lengths.get(d, int(ds.sizes[d])) for d in v.dims)}
            for name, v in ds.variables.items() if set(v.dims) & set(lengths)}


def _append(handle: Any, ds: Any, append_dims: tuple[str, ...], index: int) -> None:
    """Append ``ds`` along ``append_dims`` to the open h5netcdf file ``handle``."""
    names = {str(n) for n in ds.variables}
    have = set(handle.variables)
    if names != have:
        raise ParameterError(f"chunk {index} has variables {sorted(names ^ have)} the first chunk "
                             "has not (or lacks them): every chunk must have the same variables")
    start = {d: int(handle.dimensions[d].size) for d in append_dims if d in ds.dims}
    for d, n in start.items():
        handle.resize_dimension(d, n + int(ds.sizes[d]))
    for name, v in ds.variables.items():
        if not set(v.dims) & set(start):
            continue  # not along an appended dim: the first chunk's copy stands
        where = tuple(slice(start[d], start[d] + int(ds.sizes[d])) if d in start
                      else slice(None) for d in v.dims)
        values = v.values
        if values.dtype.kind == "U":  # netCDF4 variable-length strings
            values = values.astype(object)
        handle.variables[str(name)][where] = values


def write_netcdf_stream(chunks: Iterable[Any], path: str | os.PathLike[str], *,
                        append_dims: Iterable[str]) -> dict[str, Any]:
    """Write datasets one after the other into one netCDF file, appended along ``append_dims``.

    Memory is bounded by one chunk: the first chunk makes the file (``to_netcdf``, engine
    h5netcdf, ``append_dims`` unlimited), every next chunk is appended by HDF5 writes. The file
    is written to a temporary file beside ``path`` and renamed into place only when every
    chunk is in (:func:`atomic_output`): an exception from the writer or from the chunks'
    producer leaves no file at ``path`` (a previous file there is left untouched).

    Parameters
    ----------
    chunks : iterable of xarray.Dataset
        Datasets with the same variables, dims and dtypes; variables along none of
        ``append_dims`` are taken from the first chunk.
    path : path
        The netCDF file.
    append_dims : iterable of str
        The dims the chunks are concatenated along.

    Returns
    -------
    dict
        ``dims`` (name → total size, in the first chunk's order), ``variables`` (the sorted
        data variable names) and ``chunks`` (how many were written).

    Raises
    ------
    ParameterError
        No chunk, or a chunk whose variables differ from the first chunk's.
    """
    import h5netcdf

    dims = tuple(append_dims)
    iterator = iter(chunks)
    with atomic_output(path) as tmp:
        first = next(iterator, None)
        if first is None:
            raise ParameterError("write_netcdf_stream needs at least one chunk")
        sizes = {str(k): int(v) for k, v in first.sizes.items()}
        variables = sorted(str(v) for v in first.data_vars)
        first.to_netcdf(tmp, engine="h5netcdf", unlimited_dims=[d for d in dims
                                                                if d in first.dims],
                        encoding=_stream_encoding(first, dims))
        count = 1
        del first
        with h5netcdf.File(tmp, "a") as handle:
            for ds in iterator:
                _append(handle, ds, dims, count)
                for d in dims:
                    if d in ds.dims:
                        sizes[d] += int(ds.sizes[d])
                count += 1
    return {"dims": sizes, "variables": variables, "chunks": count}
