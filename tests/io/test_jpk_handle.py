"""JPKArchive: central directory parsed once, one file handle kept, not pickled, shared by threads."""

from __future__ import annotations

import dataclasses
import io
import pickle
import threading
import zipfile
from pathlib import Path

import numpy as np
import pytest

import viscoforce.io.jpk as jpk
from tests.io.test_jpk import _serialise, build_members, check_synthetic_curve, write, zip_bytes
from viscoforce.io.curves import jpk_to_curves
from viscoforce.io.jpk import InstrumentFormatError, read_jpk


@pytest.fixture
def map_file(tmp_path):
    return write(tmp_path / "map.jpk-force-map", build_members("force-map"))


@pytest.fixture
def opens(monkeypatch):
    """Every zip opened by io.jpk, in order (the file path or ``bytes`` for a member archive)."""
    seen: list[str] = []
    original = jpk._open_zip

    def counting(source, where):
        seen.append(str(source) if not hasattr(source, "getbuffer") else "bytes")
        return original(source, where)

    monkeypatch.setattr(jpk, "_open_zip", counting)
    return seen


def _same_curves(a: jpk.JPKCurve, b: jpk.JPKCurve) -> None:
    assert (a.index, a.source, a.x, a.y) == (b.index, b.source, b.x, b.y)
    for sa, sb in zip(a.segments, b.segments, strict=True):
        for name, values in sa.channels.items():
            np.testing.assert_array_equal(values, sb.channels[name], err_msg=name)


def test_the_member_index_serves_every_curve(map_file, opens):
    archive = read_jpk(map_file)
    assert archive._handles.outer is None          # nothing opened before the first read
    for i in (2, 0, 3, 1, -1):
        check_synthetic_curve(archive.curve(i), i % 4)
    handle = archive._handles.outer._fp
    assert [c.index for c in archive.curves()] == [0, 1, 2, 3]
    jpk_to_curves(archive, curves=[1, 3])
    assert archive._handles.outer._fp is handle    # one file handle for every read
    assert opens == [str(map_file)]               # the central directory is parsed once
    archive.close()
    assert handle.closed


def test_an_archive_without_index_builds_one_on_first_read(map_file, opens):
    archive = read_jpk(map_file)
    bare = dataclasses.replace(archive, _index=None)
    _same_curves(bare.curve(2), archive.curve(2))
    bare.curve(3)
    assert opens == [str(map_file)] * 2            # read_jpk's scan, then bare's one parse
    bare.close()
    archive.close()


def test_close_and_context_manager_then_lazy_reopen(map_file, opens):
    with read_jpk(map_file) as archive:
        archive.curve(0)
    assert archive._handles.outer is None          # closed on leaving the block
    archive.close()                                # idempotent
    check_synthetic_curve(archive.curve(1), 1)     # reopened on demand ...
    archive.curve(2)
    assert opens == [str(map_file)]                # ... without parsing the directory again
    archive.close()


def test_pickled_archive_carries_no_handle_and_reopens_once(map_file, opens):
    archive = read_jpk(map_file)
    first = archive.curve(1)
    assert archive._handles.outer is not None
    clone = pickle.loads(pickle.dumps(archive))
    assert clone._handles.outer is None and clone._lock is not archive._lock
    assert clone._index.rows == archive._index.rows
    assert (clone.kind, clone.n_curves, clone.grid, clone.metadata) == (
        archive.kind, archive.n_curves, archive.grid, archive.metadata)
    _same_curves(clone.curve(1), first)
    clone.curve(3)
    assert opens == [str(map_file)]                # the index travels: no second parse
    archive.close()
    clone.close()


def test_threads_share_one_archive(map_file):
    archive = read_jpk(map_file)
    want = [archive.curve(i) for i in range(4)]
    got: dict[int, list[jpk.JPKCurve]] = {}
    errors: list[BaseException] = []

    def work(k: int) -> None:
        try:
            got[k] = [archive.curve(i) for i in (k, (k + 1) % 4, (k + 2) % 4, (k + 3) % 4) * 5]
        except BaseException as exc:  # noqa: BLE001 - re-raised in the main thread
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for curves in got.values():
        for curve in curves:
            _same_curves(curve, want[curve.index])
    archive.close()


def test_zip_of_archives_keeps_one_member_open(tmp_path, opens):
    members = {"a/curve-1.jpk-force": zip_bytes(build_members("force")),
               "b/map.jpk-force-map": zip_bytes(build_members("force-map"))}
    path = write(tmp_path / "set.zip", members)
    archive = read_jpk(path)
    scan = len(opens)                              # the file and each member, scanned once
    check_synthetic_curve(archive.curve(2), 1)
    check_synthetic_curve(archive.curve(3), 2)     # same member: no new open
    check_synthetic_curve(archive.curve(0), 0)     # other member: one more
    assert opens[scan:] == ["bytes", "bytes"]
    assert archive._handles.inner[0] == "a/curve-1.jpk-force"
    archive.close()
    assert archive._handles.inner is None and archive._handles.outer is None


def test_a_file_removed_after_close_is_reported(map_file):
    archive = read_jpk(map_file)
    archive.close()
    map_file.unlink()
    with pytest.raises(InstrumentFormatError, match=r"map\.jpk-force-map: no such file \(moved or deleted"):
        archive.curve(0)


# ── the direct member reader (one seek + read per member) ─────────────────────────────────────


def _stored(members) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_STORED) as zf:
        for name, content in members.items():
            zf.writestr(name, content if isinstance(content, bytes) else _serialise(content))
    return buffer.getvalue()


def test_stored_members_decode_like_deflated_ones(tmp_path, map_file):
    stored = tmp_path / "stored.jpk-force-map"
    stored.write_bytes(_stored(build_members("force-map")))
    with read_jpk(stored) as a, read_jpk(map_file) as b:
        for i in range(4):
            _same_curves(a.curve(i), b.curve(i))


def _damaged(tmp_path, edit) -> Path:
    data = bytearray(_stored(build_members("force")))
    with zipfile.ZipFile(io.BytesIO(bytes(data))) as zf:
        info = zf.getinfo("segments/1/channels/vDeflection.dat")
    edit(data, info)
    path = tmp_path / "damaged.jpk-force"
    path.write_bytes(bytes(data))
    return path


@pytest.mark.parametrize(("edit", "message"), [
    (lambda data, info: data.__setitem__(slice(info.header_offset, info.header_offset + 4), b"PK\x00\x00"),
     "bad magic number for the local header"),
    (lambda data, info: data.__setitem__(info.header_offset + 30 + len(info.filename) + 1,
                                         data[info.header_offset + 30 + len(info.filename) + 1] ^ 0xFF),
     "bad CRC-32 or size"),
])
def test_damaged_member_names_member_and_problem(tmp_path, edit, message):
    archive = read_jpk(_damaged(tmp_path, edit))              # headers are fine ...
    with pytest.raises(InstrumentFormatError,
                       match=rf"segments/1/channels/vDeflection\.dat: cannot be read \({message}.*corrupt"):
        archive.curve(0)                                      # ... the channel is not
    archive.close()


def test_truncated_member_data(tmp_path):
    data = _stored(build_members("force"))
    with zipfile.ZipFile(io.BytesIO(data)) as zf:
        index = jpk._MemberIndex.of(zf)
    name = "segments/1/channels/vDeflection.dat"
    offset = int(index.offset[index.rows[name]])
    where = jpk._Where("cut")
    with pytest.raises(zipfile.BadZipFile, match="truncated data"):   # ends inside the member
        jpk._IndexedZip(data[: offset + 40], index, where).read(name)
    with pytest.raises(zipfile.BadZipFile, match="truncated local header"):   # ... or its header
        jpk._IndexedZip(data[: offset + 10], index, where).read(name)
    with pytest.raises(KeyError):
        jpk._IndexedZip(data, index, where).read("segments/9/channels/none.dat")


def test_other_compressions_go_through_zipfile(tmp_path, map_file):
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_BZIP2) as zf:
        for name, content in build_members("force-map").items():
            zf.writestr(name, content if isinstance(content, bytes) else _serialise(content))
    path = tmp_path / "bzip2.jpk-force-map"
    path.write_bytes(buffer.getvalue())
    with read_jpk(path) as a, read_jpk(map_file) as b:
        for i in range(4):
            _same_curves(a.curve(i), b.curve(i))
        assert a._handles.outer._zip is not None       # the fallback reader was used
