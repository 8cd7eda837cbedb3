"""Read a JPK archive in chunks of curves, so that memory is bounded by a chunk, not the file.

:func:`jpk_to_curves` holds every sample of the selected curves at once (a 64×64 modulation map
is 84 million samples, several GiB of arrays); a chunk of :func:`chunk_size` curves holds about
:data:`DEFAULT_CHUNK_BYTES`. :func:`iter_curves` yields the curves datasets of consecutive chunks,
numbered as one dataset of the whole selection would be (``segment`` and ``segment_curve`` offset
by the rows before the chunk), so that concatenating the chunks along ``sample``, ``curve`` and
``segment_table`` gives that dataset. :func:`write_curves_netcdf` appends them to a netCDF file
(atomically: a temporary file beside the target, renamed only when complete).

The height channel is chosen once for the whole selection (the first of
:data:`~viscoforce.io.curves.HEIGHT_CHANNELS` in metres in every segment of every selected curve,
from the headers), as :func:`jpk_to_curves` does, so a chunk never switches channel. A map's
grid rows, columns and snapped x, y are those of the whole archive
(:meth:`~viscoforce.io.jpk.JPKArchive.positions`, found once from every curve header), so a
chunk's equal the whole read's. The demodulated counterpart is
:func:`viscoforce.experiments.stream.stream_spectrum`.
"""

from __future__ import annotations

import math
import operator
import os
from collections.abc import Iterable, Iterator

import numpy as np
import xarray as xr

from viscoforce._files import write_netcdf_stream
from viscoforce.exceptions import ParameterError
from viscoforce.io.curves import _default_height, _select, check_height_channel, jpk_to_curves
from viscoforce.io.jpk import JPKArchive

__all__ = ["BYTES_PER_SAMPLE", "CURVE_DIMS", "DEFAULT_CHUNK_BYTES", "MAX_CHUNK", "chunk_size",
           "curve_chunks", "iter_curves", "selection_height", "write_curves_netcdf"]

#: Memory one chunk of curves may take while it is read and demodulated [bytes].
DEFAULT_CHUNK_BYTES = 128 * 2**20
#: Peak bytes per sample of reading and demodulating a chunk (tracemalloc, synthetic 16x16 map
#: of benchmarks/bench_load.py: decoded channels, the flattened curves dataset, the lock-in).
BYTES_PER_SAMPLE = 100
#: Largest chunk (curves), however small the curves.
MAX_CHUNK = 256
#: The dims a curves dataset grows along when curves are appended.
CURVE_DIMS = ("sample", "curve", "segment_table")


def _check_archive(archive: object) -> JPKArchive:
    if not isinstance(archive, JPKArchive):
        raise ParameterError(f"archive must be a JPKArchive (from read_jpk), got "
                             f"{type(archive).__name__}")
    return archive


def _check_chunk(chunk: object) -> int:
    if isinstance(chunk, bool) or not isinstance(chunk, int | np.integer) or chunk < 1:
        raise ParameterError(f"chunk must be an integer >= 1 (curves per chunk), got {chunk!r}")
    return int(chunk)


def chunk_size(archive: JPKArchive, *, memory_bytes: int = DEFAULT_CHUNK_BYTES) -> int:
    """Curves per chunk such that a chunk takes about ``memory_bytes`` while it is processed.

    Parameters
    ----------
    archive : JPKArchive
        The archive (its first curve's headers give the samples per curve).
    memory_bytes : int
        Memory budget of one chunk [bytes], >= 1 MiB.

    Returns
    -------
    int
        In [1, :data:`MAX_CHUNK`]: ``memory_bytes`` / (:data:`BYTES_PER_SAMPLE` × 1.25 × the
        samples of the first curve; the 25 % allow for curves a little longer than the first).
    """
    archive = _check_archive(archive)
    if isinstance(memory_bytes, bool) or not isinstance(memory_bytes, int | np.integer) \
            or memory_bytes < 2**20:
        raise ParameterError(f"memory_bytes must be an integer >= {2**20} (1 MiB), got "
                             f"{memory_bytes!r}")
    if archive.n_curves == 0:
        return 1
    samples = sum(int(s.num_points) for s in archive.curve(0).segments)
    per_curve = BYTES_PER_SAMPLE * 1.25 * max(samples, 1)
    return int(min(MAX_CHUNK, max(1, math.floor(memory_bytes / per_curve))))


def curve_chunks(curves: int | Iterable[int], chunk: int) -> list[list[int]]:
    """Consecutive chunks of ``chunk`` curves: of ``range(curves)`` or of the indices given.

    Parameters
    ----------
    curves : int or iterable of int
        Number of curves, or the curve indices in order.
    chunk : int
        Curves per chunk, >= 1 (the last chunk may be shorter).

    Returns
    -------
    list of list of int
    """
    chunk = _check_chunk(chunk)
    if isinstance(curves, int | np.integer) and not isinstance(curves, bool):
        indices = list(range(operator.index(curves)))
    else:
        indices = [operator.index(c) for c in curves]
    return [indices[i:i + chunk] for i in range(0, len(indices), chunk)]


def selection_height(archive: JPKArchive, curves: Iterable[int]) -> str:
    """The height channel :func:`jpk_to_curves` would choose for all of ``curves`` (headers only).

    Parameters
    ----------
    archive : JPKArchive
        The archive.
    curves : iterable of int
        Curve indices (non-negative).

    Returns
    -------
    str
        One of :data:`~viscoforce.io.curves.HEIGHT_CHANNELS`.
    """
    return _default_height([archive._units(i) for i in curves])


def _offset(da: xr.DataArray, by: int) -> xr.DataArray:
    """``da + by`` in ``da``'s dtype, with its attrs."""
    return da.copy(data=(da.values + by).astype(da.dtype))


def iter_curves(archive: JPKArchive, *, curves: int | Iterable[int] | None = None,
                chunk: int | None = None, height_channel: str | None = None,
                memory_bytes: int = DEFAULT_CHUNK_BYTES) -> Iterator[xr.Dataset]:
    """Curves datasets of consecutive chunks, numbered as the one dataset of all of them.

    Parameters
    ----------
    archive : JPKArchive
        An archive opened by :func:`viscoforce.io.jpk.read_jpk`.
    curves : int or iterable of int, optional
        Curves to read (as :func:`jpk_to_curves`); default all.
    chunk : int, optional
        Curves per chunk, >= 1; default :func:`chunk_size` of ``memory_bytes``.
    height_channel : str, optional
        As :func:`jpk_to_curves`; default the channel chosen for the whole selection.
    memory_bytes : int
        Memory budget of one chunk when ``chunk`` is not given [bytes].

    Returns
    -------
    iterator of xarray.Dataset
        Valid curves datasets, each read as the iteration reaches it; along ``sample``,
        ``curve`` and ``segment_table`` their concatenation equals
        ``jpk_to_curves(archive, curves=curves)``: ``segment`` and ``segment_curve`` count from
        the start of the selection, and every chunk has the selection's height channel.

    Raises
    ------
    ParameterError
        A bad archive, selection, chunk or ``height_channel``: when called, before any curve
        is decoded (not at the first chunk).
    """
    archive = _check_archive(archive)
    height_channel = check_height_channel(height_channel)  # before chunk_size decodes curve 0
    picked = _select(archive, curves)
    size = chunk_size(archive, memory_bytes=memory_bytes) if chunk is None else _check_chunk(chunk)
    height = height_channel if height_channel is not None else selection_height(archive, picked)
    return _chunks(archive, picked, size, height_channel, height)


def _chunks(archive: JPKArchive, picked: list[int], size: int, height_channel: str | None,
            height: str) -> Iterator[xr.Dataset]:
    """The chunks of :func:`iter_curves`, its options checked."""
    rows = segments = 0
    for indices in curve_chunks(picked, size):
        ds = jpk_to_curves(archive, curves=indices, height_channel=height_channel)
        if ds.attrs["height_channel"] != height:  # this chunk alone has a preferred sensor
            ds = jpk_to_curves(archive, curves=indices, height_channel=height)
        n_segments = ds.sizes["segment_table"]
        if rows or segments:
            ds = ds.assign(segment=_offset(ds["segment"], segments),
                           segment_curve=_offset(ds["segment_curve"], rows))
        rows += ds.sizes["curve"]
        segments += n_segments
        yield ds


def write_curves_netcdf(archive: JPKArchive, path: str | os.PathLike[str], *,
                        curves: int | Iterable[int] | None = None, chunk: int | None = None,
                        height_channel: str | None = None,
                        attrs: dict[str, object] | None = None,
                        memory_bytes: int = DEFAULT_CHUNK_BYTES) -> dict[str, object]:
    """Write the curves dataset of an archive to netCDF chunk by chunk (bounded memory).

    The file equals ``jpk_to_curves(archive, ...)`` written with ``to_netcdf`` (same variables,
    values, attributes; ``sample``, ``curve`` and ``segment_table`` are unlimited dimensions).
    It is written to a temporary file beside ``path`` and renamed only when complete; on any
    error no file appears at ``path`` (a previous file there is left as it was), nor does the
    temporary file stay (see :mod:`viscoforce._files`: a failed write, SIGTERM in the command
    line; one that SIGKILL left is removed by the next write of ``path``).

    Parameters
    ----------
    archive : JPKArchive
        An archive opened by :func:`viscoforce.io.jpk.read_jpk`.
    path : path
        The netCDF file (HDF5, engine h5netcdf).
    curves, chunk, height_channel, memory_bytes
        As :func:`iter_curves`.
    attrs : dict, optional
        Attributes added to (or replacing) the file's global attributes.

    Returns
    -------
    dict
        ``dims`` (name → size, in the dataset's order), ``variables`` (sorted data variable
        names), ``chunks`` (how many were written).

    Raises
    ------
    OSError
        The file cannot be written (disk full, a file-size limit): ``filename`` is ``path``.
    """
    # the options are checked here, before the file is opened (iter_curves checks when called)
    chunks = iter_curves(archive, curves=curves, chunk=chunk, height_channel=height_channel,
                         memory_bytes=memory_bytes)
    if attrs:
        chunks = (ds.assign_attrs(attrs) for ds in chunks)
    return write_netcdf_stream(chunks, path, append_dims=CURVE_DIMS)
