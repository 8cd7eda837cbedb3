"""afmformats-backed readers (Igor .ibw, AFM Workshop .csv, Chiaro .txt/.zip, NT-MDT .txt)."""

from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path

import numpy as np
import pytest

from viscoforce.exceptions import InstrumentFormatError, ParameterError
from viscoforce.io.afm import AFMFORMATS_EXTENSIONS, detect_afmformats, read_afmformats
from viscoforce.schema import SEGMENT_NAMES, validate_curves

pytest.importorskip("afmformats")

REAL = Path(__file__).resolve().parents[3] / "shared" / "data" / "real" / "afmformats"
NTMDT_K, NTMDT_S = 0.1, 50e-9  # N/m, m/V ("50nm/V" as Nova displays it)


def _real(pattern: str) -> list[Path]:
    if not REAL.is_dir():
        pytest.skip(f"real afmformats data not present at {REAL}")
    found = sorted(REAL.glob(pattern))
    if not found:
        pytest.skip(f"no {pattern} in {REAL}")
    return found


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _read_unchanged(path: Path, **kwargs):
    before = _sha(path)
    ds = read_afmformats(path, **kwargs)
    assert _sha(path) == before
    return ds


def _check_common(ds, *, source: str, force_range: tuple[float, float],
                  height_span: tuple[float, float], n_curves: int = 1):
    validate_curves(ds)
    assert ds.attrs["source"].startswith("afmformats:") and source in ds.attrs["source"]
    assert ds.sizes["curve"] == n_curves
    names = [str(n) for n in ds["segment_name"].values]
    assert {"approach", "retract"} <= set(names) <= set(SEGMENT_NAMES)
    seg = ds["segment"].values
    approach = names.index("approach")
    retract = names.index("retract")
    assert (seg == approach).sum() > 10 and (seg == retract).sum() > 10
    # approach comes before retract within the curve
    assert np.flatnonzero(seg == approach).mean() < np.flatnonzero(seg == retract).mean()
    force = ds["force"].values
    assert np.all(np.isfinite(force))
    peak = np.max(np.abs(force))
    assert force_range[0] <= peak <= force_range[1], peak
    height = ds["height"].values
    assert np.all(np.isfinite(height))
    span = np.ptp(height)
    assert height_span[0] <= span <= height_span[1], span
    assert np.max(np.abs(height)) < 1e-3  # metres, not nm
    assert ds["force"].attrs["units"] == "N" and ds["height"].attrs["units"] == "m"
    assert ds.attrs["height_channel"].startswith("height (")
    assert "afmformats_version" in ds.attrs
    assert any(k.startswith("meta_") for k in ds.attrs)
    return names


def test_extensions():
    assert set(AFMFORMATS_EXTENSIONS) == {".ibw", ".csv", ".txt", ".zip"}


@pytest.mark.parametrize("name", ["fmt-igor-fd_SiN_FD_plot.ibw", "fmt-igor-fd_U3_3_p10004.ibw"])
def test_igor(name):
    path = _real(name)[0]
    assert detect_afmformats(path)
    ds = _read_unchanged(path)
    _check_common(ds, source="Asylum Research", force_range=(1e-9, 1e-6),
                  height_span=(5e-8, 2e-5))
    k = float(ds["spring_constant"].values[0])
    s = float(ds["sensitivity"].values[0])
    assert 0.01 < k < 10 and 1e-9 < s < 1e-6
    assert ds.attrs["height_channel"] == "height (measured)"
    assert ds.attrs["segments_from"] == "wave note Indexes and Direction"
    np.testing.assert_allclose(ds["deflection"].values * k, ds["force"].values, rtol=1e-6)
    np.testing.assert_allclose(ds["tip_position"].values,
                               -ds["height"].values - ds["deflection"].values)
    t = ds["time"].values
    np.testing.assert_allclose(np.diff(t), 1 / ds.attrs["meta_rate_approach"])
    # approach lowers the height (afmformats/JPK convention: height grows away from the sample)
    seg = ds["segment"].values
    names = [str(n) for n in ds["segment_name"].values]
    h_app = ds["height"].values[seg == names.index("approach")]
    assert h_app[-1] < h_app[0]


def test_igor_recalibration():
    path = _real("fmt-igor-fd_SiN_FD_plot.ibw")[0]
    ref = read_afmformats(path)
    k0, s0 = float(ref["spring_constant"][0]), float(ref["sensitivity"][0])
    ds = read_afmformats(path, spring_constant=2 * k0, sensitivity=0.5 * s0)
    np.testing.assert_allclose(ds["deflection"].values, 0.5 * ref["deflection"].values)
    np.testing.assert_allclose(ds["force"].values, ref["force"].values, rtol=1e-12)
    assert float(ds["spring_constant"][0]) == 2 * k0
    assert "recalibrated_sensitivity" in ds.attrs


def test_afm_workshop_csv():
    path = _real("fmt-afm-workshop-fd_single_*.csv")[0]
    assert detect_afmformats(path)
    ds = _read_unchanged(path)
    _check_common(ds, source="AFM workshop", force_range=(1e-11, 1e-6),
                  height_span=(1e-7, 2e-5))
    assert "sample index" in ds.attrs["time_channel"]
    # force is given in nN and the file has no spring constant: deflection is unknown
    assert np.isnan(ds["spring_constant"].values[0])
    assert np.all(np.isnan(ds["deflection"].values))
    assert "unavailable" in ds.attrs["deflection_channel"]
    np.testing.assert_allclose([ds["x"].values[0], ds["y"].values[0]], [5e-7, 5e-7])
    ds_k = read_afmformats(path, spring_constant=0.05)
    np.testing.assert_allclose(ds_k["deflection"].values, ds_k["force"].values / 0.05)


def test_chiaro_zip():
    path = _real("fmt-chiaro-txt_*.zip")[0]
    assert detect_afmformats(path)
    ds = _read_unchanged(path)
    _check_common(ds, source="Optics11", force_range=(1e-8, 1e-5), height_span=(1e-6, 2e-4))
    assert float(ds["spring_constant"].values[0]) == pytest.approx(0.019)
    assert np.isnan(ds["sensitivity"].values[0])
    assert ds.attrs["height_channel"] == "height (piezo)"
    assert ds.attrs["time_channel"] == "time (from the file)"
    with pytest.raises(ParameterError, match="sensitivity"):
        read_afmformats(path, sensitivity=50e-9)


def test_chiaro_zip_of_several(tmp_path):
    (src,) = _real("fmt-chiaro-txt_*.zip")
    with zipfile.ZipFile(src) as zf:
        (member,) = zf.namelist()
        text = zf.read(member)
    two = tmp_path / "two.zip"
    with zipfile.ZipFile(two, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("a.txt", text)
        zf.writestr("b.txt", text)
    ds = read_afmformats(two)
    validate_curves(ds)
    assert ds.sizes["curve"] == 2
    assert ds["sample_count"].values.tolist() == [ds.sizes["sample"] // 2] * 2
    np.testing.assert_array_equal(ds["curve"].values, [0, 1])


def test_ntmdt_with_calibration():
    path = _real("fmt-ntmdt-txt-fd_*.txt")[0]
    assert detect_afmformats(path)
    ds = _read_unchanged(path, spring_constant=NTMDT_K, sensitivity=NTMDT_S)
    _check_common(ds, source="NT-MDT", force_range=(1e-10, 1e-6), height_span=(1e-6, 2e-5))
    assert float(ds["spring_constant"].values[0]) == NTMDT_K
    assert float(ds["sensitivity"].values[0]) == NTMDT_S
    np.testing.assert_allclose(ds["deflection"].values * NTMDT_K, ds["force"].values)
    # deflection: photodiode nA x 50 nm/nA -> tens of nm
    assert 1e-8 < np.max(np.abs(ds["deflection"].values)) < 1e-6
    assert ds.sizes["sample"] == 1644


@pytest.mark.parametrize("kwargs", [{}, {"spring_constant": NTMDT_K}, {"sensitivity": NTMDT_S}])
def test_ntmdt_needs_calibration(kwargs):
    path = _real("fmt-ntmdt-txt-fd_*.txt")[0]
    before = _sha(path)
    with pytest.raises(InstrumentFormatError, match="--spring-constant") as info:
        read_afmformats(path, **kwargs)
    assert path.name in str(info.value) and "--sensitivity" in str(info.value)
    assert _sha(path) == before


def test_bad_calibration_values():
    path = _real("fmt-ntmdt-txt-fd_*.txt")[0]
    with pytest.raises(ParameterError):
        read_afmformats(path, spring_constant=-1.0, sensitivity=NTMDT_S)
    with pytest.raises(ParameterError):
        read_afmformats(path, spring_constant=NTMDT_K, sensitivity=float("nan"))


def test_other_real_files_not_detected():
    if not REAL.is_dir():
        pytest.skip("no real data")
    for path in REAL.iterdir():
        if path.name.startswith("fmt-jpk") or path.name in ("LICENSE", "SOURCE.txt") \
                or path.name.startswith("10.1002_btm2"):
            assert not detect_afmformats(path), path.name


GARBAGE = [
    ("bad.ibw", bytes(range(256)) * 40),
    ("bad.txt", b"this is not\x00 an AFM file\xff\n" * 50),
    ("bad.csv", b"Force-Distance Curve\nnonsense\n1,2\n"),
    ("bad.zip", b"PK\x03\x04 definitely not a zip" * 10),
    ("chiaro.txt", b"Date\t1\nDevice:\tChiaro\nTime (s)\tLoad (uN)\n1\t2\tx\n"),
    ("ntmdt.txt", b"1,0\t2,0\t3,0\n1,0\t2,0\t3,0\n"),
    ("empty.csv", b""),
]


@pytest.mark.parametrize(("name", "content"), GARBAGE)
def test_corrupt_files(tmp_path, name, content):
    path = tmp_path / name
    path.write_bytes(content)
    kwargs = {"spring_constant": NTMDT_K, "sensitivity": NTMDT_S} if name == "ntmdt.txt" else {}
    with pytest.raises(InstrumentFormatError) as info:
        read_afmformats(path, **kwargs)
    assert name in str(info.value)
    assert path.read_bytes() == content


def test_truncated_igor(tmp_path):
    (src,) = _real("fmt-igor-fd_SiN_FD_plot.ibw")
    path = tmp_path / "cut.ibw"
    path.write_bytes(src.read_bytes()[:20000])
    assert detect_afmformats(path)  # the header is fine, the data are cut
    with pytest.raises(InstrumentFormatError, match="cut.ibw"):
        read_afmformats(path)


def test_zip_without_members(tmp_path):
    path = tmp_path / "other.zip"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("readme.md", "nothing here")
    assert not detect_afmformats(path)
    with pytest.raises(InstrumentFormatError, match="other.zip"):
        read_afmformats(path)


def test_missing_and_wrong_extension(tmp_path):
    with pytest.raises(InstrumentFormatError, match="no such file"):
        read_afmformats(tmp_path / "nope.ibw")
    other = tmp_path / "x.dat"
    other.write_text("1 2 3\n")
    assert not detect_afmformats(other)
    with pytest.raises(InstrumentFormatError, match="x.dat"):
        read_afmformats(other)
    assert not detect_afmformats(tmp_path / "nope.ibw")


def _workshop_text() -> str:
    (src,) = _real("fmt-afm-workshop-fd_single_*.csv")
    return src.read_text()


def test_afm_workshop_map_zip(tmp_path):
    text = _workshop_text().replace("Mode:\tSingle", "Mode:\tMapping")
    path = tmp_path / "map.zip"
    points = [(0.5, 0.5), (1.5, 0.5), (0.5, 1.5), (1.5, 1.5)]
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
        for i, (x, y) in enumerate(points, start=1):
            zf.writestr(f"p{i}.csv", text.replace("Point:\t1", f"Point:\t{i}")
                        .replace("X, um:\t0.500000", f"X, um:\t{x:.6f}")
                        .replace("Y, um:\t0.500000", f"Y, um:\t{y:.6f}"))
    assert detect_afmformats(path)
    ds = read_afmformats(path, spring_constant=0.05)
    validate_curves(ds)
    assert ds.sizes["curve"] == 4 and "AFM workshop" in ds.attrs["source"]
    np.testing.assert_allclose(ds["x"].values, [p[0] * 1e-6 for p in points])
    np.testing.assert_allclose(ds["y"].values, [p[1] * 1e-6 for p in points])
    np.testing.assert_allclose(ds.attrs["meta_enum"], [1, 2, 3, 4])


def test_afm_workshop_map_one_row_is_an_error(tmp_path):
    text = _workshop_text().replace("Mode:\tSingle", "Mode:\tMapping")
    path = tmp_path / "row.zip"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("p1.csv", text)
        zf.writestr("p2.csv", text.replace("Point:\t1", "Point:\t2"))
    with pytest.raises(InstrumentFormatError, match="row.zip"):
        read_afmformats(path)


def test_afm_workshop_volts_need_calibration(tmp_path):
    text = _workshop_text().replace("Force(nN)", "T-B(V)")
    path = tmp_path / "volts.csv"
    path.write_text(text)
    with pytest.raises(InstrumentFormatError, match="--spring-constant") as info:
        read_afmformats(path)
    assert "volts.csv" in str(info.value)
    ds = read_afmformats(path, spring_constant=0.2, sensitivity=100e-9)
    ref = read_afmformats(_real("fmt-afm-workshop-fd_single_*.csv")[0])
    # column value in V x 100 nm/V x 0.2 N/m; the nN file's values read as volts here
    np.testing.assert_allclose(ds["force"].values, ref["force"].values * 1e9 * 100e-9 * 0.2)
    np.testing.assert_allclose(ds["deflection"].values, ds["force"].values / 0.2)
    assert float(ds["sensitivity"][0]) == pytest.approx(100e-9)


def test_keyboard_interrupt_not_swallowed(monkeypatch):
    afmformats = pytest.importorskip("afmformats")
    path = _real("fmt-igor-fd_SiN_FD_plot.ibw")[0]

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(afmformats, "load_data", interrupted)
    with pytest.raises(KeyboardInterrupt):
        read_afmformats(path)


def test_import_is_lazy():
    import subprocess
    import sys

    code = ("import sys, viscoforce, viscoforce.io.afm; "
            "print(int('afmformats' in sys.modules or 'igor2' in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "0"
