"""The viewer page: a :class:`~viscoforce.plotting.viewer._data.MapView` laid out with Bokeh.

Bokeh is imported here only, inside :func:`report_html`. The page is one HTML file with
Bokeh's JavaScript inline (:data:`bokeh.resources.INLINE`), so it opens from a ``file://`` URL
with no network. Its parts and the Bokeh models the tests find by ``name``:

- ``parameter``: the selector of the mapped parameter;
- ``map`` / ``map_data``: the map, one rectangle per pixel, coloured by the data source's
  ``value`` column (NaN, drawn grey, where the pixel is masked for that parameter); a click
  selects a pixel;
- ``histogram`` / ``histogram_data``: the parameter over its unmasked pixels;
- ``bode_magnitude``, ``bode_phase``, ``bode_residuals``, with ``bode_data`` (the clicked
  pixel's data: ``frequency``, ``stiffness``, ``phase``, error-bar ends, residuals) and
  ``fit_data`` (its best-fit curve);
- ``pixel_table`` / ``pixel_table_data``: the clicked pixel's parameters with stderr,
  ``redchi``, ``chi2_pvalue`` and ``quality``;
- ``export_csv``: a button that downloads the per-pixel table as CSV.

The per-pixel table is also a JSON data island, ``<script type="application/json"
id="viscoforce-data">`` holding ``{"pixels": [...]}`` (:func:`.pixel_table`); the page's
callbacks read it (parameter table, CSV export). The per-pixel spectra travel as float32
arrays in Bokeh's binary encoding.
"""

from __future__ import annotations

import json

import numpy as np

from viscoforce.plotting.viewer._data import MapView

__all__ = ["DATA_ISLAND_ID", "report_html"]

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
const rows = {name: [], value: [], stderr: [], unit: []};
for (const [name, factor, unit] of params) {
  rows.name.push(name);
  rows.value.push(p[name] === null ? NaN : p[name] / factor);
  const e = p[name + '_stderr'];
  rows.stderr.push(e === null || e === undefined ? NaN : e / factor);
  rows.unit.push(unit);
}
for (const name of ['redchi', 'chi2_pvalue']) {
  rows.name.push(name);
  rows.value.push(p[name] === null || p[name] === undefined ? NaN : p[name]);
  rows.stderr.push(NaN);
  rows.unit.push('');
}
rows.name.push('quality'); rows.value.push(p.quality); rows.stderr.push(NaN);
rows.unit.push(p.quality_name);
table_data.data = rows;
const where = dims.map((d) => d + ' ' + p[d]).join(', ');
title.text = '<b>pixel ' + i + '</b> (' + where + '): quality ' + p.quality_name;
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


def _label(view: MapView, name: str) -> str:
    display = view.units[name][1]
    return f"{name} [{display}]" if display else name


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
    """The JSON data island (``</`` escaped so that no value can close the script element)."""
    text = json.dumps({"dims": list(view.dims), "params": list(view.params),
                       "pixels": view.table}, allow_nan=False, separators=(",", ":"))
    return (f'<script type="application/json" id="{DATA_ISLAND_ID}">'
            f'{text.replace("</", "<" + chr(92) + "/")}</script>')


def _first_pixel(view: MapView) -> int:
    good = np.flatnonzero(view.quality == 0)
    return int(good[0]) if good.size else 0


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

    first_name = view.params[0]
    ranges = {n: _range(view.colour[n], view.log[n]) for n in view.params}
    labels = {n: _label(view, n) for n in view.params}
    colour = ColumnDataSource({n: view.colour[n] for n in view.params}, name="colour_store")
    map_data = ColumnDataSource({
        "x": view.x, "y": view.y, "width": view.width, "height": view.height,
        "pixel": np.arange(view.n_pixels), "value": view.colour[first_name],
        "quality": [row["quality_name"] for row in view.table]}, name="map_data")
    linear_mapper = LinearColorMapper(palette="Viridis256", nan_color="lightgrey")
    log_mapper = LogColorMapper(palette="Viridis256", nan_color="lightgrey")
    mapper = log_mapper if view.log[first_name] else linear_mapper
    mapper.low, mapper.high = ranges[first_name]

    map_fig = figure(name="map", title=view.title, width=520, height=460, match_aspect=True,
                     tools="tap,pan,wheel_zoom,reset,save", x_axis_label=view.axis_labels[0],
                     y_axis_label=view.axis_labels[1])
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
    hist = ColumnDataSource({f"{n}_{k}": _padded(v, n_bins) for n in view.params
                             for k, v in zip(("left", "right", "count"), view.histograms[n],
                                             strict=True)}, name="histogram_store")
    left, right, count = view.histograms[first_name]
    histogram_data = ColumnDataSource({"left": _padded(left, n_bins),
                                       "right": _padded(right, n_bins),
                                       "count": _padded(count, n_bins)}, name="histogram_data")
    histogram = figure(name="histogram", title="over the good pixels", width=420, height=300,
                       tools="pan,wheel_zoom,reset,save", x_axis_label=labels[first_name],
                       y_axis_label="pixels")
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
              "tools": "pan,wheel_zoom,reset,save", "x_axis_label": view.frequency_label}
    magnitude = figure(name="bode_magnitude", y_axis_type="log", y_axis_label="|k*| [N/m]",
                       **common)
    pixel_title = Div(text="", name="pixel_title")
    phase = figure(name="bode_phase", y_axis_label="phase [deg]", x_range=magnitude.x_range,
                   **common)
    residuals = figure(name="bode_residuals", y_axis_label=view.residual_label,
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

    table_data = ColumnDataSource({"name": [], "value": [], "stderr": [], "unit": []},
                                  name="pixel_table_data")
    number = NumberFormatter(format="0.0000 a", nan_format="–")
    table = DataTable(source=table_data, name="pixel_table", width=420, height=260,
                      index_position=None, reorderable=False, columns=[
                          TableColumn(field="name", title="parameter"),
                          TableColumn(field="value", title="value", formatter=number),
                          TableColumn(field="stderr", title="stderr", formatter=number),
                          TableColumn(field="unit", title="unit")])

    select = Select(title="mapped parameter", value=first_name, options=list(view.params),
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
        "keys": list(_SPECTRUM_KEYS), "table_data": table_data, "title": pixel_title,
        "params": [[n, view.units[n][2], view.units[n][1]] for n in view.params],
        "dims": list(view.dims)}, code=_ON_SELECT)
    map_data.selected.js_on_change("indices", on_select)
    map_data.selected.indices = [i0]
    export = Button(label="export table as CSV", name="export_csv", button_type="primary")
    export.js_on_event("button_click", CustomJS(args={"filename": csv_name}, code=_EXPORT_CSV))
    notes = Div(text="<br>".join(view.notes), name="notes")
    help_text = Div(text="Click a pixel to see its Bode plot and parameters. Grey pixels: the "
                         "fit failed, does not describe the data, or the parameter is not "
                         "determined there.")
    layout = column(
        row(select, export, help_text), notes,
        row(map_fig, column(histogram)),
        pixel_title, row(magnitude, phase, residuals), row(table))
    # the first pixel's table and title are filled by the same callback when the page loads
    from bokeh.document import Document

    document = Document()
    document.add_root(layout)
    document.js_on_event("document_ready", on_select)
    document.title = view.title
    from markupsafe import Markup

    return file_html(document, resources=INLINE, title=view.title,
                     template="{% block postamble %}{{ island }}{% endblock %}",
                     template_variables={"island": Markup(_island(view))})
