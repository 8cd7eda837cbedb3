"""Property tests: every dataset kind survives a netCDF round trip unchanged (``identical``).

tests/schema/test_schema.py round-trips each kind once through the scipy (netCDF3) engine and draws random
spectra and curves; this adds random equilibria, trajectories and fit results, the h5netcdf
engine (what ``load`` and ``fit --out`` write) for every kind, spectra with extra dims, stderr,
quality and coordinates, and fit results over map dims with the ``message`` string variable
that :func:`viscoforce.fitting.maps.fit_map` writes.
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from viscoforce.fitting.pixels import assemble_map
from viscoforce.schema import (
    make_curves,
    make_equilibrium,
    make_fit_result,
    make_spectrum,
    make_trajectory,
    phase_quality,
    validate_fit_result,
)

#: The paper's Fig. 3 scene (2 nm) is deliberately evaluated with the SVDA, which warns there
#: (estimated error > 1 %, issue 15); the warning itself is tested in tests/theory/test_failure_regions.py.
pytestmark = pytest.mark.filterwarnings(
    "ignore:the SVDA is about:viscoforce.exceptions.ModelValidityWarning")


HYPO = settings(max_examples=20, deadline=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture])
ENGINES = ["h5netcdf", "scipy"]
FINITE = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
POSITIVE = st.floats(1e-12, 1e3, allow_nan=False, allow_infinity=False)


def roundtrip(ds: xr.Dataset, folder, engines=ENGINES) -> xr.Dataset:
    """``ds`` written into ``folder`` and read back by each engine: identical, dtypes kept.

    Each drawn dataset goes through both engines (a test per engine drew its own, twice the
    drawing for the same round trips). Returns the h5netcdf copy.
    """
    backs = {}
    for engine in engines:
        path = folder / f"{engine}.nc"
        ds.to_netcdf(path, engine=engine)
        with xr.open_dataset(path, engine=engine) as opened:
            back = opened.load()
        xr.testing.assert_identical(ds, back)
        for name, var in ds.variables.items():
            if var.dtype.kind not in "USO":
                assert back[name].dtype == var.dtype, (engine, name)
        backs[engine] = back
    return backs["h5netcdf"]


def floats(data, shape, elements=FINITE):
    return data.draw(hnp.arrays(float, shape, elements=elements))


def increasing(data, n, low=1e-6, high=1.0):
    steps = data.draw(hnp.arrays(float, n, elements=st.floats(low, high)))
    return np.cumsum(steps)


@HYPO
@given(data=st.data())
def test_equilibrium_roundtrip(data, tmp_path_factory):
    n = data.draw(st.integers(1, 8))
    r = np.concatenate([[0.0], increasing(data, n - 1, 1e-9, 1e-7)]) if n > 1 else np.zeros(1)
    ds = make_equilibrium(
        r, gap=floats(data, n, POSITIVE), deformation=floats(data, n),
        pressure=floats(data, n), undeformed_gap=floats(data, n, POSITIVE),
        position=data.draw(FINITE), force=data.draw(FINITE), force_rigid=data.draw(FINITE),
        u_center=data.draw(FINITE), h_center=data.draw(POSITIVE),
        contact_radius=data.draw(st.floats(0.0, 1e-6)),
        contact_threshold=data.draw(POSITIVE),
        attrs={"radius": data.draw(POSITIVE), "method": data.draw(st.sampled_from(["a", "µ"])),
               "steps": data.draw(st.integers(0, 10**6))})
    roundtrip(ds, tmp_path_factory.mktemp("eq"))


@HYPO
@given(data=st.data(), profiles=st.booleans())
def test_trajectory_roundtrip(data, profiles, tmp_path_factory):
    n = data.draw(st.integers(2, 12))
    t = increasing(data, n, 1e-9, 1e-3)
    args = {name: floats(data, n) for name in ("position", "force", "u_center")}
    args.update(h_center=floats(data, n, POSITIVE),
                contact_radius=floats(data, n, st.floats(0.0, 1e-6)),
                contact_threshold=data.draw(POSITIVE),
                attrs={"stepper": "exponential", "dt": data.draw(POSITIVE), "steps": n})
    if profiles:
        m = data.draw(st.integers(1, n))
        k = data.draw(st.integers(1, 6))
        args.update(profile_time=t[:m], r=np.linspace(0.0, 1e-7, k),
                    gap=floats(data, (m, k), POSITIVE), deformation=floats(data, (m, k)),
                    pressure=floats(data, (m, k)))
    ds = make_trajectory(t, **args)
    roundtrip(ds, tmp_path_factory.mktemp("traj"))


@HYPO
@given(data=st.data())
def test_spectrum_with_extra_dims_stderr_and_quality_roundtrip(data, tmp_path_factory):
    n = data.draw(st.integers(1, 6))
    extra = data.draw(st.lists(st.integers(1, 3), min_size=0, max_size=2))
    names = ("y", "x")[: len(extra)]
    shape = (*extra, n)
    dims = (*names, "omega")
    w = np.sort(data.draw(hnp.arrays(float, n, elements=st.floats(1e-3, 1e9), unique=True)))
    magnitude = floats(data, shape, st.floats(1e-6, 1e6))
    phase = floats(data, shape, st.floats(-179.0, 179.0))
    mean = floats(data, shape, st.floats(1e-9, 1e-6))
    eta = floats(data, shape, st.floats(1e-12, 1e-8)) if data.draw(st.booleans()) else 1e-10
    coords = {name: (name, np.arange(size) * 1e-6) for name, size in zip(names, extra, strict=True)}
    stderr = {"stiffness": 0.01 * magnitude, "phase": floats(data, shape, st.floats(0.0, 5.0))}
    ds = make_spectrum(w, magnitude * np.exp(1j * np.radians(phase)), mean, eta, dims=dims,
                       coords=coords, stderr=stderr, quality=phase_quality(phase),
                       mean_indentation=floats(data, shape, st.floats(0.0, 1e-8)),
                       source=data.draw(st.sampled_from([None, "jpk-force"])),
                       attrs={"file": "map.jpk-force-map", "harmonic": 1})
    roundtrip(ds, tmp_path_factory.mktemp("sp"))


@HYPO
@given(counts=st.lists(st.integers(1, 5), min_size=1, max_size=4), data=st.data())
def test_curves_roundtrip_h5netcdf(counts, data, tmp_path_factory):
    n = sum(counts)
    time = np.concatenate([increasing(data, c) for c in counts])
    force, height, deflection = (floats(data, n, st.floats(-1e-3, 1e-3)) for _ in range(3))
    segment = data.draw(hnp.arrays(np.int32, n, elements=st.integers(0, 1)))
    per_curve = {"x": floats(data, len(counts)), "spring_constant":
                 floats(data, len(counts), st.floats(1e-3, 10.0))}
    ds = make_curves(time, force, height, deflection, segment=segment,
                     segment_names=("approach", "modulation"), sample_count=counts,
                     per_curve=per_curve, source="jpk-force")
    roundtrip(ds, tmp_path_factory.mktemp("cv"), engines=("h5netcdf",))


PARAMS = ("E_inf", "E0", "tau")


def _value_and_stderr(data):
    value = data.draw(POSITIVE)
    return value, data.draw(st.none() | st.floats(0.0, 1e3))


@HYPO
@given(data=st.data(), spectrum=st.booleans())
def test_single_fit_result_roundtrip(data, spectrum, tmp_path_factory):
    params = {name: _value_and_stderr(data) for name in PARAMS}
    m = len(params)
    corr = floats(data, (m, m), st.floats(-1.0, 1.0))
    corr = (corr + corr.T) / 2
    np.fill_diagonal(corr, 1.0)
    n = data.draw(st.integers(1, 6))
    if spectrum:
        curve = {"omega": np.geomspace(1.0, 1e5, n), "fit_stiffness": floats(data, n, POSITIVE),
                 "fit_phase": floats(data, n, st.floats(-90.0, 90.0))}
    else:
        curve = {"time": increasing(data, n), "fit_force": floats(data, n)}
    ds = make_fit_result(params, correlation=corr, success=data.draw(st.booleans()),
                         redchi=data.draw(POSITIVE), aic=data.draw(FINITE), bic=data.draw(FINITE),
                         modes=1, model="svda", attrs={"position": 2e-9}, **curve)
    roundtrip(ds, tmp_path_factory.mktemp("fit"))


MESSAGES = st.sampled_from(["Fit succeeded.", "", "lost",
                            "stiffness or phase is NaN/inf at omega = 10 rad/s (point 0)",
                            "contact radius 1.5 µm > 0.1 R"])


def _pixel(data):
    if not data.draw(st.booleans()):
        return {"success": False, "message": data.draw(MESSAGES)}
    m = len(PARAMS)
    return {"names": list(PARAMS), "values": {p: data.draw(POSITIVE) for p in PARAMS},
            "stderr": {p: data.draw(st.none() | st.floats(0.0, 1e3)) for p in PARAMS},
            "correlation": floats(data, (m, m), st.floats(-1.0, 1.0)),
            "redchi": data.draw(POSITIVE), "aic": data.draw(FINITE), "bic": data.draw(FINITE),
            "success": data.draw(st.booleans()), "modes": 1, "message": data.draw(MESSAGES)}


@HYPO
@given(data=st.data())
def test_fit_map_result_with_messages_roundtrip(data, tmp_path_factory):
    """What fit_map assembles: parameters over (y, x) or curve, plus a ``message`` string."""
    grid = data.draw(st.booleans())
    shape = (data.draw(st.integers(1, 3)), data.draw(st.integers(1, 3))) if grid else (
        data.draw(st.integers(1, 5)),)
    dims = ("y", "x") if grid else ("curve",)
    n = int(np.prod(shape))
    results = [_pixel(data) for _ in range(n)]
    if not any("names" in r for r in results):
        results[0] = {**_pixel(data), "names": list(PARAMS), "values": dict.fromkeys(PARAMS, 1.0),
                      "stderr": dict.fromkeys(PARAMS), "correlation": np.eye(3), "redchi": 1.0,
                      "aic": 0.0, "bic": 0.0, "success": True, "modes": 1}
    coords = {d: np.arange(s) * 1e-6 for d, s in zip(dims, shape, strict=True)} if grid else {}
    layout = {"shape": dict(zip(dims, shape, strict=True)), "coords": coords}
    ds = assemble_map(results, dims, layout, "svda", None, n)
    validate_fit_result(ds)
    assert ds.message.dims == dims
    back = roundtrip(ds, tmp_path_factory.mktemp("map"))
    assert back.message.values.tolist() == ds.message.values.tolist()
