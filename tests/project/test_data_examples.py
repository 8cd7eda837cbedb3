"""The shipped example data (viscoforce.data): each file loads, recovers its truth, and regenerates.

Tolerances are in standard errors of the data (|value − truth| < Z_MAX·stderr, Z_MAX = 4: the
chance that one of the ~20 compared values of a correct file exceeds it is ~1e-3), except where
stated.
"""

from __future__ import annotations

import importlib.util
import math
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from viscoforce.data import example_names, example_path
from viscoforce.exceptions import ParameterError
from viscoforce.experiments.linear_response import linear_stiffness
from viscoforce.experiments.modulation import modulation_spectrum
from viscoforce.fitting import fit_spectrum
from viscoforce.io._properties import parse_properties
from viscoforce.io.csv_formats import read_trace
from viscoforce.io.instruments import load_instrument
from viscoforce.io.jpk import read_jpk
from viscoforce.schema import validate_spectrum

EXAMPLES_DIR = example_path()
Z_MAX = 4.0


def _load_make_examples():
    spec = importlib.util.spec_from_file_location("make_examples", EXAMPLES_DIR / "make_examples.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("make_examples", module)
    spec.loader.exec_module(module)
    return module


me = _load_make_examples()


@pytest.fixture(scope="module")
def true_problem():
    return me.paper_problem(**me.TRUE_SLS)


def test_every_generated_file_is_bundled_small_and_documented():
    readme = (EXAMPLES_DIR / "README.md").read_text()
    for name in me.EXAMPLES:
        path = EXAMPLES_DIR / name
        assert path.is_file(), name
        assert path.stat().st_size < 300_000, name
        assert f"`{name}`" in readme, name
    assert "`real/modulation-map.jpk-force-map`" in readme


def test_example_path_names_every_shipped_file_and_refuses_others():
    names = example_names()
    assert {*me.EXAMPLES, "README.md", "make_examples.py", "real/LICENSE", "real/SOURCE.md",
            "real/modulation-map.jpk-force-map"} == set(names)
    assert example_path("real/modulation-map.jpk-force-map").is_file()
    assert example_path() == EXAMPLES_DIR and EXAMPLES_DIR.is_absolute()
    with pytest.raises(ParameterError, match=r"no example named '\.\./__init__\.py'; the examples "
                                             r"are: README\.md, "):
        example_path("../__init__.py")


def test_the_repository_link_is_the_package_folder():
    """``data_examples/`` in the repository (benchmarks, docs, older notes) is the same folder."""
    repo = Path(__file__).resolve().parents[2]
    link = repo / "data_examples"
    if not link.exists():
        pytest.skip("not run from a repository checkout")
    assert link.resolve() == (repo / "src" / "viscoforce" / "data" / "examples").resolve()
    # installed editable or not, the package holds the same files
    assert sorted(p.relative_to(link.resolve()).as_posix() for p in link.resolve().rglob("*")
                  if p.is_file() and "__pycache__" not in p.parts) == list(example_names())


def test_approach_retract_trace_reads():
    t, position = read_trace(EXAMPLES_DIR / "approach_retract_trace.csv")
    assert t[0] == 0.0 and np.all(np.diff(t) > 0)
    assert position.max() == pytest.approx(10e-9, abs=3e-11)
    assert position.min() == pytest.approx(-8e-9, abs=3e-11)


def test_spectrum_csv_fits_back_to_the_truth(true_problem):
    ds = load_instrument(EXAMPLES_DIR / "sls_spectrum.csv")
    assert ds.attrs["source"] == "csv-spectrum" and ds.sizes["omega"] == 25
    assert {"stiffness_stderr", "phase_stderr"} <= set(ds.data_vars)
    fit = fit_spectrum(ds, "exact", position=me.H0, problem=true_problem)
    assert bool(fit["success"])
    for name, truth in me.TRUE_SLS.items():
        value, stderr = float(fit[name]), float(fit[f"{name}_stderr"])
        assert 0 < stderr < 0.05 * truth, name
        assert abs(value - truth) < Z_MAX * stderr, (name, value, stderr)


def test_step_relaxation_csv_loads_and_relaxes_to_the_static_load(true_problem):
    ds = load_instrument(EXAMPLES_DIR / "sls_step_relaxation.csv")
    assert ds.attrs["source"] == "csv-curves"
    assert list(ds["segment_name"].values) == ["pause", "approach", "pause"]
    assert list(ds["segment_type"].values) == ["dwell", "extend", "hold"]
    time, force = ds["time"].values, ds["force"].values
    np.testing.assert_allclose(ds["deflection"].values * me.CANTILEVER["spring_constant"], force,
                               rtol=1e-6)
    _, before = linear_stiffness(true_problem, me.H0, [0.0])
    _, after = linear_stiffness(true_problem, -7e-9, [0.0])
    # the first 1 ms is the static state at -5 nm; the last 2 ms (> 20 relaxation times after the
    # step) the static E_inf load at -7 nm; tolerance: the 5 nN drift plus noise (2 nN rms)
    assert np.mean(force[time < 1e-3]) == pytest.approx(before, abs=2e-9)
    assert np.mean(force[time > time[-1] - 2e-3]) == pytest.approx(after, abs=6e-9)
    assert force.max() > 1.5 * after                   # the glassy overshoot of the step


def test_modulation_jpk_recovers_the_linear_response(true_problem):
    path = EXAMPLES_DIR / "sls_modulation.jpk-force"
    curves = load_instrument(path)
    assert curves.attrs["source"] == "jpk" and curves.attrs["height_channel"] == "measuredHeight"
    assert list(curves["segment_style"].values) == ["extend", "pause"] + ["modulation"] * 6 + [
        "retract"]
    with read_jpk(path) as archive:
        curve = archive.curve(0)
    assert curve.spring_constant == me.CANTILEVER["spring_constant"]
    assert curve.sensitivity == me.CANTILEVER["sensitivity"]
    assert [s.modulation.frequency for s in curve.segments if s.modulation] == list(
        me.JPK_FREQUENCIES)

    spec = modulation_spectrum(path)
    assert spec.sizes == {"curve": 1, "omega": 6}
    k, mean_force = linear_stiffness(true_problem, me.H0, spec["omega"].values)
    np.testing.assert_allclose(spec["frequency"].values, sorted(me.JPK_FREQUENCIES))
    stiffness, phase = spec["stiffness"].values[0], spec["phase"].values[0]
    z_k = (stiffness - np.abs(k)) / spec["stiffness_stderr"].values[0]
    z_phase = (phase - np.degrees(np.angle(k))) / spec["phase_stderr"].values[0]
    assert np.all(np.abs(z_k) < Z_MAX), z_k
    assert np.all(np.abs(z_phase) < Z_MAX), z_phase
    assert np.all(spec["stiffness_stderr"].values < 0.01 * stiffness)   # a meaningful test
    z_mean = (spec["mean_force"].values[0] - mean_force) / spec["mean_force_stderr"].values[0]
    assert np.all(np.abs(z_mean) < Z_MAX), z_mean                      # baseline subtracted
    np.testing.assert_allclose(spec["drive_amplitude"].values[0], me.JPK_ETA, rtol=0.02)
    assert np.all(spec["quality"].values == 0)


def test_spectrum_map_opens_and_a_pixel_fits_back(true_problem):
    with xr.open_dataset(EXAMPLES_DIR / "sls_spectrum_map.nc", engine="h5netcdf") as opened:
        ds = validate_spectrum(opened.load())
    assert dict(ds.sizes) == {"y": 4, "x": 4, "omega": me.MAP_FREQUENCIES.size}
    assert ds["stiffness"].dims == ("y", "x", "omega") and ds.attrs["source"] == "synthetic"
    for iy in range(4):
        for ix in range(4):
            truth = me.map_material(iy, ix)
            for name, value in truth.items():
                assert float(ds[f"true_{name}"][iy, ix]) == value
    for iy, ix in ((0, 0), (3, 2)):
        pixel = ds.isel(y=iy, x=ix).drop_vars(["true_E0", "true_E_inf", "true_tau"])
        fit = fit_spectrum(pixel, "exact", position=me.H0, problem=true_problem)
        for name, truth in me.map_material(iy, ix).items():
            value, stderr = float(fit[name]), float(fit[f"{name}_stderr"])
            assert abs(value - truth) < Z_MAX * stderr, (iy, ix, name, value, truth, stderr)


def _csv_values(path: Path) -> tuple[list[str], np.ndarray]:
    lines = [line for line in path.read_text().splitlines() if not line.startswith("#")]
    rows = [line.split(",") for line in lines[1:]]
    numeric = [[float(c) for c in row if not c.isalpha()] for row in rows]
    return [lines[0]] + [c for row in rows for c in row if c.isalpha()], np.asarray(numeric)


def _same_properties(new: bytes, old: bytes, member: str) -> None:
    """The same keys, text values equal, numbers equal to 1e-12 (a header's floats are values
    computed through the solvers: their last digit follows the platform's BLAS and libm)."""
    a, b = parse_properties(new), parse_properties(old)
    assert a.keys() == b.keys(), member
    for key in b:
        if a[key] == b[key]:
            continue
        try:
            x, y = float(a[key]), float(b[key])
        except ValueError:
            raise AssertionError(f"{member}: {key} = {a[key]!r}, bundled {b[key]!r}") from None
        assert math.isclose(x, y, rel_tol=1e-12, abs_tol=0.0), (member, key, x, y)


def test_regeneration_gives_the_bundled_files(tmp_path):
    assert me.main(["--out", str(tmp_path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(me.EXAMPLES)
    # pure numpy: byte for byte
    for name in ("approach_retract_trace.csv", "sls_spectrum.csv"):
        assert (tmp_path / name).read_bytes() == (EXAMPLES_DIR / name).read_bytes(), name
    # through the solvers (BLAS): the same values to the printed precision
    labels, values = _csv_values(tmp_path / "sls_step_relaxation.csv")
    want_labels, want = _csv_values(EXAMPLES_DIR / "sls_step_relaxation.csv")
    assert labels == want_labels
    np.testing.assert_allclose(values, want, rtol=2e-6, atol=0)
    with xr.open_dataset(tmp_path / "sls_spectrum_map.nc", engine="h5netcdf") as new, \
            xr.open_dataset(EXAMPLES_DIR / "sls_spectrum_map.nc", engine="h5netcdf") as old:
        xr.testing.assert_allclose(new.load(), old.load(), rtol=1e-9, atol=0)
        assert new.attrs == old.attrs
    name = "sls_modulation.jpk-force"
    with zipfile.ZipFile(tmp_path / name) as new, zipfile.ZipFile(EXAMPLES_DIR / name) as old:
        assert new.namelist() == old.namelist()
        for member in new.namelist():
            if member.endswith("segment-header.properties") or member == "header.properties":
                _same_properties(new.read(member), old.read(member), member)
        shared_new = parse_properties(new.read("shared-data/header.properties"))
        shared_old = parse_properties(old.read("shared-data/header.properties"))
        assert shared_new.keys() == shared_old.keys()
    curve_new = read_jpk(tmp_path / name).curve(0)
    curve_old = read_jpk(EXAMPLES_DIR / name).curve(0)
    for a, b in zip(curve_new.segments, curve_old.segments, strict=True):
        for channel in b.channels:
            scale = np.abs(b.channels[channel]).max()
            np.testing.assert_allclose(a.channels[channel], b.channels[channel], rtol=0,
                                       atol=1e-9 * scale + math.ulp(scale), err_msg=channel)
