"""``viscoforce.measured.open_data`` (issue 36 item 3): one call from a file to analysable data.

It gives exactly what ``viscoforce load --out`` writes (bundled examples), reads a JPK map in
chunks with the same result as a whole read, and refuses bad options with messages naming the
parameters (the command line tells the same with its flags). The real files of
../shared/data/real are in test_open_real.py (split off so that the two halves run on
different xdist workers).
"""

from __future__ import annotations

import json
import math
import pickle

import numpy as np
import pytest
import xarray as xr

from tests.conftest import REPO
from viscoforce.cli import main
from viscoforce.exceptions import ParameterError

EXAMPLES = REPO / "src" / "viscoforce" / "data" / "examples"
MAP = EXAMPLES / "real" / "modulation-map.jpk-force-map"
CURVE = EXAMPLES / "sls_modulation.jpk-force"
FREQUENCIES = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0)


def _opened(path):
    with xr.open_dataset(path, engine="h5netcdf") as ds:
        return ds.load()


def _cli_out(tmp_path, capsys, path, *flags):
    """What ``viscoforce load PATH FLAGS --out`` writes, and its --json object."""
    out = tmp_path / "cli.nc"
    code = main(["load", str(path), *map(str, flags), "--out", str(out), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return _opened(out), json.loads(captured.out)


def _as_written(ds, tmp_path):
    """``ds`` through the netCDF writer (the encodings the CLI's file has)."""
    from viscoforce._files import write_netcdf

    write_netcdf(ds, tmp_path / "lib.nc")
    return _opened(tmp_path / "lib.nc")


def open_data_and_made(path, **options):
    """``open_data(path, **options)`` and the :class:`MeasuredData` it came from, of one read.

    ``open_data`` returns ``read_measured(...).dataset``; the ``read_measured`` it calls is
    watched, so that the dataset and the summary (``load --json``) come from one read of the file
    (a second ``read_measured`` read it again: 0.6 s for the bundled map).
    """
    import viscoforce.measured.open as module

    made = []
    real = module.read_measured

    def watched(*args, **kwargs):
        made.append(real(*args, **kwargs))
        return made[-1]

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(module, "read_measured", watched)
        ds = module.open_data(path, **options)
    assert len(made) == 1 and made[0].dataset is ds
    return ds, made[0]


@pytest.fixture(scope="module")
def map_curves():
    """The bundled map's curves read whole by load_instrument, once for the tests that compare
    with them unchanged (each read them again)."""
    from viscoforce.io.instruments import load_instrument

    return load_instrument(MAP)


@pytest.fixture(scope="module")
def map_curves_written(map_curves, tmp_path_factory):
    """``map_curves`` through the netCDF writer, once."""
    return _as_written(map_curves, tmp_path_factory.mktemp("map"))


# ── reachable ────────────────────────────────────────────────────────────────────────────────────

def test_the_package_exports_open_data_and_the_steps():
    import viscoforce.measured as measured
    from viscoforce.experiments.modulation import modulation_spectrum
    from viscoforce.io.instruments import load_instrument

    assert callable(measured.open_data) and callable(measured.read_measured)
    assert measured.modulation_spectrum is modulation_spectrum
    assert measured.load_instrument is load_instrument
    for name in measured.__all__:
        assert hasattr(measured, name), name
    assert issubclass(measured.OptionError, ParameterError)


def test_the_cli_keeps_its_names():
    from viscoforce.cli.analysis import has_modulation, open_streamable, streamed_spectrum
    from viscoforce.cli.fitting import one_curve_squeezed, read_data

    assert all(map(callable, (has_modulation, open_streamable, streamed_spectrum,
                              one_curve_squeezed, read_data)))


# ── the same as `viscoforce load` ────────────────────────────────────────────────────────────────

@pytest.mark.parametrize(("name", "options", "flags"), [
    ("sls_modulation.jpk-force", {}, []),
    ("sls_modulation.jpk-force", {"raw": True}, ["--raw"]),
    ("sls_modulation.jpk-force", {"phase_lag": 2.5, "drag": 1e-7},
     ["--phase-lag", "2.5", "--drag", "1e-7"]),
    ("sls_modulation.jpk-force", {"phase_lag": {300.0: 4.0, 10.0: 1.0}, "tip": "sphere:5um",
                                  "poisson": 0.4},
     ["--phase-lag", "300Hz=4", "10Hz=1", "--tip", "sphere:5um", "--poisson", "0.4"]),
    ("sls_spectrum.csv", {}, []),
    ("sls_spectrum.csv", {"phase_lag": 1.0, "drag": 2e-7}, ["--phase-lag", "1", "--drag", "2e-7"]),
    ("sls_step_relaxation.csv", {}, []),
    ("sls_spectrum_map.nc", {}, []),
    ("real/modulation-map.jpk-force-map", {}, []),
    ("real/modulation-map.jpk-force-map", {"phase_lag": {300.0: 14.0}, "tip": "cone:35"},
     ["--phase-lag", "300Hz=14", "--tip", "cone:35"]),
], ids=["jpk", "jpk-raw", "jpk-lag-drag", "jpk-lags-moduli", "csv-spectrum", "csv-corrected",
        "csv-step", "netcdf", "map", "map-moduli"])
def test_open_data_gives_what_load_writes(tmp_path, capsys, name, options, flags):
    path = EXAMPLES / name
    written, summary = _cli_out(tmp_path, capsys, path, *flags)
    ds, made = open_data_and_made(path, **options)
    xr.testing.assert_identical(written, _as_written(ds, tmp_path))
    assert made.summary() == summary


def test_the_streamed_raw_map_is_written_and_returned_lazily(tmp_path, capsys, map_curves,
                                                            map_curves_written):
    from viscoforce.measured import open_data, read_measured

    written, summary = _cli_out(tmp_path, capsys, MAP, "--raw")
    out = tmp_path / "curves.nc"
    with open_data(MAP, raw=True, out=out) as lazy:
        xr.testing.assert_identical(lazy.load(), written)
    xr.testing.assert_identical(written, map_curves_written)
    xr.testing.assert_identical(open_data(MAP, raw=True), map_curves)
    counted = read_measured(MAP, raw=True, keep_streamed=False)
    assert counted.dataset is None and counted.streamed
    assert counted.summary() == summary


def test_a_netcdf_file_is_read_as_written(tmp_path):
    from viscoforce.measured import open_data, read_measured

    spectrum = open_data(CURVE, out=tmp_path / "s.nc")
    xr.testing.assert_identical(open_data(tmp_path / "s.nc"), _as_written(spectrum, tmp_path))
    curves = open_data(CURVE, raw=True, out=tmp_path / "c.nc")
    back = read_measured(tmp_path / "c.nc")  # never demodulated again
    assert back.kind == "curves" and back.source == "jpk"
    xr.testing.assert_identical(back.dataset, _as_written(curves, tmp_path))


def test_drag_heights_as_load_does(tmp_path, capsys):
    omega = 2 * np.pi * np.asarray(FREQUENCIES)
    items = []
    for h in (1e-6, 2e-6, 4e-6, 8e-6):  # out of contact: a small elastic part plus the drag
        k = 1e-4 + 1j * omega * 6 * np.pi * 1e-3 * (12e-6) ** 2 / (h + 1.5e-6)
        rows = ["frequency (Hz),stiffness (N/m),phase (deg),stiffness_stderr (N/m),"
                "phase_stderr (deg)"]
        rows += [f"{f!r},{float(abs(v))!r},{math.degrees(np.angle(v))!r},"
                 f"{float(1e-4 * abs(v))!r},{math.degrees(1e-4)!r}"
                 for f, v in zip(FREQUENCIES, k, strict=True)]
        (tmp_path / f"free{h:g}.csv").write_text("\n".join(rows) + "\n")
        items.append((h, str(tmp_path / f"free{h:g}.csv")))
    data = EXAMPLES / "sls_spectrum.csv"
    written, summary = _cli_out(tmp_path, capsys, data, "--drag-heights",
                                *(f"{h}m={p}" for h, p in items))
    ds, made = open_data_and_made(data, drag_heights=items)
    xr.testing.assert_identical(written, _as_written(ds, tmp_path))
    assert made.summary() == summary and summary["drag_at_contact"] == ds.attrs["drag"]
    assert made.drag_fit.drag_at_contact_stderr == ds.attrs["drag_stderr"]


# ── chunks of curves ─────────────────────────────────────────────────────────────────────────────

def test_a_map_read_in_chunks_equals_the_whole_read(monkeypatch, tmp_path, map_curves,
                                                   map_curves_written):
    import viscoforce.experiments.stream as stream_module
    import viscoforce.io.stream as io_stream
    from viscoforce.experiments.modulation import modulation_spectrum
    from viscoforce.measured import open_data, read_measured

    whole = map_curves
    lags = {300.0: 3.0, 10.0: 0.5}
    # the archive read whole: the curves of load_instrument lack the piezo record that the
    # default phase reference compares the sensor with
    expected = modulation_spectrum(MAP, phase_lag={f: lags.get(f, 0.0) for f in FREQUENCIES},
                                   drag=1e-7)
    calls = []
    real = stream_module.chunk_size

    def three(archive, **kw):
        calls.append(real(archive, **kw))
        return 3

    monkeypatch.setattr(stream_module, "chunk_size", three)
    monkeypatch.setattr(io_stream, "chunk_size", three)
    made = read_measured(MAP, phase_lag=lags, drag=1e-7)
    assert calls and made.streamed and whole.sizes["curve"] > 3
    xr.testing.assert_identical(made.dataset, expected)
    out = tmp_path / "curves.nc"
    with open_data(MAP, raw=True, out=out) as lazy:  # curves written 3 at a time
        xr.testing.assert_identical(lazy.load(), map_curves_written)


def test_a_phase_reference_path_or_dataset(tmp_path):
    from viscoforce.measured import open_data

    reference = open_data(MAP, phase_reference="sensor")   # a file is read against the sensor
    by_path = open_data(MAP, phase_reference=MAP)
    xr.testing.assert_identical(by_path, open_data(MAP, phase_reference=reference))
    assert abs(by_path["phase"].median("curve").values).max() < 1.0


# ── refusals name the parameters ─────────────────────────────────────────────────────────────────

@pytest.mark.parametrize(("path", "options", "message"), [
    ("absent.jpk-force", {"drag": 1e-7, "drag_heights": [(1e-6, "a")] * 3},
     "give drag or drag_heights, not both"),
    (CURVE, {"phase_lag": {3.7: 1.0}},
     "phase_lag 3.7Hz: the file has no modulation at that frequency (it has 1, 3, 10, 30, 100, "
     "300 Hz)"),
    (CURVE, {"raw": True, "drag": 1e-7},
     "drag, drag_heights, phase_lag and phase_reference correct a spectrum; this file gives "
     "curves (no modulation segments, or raw=True)"),
    (CURVE, {"raw": True, "tip": "sphere:5um"},
     "tip and poisson give the complex modulus of a spectrum; this file gives curves"),
    (EXAMPLES / "sls_step_relaxation.csv", {"phase_lag": 2.0},
     "drag, drag_heights, phase_lag and phase_reference correct a spectrum; this file gives "
     "curves"),
    ("absent.jpk-force", {"poisson": 0.3}, "poisson needs tip (the moduli need the tip's"),
    ("absent.jpk-force", {"poisson": "0.3x", "tip": "sphere:5um"},
     "poisson must be a number in [0, 0.5], got '0.3x'"),
    ("absent.jpk-force", {"poisson": 0.7, "tip": "sphere:5um"},
     "poisson must be in [0, 0.5], got 0.7"),
    ("absent.jpk-force", {"phase_lag": "14"}, "phase_lag must be degrees for every frequency"),
    ("absent.jpk-force", {"phase_lag": {"300Hz": 14}}, "phase_lag maps frequencies [Hz]"),
    ("absent.jpk-force", {"drag_heights": ["1um=a.jpk-force"]},
     "drag_heights must be (height [m], path) pairs"),
    ("absent.jpk-force", {"phase_reference": 3}, "phase_reference must be a path or a spectrum"),
    ("absent.jpk-force", {"raw": "yes"}, "raw must be True or False, got 'yes'"),
    ("absent.jpk-force", {"height_channel": "bogus"}, "height_channel must be None"),
    (None, {}, "path must be a str or Path, got NoneType"),
    (EXAMPLES / "sls_spectrum.csv", {"height_channel": "height"},
     "height_channel: "),
    (CURVE, {"spring_constant": 0.1}, "spring_constant: "),
    (EXAMPLES / "sls_spectrum_map.nc", {"sensitivity": 5e-8},
     "sensitivity: " + str(EXAMPLES / "sls_spectrum_map.nc") + " is a netCDF file, read as "
     "written"),
    ("absent.nc", {}, "absent.nc: no such file"),
], ids=["drag-twice", "lag-frequency", "raw-corrections", "raw-moduli", "curves-corrections",
        "poisson-alone", "poisson-text", "poisson-range", "lag-text", "lag-keys", "heights-text",
        "reference-int", "raw-text", "height-channel", "path-none", "height-channel-csv",
        "calibrated", "netcdf-options", "netcdf-missing"])
def test_bad_options_are_refused_naming_them(path, options, message):
    from viscoforce.measured import open_data

    with pytest.raises(ParameterError) as raised:
        open_data(path, **options)
    assert message in str(raised.value)
    assert str(raised.value).startswith(message.split(" ")[0])


def test_a_drag_height_without_modulation_is_named(tmp_path):
    from viscoforce.measured import OptionError, open_data

    trace = EXAMPLES / "sls_step_relaxation.csv"
    with pytest.raises(OptionError, match=r"^drag_heights 2e-06m=.*relaxation\.csv: the file "
                                          r"has no modulation segments"):
        open_data(EXAMPLES / "sls_spectrum.csv", drag_heights=[(1e-6, trace), (2e-6, trace)][::-1])


def test_option_errors_are_told_with_flags_and_pickle():
    from viscoforce.measured import OptionError, open_data

    with pytest.raises(OptionError) as raised:
        open_data("absent.nc")
    assert raised.value.told({"path": "DATA "}) == "DATA absent.nc: no such file"
    back = pickle.loads(pickle.dumps(raised.value))
    assert str(back) == str(raised.value) and back.template == raised.value.template


@pytest.mark.parametrize(("flags", "message"), [
    (["--raw", "--tip", "sphere:5um"],
     "--tip and --poisson give the complex modulus of a spectrum; this file gives curves (no "
     "modulation segments, or --raw)"),
    (["--phase-lag", "3.7Hz=1"],
     "--phase-lag 3.7Hz: the file has no modulation at that frequency (it has 1, 3, 10, 30, 100, "
     "300 Hz)"),
    (["--poisson", "0.3"], "--poisson needs --tip (the moduli need the tip's contact size)"),
    (["--poisson", "x", "--tip", "sphere:5um"], "--poisson must be a number in [0, 0.5], got 'x'"),
])
def test_the_cli_tells_them_with_its_flags(capsys, flags, message):
    assert main(["load", str(CURVE), *flags]) == 2
    assert capsys.readouterr().err == f"viscoforce load: error: {message}\n"


def test_fit_names_data_for_a_missing_netcdf(capsys, tmp_path):
    from viscoforce.cli import UsageError
    from viscoforce.cli.fitting import read_data

    with pytest.raises(UsageError, match=r"^DATA .*missing\.nc: no such file$"):
        read_data(str(tmp_path / "missing.nc"))
