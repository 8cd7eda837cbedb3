"""Nothing from a results file runs in the reader's browser (issue 40): escaping, CSP, --serve.

A fitted map from someone else carries strings the viewer shows: the quality codes' meanings
(``flag_meanings``), the map's dim names, parameter names and units, the ``model`` attribute.
:func:`crafted_map` puts markup and script in every one of them; each payload sets
``window.__pwned`` (or opens a dialog) if it ever runs. Checked without a browser: the JSON
data island cannot hold markup and gives every string back; no crafted string appears verbatim
anywhere in the page; the page's Content-Security-Policy allows exactly its own inline scripts
(by hash). In headless Chromium (as tests/plotting/test_viewer_browser.py, skipped without it): the page
of the crafted map, written by ``viscoforce view`` from netCDF files, loads, runs no payload
before or after clicks on pixels, and draws every crafted string as text in the pixel title,
the parameter table, the selector and the hover tooltip; the policy blocks an inline event
handler, an injected inline script and remote loads. ``--serve`` answers only requests
addressed to its loopback host and port, and sends the policy and ``nosniff``.

Every wait is for a condition of the page; Playwright's timeout is only the browser tests'
backstop against a hang.
"""

from __future__ import annotations

import base64
import hashlib
import http.client
import json
import re
import threading

import numpy as np
import pytest

pytest.importorskip("bokeh", reason="the viewer needs bokeh (pip install bokeh)")

from tests.plotting.test_viewer import big_map, island  # noqa: E402
from viscoforce.cli import main  # noqa: E402
from viscoforce.plotting.viewer import DATA_ISLAND_ID, map_view, report_html  # noqa: E402

#: Meaning of quality code 0 (the pixel shown when the page opens): runs on load if unescaped.
QUALITY_GOOD = "<img/src/onerror=window.__pwned='quality';alert('quality')>"
#: Meaning of quality code 2: closes the data island's script element and opens another.
QUALITY_BAD = "</script><script>window.__pwned='island'</script>"
#: Meaning of quality code 3: in a script element, puts the HTML parser in its escaped state.
QUALITY_COMMENT = "<!--<script>"
#: The map's dims (no ``/``: netCDF names cannot hold it). U+2028 ends a JavaScript line.
DIM_Y = "<img src=x onerror=window.__pwned='dim'>"
DIM_X = "<!--<script>\u2028x"
#: A parameter's name and another's units.
PARAM = "<svg onload=window.__pwned='param'>"
UNITS = "<img src=x onerror=window.__pwned='units'>"
#: The model attribute (the page's title).
MODEL = "</title><script>window.__pwned='model'</script><b>"
#: Seconds the in-process server may take to start or stop: a guard against a hang only.
HANG_GUARD = 300
CRAFTED = (QUALITY_GOOD, QUALITY_BAD, QUALITY_COMMENT, DIM_Y, DIM_X, PARAM, UNITS, MODEL)


def crafted_map():
    """A fitted 2 × 3 map and its spectra with markup and script in every string shown."""
    fits, spectra = big_map(2, 3, 6)
    quality = np.array([[0, 2, 0], [3, 0, 0]], dtype=np.int8)
    fits["quality"] = (fits["quality"].dims, quality, {
        "flag_values": np.arange(4, dtype=np.int8),
        "flag_meanings": f"{QUALITY_GOOD} optimiser_failed {QUALITY_BAD} {QUALITY_COMMENT}"})
    for name in ("E0", "E0_stderr"):
        fits[name].attrs["units"] = UNITS
    fits.attrs["model"] = MODEL
    fits = fits.rename({"tau": PARAM, "tau_stderr": f"{PARAM}_stderr"}).assign_coords(
        param_i=["E0", "E_inf", PARAM])
    dims = {"y": DIM_Y, "x": DIM_X}
    return fits.rename(dims), spectra.rename(dims)


@pytest.fixture(scope="module")
def crafted_page():
    """The crafted map's page, rendered in this process."""
    fits, spectra = crafted_map()
    return report_html(map_view(fits, spectra))


def _island_text(html: str) -> str:
    match = re.search(rf'<script type="application/json" id="{DATA_ISLAND_ID}">(.*?)</script>',
                      html, re.S)
    assert match is not None, "no data island"
    return match.group(1)


def test_the_data_island_holds_no_markup_and_gives_back_every_string(crafted_page):
    text = _island_text(crafted_page)
    assert not set(text) & set("<>&\u2028\u2029"), "markup characters in the island"
    data = json.loads(text)
    assert data["dims"] == [DIM_Y, DIM_X]
    assert data["params"] == ["E0", "E_inf", PARAM]
    names = [p["quality_name"] for p in data["pixels"]]
    assert names == [QUALITY_GOOD, QUALITY_BAD, QUALITY_GOOD, QUALITY_COMMENT, QUALITY_GOOD,
                     QUALITY_GOOD]
    assert [p[DIM_X] for p in data["pixels"]] == [0, 1, 2, 0, 1, 2]


def test_no_crafted_string_appears_verbatim_in_the_page(crafted_page):
    """Each string reaches the page escaped (HTML, JSON) or not at all, never as markup."""
    for crafted in CRAFTED:
        assert crafted not in crafted_page, crafted


def _policy(html: str) -> dict[str, list[str]]:
    """The page's Content-Security-Policy (its meta element), directive → values."""
    match = re.search(r'<meta http-equiv="Content-Security-Policy" content="([^"]*)">', html)
    assert match is not None, "no Content-Security-Policy meta element"
    head = html[:match.start()]
    assert "<script" not in head.lower(), "a script before the policy"
    return {name: values for name, *values in
            (d.split() for d in match.group(1).split(";") if d.strip())}


def _inline_scripts(html: str) -> list[str]:
    """Text of every script element the browser runs (not the JSON data blocks)."""
    return [body for attrs, body in re.findall(r"<script(\s[^>]*)?>(.*?)</script", html,
                                               re.S | re.I)
            if "application/json" not in (attrs or "")]


def test_the_policy_allows_the_pages_own_scripts_by_hash_and_nothing_else(crafted_page):
    policy = _policy(crafted_page)
    scripts = _inline_scripts(crafted_page)
    assert len(scripts) >= 3  # Bokeh's bundles, its log level, the embedding
    hashes = {"'sha256-" + base64.b64encode(hashlib.sha256(s.encode()).digest()).decode() + "'"
              for s in scripts}
    allowed = set(policy["script-src"])
    assert allowed - hashes == {"'unsafe-eval'"}  # CustomJS code is compiled by new Function
    assert hashes <= allowed
    assert policy["default-src"] == ["'none'"]
    for directive in ("object-src", "base-uri", "connect-src", "form-action"):
        assert policy[directive] == ["'none'"], directive
    assert policy["img-src"] == ["data:"]
    assert "'unsafe-inline'" not in policy["script-src"]
    assert not any("http" in v or v == "*" for values in policy.values() for v in values)


def test_a_page_without_a_title_ahead_of_its_scripts_is_refused(monkeypatch):
    """The policy must precede every script; a changed Bokeh template is not served unguarded."""
    import bokeh.embed

    monkeypatch.setattr(bokeh.embed, "file_html",
                        lambda *args, **kwargs: "<html><script>1</script><title>t</title>")
    with pytest.raises(RuntimeError, match=r"internal: Bokeh's page template changed: no "
                                           r"<title> ahead of its scripts"):
        report_html(map_view(*big_map(2, 3, 4)))


# ── in Chromium ──────────────────────────────────────────────────────────────────────────────

@pytest.fixture(scope="module")
def crafted_report(tmp_path_factory):
    """The crafted map's page written by the CLI from netCDF files, and those files' folder."""
    fits, spectra = crafted_map()
    folder = tmp_path_factory.mktemp("crafted")
    fits.to_netcdf(folder / "fits.nc")
    spectra.to_netcdf(folder / "spectra.nc")
    out = folder / "report.html"
    assert main(["view", str(folder / "fits.nc"), "--data", str(folder / "spectra.nc"),
                 "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def chromium(tmp_path_factory):
    """tests/plotting/test_viewer_browser.py's helpers and a headless Chromium context (or a skip)."""
    browser = pytest.importorskip("tests.plotting.test_viewer_browser")  # skips without playwright
    if browser.CHROMIUM is None:
        pytest.skip("no Chromium at /usr/bin/chromium or on PATH (Debian: apt-get install -y "
                    "chromium; .ci/run installs it)")
    with browser.playwright_api.sync_playwright() as p:
        context = browser.launch(p, tmp_path_factory.mktemp("chromium-profile"))
        yield browser, context
        context.close()


def _open(chromium, path):
    """``path`` in a new page, loaded; the page, its console errors and the dialogs it opened."""
    browser, context = chromium
    page = context.new_page()
    errors: list[str] = []
    dialogs: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("dialog", lambda d: (dialogs.append(d.message), d.dismiss()))
    page.goto(path.as_uri())
    # the data island is one element that parses (a page blanked by it fails here, not on the
    # backstop), then Bokeh has drawn the document
    assert page.evaluate(f"""() => JSON.parse(
        document.getElementById('{DATA_ISLAND_ID}').textContent).pixels.length""") == 6
    browser.wait_until_drawn(page)
    return page, errors, dialogs


#: JavaScript: the text of every hover tooltip drawn (inside Bokeh's shadow roots).
_TOOLTIPS = """() => { const out = [];
  const walk = (root) => { for (const el of root.querySelectorAll('*')) {
    if (el.shadowRoot) { walk(el.shadowRoot); }
    if (/tooltip/i.test(String(el.className))) { out.push(el.textContent); } } };
  walk(document); return out; }"""


def _pwned(page):
    return page.evaluate("() => window.__pwned === undefined ? null : String(window.__pwned)")


def test_crafted_strings_run_nothing_and_are_drawn_as_text(chromium, crafted_report):
    browser, _ = chromium
    page, errors, dialogs = _open(chromium, crafted_report)
    expected = island(crafted_report.read_text())["pixels"]
    assert _pwned(page) is None and dialogs == []  # nothing ran on load
    assert page.evaluate("() => document.title") == f"fits.nc: {MODEL} model"
    options = page.evaluate(f"""() => [...Bokeh.index.find_one(({browser.MODEL})('parameter'))
        .shadow_el.querySelectorAll('option')].map((o) => o.textContent)""")
    assert options == ["E0", "E_inf", PARAM]
    data = browser.data_source(page, "map_data")
    for pixel in (None, 1, 3):  # as opened (pixel 0), then two clicks
        if pixel is not None:
            page.mouse.click(*browser.screen_position(page, data["x"][pixel], data["y"][pixel]))
            page.wait_for_function(f"() => ({browser.MODEL})('map_data').selected.indices[0] "
                                   f"=== {pixel}")
        shown = 0 if pixel is None else pixel
        row = expected[shown]
        title = browser.drawn_text(page, "pixel_title")
        assert title == (f"pixel {shown} ({DIM_Y} {row[DIM_Y]}, {DIM_X} {row[DIM_X]}): "
                         f"quality {row['quality_name']}")
        table = {cells[0]: cells for cells in browser.drawn_table(page)}
        assert list(table) == ["E0", "E_inf", PARAM, "redchi", "chi2_pvalue", "quality"]
        assert table["E0"][3] == UNITS
        assert table["quality"][3] == row["quality_name"]
        assert _pwned(page) is None and dialogs == []
    page.mouse.move(*browser.screen_position(page, data["x"][1], data["y"][1]))
    page.wait_for_function(f"() => ({_TOOLTIPS})().some((t) => t.includes('quality'))")
    assert any(f"quality: {QUALITY_BAD}" in t for t in page.evaluate(_TOOLTIPS))
    assert _pwned(page) is None and dialogs == []
    assert errors == []


def test_the_policy_blocks_inline_handlers_injected_scripts_and_remote_loads(chromium,
                                                                             crafted_report):
    page, _, _ = _open(chromium, crafted_report)
    fetched = page.evaluate("""async () => {
        window.__violations = [];
        document.addEventListener('securitypolicyviolation',
                                  (e) => window.__violations.push(e.effectiveDirective));
        const script = document.createElement('script');
        script.textContent = "window.__pwned = 'injected script'";
        document.head.append(script);  // an allowed inline script runs here, synchronously
        const load = (src, handler) => new Promise((resolve) => {
          const img = document.createElement('img');
          if (handler) { img.setAttribute('onerror', handler); }
          img.addEventListener('error', resolve);  // after the onerror attribute's handler
          img.src = src;
          document.body.append(img);
        });
        await load('data:,', "window.__pwned = 'inline handler'");
        await load('http://127.0.0.1:9/remote.png', null);
        return fetch('http://127.0.0.1:9/remote').then(() => 'fetched', () => 'refused');
    }""")
    assert _pwned(page) is None
    assert fetched == "refused"
    page.wait_for_function("() => window.__violations.length >= 4")
    assert set(page.evaluate("() => window.__violations")) == {
        "script-src-elem", "script-src-attr", "img-src", "connect-src"}


# ── --serve ──────────────────────────────────────────────────────────────────────────────────

def _get(port: int, host: str | None) -> tuple[int, dict[str, str], str]:
    """GET / on 127.0.0.1:port with the Host header ``host`` (None: no Host header)."""
    connection = http.client.HTTPConnection("127.0.0.1", port)
    try:
        connection.putrequest("GET", "/", skip_host=True)
        if host is not None:
            connection.putheader("Host", host)
        connection.endheaders()
        response = connection.getresponse()
        return response.status, dict(response.getheaders()), response.read().decode()
    finally:
        connection.close()


def test_serve_answers_only_its_own_host_and_sends_the_policy(crafted_report, monkeypatch,
                                                             capsys):
    """DNS rebinding: a page of another site reaching 127.0.0.1 under its own host name.

    The server of ``view --serve`` (``serve_html``) runs in a thread of this process on the page
    ``view --out`` wrote from the same files (``run_view`` makes one page for both); the command
    in a child process and its Ctrl-C are tests/plotting/test_viewer.py's.
    """
    import http.server

    from viscoforce.cli.view import serve_html

    started = threading.Event()
    servers = []

    class Recorded(http.server.ThreadingHTTPServer):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)  # bound and listening
            servers.append(self)
            started.set()

    monkeypatch.setattr(http.server, "ThreadingHTTPServer", Recorded)
    returned = []
    thread = threading.Thread(target=lambda: returned.append(
        serve_html(crafted_report.read_text(encoding="utf-8"))), daemon=True)
    thread.start()
    try:
        assert started.wait(HANG_GUARD), "the server did not start"
        port = servers[0].server_address[1]
        for host in (f"evil.example:{port}", "evil.example", f"127.0.0.1.evil.example:{port}",
                     f"127.0.0.1:{port + 1}", None):
            status, headers, body = _get(port, host)
            assert status == 421, host
            assert "evil" not in body and DATA_ISLAND_ID not in body, host
            assert headers["X-Content-Type-Options"] == "nosniff"
        for host in (f"127.0.0.1:{port}", f"localhost:{port}", f"LOCALHOST:{port}",
                     f"[::1]:{port}"):
            status, headers, body = _get(port, host)
            assert status == 200, host
            assert len(island(body)["pixels"]) == 6
            assert headers["X-Content-Type-Options"] == "nosniff"
            meta = re.search(r'<meta http-equiv="Content-Security-Policy" content="([^"]*)">',
                             body).group(1)
            assert headers["Content-Security-Policy"] == f"{meta}; frame-ancestors 'none'"
    finally:
        if servers:
            servers[0].shutdown()  # serve_forever returns; serve_html closes the socket
        thread.join(HANG_GUARD)
    assert returned == [0] and servers[0].socket.fileno() == -1
    url = f"http://127.0.0.1:{port}/"
    assert capsys.readouterr().out == f"serving the viewer at {url} (Ctrl-C stops)\n"
