"""An interactive viewer of fitted maps: one self-contained HTML page (Bokeh, JavaScript inline).

``viscoforce view FITS.nc [--data SPECTRA.nc] --out report.html`` writes it. The page shows a
heat map of any fitted parameter (a selector), grey where the pixel's fit failed, does not
describe its data or leaves that parameter undetermined (the rules of
:func:`viscoforce.plotting.map_plot`); a click on a pixel shows its Bode plot (data with error
bars from the spectra's ``*_stderr``, the best-fit curve, residuals) and its parameter table; a
histogram of the parameter over the unmasked pixels; a button exporting the per-pixel table as
CSV. The table is also a JSON data island, ``<script type="application/json"
id="viscoforce-data">``.

Compute and draw apart: :func:`map_view` gathers the arrays (no Bokeh), :func:`report_html` lays
them out (Bokeh imported there only), :func:`best_fit_curves` evaluates each pixel's best fit
where the map result holds only its parameters.

A results file cannot run script in the reader's browser: every string from it reaches the
page escaped for where it goes, and the page's Content-Security-Policy
(:func:`content_security_policy`) runs only the page's own scripts (docs/security.md).
"""

from __future__ import annotations

from viscoforce.plotting.viewer._data import MapView, best_fit_curves, map_view, pixel_table
from viscoforce.plotting.viewer._page import (
    DATA_ISLAND_ID,
    content_security_policy,
    report_html,
)

__all__ = ["DATA_ISLAND_ID", "MapView", "best_fit_curves", "content_security_policy",
           "map_view", "pixel_table", "report_html"]
