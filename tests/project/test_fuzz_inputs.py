"""Fuzz: damaged inputs never crash the CLI, never change a file, never leave a partial output.

Seeded (derandomized) hypothesis runs over truncations, byte flips and header mutations of a
real JPK archive and of a spectrum CSV; each run loads through the CLI and must exit 0 (the
damage missed everything that matters) or 2 with one message, never 1 (an internal error), with
the input unchanged and no debris beside the output.
"""

from __future__ import annotations

import hashlib
import io
import zipfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tests.conftest import REAL_DATA_DIR
from viscoforce.cli import main

REPO = Path(__file__).resolve().parents[2]
JPK = REPO / "data_examples" / "sls_modulation.jpk-force"
CSV = REPO / "data_examples" / "sls_spectrum.csv"
FUZZ = settings(max_examples=60, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])


def _load(tmp: Path, name: str, data: bytes, capsys) -> tuple[int, str]:
    src = tmp / name
    src.write_bytes(data)
    before = hashlib.sha256(data).hexdigest()
    out = tmp / "out.nc"
    code = main(["load", str(src), "--out", str(out)])
    _, err = capsys.readouterr()
    assert code in (0, 2), err
    assert "internal error" not in err and "Traceback" not in err
    if code == 2:
        assert err.count("\n") == 1 and len(err) < 2000, err  # one message
    assert hashlib.sha256(src.read_bytes()).hexdigest() == before  # never modified
    debris = [p.name for p in tmp.iterdir() if p.name.startswith(".out.nc")]
    assert not debris
    for p in (src, out):
        p.unlink(missing_ok=True)
    return code, err


@FUZZ
@given(cut=st.floats(0.0, 0.999))
def test_truncated_archive(tmp_path, capsys, cut):
    data = JPK.read_bytes()
    code, err = _load(tmp_path, "x.jpk-force", data[:int(cut * len(data))], capsys)
    assert code == 2


@FUZZ
@given(flips=st.lists(st.tuples(st.floats(0.0, 0.999), st.integers(1, 255)), min_size=1,
                      max_size=8))
def test_byte_flips_in_an_archive(tmp_path, capsys, flips):
    data = bytearray(JPK.read_bytes())
    for where, xor in flips:
        data[int(where * len(data))] ^= xor
    _load(tmp_path, "x.jpk-force", bytes(data), capsys)


HEADER_VALUES = st.sampled_from(["0", "-40", "1e308", "nan", "inf", "", "abc", "1e-300",
                                 "99999999999999", "-1"])


@FUZZ
@given(value=HEADER_VALUES, which=st.integers(0, 10_000))
def test_header_mutations(tmp_path, capsys, value, which):
    """One numeric header value of one member replaced by a hostile one."""
    with zipfile.ZipFile(JPK) as zf:
        members = [(i, zf.read(i)) for i in zf.infolist()]
    headers = [k for k, (info, _) in enumerate(members)
               if info.filename.endswith(".properties")]
    k = headers[which % len(headers)]
    lines = members[k][1].decode("latin-1").splitlines()
    numeric = [n for n, line in enumerate(lines) if "=" in line and line.split("=", 1)[1]
               .strip().replace(".", "", 1).replace("-", "", 1).replace("e", "", 1).isdigit()]
    if numeric:
        n = numeric[which % len(numeric)]
        lines[n] = lines[n].split("=", 1)[0] + "=" + value
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as out:
        for idx, (info, content) in enumerate(members):
            out.writestr(info, "\n".join(lines).encode("latin-1") if idx == k else content)
    _load(tmp_path, "x.jpk-force", buffer.getvalue(), capsys)


@FUZZ
@given(cut=st.floats(0.0, 1.0), flips=st.lists(
    st.tuples(st.floats(0.0, 0.999), st.sampled_from(list(b",;\n\t-.eE9x\x00\xff"))),
    max_size=6))
def test_spectrum_csv_damage(tmp_path, capsys, cut, flips):
    data = bytearray(CSV.read_bytes()[:max(1, int(cut * CSV.stat().st_size))])
    for where, byte in flips:
        data[int(where * len(data))] = byte
    _load(tmp_path, "x.csv", bytes(data), capsys)


@pytest.mark.skipif(not (REAL_DATA_DIR / "afmformats").is_dir(), reason="no shared real data")
@FUZZ
@given(cut=st.floats(0.05, 0.999))
def test_truncated_real_files(tmp_path, capsys, cut):
    for path in sorted((REAL_DATA_DIR / "afmformats").glob("fmt-jpk-*.jpk-force"))[:1]:
        data = path.read_bytes()
        code, _ = _load(tmp_path, path.name, data[:int(cut * len(data))], capsys)
        assert code == 2
