"""JPK archive reader: exact decoding of self-made archives, every error branch, and the real files."""

from __future__ import annotations

import hashlib
import io
import itertools
import zipfile
from pathlib import Path

import numpy as np
import pytest

import viscoforce.io.jpk as jpk
from viscoforce.exceptions import ViscoforceError
from viscoforce.io._properties import HeaderError, parse_properties, resolve_references
from viscoforce.io.jpk import InstrumentFormatError, read_jpk

REAL = Path(__file__).resolve().parents[3] / "shared" / "data" / "real"
FIXTURES = Path(__file__).resolve().parents[1] / "data" / "jpk"

# ── a minimal valid archive with known raw integers, scalings and conversion chains ───────────

K, SENS, DIST_OFF = 0.25, 2e-8, 1e-9            # force slot [N/m], distance slot [m/V] + offset [m]
V_MULT, V_OFF = 0.5, 1.0                        # vDeflection encoder (signedinteger) -> V
H_MULT, H_OFF = 1e-3, 2.0                       # height encoder (signedshort) -> V
NOM_MULT, NOM_OFF, CAL_MULT = -1e-6, 5e-5, 0.8  # height V -> nominal [m] -> calibrated [m]
S_MULT, S_OFF, S_NOM_OFF = 1e-12, 1e-5, 2e-5    # measuredHeight encoder -> absolute [m] -> nominal
BASELINE_V = 0.5
LCD = {"height": 0, "measuredHeight": 1, "vDeflection": 2}   # deliberately not in channel order
# (style, type, actual points, duration [s], planned points, shared force-segment-header-info or None)
SEGMENTS = (("extend", "z-extend-height", 4, 0.4, 4, None),
            ("modulation", "sine-z-modulation-segment-settings", 8, 0.08, 8, 2),
            ("retract", "z-retract-height", 3, 0.3, 4, None))
GRID = {"ilength": 2, "jlength": 2, "ulength": 4e-6, "vlength": 4e-6, "xcenter": 1e-6, "ycenter": -1e-6}
DTYPES = {"height": ">i2", "measuredHeight": ">i4", "vDeflection": ">i4"}


def _escape(text: str) -> str:
    out = text.replace("\\", "\\\\").replace(":", "\\:").replace("=", "\\=")
    return "".join(c if ord(c) < 128 else f"\\u{ord(c):04X}" for c in out)


def _serialise(props: dict[str, str]) -> bytes:
    lines = ["#Tue Dec 01 12:00:00 CET 2026"] + [f"{_escape(k)}={_escape(v)}" for k, v in props.items()]
    return ("\n".join(lines) + "\n").encode("latin-1")


def _slot(name: str, base: str, mult: float, off: float, unit: str) -> dict[str, str]:
    pre = f"conversion-set.conversion.{name}."
    return {pre + "name": name.title(), pre + "defined": "true", pre + "type": "simple",
            pre + "base-calibration-slot": base, pre + "calibration-slot": name,
            pre + "scaling.type": "linear", pre + "scaling.style": "offsetmultiplier",
            pre + "scaling.offset": repr(off), pre + "scaling.multiplier": repr(mult),
            pre + "scaling.unit.type": "metric-unit", pre + "scaling.unit.unit": unit}


def _lcd(channel: str) -> dict[str, str]:
    """lcd-info block (keys relative to ``lcd-info.<L>.``) of a channel."""
    enc_type, mult, off, base, unit, slots = {
        "vDeflection": ("signedinteger", V_MULT, V_OFF, "volts", "V",
                        [("distance", "volts", SENS, DIST_OFF, "m"), ("force", "distance", K, 0.0, "N")]),
        "height": ("signedshort", H_MULT, H_OFF, "volts", "V",
                   [("nominal", "volts", NOM_MULT, NOM_OFF, "m"),
                    ("calibrated", "nominal", CAL_MULT, 0.0, "m")]),
        "measuredHeight": ("signedinteger", S_MULT, S_OFF, "absolute", "m",
                           [("nominal", "absolute", 1.0, S_NOM_OFF, "m")]),
    }[channel]
    block = {"type": "integer-data", "channel.name": channel, "unit.unit": unit,
             "conversion-set.conversions.list": " ".join(s[0] for s in slots),
             "conversion-set.conversions.default": slots[-1][0],
             "conversion-set.conversions.base": base,
             f"conversion-set.conversion.{base}.defined": "false",
             "encoder.type": enc_type, "encoder.scaling.type": "linear",
             "encoder.scaling.style": "offsetmultiplier", "encoder.scaling.offset": repr(off),
             "encoder.scaling.multiplier": repr(mult), "encoder.scaling.unit.unit": unit}
    for slot in slots:
        block.update(_slot(*slot))
    return block


def raw(curve: int, seg: int, channel: str, n: int) -> np.ndarray:
    """The raw integers stored for a channel (known, distinct per curve, segment and channel)."""
    i = np.arange(n)
    values = {"vDeflection": 3 * i - 5 + 100 * curve + 1000 * seg,
              "height": 40 * i + 7 * curve - 300 * seg,
              "measuredHeight": -50 * i + 11 * curve + 10_000 * seg}[channel]
    return values.astype(DTYPES[channel])


def expected(curve: int, seg: int, n: int) -> dict[str, np.ndarray]:
    """The SI channels the reader must return, computed here by hand from the constants above."""
    volts = raw(curve, seg, "vDeflection", n).astype(float) * V_MULT + V_OFF
    deflection = volts * SENS + DIST_OFF
    height_v = raw(curve, seg, "height", n).astype(float) * H_MULT + H_OFF
    sensor = raw(curve, seg, "measuredHeight", n).astype(float) * S_MULT + S_OFF
    return {"vDeflection": deflection, "force": deflection * K,
            "height": (height_v * NOM_MULT + NOM_OFF) * CAL_MULT, "measuredHeight": sensor + S_NOM_OFF}


def _segment_settings(style: str, seg_type: str, duration: float, planned: int) -> dict[str, str]:
    pre = "settings.segment-settings."
    settings = {"settings.type": "combined", "settings.style": style, pre + "type": seg_type,
                pre + "style": style, pre + "duration": repr(duration), pre + "num-points": str(planned)}
    if style == "modulation":
        settings.update({pre + "frequency": "100.0", pre + "amplitude": "1.5000000000000002E-8",
                         pre + "start-phase": "0.0", pre + "axis-direction": "ZPOS"})
    return settings


def _segment_header(curve: int, seg: int, inline: bool) -> tuple[dict[str, str], dict[str, bytes]]:
    style, seg_type, n, duration, planned, info = SEGMENTS[seg]
    head = {"force-segment-header.num-points": str(n), "force-segment-header.duration": repr(duration),
            "force-segment-header.time-stamp": "2026-12-01 12:00:00.000 +0100",
            "force-segment-header.baseline.baseline": repr(BASELINE_V),
            "force-segment-header.baseline.measured": "true"}
    if info is None:
        head.update({f"force-segment-header.{k}": v
                     for k, v in _segment_settings(style, seg_type, duration, planned).items()})
    else:
        head["force-segment-header.force-segment-header-info.*"] = str(info)
    head["channels.list"] = "height vDeflection measuredHeight"
    data = {}
    for channel in ("height", "vDeflection", "measuredHeight"):
        if inline:
            head.update({f"channel.{channel}.{k.replace('encoder.', 'data.encoder.')}": v
                         for k, v in _lcd(channel).items()})
        else:
            head[f"channel.{channel}.lcd-info.*"] = str(LCD[channel])
        head.update({f"channel.{channel}.data.file.name": f"channels/{channel}.dat",
                     f"channel.{channel}.data.file.format": "raw",
                     f"channel.{channel}.data.num-points": str(n)})
        data[f"channels/{channel}.dat"] = raw(curve, seg, channel, n).tobytes()
    return head, data


def _shared() -> dict[str, str]:
    shared = {"lcd-infos.count": str(len(LCD))}
    for channel, number in LCD.items():
        shared.update({f"lcd-info.{number}.{k}": v for k, v in _lcd(channel).items()})
    for style, seg_type, _, duration, planned, info in SEGMENTS:
        if info is not None:
            shared.update({f"force-segment-header-info.{info}.{k}": v
                           for k, v in _segment_settings(style, seg_type, duration, planned).items()})
    return shared


def _curve_header(curve: int, kind: str) -> dict[str, str]:
    x = GRID["xcenter"] + (curve % 2 - 0.5) * GRID["ulength"] / 2
    y = GRID["ycenter"] + (curve // 2 - 0.5) * GRID["vlength"] / 2
    header = {"jpk-data-file": "spm-forcefile"} if kind == "force" else {}
    header.update({"type": "force-scan-series", "force-scan-series.force-segments.count": str(len(SEGMENTS)),
                   "force-scan-series.header.position.x": repr(x),
                   "force-scan-series.header.position.y": repr(y),
                   "force-scan-series.description.instrument": "JPK-TEST 15µm Z"})
    return header


def build_members(kind: str = "force", *, inline: bool = False) -> dict[str, dict[str, str] | bytes]:
    """Members of a minimal archive: properties as dicts (tests edit them), channels as bytes."""
    curves = [""] if kind == "force" else [f"index/{c}/" for c in range(4)]
    members: dict[str, dict[str, str] | bytes] = {}
    if kind == "force":
        members["header.properties"] = _curve_header(0, kind)
    else:
        members["header.properties"] = {"jpk-data-file": "spm-force-scan-map-file", "type": "force-scan-map",
                                        "force-scan-map.position-pattern.grid.unit.unit": "m",
                                        **{f"force-scan-map.position-pattern.grid.{k}": repr(v)
                                           for k, v in GRID.items()}}
    if not inline:
        members["shared-data/header.properties"] = _shared()
    for c, curve_dir in enumerate(curves):
        if curve_dir:
            members[f"{curve_dir}header.properties"] = _curve_header(c, kind)
        for s in range(len(SEGMENTS)):
            head, data = _segment_header(c, s, inline)
            members[f"{curve_dir}segments/{s}/segment-header.properties"] = head
            members.update({f"{curve_dir}segments/{s}/{k}": v for k, v in data.items()})
    return members


def zip_bytes(members: dict[str, dict[str, str] | bytes]) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, content in members.items():
            info = zipfile.ZipInfo(name, date_time=(2026, 12, 1, 12, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            zf.writestr(info, content if isinstance(content, bytes) else _serialise(content))
    return buffer.getvalue()


def write(path: Path, members: dict[str, dict[str, str] | bytes]) -> Path:
    path.write_bytes(zip_bytes(members))
    return path


def write_fixtures(directory: Path = FIXTURES) -> None:
    """Regenerate tests/data/jpk (see its README)."""
    write(directory / "synthetic.jpk-force", build_members("force"))
    write(directory / "synthetic-2x2.jpk-force-map", build_members("force-map"))


@pytest.fixture
def force_file(tmp_path):
    return write(tmp_path / "curve.jpk-force", build_members("force"))


@pytest.fixture
def map_file(tmp_path):
    return write(tmp_path / "map.jpk-force-map", build_members("force-map"))


def check_synthetic_curve(curve: jpk.JPKCurve, c: int) -> None:
    assert curve.spring_constant == K and curve.sensitivity == SENS
    assert [s.style for s in curve.segments] == ["extend", "modulation", "retract"]
    assert [s.type for s in curve.segments] == [s[1] for s in SEGMENTS]
    assert [s.num_points for s in curve.segments] == [4, 8, 3]          # actual, not the planned 4
    assert [s.start_time for s in curve.segments] == [0.0, 0.4, 0.4 + 0.08]
    for s, segment in enumerate(curve.segments):
        want = expected(c, s, segment.num_points)
        assert set(segment.channels) == set(want)
        for name, values in want.items():
            np.testing.assert_allclose(segment.channels[name], values, rtol=1e-15, atol=0, err_msg=name)
        assert segment.units == {"vDeflection": "m", "force": "N", "height": "m", "measuredHeight": "m"}
        dt = segment.duration / segment.num_points
        np.testing.assert_allclose(segment.time, segment.start_time + dt * np.arange(segment.num_points),
                                   rtol=1e-15)
        assert segment.baseline == pytest.approx((BASELINE_V * SENS + DIST_OFF) * K, rel=1e-15)
    mod = curve.segments[1].modulation
    assert (mod.frequency, mod.amplitude, mod.start_phase) == (100.0, 1.5000000000000002e-8, 0.0)
    assert curve.segments[0].modulation is None and curve.segments[2].modulation is None


# ── properties ───────────────────────────────────────────────────────────────────────────────


def test_properties_unescape_comments_continuations_and_separators():
    text = (b"#comment\n! other comment\n  a\\:b = x\\ y\\u00B5\nkey value\\\n    continued\n"
            b"empty\nsuffix:\\\\u0020(1)\nstamp=12\\:04\\:16.071\ng\\=h=1\r\nlast=\\t")
    assert parse_properties(text) == {"a:b": "x yµ", "key": "valuecontinued", "empty": "",
                                      "suffix": "\\u0020(1)", "stamp": "12:04:16.071", "g=h": "1",
                                      "last": "\t"}


def test_properties_malformed_unicode_escape():
    with pytest.raises(HeaderError, match=r"malformed \\uXXXX escape '\\\\u00G5'"):
        parse_properties(b"a=\\u00G5x")


def test_references_resolve_and_missing_block():
    blocks = {"lcd-info.3": {"encoder.type": "signedshort"}}
    props = {"channel.h.lcd-info.*": "3", "channel.h.encoder.type": "inline wins"}
    assert resolve_references(props, blocks)["channel.h.encoder.type"] == "inline wins"
    resolved = resolve_references({"channel.h.lcd-info.*": "3"}, blocks)
    assert resolved["channel.h.encoder.type"] == "signedshort"
    with pytest.raises(HeaderError, match=r"'channel.h.lcd-info.\*=4' refers to 'lcd-info.4.\*'"):
        resolve_references({"channel.h.lcd-info.*": "4"}, blocks)


# ── synthetic archives: exact values ─────────────────────────────────────────────────────────


def test_single_curve_decodes_exactly(force_file):
    archive = read_jpk(force_file)
    assert (archive.kind, archive.n_curves, archive.grid) == ("force", 1, None)
    assert archive.metadata["force-scan-series.description.instrument"] == "JPK-TEST 15µm Z"
    curve = archive.curve(0)
    assert (curve.index, curve.source) == (0, "")
    assert (curve.x, curve.y) == (0.0, -2e-6)          # xcenter - ulength/4, ycenter - vlength/4
    check_synthetic_curve(curve, 0)
    settings = curve.segments[1].settings            # resolved through force-segment-header-info.2
    assert settings["force-segment-header.settings.segment-settings.frequency"] == "100.0"
    assert settings["force-segment-header.time-stamp"] == "2026-12-01 12:00:00.000 +0100"
    assert [c.index for c in archive.curves()] == [0]


def test_force_is_spring_constant_times_deflection_and_time_is_continuous(force_file):
    curve = read_jpk(force_file).curve(0)
    for segment in curve.segments:
        np.testing.assert_allclose(segment.channels["force"],
                                   curve.spring_constant * segment.channels["vDeflection"], rtol=1e-15)
    for before, after in itertools.pairwise(curve.segments):
        step = before.duration / before.num_points
        assert after.time[0] == pytest.approx(before.time[-1] + step, rel=1e-15)


def test_map_2x2_grid_positions_and_lazy_curves(map_file, monkeypatch):
    calls = []
    original = jpk._read_segment
    monkeypatch.setattr(jpk, "_read_segment", lambda *a: calls.append(a[2]) or original(*a))
    archive = read_jpk(map_file)
    assert calls == []                                       # nothing decoded up front
    assert (archive.kind, archive.n_curves) == ("force-map", 4)
    assert archive.grid == jpk.JPKGrid(**GRID)
    curve = archive.curve(2)
    assert calls == [f"index/2/segments/{s}/" for s in range(3)]   # only the curve asked for
    assert (curve.index, curve.source) == (2, "index/2/")
    assert (curve.x, curve.y) == (0.0, 0.0)            # xcenter - ulength/4, ycenter + vlength/4
    check_synthetic_curve(curve, 2)
    assert archive.curve(-1).index == 3
    curves = list(archive.curves())
    assert [c.index for c in curves] == [0, 1, 2, 3]
    for c, one in enumerate(curves):
        check_synthetic_curve(one, c)
    assert len({(c.x, c.y) for c in curves}) == 4


def test_zip_of_archives(tmp_path):
    members = {"a/curve-1.jpk-force": zip_bytes(build_members("force")), "notes.txt": b"x",
               "b/map.jpk-force-map": zip_bytes(build_members("force-map")),
               "curve-2.JPK-FORCE": zip_bytes(build_members("force"))}
    archive = read_jpk(write(tmp_path / "set.zip", members))
    assert (archive.kind, archive.n_curves, archive.grid, archive.metadata) == ("zip", 6, None, {})
    curves = list(archive.curves())
    assert [c.source for c in curves] == ["a/curve-1.jpk-force!", "b/map.jpk-force-map!index/0/",
                                          "b/map.jpk-force-map!index/1/", "b/map.jpk-force-map!index/2/",
                                          "b/map.jpk-force-map!index/3/", "curve-2.JPK-FORCE!"]
    assert [c.index for c in curves] == list(range(6))
    check_synthetic_curve(archive.curve(3), 2)
    check_synthetic_curve(archive.curve(5), 0)


def test_older_layout_with_inline_calibration(tmp_path):
    members = build_members("force", inline=True)
    members["shared-data/header.properties"] = {
        f"force-segment-header-info.2.{k}": v
        for k, v in _segment_settings(*[SEGMENTS[1][i] for i in (0, 1, 3, 4)]).items()}
    check_synthetic_curve(read_jpk(write(tmp_path / "old.jpk-force", members)).curve(0), 0)


def test_float_encoders_and_unencoded_float_data(tmp_path):
    members = build_members("force")
    shared = members["shared-data/header.properties"]
    L = LCD["vDeflection"]
    shared[f"lcd-info.{L}.encoder.type"] = "double"
    for s, (_, _, n, *_rest) in enumerate(SEGMENTS):
        as_double = raw(0, s, "vDeflection", n).astype(">f8")
        members[f"segments/{s}/channels/vDeflection.dat"] = as_double.tobytes()
    L = LCD["measuredHeight"]
    del shared[f"lcd-info.{L}.encoder.type"]
    shared[f"lcd-info.{L}.type"] = "float-data"                 # no encoder: stored in the base unit
    for s, (_, _, n, *_rest) in enumerate(SEGMENTS):
        sensor = raw(0, s, "measuredHeight", n) * S_MULT + S_OFF
        members[f"segments/{s}/channels/measuredHeight.dat"] = sensor.astype(">f4").tobytes()
    curve = read_jpk(write(tmp_path / "float.jpk-force", members)).curve(0)
    for s, segment in enumerate(curve.segments):
        want = expected(0, s, segment.num_points)
        np.testing.assert_allclose(segment.channels["force"], want["force"], rtol=1e-15)
        sensor = (raw(0, s, "measuredHeight", segment.num_points) * S_MULT + S_OFF).astype(">f4")
        np.testing.assert_array_equal(segment.channels["measuredHeight"], sensor.astype(float) + S_NOM_OFF)


def test_unknown_channel_in_its_default_slot_or_base(tmp_path):
    members = build_members("force")
    shared = members["shared-data/header.properties"]
    aux = {"channel.name": "aux3", "conversion-set.conversions.list": "user",
           "conversion-set.conversions.default": "user", "conversion-set.conversions.base": "volts",
           "conversion-set.conversion.user.defined": "false", "encoder.type": "signedshort",
           "encoder.scaling.multiplier": "0.25", "encoder.scaling.offset": "-1.0",
           "encoder.scaling.unit.unit": "V"}
    shared.update({f"lcd-info.7.{k}": v for k, v in aux.items()})
    for s, (_, _, n, *_rest) in enumerate(SEGMENTS):
        head = members[f"segments/{s}/segment-header.properties"]
        head["channels.list"] += " aux3"
        head.update({"channel.aux3.lcd-info.*": "7", "channel.aux3.data.file.name": "channels/aux3.dat"})
        members[f"segments/{s}/channels/aux3.dat"] = np.arange(n, dtype=">i2").tobytes()
    segment = read_jpk(write(tmp_path / "aux.jpk-force", members)).curve(0).segments[0]
    assert segment.units["aux3"] == "V"
    np.testing.assert_array_equal(segment.channels["aux3"], np.arange(4) * 0.25 - 1.0)


def test_committed_fixtures_decode_like_fresh_ones():
    assert read_jpk(FIXTURES / "synthetic.jpk-force").n_curves == 1
    check_synthetic_curve(read_jpk(FIXTURES / "synthetic.jpk-force").curve(0), 0)
    archive = read_jpk(FIXTURES / "synthetic-2x2.jpk-force-map")
    assert archive.grid == jpk.JPKGrid(**GRID)
    for c, curve in enumerate(archive.curves()):
        check_synthetic_curve(curve, c)


def test_file_is_never_modified(map_file):
    before = hashlib.sha256(map_file.read_bytes()).hexdigest(), map_file.stat().st_mtime_ns
    list(read_jpk(map_file).curves())
    assert (hashlib.sha256(map_file.read_bytes()).hexdigest(), map_file.stat().st_mtime_ns) == before


def test_error_class_and_index_errors(force_file):
    assert issubclass(InstrumentFormatError, ViscoforceError)
    assert issubclass(InstrumentFormatError, ValueError)
    archive = read_jpk(force_file)
    with pytest.raises(IndexError, match="curve index 1 out of range for 1 curves"):
        archive.curve(1)
    with pytest.raises(TypeError):
        archive.curve(0.5)


# ── every error branch ───────────────────────────────────────────────────────────────────────

SEG0 = "segments/0/segment-header.properties"
SHARED = "shared-data/header.properties"
VDEF = "lcd-info.2.conversion-set.conversion."
HEIGHT = "lcd-info.0.conversion-set.conversion."


def _drop(members, member, key):
    del members[member][key]


ERRORS = {  # id: (edit of the members of a single curve, message pattern)
    "wrong type": (lambda m: m["header.properties"].update(type="spm-image"),
                   r"header\.properties: type='spm-image' is not a JPK force curve or force map"),
    "missing segment": (lambda m: [m.pop(k) for k in list(m) if k.startswith("segments/1/")],
                        r"segments/: segment\(s\) \[1\] missing \(found \[0, 2\]\)"),
    "count": (lambda m: m["header.properties"].update({"force-scan-series.force-segments.count": "4"}),
              r"header\.properties: force-scan-series\.force-segments\.count=4 but the archive holds 3"),
    "no shared data": (lambda m: m.pop(SHARED),
                       rf"{SEG0}: 'channel\.height\.lcd-info\.\*=0' refers to 'lcd-info\.0\.\*'"),
    "missing key": (lambda m: _drop(m, SEG0, "force-segment-header.num-points"),
                    rf"{SEG0}: missing key 'force-segment-header\.num-points'"),
    "not a number": (lambda m: m[SEG0].update({"force-segment-header.duration": "fast"}),
                     rf"{SEG0}: 'force-segment-header\.duration' is not a number: 'fast'"),
    "negative points": (lambda m: m[SEG0].update({"force-segment-header.num-points": "-1"}),
                        r"num-points=-1, duration=0\.4: must be >= 0"),
    "missing slot": (lambda m: [m[SHARED].pop(k) for k in list(m[SHARED])
                                if k.startswith("lcd-info.0.conversion-set.conversion.calibrated.")],
                     rf"{SEG0}: channel 'height' has no calibration slot 'calibrated' "
                     r"\(needed for 'calibrated'; defined slots: nominal\)"),
    "undefined slot": (lambda m: m[SHARED].update({VDEF + "distance.defined": "false"}),
                       r"channel 'vDeflection' has no calibration slot 'distance'"),
    "slot loop": (lambda m: m[SHARED].update({VDEF + "distance.base-calibration-slot": "force"}),
                  r"channel 'vDeflection': calibration slots loop at 'distance'"),
    "points vs data": (lambda m: m[SEG0].update({"force-segment-header.num-points": "5"}),
                       r"segments/0/channels/height\.dat: holds 8 bytes = 4 samples of >i2, but the "
                       r"segment header says num-points=5"),
    "channel points": (lambda m: m[SEG0].update({"channel.vDeflection.data.num-points": "3"}),
                       r"segments/0/channels/vDeflection\.dat: .* \(channel num-points=3\)"),
    "short data file": (lambda m: m.update({"segments/2/channels/height.dat": b"\x00\x01\x02"}),
                        r"segments/2/channels/height\.dat: holds 3 bytes = 1\.5 samples"),
    "missing data file": (lambda m: m.pop("segments/1/channels/measuredHeight.dat"),
                          r"segments/1/channels/measuredHeight\.dat: missing from the archive"),
    "unknown encoder": (lambda m: m[SHARED].update({"lcd-info.1.encoder.type": "bcd"}),
                        r"channel\.measuredHeight\.encoder\.type='bcd' is an unknown encoder"),
    "no encoder": (lambda m: _drop(m, SHARED, "lcd-info.1.encoder.type"),
                   r"channel 'measuredHeight': unknown encoder \(no channel\.measuredHeight\.encoder\.type"),
    "data format": (lambda m: m[SEG0].update({"channel.height.data.file.format": "zip"}),
                    r"channel 'height': data file format 'zip' is not supported"),
    "nonlinear": (lambda m: m[SHARED].update({VDEF + "force.scaling.type": "polynomial"}),
                  r"force\.scaling\.type=polynomial, style=offsetmultiplier: only linear"),
    "unit": (lambda m: m[SHARED].update({HEIGHT + "calibrated.scaling.unit.unit": "nm"}),
             r"channel 'height' slot 'calibrated' is in 'nm', expected 'm'"),
    "modulation frequency": (lambda m: _drop(m, SHARED, "force-segment-header-info.2.settings."
                                                        "segment-settings.frequency"),
                             r"segments/1/segment-header\.properties: modulation segment "
                             r"\(sine-z-modulation-segment-settings\) without"),
    "no vDeflection": (lambda m: [h.update({"channels.list": "height measuredHeight"})
                                  for k, h in m.items() if k.endswith("segment-header.properties")],
                       r"segments/: no segment has a vDeflection channel"),
    "force chain": (lambda m: m[SHARED].update({VDEF + "force.base-calibration-slot": "volts"}),
                    rf"{SEG0}: vDeflection slots force <- volts, distance <- volts"),
    "bad escape": (lambda m: m.update({"header.properties": b"type=force-scan-series\nx=\\u12\n"}),
                   r"header\.properties: malformed \\uXXXX escape"),
    "bad position": (lambda m: m["header.properties"].update({"force-scan-series.header.position.x": "?"}),
                     r"header\.properties: 'force-scan-series\.header\.position\.x' is not a number"),
}


@pytest.mark.parametrize("case", list(ERRORS))
def test_error_branches_name_file_member_and_problem(tmp_path, case):
    edit, pattern = ERRORS[case]
    members = build_members("force")
    edit(members)
    path = write(tmp_path / "bad.jpk-force", members)
    with pytest.raises(InstrumentFormatError, match=pattern) as info:
        archive = read_jpk(path)
        archive.curve(0)
    assert str(info.value).startswith(str(path))


def test_missing_file_empty_file_and_not_a_zip(tmp_path):
    with pytest.raises(InstrumentFormatError, match=r"nothere\.jpk-force: no such file"):
        read_jpk(tmp_path / "nothere.jpk-force")
    (tmp_path / "empty.jpk-force").write_bytes(b"")
    with pytest.raises(InstrumentFormatError, match=r"empty\.jpk-force: is empty \(0 bytes\)"):
        read_jpk(tmp_path / "empty.jpk-force")
    (tmp_path / "text.jpk-force").write_text("jpk-data-file=spm-forcefile\n")
    with pytest.raises(InstrumentFormatError, match=r"text\.jpk-force: is not a readable zip archive"):
        read_jpk(tmp_path / "text.jpk-force")


def test_truncated_archive(tmp_path, force_file):
    data = force_file.read_bytes()
    (tmp_path / "cut.jpk-force").write_bytes(data[: len(data) // 2])
    with pytest.raises(InstrumentFormatError, match=r"cut\.jpk-force: is not a readable zip .*truncated"):
        read_jpk(tmp_path / "cut.jpk-force")


def test_corrupt_member_data(tmp_path):
    members = build_members("force")
    data = bytearray(zip_bytes(members))
    with zipfile.ZipFile(io.BytesIO(bytes(data))) as zf:
        info = zf.getinfo("segments/1/channels/vDeflection.dat")
    start = info.header_offset + 30 + len(info.filename) + len(info.extra)
    data[start:start + info.compress_size] = bytes(b ^ 0x5A for b in data[start:start + info.compress_size])
    path = tmp_path / "corrupt.jpk-force"
    path.write_bytes(bytes(data))
    archive = read_jpk(path)                                 # headers are fine ...
    with pytest.raises(InstrumentFormatError,
                       match=r"segments/1/channels/vDeflection\.dat: cannot be read .*truncated or corrupt"):
        archive.curve(0)                                     # ... the channel is not


def test_zip_without_jpk_member_and_bad_members(tmp_path):
    with pytest.raises(InstrumentFormatError, match=r"docs\.zip: neither a JPK archive .* nor a zip of"):
        read_jpk(write(tmp_path / "docs.zip", {"readme.txt": b"hello"}))
    with pytest.raises(InstrumentFormatError, match=r"set\.zip!x\.jpk-force: is not a readable zip archive"):
        read_jpk(write(tmp_path / "set.zip", {"x.jpk-force": b"not a zip"}))
    with pytest.raises(InstrumentFormatError, match=r"set2\.zip!y\.jpk-force: not a JPK archive"):
        read_jpk(write(tmp_path / "set2.zip", {"y.jpk-force": zip_bytes({"other.txt": b""})}))


def test_map_errors(tmp_path):
    members = build_members("force-map")
    del members["index/1/header.properties"]
    archive = read_jpk(write(tmp_path / "m1.jpk-force-map", members))
    archive.curve(0)
    with pytest.raises(InstrumentFormatError, match=r"m1\.jpk-force-map: index/1/header\.properties: missing"
                       r" from the archive"):
        archive.curve(1)
    empty = {"header.properties": build_members("force-map")["header.properties"]}
    with pytest.raises(InstrumentFormatError, match=r"m2\.jpk-force-map: the force map holds no curve"):
        read_jpk(write(tmp_path / "m2.jpk-force-map", empty))
    members = build_members("force-map")
    members["header.properties"]["force-scan-map.position-pattern.grid.unit.unit"] = "um"
    with pytest.raises(InstrumentFormatError, match=r"header\.properties: .*grid\.unit\.unit='um', expected"):
        read_jpk(write(tmp_path / "m3.jpk-force-map", members))
    members = build_members("force-map")
    members["header.properties"]["force-scan-map.position-pattern.grid.ilength"] = "2.5"
    with pytest.raises(InstrumentFormatError, match=r"grid\.ilength' is not an integer: '2\.5'"):
        read_jpk(write(tmp_path / "m4.jpk-force-map", members))


# ── the real files ───────────────────────────────────────────────────────────────────────────


def real(name: str) -> Path:
    path = REAL / name
    if not path.is_file():
        pytest.skip(f"real data file not present: {path}")
    return path


def _check_physics(curve: jpk.JPKCurve) -> None:
    """force = k·deflection; piezo height falls on the extend, rises on the retract; time is continuous."""
    for segment in curve.segments:
        np.testing.assert_allclose(segment.channels["force"],
                                   curve.spring_constant * segment.channels["vDeflection"], rtol=1e-14)
        steps = np.diff(segment.channels["height"])
        if segment.style == "extend":
            assert np.all(steps <= 0) and steps.sum() < 0
        if segment.style == "retract":
            assert np.all(steps >= 0) and steps.sum() > 0
    start = 0.0
    for before, after in itertools.pairwise(curve.segments):
        start += before.duration
        step = before.duration / before.num_points
        assert after.start_time == pytest.approx(start, rel=1e-12)
        assert after.time[0] == pytest.approx(before.time[-1] + step, rel=1e-12)


def test_real_modulation_map():
    path = real("PyFMReader/map-data-2021.11.05-17.37.44.432.jpk-force-map")
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    archive = read_jpk(path)
    assert (archive.kind, archive.n_curves) == ("force-map", 16)
    assert (archive.grid.ilength, archive.grid.jlength) == (4, 4)
    assert archive.grid.ulength == pytest.approx(5e-6) and archive.grid.vlength == pytest.approx(5e-6)
    assert archive.metadata["force-scan-map.settings.force-settings.global-settings.closed-loop"] == "false"
    positions = set()
    for curve in archive.curves():
        assert len(curve.segments) == 9
        assert curve.spring_constant == pytest.approx(0.009727, abs=5e-7)
        assert curve.sensitivity == pytest.approx(3.848e-8, abs=5e-12)
        styles = [s.style for s in curve.segments]
        assert styles == ["extend", "pause"] + ["modulation"] * 6 + ["retract"]
        assert curve.segments[1].type == "constant-force-pause"
        modulations = [s.modulation for s in curve.segments if s.type == "sine-z-modulation-segment-settings"]
        assert [m.frequency for m in modulations] == [300, 3, 100, 30, 1, 10]
        assert all(m.amplitude == pytest.approx(15e-9) and m.start_phase == 0.0 for m in modulations)
        assert [s.num_points for s in curve.segments[2:8]] == [2000, 2000, 4000, 4000, 1000, 4000]
        for segment in curve.segments:
            assert set(segment.channels) == {"height", "vDeflection", "force", "measuredHeight"}
        positions.add((curve.x, curve.y))
        _check_physics(curve)
    assert len(positions) == 16
    assert hashlib.sha256(path.read_bytes()).hexdigest() == digest


def test_real_stress_relaxation_curve():
    path = real("afmformats/fmt-jpk-sr_cell1-0008.jpk-force")
    archive = read_jpk(path)
    assert (archive.kind, archive.n_curves, archive.grid) == ("force", 1, None)
    curve = archive.curve(0)
    assert curve.spring_constant == pytest.approx(1.0677, rel=1e-12)
    assert curve.sensitivity == pytest.approx(1.1028e-7, rel=1e-12)
    assert [s.style for s in curve.segments] == ["pause", "extend", "pause", "retract"]
    assert [s.type for s in curve.segments] == ["constant-height-pause", "z-extend-height",
                                                "constant-height-pause", "z-retract-height"]
    assert [s.duration for s in curve.segments[:3]] == [1.0, 1.0, 30.0]
    assert curve.segments[3].num_points == 1951           # truncated: 2048 planned
    assert curve.segments[3].settings["force-segment-header.settings.segment-settings.num-points"] == "2048"
    assert all("strainGaugeHeight" in s.channels and s.units["strainGaugeHeight"] == "m"
               for s in curve.segments)
    hold = curve.segments[2].channels
    assert np.ptp(hold["height"]) > 0.5e-6 and np.ptp(hold["strainGaugeHeight"]) < 30e-9
    _check_physics(curve)


@pytest.mark.parametrize("name", ["fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force",
                                  "fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force"])
def test_real_creep_curves(name):
    curve = read_jpk(real(f"afmformats/{name}")).curve(0)
    assert curve.spring_constant == pytest.approx(0.061, rel=1e-12)
    assert curve.sensitivity == pytest.approx(6.086e-8, rel=1e-12)
    assert [s.style for s in curve.segments] == ["extend", "pause", "retract"]
    assert [s.type for s in curve.segments] == ["z-extend-force", "constant-force-pause", "z-retract-height"]
    assert curve.segments[1].duration == 3.0
    assert "measuredHeight" in curve.segments[1].channels
    assert ["capacitiveSensorHeight" in s.channels for s in curve.segments] == [True, False, True]
    _check_physics(curve)


def test_real_pyfmrheo_map():
    archive = read_jpk(real("PyFMRheo/map-data-2022.10.29-12.27.34.564.jpk-force-map"))
    assert (archive.kind, archive.n_curves) == ("force-map", 16)
    assert archive.grid.ulength == pytest.approx(20e-6)
    for curve in archive.curves():
        assert [s.style for s in curve.segments] == ["extend", "retract"]
        assert curve.spring_constant == pytest.approx(0.191, rel=1e-12)
        assert curve.sensitivity == pytest.approx(14.68e-9, rel=1e-3)
        _check_physics(curve)
    assert archive.curve(1).segments[0].num_points == 3090      # an extend stopped early


def test_real_zip_of_fifteen_curves():
    archive = read_jpk(real("afmformats/10.1002_btm2.10294_fig5d-cell1.zip"))
    assert (archive.kind, archive.n_curves) == ("zip", 15)
    curves = list(archive.curves())
    assert [c.source for c in curves] == [f"cell1-{i:04d}.jpk-force!" for i in range(1, 16)]
    assert all(c.spring_constant == pytest.approx(1.0677) for c in curves)
    retract_points = [c.segments[3].num_points for c in curves]          # truncated: 2048 planned
    assert (min(retract_points), max(retract_points)) == (1921, 1977)
    single = read_jpk(real("afmformats/fmt-jpk-sr_cell1-0008.jpk-force")).curve(0)
    for mine, theirs in zip(curves[7].segments, single.segments, strict=True):   # byte-identical file
        np.testing.assert_array_equal(mine.channels["force"], theirs.channels["force"])
