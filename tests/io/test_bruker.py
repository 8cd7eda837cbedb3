"""Bruker Nanoscope: the UFF text reader (real file + synthetic edge cases); .spm in test_bruker_spm."""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from tests.conftest import REAL_DATA_DIR
from viscoforce.cli import main
from viscoforce.exceptions import InstrumentFormatError, ParameterError, UnitError
from viscoforce.io.bruker import detect_nanoscope, detect_uff, read_uff
from viscoforce.io.instruments import detect_format, load_instrument
from viscoforce.physics.tips import Pyramid, Tip
from viscoforce.schema import validate_curves

REAL = REAL_DATA_DIR / "PyFMReader"
UFF = REAL / "20200904_Egel4-Z1.0_00025.uff"
SPM = REAL / "20200904_Egel4-Z1.0_00025.spm"


def _real(path: Path) -> Path:
    if not path.is_file():
        pytest.skip(f"real data file not present: {path}")
    return path


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _plain_parse(path: Path) -> tuple[dict[str, str], dict[str, np.ndarray]]:
    """A separate, simple parse of a UFF file: header dict and rows per segment code."""
    header: dict[str, str] = {}
    rows: dict[str, list[list[float]]] = {}
    for line in path.read_text().splitlines():
        if line.startswith("HE "):
            key, _, value = line[3:].partition(":")
            header[key.strip()] = value.strip()
        elif line.strip() and not line.startswith("*"):
            code, _, *values = line.split()
            rows.setdefault(code, []).append([float(v) for v in values])
    return header, {code: np.array(r) for code, r in rows.items()}


# ── the real UFF file ─────────────────────────────────────────────────────────────────────────


def test_real_uff_loads_in_si_with_the_header_calibration():
    path = _real(UFF)
    header, rows = _plain_parse(path)
    k = float(header["Cantilever_springK_used(N/m)"])
    s = float(header["Recording_inv_optical_lever_sens_used(m/V)"])
    assert (k, s) == (0.1332, 2.739e-8)
    before = _sha(path)
    assert detect_uff(path) and not detect_nanoscope(path)
    assert detect_format(path).name == "uff"
    ds = load_instrument(path)
    assert _sha(path) == before
    validate_curves(ds)
    assert ds.attrs["source"] == "uff" and ds.attrs["file"] == str(path)
    assert ds.sizes == {"sample": 2048, "curve": 1, "segment_table": 2}
    assert len(rows["AP"]) == len(rows["RE"]) == 1024
    assert list(ds["segment_name"].values) == ["approach", "retract"]
    assert list(ds["segment_type"].values) == ["Approach", "Retract"]
    np.testing.assert_array_equal(ds["segment"].values, np.repeat([0, 1], 1024))
    assert float(ds["spring_constant"][0]) == k and float(ds["sensitivity"][0]) == s
    for name, unit in (("time", "s"), ("force", "N"), ("height", "m"), ("deflection", "m"),
                       ("tip_position", "m")):
        assert ds[name].attrs["units"] == unit
    # the file lists both segments from the turnaround outward: the approach is reversed
    approach, retract = rows["AP"][::-1], rows["RE"]
    height = np.concatenate([approach[:, 0], retract[:, 0]])
    volts = np.concatenate([approach[:, 1], retract[:, 1]])
    np.testing.assert_array_equal(ds["height"].values, height)
    np.testing.assert_allclose(ds["deflection"].values, volts * s, rtol=1e-15, atol=0)
    np.testing.assert_allclose(ds["force"].values, volts * s * k, rtol=1e-15, atol=0)
    np.testing.assert_allclose(ds["tip_position"].values, -height - volts * s, rtol=1e-15,
                               atol=0)
    assert ds["height"].values[0] == 2.997071e-06 and ds["height"].values[1023] == 0.0
    assert ds["deflection"].values[0] == pytest.approx(3.21e-01 * s, rel=1e-12)  # far away
    assert ds["force"].values[1023] == pytest.approx(1.599 * s * k, rel=1e-12)  # turnaround
    assert np.all(np.diff(ds["height"].values[:1024]) < 0)  # toward the sample
    assert np.all(np.diff(ds["height"].values[1024:]) > 0)  # away from it
    # time from the ramp: mean height step / velocity, the retract one interval after
    velocity = float(header["Recording_segment_0_velocity(m/s)"])
    dt = 2.997071e-06 / 1023 / velocity
    time = ds["time"].values
    np.testing.assert_allclose(time, np.arange(2048) * dt, rtol=1e-12, atol=0)
    assert dt == pytest.approx(4.8e-4, rel=1e-4)
    assert "derived from the ramp" in ds.attrs["time_channel"]
    assert "segment 0 (Approach)" in ds.attrs["time_channel"]
    assert "rows reversed" in ds.attrs["time_channel"].split(";")[0]
    assert "rows reversed" not in ds.attrs["time_channel"].split(";")[1]
    assert "segment 1 (RE) columns are '?'" in ds.attrs["column_note"]
    assert ds.attrs["force_baseline_subtracted"] == 0
    assert ds.attrs["meta_entry_filename"] == "20200904_Egel4-Z1.0_00025.spm"
    assert ds.attrs["meta_cantilever_springk_used_n_m"] == k
    assert ds.attrs["meta_experimental_instrument"] == "Multimode 8"
    assert float(ds["x"][0]) == 0.0 and float(ds["y"][0]) == 0.0


def test_real_uff_tip_is_stored_as_tip_attrs():
    ds = read_uff(_real(UFF))
    header, _ = _plain_parse(UFF)
    assert header["Tip_geometry"] == "pyramidal"
    assert ds.attrs["tip_shape"] == "pyramid"
    assert ds.attrs["tip_half_angle"] == float(header["Tip_half_angle(deg)"]) == 20.0
    tip = Tip.from_attrs(ds.attrs)
    assert isinstance(tip, Pyramid) and tip.as_attrs() == {"tip_shape": "pyramid",
                                                           "tip_half_angle": 20.0}
    # the file's "Tip_radius(m): 1.0E+01" (10 m) is not a tip radius: said, not used
    assert "tip_radius" not in ds.attrs
    assert "Tip_radius(m) = 1.000000E+01 is not a plausible tip radius" in ds.attrs["tip_note"]


def test_real_uff_recalibrated_and_round_trips(tmp_path):
    path = _real(UFF)
    _, rows = _plain_parse(path)
    ds = load_instrument(path, spring_constant="0.2N/m", sensitivity="30nm/V")
    volts = np.concatenate([rows["AP"][::-1, 1], rows["RE"][:, 1]])
    np.testing.assert_allclose(ds["force"].values, 0.2 * 30e-9 * volts, rtol=1e-14, atol=0)
    assert float(ds["spring_constant"][0]) == 0.2 and float(ds["sensitivity"][0]) == 30e-9
    assert "(spring_constant)" in ds.attrs["force_channel"]
    out = tmp_path / "uff.nc"
    ds.to_netcdf(out, engine="h5netcdf")
    with xr.open_dataset(out, engine="h5netcdf") as back:
        xr.testing.assert_identical(back.load(), ds)


def test_real_uff_cli_load(capsys, tmp_path):
    path = _real(UFF)
    out = tmp_path / "curves.nc"
    assert main(["load", str(path), "--out", str(out), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["format"] == "uff" and result["kind"] == "curves"
    assert result["dims"] == {"sample": 2048, "curve": 1, "segment_table": 2}
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert ds.force.attrs["units"] == "N"


# ── the Nanoscope binary: read (tests/io/test_bruker_spm.py), told apart from UFF ───────────


def test_real_spm_is_detected_as_nanoscope_not_uff():
    path = _real(SPM)
    assert detect_nanoscope(path) and not detect_uff(path)
    assert detect_format(path).name == "nanoscope"


# ── synthetic UFF files: every branch ─────────────────────────────────────────────────────────

_HEADER = {
    "UFF_code": "_1_2_3_4_5", "Entry_UFF_version": "0", "Entry_tot_nb_curve": "1",
    "Cantilever_springK_used(N/m)": "1.000000E-01", "Tip_geometry": "pyramidal",
    "Tip_half_angle(deg)": "1.750000E+01", "Tip_radius(m)": "-1.000000E+00",
    "Recording_xposition(m)": "1.0E-06", "Recording_yposition(m)": "2.0E-06",
    "Recording_inv_optical_lever_sens_used(m/V)": "5.000000E-08",
    "Recording_number_segment": "2",
}


def _segment(i: int, code: str, kind: str, rows: list[tuple[float, ...]], *,
             columns=(("Displacement", "m"), ("Deflection", "volt")), velocity="1.0E-06",
             n_points: int | None = None, nb: str | None = None) -> tuple[dict, list[str]]:
    pre = f"Recording_segment_{i}_"
    fields = {pre + "type": kind, pre + "code": code, pre + "nb": str(i),
              pre + "nb_point": str(len(rows) if n_points is None else n_points),
              pre + "nb_col": str(len(columns))}
    for j, (title, unit) in enumerate(columns):
        fields[f"{pre}col_{j}_title"] = title
        fields[f"{pre}col_{j}_unit"] = unit
    if velocity is not None:
        fields[pre + "velocity(m/s)"] = velocity
    data = [f"{code} {i if nb is None else nb} " + " ".join(f"{v:E}" for v in row)
            for row in rows]
    return fields, data


_AP = [(0.0, 1.0), (1e-8, 0.6), (2e-8, 0.2)]
_RE = [(0.0, 0.9), (1e-8, 0.1), (2e-8, 0.0)]


def _write(tmp_path: Path, *, header=None, drop=(), segments=None, tail="****\n",
           name="curve.uff") -> Path:
    fields = dict(_HEADER, **(header or {}))
    segments = segments if segments is not None else [
        _segment(0, "AP", "Approach", _AP), _segment(1, "RE", "Retract", _RE)]
    lines = [f"HE {key}: {value}" for key, value in fields.items() if key not in drop]
    for seg_fields, data in segments:
        lines += [f"HE {key}: {value}" for key, value in seg_fields.items() if key not in drop]
        lines += data
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n" + tail)
    return path


def test_synthetic_uff_values(tmp_path):
    ds = read_uff(_write(tmp_path))
    np.testing.assert_array_equal(ds["height"].values, [2e-8, 1e-8, 0.0, 0.0, 1e-8, 2e-8])
    np.testing.assert_allclose(ds["deflection"].values,
                               5e-8 * np.array([0.2, 0.6, 1.0, 0.9, 0.1, 0.0]), rtol=1e-15)
    np.testing.assert_allclose(ds["force"].values, 0.1 * ds["deflection"].values, rtol=1e-15)
    np.testing.assert_allclose(ds["time"].values, 0.01 * np.arange(6), rtol=1e-12, atol=1e-15)
    assert (float(ds["x"][0]), float(ds["y"][0])) == (1e-6, 2e-6)
    assert ds.attrs["tip_shape"] == "pyramid" and ds.attrs["tip_half_angle"] == 17.5
    assert "tip_note" not in ds.attrs and "column_note" not in ds.attrs


def test_synthetic_rows_already_in_time_order_are_kept(tmp_path):
    approach = list(reversed(_AP))  # far → turnaround: already in time order
    retract = list(reversed(_RE))   # far → turnaround: must be reversed
    path = _write(tmp_path, segments=[_segment(0, "AP", "Approach", approach),
                                      _segment(1, "RE", "Retract", retract)])
    ds = read_uff(path)
    np.testing.assert_array_equal(ds["height"].values, [2e-8, 1e-8, 0.0, 0.0, 1e-8, 2e-8])
    hows = ds.attrs["time_channel"].split(";")
    assert "rows reversed" not in hows[0] and "rows reversed" in hows[1]


def test_synthetic_deflection_in_nm_and_extra_column(tmp_path):
    cols = (("Height", "nm"), ("Deflection", "nm"), ("Error", "V"))
    rows_ap = [(0.0, 3.0, 9.0), (10.0, 2.0, 9.0)]
    rows_re = [(0.0, 3.0, 9.0), (10.0, 1.0, 9.0)]
    path = _write(tmp_path, drop=("Recording_inv_optical_lever_sens_used(m/V)",), segments=[
        _segment(0, "AP", "extend", rows_ap, columns=cols),
        _segment(1, "RE", "retract", rows_re, columns=cols)])
    ds = read_uff(path)
    np.testing.assert_allclose(ds["height"].values, [10e-9, 0.0, 0.0, 10e-9], rtol=1e-15)
    np.testing.assert_allclose(ds["deflection"].values, [2e-9, 3e-9, 3e-9, 1e-9], rtol=1e-15)
    assert math.isnan(float(ds["sensitivity"][0]))
    assert ds.attrs["ignored_columns"] == "segment 0 Error [V], segment 1 Error [V]"
    assert ds.attrs["deflection_channel"] == "Deflection [nm] as recorded"


@pytest.mark.parametrize(("geometry", "extra", "expected", "note"), [
    ("spherical", {"Tip_radius(m)": "5.0E-06"}, {"tip_shape": "sphere", "tip_radius": 5e-6},
     None),
    ("conical", {}, {"tip_shape": "cone", "tip_half_angle": 17.5}, None),
    ("flat punch", {"Tip_radius(m)": "1.0E-06"}, {"tip_shape": "flat", "tip_radius": 1e-6}, None),
    ("parabolic", {"Tip_radius(m)": "?"}, {}, "parabolic tip without a plausible radius"),
    ("pyramidal", {"Tip_half_angle(deg)": "-1"}, {},
     "pyramidal tip without a half angle in [0.1, 89.9] degrees"),
    ("blade", {}, {}, "Tip_geometry 'blade' names no known tip shape"),
    ("?", {}, {}, None),
])
def test_synthetic_tip_geometries(tmp_path, geometry, extra, expected, note):
    ds = read_uff(_write(tmp_path, header={"Tip_geometry": geometry, **extra}))
    got = {k: ds.attrs[k] for k in ("tip_shape", "tip_radius", "tip_half_angle")
           if k in ds.attrs}
    assert got == expected
    if expected:
        assert Tip.from_attrs(ds.attrs).as_attrs() == expected
    assert ds.attrs.get("tip_note") == note or note in ds.attrs.get("tip_note", "")


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"header": {"Entry_tot_nb_curve": "2"}}, r"holds 2 curves \(Entry_tot_nb_curve\)"),
    ({"header": {"Recording_number_segment": "two"}},
     r"'Recording_number_segment' must be an integer >= 1, got 'two'"),
    ({"drop": ("Recording_segment_0_nb_col",)},
     r"the UFF header lacks 'Recording_segment_0_nb_col'"),
    ({"segments": [_segment(0, "AP", "Approach", _AP, n_points=4),
                   _segment(1, "RE", "Retract", _RE)]},
     r"segment 0 \(AP\) declares 4 points \(Recording_segment_0_nb_point\), the file has 3"),
    ({"segments": [_segment(0, "AP", "Approach", _AP), _segment(1, "AP", "Retract", _RE)]},
     r"segment codes \['AP', 'AP'\] are not unique"),
    ({"segments": [_segment(0, "AP", "Approach", _AP),
                   _segment(1, "RE", "Retract", _RE, nb="7")]},
     r"line \d+: a data line of segment 1 \(RE\) needs 'RE 1' and 2 numbers"),
    ({"header": {"Recording_number_segment": "1"},
      "segments": [_segment(0, "AP", "Approach", [(0.0, 1.0, 2.0)], n_points=1,
                            columns=(("Displacement", "m"), ("Deflection", "V")))]},
     r"needs 'AP 0' and 2 numbers, got 'AP 0 0.000000E\+00 1.000000E\+00 2.000000E\+00'"),
    ({"tail": "XX 0 1 2\n****\n"}, r"'XX' is neither a header \('HE '\) nor a data line of a "
                                   r"declared segment \(codes AP, RE\)"),
    ({"tail": "AP 0 nan 1\n****\n"}, r"line \d+: not finite numbers \('nan 1'\)"),
    ({"tail": "AP 0 x 1\n****\n"}, r"not finite numbers \('x 1'\)"),
    ({"tail": "****\nAP 0 0 1\n"}, r"content after the '\*\*\*\*' end marker"),
    ({"tail": "HE Entry_UFF_version: 1\n"}, r"header field 'Entry_UFF_version' given twice"),
    ({"tail": "HE no colon here\n"}, r"header line without 'key: value'"),
    ({"segments": [_segment(0, "AP", "Approach", _AP, columns=(("?", "?"), ("?", "?"))),
                   _segment(1, "RE", "Retract", _RE)]},
     r"segment 0 \(AP\) does not describe its columns"),
    ({"segments": [_segment(0, "AP", "Approach", _AP,
                            columns=(("Displacement", "m"), ("Deflection", "furlong"))),
                   _segment(1, "RE", "Retract", _RE)]},
     r"column 'Deflection': unit 'furlong' is not a length or volts"),
    ({"segments": [_segment(0, "AP", "Approach", _AP,
                            columns=(("Displacement", "volt"), ("Deflection", "V"))),
                   _segment(1, "RE", "Retract", _RE)]},
     r"column 'Displacement': unit 'volt' is not a length$"),
    ({"segments": [_segment(0, "AP", "Approach", _AP,
                            columns=(("Displacement", "m"), ("Height", "m"))),
                   _segment(1, "RE", "Retract", _RE)]},
     r"segment 0 \(AP\) has two height columns; keep one"),
    ({"segments": [_segment(0, "AP", "Approach", _AP,
                            columns=(("Displacement", "m"), ("Force", "N"))),
                   _segment(1, "RE", "Retract", _RE)]},
     r"segment 0 \(AP\) lacks a Deflection column \(it has Displacement, Force\)"),
    ({"segments": [_segment(0, "AP", "Approach", _AP), _segment(1, "PA", "Pause", _RE)]},
     r"segment 1 \(PA, Pause\): the file records no time, and this segment's sample times "
     r"cannot be derived from the ramp"),
    ({"segments": [_segment(0, "AP", "Approach", [(0.0, 1.0), (1e-8, 0.5), (0.5e-8, 0.1)]),
                   _segment(1, "RE", "Retract", _RE)]}, r"cannot be derived from the ramp"),
    ({"segments": [_segment(0, "AP", "Approach", _AP, velocity="-1.0"),
                   _segment(1, "RE", "Retract", _RE)]},
     r"no positive Recording_segment_0_velocity\(m/s\) \('-1.0'\): the sample times are unknown"),
    ({"drop": ("Recording_inv_optical_lever_sens_used(m/V)",)},
     r"the deflection is in volts and the header gives no inverse optical lever sensitivity.*"
     r"pass sensitivity \(CLI: --sensitivity 50nm/V\)"),
    ({"header": {"Cantilever_springK_used(N/m)": "-1.0"}},
     r"the header gives no spring constant .*pass spring_constant \(CLI: --spring-constant"),
])
def test_synthetic_malformed_uff_is_refused(tmp_path, kwargs, match):
    path = _write(tmp_path, **kwargs)
    with pytest.raises(InstrumentFormatError, match=match) as info:
        read_uff(path)
    assert str(info.value).startswith(f"{path}: ")


def test_synthetic_question_mark_columns_take_the_previous_segment(tmp_path):
    path = _write(tmp_path, segments=[
        _segment(0, "AP", "Approach", _AP),
        _segment(1, "RE", "Retract", _RE, columns=(("?", "?"), ("?", "?")))])
    ds = read_uff(path)
    assert ds.attrs["column_note"] == ("segment 1 (RE) columns are '?' in the file: taken as "
                                       "segment 0's (Displacement [m], Deflection [volt])")


def test_calibration_given_where_the_file_has_none(tmp_path):
    path = _write(tmp_path, drop=("Cantilever_springK_used(N/m)",
                                  "Recording_inv_optical_lever_sens_used(m/V)"))
    ds = load_instrument(path, spring_constant=0.5, sensitivity=2e-8)
    np.testing.assert_allclose(ds["force"].values,
                               0.5 * 2e-8 * np.array([0.2, 0.6, 1.0, 0.9, 0.1, 0.0]), rtol=1e-15)


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"spring_constant": 0.0}, ParameterError, r"spring_constant must be finite and > 0, got 0.0"),
    ({"spring_constant": [0.1]}, ParameterError, r"spring_constant must be a number"),
    ({"sensitivity": math.nan}, ParameterError, r"sensitivity must be finite and > 0"),
    ({"sensitivity": "3 N"}, UnitError, r"sensitivity"),
])
def test_bad_options(tmp_path, kwargs, error, match):
    with pytest.raises(error, match=match):
        read_uff(_write(tmp_path), **kwargs)


def test_not_uff_or_missing(tmp_path):
    other = tmp_path / "table.uff"
    other.write_text("time (s),force (N),height (m)\n0,1,2\n")
    assert not detect_uff(other) and not detect_nanoscope(other)
    with pytest.raises(InstrumentFormatError, match=r"not a UFF text file"):
        read_uff(other)
    missing = tmp_path / "missing.uff"
    assert not detect_uff(missing) and not detect_nanoscope(missing)
    with pytest.raises(InstrumentFormatError, match=r"missing.uff: no such file"):
        read_uff(missing)
    with pytest.raises(ParameterError, match=r"path must be a file path"):
        read_uff(3)
    binary = tmp_path / "binary.uff"
    binary.write_bytes(b"HE UFF_code: 1\x00\x00")
    assert not detect_uff(binary)
