"""The viewer page: a :class:`~viscoforce.plotting.viewer._data.MapView` laid out with Bokeh.

Bokeh is imported here only, inside :func:`report_html`. The page is one HTML file with
Bokeh's JavaScript inline (:data:`bokeh.resources.INLINE`), so it opens from a ``file://`` URL
with no network. Its parts and the Bokeh models the tests find by ``name``:

- ``parameter``: the selector of the mapped variable (Young's modulus of the main modulus
  first and by default, then the paper's modulus and the shear modulus of each fitted
  parameter: :attr:`MapView.variables`, issue 38 item 3);
- ``map`` / ``map_data``: the map, one rectangle per pixel, coloured by the data source's
  ``value`` column (NaN, drawn grey, where the pixel is masked for that parameter); a click
  selects a pixel;
- ``histogram`` / ``histogram_data``: the parameter over its unmasked pixels;
- ``bode_magnitude``, ``bode_phase``, ``bode_residuals``, with ``bode_data`` (the clicked
  pixel's data: ``frequency``, ``stiffness``, ``phase``, error-bar ends, residuals) and
  ``fit_data`` (its best-fit curve);
- ``force_curve`` with ``curve_data`` (a map of ``hertz`` fits, in place of the Bode plots:
  the clicked pixel's approach, ``position`` from its contact point [µm] and ``force`` [nN],
  and its best fit ``fit_force``), the pixels' curves in ``curve_store``;
- ``pixel_table`` / ``pixel_table_data``: the clicked pixel's variables (Young's modulus
  first, the paper's modulus beside it labelled as the paper's convention in the ``what``
  column) with stderr, ``redchi``, ``chi2_pvalue`` and ``quality``;
- ``export_csv``: a button that downloads the per-pixel table as CSV.

The per-pixel table is also a JSON data island, ``<script type="application/json"
id="viscoforce-data">`` holding ``{"pixels": [...]}`` (:func:`.pixel_table`); the page's
callbacks read it (parameter table, CSV export). The per-pixel spectra travel as float32
arrays in Bokeh's binary encoding.

Nothing from the netCDF runs (issue 40): its strings (quality meanings, dim names, parameter
names and units, the ``model`` attribute) reach the page by one path per kind of place, each
one function here:

- as HTML (the ``Div`` texts, and the pixel title the click callback builds): escaped by
  :func:`_html_text`, in Python; the callback only joins pieces escaped there with numbers;
- as Bokeh text (figure titles, axis labels, the colour bar's title): :func:`_plain`, a
  ``PlainText`` model, drawn as it is (a plain string would be parsed for TeX delimiters);
  the table's cells, the selector's options and the hover tooltips are text nodes (Bokeh's
  ``StringFormatter``, ``<option>``, its escaped tooltips) and take the strings as they are;
- in the data island: :func:`_script_json`, JSON with ``<``, ``>``, ``&``, U+2028 and U+2029
  written as JSON's unicode escapes, so that nothing in it can end the script element or open
  markup (Bokeh's own document JSON is HTML-escaped by Bokeh);
- the ``<title>``: Bokeh's template escapes it.

The page also carries a Content-Security-Policy (:func:`content_security_policy`, a ``<meta>``
element ahead of every script): its inline scripts run by their SHA-256 hashes, nothing else
does, inline event handlers included, and nothing is loaded from anywhere.
"""

from __future__ import annotations

import base64
import hashlib
import html
import json
import re
from typing import Any

import numpy as np

from viscoforce.plotting.viewer._data import MapView

__all__ = ["DATA_ISLAND_ID", "content_security_policy", "report_html"]

#: ``id`` of the page's JSON data island.
DATA_ISLAND_ID = "viscoforce-data"
_SPECTRUM_KEYS = ("stiffness", "stiffness_lower", "stiffness_upper", "phase", "phase_lower",
                  "phase_upper", "residual_re", "residual_im")

_READ_ISLAND = f"""
const island = JSON.parse(document.getElementById('{DATA_ISLAND_ID}').textContent);
"""

_ON_SELECT = _READ_ISLAND + """
const i = map_data.selected.indices.length ? map_data.selected.indices[0] : -1;
if (i < 0) { return; }
const n = frequency.length;
const d = {frequency: frequency};
for (const k of keys) { d[k] = store.data[k] ? store.data[k].slice(i * n, (i + 1) * n) : []; }
bode_data.data = d;
const m = fit_frequency.length;
const part = (a) => a ? a.slice(i * m, (i + 1) * m) : [];
fit_data.data = {frequency: fit_frequency, stiffness: part(fit_store.data.stiffness),
                 phase: part(fit_store.data.phase)};
const p = island.pixels[i];
const rows = {name: [], value: [], stderr: [], unit: [], what: []};
for (const [name, factor, unit, what] of params) {
  rows.name.push(name);
  rows.value.push(p[name] === null || p[name] === undefined ? NaN : p[name] / factor);
  const e = p[name + '_stderr'];
  rows.stderr.push(e === null || e === undefined ? NaN : e / factor);
  rows.unit.push(unit);
  rows.what.push(what);
}
for (const name of ['redchi', 'chi2_pvalue']) {
  rows.name.push(name);
  rows.value.push(p[name] === null || p[name] === undefined ? NaN : p[name]);
  rows.stderr.push(NaN);
  rows.unit.push('');
  rows.what.push('');
}
rows.name.push('quality'); rows.value.push(p.quality); rows.stderr.push(NaN);
rows.unit.push(p.quality_name); rows.what.push('');
table_data.data = rows;
if (curve_offsets.length > 1) {  // a curve map (hertz): the pixel's approach and its fit
  const a = curve_offsets[i], b = curve_offsets[i + 1], c = curve_store.data;
  curve_data.data = {position: c.position.slice(a, b), force: c.force.slice(a, b),
                     fit_force: c.fit_force.slice(a, b)};
}
// Bokeh 3.9 redraws a DataTable when its view's rows change, not when the same rows get new
// values (issue 38; bokeh/bokeh#15328): ask for the redraw
table.view.change.emit();
// HTML from pieces escaped in Python (dims_html, quality_html) and numbers only
const number = (v) => typeof v === 'number' ? String(v) : '–';
const where = dims.map((d, k) => dims_html[k] + ' ' + number(p[d])).join(', ');
title.text = '<b>pixel ' + i + '</b> (' + where + '): quality ' +
  (quality_html[String(p.quality)] ?? number(p.quality));
"""

_ON_DOUBLE_TAP = """
const d = map_data.data;
for (let i = 0; i < d.x.length; i++) {
  if (Math.abs(cb_obj.x - d.x[i]) <= d.width[i] / 2 &&
      Math.abs(cb_obj.y - d.y[i]) <= d.height[i] / 2) {
    map_data.selected.indices = [i];
    break;
  }
}
"""

_ON_PARAMETER = """
const name = select.value;
map_data.data = Object.assign({}, map_data.data, {value: colour.data[name]});
const mapper = log[name] ? log_mapper : linear_mapper;
mapper.low = ranges[name][0];
mapper.high = ranges[name][1];
renderer.glyph.fill_color = {field: 'value', transform: mapper};
bar.color_mapper = mapper;
bar.title = labels[name];
histogram_data.data = {left: hist.data[name + '_left'], right: hist.data[name + '_right'],
                       count: hist.data[name + '_count']};
hist_axis.axis_label = labels[name];
"""

_EXPORT_CSV = _READ_ISLAND + """
const pixels = island.pixels;
const columns = Object.keys(pixels[0]);
const quote = (v) => (v === null || v === undefined) ? '' :
  (typeof v === 'string' && /[",\\n]/.test(v)) ? '"' + v.replace(/"/g, '""') + '"' : String(v);
const lines = [columns.join(',')];
for (const p of pixels) { lines.push(columns.map((c) => quote(p[c])).join(',')); }
const blob = new Blob([lines.join('\\n') + '\\n'], {type: 'text/csv'});
const a = document.createElement('a');
a.href = URL.createObjectURL(blob);
a.download = filename;
document.body.appendChild(a);
a.click();
a.remove();
"""


#: The page's Content-Security-Policy less its scripts' hashes (:func:`content_security_policy`).
_POLICY = (
    "default-src 'none'",
    # Bokeh compiles each CustomJS callback's code with `new Function`: 'unsafe-eval'. It runs
    # only code the page's own scripts hand it (the callbacks below), never a string of the
    # data; inline event handlers and injected scripts stay blocked (a hash allows neither)
    "script-src {hashes} 'unsafe-eval'",
    "style-src 'unsafe-inline'",  # Bokeh's <style> elements and style attributes
    "img-src data:",  # Bokeh's icons (data: URIs); the save tool and CSV export download blob:
    # URLs through a link, which img-src does not govern
    "object-src 'none'",
    "base-uri 'none'",
    "form-action 'none'",
    "connect-src 'none'",
)
#: An inline script element: (attributes, text) up to the first ``</script``, as HTML parses.
_SCRIPT = re.compile(r"<script(\s[^>]*)?>(.*?)</script", re.S | re.I)
#: What JSON inside a script element must not hold literally.
_SCRIPT_SAFE = str.maketrans({"<": "\\u003c", ">": "\\u003e", "&": "\\u0026",
                              "\u2028": "\\u2028", "\u2029": "\\u2029"})


def _html_text(text: object) -> str:
    """``text`` as HTML text: the one escaping of what the page shows as HTML."""
    return html.escape(str(text), quote=True)


def _plain(text: str) -> Any:
    """``text`` as Bokeh text drawn as it is (a ``PlainText``: no TeX, no markup)."""
    from bokeh.models import PlainText

    return PlainText(text=text)


def _script_json(value: Any) -> str:
    """``value`` as JSON that cannot end a script element or open markup in it."""
    return json.dumps(value, allow_nan=False, separators=(",", ":")).translate(_SCRIPT_SAFE)


def content_security_policy(page: str) -> str:
    """The Content-Security-Policy of a viewer page: its own inline scripts, nothing else.

    ``script-src`` lists the SHA-256 hash of each inline ``<script>`` element of ``page``
    (its JSON data blocks are not run and not listed), so no other script and no inline event
    handler runs; nothing is fetched, framed or embedded.

    Parameters
    ----------
    page : str
        The rendered page (:func:`report_html`); a ``<meta>`` policy in it does not change the
        result.

    Returns
    -------
    str
        The policy, directives separated by ``"; "``.
    """
    hashes = []
    for attrs, text in _SCRIPT.findall(page):
        if "application/json" in attrs:
            continue
        # the hash is over the element's text as parsed: line ends normalised to LF
        text = text.replace("\r\n", "\n").replace("\r", "\n")
        digest = base64.b64encode(hashlib.sha256(text.encode("utf-8")).digest()).decode()
        hashes.append(f"'sha256-{digest}'")
    return "; ".join(_POLICY).replace("{hashes}", " ".join(dict.fromkeys(hashes)))


def _label(view: MapView, name: str) -> str:
    """The axis and colour-bar label of a variable (``"Young's modulus E_young [kPa]"``)."""
    if name in view.labels:
        return view.labels[name]
    display = view.units[name][1]
    return f"{name} [{display}]" if display else name


def _variables(view: MapView) -> tuple[str, ...]:
    """What the page maps and tabulates (Young's first), or the fitted parameters."""
    return view.variables or view.params


def _range(values: np.ndarray, log: bool) -> tuple[float, float]:
    finite = values[np.isfinite(values)]
    if log:
        finite = finite[finite > 0]
    if not finite.size:
        return (1.0, 10.0) if log else (0.0, 1.0)
    lo, hi = float(finite.min()), float(finite.max())
    if hi <= lo:
        lo, hi = (lo / 1.1, hi * 1.1) if log else (lo - max(abs(lo), 1.0) * 0.05,
                                                    hi + max(abs(hi), 1.0) * 0.05)
    return lo, hi


def _padded(values: np.ndarray, n: int) -> np.ndarray:
    out = np.full(n, np.nan)
    out[:values.size] = values
    return out


def _island(view: MapView) -> str:
    """The JSON data island (:func:`_script_json`: nothing in it can end it or open markup)."""
    text = _script_json({"dims": list(view.dims), "params": list(view.params),
                         "variables": list(_variables(view)),
                         "pixels": view.table})
    return f'<script type="application/json" id="{DATA_ISLAND_ID}">{text}</script>'


def _first_pixel(view: MapView) -> int:
    good = np.flatnonzero(view.quality == 0)
    return int(good[0]) if good.size else 0


def _force_curve(view: MapView, i0: int) -> tuple[Any, Any, Any, list[int]]:
    """A curve map's force-curve figure and its data.

    Returns the figure, the store of every pixel's curve, the shown pixel's source (pixel
    ``i0``) and the pixels' offsets in the store (empty: not a curve map).
    """
    from bokeh.models import ColumnDataSource
    from bokeh.plotting import figure

    keys = ("position", "force", "fit_force")
    offsets = [int(k) for k in view.curves.get("offsets", ())]
    store = ColumnDataSource({k: np.asarray(view.curves.get(k, np.zeros(0)), dtype=np.float32)
                              for k in keys}, name="curve_store")
    a, b = (offsets[i0], offsets[i0 + 1]) if offsets else (0, 0)
    shown = ColumnDataSource({k: store.data[k][a:b] for k in keys}, name="curve_data")
    fig = figure(name="force_curve", width=520, height=320, tools="pan,wheel_zoom,reset,save",
                 x_axis_label=_plain("tip position toward the sample from the contact point "
                                     "[µm]"), y_axis_label=_plain("force [nN]"))
    fig.title.text = _plain("approach and Hertz fit")
    fig.scatter("position", "force", source=shown, size=3, color="#777777", legend_label="data")
    fig.line("position", "fit_force", source=shown, color="black", line_width=2,
             legend_label="fit")
    fig.legend.location = "top_left"
    return fig, store, shown, offsets


def report_html(view: MapView, *, csv_name: str = "viscoforce-map.csv") -> str:
    """The self-contained HTML page of a map (module docstring).

    Parameters
    ----------
    view : MapView
        What to show (:func:`viscoforce.plotting.viewer.map_view`).
    csv_name : str
        File name the CSV export suggests.

    Returns
    -------
    str
        The HTML text.
    """
    from bokeh.embed import file_html
    from bokeh.layouts import column, row
    from bokeh.models import (
        Button,
        ColorBar,
        ColumnDataSource,
        CustomJS,
        DataTable,
        Div,
        HoverTool,
        LinearColorMapper,
        LogColorMapper,
        NumberFormatter,
        Select,
        TableColumn,
        TapTool,
        Whisker,
    )
    from bokeh.plotting import figure
    from bokeh.resources import INLINE

    variables = _variables(view)
    first_name = variables[0]  # Young's modulus of the main modulus, where the fit has one
    ranges = {n: _range(view.colour[n], view.log[n]) for n in variables}
    labels = {n: _plain(_label(view, n)) for n in variables}
    colour = ColumnDataSource({n: view.colour[n] for n in variables}, name="colour_store")
    map_data = ColumnDataSource({
        "x": view.x, "y": view.y, "width": view.width, "height": view.height,
        "pixel": np.arange(view.n_pixels), "value": view.colour[first_name],
        "quality": [row["quality_name"] for row in view.table]}, name="map_data")
    linear_mapper = LinearColorMapper(palette="Viridis256", nan_color="lightgrey")
    log_mapper = LogColorMapper(palette="Viridis256", nan_color="lightgrey")
    mapper = log_mapper if view.log[first_name] else linear_mapper
    mapper.low, mapper.high = ranges[first_name]

    map_fig = figure(name="map", width=520, height=460, match_aspect=True,
                     tools="tap,pan,wheel_zoom,reset,save",
                     x_axis_label=_plain(view.axis_labels[0]),
                     y_axis_label=_plain(view.axis_labels[1]))
    map_fig.title.text = _plain(view.title)
    renderer = map_fig.rect("x", "y", "width", "height", source=map_data, name="pixels",
                            fill_color={"field": "value", "transform": mapper},
                            line_color="white", line_width=0.5,
                            selection_line_color="red", selection_line_width=2,
                            nonselection_fill_alpha=0.75)
    map_fig.select_one(TapTool).mode = "replace"
    # Bokeh takes a second click within 300 ms of the first for a double tap, wherever it
    # falls, and the tap tool ignores it: select the pixel under a double tap too, so that quick
    # clicks from pixel to pixel (a user's or a test's) always select
    map_fig.js_on_event("doubletap", CustomJS(args={"map_data": map_data}, code=_ON_DOUBLE_TAP))
    map_fig.add_tools(HoverTool(renderers=[renderer], tooltips=[
        ("pixel", "@pixel"), ("x, y", "@x{0.00}, @y{0.00}"), ("value", "@value{0.000 a}"),
        ("quality", "@quality")]))
    bar = ColorBar(color_mapper=mapper, title=labels[first_name], name="colour_bar")
    map_fig.add_layout(bar, "right")

    n_bins = max((h[0].size for h in view.histograms.values()), default=0)
    hist = ColumnDataSource({f"{n}_{k}": _padded(v, n_bins) for n in variables
                             for k, v in zip(("left", "right", "count"), view.histograms[n],
                                             strict=True)}, name="histogram_store")
    left, right, count = view.histograms[first_name]
    histogram_data = ColumnDataSource({"left": _padded(left, n_bins),
                                       "right": _padded(right, n_bins),
                                       "count": _padded(count, n_bins)}, name="histogram_data")
    histogram = figure(name="histogram", width=420, height=300,
                       tools="pan,wheel_zoom,reset,save", x_axis_label=labels[first_name],
                       y_axis_label=_plain("pixels"))
    histogram.title.text = _plain("over the good pixels")
    histogram.quad(left="left", right="right", bottom=0, top="count", source=histogram_data,
                   fill_color="steelblue", line_color="white")

    n_f = 0 if view.frequency is None else view.frequency.size
    frequency = (np.zeros(0) if view.frequency is None else view.frequency).astype(np.float32)
    store = ColumnDataSource({k: np.asarray(view.spectra[k], dtype=np.float32)
                              for k in _SPECTRUM_KEYS if k in view.spectra},
                             name="spectra_store")
    fit_frequency = (np.zeros(0) if view.fit_frequency is None
                     else view.fit_frequency).astype(np.float32)
    n_fit = fit_frequency.size
    fit_store = ColumnDataSource({k: np.asarray(v, dtype=np.float32)
                                  for k, v in view.fits.items()}, name="fit_store")
    i0 = _first_pixel(view)
    bode_data = ColumnDataSource({"frequency": frequency, **{
        k: np.asarray(view.spectra[k][i0 * n_f:(i0 + 1) * n_f], dtype=np.float32)
        if k in view.spectra else np.zeros(0) for k in _SPECTRUM_KEYS}}, name="bode_data")
    fit_data = ColumnDataSource({"frequency": fit_frequency, **{
        k: np.asarray(view.fits[k][i0 * n_fit:(i0 + 1) * n_fit], dtype=np.float32)
        if k in view.fits else np.zeros(0) for k in ("stiffness", "phase")}}, name="fit_data")

    common = {"width": 420, "height": 260, "x_axis_type": "log",
              "tools": "pan,wheel_zoom,reset,save", "x_axis_label": _plain(view.frequency_label)}
    magnitude = figure(name="bode_magnitude", y_axis_type="log",
                       y_axis_label=_plain("|k*| [N/m]"), **common)
    pixel_title = Div(text="", name="pixel_title")
    phase = figure(name="bode_phase", y_axis_label=_plain("phase [deg]"),
                   x_range=magnitude.x_range, **common)
    residuals = figure(name="bode_residuals", y_axis_label=_plain(view.residual_label),
                       x_range=magnitude.x_range, **common)
    for fig, key in ((magnitude, "stiffness"), (phase, "phase")):
        fig.line("frequency", key, source=fit_data, color="black", line_width=2,
                 legend_label="fit")
        fig.scatter("frequency", key, source=bode_data, size=7, color="#1f77b4",
                    legend_label="data")
        fig.add_layout(Whisker(source=bode_data, base="frequency", lower=f"{key}_lower",
                               upper=f"{key}_upper", line_color="#1f77b4"))
        fig.legend.location = "top_left"
    residuals.scatter("frequency", "residual_re", source=bode_data, size=7, color="#1f77b4",
                      legend_label="Re k*")
    residuals.scatter("frequency", "residual_im", source=bode_data, size=7, marker="square",
                      fill_color=None, line_color="#d62728", legend_label="Im k*")
    residuals.line("frequency", 0, source=fit_data, color="grey")
    residuals.legend.location = "top_left"

    force_figure, curve_store, curve_data, curve_offsets = _force_curve(view, i0)
    table_data = ColumnDataSource({"name": [], "value": [], "stderr": [], "unit": [],
                                   "what": []}, name="pixel_table_data")
    number = NumberFormatter(format="0.0000 a", nan_format="–")
    table = DataTable(source=table_data, name="pixel_table", width=640, height=300,
                      index_position=None, reorderable=False, columns=[
                          TableColumn(field="name", title="parameter", width=110),
                          TableColumn(field="value", title="value", formatter=number,
                                      width=80),
                          TableColumn(field="stderr", title="stderr", formatter=number,
                                      width=80),
                          TableColumn(field="unit", title="unit", width=70),
                          TableColumn(field="what", title="what it is", width=300)])

    select = Select(title="mapped parameter", value=first_name, options=list(variables),
                    name="parameter")
    select.js_on_change("value", CustomJS(args={
        "select": select, "map_data": map_data, "colour": colour, "renderer": renderer,
        "linear_mapper": linear_mapper, "log_mapper": log_mapper, "bar": bar,
        "ranges": {n: list(r) for n, r in ranges.items()}, "labels": labels,
        "log": dict(view.log), "hist": hist, "histogram_data": histogram_data,
        "hist_axis": histogram.xaxis[0]}, code=_ON_PARAMETER))
    on_select = CustomJS(args={
        "map_data": map_data, "store": store, "fit_store": fit_store, "bode_data": bode_data,
        "fit_data": fit_data, "frequency": frequency, "fit_frequency": fit_frequency,
        "curve_store": curve_store, "curve_data": curve_data, "curve_offsets": curve_offsets,
        "keys": list(_SPECTRUM_KEYS), "table_data": table_data, "table": table,
        "title": pixel_title,
        "params": [[n, view.units[n][2], view.units[n][1], view.what.get(n, "")]
                   for n in variables],
        "dims": list(view.dims), "dims_html": [_html_text(d) for d in view.dims],
        "quality_html": {str(row["quality"]): _html_text(row["quality_name"])
                         for row in view.table}}, code=_ON_SELECT)
    map_data.selected.js_on_change("indices", on_select)
    map_data.selected.indices = [i0]
    export = Button(label="export table as CSV", name="export_csv", button_type="primary")
    export.js_on_event("button_click", CustomJS(args={"filename": csv_name}, code=_EXPORT_CSV))
    notes = Div(text="<br>".join(_html_text(n) for n in view.notes), name="notes")
    shown = "force curve" if curve_offsets else "Bode plot"
    help_text = Div(text=_html_text(f"Click a pixel to see its {shown} and parameters (Young's "
                                    "modulus first; E, E0, ... in the paper's convention, "
                                    "2/E = Σ(1 − ν²)/E_i). Grey pixels: the fit failed, does "
                                    "not describe the data, or the parameter is not determined "
                                    "there."))
    plots = (row(force_figure, table) if curve_offsets else
             column(row(magnitude, phase, residuals), row(table)))
    layout = column(row(select, export, help_text), notes, row(map_fig, column(histogram)),
                    pixel_title, plots)
    # the first pixel's table and title are filled by the same callback when the page loads
    from bokeh.document import Document

    document = Document()
    document.add_root(layout)
    document.js_on_event("document_ready", on_select)
    document.title = view.title
    from markupsafe import Markup

    page = file_html(document, resources=INLINE, title=view.title,
                     template="{% block postamble %}{{ island }}{% endblock %}",
                     template_variables={"island": Markup(_island(view))})
    # the policy goes ahead of every script: before <title>, where only the template's fixed
    # text precedes it (the title itself, escaped, is the first text from the data)
    head, title_tag, rest = page.partition("<title>")
    if not title_tag or "<script" in head.lower():
        raise RuntimeError("internal: Bokeh's page template changed: no <title> ahead of its "
                           "scripts, so no place for the Content-Security-Policy")
    # the policy is fixed text and base64 hashes: nothing to escape in a "-quoted attribute
    meta = f'<meta http-equiv="Content-Security-Policy" content="{content_security_policy(page)}">'
    return f"{head}{meta}\n    {title_tag}{rest}"
