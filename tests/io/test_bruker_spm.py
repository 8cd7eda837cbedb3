r"""Bruker Nanoscope ``.spm`` force curves: the real file equals its UFF export; hand-made files.

The real pair (../shared/data/real/PyFMReader, skipped when absent) is one curve saved by
Nanoscope 9.2 and its UFF text export made by another program: the two readers must give the
same dataset (force, height and every derived variable within 1e-6 relative: the UFF writes 7
significant digits). The synthetic files are written here, a handmade header + little-endian
integers, with a scaling worked out by hand in the test.
"""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import REAL_DATA_DIR
from viscoforce.cli import main
from viscoforce.exceptions import InstrumentFormatError
from viscoforce.io.bruker import detect_nanoscope, read_nanoscope
from viscoforce.io.instruments import detect_format, load_instrument
from viscoforce.schema import validate_curves

REAL = REAL_DATA_DIR / "PyFMReader"
SPM = REAL / "20200904_Egel4-Z1.0_00025.spm"
UFF = REAL / "20200904_Egel4-Z1.0_00025.uff"
#: the UFF export writes 7 significant digits (2.929688E-09 for 3 µm / 1024)
RTOL = 1e-6


def _real(path: Path) -> Path:
    if not path.is_file():
        pytest.skip(f"real data file not present: {path}")
    return path


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# ── the real file and its UFF export ──────────────────────────────────────────────────────────


def test_real_spm_equals_its_uff_export():
    spm, uff = _real(SPM), _real(UFF)
    before = _sha(spm)
    assert detect_format(spm).name == "nanoscope"
    a, b = load_instrument(spm), load_instrument(uff)
    assert _sha(spm) == before  # read-only
    validate_curves(a)
    assert a.attrs["source"] == "nanoscope" and b.attrs["source"] == "uff"
    assert a.sizes == b.sizes == {"sample": 2048, "curve": 1, "segment_table": 2}
    assert set(a.variables) == set(b.variables)
    for name in ("force", "height", "deflection", "tip_position", "time"):
        np.testing.assert_allclose(a[name].values, b[name].values, rtol=RTOL, atol=0,
                                   err_msg=name)
        assert a[name].attrs == b[name].attrs, name  # units, long names
    for seg in (0, 1):  # every segment, each within 1e-6 relative
        mask = b["segment"].values == seg
        assert mask.sum() == 1024
        for name in ("force", "height"):
            np.testing.assert_allclose(a[name].values[mask], b[name].values[mask], rtol=RTOL,
                                       atol=0, err_msg=f"{name} segment {seg}")
    np.testing.assert_array_equal(a["segment"].values, b["segment"].values)
    assert list(a["segment_name"].values) == list(b["segment_name"].values) == [
        "approach", "retract"]
    assert list(a["segment_type"].values) == list(b["segment_type"].values)
    for name in ("spring_constant", "sensitivity", "x", "y", "sample_count"):
        assert a[name].values.tolist() == b[name].values.tolist(), name
    assert (float(a["spring_constant"][0]), float(a["sensitivity"][0])) == (0.1332, 2.739e-8)
    for key in ("n_curves", "force_baseline_subtracted", "sample_order", "time_channel"):
        assert a.attrs[key] == b.attrs[key], key
    # an independent read of the first raw samples: 4-byte integers under "Bytes/pixel: 2"
    raw = np.frombuffer(spm.read_bytes()[80960:80960 + 8192], "<i4")
    assert raw[0] == 4264 and a.attrs["meta_nanoscope_bytes_pixel"] == 2.0
    # the approach's first row (turnaround) is its last sample in time
    assert a["deflection"].values[1023] == pytest.approx(4264 * 0.000375 * 27.39e-9, rel=1e-14)
    assert a["height"].values[1023] == 0.0
    assert a["height"].values[0] == pytest.approx(1023 / 1024 * 227.2211 * 13.203e-9,
                                                  rel=1e-14)
    assert "4-byte samples (the header's Bytes/pixel says 2)" in a.attrs["nanoscope_scaling"]
    assert a.attrs["meta_nanoscope_version"] == "0x0920B046"
    assert a.attrs["meta_nanoscope_deflection_sensitivity_correction"] == 1.08
    assert "tip_shape" not in a.attrs  # the .spm records no tip (the .uff's 20° is added)


def test_real_spm_recalibrated(tmp_path):
    spm = _real(SPM)
    a = read_nanoscope(spm)
    b = read_nanoscope(spm, spring_constant="0.2N/m", sensitivity="30nm/V")
    np.testing.assert_allclose(b["force"].values,
                               a["deflection"].values / 27.39e-9 * 30e-9 * 0.2, rtol=1e-13)
    assert float(b["spring_constant"][0]) == 0.2 and "(spring_constant)" in b.attrs[
        "force_channel"]


def test_real_spm_cli_load_json(capsys, tmp_path):
    spm = _real(SPM)
    out = tmp_path / "curves.nc"
    assert main(["load", str(spm), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["format"] == "nanoscope" and result["kind"] == "curves"
    assert result["dims"] == {"sample": 2048, "curve": 1, "segment_table": 2}
    assert main(["load", str(spm), "--out", str(out)]) == 0
    assert out.is_file()


@pytest.mark.parametrize("keep", [0, 2000, 34000, 80960, 80960 + 4096, 89151])
def test_real_spm_truncated_is_refused_by_name(tmp_path, keep):
    path = tmp_path / "cut.spm"
    path.write_bytes(_real(SPM).read_bytes()[:keep])
    if keep == 0:
        assert not detect_nanoscope(path)
        return
    with pytest.raises(InstrumentFormatError, match=re.escape(str(path))) as info:
        read_nanoscope(path)
    assert "truncated" in str(info.value)


# ── hand-made files: a scaling computed by hand ───────────────────────────────────────────────

#: Zsens 10 nm/V, Ramp Size 100 V → ramp 1000 nm; 4 samples → 250 nm steps; hard scale
#: 0.0005 V/LSB, DeflSens 20 nm/V → 1 LSB = 10 pm; k = 0.05 N/m; 50 V/s x 10 nm/V = 500 nm/s.
_APPROACH = [400, 200, 0, -20]  # from the turnaround outward
_RETRACT = [380, 100, 10, -10]
_SECTIONS = {
    "Force file list": {"Version": "0x0920B046", "Data length": "@HEADER"},
    "Scanner list": {"@Sens. Zsens": "V 10.00000 nm/V"},
    "Ciao scan list": {"Operating mode": "Force", "X Offset": "100 nm", "Y Offset": "-2 ~m",
                       "@Sens. DeflSens": "V 20.00000"},
    "Ciao force list": {"Forward vel.": "50", "Reverse vel.": "25", "Hold Time": "0",
                        "Deflection Sensitivity Correction": "1.08"},
    "Ciao force image list": {
        "Data offset": "@HEADER", "Data length": "@LENGTH", "Bytes/pixel": "2",
        "Samps/line": "4 4", "Spring Constant": "0.05",
        "@4:Image Data": 'S [DeflectionError] "Deflection Error"',
        "@4:Z scale": "V [Sens. DeflSens] (0.0005000000 V/LSB) 2.500000 V",
        "@4:Ramp Size": "V [Sens. Zsens] (0.006713765 V/LSB) 100.0000 V"},
}


def _spm(tmp_path: Path, *, width=2, raw=None, change=None, drop=(), extra=None,
         name="curve.spm", cut=None) -> Path:
    sections = {s: dict(f) for s, f in _SECTIONS.items()}
    for section, fields in (change or {}).items():
        sections.setdefault(section, {}).update(fields)
    for section, key in drop:
        del sections[section][key]
    values = np.array(raw if raw is not None else _APPROACH + _RETRACT)
    data = values.astype("<i2" if width == 2 else "<i4").tobytes()
    header_size = 4096
    lines = []
    for section, fields in sections.items():
        lines.append(f"\\*{section}")
        for key, value in fields.items():
            value = value.replace("@HEADER", str(header_size)).replace("@LENGTH", str(len(data)))
            lines.append(f"\\{key}: {value}")
    lines += (extra or [])
    text = ("\r\n".join(lines) + "\r\n\\*File list end\r\n").encode("latin-1")
    assert len(text) < header_size
    blob = text + b"\x1a" * (header_size - len(text)) + data
    path = tmp_path / name
    path.write_bytes(blob[:cut] if cut is not None else blob)
    return path


@pytest.mark.parametrize("width", [2, 4])
def test_synthetic_spm_values_computed_by_hand(tmp_path, width):
    ds = read_nanoscope(_spm(tmp_path, width=width))
    validate_curves(ds)
    nm, lsb = 1e-9, 0.0005 * 20e-9  # 1 LSB = 10 pm of deflection
    # the approach in time order: from 750 nm toward the turnaround (rows reversed)
    np.testing.assert_allclose(ds["height"].values,
                               np.array([750, 500, 250, 0, 0, 250, 500, 750]) * nm, rtol=1e-15)
    expected = np.array(_APPROACH[::-1] + _RETRACT) * lsb
    np.testing.assert_allclose(ds["deflection"].values, expected, rtol=1e-15, atol=0)
    np.testing.assert_allclose(ds["force"].values, 0.05 * expected, rtol=1e-15, atol=0)
    assert ds["deflection"].values[3] == pytest.approx(4e-9, rel=1e-15)  # 400 LSB x 10 pm
    # dt = 250 nm / (50 V/s x 10 nm/V) = 0.5 s approaching; 250 nm / 250 nm/s = 1 s retracting
    np.testing.assert_allclose(ds["time"].values, [0, 0.5, 1, 1.5, 2.5, 3.5, 4.5, 5.5],
                               rtol=1e-14)
    assert (float(ds["x"][0]), float(ds["y"][0])) == (pytest.approx(1e-7), pytest.approx(-2e-6))
    assert float(ds["spring_constant"][0]) == 0.05
    assert float(ds["sensitivity"][0]) == pytest.approx(20e-9, rel=1e-15)
    assert list(ds["segment"].values) == [0] * 4 + [1] * 4
    assert ds.attrs["meta_nanoscope_operating_mode"] == "Force"
    says = ds.attrs["nanoscope_scaling"]
    assert "Deflection Error [V] = raw x 0.0005 V/LSB" in says and f"{width}-byte" in says


_CASES = [
    ({"drop": [("Scanner list", "@Sens. Zsens")]}, r"soft scale 'Sens. Zsens', which the header"),
    ({"change": {"Ciao force image list": {"Samps/line": "4"}}}, r"not two sample counts"),
    ({"change": {"Ciao force image list": {"Samps/line": "4 3"}}}, r"unequal approach and"),
    ({"change": {"Ciao force image list": {"Data length": "12"}}}, r"not 2 or 4 bytes per"),
    ({"change": {"Ciao force image list": {"Data offset": "100"}}}, r"truncated or damaged"),
    ({"cut": 4096 + 10}, r"bytes 4096 to 4112 .* the file has 4106 bytes"),
    ({"width": 4, "raw": [40000] + _APPROACH[1:] + _RETRACT}, r"4-byte sample 0 is 40000"),
    ({"change": {"Ciao scan list": {"Operating mode": "Force Volume"}}}, r"a force volume"),
    ({"change": {"Ciao image list": {"Samps/line": "16", "Number of lines": "16"}}},
     r"a force volume \(16 x 16 pixels"),
    ({"change": {"Ciao scan list": {"Operating mode": "PeakForce Capture"}}},
     r"operating mode 'PeakForce Capture'"),
    ({"change": {"Ciao force list": {"Hold Time": "0.5"}}}, r"a surface hold"),
    ({"change": {"Ciao force image list": {"@4:Image Data": 'S [Height] "Height"'}}},
     r"no deflection channel among"),
    ({"change": {"Ciao force image list": {"@4:Z scale": "V [Sens. DeflSens] 2.5 V"}}},
     r"no positive hard scale in V/LSB"),
    ({"change": {"Ciao force image list": {"@4:Ramp Size": "S [x] \"y\""}}},
     r"'@4:Ramp Size' = 'S \[x\] \"y\"' is not a scaled value"),
    ({"change": {"Ciao force list": {"Forward vel.": "-3"}}}, r"'\\Forward vel.' = '-3'"),
    ({"drop": [("Ciao force image list", "Spring Constant")]},
     r"gives no spring constant .*--spring-constant"),
    ({"change": {"Ciao force image list": {"Spring Constant": "5e6"}}},
     r"spring constant Spring Constant \(N/m\) = 5000000.0 is outside the plausible range"),
    ({"change": {"Scanner list": {"@Sens. Zsens": "V 10 V/V"}}}, r"not a positive length per"),
]


@pytest.mark.parametrize(("kwargs", "match"), _CASES)
def test_synthetic_damaged_spm_is_refused_naming_file_and_field(tmp_path, kwargs, match):
    path = _spm(tmp_path, **kwargs)
    with pytest.raises(InstrumentFormatError, match=match) as info:
        read_nanoscope(path)
    assert str(info.value).startswith(str(path))


def test_no_end_marker_and_not_nanoscope(tmp_path):
    text = _spm(tmp_path).read_bytes()
    cut = tmp_path / "nohead.spm"
    cut.write_bytes(text[:200])
    with pytest.raises(InstrumentFormatError, match=r"no '\\\*File list end' line"):
        read_nanoscope(cut)
    other = tmp_path / "other.spm"
    other.write_bytes(b"not a nanoscope file")
    with pytest.raises(InstrumentFormatError, match=r"not a Bruker Nanoscope file"):
        read_nanoscope(other)
    with pytest.raises(InstrumentFormatError, match=r"no such file"):
        read_nanoscope(tmp_path / "missing.spm")

