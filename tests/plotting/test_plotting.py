"""Trajectory plots (viscoforce.plotting) and the script notebooks/paper_figures.py."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import subprocess
import sys

import numpy as np
import pytest

import viscoforce as vf
from tests.conftest import REPO
from viscoforce.exceptions import ParameterError, SchemaError
from viscoforce.experiments import Ramp, Triangle
from viscoforce.plotting import (
    PlotHandle,
    _branches,
    contact_radius_plot,
    force_time_plot,
    hysteresis_plot,
    profile_plot,
)
from viscoforce.solvers.simulate import simulate

NM, UN, MS = 1e-9, 1e-6, 1e-3


def _problem(deepest):
    return vf.ContactProblem.create(
        sphere=vf.Sphere(10e-6), surface_force=vf.paper_pressure_law(),
        material=vf.StandardLinearSolid(E0=1e10, E_inf=1e9, tau=1e-3), deepest_position=deepest)


@pytest.fixture(scope="module")
def trajectory():
    """A short triangle 3 → −3 → 3 nm at 20 µm/s, 31 outputs, a profile every 5th output."""
    drive = Triangle(top=3e-9, turn=-3e-9, speed=20e-6)
    return simulate(_problem(drive.extent()[0]), drive, t_end=drive.duration,
                    t_eval=np.linspace(0.0, drive.duration, 31), profiles=5, progress=False)


@pytest.fixture
def axes():
    import matplotlib.pyplot as plt

    return plt.subplots()[1]


def _turn(ds):
    return int(np.argmin(ds.position.values))


# ── the handle and the import ───────────────────────────────────────────────────────────────────


def test_import_does_not_load_matplotlib():
    code = ("import sys, viscoforce.plotting; "
            "sys.exit(1 if 'matplotlib' in sys.modules else 0)")
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


def test_handle_is_frozen(trajectory):
    handle = hysteresis_plot(trajectory)
    assert isinstance(handle, PlotHandle)
    assert handle.ax is handle.axes[0]
    with pytest.raises(dataclasses.FrozenInstanceError):
        handle.lines = ()  # type: ignore[misc]


# ── hysteresis_plot ─────────────────────────────────────────────────────────────────────────────


def test_hysteresis_branches_carry_the_data(trajectory):
    handle = hysteresis_plot(trajectory, label="run")
    ax = handle.ax
    assert ax.get_xlabel() == "position $h_0$ [nm]"
    assert ax.get_ylabel() == "force $F$ [µN]"
    loading, unloading = handle.lines
    k = _turn(trajectory)
    position = trajectory.position.values
    force = trajectory.force.values
    # exact: the plot only rescales (1e9, 1e6) — tolerance is float rounding
    np.testing.assert_allclose(loading.get_xdata(), position[: k + 1] / NM, rtol=1e-12)
    np.testing.assert_allclose(loading.get_ydata(), force[: k + 1] / UN, rtol=1e-12)
    np.testing.assert_allclose(unloading.get_xdata(), position[k:] / NM, rtol=1e-12)
    assert loading.get_linestyle() == "-" and unloading.get_linestyle() == "--"
    assert loading.get_color() == unloading.get_color()
    assert loading.get_label() == "run" and unloading.get_label() == "_nolegend_"
    assert np.all(np.diff(loading.get_xdata()) < 0) and np.all(np.diff(unloading.get_xdata()) > 0)


def test_hysteresis_force_unit_and_given_axes(trajectory, axes):
    handle = hysteresis_plot(trajectory, ax=axes, force_unit="nN",
                             line_kw={"color": "red", "linewidth": 3})
    assert handle.ax is axes and handle.figure is axes.figure
    assert axes.get_ylabel() == "force $F$ [nN]"
    np.testing.assert_allclose(handle.lines[0].get_ydata()[0], trajectory.force.values[0] / NM,
                               rtol=1e-12)
    assert all(line.get_color() == "red" and line.get_linewidth() == 3 for line in handle.lines)


def test_hysteresis_statics_and_rigid(trajectory):
    h = np.array([3e-9, 0.0, -3e-9])
    statics = {"E_inf": (h, [1e-8, 2e-7, 5e-7]), "E0": (h, [1e-8, 4e-7, 9e-7])}
    fmax = max(float(trajectory.force.max()), 9e-7)
    rigid_h = np.array([3e-9, 1e-9, 0.1e-9, 0.01e-9, 0.0])
    rigid_f = np.array([1e-8, 1e-7, 0.5 * fmax, 10 * fmax, np.inf])
    handle = hysteresis_plot(trajectory, statics=statics, rigid=(rigid_h, rigid_f))
    branches, s1, s2, rigid = handle.lines[:2], handle.lines[2], handle.lines[3], handle.lines[4]
    assert len(handle.lines) == 5 and len(branches) == 2
    assert (s1.get_marker(), s2.get_marker()) == ("^", "x")
    assert s1.get_label() == "E_inf" and s1.get_linestyle() == "None"
    np.testing.assert_allclose(s2.get_ydata(), [1e-2, 0.4, 0.9], rtol=1e-12)
    # inf and the point above 1.2 × the largest force are dropped
    np.testing.assert_allclose(rigid.get_xdata(), [3.0, 1.0, 0.1], rtol=1e-12)
    assert rigid.get_label() == "rigid" and rigid.get_linewidth() == 2.5


def test_hysteresis_log_axis(trajectory):
    handle = hysteresis_plot(trajectory, log=True)
    assert handle.ax.get_yscale() == "log"


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"force_unit": "kN"}, "force_unit must be one of"),
    ({"ax": "not axes"}, "ax must be a matplotlib Axes"),
    ({"line_kw": {"linestyle": ":"}}, r"line_kw must not set \['linestyle'\]"),
    ({"statics": [1, 2]}, "statics must be a mapping"),
    ({"statics": {"a": (np.zeros(3), np.zeros(2))}}, "same length, got 3 and 2"),
    ({"statics": {"a": (np.zeros(2), [1.0, np.inf])}}, r"statics\['a'\] values must be finite"),
    ({"statics": {"a": (np.zeros(2), ["x", "y"])}}, "values must be real numbers"),
    ({"statics": {"a": 5.0}}, r"statics\['a'\] must be a pair"),
    ({"rigid": (np.zeros(2), [1.0, np.nan])}, "rigid values must not be NaN"),
    ({"rigid": ([np.nan, 1.0], [1.0, 1.0])}, "rigid positions must be finite"),
])
def test_hysteresis_rejects_bad_input(trajectory, kwargs, match):
    with pytest.raises(ParameterError, match=match):
        hysteresis_plot(trajectory, **kwargs)


def test_trajectory_must_be_a_dataset_with_the_variables(trajectory):
    with pytest.raises(ParameterError, match="trajectory must be the xarray.Dataset"):
        hysteresis_plot({"position": [0, 1], "force": [0, 1]})
    with pytest.raises(SchemaError, match=r"missing \['force'\]"):
        hysteresis_plot(trajectory.drop_vars("force"))
    with pytest.raises(SchemaError, match="at least 2 output times, got 1"):
        hysteresis_plot(trajectory.isel(time=[0]))


# ── branch splitting ────────────────────────────────────────────────────────────────────────────


@pytest.mark.parametrize(("position", "expected"), [
    ([3, 2, 1, 2, 3], [(0, 2, True), (2, 4, False)]),
    ([3, 3, 2, 2, 3], [(0, 3, True), (3, 4, False)]),       # holds join the move they interrupt
    ([1, 2, 2, 1], [(0, 2, False), (2, 3, True)]),           # retraction first
    ([5, 5, 5], [(0, 2, True)]),                            # never moves: one loading run
    ([3, 1, 3, 1], [(0, 1, True), (1, 2, False), (2, 3, True)]),
])
def test_branches(position, expected):
    assert _branches(np.asarray(position, dtype=float)) == expected


# ── contact_radius_plot ─────────────────────────────────────────────────────────────────────────


def test_contact_radius_plot(trajectory):
    assert float(trajectory.contact_radius.max()) > 0  # the fixture reaches contact
    h = np.array([0.0, -3e-9])
    handle = contact_radius_plot(trajectory, statics={"static": (h, [50e-9, 150e-9])},
                                 label="20 µm/s")
    ax = handle.ax
    assert ax.get_xlabel() == "position $h_0$ [nm]"
    assert ax.get_ylabel() == "contact radius $a$ [nm]"
    k = _turn(trajectory)
    np.testing.assert_allclose(handle.lines[0].get_ydata(),
                               trajectory.contact_radius.values[: k + 1] / NM, rtol=1e-12)
    np.testing.assert_allclose(handle.lines[2].get_ydata(), [50.0, 150.0], rtol=1e-12)
    um = contact_radius_plot(trajectory, radius_unit="um")
    assert um.ax.get_ylabel() == "contact radius $a$ [µm]"
    with pytest.raises(ParameterError, match="radius_unit must be one of"):
        contact_radius_plot(trajectory, radius_unit="mm")
    with pytest.raises(SchemaError, match=r"missing \['contact_radius'\]"):
        contact_radius_plot(trajectory.drop_vars("contact_radius"))


# ── profile_plot ────────────────────────────────────────────────────────────────────────────────


def test_profile_plot_two_panels(trajectory):
    handle = profile_plot(trajectory, r_max=300e-9, gap_max=8e-9)
    load, unload = handle.axes
    assert load.get_title() == "loading (approach)"
    assert unload.get_title() == "unloading (retraction)"
    assert load.get_xlabel() == "radius $r$ [nm]" and load.get_ylabel() == "local gap $h(r)$ [nm]"
    np.testing.assert_allclose(load.get_xlim(), (0.0, 300.0), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(load.get_ylim(), (0.0, 8.0), rtol=1e-12, atol=1e-12)
    times = trajectory.profile_time.values
    t_turn = float(trajectory.time.values[_turn(trajectory)])
    n_load = int(np.sum(times <= t_turn))
    n_unload = int(np.sum(times >= t_turn))
    assert len(load.lines) == n_load and len(unload.lines) == n_unload
    assert len(handle.lines) == n_load + n_unload + 1  # + the colour bar
    assert handle.lines[-1].ax.get_ylabel() == "position $h_0$ [nm]"
    first = handle.lines[0]
    r = trajectory.r.values
    np.testing.assert_allclose(first.get_xdata(), r[r <= 300e-9] / NM, rtol=1e-12)
    np.testing.assert_allclose(first.get_ydata(), trajectory.gap.values[0, r <= 300e-9] / NM,
                               rtol=1e-12)


def test_profile_plot_single_and_pair(trajectory, axes):
    import matplotlib.pyplot as plt

    one = profile_plot(trajectory, ax=axes)
    assert one.axes == (axes,)
    styles = {line.get_linestyle() for line in axes.lines}
    assert styles == {"-", "--"}
    pair = plt.subplots(1, 2)[1]
    two = profile_plot(trajectory, ax=list(pair), radius_unit="um")
    assert two.axes == (pair[0], pair[1]) and pair[1].get_xlabel() == "radius $r$ [µm]"


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"ax": (1, 2, 3)}, ParameterError, "ax must be None, one matplotlib Axes or a pair"),
    ({"r_max": -1.0}, ParameterError, "r_max must be > 0"),
    ({"gap_max": 0.0}, ParameterError, "gap_max must be > 0"),
    ({"cmap": "no-such-map"}, ParameterError, "cmap must be a matplotlib colormap"),
    ({"radius_unit": "km"}, ParameterError, "radius_unit must be one of"),
])
def test_profile_plot_rejects_bad_input(trajectory, kwargs, error, match):
    with pytest.raises(error, match=match):
        profile_plot(trajectory, **kwargs)


def test_profile_plot_needs_profiles(trajectory):
    with pytest.raises(SchemaError, match=r"profiles=N"):
        profile_plot(trajectory.drop_vars(["gap", "deformation", "pressure", "profile_time"]))


# ── force_time_plot ─────────────────────────────────────────────────────────────────────────────


def test_force_time_plot(trajectory):
    handle = force_time_plot(trajectory, label="F", t_start=0.1e-3)
    (line,) = handle.lines
    assert handle.ax.get_xlabel() == "time $t$ [ms]"
    assert handle.ax.get_ylabel() == "force $F$ [µN]"
    np.testing.assert_allclose(line.get_xdata(), (trajectory.time.values - 0.1e-3) / MS,
                               rtol=1e-12, atol=1e-12)
    assert line.get_label() == "F" and handle.ax.get_yscale() == "linear"


def test_force_time_plot_log_difference(trajectory):
    force = trajectory.force.values
    reference = float(force[5])
    handle = force_time_plot(trajectory, log=True, reference=reference, force_unit="nN",
                             time_unit="us")
    (line,) = handle.lines
    assert handle.ax.get_yscale() == "log"
    assert handle.ax.get_ylabel() == "$|F - F^*|$ [nN]"
    assert handle.ax.get_xlabel() == "time $t$ [µs]"
    y = np.asarray(line.get_ydata(), dtype=float)
    assert np.isnan(y[5])  # |F − F*| = 0 cannot be drawn on a log axis
    keep = np.arange(y.size) != 5
    np.testing.assert_allclose(y[keep], np.abs(force - reference)[keep] / NM, rtol=1e-12)
    linear = force_time_plot(trajectory, reference=reference)
    assert linear.ax.get_ylabel() == "$F - F^*$ [µN]"
    assert np.nanmin(linear.lines[0].get_ydata()) < 0


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"time_unit": "h"}, "time_unit must be one of"),
    ({"reference": np.inf}, "reference must be finite"),
    ({"t_start": "soon"}, "t_start must be a real number"),
    ({"line_kw": {"label": "x"}}, r"line_kw must not set \['label'\]"),
])
def test_force_time_plot_rejects_bad_input(trajectory, kwargs, match):
    with pytest.raises(ParameterError, match=match):
        force_time_plot(trajectory, **kwargs)


def test_force_time_plot_of_a_ramp():
    """A hold-free ramp is a single loading branch; its force rises monotonically."""
    drive = Ramp.from_speed(5e-9, 2e-9, 50e-6)
    ds = simulate(_problem(2e-9), drive, t_end=drive.duration,
                  t_eval=np.linspace(0.0, drive.duration, 11), progress=False)
    handle = hysteresis_plot(ds)
    assert len(handle.lines) == 1 and handle.lines[0].get_linestyle() == "-"
    assert np.all(np.diff(force_time_plot(ds).lines[0].get_ydata()) > 0)


# ── notebooks/paper_figures.py ──────────────────────────────────────────────────────────────────


@pytest.mark.slow
def test_paper_figures_quick(tmp_path, capsys):
    """``python notebooks/paper_figures.py --quick``: its main() in this process (the script's
    ``__main__`` block is ``sys.exit(main())``), without an interpreter start and imports.

    Slow (3.7 s): in CI the paper_figures notebook runs the same figure functions in quick mode
    (``tests/project/test_notebooks.py``) and compares everything they print — Fig. 1's relaxed
    loads, Fig. 5's peak forces, Fig. 8's works, to 3 significant digits — with the committed
    outputs; what only this test checks is the script's own command line and figures.json."""
    spec = importlib.util.spec_from_file_location("_paper_figures_script",
                                                  REPO / "notebooks" / "paper_figures.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    assert script.main(["--quick", "--out", str(tmp_path)]) == 0
    stdout = capsys.readouterr().out
    for name in ("fig1", "fig2", "fig5", "fig6", "fig7", "fig8"):
        png = (tmp_path / f"{name}.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000
    results = json.loads((tmp_path / "figures.json").read_text())
    assert results["parameters"]["quick"] is True
    relaxed = {round(r["end_position_m"] / 1e-9): r["relaxed_load_N"]
               for r in results["fig1"]["runs"]}
    # paper Fig. 1: F* = 1.59 and 0.66 µN (3 digits quoted: tolerance half a unit in the last)
    assert relaxed[-7] == pytest.approx(1.59e-6, abs=0.005e-6)
    assert relaxed[-3] == pytest.approx(0.66e-6, abs=0.005e-6)
    peaks = [r["peak_force_N"] for r in results["fig5"]["runs"]]
    assert peaks == sorted(peaks)  # faster drives give larger peak forces (paper Fig. 5)
    works = [r["hysteresis_work_J"] for r in results["fig8"]["runs"]]
    assert all(w > 0 for w in works)
    assert "Fig.1 tau=1 ms" in stdout


# ── inputs are checked against the schema ───────────────────────────────────────────────────────


def _spectrum():
    from viscoforce.schema import make_spectrum

    w = np.geomspace(10, 1e4, 5)
    return make_spectrum(w, 10 + 30j * w * 1e-3 / (1 + 1j * w * 1e-3), 1e-7, 1e-10,
                         attrs={"method": "linear"})


@pytest.mark.parametrize(("spectra", "error", "match"), [
    (None, ParameterError, "spectra must be a spectrum Dataset, a mapping .* got NoneType"),
    (42, ParameterError, "spectra must be a spectrum Dataset, .* got int"),
    ("spectrum.nc", ParameterError, "got str"),
    ([], ParameterError, "at least one spectrum"),
    ([None], SchemaError, "bode_plot: spectrum 'spectrum 1': spectrum must be an xarray.Dataset"),
    ({"data": 3.0}, SchemaError, "spectrum 'data': spectrum must be an xarray.Dataset, got float"),
])
def test_bode_plot_rejects_what_is_not_a_spectrum(spectra, error, match):
    from viscoforce.plotting import bode_plot

    with pytest.raises(error, match=match):
        bode_plot(spectra)


def test_bode_plot_checks_units_and_dims():
    from viscoforce.plotting import bode_plot

    ds = _spectrum()
    assert len(bode_plot(ds).lines) == 2
    assert bode_plot([ds]).axes[0].get_legend_handles_labels()[1] == ["linear"]
    bad = ds.assign(phase=ds.phase.assign_attrs(units="rad"))
    with pytest.raises(SchemaError, match="spectrum 'linear': spectrum: 'phase' must have units "
                                          "'degree', got 'rad'"):
        bode_plot(bad)
    with pytest.raises(SchemaError, match="has no 'amplitude'"):
        bode_plot(ds.drop_vars("amplitude"), magnitude="amplitude")
    with pytest.raises(ParameterError, match=r"also spans \['curve'\]: select one, e.g. "
                                             r"ds.isel\(curve=0\)"):
        bode_plot(ds.expand_dims(curve=2).transpose("curve", "omega"))


@pytest.mark.parametrize("plot", [hysteresis_plot, contact_radius_plot, force_time_plot,
                                  profile_plot])
def test_trajectory_plots_reject_none(plot):
    with pytest.raises(ParameterError, match="trajectory must be the xarray.Dataset returned by "
                                             "simulate\\(\\), got NoneType"):
        plot(None)


def test_trajectory_plots_check_units(trajectory):
    bad = trajectory.assign(force=trajectory.force.assign_attrs(units="uN"))
    with pytest.raises(SchemaError, match="hysteresis_plot: trajectory: 'force' must have units "
                                          "'N', got 'uN'"):
        hysteresis_plot(bad)
    with pytest.raises(SchemaError, match="force_time_plot: trajectory is missing 'time'"):
        force_time_plot(trajectory.drop_vars("time"))


# ── bad option types (robustness probe): ParameterError naming the option ───────────────────────

_EMPTY = np.array([])


@pytest.mark.parametrize(("plot", "kwargs", "match"), [
    (hysteresis_plot, {"label": ["a", "b"]}, r"label must be a string or None, got list"),
    (hysteresis_plot, {"label": {}}, r"label must be a string or None, got dict"),
    (hysteresis_plot, {"label": 3.0}, r"label must be a string or None, got float 3.0"),
    (contact_radius_plot, {"label": ["a"]}, r"label must be a string or None, got list"),
    (force_time_plot, {"label": _EMPTY}, r"label must be a string or None, got ndarray"),
    (hysteresis_plot, {"force_unit": ["uN"]}, r"force_unit must be one of 'N', .* got list"),
    (hysteresis_plot, {"force_unit": {}}, r"force_unit must be one of .* got dict"),
    (force_time_plot, {"force_unit": _EMPTY}, r"force_unit must be one of .* got ndarray"),
    (force_time_plot, {"time_unit": ["ms"]}, r"time_unit must be one of .* got list"),
    (contact_radius_plot, {"radius_unit": {}}, r"radius_unit must be one of .* got dict"),
    (profile_plot, {"radius_unit": ["nm"]}, r"radius_unit must be one of .* got list"),
    (profile_plot, {"cmap": ["viridis"]}, r"cmap must be a matplotlib colormap name .* got list"),
    (profile_plot, {"cmap": {}}, r"cmap must be a matplotlib colormap name .* got dict"),
    (profile_plot, {"r_max": 1e300}, r"r_max must be at most .* m to be shown in nm, got 1e\+300"),
    (profile_plot, {"gap_max": 1e300}, r"gap_max must be at most .* to be shown in nm"),
    (hysteresis_plot, {"line_kw": "red"}, r"line_kw must be a mapping of matplotlib line "
                                          r"properties .* got str 'red'"),
    (hysteresis_plot, {"line_kw": [("color", "r")]}, r"line_kw must be a mapping .* got list"),
    (contact_radius_plot, {"line_kw": 3.0}, r"line_kw must be a mapping .* got float 3.0"),
    (force_time_plot, {"line_kw": True}, r"line_kw must be a mapping .* got bool True"),
    (force_time_plot, {"line_kw": {1: "r"}}, r"line_kw keys must be property names"),
    (hysteresis_plot, {"line_kw": {"colour": "r"}},
     r"line_kw holds an invalid matplotlib line property"),
    (force_time_plot, {"line_kw": {"linewidth": "thick"}},
     r"line_kw holds an invalid matplotlib line property"),
    (hysteresis_plot, {"log": _EMPTY}, r"log must be True or False, got ndarray"),
    (hysteresis_plot, {"log": "yes"}, r"log must be True or False, got str 'yes'"),
    (force_time_plot, {"log": None}, r"log must be True or False, got None"),
])
def test_trajectory_plots_reject_bad_options(trajectory, plot, kwargs, match):
    with pytest.raises(ParameterError, match=match):
        plot(trajectory, **kwargs)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"ax": [1.0, 2.0]}, r"ax must be None or a pair of matplotlib Axes .* got list \[1.0, 2.0\]"),
    ({"ax": object()}, r"ax must be None or a pair of matplotlib Axes .* got object"),
    ({"ax": 3.0}, r"ax must be None or a pair of matplotlib Axes .* got float 3.0"),
    ({"ax": "ab"}, r"ax must be None or a pair of matplotlib Axes .* got str 'ab'"),
    ({"magnitude": ["stiffness"]}, r"magnitude must be one of 'stiffness', 'amplitude', got list"),
    ({"magnitude": {}}, r"magnitude must be one of .* got dict"),
    ({"magnitude": _EMPTY}, r"magnitude must be one of .* got ndarray"),
    ({"frequency_unit": _EMPTY}, r"frequency_unit must be one of 'auto', 'rad/s', 'Hz', got ndarray"),
    ({"frequency_unit": ["Hz"]}, r"frequency_unit must be one of .* got list"),
    ({"markers": _EMPTY}, r"markers must be True, False or None, got ndarray"),
    ({"markers": "o"}, r"markers must be True, False or None, got str 'o'"),
    ({"title": _EMPTY}, r"title must be a string or None, got ndarray"),
    ({"title": 3}, r"title must be a string or None, got int 3"),
])
def test_bode_plot_rejects_bad_options(kwargs, match):
    from viscoforce.plotting import bode_plot

    with pytest.raises(ParameterError, match=match):
        bode_plot(_spectrum(), **kwargs)


def test_bode_plot_accepts_a_pair_of_axes_and_a_numpy_bool():
    import matplotlib.pyplot as plt

    from viscoforce.plotting import bode_plot

    pair = plt.subplots(2, 1)[1]
    handle = bode_plot(_spectrum(), ax=list(pair), markers=np.True_, title="t")
    assert handle.axes == (pair[0], pair[1])
    plt.close("all")


def test_loops_say_which_branch_is_loading(trajectory):
    """Each branch carries an arrowhead along the drive, and a corner key names the styles."""
    handle = hysteresis_plot(trajectory)
    ax = handle.axes[0]
    arrows = [a for a in ax.texts if getattr(a, "arrow_patch", None) is not None]
    assert len(arrows) == len(handle.lines)  # one per branch
    tip, tail = arrows[0].xy, arrows[0].xyann
    assert tip[0] < tail[0]  # the approach runs towards smaller h0 (loading)
    assert handle.lines[0].get_linestyle() == "-"
    assert len(arrows) == 2 and arrows[1].xy[0] > arrows[1].xyann[0]  # retraction: unloading
    assert any("solid: loading (approach)" in t.get_text() for t in ax.texts)
