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
thread of its own while the main thread waits (:class:`_HDF5Thread`): an exception raised
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
import contextvars
import errno
import functools
import os
import queue
import re
import socket
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any, TypeVar

from viscoforce.exceptions import ParameterError

#: Largest netCDF image built in memory before writing [bytes]; beyond it the engine writes the
#: temporary file itself (still renamed into place only when complete).
NETCDF_IN_MEMORY = 1 << 30

_T = TypeVar("_T")


def _umask() -> int:
    current = os.umask(0)
    os.umask(current)
    return current


def _write_error(exc: OSError, path: str | os.PathLike[str]) -> OSError:
    """``exc`` (a failed write of the temporary file) as an error of writing ``path``."""
    if exc.errno is None:
        return exc
    return OSError(exc.errno, exc.strerror, os.fspath(path))


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


# ── what HDF5 writes through ─────────────────────────────────────────────────────────────────────

def _write_at(fd: int, data: memoryview, offset: int) -> int:
    if hasattr(os, "pwrite"):
        return os.pwrite(fd, data, offset)
    os.lseek(fd, offset, os.SEEK_SET)  # pragma: no cover - Windows
    return os.write(fd, data)  # pragma: no cover


def _read_at(fd: int, size: int, offset: int) -> bytes:
    if hasattr(os, "pread"):
        return os.pread(fd, size, offset)
    os.lseek(fd, offset, os.SEEK_SET)  # pragma: no cover - Windows
    return os.read(fd, size)  # pragma: no cover


class _HDF5Output:
    """The temporary file as HDF5 sees it (h5py's ``fileobj`` driver): no call of it fails.

    h5py calls ``seek`` and ``tell``, ``readinto``, ``write``, ``truncate`` and ``flush`` from
    inside HDF5. The first :class:`OSError` of a write (or a read) is kept (:attr:`error`); from
    then on, and after :meth:`close`, what HDF5 writes is kept in memory and read back from there
    (so HDF5 sees the file it wrote), and the disk is left alone. :meth:`check` raises the error,
    as an error of writing the target, between two HDF5 calls.
    """

    def __init__(self, tmp: Path, target: str | os.PathLike[str]) -> None:
        self._fd: int | None = os.open(tmp, os.O_RDWR | getattr(os, "O_BINARY", 0))
        self._target = os.fspath(target)
        self._position = 0
        self._size = os.fstat(self._fd).st_size  # the file's end as HDF5 sees it
        self._kept: list[tuple[int, bytes]] = []  # (offset, bytes) not on disk, oldest first
        self._reported = False
        #: The first failed write or read of the disk (None: none failed).
        self.error: OSError | None = None

    def __repr__(self) -> str:  # HDF5's name of the file
        return f"<netCDF output {self._target!r}>"

    def _on_disk(self) -> bool:
        return self.error is None and self._fd is not None

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        base = {os.SEEK_SET: 0, os.SEEK_CUR: self._position, os.SEEK_END: self._size}[whence]
        self._position = base + offset
        return self._position

    def tell(self) -> int:
        return self._position

    def readinto(self, buffer: Any) -> int:
        view = memoryview(buffer).cast("B")
        start, size = self._position, len(view)
        got = 0
        if self._fd is not None:
            try:
                while got < min(size, self._size - start):
                    data = _read_at(self._fd, min(size, self._size - start) - got, start + got)
                    if not data:
                        break
                    view[got:got + len(data)] = data
                    got += len(data)
            except OSError as exc:
                self.error = self.error or exc
        view[got:] = bytes(size - got)  # beyond the end: zeros, as HDF5's own drivers read
        for offset, data in self._kept:
            low, high = max(offset, start), min(offset + len(data), start + size)
            if low < high:
                view[low - start:high - start] = data[low - offset:high - offset]
        self._position = start + size
        return size

    def read(self, size: int = -1) -> bytes:
        buffer = bytearray(max(self._size - self._position, 0) if size < 0 else size)
        self.readinto(buffer)
        return bytes(buffer)

    def write(self, data: Any) -> int:
        view = memoryview(data).cast("B")
        start, size = self._position, len(view)
        if self._on_disk():
            try:
                done = 0
                while done < size:
                    written = _write_at(self._fd, view[done:], start + done)
                    if written <= 0:
                        raise OSError(errno.EIO, os.strerror(errno.EIO))  # no progress
                    done += written
            except OSError as exc:
                self.error = exc
        if not self._on_disk():
            end = start + size
            self._kept = [(o, d) for o, d in self._kept if o < start or o + len(d) > end]
            self._kept.append((start, bytes(view)))
        self._position = start + size
        self._size = max(self._size, self._position)
        return size

    def truncate(self, size: int | None = None) -> int:
        size = self._position if size is None else size
        if self._on_disk():
            try:
                os.ftruncate(self._fd, size)
            except OSError as exc:
                self.error = exc
        self._size = size
        self._kept = [(o, d[:size - o]) for o, d in self._kept if o < size]
        return size

    def flush(self) -> None:
        """Nothing: :func:`atomic_output` flushes the file to disk before renaming it."""

    def close(self) -> None:
        """Close the file (HDF5 has closed it: h5py closes every object of a file it closes)."""
        if self._fd is not None:
            fd, self._fd = self._fd, None
            os.close(fd)

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # at interpreter exit, os may be gone: the system closes it anyway
            pass

    def check(self) -> None:
        """Raise the failed write, as an error of writing the target (once)."""
        if self.error is not None and not self._reported:
            self._reported = True
            raise _write_error(self.error, self._target) from self.error


class _Job:
    """One call into HDF5 for :class:`_HDF5Thread`; ``finished`` is released when it is done."""

    def __init__(self, call: Callable[[], Any]) -> None:
        self.call: Callable[[], Any] | None = call
        self.context = contextvars.copy_context()  # numpy's errstate and the like, as the caller's
        self.claimed = self.cancelled = self.done = False
        self.outcome: tuple[bool, Any] | None = None
        self.finished = threading.Lock()
        self.finished.acquire()


class _HDF5Thread:
    """A thread of its own that makes the calls into HDF5 of one writer, one at a time.

    In the main thread a signal handler may raise at any time; in another thread the methods of
    :class:`_HDF5Output` that HDF5 calls never see its exception. :meth:`run` hands a call over
    and waits for it; an exception raised meanwhile (or while handing over) is raised once the
    call has returned, or at once if it had not started (then it never does). Only C-level
    primitives are waited on (a lock, a queue): a ``Thread.join`` or an ``Event.wait`` that
    such an exception interrupts may get their state wrong (Python < 3.13 marks a thread that
    runs on as ended: the process would exit with HDF5 mid-call in it, holding h5py's lock).
    """

    def __init__(self) -> None:
        self._inbox: queue.SimpleQueue[_Job | None] | None = None

    @staticmethod
    def _serve(inbox: queue.SimpleQueue[_Job | None]) -> None:
        while (job := inbox.get()) is not None:
            if job.claimed:
                continue  # handed over again by an interrupted caller: done already
            job.claimed = True
            try:
                if not job.cancelled and job.call is not None:
                    job.outcome = (True, job.context.run(job.call))
            except BaseException as exc:  # handed to the waiting thread, raised there
                job.outcome = (False, exc)
            finally:
                job.call = None
                job.done = True
                job.finished.release()

    def run(self, call: Callable[[], _T], *, undo: Callable[[_T], object] | None = None) -> _T:
        """``call()``, made in the thread; this one waits for it.

        ``undo(result)`` is made too (e.g. closing the file ``call`` opened, which the caller
        never gets) when an exception raised while waiting takes the result's place. Outside the
        main thread (no signal handler runs there) ``call`` is made in this thread.
        """
        if threading.current_thread() is not threading.main_thread():
            return call()
        inbox = self._inbox
        if inbox is None:  # a daemon: one a signal left waiting must not keep the process alive
            inbox = queue.SimpleQueue()
            try:
                threading.Thread(target=self._serve, args=(inbox,), name="viscoforce-hdf5-write",
                                 daemon=True).start()
                self._inbox = inbox
            except BaseException:  # started or not: nothing to wait for, and it ends if it runs
                self._inbox = None
                inbox.put(None)
                raise
        job = _Job(call)
        interrupted: BaseException | None = None
        while not job.done:
            try:
                if interrupted is not None:
                    job.cancelled = True  # not started yet: never started
                inbox.put(job)  # at least once; a repeat is ignored
                while not job.done:
                    job.finished.acquire()
            except BaseException as exc:  # a signal handler's: raised below, HDF5 being done
                interrupted = interrupted or exc
        if interrupted is not None:
            if undo is not None and job.outcome is not None and job.outcome[0]:
                with contextlib.suppress(Exception):  # the interruption is what is reported
                    self.run(functools.partial(undo, job.outcome[1]))
            raise interrupted
        assert job.outcome is not None  # not cancelled: nothing interrupted
        done, value = job.outcome
        if not done:
            raise value
        return value

    def stop(self) -> None:
        """Let the thread end (it waits for calls otherwise)."""
        if self._inbox is not None:
            inbox, self._inbox = self._inbox, None
            inbox.put(None)


@contextlib.contextmanager
def _hdf5_output(tmp: Path, target: str | os.PathLike[str]
                 ) -> Iterator[tuple[_HDF5Output, Callable[..., Any]]]:
    """An :class:`_HDF5Output` on ``tmp`` and :meth:`_HDF5Thread.run` to make HDF5 calls with.

    The output is checked when the writer is done: a failed write is raised in place of an
    :class:`Exception` that followed it (its cause). It is closed on success; on an error, when
    the last reference goes (HDF5 may still hold one, e.g. for an object an exception's traceback
    keeps: it must go on reading what it wrote).
    """
    out = _HDF5Output(tmp, target)
    thread = _HDF5Thread()
    try:
        yield out, thread.run
        out.check()
    except Exception:
        out.check()
        raise
    finally:
        thread.stop()
    out.close()


# ── netCDF ───────────────────────────────────────────────────────────────────────────────────────

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
        write_bytes(path, ds.to_netcdf(engine=engine))
        return
    with atomic_output(path) as tmp:
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
    with atomic_output(path) as tmp, _hdf5_output(tmp, path) as (out, hdf5):
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
