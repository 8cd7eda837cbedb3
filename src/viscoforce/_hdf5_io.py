"""HDF5 writes that never fail inside HDF5 (:mod:`viscoforce._files` writes netCDF through them).

HDF5 writes much of its data late, when an object is closed, which h5py does when the Python
object is garbage collected, where an error can only be printed and ignored; the objects such a
failure leaves half-closed crash HDF5 (SIGSEGV) at its next walk over the open objects. So HDF5
writes through :class:`_HDF5Output` (h5py's ``fileobj`` driver), which keeps the first
:class:`OSError`, keeps what HDF5 writes after it in memory and reads it back from there, and the
writer raises the error after the HDF5 call returns; the calls run in one thread of their own
(:class:`_HDF5Thread`), so that a signal handler's exception is never raised inside them. The
whole story: :mod:`viscoforce._files`' module docstring.
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import functools
import os
import queue
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

_T = TypeVar("_T")


def _write_error(exc: OSError, path: str | os.PathLike[str]) -> OSError:
    """``exc`` (a failed write of the temporary file) as an error of writing ``path``."""
    if exc.errno is None:
        return exc
    return OSError(exc.errno, exc.strerror, os.fspath(path))


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
