"""Atomic file outputs: write beside the target, rename into place only when complete.

Every file viscoforce writes (netCDF, CSV, figures, JPK archives, the demo's JSON) goes through
:func:`atomic_output`: the data go to a temporary file in the target's own folder (same file
system, so the final :func:`os.replace` is atomic), which is flushed to disk and renamed over the
target only when the writer returned. A writer that fails (disk full, a file-size limit, an
exception) leaves the temporary file deleted and any previous file at the target untouched; two
processes writing one target each rename a complete file, so the survivor is whole (the last
rename wins), never a mixture or a truncated file. A failed write is an :class:`OSError` whose
``filename`` is the target as given (``[Errno 27] File too large: 'good.nc'``).

netCDF files are made in memory first (:func:`write_netcdf`) and written with plain file I/O.
A dataset over :data:`NETCDF_IN_MEMORY`, and one written chunk by chunk because it is too big to
hold at once (the raw curves of a big map, :func:`write_netcdf_stream`), are written by HDF5 itself
into the temporary file, renamed likewise only when complete. HDF5 must never see a failed write:
it writes much of its data late, when an object is closed, which h5py does when the Python object
is garbage collected, where an error can only be printed and ignored; the objects such a failure
leaves half-closed crash HDF5 (SIGSEGV) at its next walk over the open objects. So HDF5 writes
through a file object of this module (h5py's ``fileobj`` driver) that keeps the first
:class:`OSError`, keeps what HDF5 writes after it in memory and reads it back from there, so that
HDF5 goes on with a consistent file; the writer raises the error (as an error of the target) as
soon as that HDF5 call returns, and every HDF5 file is closed before the temporary file is
removed. What is kept is what HDF5 writes in that call after the failure: about one chunk for a
stream, up to the rest of the dataset for :func:`write_netcdf` of one over
:data:`NETCDF_IN_MEMORY`.

Signals. A signal handler that raises (Ctrl-C's :class:`KeyboardInterrupt`, the command line's
SIGTERM exit) would be a failed write too if it ran inside that file object's methods, which HDF5
calls. Python runs signal handlers in the main thread only, so a writer makes its HDF5 calls in a
thread of its own while the main thread waits (:class:`viscoforce._hdf5_io._HDF5Thread`): an exception raised
meanwhile is raised as soon as that call has returned (within one chunk's write), then the
temporary file is removed as for any error. SIGTERM's default action kills the process at once;
:func:`viscoforce.cli.main` makes it such an exception (exit status 143), a library caller who
wants the same installs a handler of its own that raises; this module changes no signal setting.

SIGKILL (or a power cut) cannot be caught: the temporary file stays. Its name,
``.{name}.{pid}@{host}.{random}.part{suffix}``, says which process on which host wrote it, and the
next :func:`atomic_output` to the same target from the same host removes those of that target
whose process is gone (``os.kill(pid, 0)`` finds no such process). Never removed: a file of
another target, of another host (a folder shared over the network: a PID means nothing on another
host), of a process that is alive, or named otherwise. A dead writer's PID that the system has
given to another, live process keeps its file until that one ends too (a file left a while
longer, never a live writer's file removed); on Windows (where ``os.kill`` would end the process)
nothing is removed.
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import socket
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, TypeVar

from viscoforce._hdf5_io import _hdf5_output, _write_error
from viscoforce.exceptions import ParameterError

#: Largest netCDF image built in memory before writing [bytes]; beyond it the engine writes the
#: temporary file itself (still renamed into place only when complete).
NETCDF_IN_MEMORY = 1 << 30

_T = TypeVar("_T")


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


# ── temporary files ──────────────────────────────────────────────────────────────────────────────

@functools.cache
def _host() -> str:
    """The host's name in temporary file names: its first label, letters, digits and ``-``."""
    name = re.sub(r"[^A-Za-z0-9-]", "-", socket.gethostname().split(".")[0])[:40]
    return name or "localhost"


def _alive(pid: int) -> bool:
    """Whether process ``pid`` may be running (True when it cannot be told)."""
    if os.name != "posix" or pid <= 0:  # Windows' os.kill(pid, 0) would end the process
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):  # PermissionError: someone else's, alive
        return True
    return True


def _remove_stale(folder: Path, name: str, suffix: str) -> None:
    """Remove the temporary files of ``name`` left in ``folder`` by dead processes of this host."""
    pattern = re.compile(rf"\.{re.escape(name)}\.(\d+)@{re.escape(_host())}\.[A-Za-z0-9_]+"
                         rf"\.part{re.escape(suffix)}")
    prefix = f".{name}."
    with contextlib.suppress(OSError), os.scandir(folder) as entries:
        for entry in entries:
            if not entry.name.startswith(prefix):
                continue
            match = pattern.fullmatch(entry.name)
            if match and not _alive(int(match[1])) and entry.is_file(follow_symlinks=False):
                with contextlib.suppress(OSError):  # gone already, or not ours to remove
                    os.unlink(entry.path)


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success rename it to ``path``.

    The temporary file, ``.{name}.{pid}@{host}.{random}.part{suffix}``, keeps ``path``'s suffix
    (writers that pick a format from it still do) and gets the permissions a new file would (the
    umask). Whatever the writer raises propagates, after the temporary file is removed; ``path``
    is then exactly as before. Temporary files of ``path`` left by processes of this host that no
    longer run (killed by SIGKILL) are removed first (see the module's docstring).

    Parameters
    ----------
    path : path
        The final file.

    Yields
    ------
    pathlib.Path
        Where to write (an empty file that exists).

    Raises
    ------
    OSError
        The temporary file cannot be made, flushed (a full disk shows there on some file
        systems) or renamed; ``filename`` is ``path``.
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    _remove_stale(folder, target.name, target.suffix)
    try:
        fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.{os.getpid()}@{_host()}.",
                                        suffix=f".part{target.suffix}", dir=folder)
    except OSError as exc:
        raise _write_error(exc, path) from exc
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        os.chmod(tmp, 0o666 & ~_umask())
        yield tmp
        try:
            with open(tmp, "rb+") as handle:  # on disk before the rename makes it visible
                os.fsync(handle.fileno())
            os.replace(tmp, target)
        except OSError as exc:
            raise _write_error(exc, path) from exc
    except BaseException:
        _remove(tmp)
        raise


def _remove(path: Path) -> None:
    """Remove ``path`` if it exists, even if a signal handler raises meanwhile (a second Ctrl-C)."""
    while True:
        try:
            path.unlink()
        except OSError:  # removed (perhaps by the previous try), or cannot be
            return
        except BaseException:  # the first interruption is the one propagating: remove first
            continue
        return


def write_bytes(path: str | os.PathLike[str], data: bytes | memoryview) -> None:
    """Write ``data`` to ``path`` atomically (:func:`atomic_output`).

    Raises
    ------
    OSError
        The data cannot be written (``filename`` is ``path``).
    """
    with atomic_output(path) as tmp:
        try:
            with open(tmp, "wb") as handle:
                handle.write(data)
        except OSError as exc:
            raise _write_error(exc, path) from exc


def write_text(path: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically (:func:`atomic_output`)."""
    write_bytes(path, text.encode("utf-8"))


# ── netCDF ───────────────────────────────────────────────────────────────────────────────────────

@contextlib.contextmanager
def dask_unasked() -> Iterator[None]:
    """Keep xarray's ``to_netcdf`` from importing dask.distributed to ask for a scheduler.

    xarray looks up the dask scheduler on every write (for its lock) and imports
    dask.distributed to see whether it is a ``Client``: ~0.2-0.6 s for a command that never
    uses it. Where ``distributed`` is not imported yet no Client exists, so the answer is known:
    inside the block ``import distributed`` raises ImportError (``sys.modules["distributed"] =
    None``), which xarray takes as "not distributed". Where it is imported (a map on a
    cluster), nothing changes.
    """
    import sys

    if "distributed" in sys.modules:
        yield
        return
    sys.modules["distributed"] = None  # type: ignore[assignment]
    try:
        yield
    finally:
        if "distributed" in sys.modules and sys.modules["distributed"] is None:
            del sys.modules["distributed"]


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

    Raises
    ------
    OSError
        The file cannot be written (disk full, a file-size limit: ``filename`` is ``path``);
        ``path`` is left as it was.
    """
    if engine not in ("h5netcdf", "scipy"):
        raise ParameterError(f"engine must be 'h5netcdf' or 'scipy', got {engine!r}")
    if int(getattr(ds, "nbytes", 0)) <= NETCDF_IN_MEMORY:
        with dask_unasked():
            data = ds.to_netcdf(engine=engine)
        write_bytes(path, data)
        return
    with atomic_output(path) as tmp, dask_unasked():
        if engine == "scipy":  # pure Python I/O: a failed write is an OSError there
            ds.to_netcdf(tmp, engine=engine)
            return
        with _hdf5_output(tmp, path) as (out, hdf5):
            hdf5(functools.partial(ds.to_netcdf, out, engine=engine))


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
    producer leaves no file at ``path`` (a previous file there is left untouched). The chunks
    are made in the calling thread, HDF5 writes each in a thread of its own: see the module's
    docstring for a failed write (an :class:`OSError`, HDF5 never sees it) and for signals (an
    exception a handler raises is raised once the chunk being written is in).

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
    OSError
        The file cannot be written (disk full, a file-size limit: ``filename`` is ``path``).
    """
    import h5netcdf

    dims = tuple(append_dims)
    iterator = iter(chunks)
    with atomic_output(path) as tmp, _hdf5_output(tmp, path) as (out, hdf5), dask_unasked():
        first = next(iterator, None)
        if first is None:
            raise ParameterError("write_netcdf_stream needs at least one chunk")
        sizes = {str(k): int(v) for k, v in first.sizes.items()}
        variables = sorted(str(v) for v in first.data_vars)
        hdf5(functools.partial(
            first.to_netcdf, out, engine="h5netcdf",
            unlimited_dims=[d for d in dims if d in first.dims],
            encoding=_stream_encoding(first, dims)))
        out.check()
        count = 1
        del first
        handle = hdf5(functools.partial(h5netcdf.File, out, "a"),
                      undo=lambda opened: opened.close())
        try:
            for ds in iterator:
                hdf5(functools.partial(_append, handle, ds, dims, count))
                out.check()
                for d in dims:
                    if d in ds.dims:
                        sizes[d] += int(ds.sizes[d])
                count += 1
                del ds
        finally:
            hdf5(handle.close)
    return {"dims": sizes, "variables": variables, "chunks": count}
