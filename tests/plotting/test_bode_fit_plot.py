"""bode_plot with a fit result: error bars, flagged points, the best-fit curve, the parameter box."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from viscoforce.closed_form import sls_complex_compliance
from viscoforce.exceptions import ParameterError, SchemaError
from viscoforce.plotting import bode_plot
from viscoforce.schema import make_fit_result, make_spectrum

TAU, E0, E_INF = 1e-3, 1e10, 1e9
GEOMETRY = 1e-7  # k* = E*(ω)·GEOMETRY [m]: stiffness 1e2 to 1e3 N/m


def _stiffness(omega):
    return GEOMETRY / sls_complex_compliance(omega, E0=E0, E_inf=E_INF, tau=TAU)


def _spectrum(rng, dims=None):
    w = np.geomspace(10.0, 1e5, 13)
    k = _stiffness(w) * (1 + 0.02 * rng.standard_normal(w.size))
    quality = np.zeros(w.size, dtype=np.int8)
    quality[-1] = 1  # phase_outside_passive_range
    if dims is not None:  # a map of two curves
        k = np.stack([k, 1.1 * k])
        quality = np.stack([quality, quality])
    return make_spectrum(w, k, 1e-7, 1e-10, dims=dims, quality=quality, source="csv",
                         stderr={"stiffness": 0.02 * np.abs(k), "phase": np.full(k.shape, 1.0)})


def _fit(**over):
    w = np.geomspace(10.0, 1e5, 200)
    k = _stiffness(w)
    kwargs = {"params": {"tau": (TAU, 4e-5), "E0": (E0, 2e8), "E_inf": (E_INF, 3e7)},
              "success": True, "redchi": 1.07, "aic": -10.0, "bic": -8.0, "modes": 1,
              "model": "exact", "omega": w, "fit_stiffness": np.abs(k),
              "fit_phase": np.degrees(np.angle(k))}
    return make_fit_result(**{**kwargs, **over})


def test_data_with_error_bars_flags_and_the_fit(rng):
    from matplotlib.container import ErrorbarContainer
    from matplotlib.text import Text

    data, fit = _spectrum(rng), _fit()
    handle = bode_plot(data, fit=fit, frequency_unit="Hz", title="probe 1")
    mag, phase = handle.axes
    assert mag.get_xscale() == phase.get_xscale() == "log"
    assert mag.get_yscale() == "log"
    assert "[N/m]" in mag.get_ylabel() and "[deg]" in phase.get_ylabel()
    assert "Hz" in phase.get_xlabel()
    for panel in (mag, phase):
        assert sum(isinstance(c, ErrorbarContainer) for c in panel.containers) == 1
    # order: data (magnitude, phase), flagged rings, fit lines, parameter box
    bars, _, ring, ring_phase, fit_mag, fit_phase, box = handle.lines
    assert isinstance(bars, ErrorbarContainer)
    assert ring.get_label() == "flagged: phase outside passive range"
    assert ring.get_markerfacecolor() == "none" and ring.get_linestyle() == "None"
    np.testing.assert_allclose(ring.get_xdata(), data.omega.values[-1:] / (2 * np.pi))
    np.testing.assert_allclose(ring_phase.get_ydata(), data.phase.values[-1:])
    np.testing.assert_allclose(fit_mag.get_xdata(), fit.omega.values / (2 * np.pi))
    np.testing.assert_allclose(fit_mag.get_ydata(), fit.fit_stiffness.values)
    np.testing.assert_allclose(fit_phase.get_ydata(), fit.fit_phase.values)
    labels = [t.get_text() for t in mag.get_legend().get_texts()]
    assert labels == ["data", "flagged: phase outside passive range", "fit (exact)"]
    assert isinstance(box, Text)
    text = box.get_text()
    assert "tau = 1.000 ± 0.040 ms" in text
    assert "E0 = 10.00 ± 0.20 GPa" in text and "E_inf = 1.000 ± 0.030 GPa" in text
    assert "redchi = 1.07" in text and "fit: exact" in text
    assert handle.figure.get_suptitle() == "probe 1"


def test_parameter_box_units_suit_each_value(rng):
    fit = _fit(params={"tau": (2.5e-6, None), "E0": (3.2e6, 1.1e5), "E_inf": (4e3, 200.0),
                       "k_inf": (2.1e-3, 1e-4), "F_inf": (3e-9, 1e-10), "m": (0.3, 0.01),
                       "C1": (1.5e-8, 2e-9), "E_2": (7.0, 0.0)},
               success=False)
    text = bode_plot(_spectrum(rng), fit=fit).lines[-1].get_text()
    for line in ("tau = 2.5 µs (no stderr)", "E0 = 3.20 ± 0.11 MPa", "E_inf = 4.00 ± 0.20 kPa",
                 "k_inf = 2.10 ± 0.10 mN/m", "F_inf = 3.00 ± 0.10 nN", "m = 0.300 ± 0.010",
                 "C1 = (1.50 ± 0.20)e-8 Pa-1 s-m", "E_2 = 7 ± 0 Pa", "(did not converge)"):
        assert line in text, (line, text)


def test_select_picks_one_curve_of_a_map(rng):
    data = _spectrum(rng, dims=("curve", "omega"))
    handle = bode_plot(data, fit=_fit(), select={"curve": 1})
    np.testing.assert_allclose(handle.lines[0].lines[0].get_ydata(), data.stiffness.values[1])
    with pytest.raises(ParameterError, match=r"spectrum 'spectrum' also spans \['curve'\]: select "
                                             r"one, e.g. ds.isel\(curve=0\) or "
                                             r"select=\{'curve': 0\}"):
        bode_plot(data, fit=_fit())
    with pytest.raises(ParameterError, match=r"select\['curve'\] = 2 is out of range: spectrum "
                                             r"'spectrum' has 2 entries along 'curve'"):
        bode_plot(data, fit=_fit(), select={"curve": 2})
    with pytest.raises(ParameterError, match=r"select names dims \['pixel'\] that neither the "
                                             r"spectra nor the fit have \(they have \['curve'\]\)"):
        bode_plot(data, select={"pixel": 0})


def test_select_also_picks_from_a_fit_over_a_map(rng):
    fits = xr.concat([_fit(), _fit(redchi=2.5)], dim="curve")
    data = _spectrum(rng, dims=("curve", "omega"))
    assert "redchi = 2.5" in bode_plot(data, fit=fits, select={"curve": -1}).lines[-1].get_text()
    with pytest.raises(ParameterError, match=r"the fit result also spans \['curve'\]"):
        bode_plot(data.isel(curve=0), fit=fits)


def test_existing_calls_are_unchanged(rng):
    data = _spectrum(rng)
    plain = data.drop_vars(["quality", "stiffness_stderr", "phase_stderr"])
    handle = bode_plot(plain)
    assert len(handle.lines) == 2 and handle.axes[0].get_legend_handles_labels()[1] == [
        "spectrum"]
    assert len(bode_plot(data).lines) == 4  # error bars (2) and flagged rings (2), no fit


@pytest.mark.parametrize(("kwargs", "error", "match"), [
    ({"fit": 3.0}, ParameterError, r"fit must be a fit-result Dataset .* or None, got float 3.0"),
    ({"fit": "fit.nc"}, ParameterError, r"fit must be a fit-result Dataset .* got str"),
    ({"select": "curve"}, ParameterError, r"select must be a mapping dim -> index .* got str"),
    ({"select": {"curve": 0.5}}, ParameterError, r"select\['curve'\] must be an integer index"),
    ({"select": {"curve": True}}, ParameterError, r"select\['curve'\] must be an integer index"),
    ({"select": {0: 0}}, ParameterError, r"select keys must be dim names"),
    ({"select": {"omega": 0}}, ParameterError, r"select must not pick along 'omega'"),
])
def test_bad_options_raise(rng, kwargs, error, match):
    with pytest.raises(error, match=match):
        bode_plot(_spectrum(rng), **kwargs)


def test_bad_fit_results_raise(rng):
    data = _spectrum(rng)
    no_curve = _fit(omega=None, fit_stiffness=None, fit_phase=None)
    with pytest.raises(ParameterError, match=r"fit has no best-fit spectrum: it lacks "
                                             r"\['fit_stiffness', 'fit_phase'\] over 'omega'"):
        bode_plot(data, fit=no_curve)
    with pytest.raises(ParameterError, match=r"fit has no best-fit spectrum: it lacks "
                                             r"\['fit_phase'\]"):
        bode_plot(data, fit=_fit().drop_vars("fit_phase"))
    with pytest.raises(SchemaError, match=r"bode_plot: fit: fit result has no attrs\['model'\]"):
        bode_plot(data, fit=_fit().drop_attrs())
    with pytest.raises(SchemaError, match=r"bode_plot: fit: .*'fit_stiffness' must have units "
                                          r"'N/m'"):
        bode_plot(data, fit=_fit().assign(
            fit_stiffness=lambda d: d.fit_stiffness.assign_attrs(units="N")))
    with pytest.raises(SchemaError, match=r"bode_plot: fit: fit result must be an "
                                          r"xarray.Dataset|bode_plot: spectrum"):
        bode_plot(_fit(), fit=_fit())
    with pytest.raises(ParameterError, match=r"use magnitude='stiffness' with fit="):
        bode_plot(data.assign(amplitude=data.stiffness * 0 + 1.0).assign(
            amplitude=lambda d: d.amplitude.assign_attrs(units="1")), fit=_fit(),
            magnitude="amplitude")


def test_example_figure_is_saved(rng, tmp_path):
    handle = bode_plot(_spectrum(rng), fit=_fit(), frequency_unit="Hz",
                       title="synthetic SLS spectrum, exact fit")
    out = tmp_path / "bode.png"
    handle.figure.savefig(out, dpi=80)
    assert out.stat().st_size > 10_000


def test_unidentified_values_read_as_bounds_or_not_determined_never_as_huge_errors(rng):
    """E0 bounded below only, tau not determined: no ``value ± error`` line for either."""
    fit = _fit(params={"tau": (TAU, 5e-2), "E0": (8e5, 8.6e15), "E_inf": (E_INF, 3e7)})
    fit = fit.assign(identifiability=("param_i", np.array([3, 1, 0], dtype=np.int8),
                                      {"flag_values": np.arange(4, dtype=np.int8),
                                       "flag_meanings": "determined lower_bound_only "
                                                        "upper_bound_only not_determined"}),
                     E0_lower=2.1e9, E0_upper=np.nan)
    text = bode_plot(_spectrum(rng), fit=fit).lines[-1].get_text()
    assert "tau not determined" in text
    assert "E0 > 2.1 GPa (bound only)" in text
    assert "E0 =" not in text and "tau =" not in text and "86240" not in text
    assert "E_inf = 1.000 ± 0.030 GPa" in text


def test_the_box_names_tip_poisson_and_indentation_and_sits_off_the_curve(rng):
    fit = _fit(attrs={"tip": "sphere, R = 5 um", "poisson": 0.5, "indentation": 5e-7})
    handle = bode_plot(_spectrum(rng), fit=fit)
    text = handle.lines[-1].get_text()
    assert "tip: sphere, R = 5 um" in text and "nu = 0.5" in text
    assert "indentation 500 nm" in text
    assert handle.axes[1].get_legend()._loc == 0  # "best": matplotlib places it off the data


def test_measured_spectra_are_drawn_in_hz_simulated_in_rad_per_s(rng):
    measured = _spectrum(rng)  # source "csv"
    simulated = measured.assign_attrs(source="simulation")
    assert "[Hz]" in bode_plot(measured).axes[-1].get_xlabel()
    assert "[rad/s]" in bode_plot(simulated).axes[-1].get_xlabel()
    assert "[rad/s]" in bode_plot(measured, frequency_unit="rad/s").axes[-1].get_xlabel()


def test_a_dense_spectrum_is_drawn_as_few_paths(rng):
    """Above DENSE_POINTS the stderr bars are one NaN-broken line, the legends sit in a corner.

    matplotlib draws an ErrorbarContainer as one path per point and places a loc="best" legend
    by testing every point: a 1e6-point spectrum took 206 s (issue 40 item 7).
    """
    from matplotlib.container import ErrorbarContainer

    from viscoforce.plotting.bode import DENSE_POINTS

    n = 3 * DENSE_POINTS
    w = np.geomspace(10.0, 1e5, n)
    k = _stiffness(w) * (1 + 0.02 * rng.standard_normal(n))
    err = 0.02 * np.abs(k)
    ds = make_spectrum(w, k, 1e-7, 1e-10, source="csv",
                       stderr={"stiffness": err, "phase": np.full(n, 1.0)})
    handle = bode_plot(ds, fit=_fit(), residuals=True)
    magnitude = handle.axes[0]
    assert not magnitude.containers and not magnitude.collections
    assert not any(isinstance(a, ErrorbarContainer) for a in handle.lines)
    (bars,) = [line for line in magnitude.get_lines() if line.get_label() == "_stderr"]
    x, y = bars.get_xdata(), bars.get_ydata()
    assert x.size == 3 * n  # (x, lower), (x, upper), a NaN break per point
    np.testing.assert_array_equal(y[0::3], np.abs(k) - err)
    np.testing.assert_array_equal(y[1::3], np.abs(k) + err)
    assert np.isnan(y[2::3]).all()
    for ax in handle.axes:
        legend = ax.get_legend()
        assert legend is None or legend._loc != 0  # 0 is "best"
