"""A write that fails or is stopped leaves no debris and no crash (issue 40, item 4).

``viscoforce load MAP --raw --out FILE`` streams the curves into a temporary file beside FILE
(viscoforce._files). A file-size limit or a full disk mid-write is exit 2 with one line naming
the file; SIGTERM removes the temporary file; a temporary file left by a killed writer is
removed by the next write to the same target. The children run the real command line on the
bundled real map; where a child must be caught mid-write it waits on its stdin (no sleeping, no
time asserted); waits on children are bounded only as a guard against a hang.
"""

from __future__ import annotations

import errno
import os
import resource
import select
import signal
import subprocess
import sys

import numpy as np
import pytest
import xarray as xr
from h5py import h5f

from viscoforce._files import atomic_output, write_netcdf_stream
from viscoforce.cli import main
from viscoforce.data import example_path
from viscoforce.io.jpk import read_jpk
from viscoforce.io.stream import CURVE_DIMS, iter_curves, write_curves_netcdf

MAP = example_path("real/modulation-map.jpk-force-map")  # 16 curves, 14.7 MB of raw netCDF
#: Curves per chunk where several chunks are needed (the map is one chunk otherwise): one curve,
#: 0.9 MB of raw netCDF, so that a child caught after its first chunk has read one or two curves
#: (at 4 it read 4 to 12 of them, the same steps on more data).
CHUNK = 1
#: Guard against a hung child [s]; a healthy one exits in a few seconds.
HANG_GUARD = 300
PREVIOUS = b"the previous output, which must survive"

#: ``viscoforce`` with at most CHUNK curves per chunk, so that the map is written in 16 chunks.
CHUNKED = """
import sys
import viscoforce.io.stream as stream
stream.MAX_CHUNK = int(sys.argv[1])
from viscoforce.cli import main
sys.exit(main(sys.argv[2:]))
"""

#: ``viscoforce`` in chunks of CHUNK curves that prints "waiting" and waits for a line on stdin
#: before reading the second chunk ("between": the first chunk is in the temporary file) or
#: inside the writing of it ("inside": HDF5 is appending).
WAITING = """
import sys
import viscoforce._files as files
import viscoforce.io.stream as stream
stream.MAX_CHUNK = int(sys.argv[2])

def wait():
    print("waiting", flush=True)
    sys.stdin.readline()

if sys.argv[1] == "between":
    read = stream.jpk_to_curves
    def jpk_to_curves(*args, **kwargs):
        if min(kwargs["curves"]) >= stream.MAX_CHUNK:
            wait()
        return read(*args, **kwargs)
    stream.jpk_to_curves = jpk_to_curves
else:
    append = files._append
    def _append(*args, **kwargs):
        wait()
        return append(*args, **kwargs)
    files._append = _append
from viscoforce.cli import main
sys.exit(main(sys.argv[3:]))
"""


def _names(folder):
    return sorted(p.name for p in folder.iterdir())


def _open_hdf5():
    """HDF5 files, datasets, groups and attributes open in this process."""
    return h5f.get_obj_count(h5f.OBJ_ALL, h5f.OBJ_FILE | h5f.OBJ_DATASET | h5f.OBJ_GROUP
                             | h5f.OBJ_ATTR)


def _limited(limit):
    def preexec():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return preexec


@pytest.fixture(scope="module")
def sizes(tmp_path_factory):
    """Bytes of the raw netCDF of the first chunk alone, and of the first two chunks."""
    folder = tmp_path_factory.mktemp("sizes")
    with read_jpk(MAP) as archive:
        write_curves_netcdf(archive, folder / "first.nc", curves=range(CHUNK))
        write_curves_netcdf(archive, folder / "two.nc", curves=range(2 * CHUNK), chunk=CHUNK)
    return (folder / "first.nc").stat().st_size, (folder / "two.nc").stat().st_size


def _check_refused(run, folder):
    """Exit 2, one line naming --out and the OS error, no traceback, good.nc as it was."""
    assert run.returncode == 2, (run.returncode, run.stderr[-3000:])
    assert "Traceback" not in run.stderr and "Exception ignored" not in run.stderr, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1, run.stderr
    assert lines[0].startswith("viscoforce load: error: --out good.nc: could not write (File "
                               "too large)"), lines
    assert _names(folder) == ["good.nc"]
    assert (folder / "good.nc").read_bytes() == PREVIOUS


# ── a file-size limit ────────────────────────────────────────────────────────────────────────────

def test_size_limit_within_the_first_chunk_is_a_clean_error(tmp_path, sizes):
    """The reproduction of issue 40: exit 139 (SIGSEGV in h5py) and a part file left, before."""
    first, _ = sizes
    (tmp_path / "good.nc").write_bytes(PREVIOUS)
    run = subprocess.run([sys.executable, "-m", "viscoforce", "load", str(MAP), "--raw", "--out",
                          "good.nc"], cwd=tmp_path, capture_output=True, text=True, check=False,
                         preexec_fn=_limited(first // 2), timeout=HANG_GUARD)
    _check_refused(run, tmp_path)


def test_size_limit_after_the_first_chunk_is_a_clean_error(tmp_path, sizes):
    first, two = sizes
    limit = first + (two - first) // 2  # the first chunk fits, the second does not
    (tmp_path / "good.nc").write_bytes(PREVIOUS)
    run = subprocess.run([sys.executable, "-c", CHUNKED, str(CHUNK), "load", str(MAP), "--raw",
                          "--out", "good.nc"], cwd=tmp_path, capture_output=True, text=True,
                         check=False, preexec_fn=_limited(limit), timeout=HANG_GUARD)
    _check_refused(run, tmp_path)


def test_disk_full_mid_stream_is_an_oserror_naming_the_file(tmp_path, monkeypatch):
    """ENOSPC after 1 MB (in the second chunk), in this process: an OSError naming the target,
    nothing left (no part file, no HDF5 object open), and the next write works (HDF5 saw no
    failed write; pytest turns an error printed and ignored in a destructor into a failure).
    Four curves are written: the four chunks after the first are the same steps."""
    target = tmp_path / "curves.nc"
    target.write_bytes(PREVIOUS)
    open_before = _open_hdf5()
    written = [0]
    pwrite = os.pwrite

    def full_disk(fd, data, offset):
        if written[0] + len(data) > 2**20:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        written[0] += len(data)
        return pwrite(fd, data, offset)

    with read_jpk(MAP) as archive:
        monkeypatch.setattr(os, "pwrite", full_disk)
        with pytest.raises(OSError, match="No space left on device") as caught:
            write_netcdf_stream(iter_curves(archive, curves=range(4), chunk=CHUNK), target,
                                append_dims=CURVE_DIMS)
        monkeypatch.undo()
        assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(target)
        assert _names(tmp_path) == ["curves.nc"] and target.read_bytes() == PREVIOUS
        assert _open_hdf5() == open_before
        summary = write_netcdf_stream(iter_curves(archive, curves=range(4), chunk=CHUNK),
                                      target, append_dims=CURVE_DIMS)
    assert summary["chunks"] == 4 and _names(tmp_path) == ["curves.nc"]
    with xr.open_dataset(target, engine="h5netcdf") as ds:
        assert ds.sizes["curve"] == 4 and np.isfinite(ds["force"].values).all()


# ── SIGTERM ──────────────────────────────────────────────────────────────────────────────────────

@pytest.mark.parametrize("where", ["between", "inside"])
def test_sigterm_mid_write_removes_the_part_file(tmp_path, where):
    """SIGTERM between two chunks, or while HDF5 appends one: exit 143, no part file, the old
    output intact (before: killed by the signal, the part file left for ever)."""
    (tmp_path / "good.nc").write_bytes(PREVIOUS)
    child = subprocess.Popen([sys.executable, "-c", WAITING, where, str(CHUNK), "load", str(MAP),
                              "--raw", "--out", "good.nc"], cwd=tmp_path, stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        ready, _, _ = select.select([child.stdout], [], [], HANG_GUARD)
        assert ready, f"the child did not reach the second chunk within {HANG_GUARD} s"
        assert child.stdout.readline() == "waiting\n", child.communicate()
        parts = [p for p in tmp_path.iterdir() if p.name != "good.nc"]
        assert len(parts) == 1 and parts[0].name.startswith(".good.nc.")
        assert parts[0].name.endswith(".part.nc") and parts[0].stat().st_size > 0
        child.send_signal(signal.SIGTERM)
        child.stdin.write("\n")  # let the step it waits in finish (it must, before exiting)
        child.stdin.flush()
        _, err = child.communicate(timeout=HANG_GUARD)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the child did not exit within {HANG_GUARD} s of SIGTERM")
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == 143, (child.returncode, err[-3000:])
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert err.strip().splitlines() == ["viscoforce load: stopped by SIGTERM"]
    assert _names(tmp_path) == ["good.nc"]
    assert (tmp_path / "good.nc").read_bytes() == PREVIOUS


def test_main_turns_sigterm_into_an_exit_only_while_it_runs(monkeypatch):
    """SIGTERM's default (kill) is replaced inside main only; a handler someone set stays."""
    import viscoforce.cli as cli

    seen = []
    monkeypatch.setattr(cli, "_run", lambda args: seen.append(signal.getsignal(signal.SIGTERM)) or 0)
    previous = signal.signal(signal.SIGTERM, signal.SIG_DFL)
    try:
        assert main(["load", "spectrum.csv"]) == 0
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL
        assert callable(seen[-1])
        with pytest.raises(SystemExit) as stopped:
            seen[-1](signal.SIGTERM, None)
        assert stopped.value.code == 143

        def theirs(signum, frame):
            pass

        signal.signal(signal.SIGTERM, theirs)
        assert main(["load", "spectrum.csv"]) == 0
        assert seen[-1] is theirs and signal.getsignal(signal.SIGTERM) is theirs
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_importing_changes_no_signal_setting():
    script = ("import signal\n"
              "before = [signal.getsignal(s) for s in signal.valid_signals()]\n"
              "import viscoforce, viscoforce.cli, viscoforce.cli.analysis, viscoforce._files\n"
              "import viscoforce.io.stream\n"
              "assert [signal.getsignal(s) for s in signal.valid_signals()] == before\n")
    subprocess.run([sys.executable, "-c", script], check=True, timeout=HANG_GUARD)


# ── what SIGKILL leaves ──────────────────────────────────────────────────────────────────────────

def _dead_pid():
    child = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                           capture_output=True, text=True, check=True)
    return int(child.stdout)


def test_stale_part_file_of_a_dead_writer_is_removed_by_the_next_write(tmp_path):
    target = tmp_path / "out.nc"
    with atomic_output(target) as tmp:
        tmp.write_bytes(b"first")
    ours = f".out.nc.{os.getpid()}"
    assert tmp.name.startswith(ours) and tmp.name.endswith(".part.nc"), tmp.name
    rest = tmp.name[len(ours):]  # "@{host}.{random}.part.nc"
    assert rest.startswith("@"), tmp.name
    after_host = rest[rest.index("."):]
    dead = _dead_pid()
    stale = tmp_path / f".out.nc.{dead}{rest}"
    alive = tmp_path / tmp.name  # this process is alive: it may be writing it
    other = tmp_path / f".other.nc.{dead}{rest}"  # another target's
    remote = tmp_path / f".out.nc.{dead}@elsewhere-0{after_host}"  # its PID means nothing here
    foreign = tmp_path / ".out.nc.abc123xy.part.nc"  # no writer named: not ours to judge
    kept = (alive, other, remote, foreign)
    for p in (stale, *kept):
        p.write_bytes(b"half a file")
    with atomic_output(target) as tmp:
        tmp.write_bytes(b"second")
    assert not stale.exists()
    assert all(p.exists() for p in kept)
    assert target.read_bytes() == b"second"
