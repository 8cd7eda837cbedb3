"""Format detection says what is wrong with a damaged file (issue 25, item 4).

A file no format recognises gets the closest format and its first failure (a truncated archive,
a JPK archive without header.properties, UTF-16 text, a header cell without a unit, a missing
column), not the whole list of formats; the list of format names is a short last line only when
the guess is weak. Sample-level errors of a JPK archive name file, curve, segment and channel.
"""

from __future__ import annotations

import io
import re
import zipfile
from pathlib import Path

import numpy as np
import pytest

from viscoforce.cli import main
from viscoforce.exceptions import InstrumentFormatError, ParameterError, ViscoforceError
from viscoforce.io.instruments import detect_format, load_instrument
from viscoforce.io.jpk import JPKArchive

FIXTURES = Path(__file__).resolve().parents[1] / "data" / "jpk"
JPK = FIXTURES / "synthetic.jpk-force"
JPK_MAP = FIXTURES / "synthetic-2x2.jpk-force-map"
SPECTRUM = "frequency (Hz),stiffness (N/m),phase (deg)\n1,1,10\n2,1,20\n"
#: words of the old 849-character list of every format's description
OLD_LIST = ("Asylum", "Optics11", "NT-MDT", "recognised only")


def write(path: Path, data: str | bytes) -> Path:
    path.write_bytes(data.encode() if isinstance(data, str) else data)
    return path


def refusal(path: Path) -> str:
    """The detection message without the path, checked for length and the old list."""
    with pytest.raises(InstrumentFormatError) as info:
        detect_format(path)
    message = str(info.value)
    assert message.startswith(f"{path}: not a known instrument format: ")
    rest = message[len(str(path)):]
    assert len(rest) < 300, rest
    assert not any(word in rest for word in OLD_LIST), rest
    return rest


def _zip(members: dict[str, bytes]) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return buffer.getvalue()


def _without(path: Path, member: str) -> bytes:
    with zipfile.ZipFile(path) as archive:
        return _zip({n: archive.read(n) for n in archive.namelist() if n != member})


# ── the closest format and its first failure ────────────────────────────────────────────────────


def test_utf16_with_a_bom(tmp_path):
    rest = refusal(write(tmp_path / "u.csv", ("time (s),force (nN),height (nm)\n0,1,2\n")
                         .encode("utf-16")))
    assert "UTF-16 text (a table with the header 'time (s),force (nN),height (nm)'): save it " \
           "as UTF-8" in rest
    assert "known formats" not in rest  # a sure guess needs no list


def test_utf16_without_a_bom_and_without_a_table(tmp_path):
    rest = refusal(write(tmp_path / "u.csv", SPECTRUM.encode("utf-16-le")))
    assert "UTF-16 text (a table with the header 'frequency (Hz),stiffness (N/m),phase (deg)')" \
        in rest
    rest = refusal(write(tmp_path / "v.txt", "hello\nworld\n".encode("utf-16-be")))
    assert "UTF-16 text: save it as UTF-8; known formats: jpk (.jpk-force), csv-curves" in rest


def test_utf16_read_directly_says_so(tmp_path):
    from viscoforce.io.csv_formats import read_spectrum_csv

    with pytest.raises(InstrumentFormatError, match=r"UTF-16 text .*save it as UTF-8"):
        read_spectrum_csv(write(tmp_path / "u.csv", SPECTRUM.encode("utf-16")))


def test_a_trailing_comma_is_read(tmp_path):
    path = write(tmp_path / "t.csv", "frequency (Hz),stiffness (N/m),phase (deg),\n1,1,10,\n"
                                     "2,1,20,\n")
    assert detect_format(path).name == "csv-spectrum"
    np.testing.assert_allclose(load_instrument(path)["phase"].values, [10, 20])


def test_a_truncated_jpk_archive(tmp_path):
    data = JPK.read_bytes()
    for cut in (200, len(data) // 2, len(data) - 30):
        rest = refusal(write(tmp_path / f"cut{cut}.jpk-force", data[:cut]))
        assert re.search(r"a JPK archive \(first member 'header.properties'\) that is truncated "
                         r"or damaged \(.*\); copy it again$", rest), rest


def test_a_truncated_jpk_map(tmp_path):
    data = JPK_MAP.read_bytes()
    rest = refusal(write(tmp_path / "cut.jpk-force-map", data[: len(data) // 3]))
    assert "a JPK archive (first member" in rest and "truncated or damaged" in rest


def test_a_zip_without_jpk_members(tmp_path):
    rest = refusal(write(tmp_path / "other.zip", _zip({"readme.txt": b"x", "notes.md": b"y",
                                                       "a.dat": b"1", "b.dat": b"2"})))
    assert ("a zip archive without .jpk-force members or files afmformats reads (members: "
            "'readme.txt', 'notes.md', 'a.dat' and 1 more)") in rest
    assert rest.endswith("known formats: jpk (.jpk-force), csv-curves, csv-spectrum, afmformats, "
                         "uff, nanoscope")
    assert "an empty zip archive" in refusal(write(tmp_path / "empty.zip", _zip({})))


def test_a_jpk_archive_without_header_properties(tmp_path):
    rest = refusal(write(tmp_path / "h.jpk-force", _without(JPK, "header.properties")))
    assert re.search(r"a JPK archive without header.properties \(\d+ members, e.g. "
                     r"'segments/0/[^']+'\): incomplete; export it again$", rest), rest


@pytest.mark.parametrize(("text", "expected"), [
    ("frequency,stiffness,phase\n1,1,1\n",
     "looks like a CSV spectrum (header 'frequency,stiffness,phase') but column 'frequency' has "
     "no unit: a CSV needs a 'name (unit)' header, e.g. 'frequency (Hz)'"),
    ("frequency (Hz),stiffness (N/m)\n1,1\n",
     "looks like a CSV spectrum (header 'frequency (Hz),stiffness (N/m)') but it has no phase "
     "column 'phase (deg)'"),
    ("time (s),force (nN)\n0,1\n",
     "looks like a CSV time series (header 'time (s),force (nN)') but it has no height column "
     "'height (m)' (or 'position', 'z')"),
    ("time (s),force (nN),,height (nm)\n0,1,,2\n",
     "looks like a CSV time series (header 'time (s),force (nN),,height (nm)') but the header's "
     "cell 3 is empty"),
    ("time (s) force (N) height (m)\n0 1 2\n",
     "a header 'time (s) force (N) height (m)' of one cell: separate the columns by commas, "
     "semicolons or tabs (not spaces)"),
    ("# only a comment\n\n",
     "text without a header line (only blank or '#' lines)"),
], ids=["no-unit", "no-phase", "no-height", "empty-cell", "spaces", "comments"])
def test_text_tables(tmp_path, text, expected):
    assert expected in refusal(write(tmp_path / "t.csv", text))


def test_a_detected_table_says_what_it_lacks(tmp_path):
    path = write(tmp_path / "m.csv", "omega (rad/s),phase (deg)\n1,1\n")
    assert detect_format(path).name == "csv-spectrum"
    with pytest.raises(ParameterError, match=r"m.csv: no magnitude column: 'stiffness \(N/m\)'"):
        load_instrument(path)


def test_prose_keeps_the_short_list(tmp_path):
    rest = refusal(write(tmp_path / "notes.csv", "hello, world\n1,2\n"))
    assert "text whose first line ('hello, world') is no 'name (unit)' header like" in rest
    assert "; known formats: jpk (.jpk-force), csv-curves, csv-spectrum" in rest


@pytest.mark.parametrize(("data", "expected"), [
    (b"\x89HDF\r\n\x1a\ngarbage", "a netCDF/HDF5 file (fit and bode read the netCDF files"),
    (bytes(range(256)) * 4, "binary content (first bytes 00 01 02 03 04 05 06 07), neither a "
                            "text table nor a zip archive"),
    (b"time (s),force (nN)\n0,1\n" + b"\x00" * 100, "text up to byte 24, then NUL bytes: a "
                                                     "damaged or zero-padded file"),
], ids=["netcdf", "binary", "zero-padded"])
def test_binary_content(tmp_path, data, expected):
    assert expected in refusal(write(tmp_path / "b.dat", data))


def test_the_cli_prints_the_diagnosis_in_one_line(tmp_path, capsys):
    path = write(tmp_path / "u.csv", SPECTRUM.encode("utf-16"))
    code = main(["load", str(path), "--out", str(tmp_path / "x.nc")])
    err = capsys.readouterr().err
    assert code == 2 and "Traceback" not in err
    assert err.strip().splitlines() == [
        f"viscoforce load: error: {path}: not a known instrument format: UTF-16 text (a table "
        "with the header 'frequency (Hz),stiffness (N/m),phase (deg)'): save it as UTF-8"]


def _damaged(tmp_path: Path) -> list[Path]:
    """About fifty damaged inputs: cut, flipped, re-encoded, stripped of members or units."""
    out = []
    data = JPK.read_bytes()
    for i, cut in enumerate(np.linspace(10, len(data) - 10, 12).astype(int)):
        out.append(write(tmp_path / f"cut{i}.jpk-force", data[:cut]))
    with zipfile.ZipFile(JPK) as archive:
        names = archive.namelist()
    for name in ("header.properties",):
        out.append(write(tmp_path / "nohead.jpk-force", _without(JPK, name)))
    out.append(write(tmp_path / "zipped-csv.zip", _zip({"table.csv": SPECTRUM.encode()})))
    out.append(write(tmp_path / "only-segments.zip", _zip(
        {n: b"" for n in names if n.startswith("segments/")})))
    texts = {
        "no-units": "frequency,stiffness,phase\n1,1,1\n",
        "one-unit-missing": "frequency (Hz),stiffness,phase (deg)\n1,1,1\n",
        "no-phase": "frequency (Hz),stiffness (N/m)\n1,1\n",
        "no-time": "force (nN),height (nm)\n1,1\n",
        "no-force": "time (s),height (nm)\n0,1\n",
        "semicolon-no-unit": "time;force;height\n0;1;2\n",
        "tab-empty-cell": "time (s)\t\tforce (nN)\theight (nm)\n0\t1\t2\t3\n",
        "spaces": "frequency (Hz) stiffness (N/m) phase (deg)\n1 1 1\n",
        "comments-only": "# a\n# b\n\n",
        "prose": "This file holds the measurement of 2024-01-01.\n",
    }
    for name, text in texts.items():
        out.append(write(tmp_path / f"{name}.csv", text))
        out.append(write(tmp_path / f"{name}-utf16.csv", text.encode("utf-16")))
        out.append(write(tmp_path / f"{name}-padded.csv", text.encode() + b"\x00" * 64))
    flips = bytearray(data)
    flips[:4] = b"PK\x05\x06"
    out.append(write(tmp_path / "flipped.jpk-force", bytes(flips)))
    out.append(write(tmp_path / "hdf.nc", b"\x89HDF\r\n\x1a\n" + bytes(100)))
    return out


def test_fifty_damaged_inputs_get_specific_short_messages(tmp_path):
    paths = _damaged(tmp_path)
    assert len(paths) >= 45
    for path in paths:
        rest = refusal(path)
        assert "content not recognised" not in rest


# ── sample-level errors name file, curve, segment and channel ───────────────────────────────────


def _inject(monkeypatch, channel: str, value: float, *, curve: int = 0, segment: int = 1,
            sample: int = 7):
    original = JPKArchive._curve_only

    def patched(self, i, channels):
        decoded = original(self, i, channels)
        if i == curve:
            values = decoded.segments[segment].channels[channel]
            values[sample] = value
        return decoded

    monkeypatch.setattr(JPKArchive, "_curve_only", patched)


def test_a_nan_sample_names_file_curve_segment_and_channel(monkeypatch):
    _inject(monkeypatch, "vDeflection", float("nan"))
    with pytest.raises(InstrumentFormatError) as info:
        load_instrument(JPK)
    message = str(info.value)
    assert re.search(rf"{re.escape(str(JPK))}: curve 0 segment 1 \([\w-]+\) channel "
                     r"'vDeflection': sample 7 of \d+ is nan \(1 non-finite samples\)", message)


def test_a_nan_sample_in_a_map_names_the_curve(monkeypatch):
    _inject(monkeypatch, "force", float("inf"), curve=2, segment=0, sample=0)
    with pytest.raises(InstrumentFormatError, match=r"synthetic-2x2.jpk-force-map: curve 2 "
                                                    r"\(index/2\) segment 0 .* channel 'force': "
                                                    r"sample 0 of \d+ is inf"):
        load_instrument(JPK_MAP)


def test_an_impossible_sample_names_the_range(monkeypatch):
    _inject(monkeypatch, "force", 1e30)
    with pytest.raises(InstrumentFormatError, match=r"channel 'force': sample 7 of \d+ is 1e\+30 "
                                                    r"N, beyond the physical range -1000 <= force "
                                                    r"<= 1000 N; the file's calibration"):
        load_instrument(JPK)


def test_the_modulation_route_names_the_sample_too(monkeypatch):
    from viscoforce.experiments.modulation import modulation_spectrum

    _inject(monkeypatch, "vDeflection", float("nan"))
    with pytest.raises(ViscoforceError, match=r"curve 0 segment 1 .* channel 'vDeflection': "
                                              r"sample 7"):
        modulation_spectrum(JPK)


def test_the_csv_names_the_curve_of_a_nan(tmp_path):
    path = write(tmp_path / "c.csv", "curve,time (s),force (nN),height (nm)\na,0,1,2\nb,0,nan,2\n")
    with pytest.raises(ParameterError, match=r"column 'force \(nN\)' data row 2 \(line 3\) is not "
                                             r"a finite number \('nan'\) in curve 'b'"):
        load_instrument(path)
