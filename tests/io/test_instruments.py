"""Instrument format registry and the generic CSV/TSV readers: round trips, detection, errors."""

from __future__ import annotations

import hashlib
import math
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from viscoforce.exceptions import InstrumentFormatError, ParameterError, UnitError
from viscoforce.io.csv_formats import read_curves_csv, read_spectrum_csv, segment_label
from viscoforce.io.curves import jpk_to_curves
from viscoforce.io.instruments import (
    FORMATS,
    InstrumentFormat,
    detect_format,
    get_format,
    load_instrument,
)
from viscoforce.io.jpk import read_jpk
from viscoforce.schema import make_curves, make_spectrum, validate_curves, validate_spectrum

FIXTURES = Path(__file__).resolve().parents[1] / "data" / "jpk"
REAL = Path(__file__).resolve().parents[3] / "shared" / "data" / "real"
REAL_JPK = ("PyFMReader/map-data-2021.11.05-17.37.44.432.jpk-force-map",
            "PyFMRheo/map-data-2022.10.29-12.27.34.564.jpk-force-map",
            "afmformats/fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force",
            "afmformats/fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force",
            "afmformats/fmt-jpk-sr_cell1-0008.jpk-force")
REAL_ZIP = "afmformats/10.1002_btm2.10294_fig5d-cell1.zip"


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def fmt(value: float, decimal_comma: bool = False) -> str:
    text = repr(float(value))
    return text.replace(".", ",") if decimal_comma else text


# ── registry ────────────────────────────────────────────────────────────────────────────────


def test_registry_names_and_kinds():
    assert [f.name for f in FORMATS] == ["jpk", "csv-curves", "csv-spectrum", "afmformats", "uff",
                                         "nanoscope"]
    assert {f.name: f.kind for f in FORMATS} == {"jpk": "curves", "csv-curves": "curves",
                                                 "csv-spectrum": "spectrum",
                                                 "afmformats": "curves", "uff": "curves",
                                                 "nanoscope": "curves"}
    for f in FORMATS:
        assert isinstance(f, InstrumentFormat)
        assert f.extensions and all(e.startswith(".") for e in f.extensions)
        with pytest.raises(AttributeError):
            f.name = "other"  # frozen
    assert get_format("jpk") is FORMATS[0]
    assert get_format(FORMATS[1]) is FORMATS[1]
    with pytest.raises(ParameterError, match=r"unknown format 'ibw'; known formats: jpk, "):
        get_format("ibw")


# ── curves CSV ──────────────────────────────────────────────────────────────────────────────


def _curves_dataset() -> xr.Dataset:
    t = np.array([0.0, 1e-3, 2e-3, 3e-3, 0.0, 0.5e-3, 1.5e-3])
    force = np.array([1e-9, 2.5e-9, 3e-9, -1e-10, 0.0, 4e-9, 5e-9])
    height = np.array([10e-9, 8e-9, 6e-9, 7e-9, 1e-6, 0.9e-6, 0.8e-6])
    k = 0.1
    return make_curves(t, force, height, force / k, segment=[0, 0, 1, 2, 0, 1, 2],
                       segment_names=("approach", "pause", "retract"),
                       segment_types=("extend", "pause", "retract"), sample_count=[4, 3],
                       per_curve={"x": [0.0, 1e-6], "y": [2e-6, 2e-6]}, source="test")


def _write_curves(ds: xr.Dataset, path: Path, *, delimiter: str = ",",
                  decimal_comma: bool = False, deflection: bool = True) -> Path:
    counts = ds["sample_count"].values
    curve = np.repeat(np.arange(counts.size), counts)
    types = ds["segment_type"].values
    cols = ["curve", "time (ms)", "force (nN)", "height (µm)", "segment", "x (um)", "y (nm)"]
    if deflection:
        cols.append("deflection (nm)")
    lines = ["# written by the test", delimiter.join(cols)]
    x, y = ds["x"].values, ds["y"].values
    for i in range(ds.sizes["sample"]):
        c = curve[i]
        row = [str(c), fmt(ds["time"].values[i] * 1e3, decimal_comma),
               fmt(ds["force"].values[i] * 1e9, decimal_comma),
               fmt(ds["height"].values[i] * 1e6, decimal_comma), str(types[ds["segment"].values[i]]),
               fmt(x[c] * 1e6, decimal_comma), fmt(y[c] * 1e9, decimal_comma)]
        if deflection:
            row.append(fmt(ds["deflection"].values[i] * 1e9, decimal_comma))
        lines.append(delimiter.join(row))
    return write(path, "\n".join(lines) + "\n")


def _compare_curves(got: xr.Dataset, want: xr.Dataset) -> None:
    validate_curves(got)
    for name in ("time", "force", "height", "deflection", "tip_position"):
        np.testing.assert_allclose(got[name].values, want[name].values, rtol=1e-13, atol=0,
                                   err_msg=name)
    np.testing.assert_array_equal(got["sample_count"].values, want["sample_count"].values)
    names = got["segment_name"].values[got["segment"].values]
    np.testing.assert_array_equal(names, want["segment_name"].values[want["segment"].values])
    for name in ("x", "y"):
        np.testing.assert_allclose(got[name].values, want[name].values, rtol=1e-13)


@pytest.mark.parametrize("delimiter, decimal_comma", [(",", False), (";", False), (";", True),
                                                      ("\t", False), ("\t", True)])
def test_curves_round_trip(tmp_path, delimiter, decimal_comma):
    want = _curves_dataset()
    path = _write_curves(want, tmp_path / "curves.txt", delimiter=delimiter,
                         decimal_comma=decimal_comma)
    before = sha256(path)
    got = load_instrument(path)
    assert sha256(path) == before
    assert got.attrs["source"] == "csv-curves" and got.attrs["file"] == str(path)
    _compare_curves(got, want)
    assert list(got["segment_type"].values) == ["extend", "pause", "retract"]
    assert list(got["curve"].values) == [0, 1]


def test_curves_from_deflection_and_spring_constant(tmp_path):
    want = _curves_dataset()
    path = tmp_path / "c.csv"
    _write_curves(want.drop_vars("force").assign(force=want["deflection"] * 0.1), path)
    text = path.read_text().replace("force (nN),", "unused (nN),")
    write(path, text)
    got = load_instrument(path, format="csv-curves", spring_constant="100mN/m")
    np.testing.assert_allclose(got["force"].values, want["force"].values, rtol=1e-13)
    assert got.attrs["force_from"] == "spring_constant x deflection"
    assert got.attrs["ignored_columns"] == "unused (nN)"
    np.testing.assert_allclose(got["spring_constant"].values, 0.1)


def test_curves_force_only(tmp_path):
    path = write(tmp_path / "f.csv", "time (s),force (N),z (m)\n0,1e-9,1e-8\n1,2e-9,0.5e-8\n")
    got = read_curves_csv(path)
    assert np.all(np.isnan(got["deflection"].values)) and np.all(np.isnan(got["tip_position"]))
    assert list(got["segment_name"].values) == ["other"]
    got = read_curves_csv(path, spring_constant=0.5)
    np.testing.assert_allclose(got["deflection"].values, [2e-9, 4e-9])
    np.testing.assert_allclose(got["tip_position"].values, [-1e-8 - 2e-9, -0.5e-8 - 4e-9])


def test_curves_deflection_in_volts(tmp_path):
    path = write(tmp_path / "v.csv", "time (s);deflection (V);height (nm)\n0;0,5;3\n1;1,0;2\n")
    got = read_curves_csv(path, spring_constant=0.1, sensitivity="50nm/V")
    np.testing.assert_allclose(got["deflection"].values, [25e-9, 50e-9])
    np.testing.assert_allclose(got["force"].values, [2.5e-9, 5e-9])
    np.testing.assert_allclose(got["sensitivity"].values, 50e-9)


def test_segment_labels():
    cases = {"Extend": "approach", "ext": "approach", "approach": "approach", "Retract": "retract",
             "ret": "retract", "pause": "pause", "Hold": "pause", "dwell": "pause",
             "sine-z-modulation": "modulation", "mod": "modulation", "3": "other",
             "whatever": "other"}
    assert {k: segment_label(k) for k in cases} == cases


# magnitudes a measurement can have: 0, or at least the readers' smallest scale (1e-3 pN of
# force, 1e-3 nm of height; io.quality.SMALLEST_SCALES refuses a column of 1e-188 pN)
_finite = st.one_of(st.just(0.0), st.floats(1e-3, 1e3), st.floats(-1e3, -1e-3))


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(steps=st.lists(st.floats(1e-3, 10.0), min_size=1, max_size=6),
       data=st.data(), delimiter=st.sampled_from([",", ";", "\t"]), comma=st.booleans())
def test_curves_csv_hypothesis(tmp_path_factory, steps, data, delimiter, comma):
    n = len(steps)
    time = np.cumsum(steps)
    force = np.array(data.draw(st.lists(_finite, min_size=n, max_size=n)))
    height = np.array(data.draw(st.lists(_finite, min_size=n, max_size=n)))
    comma = comma and delimiter != ","
    lines = [delimiter.join(["time (ms)", "force (pN)", "height (nm)"])]
    lines += [delimiter.join(fmt(v, comma) for v in row) for row in zip(time, force, height, strict=True)]
    path = write(tmp_path_factory.mktemp("h") / "t.csv", "\n".join(lines))
    got = load_instrument(path)
    assert got.attrs["source"] == "csv-curves"
    np.testing.assert_allclose(got["time"].values, time * 1e-3, rtol=1e-15)
    np.testing.assert_allclose(got["force"].values, force * 1e-12, rtol=1e-15)
    np.testing.assert_allclose(got["height"].values, height * 1e-9, rtol=1e-15)


# ── spectrum CSV ────────────────────────────────────────────────────────────────────────────


def _spectrum(curves: int = 2) -> xr.Dataset:
    omega = 2 * np.pi * np.array([1.0, 3.0, 10.0, 30.0])
    rng = np.random.default_rng(3)
    k = rng.uniform(0.01, 1.0, (curves, 4)) * np.exp(1j * np.radians(rng.uniform(1, 60, (curves, 4))))
    mean = rng.uniform(1e-9, 5e-9, (curves, 4))
    eta = rng.uniform(5e-9, 20e-9, (curves, 4))
    stderr = {"stiffness": 0.01 * np.abs(k), "phase": np.full((curves, 4), 0.5)}
    return make_spectrum(omega, k, mean, eta, dims=("curve", "omega"),
                         coords={"curve": ("curve", np.arange(curves, dtype=np.int32))},
                         stderr=stderr, amplitude=False, source="test")


def _write_spectrum(ds: xr.Dataset, path: Path, *, magnitude: str = "stiffness",
                    delimiter: str = ",", decimal_comma: bool = False) -> Path:
    head = ["curve", "frequency (Hz)", "phase (rad)", "phase_stderr (rad)", "mean_force (nN)",
            "drive_amplitude (nm)"]
    if magnitude == "stiffness":
        head += ["stiffness (mN/m)", "stiffness_stderr (mN/m)"]
    elif magnitude == "force_amplitude":
        head += ["force_amplitude (pN)"]
    else:
        head += ["amplitude (1)"]
    lines = [delimiter.join(head)]
    for c in range(ds.sizes["curve"]):
        for j in reversed(range(ds.sizes["omega"])):  # unsorted on purpose
            p = ds.isel(curve=c, omega=j)
            row = [str(c), fmt(float(p["omega"]) / (2 * np.pi), decimal_comma),
                   fmt(np.radians(float(p["phase"])), decimal_comma),
                   fmt(np.radians(float(p["phase_stderr"])), decimal_comma),
                   fmt(float(p["mean_force"]) * 1e9, decimal_comma),
                   fmt(float(p["drive_amplitude"]) * 1e9, decimal_comma)]
            if magnitude == "stiffness":
                row += [fmt(float(p["stiffness"]) * 1e3, decimal_comma),
                        fmt(float(p["stiffness_stderr"]) * 1e3, decimal_comma)]
            elif magnitude == "force_amplitude":
                row += [fmt(float(p["force_amplitude"]) * 1e12, decimal_comma)]
            else:
                row += [fmt(float(p["force_amplitude"] / p["mean_force"]), decimal_comma)]
            lines.append(delimiter.join(row))
    return write(path, "\n".join(lines) + "\n")


@pytest.mark.parametrize("magnitude", ["stiffness", "force_amplitude", "amplitude"])
@pytest.mark.parametrize("delimiter, decimal_comma", [(",", False), (";", True), ("\t", True)])
def test_spectrum_round_trip(tmp_path, magnitude, delimiter, decimal_comma):
    want = _spectrum()
    path = _write_spectrum(want, tmp_path / "spectrum.csv", magnitude=magnitude,
                           delimiter=delimiter, decimal_comma=decimal_comma)
    before = sha256(path)
    got = load_instrument(path)
    assert sha256(path) == before
    validate_spectrum(got)
    assert got.attrs["source"] == "csv-spectrum" and got.attrs["magnitude_column"] == magnitude
    assert got["stiffness"].dims == ("curve", "omega")
    names = ["omega", "stiffness", "phase", "mean_force", "drive_amplitude", "force_amplitude",
             "phase_stderr"] + (["stiffness_stderr"] if magnitude == "stiffness" else [])
    for name in names:
        np.testing.assert_allclose(got[name].values, want[name].values, rtol=1e-12, err_msg=name)
        assert got[name].attrs["units"] == want[name].attrs["units"]
    np.testing.assert_array_equal(got["curve"].values, [0, 1])
    assert ("amplitude" in got) == (magnitude == "amplitude")


def test_spectrum_minimal_and_nan_mean_force(tmp_path):
    path = write(tmp_path / "s.csv", "omega (rad/s),stiffness (N/m),phase (deg)\n"
                                     "10,0.5,20\n1,0.25,5\n")
    got = load_instrument(path)
    np.testing.assert_array_equal(got["omega"].values, [1.0, 10.0])
    np.testing.assert_allclose(got["stiffness"].values, [0.25, 0.5])
    np.testing.assert_allclose(got["phase"].values, [5.0, 20.0])
    assert np.all(np.isnan(got["mean_force"].values))
    assert "drive_amplitude" not in got and "force_amplitude" not in got
    assert got.attrs["drive_amplitude_known"] == 0
    got = load_instrument(path, drive_amplitude="2nm")
    np.testing.assert_allclose(got["drive_amplitude"].values, 2e-9)


def test_spectrum_partly_missing_mean_force_and_propagated_stderr(tmp_path):
    path = write(tmp_path / "s.csv",
                 "frequency (Hz),force_amplitude (nN),force_amplitude_stderr (nN),"
                 "drive_amplitude (nm),phase (deg),mean_force (nN),mean_indentation (nm)\n"
                 "1,2,0.2,10,10,,5\n2,4,0.4,10,20,3,6\n")
    got = read_spectrum_csv(path)
    assert np.isnan(got["mean_force"].values[0]) and got["mean_force"].values[1] == 3e-9
    np.testing.assert_allclose(got["stiffness"].values, [0.2, 0.4])
    np.testing.assert_allclose(got["stiffness_stderr"].values, [0.02, 0.04])
    np.testing.assert_allclose(got["force_amplitude_stderr"].values, [0.2e-9, 0.4e-9])
    np.testing.assert_allclose(got["mean_indentation"].values, [5e-9, 6e-9])


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(freqs=st.lists(st.floats(1e-2, 1e4), min_size=1, max_size=6, unique=True),
       data=st.data(), delimiter=st.sampled_from([",", ";", "\t"]), comma=st.booleans(),
       rad=st.booleans())
def test_spectrum_csv_hypothesis(tmp_path_factory, freqs, data, delimiter, comma, rad):
    n = len(freqs)
    stiff = np.array(data.draw(st.lists(st.floats(1e-6, 1e3), min_size=n, max_size=n)))
    phase = np.array(data.draw(st.lists(st.floats(-179.0, 179.0), min_size=n, max_size=n)))
    comma = comma and delimiter != ","
    unit = "rad" if rad else "deg"
    lines = [delimiter.join(["frequency (kHz)", "stiffness (N/m)", f"phase ({unit})"])]
    lines += [delimiter.join(fmt(v, comma) for v in (f, k, np.radians(p) if rad else p))
              for f, k, p in zip(freqs, stiff, phase, strict=True)]
    path = write(tmp_path_factory.mktemp("h") / "s.txt", "\n".join(lines))
    if rad and n >= 3 and np.all(np.radians(phase) > np.pi / 2):
        # every value in (pi/2, 2 pi]: read as degrees by the reader's rule (csv_formats
        # _check_rad_phase), which refuses the radian header rather than guess
        with pytest.raises(UnitError, match="these are degrees"):
            load_instrument(path)
        return
    got = load_instrument(path)
    order = np.argsort(freqs)
    np.testing.assert_allclose(got["omega"].values, 2e3 * np.pi * np.asarray(freqs)[order],
                               rtol=1e-14)
    np.testing.assert_allclose(got["stiffness"].values, stiff[order], rtol=1e-12)
    np.testing.assert_allclose(got["phase"].values, phase[order], rtol=1e-10, atol=1e-10)


def test_netcdf_round_trip_of_csv_results(tmp_path):
    curves = write(tmp_path / "c.csv", "curve,time (s),force (N),height (m),segment\n"
                                        "left,0,1,1,extend\nleft,1,2,0,retract\nright,0,3,1,hold\n")
    spectrum = write(tmp_path / "s.csv", "curve;omega (rad/s);stiffness (N/m);phase (deg)\n"
                                         "p;1;1;1\nq;1;2;2\n")
    for path in (curves, spectrum):
        ds = load_instrument(path)
        ds.to_netcdf(tmp_path / "out.nc", engine="scipy")
        with xr.open_dataset(tmp_path / "out.nc", engine="scipy") as back:
            xr.testing.assert_identical(back.load(), ds)
    ds = load_instrument(curves)
    assert list(ds["curve"].values) == ["left", "right"]
    assert list(ds["segment_name"].values) == ["approach", "retract", "pause"]


# ── JPK ─────────────────────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize("name", ["synthetic.jpk-force", "synthetic-2x2.jpk-force-map"])
def test_jpk_round_trip(tmp_path, name):
    src = FIXTURES / name
    before = sha256(src)
    got = load_instrument(src)
    assert sha256(src) == before
    want = jpk_to_curves(read_jpk(src))
    assert got.attrs["source"] == "jpk"
    xr.testing.assert_identical(got.drop_attrs() if hasattr(got, "drop_attrs") else got,
                                want.drop_attrs() if hasattr(want, "drop_attrs") else want)
    one = load_instrument(src, curves=[0])
    assert one.sizes["curve"] == 1


def test_jpk_detected_by_content(tmp_path):
    txt = tmp_path / "disguised.txt"
    shutil.copyfile(FIXTURES / "synthetic.jpk-force", txt)
    assert detect_format(txt).name == "jpk"
    assert load_instrument(txt).attrs["source"] == "jpk"
    bundle = tmp_path / "bundle.dat"
    with zipfile.ZipFile(bundle, "w") as zf:
        zf.write(FIXTURES / "synthetic.jpk-force", "a/synthetic.jpk-force")
        zf.write(FIXTURES / "synthetic-2x2.jpk-force-map", "b/synthetic-2x2.jpk-force-map")
    assert detect_format(bundle).name == "jpk"
    ds = load_instrument(bundle)
    assert ds.sizes["curve"] == 5


def test_spectrum_detected_by_content(tmp_path):
    path = write(tmp_path / "looks_like.csv", "# spectrum\nfrequency (Hz);stiffness (N/m);"
                                              "phase (deg)\n1;0,5;10\n")
    assert detect_format(path).name == "csv-spectrum"
    weird = write(tmp_path / "spectrum.jpk-force", "omega (rad/s),stiffness (N/m),phase (rad)\n"
                                                   "1,1,0.1\n")
    assert detect_format(weird).name == "csv-spectrum"
    assert detect_format(_write_curves(_curves_dataset(), tmp_path / "c.tsv")).name == "csv-curves"


# ── errors ──────────────────────────────────────────────────────────────────────────────────


def test_load_errors(tmp_path):
    with pytest.raises(InstrumentFormatError, match=r"missing\.csv: no such file"):
        load_instrument(tmp_path / "missing.csv")
    with pytest.raises(InstrumentFormatError, match="is a directory"):
        load_instrument(tmp_path)
    empty = write(tmp_path / "empty.csv", "")
    with pytest.raises(InstrumentFormatError, match=r"empty\.csv: the file is empty"):
        load_instrument(empty)
    prose = write(tmp_path / "notes.csv", "hello, world\n1,2\n")
    with pytest.raises(InstrumentFormatError, match=r"notes\.csv: not a known instrument format.*"
                                                    r"known formats: jpk .*csv-curves.*"
                                                    r"csv-spectrum"):
        load_instrument(prose)
    broken = tmp_path / "broken.jpk-force"
    broken.write_bytes((FIXTURES / "synthetic.jpk-force").read_bytes()[:200])
    with pytest.raises(InstrumentFormatError, match="not a known instrument format"):
        detect_format(broken)
    with pytest.raises(InstrumentFormatError, match=r"broken\.jpk-force"):
        load_instrument(broken, format="jpk")
    other_zip = tmp_path / "other.zip"
    with zipfile.ZipFile(other_zip, "w") as zf:
        zf.writestr("readme.txt", "nothing")
    with pytest.raises(InstrumentFormatError, match="not a known instrument format"):
        load_instrument(other_zip)
    spectrum = write(tmp_path / "s.csv", "frequency (Hz),stiffness (N/m),phase (deg)\n1,1,1\n")
    with pytest.raises(TypeError, match=r"s\.csv: format 'csv-spectrum' takes no option.*"
                                        r"spring_constant.*takes drive_amplitude"):
        load_instrument(spectrum, spring_constant=1.0)
    with pytest.raises(ParameterError, match=r"s\.csv: unknown format 'bogus'"):
        load_instrument(spectrum, format="bogus")
    with pytest.raises(ParameterError, match=r"s\.csv: no 'time \(<unit>\)' column"):
        load_instrument(spectrum, format="csv-curves")
    with pytest.raises(ParameterError, match="path must be a str or Path"):
        load_instrument(3)
    with pytest.raises(InstrumentFormatError, match="header but no data rows"):
        read_spectrum_csv(write(tmp_path / "h.csv", "omega (rad/s),stiffness (N/m),phase (deg)\n"))
    with pytest.raises(InstrumentFormatError, match="no header line"):
        read_spectrum_csv(write(tmp_path / "c.csv", "# only a comment\n\n"))


CURVE_ERRORS = [
    ("time (s),force,height (m)\n0,1,1\n", UnitError, r"column 'force' has no unit"),
    ("time (s),force (N),height (m),junk\n0,1,1,2\n", UnitError, r"column 'junk' has no unit"),
    ("time (s),force (furlong),height (m)\n0,1,1\n", UnitError,
     r"column 'force \(furlong\)': unknown unit 'furlong'"),
    ("time (s),force (nm),height (m)\n0,1,1\n", UnitError, r"'nm' is a unit of length"),
    ("time (s),force (N),height (m)\n0,1,1\n1,,2\n", ParameterError,
     r"column 'force \(N\)' data row 2 \(line 3\) is not a finite number \(''\)"),
    ("time (s),force (N),height (m)\n0,1,1\n1,nan,2\n", ParameterError, r"data row 2"),
    ("time (s),force (N),height (m)\n0,1,1\n1,\"1,5\",2\n", ParameterError,
     r"decimal commas need a semicolon or tab delimiter"),
    ("time (s),force (N),height (m)\n0,1,1\n2,1,1\n1,1,1\n", ParameterError,
     r"time is not strictly increasing at data row 3 \(line 4\)"),
    ("time (s),force (N),height (m)\n0,1,1\n0,1,1\n", ParameterError, r"not strictly increasing"),
    ("curve,time (s),force (N),height (m)\na,0,1,1\nb,0,1,1\na,0,1,1\n", ParameterError,
     r"time of curve 'a' is not strictly increasing at data row 3"),
    ("force (N),height (m)\n1,1\n", ParameterError, r"no 'time \(<unit>\)' column"),
    ("time (s),force (N)\n0,1\n", ParameterError, r"exactly one height column.*found none"),
    ("time (s),force (N),height (m),z (m)\n0,1,1,1\n", ParameterError,
     r"found \['height', 'z'\]"),
    ("time (s),force (N),force (nN),height (m)\n0,1,1,1\n", ParameterError,
     r"2 columns named 'force'"),
    ("time (s),height (m)\n0,1\n", ParameterError, r"no 'force \(<unit>\)' or 'deflection"),
    ("time (s),deflection (m),height (m)\n0,1,1\n", ParameterError, r"give the spring constant"),
    ("time (s),deflection (V),height (m)\n0,1,1\n", ParameterError, r"give the sensitivity"),
    ("curve,time (s),force (N),height (m),x (m)\n0,0,1,1,0\n0,1,1,1,1\n", ParameterError,
     r"'x' must be constant within curve '0'"),
    ("time (s),force (N),height (m),segment\n0,1,1,\n", ParameterError,
     r"column 'segment' data row 1 \(line 2\) is empty"),
    ("time (s),force (N),,height (m)\n0,1,2,1\n", ParameterError, r"empty column name"),
    ("time (s),force (N),force (N),height (m)\n0,1,1,1\n", ParameterError,
     r"2 columns named 'force'"),
]


@pytest.mark.parametrize("text, error, match", CURVE_ERRORS)
def test_curves_csv_errors(tmp_path, text, error, match):
    path = write(tmp_path / "bad.csv", text)
    with pytest.raises(error, match=match) as info:
        load_instrument(path, format="csv-curves")
    assert str(path) in str(info.value)


@pytest.mark.parametrize("options, error, match", [
    ({"spring_constant": -1.0}, ParameterError, r"spring_constant must be finite and > 0"),
    ({"spring_constant": "1nm"}, UnitError, r"spring_constant"),
    ({"spring_constant": True}, ParameterError, r"spring_constant must be a number"),
    ({"sensitivity": "50nm"}, UnitError, r"length per volt"),
    ({"sensitivity": "/V"}, UnitError, r"no number before '/V'"),
])
def test_curves_option_errors(tmp_path, options, error, match):
    path = write(tmp_path / "ok.csv", "time (s),deflection (V),height (m)\n0,1,1\n")
    with pytest.raises(error, match=match) as info:
        load_instrument(path, **options)
    assert str(path) in str(info.value)


SPECTRUM_ERRORS = [
    ("frequency (Hz),omega (rad/s),stiffness (N/m),phase (deg)\n1,1,1,1\n",
     r"exactly one frequency column"),
    ("stiffness (N/m),phase (deg),time (s)\n1,1,1\n", r"exactly one frequency column"),
    ("frequency (Hz),stiffness (N/m),mean_force (N)\n1,1,1\n", r"no phase column"),
    ("frequency (Hz),phase (deg),mean_force (N)\n1,1,1\n", r"no magnitude column"),
    ("frequency (Hz),amplitude (1),phase (deg),drive_amplitude (m)\n1,1,1,1\n",
     r"needs a 'mean_force \(N\)' column"),
    ("frequency (Hz),amplitude (1),phase (deg),mean_force (N)\n1,1,1,1\n",
     r"needs a drive amplitude"),
    ("frequency (Hz),amplitude (1),phase (deg),mean_force (N),drive_amplitude (m)\n1,1,1,,1\n",
     r"needs the mean force at every row; data row 1"),
    ("frequency (Hz),force_amplitude (N),phase (deg)\n1,1,1\n", r"needs a 'drive_amplitude"),
    ("frequency (Hz),stiffness (N/m),phase (deg)\n1,1,1\n1,2,2\n", r"a frequency appears twice"),
    ("curve,frequency (Hz),stiffness (N/m),phase (deg)\na,1,1,1\nb,2,1,1\n",
     r"curve 'b' does not have the same frequencies as curve 'a'"),
    ("frequency (Hz),stiffness (N/m),stiffness_stderr (N/m),phase (deg)\n1,1,-1,1\n",
     r"'stiffness_stderr \(N/m\)' has a negative standard error"),
    ("frequency (Hz),frequency_stderr (Hz),stiffness (N/m),phase (deg)\n1,1,1,1\n",
     r"a frequency has no standard error"),
    ("frequency (Hz),stiffness (N/m),phase (deg),mean_indentation_stderr (m)\n1,1,1,1\n",
     r"stderr columns for \['mean_indentation'\] without their value"),
    ("frequency (Hz),stiffness (N/m),phase (deg)\n0,1,1\n", r"frequency at data row 1 .* > 0"),
    ("frequency (Hz),stiffness (N/m),phase (deg)\n1,-1,1\n", r"magnitude at data row 1 .*negative"),
    ("frequency (Hz),force_amplitude (N),drive_amplitude (m),phase (deg)\n1,1,0,1\n",
     r"drive_amplitude at data row 1 \(line 2\) must be > 0"),
    ("frequency (Hz),stiffness (N/m),phase (grad)\n1,1,1\n",
     r"column 'phase \(grad\)': unknown unit 'grad' for an angle"),
    ("frequency (rad/s),stiffness (N/m),phase (deg)\n1,1,1\n",
     r"column 'frequency \(rad/s\)'.*'rad/s' is a unit of angular frequency"),
    ("frequency (Hz),stiffness,phase (deg)\n1,1,1\n", r"column 'stiffness' has no unit"),
    ("frequency (Hz);stiffness (N/m);phase (deg)\n1;x;1\n",
     r"column 'stiffness \(N/m\)' data row 1 \(line 2\) is not a finite number \('x'\)"),
]


@pytest.mark.parametrize("text, match", SPECTRUM_ERRORS)
def test_spectrum_csv_errors(tmp_path, text, match):
    path = write(tmp_path / "bad.csv", text)
    with pytest.raises((ParameterError, UnitError), match=match) as info:
        load_instrument(path, format="csv-spectrum")
    assert str(path) in str(info.value)


def test_spectrum_option_error(tmp_path):
    path = write(tmp_path / "s.csv", "frequency (Hz),stiffness (N/m),phase (deg)\n1,1,1\n")
    with pytest.raises(ParameterError, match=r"drive_amplitude must be finite and > 0"):
        load_instrument(path, drive_amplitude=0.0)
    with pytest.raises(UnitError, match="drive_amplitude"):
        load_instrument(path, drive_amplitude="1Hz")


# ── real files ──────────────────────────────────────────────────────────────────────────────


def _real(name: str) -> Path:
    path = REAL / name
    if not path.is_file():
        pytest.skip(f"real data file not present: {path}")
    return path


@pytest.mark.parametrize("name", [*REAL_JPK, REAL_ZIP])
def test_real_jpk_files(name):
    path = _real(name)
    before = sha256(path)
    assert detect_format(path).name == "jpk"
    ds = load_instrument(path)
    assert sha256(path) == before
    validate_curves(ds)
    assert ds.attrs["source"] == "jpk"
    assert np.all(np.isfinite(ds["force"].values))
    if name == REAL_ZIP:
        assert ds.sizes["curve"] == 15


@pytest.mark.parametrize("name", [
    "afmformats/fmt-afm-workshop-fd_single_2021-10-22_14.16.csv",
    "afmformats/fmt-ntmdt-txt-fd_2015_01_17_gel4-0_1_mQ_adh_6B_Curve_DFL_Height_51.txt",
    "afmformats/fmt-igor-fd_SiN_FD_plot.ibw",
    "afmformats/fmt-chiaro-txt_AEBP1_Indentation_002.zip",
])
def test_real_vendor_files_are_detected_as_afmformats(name):
    """The vendor formats are afmformats' (by content); the native readers do not claim them."""
    path = _real(name)
    assert detect_format(path).name == "afmformats"


def test_bom_comments_and_quoted_cells(tmp_path):
    path = tmp_path / "bom.csv"
    path.write_bytes("\ufeff# exported\n\n\"time (s)\",\"force (N)\",\"height (µm)\"\n"
                     "# a comment between rows\n0,1,2\n\n1,3,4\n".encode())
    got = load_instrument(path)
    np.testing.assert_allclose(got["height"].values, [2e-6, 4e-6])
    np.testing.assert_allclose(got["force"].values, [1.0, 3.0])
    assert got.attrs["file"] == str(path)
    assert math.isclose(float(got["time"].values[-1]), 1.0)
