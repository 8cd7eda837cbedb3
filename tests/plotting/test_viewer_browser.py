"""The map viewer in a real browser: headless Chromium driven by Playwright.

The page is written by ``viscoforce view`` from netCDF files and opened from a ``file://`` URL
(no server, no network), under its Content-Security-Policy. Checked: no console errors (a
blocked script or style would be one); every pixel is in the map's data source at its place; a
mouse click at a pixel's position on the screen puts that pixel's spectrum (as stored in the
netCDF) into the Bode plot's data source and its parameters into the table, whose drawn cells
show them (issue 38: they kept the first pixel's); the parameter selector switches the map's
colour field; the CSV export downloads the data island's table; the save tool downloads a PNG.
The helpers (:func:`launch`, :func:`data_source`, :func:`drawn_table`, …) serve
tests/plotting/test_viewer_security.py too.

Needs the ``playwright`` Python package and Chromium at /usr/bin/chromium (Debian's
``chromium``; ``.ci/run`` installs it); skipped, saying which is missing, without them.
Playwright's own browser download is not used. Every wait is for a condition of the page, never
for a time; Playwright's timeout is only a generous backstop (:data:`BACKSTOP_MS`) that turns a
page which never reaches the condition into a failure instead of a hung run.
"""

from __future__ import annotations

import csv
import json
import os
import re
import shutil

import numpy as np
import pytest
import xarray as xr

pytest.importorskip("bokeh", reason="the viewer needs bokeh (pip install bokeh)")
playwright_api = pytest.importorskip(
    "playwright.sync_api", reason="the browser tests need the playwright package "
                                  "(pip install playwright; its browser download is not needed)")

from tests.plotting.test_viewer import fit_synthetic_map, island  # noqa: E402
from viscoforce.cli import main  # noqa: E402
from viscoforce.plotting.viewer import map_view  # noqa: E402

CHROMIUM = os.environ.get("VISCOFORCE_CHROMIUM") or shutil.which("chromium") or (
    "/usr/bin/chromium" if os.path.exists("/usr/bin/chromium") else None)
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="no Chromium at /usr/bin/chromium or on PATH (Debian: apt-get "
                             "install -y chromium; .ci/run installs it)")

#: Chromium flags for a closed network and no screen (a fresh profile is the context's folder).
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]

#: Playwright's timeout [ms]: a backstop against a hang, far above what any step needs.
BACKSTOP_MS = 300_000
#: JavaScript: the Bokeh model of the page named ``name``.
MODEL = """(name) => [...Bokeh.documents[0]._all_models.values()].find((m) => {
  try { return m.name === name; } catch (e) { return false; } })"""


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """The page of the fitted 2 × 3 map, written by the CLI from netCDF files, and those files."""
    fits, spectra = fit_synthetic_map()
    assert "fit_stiffness" in fits  # fit_map stores each pixel's best-fit spectrum
    folder = tmp_path_factory.mktemp("browser")
    fits.to_netcdf(folder / "fits.nc")
    spectra.to_netcdf(folder / "spectra.nc")
    out = folder / "report.html"
    assert main(["view", str(folder / "fits.nc"), "--data", str(folder / "spectra.nc"),
                 "--out", str(out)]) == 0
    return out, xr.open_dataset(folder / "fits.nc"), xr.open_dataset(folder / "spectra.nc")


def launch(playwright, profile):
    """A headless Chromium context (fresh profile ``profile``) with the backstop timeout."""
    context = playwright.chromium.launch_persistent_context(
        str(profile), executable_path=CHROMIUM, args=CHROMIUM_ARGS, headless=True,
        viewport={"width": 1320, "height": 1100}, accept_downloads=True, timeout=BACKSTOP_MS)
    context.set_default_timeout(BACKSTOP_MS)
    return context


def wait_until_drawn(page) -> None:
    """Wait until Bokeh has embedded the page's document and is idle."""
    page.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0 && "
                           "Bokeh.documents[0].is_idle")


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    """One headless Chromium context for the module's pages (Playwright runs one at a time)."""
    with playwright_api.sync_playwright() as p:
        context = launch(p, tmp_path_factory.mktemp("chromium-profile"))
        yield context
        context.close()


def open_page(context, url: str):
    """(page, console errors seen while it loads and after) of ``url``, drawn."""
    page = context.new_page()
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url)
    wait_until_drawn(page)
    return page, errors


@pytest.fixture(scope="module")
def browser_page(report, browser):
    """The page loaded in headless Chromium, and the console errors seen while it loaded."""
    out, _, _ = report
    page, errors = open_page(browser, out.as_uri())
    yield page, errors
    page.close()


def data_source(page, name: str) -> dict:
    """The columns of the data source ``name`` (typed arrays as lists; NaN as None)."""
    return page.evaluate(f"""() => {{ const m = ({MODEL})({json.dumps(name)});
        const out = {{}};
        for (const [k, v] of Object.entries(m.data)) {{
          out[k] = Array.from(v, (x) => (typeof x === 'number' && Number.isNaN(x)) ? null : x);
        }}
        return out; }}""")


#: The table's number format ("0.0000 a"): four decimals and a thousands suffix.
_SUFFIX = {"": 1.0, "k": 1e3, "m": 1e6, "b": 1e9, "t": 1e12}


def _shown(text: str) -> tuple[float, str] | None:
    """A drawn number cell as (mantissa, suffix); None for the NaN mark."""
    if text.strip() == "–":
        return None
    match = re.fullmatch(r"(-?\d+\.\d{4}) ?([kmbt]?)", text.strip())
    assert match, text
    return float(match.group(1)), match.group(2)


def _rounded(value: float | None) -> tuple[float, str] | None:
    """``value`` as the table shows it: (mantissa to four decimals, suffix)."""
    if value is None:
        return None
    suffix = next((s for s, f in reversed(_SUFFIX.items()) if abs(value) >= f), "")
    return round(value / _SUFFIX[suffix], 4), suffix


def _nan(values) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in values], dtype=float)


def test_page_loads_without_console_errors(browser_page):
    _, errors = browser_page
    assert errors == []


def test_every_pixel_is_in_the_map_at_its_place(browser_page, report):
    page, _ = browser_page
    _, fits, _ = report
    data = data_source(page, "map_data")
    n = fits.sizes["y"] * fits.sizes["x"]
    assert data["pixel"] == list(range(n))
    yy, xx = np.meshgrid(fits["y"].values, fits["x"].values, indexing="ij")
    np.testing.assert_allclose(data["x"], xx.reshape(-1) * 1e6)
    np.testing.assert_allclose(data["y"], yy.reshape(-1) * 1e6)
    assert len(island(page.content())["pixels"]) == n


def drawn_text(page, name: str) -> str:
    """The text the Div ``name`` shows (its drawn markup's text, not the model's)."""
    return page.evaluate(f"() => Bokeh.index.find_one(({MODEL})({json.dumps(name)}))"
                         ".markup_el.textContent")


def drawn_table(page) -> list[list[str]]:
    """The cells the parameter table shows, row by row (the drawn grid, not its data source)."""
    return page.evaluate(f"""() => {{
        const view = Bokeh.index.find_one(({MODEL})('pixel_table'));
        return [...view.shadow_el.querySelectorAll('.slick-row')]
          .sort((a, b) => a.getBoundingClientRect().top - b.getBoundingClientRect().top)
          .map((r) => [...r.querySelectorAll('.slick-cell')].map((c) => c.textContent)); }}""")


def screen_position(page, x: float, y: float) -> tuple[float, float]:
    """Page coordinates of the data point (x, y) of the map figure."""
    return tuple(page.evaluate(f"""() => {{
        const view = Bokeh.index.find_one(({MODEL})('map'));
        const box = view.el.getBoundingClientRect();
        return [box.left + view.frame.x_scale.compute({x}),
                box.top + view.frame.y_scale.compute({y})]; }}"""))


@pytest.mark.parametrize("pixel", [4, 1])
def test_a_click_on_a_pixel_draws_its_bode_plot_from_the_netcdf(browser_page, report, pixel):
    page, errors = browser_page
    _, fits, spectra = report
    data = data_source(page, "map_data")
    page.mouse.click(*screen_position(page, data["x"][pixel], data["y"][pixel]))
    page.wait_for_function(f"() => ({MODEL})('map_data').selected.indices[0] === {pixel}")
    bode = data_source(page, "bode_data")
    j, i = divmod(pixel, fits.sizes["x"])
    measured = spectra.isel(y=j, x=i)
    keep = measured["quality"].values == 0
    for key in ("stiffness", "phase"):
        expected = np.where(keep, measured[key].values, np.nan)
        np.testing.assert_allclose(_nan(bode[key]), expected, rtol=1e-6)  # float32 on the page
        upper = np.where(keep, measured[key].values + measured[f"{key}_stderr"].values, np.nan)
        np.testing.assert_allclose(_nan(bode[f"{key}_upper"]), upper, rtol=1e-6)
    np.testing.assert_allclose(bode["frequency"], spectra["frequency"].values, rtol=1e-6)
    fit = data_source(page, "fit_data")
    stored = fits.isel(y=j, x=i)
    np.testing.assert_allclose(fit["stiffness"], stored["fit_stiffness"].values, rtol=1e-6)
    np.testing.assert_allclose(fit["phase"], stored["fit_phase"].values, rtol=1e-5)
    table = data_source(page, "pixel_table_data")
    rows = dict(zip(table["name"], table["value"], strict=True))
    units = dict(zip(table["name"], table["unit"], strict=True))
    for name, (_, display, factor) in map_view(fits).units.items():  # kPa, ms, … on the page
        assert units[name] == display
        assert rows[name] * factor == pytest.approx(float(stored[name]), rel=1e-12)
    assert rows["redchi"] == pytest.approx(float(stored["redchi"]), rel=1e-12)
    assert f"pixel {pixel}" in page.evaluate(f"() => ({MODEL})('pixel_title').text")
    # what the table draws is that pixel's, not the first pixel's (issue 38)
    drawn = drawn_table(page)
    assert [cells[0] for cells in drawn] == table["name"]
    for cells, value, stderr, unit in zip(drawn, table["value"], table["stderr"], table["unit"],
                                          strict=True):
        assert _shown(cells[1]) == _rounded(value), cells
        assert _shown(cells[2]) == _rounded(stderr), cells
        assert cells[3] == unit
    assert drawn_text(page, "pixel_title").startswith(f"pixel {pixel} ")
    # Young's modulus first, the paper's E0 beside it, labelled so (issue 38 item 3)
    main_modulus = str(fits["param_i"].values[0])                       # E_inf
    assert [cells[0] for cells in drawn[:3]] == [f"{main_modulus}_young", main_modulus,
                                                 f"{main_modulus}_shear"]
    assert drawn[0][4] == "Young's modulus" and drawn[1][4].startswith(f"paper's {main_modulus}")
    assert _shown(drawn[0][1]) == _rounded(float(stored[f"{main_modulus}_young"]) / map_view(
        fits).units[f"{main_modulus}_young"][2])
    assert errors == []


@pytest.fixture(scope="module")
def hertz_page(tmp_path_factory, browser):
    """A Hertz map's page (``fit CURVES --model hertz``, then ``view --data CURVES``) in Chromium.

    Yields (page, console errors, fits, curves) with the fits and curves as read from netCDF.
    """
    from tests.cli.test_young_first import TIP, hertz_curves

    folder = tmp_path_factory.mktemp("hertz-view")
    curves, fits, out = folder / "curves.nc", folder / "fits.nc", folder / "hertz.html"
    hertz_curves(3).to_netcdf(curves)
    assert main(["fit", str(curves), "--model", "hertz", "--tip", TIP, "--scheduler",
                 "synchronous", "--no-progress", "--out", str(fits)]) == 0
    assert main(["view", str(fits), "--data", str(curves), "--out", str(out)]) == 0
    page, errors = open_page(browser, out.as_uri())
    yield page, errors, xr.open_dataset(fits), xr.open_dataset(curves)
    page.close()


def test_a_hertz_map_leads_with_youngs_modulus_and_draws_the_clicked_force_curve(hertz_page):
    """Issue 38 item 3: Young's modulus mapped by default and first in the drawn table (its
    value the netCDF's), the paper's E beside it; the clicked pixel's approach and fit drawn."""
    page, errors, fits, curves = hertz_page
    view = map_view(fits, curves)
    assert page.evaluate(f"() => ({MODEL})('parameter').value") == "E_young"
    assert page.evaluate(f"() => ({MODEL})('colour_bar').title.text") == (
        "Young's modulus E_young [kPa]")
    np.testing.assert_allclose(_nan(data_source(page, "map_data")["value"]),
                               fits["E_young"].values / 1e3, rtol=1e-12)
    pixel = 2
    data = data_source(page, "map_data")
    page.mouse.click(*screen_position(page, data["x"][pixel], data["y"][pixel]))
    page.wait_for_function(f"() => ({MODEL})('map_data').selected.indices[0] === {pixel}")
    page.wait_for_function("(n) => { const v = Bokeh.index.find_one((" + MODEL + ")("
                           "'pixel_table')); return v.shadow_el.querySelectorAll("
                           "'.slick-row').length >= n; }", arg=3)
    drawn = drawn_table(page)
    assert [cells[0] for cells in drawn[:3]] == ["E_young", "E", "E_shear"]
    assert drawn[0][4] == "Young's modulus" and drawn[1][4].startswith("paper's E")
    factor = view.units["E_young"][2]                                   # kPa
    assert drawn[0][3] == "kPa"
    assert _shown(drawn[0][1]) == _rounded(float(fits["E_young"].values[pixel]) / factor)
    assert _shown(drawn[1][1]) == _rounded(float(fits["E"].values[pixel]) / factor)
    shown = data_source(page, "curve_data")
    a, b = view.curves["offsets"][pixel], view.curves["offsets"][pixel + 1]
    for key in ("position", "force", "fit_force"):               # float32 on the page
        np.testing.assert_allclose(shown[key], view.curves[key][a:b], rtol=2e-6, atol=1e-6)
    assert errors == []


def test_two_quick_clicks_select_the_second_pixel(browser_page):
    """Bokeh takes a click within 300 ms of the last for a double tap: it must select as well."""
    page, errors = browser_page
    data = data_source(page, "map_data")
    first, second = (screen_position(page, data["x"][i], data["y"][i]) for i in (0, 5))
    page.mouse.click(*first)
    page.mouse.click(*second)  # at once: a double tap for Bokeh
    page.wait_for_function(f"() => ({MODEL})('map_data').selected.indices[0] === 5")
    assert "pixel 5" in page.evaluate(f"() => ({MODEL})('pixel_title').text")
    assert errors == []


def test_the_selector_switches_the_maps_colour_field(browser_page, report):
    page, errors = browser_page
    _, fits, _ = report
    page.locator("select").select_option("tau")
    page.wait_for_function(f"() => ({MODEL})('colour_bar').title.text.startsWith('tau')")
    units = map_view(fits).units
    value = _nan(data_source(page, "map_data")["value"])
    np.testing.assert_allclose(value, fits["tau"].values.reshape(-1) / units["tau"][2],
                               rtol=1e-12)
    histogram = data_source(page, "histogram_data")
    assert np.nansum(_nan(histogram["count"])) == np.isfinite(value).sum()
    page.locator("select").select_option("E0")
    page.wait_for_function(f"() => ({MODEL})('colour_bar').title.text.startsWith('E0')")
    value = _nan(data_source(page, "map_data")["value"])
    np.testing.assert_allclose(value, fits["E0"].values.reshape(-1) / units["E0"][2],
                               rtol=1e-12)
    assert errors == []


def test_csv_export_downloads_the_pixel_table(browser_page, report):
    page, errors = browser_page
    _, fits, _ = report
    with page.expect_download() as download:
        page.get_by_text("export table as CSV").click()
    with open(download.value.path(), newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert len(rows) == fits.sizes["y"] * fits.sizes["x"]
    for row in rows:
        j, i = divmod(int(row["index"]), fits.sizes["x"])
        assert float(row["E0"]) == float(fits["E0"].values[j, i])
        assert float(row["E0_stderr"]) == float(fits["E0_stderr"].values[j, i])
        assert row["quality_name"] in ("good", "bad_fit", "not_determined", "at_bound",
                                       "optimiser_failed")
    assert errors == []


def test_the_save_tool_downloads_the_map_as_png(browser_page):
    page, errors = browser_page
    page.once("dialog", lambda dialog: dialog.accept("map"))  # Bokeh asks for a file name
    with page.expect_download() as download:
        page.locator(".bk-tool-icon-save").first.click()
    assert download.value.suggested_filename == "map.png"
    with open(download.value.path(), "rb") as handle:
        assert handle.read(8) == b"\x89PNG\r\n\x1a\n"
    assert errors == []
