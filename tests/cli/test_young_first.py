"""Young's modulus leads everywhere a person reads (issue 38 item 3), the paper's E beside it.

The paper's E is 2/E = Σ(1 − ν²)/E_i, twice Johnson's E*: at ν = ½ it is 8/3 of Young's
modulus, so a summary, figure or table leading with it overstates the stiffness 2.67-fold.
Checked on Hertz fits of synthetic approaches (Hertz's paraboloid, R = 5 µm, paper E 3-3.75
kPa, 30 pN noise): the map summary's first modulus line, the fit figure's text, the map plot's
default colour field and label, the fit table's column order and the viewer's data (the
browser half is tests/plotting/test_viewer_browser.py). The JSON keys stay as they were.
"""

from __future__ import annotations

import re

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402

from viscoforce.cli import main  # noqa: E402
from viscoforce.schema import make_curves  # noqa: E402

#: The paper's modulus of pixel 0 [Pa] (pixel i: E_PAPER·(1 + 0.25 i)); Young's = 3/8 of it.
E_PAPER = 3.0e3
TIP = "paraboloid:5um"
#: Display-unit prefixes of the figure text.
_PREFIX = {"": 1.0, "k": 1e3, "M": 1e6, "G": 1e9}


def hertz_curves(n_pixels: int = 2, *, n: int = 400, seed: int = 3) -> xr.Dataset:
    """Approaches z [m] → F [N]: F = b + E·(2/3)√R·(z − c)^1.5 past c = 1.8 µm (Hertz 1882)."""
    rng = np.random.default_rng(seed)
    z = np.linspace(-1.0e-6, 2.6e-6, n)
    forces = [-5e-9 + E_PAPER * (1 + 0.25 * i) * 2 / 3 * np.sqrt(5e-6)
              * np.maximum(z - 1.8e-6, 0.0) ** 1.5 + rng.normal(0.0, 30e-12, n)
              for i in range(n_pixels)]
    zz = np.tile(z, n_pixels)
    return make_curves(np.tile(np.linspace(0, 1, n), n_pixels), np.concatenate(forces), -zz,
                       np.zeros_like(zz), tip_position=zz, segment=0,
                       segment_names=("approach",), sample_count=[n] * n_pixels,
                       source="synthetic")


@pytest.fixture(scope="module")
def hertz_map(tmp_path_factory):
    """(curves file, fits file, printed summary) of ``fit CURVES --model hertz --out fits.nc``."""
    import contextlib
    import io

    folder = tmp_path_factory.mktemp("young")
    curves, fits = folder / "curves.nc", folder / "fits.nc"
    hertz_curves().to_netcdf(curves)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["fit", str(curves), "--model", "hertz", "--tip", TIP, "--scheduler",
                     "synchronous", "--no-progress", "--out", str(fits)]) == 0
    return curves, fits, out.getvalue()


def test_the_map_summary_leads_with_youngs_modulus(hertz_map):
    _, fits, printed = hertz_map
    result = xr.open_dataset(fits)
    lines = printed.splitlines()
    quartile_lines = [s.split()[0] for s in lines if " median " in s]
    assert quartile_lines[0] == "E_young", printed
    assert quartile_lines.index("E") > 0 and quartile_lines.index("E_shear") > 0
    heading = next(i for i, s in enumerate(lines) if "Young's modulus" in s)
    assert "Poisson's ratio 0.5" in lines[heading]
    assert lines[heading + 1].split()[0] == "E_young"
    assert "paper's convention" in printed
    median = float(np.median(result["E_young"].values))  # 1.3 kPa: shown to 3 digits
    shown = re.search(r"E_young +median ([\d.]+) kPa", printed)
    assert shown is not None and float(shown.group(1)) * 1e3 == pytest.approx(median, rel=5e-3)
    # Young's is 3/8 of the paper's E at nu = 1/2 (the issue: 663 Pa against 1.77 kPa)
    np.testing.assert_allclose(result["E_young"].values, 3 / 8 * result["E"].values, rtol=1e-12)


def test_the_map_json_keeps_its_keys(hertz_map, capsys):
    import json

    curves, _, _ = hertz_map
    assert main(["fit", str(curves), "--model", "hertz", "--tip", TIP, "--scheduler",
                 "synchronous", "--no-progress", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert {"model", "n_fits", "n_good", "left_out", "by_modes", "modes", "params", "derived",
            "poisson"} <= set(info)
    assert list(info["params"]) == ["E", "contact_point", "baseline", "baseline_slope"]
    assert {"E_young", "E_shear"} <= set(info["derived"])


def _figure_lines(fit, data) -> list[str]:
    from matplotlib.text import Text

    from viscoforce.plotting import fit_curve_plot

    handle = fit_curve_plot(fit, data=data)
    texts = [t.get_text() for t in handle.figure.findobj(Text) if "fit: hertz" in t.get_text()]
    assert len(texts) == 1
    return texts[0].splitlines()


def _value(line: str) -> tuple[float, float]:
    """``"E_young = 1.1191 ± 0.0056 kPa"`` → (1119.1, 0.05): value and half its last digit [Pa]."""
    match = re.fullmatch(r"\S+ = (-?\d+\.?(\d*)) ± [\d.]+ (k|M|G|)Pa", line)
    assert match, line
    scale = _PREFIX[match.group(3)]
    return float(match.group(1)) * scale, 0.5 * 10.0 ** -len(match.group(2)) * scale


def test_the_fit_figure_names_youngs_modulus_first():
    from viscoforce.fitting.curves import curve_data, fit_curve

    curves = hertz_curves(1)
    fit = fit_curve(curves, "hertz", tip=TIP)
    data = curve_data(curves, "hertz")
    lines = _figure_lines(fit, (data.x, data.y))
    moduli = [i for i, s in enumerate(lines) if re.match(r"E(_young|_shear)? [=<>]", s)]
    first = lines[moduli[0]]
    assert first.startswith("E_young = ") and "Young's modulus" in lines[moduli[0] - 1]
    young, half = _value(first)           # "1.1296 ± 0.0058 kPa": rounded to the stderr's digit
    assert abs(young - float(fit["E_young"])) <= half * (1 + 1e-9)
    paper = next(s for s in lines if s.startswith("E = "))
    assert lines.index(paper) > moduli[0]
    assert "paper's E" in lines[lines.index(paper) - 1]
    value, half = _value(paper)
    assert abs(value - float(fit["E"])) <= half * (1 + 1e-9)
    assert value / young == pytest.approx(8 / 3, rel=2e-3)


def test_a_bound_reads_in_youngs_form_too():
    """E bounded below only: Young's bound is the paper's bound × (1 − ν²)/2, no ± value."""
    from viscoforce.fitting.curves import fit_curve
    from viscoforce.plotting._parameter_text import _parameter_text

    fit = fit_curve(hertz_curves(1), "hertz", tip=TIP)
    codes = np.zeros(fit.sizes["param_i"], dtype=np.int8)
    codes[0] = 1  # E: lower bound only
    fit = fit.assign(identifiability=("param_i", codes), E_lower=4.0e3)
    lines = _parameter_text(fit).splitlines()
    assert "E_young > 1.5 kPa (bound only)" in lines   # 4 kPa × 3/8
    assert "E > 4 kPa (bound only)" in lines
    assert lines.index("E_young > 1.5 kPa (bound only)") < lines.index("E > 4 kPa (bound only)")
    assert not any(s.startswith(("E = ", "E_young = ")) for s in lines)


def test_the_map_plot_shows_youngs_modulus_by_default(hertz_map):
    from viscoforce.plotting import map_plot

    _, fits, _ = hertz_map
    result = xr.open_dataset(fits)
    handle = map_plot(result)
    label = handle.axes[1].get_ylabel()
    assert label == "Young's modulus E_young [kPa]"
    shown = np.ma.getdata(handle.lines[0].get_array()).reshape(-1)
    np.testing.assert_allclose(shown, result["E_young"].values / 1e3, rtol=1e-12)
    assert handle.axes[0].get_title().startswith("E_young (hertz)")
    paper = map_plot(result, "E")  # --plot-variable still chooses
    assert paper.axes[1].get_ylabel().startswith("E (paper's convention")
    np.testing.assert_allclose(np.ma.getdata(paper.lines[0].get_array()).reshape(-1),
                               result["E"].values / 1e3, rtol=1e-12)


def test_the_fit_table_puts_youngs_modulus_before_the_papers(hertz_map):
    from viscoforce.io.fit_tables import fit_table_columns

    _, fits, _ = hertz_map
    result = xr.open_dataset(fits)
    columns = fit_table_columns(result)
    assert columns[:6] == ["E_young", "E_young_stderr", "E", "E_stderr", "E_shear",
                           "E_shear_stderr"]
    assert columns.index("E_young_budget_lower") < columns.index("E_budget_lower")
    # every column of before issue 38 is kept, none twice
    names = [str(n) for n in result["param_i"].values]
    before = [n for name in names for n in (name, f"{name}_stderr")]
    before += [str(n) for n in result.data_vars if str(n).endswith(
        ("_young", "_shear", "_young_stderr", "_shear_stderr", "_budget_lower",
         "_budget_upper", "_budget_determined"))]
    before += [n for n in ("redchi", "chi2_pvalue", "quality", "success", "modes")
               if n in result.variables]
    assert sorted(columns) == sorted(before) and len(set(columns)) == len(columns)


def test_the_viewer_lists_youngs_modulus_first_and_draws_each_force_curve(hertz_map):
    pytest.importorskip("bokeh", reason="the viewer needs bokeh")
    from viscoforce.fitting.curves import curve_data
    from viscoforce.fitting.models import make_model
    from viscoforce.plotting.viewer import map_view

    curves_path, fits, _ = hertz_map
    result, curves = xr.open_dataset(fits), xr.open_dataset(curves_path)
    view = map_view(result, curves)
    assert view.variables[:3] == ("E_young", "E", "E_shear")
    assert view.what["E_young"] == "Young's modulus" and "paper's" in view.what["E"]
    assert view.labels["E_young"] == "Young's modulus E_young [kPa]"
    row = view.table[1]
    keys = [k for k in row if k.startswith("E")]
    assert keys[:4] == ["E_young", "E_young_stderr", "E", "E_stderr"]
    assert row["E_young"] == float(result["E_young"].values[1])
    np.testing.assert_allclose(view.colour["E_young"], result["E_young"].values / 1e3)
    offsets = view.curves["offsets"]
    a, b = offsets[1], offsets[2]
    data = curve_data(curves, "hertz", curve=1)
    order = np.argsort(data.x)
    cp = float(result["contact_point"].values[1])
    np.testing.assert_allclose(view.curves["position"][a:b], (data.x[order] - cp) * 1e6)
    np.testing.assert_allclose(view.curves["force"][a:b], data.y[order] * 1e9)
    values = {str(p): float(result[str(p)].values[1]) for p in result["param_i"].values}
    model = make_model("hertz", tip=TIP).raw(data.x[order], values)
    np.testing.assert_allclose(view.curves["fit_force"][a:b], model * 1e9, rtol=1e-12)
    residual = view.curves["force"][a:b] - view.curves["fit_force"][a:b]  # nN; noise 0.03 nN
    assert np.sqrt(np.mean(residual ** 2)) < 0.045


def test_fit_out_csv_leads_with_youngs_modulus(hertz_map, tmp_path):
    curves, _, _ = hertz_map
    out = tmp_path / "fits.csv"
    assert main(["fit", str(curves), "--model", "hertz", "--tip", TIP, "--scheduler",
                 "synchronous", "--no-progress", "--out", str(out)]) == 0
    header = out.read_text().splitlines()[0].split(",")
    assert header.index("E_young (Pa)") < header.index("E (Pa)") < header.index("E_shear (Pa)")
