"""Hostile and damaged archives: decompression caps, lying headers, impossible calibrations.

Issue 25 (items 2-4 for archives): every JPK member and every zip member read through afmformats
is checked against its declared size and the limits of :mod:`viscoforce._limits` before it is
decompressed; decompression stops one byte past the declared size; ``num-points`` is checked
against the data before anything is allocated; calibrations outside their plausible ranges are
refused; damaged archives and non-finite samples are named precisely. The caps are monkeypatched
small so that the bombs stay small and fast; memory is measured with tracemalloc.
"""

from __future__ import annotations

import bz2
import io
import re
import struct
import tempfile
import tracemalloc
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest

import viscoforce._limits as limits
import viscoforce.io.afm as afm
from tests.io.test_jpk import _serialise, build_members, write, zip_bytes
from viscoforce.exceptions import EffortError, InstrumentFormatError, ParameterError
from viscoforce.io.jpk import read_jpk
from viscoforce.io.jpk_write import ForceSegment, write_jpk_force

MiB = 1024**2
SEG0 = "segments/0/segment-header.properties"
SHARED = "shared-data/header.properties"
VDEF = "lcd-info.2.conversion-set.conversion."       # vDeflection slots in the shared data
K_KEY = r"channel\.vDeflection\.conversion-set\.conversion\.force\.scaling\.multiplier"
S_KEY = r"channel\.vDeflection\.conversion-set\.conversion\.distance\.scaling\.multiplier"


# ── hostile zips, byte by byte ─────────────────────────────────────────────────────────────────


def _deflate(data: bytes) -> bytes:
    packer = zlib.compressobj(9, zlib.DEFLATED, -zlib.MAX_WBITS)
    return packer.compress(data) + packer.flush()


def _raw_zip(entries: list[tuple[str, bytes, int, int, int]]) -> bytes:
    """A zip of (name, payload as stored, method, CRC, declared decompressed size): any lie goes."""
    out, directory = io.BytesIO(), []
    for name, payload, method, crc, size in entries:
        offset, encoded = out.tell(), name.encode()
        out.write(struct.pack("<4sHHHHHIIIHH", b"PK\x03\x04", 20, 0, method, 0, 0, crc,
                              len(payload), size, len(encoded), 0) + encoded + payload)
        directory.append(struct.pack("<4sHHHHHHIIIHHHHHII", b"PK\x01\x02", 20, 20, 0, method, 0,
                                     0, crc, len(payload), size, len(encoded), 0, 0, 0, 0, 0,
                                     offset) + encoded)
    start = out.tell()
    for entry in directory:
        out.write(entry)
    out.write(struct.pack("<4sHHHHIIH", b"PK\x05\x06", 0, 0, len(directory), len(directory),
                          out.tell() - start, start, 0))
    return out.getvalue()


def _honest(name: str, data: bytes) -> tuple[str, bytes, int, int, int]:
    return name, _deflate(data), zipfile.ZIP_DEFLATED, zlib.crc32(data), len(data)


def _jpk_with(members: dict, replaced: dict[str, tuple[bytes, int, int]]) -> bytes:
    """A JPK archive of ``members`` where ``replaced[name] = (payload, method, declared size)``."""
    entries = []
    for name, content in members.items():
        if name in replaced:
            payload, method, declared = replaced[name]
            entries.append((name, payload, method, 0, declared))
        else:
            entries.append(_honest(name, content if isinstance(content, bytes) else _serialise(content)))
    return _raw_zip(entries)


def _peak(call) -> tuple[BaseException | None, int]:
    """(the exception ``call`` raised or None, tracemalloc peak [bytes] during the call)."""
    tracemalloc.start()
    try:
        call()
        error = None
    except Exception as exc:  # noqa: BLE001 - returned to the test
        error = exc
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return error, peak


def _curve0(path: Path):
    with read_jpk(path) as archive:
        return archive.curve(0)


# ── JPK: decompression caps and lying sizes ───────────────────────────────────────────────────


def test_header_beyond_the_cap_is_refused_from_its_declared_size(tmp_path, monkeypatch):
    monkeypatch.setattr(limits, "MAX_HEADER_BYTES", 64 * 1024)
    members = build_members("force")
    members["header.properties"] = _serialise(members["header.properties"]) + b"#" * (4 * MiB)
    path = tmp_path / "bomb.jpk-force"
    path.write_bytes(zip_bytes(members))
    assert path.stat().st_size < 64 * 1024                   # 4 MiB of header in a few kB
    error, peak = _peak(lambda: read_jpk(path))
    assert isinstance(error, EffortError)
    assert str(error).startswith(f"{path}: header.properties: decompressing this member: about "
                                 "4.19e+06 bytes needed, beyond the limit of 6.55e+04 bytes")
    assert "MAX_HEADER_BYTES" in str(error)
    assert (error.estimate, error.limit) == (4 * MiB + len(_serialise(build_members()["header.properties"])),
                                             64 * 1024)
    assert peak < MiB                                        # nothing was decompressed


def test_channel_beyond_the_member_cap_is_refused(tmp_path, monkeypatch):
    monkeypatch.setattr(limits, "MAX_MEMBER_BYTES", 10)      # the channels hold 6-32 bytes
    path = write(tmp_path / "curve.jpk-force", build_members("force"))
    archive = read_jpk(path)                                 # headers are within their own cap
    with pytest.raises(EffortError, match=r"segments/0/channels/vDeflection\.dat: decompressing this "
                                          r"member: about 16 bytes needed.*MAX_MEMBER_BYTES") as info:
        archive.curve(0)
    assert "beyond the limit of 10 bytes" in str(info.value)
    archive.close()


def test_header_that_lies_about_its_size_stops_at_the_declared_size(tmp_path):
    bomb = _deflate(b"\0" * (16 * MiB))                      # 16 MiB in about 16 kB
    members = build_members("force")
    path = tmp_path / "lying.jpk-force"
    path.write_bytes(_jpk_with(members, {"header.properties": (bomb, zipfile.ZIP_DEFLATED, len(bomb))}))
    error, peak = _peak(lambda: read_jpk(path))
    assert isinstance(error, InstrumentFormatError)
    assert str(error) == (f"{path}: header.properties: cannot be read ('header.properties' "
                          f"decompresses to more than the {len(bomb)} bytes the zip declares); the "
                          "archive is truncated or corrupt")
    assert peak < MiB                                        # not the 16 MiB it expands to

    path.write_bytes(_jpk_with(members, {"header.properties": (bomb, zipfile.ZIP_DEFLATED, 100)}))
    with pytest.raises(InstrumentFormatError, match=rf"header\.properties: cannot be read \("
                                                    rf"'header\.properties': {len(bomb)} compressed "
                                                    r"bytes declared for 100 decompressed ones"):
        read_jpk(path)


def test_channel_that_lies_about_its_size_is_refused_with_bounded_memory(tmp_path):
    n = 32768                                                # every channel of segment 0: n samples
    members = build_members("force")
    head = members[SEG0]
    head["force-segment-header.num-points"] = str(n)
    for channel, dtype in (("height", ">i2"), ("vDeflection", ">i4"), ("measuredHeight", ">i4")):
        head[f"channel.{channel}.data.num-points"] = str(n)
        members[f"segments/0/channels/{channel}.dat"] = np.zeros(n, dtype=dtype).tobytes()
    bomb = _deflate(b"\0" * (32 * MiB))                      # declared: the 128 kB of n samples
    path = tmp_path / "lying-channel.jpk-force"
    path.write_bytes(_jpk_with(members, {"segments/0/channels/vDeflection.dat":
                                         (bomb, zipfile.ZIP_DEFLATED, 4 * n)}))
    error, peak = _peak(lambda: _curve0(path))
    assert isinstance(error, InstrumentFormatError)
    assert str(error).startswith(f"{path}: segments/0/channels/vDeflection.dat: cannot be read "
                                 f"('segments/0/channels/vDeflection.dat' decompresses to more than "
                                 f"the {4 * n} bytes the zip declares)")
    assert peak < 4 * MiB                                    # not the 32 MiB of the bomb


def test_bzip2_bomb_through_the_zipfile_fallback_is_bounded(tmp_path):
    bomb = bz2.compress(b"\0" * (128 * MiB), 9)              # about 100 bytes
    members = build_members("force")
    path = tmp_path / "bzip2.jpk-force"
    path.write_bytes(_jpk_with(members, {"header.properties": (bomb, zipfile.ZIP_BZIP2, 200)}))
    error, peak = _peak(lambda: read_jpk(path))
    assert isinstance(error, InstrumentFormatError)
    assert str(error).startswith(f"{path}: header.properties: cannot be read (Bad CRC-32")
    assert peak < 96 * MiB                                   # at most a bzip2 block or two


def test_archive_total_beyond_the_cap(tmp_path, monkeypatch):
    path = write(tmp_path / "curve.jpk-force", build_members("force"))
    total = sum(info.file_size for info in zipfile.ZipFile(path).infolist())
    monkeypatch.setattr(limits, "MAX_ARCHIVE_BYTES", total - 1)
    with pytest.raises(EffortError, match=re.escape(f"curve.jpk-force: decompressing the archive's "
                                                    f"members: about {total:.3g} bytes needed")):
        read_jpk(path)
    inner = zip_bytes(build_members("force"))
    zipped = write(tmp_path / "set.zip", {"a.jpk-force": inner, "b.jpk-force": inner})
    monkeypatch.setattr(limits, "MAX_ARCHIVE_BYTES", 2 * len(inner) + total)  # the 2nd is too many
    with pytest.raises(EffortError, match=r"set\.zip: decompressing the archive's members: about "):
        read_jpk(zipped)


# ── JPK: damaged archives say what is damaged ─────────────────────────────────────────────────


def test_truncated_zip_names_its_first_member(tmp_path):
    data = zip_bytes(build_members("force"))
    path = tmp_path / "cut.jpk-force"
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(InstrumentFormatError) as info:
        read_jpk(path)
    assert str(info.value) == (
        f"{path}: is not a readable zip archive (File is not a zip file): it starts as one (first "
        "member 'header.properties') but its central directory, the member list at the end of a "
        f"zip, is missing or damaged: the {len(data) // 2}-byte file is truncated or corrupt")


def test_missing_header_properties_is_named(tmp_path):
    members = build_members("force")
    del members["header.properties"]
    path = write(tmp_path / "headless.jpk-force", members)
    with pytest.raises(InstrumentFormatError) as info:
        read_jpk(path)
    assert str(info.value).startswith(
        f"{path}: header.properties: missing from the archive: it holds 13 of a JPK archive's "
        "members (shared-data/header.properties, segments/0/segment-header.properties, "
        "segments/0/channels/height.dat, ...) but not the header")


def test_short_channel_names_member_declared_and_actual(tmp_path):
    members = build_members("force")
    members["segments/2/channels/vDeflection.dat"] = members["segments/2/channels/vDeflection.dat"][:-4]
    path = write(tmp_path / "short.jpk-force", members)
    with pytest.raises(InstrumentFormatError) as info:
        _curve0(path)
    assert str(info.value) == (
        f"{path}: segments/2/channels/vDeflection.dat: holds 8 bytes = 2 samples of >i4, but the "
        "segment header says num-points=3 (channel num-points=3), i.e. 12 bytes: truncated or "
        "inconsistent")


def test_huge_num_points_is_refused_before_allocating(tmp_path):
    members = build_members("force")
    members[SEG0]["force-segment-header.num-points"] = "100000000000"   # 745 GiB of float64
    path = write(tmp_path / "huge.jpk-force", members)
    error, peak = _peak(lambda: _curve0(path))
    assert isinstance(error, InstrumentFormatError)
    assert str(error).startswith(f"{path}: segments/0/channels/height.dat: holds 8 bytes = 4 "
                                 "samples of >i2, but the segment header says num-points="
                                 "100000000000")
    assert peak < MiB
    members[SEG0]["channels.list"] = ""                      # no data to check it against
    path = write(tmp_path / "huge-empty.jpk-force", members)
    error, peak = _peak(lambda: _curve0(path))
    assert isinstance(error, EffortError)
    assert str(error).startswith(f"{path}: {SEG0}: decoding segment 0 (num-points=100000000000, "
                                 "2 arrays of float64): about 1.6e+12 bytes needed, beyond the "
                                 "limit of 2.15e+09 bytes")
    assert peak < MiB


# ── JPK: impossible calibrations ──────────────────────────────────────────────────────────────


@pytest.mark.parametrize(("slot", "value", "pattern"), [
    ("force", "0.0", rf"spring constant '{K_KEY}' = 0\.0 N/m is outside the plausible range "
                     r"\[1e-05, 1000\] N/m"),
    ("force", "-40", rf"spring constant '{K_KEY}' = -40\.0 N/m is outside"),
    ("force", "1e308", rf"spring constant '{K_KEY}' = 1e\+308 N/m is outside"),
    ("force", "NaN", rf"spring constant '{K_KEY}' = nan N/m is outside"),
    ("distance", "0", rf"deflection sensitivity '{S_KEY}' = 0\.0 m/V is outside the plausible "
                      r"range \[1e-12, 0\.001\] m/V"),
    ("distance", "1e308", rf"deflection sensitivity '{S_KEY}' = 1e\+308 m/V is outside"),
])
def test_spring_constant_and_sensitivity_out_of_range(tmp_path, slot, value, pattern):
    members = build_members("force")
    members[SHARED][f"{VDEF}{slot}.scaling.multiplier"] = value
    path = write(tmp_path / "calibration.jpk-force", members)
    with pytest.raises(InstrumentFormatError, match=rf"^{path}: {SEG0}: {pattern}"):
        _curve0(path)


@pytest.mark.parametrize(("key", "value", "pattern"), [
    ("lcd-info.0.encoder.scaling.multiplier", "Infinity",
     r"'channel\.height\.encoder\.scaling\.multiplier' = inf must be finite and non-zero"),
    ("lcd-info.0.encoder.scaling.offset", "NaN",
     r"'channel\.height\.encoder\.scaling\.offset' = nan must be finite"),
    ("lcd-info.0.conversion-set.conversion.nominal.scaling.multiplier", "0",
     r"'channel\.height\.conversion-set\.conversion\.nominal\.scaling\.multiplier' = 0\.0 must be"),
    ("lcd-info.1.conversion-set.conversion.nominal.scaling.offset", "-Infinity",
     r"'channel\.measuredHeight\.conversion-set\.conversion\.nominal\.scaling\.offset' = -inf"),
])
def test_non_finite_scalings_are_refused(tmp_path, key, value, pattern):
    members = build_members("force")
    members[SHARED][key] = value
    path = write(tmp_path / "scaling.jpk-force", members)
    with pytest.raises(InstrumentFormatError, match=rf"^{path}: {SEG0}: {pattern}"):
        _curve0(path)


def test_non_finite_samples_name_file_curve_segment_and_channel(tmp_path):
    members = build_members("force-map")
    shared = members[SHARED]
    shared["lcd-info.1.type"] = "float-data"                  # measuredHeight stored as floats
    del shared["lcd-info.1.encoder.type"]
    for c in range(4):
        for s, n in enumerate((4, 8, 3)):
            values = (np.arange(n) * 1e-6).astype(">f4")
            if (c, s) == (2, 1):
                values[5] = np.nan
            members[f"index/{c}/segments/{s}/channels/measuredHeight.dat"] = values.tobytes()
    path = write(tmp_path / "nan.jpk-force-map", members)
    archive = read_jpk(path)
    archive.curve(1)
    with pytest.raises(InstrumentFormatError) as info:
        archive.curve(2)
    assert str(info.value) == (
        f"{path}: index/2/segments/1/channels/measuredHeight.dat: curve 2, segment 1, channel "
        "'measuredHeight': 1 of 8 samples are not finite (first: sample 5 = nan); the raw data "
        "or the header's calibration (encoder and slot multipliers) is corrupt")
    archive.close()
    members = build_members("force")
    members[SHARED]["lcd-info.0.encoder.scaling.multiplier"] = "1e307"   # overflows to inf
    path = write(tmp_path / "overflow.jpk-force", members)
    with pytest.raises(InstrumentFormatError, match=r"segments/0/channels/height\.dat: curve 0, "
                                                    r"segment 0, channel 'height': 3 of 4 samples "
                                                    r"are not finite \(first: sample 1 = -inf\)"):
        _curve0(path)


# ── JPK: memory of an ordinary read ───────────────────────────────────────────────────────────


def test_reading_peaks_at_a_small_multiple_of_the_data(tmp_path):
    rng = np.random.default_rng(25)
    n = 50_000
    segments = [ForceSegment(style, 1.0, {"vDeflection": rng.normal(0, 1e-9, n),
                                          "height": np.linspace(0, 1e-6, n),
                                          "measuredHeight": np.linspace(0, 1e-6, n)})
                for style in ("extend", "pause", "retract")]
    path = write_jpk_force(tmp_path / "big.jpk-force", segments, spring_constant=0.1,
                           sensitivity=5e-8)
    read_jpk(path).curve(0)                                   # imports and caches warm
    curves = []
    error, peak = _peak(lambda: curves.append(_curve0(path)))
    assert error is None
    data = sum(s.time.nbytes + sum(v.nbytes for v in s.channels.values())
               for s in curves[0].segments)
    assert data == 3 * 5 * 8 * n                              # time, vDeflection, force, 2 heights
    assert peak <= 2 * data                                   # measured: 1.4x


# ── afmformats zips: caps, lies, temp folder ──────────────────────────────────────────────────


CHIARO_HEADER = ["Date\t12/05/2025\tTime\t11:20:38\tStatus\tOK", "synthetic",
                 "Scan (#)\t1\tX (#)\t1\tY (#)\t1\tIndentation (#)\t1", "",
                 "X-position (um)\t5314.320", "Y-position (um)\t5500.880",
                 "Z-position (um)\t6833.680", "Z surface (um)\t6838.680",
                 "Piezo position (nm) (Measured)\t-10.3", "", "k (N/m)\t{k}",
                 "Tip radius (um)\t27.500", "Calibration factor\t2.809", "SMDuration (s) 0.000", "",
                 "Device:\tChiaro", "Software version: V3.5.0", "", "Control mode: Peak Load Poking",
                 "Measurement: Indentation", "", "Profile:", "Max load (µN)\t0.050",
                 "Piezo speed  (µm/s)\t7.000", "", "Step absolute start times (s)\t",
                 "Step absolute end times (s) ", "Model: Hertz", "Comment: ", "",
                 "Time (s)\tLoad (uN)\tIndentation (nm)\tCantilever (nm)\tPiezo (nm)\tAuxiliary"]


def _chiaro(k: str = "0.019", nan_at: int | None = None, n: int = 400) -> bytes:
    piezo = np.concatenate([np.linspace(0, 2000, n // 2), np.linspace(2000, 0, n - n // 2)])
    load = np.maximum(piezo - 1000, 0) * 1e-5
    rows = [f"{i * 1e-3:.6f}\t{'nan' if i == nan_at else f'{load[i]:.6f}'}\t0.000000\t"
            f"{load[i] / 0.019 * 1e3:.6f}\t{piezo[i]:.6f}\t0.0" for i in range(n)]
    lines = [line.format(k=k) for line in CHIARO_HEADER] + rows
    return ("\n".join(lines) + "\n").encode("latin-1")


@pytest.fixture
def temp_folder(tmp_path, monkeypatch):
    """The temporary folder afm uses (empty at the start; tests check it stays so)."""
    folder = tmp_path / "temp"
    folder.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(folder))
    return folder


@pytest.fixture
def copies(monkeypatch):
    """Bytes each member copy left in the temporary folder before it was removed."""
    seen: list[int] = []
    original = afm._copy_member

    def spy(zf, info, target, where):
        try:
            original(zf, info, target, where)
        finally:
            seen.append(target.stat().st_size if target.exists() else 0)

    monkeypatch.setattr(afm, "_copy_member", spy)
    return seen


def test_afm_zip_reads_and_leaves_no_temp_files(tmp_path, temp_folder, copies):
    pytest.importorskip("afmformats")
    path = tmp_path / "two.zip"
    path.write_bytes(_raw_zip([_honest("a.txt", _chiaro()), _honest("b.txt", _chiaro())]))
    ds = afm.read_afmformats(path)
    assert ds.sizes["curve"] == 2 and ds.spring_constant.values.tolist() == [0.019, 0.019]
    assert copies == [len(_chiaro())] * 2
    assert list(temp_folder.iterdir()) == []


def test_afm_member_beyond_the_cap_is_refused_before_copying(tmp_path, temp_folder, copies,
                                                              monkeypatch):
    monkeypatch.setattr(limits, "MAX_PARSED_BYTES", MiB)
    path = tmp_path / "bomb.zip"
    path.write_bytes(_raw_zip([_honest("curve.txt", _chiaro() + b"#" * (8 * MiB))]))
    error, peak = _peak(lambda: afm.read_afmformats(path))
    assert isinstance(error, EffortError)
    size = len(_chiaro()) + 8 * MiB
    assert str(error).startswith(f"{path}!curve.txt: decompressing this member: about {size:.3g} "
                                 "bytes needed, beyond the limit of 1.05e+06 bytes")
    assert "MAX_PARSED_BYTES" in str(error)
    assert copies == [] and list(temp_folder.iterdir()) == []
    assert peak < MiB


def test_afm_zip_total_beyond_the_cap(tmp_path, temp_folder, copies, monkeypatch):
    text = _chiaro()
    monkeypatch.setattr(limits, "MAX_PARSED_TOTAL_BYTES", 2 * len(text) - 1)
    path = tmp_path / "many.zip"
    path.write_bytes(_raw_zip([_honest("a.txt", text), _honest("b.txt", text)]))
    with pytest.raises(EffortError, match=r"many\.zip: decompressing the zip's 2 member\(s\): about "
                                          r".*MAX_PARSED_TOTAL_BYTES"):
        afm.read_afmformats(path)
    assert copies == [] and list(temp_folder.iterdir()) == []


def test_afm_member_that_lies_is_not_written_beyond_its_declared_size(tmp_path, temp_folder,
                                                                      copies):
    bomb = _deflate(_chiaro() + b"\0" * (32 * MiB))
    path = tmp_path / "lying.zip"
    path.write_bytes(_raw_zip([("curve.txt", bomb, zipfile.ZIP_DEFLATED, 0, 100_000)]))
    error, peak = _peak(lambda: afm.read_afmformats(path))
    assert isinstance(error, InstrumentFormatError)
    assert str(error) == (f"{path}!curve.txt: cannot be decompressed (BadZipFile: Bad CRC-32 for "
                          "file 'curve.txt'): the zip is damaged (truncated, or the member is not "
                          "the 100000 bytes its header declares)")
    assert len(copies) == 1 and copies[0] <= 100_000         # never past the declared size
    assert list(temp_folder.iterdir()) == []
    assert peak < 4 * MiB


def test_afm_bzip2_member_is_refused(tmp_path, temp_folder):
    data = _chiaro()
    path = tmp_path / "bz.zip"
    path.write_bytes(_raw_zip([("curve.txt", bz2.compress(data), zipfile.ZIP_BZIP2,
                                zlib.crc32(data), len(data))]))
    with pytest.raises(InstrumentFormatError, match=r"bz\.zip!curve\.txt: zip compression method 12 "
                                                    r"is not read .*zip-bomb risk"):
        afm.read_afmformats(path)
    assert list(temp_folder.iterdir()) == []


def test_afm_truncated_zip(tmp_path):
    data = _raw_zip([_honest("a.txt", _chiaro()), _honest("b.txt", _chiaro())])
    path = tmp_path / "cut.zip"
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(InstrumentFormatError, match=r"cut\.zip: corrupt or unreadable zip \(BadZipFile: "
                                                    r"File is not a zip file\): it starts as a zip but "
                                                    r"its central directory .* so the file is truncated"):
        afm.read_afmformats(path)


def test_afm_plain_file_beyond_the_cap(tmp_path, monkeypatch):
    monkeypatch.setattr(limits, "MAX_PARSED_BYTES", 1000)
    path = tmp_path / "big.txt"
    path.write_bytes(_chiaro())
    with pytest.raises(EffortError, match=re.escape(f"big.txt: parsing the file: about "
                                                    f"{len(_chiaro()):.3g} bytes needed, beyond the "
                                                    "limit of 1e+03 bytes")):
        afm.read_afmformats(path)


# ── afmformats: calibrations and samples ──────────────────────────────────────────────────────


@pytest.mark.parametrize("k", ["0", "-40", "1e308"])
def test_afm_file_spring_constant_out_of_range(tmp_path, k):
    pytest.importorskip("afmformats")
    path = tmp_path / "k.txt"
    path.write_bytes(_chiaro(k=k))
    with pytest.raises(InstrumentFormatError, match=re.escape(
            f"k.txt: the file's spring constant is {float(k)!r} N/m, outside the plausible range "
            "[1e-05, 1000] N/m (spring_constant): a corrupt header")):
        afm.read_afmformats(path)


@pytest.mark.parametrize(("option", "value", "pattern"), [
    ("spring_constant", 1e308, r"spring_constant must be within the plausible range \[1e-05, "
                               r"1000\] N/m, got 1e\+308 N/m"),
    ("spring_constant", -40.0, r"spring_constant"),
    ("sensitivity", 1.0, r"sensitivity must be within the plausible range \[1e-12, 0\.001\] m/V, "
                         r"got 1\.0 m/V"),
])
def test_afm_option_calibration_out_of_range(tmp_path, option, value, pattern):
    path = tmp_path / "ok.txt"
    path.write_bytes(_chiaro())
    with pytest.raises(ParameterError, match=pattern):
        afm.read_afmformats(path, **{option: value})


def test_afm_nan_sample_names_file_curve_segment_and_channel(tmp_path):
    pytest.importorskip("afmformats")
    path = tmp_path / "zipped.zip"
    path.write_bytes(_raw_zip([_honest("a.txt", _chiaro()), _honest("b.txt", _chiaro(nan_at=100))]))
    with pytest.raises(InstrumentFormatError) as info:
        afm.read_afmformats(path)
    assert str(info.value) == (f"{path}!b.txt: curve 0, segment 'approach', channel 'force': 1 "
                               "of 400 samples are not finite (first: sample 100 = nan)")
