"""The map viewer without a browser: data island, best-fit curves, self-containment, size, CLI.

The browser half (clicks, selector, console) is tests/plotting/test_viewer_browser.py.
"""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import urllib.request

import numpy as np
import pytest
import xarray as xr

pytest.importorskip("bokeh", reason="the viewer needs bokeh (pip install bokeh)")

from viscoforce.cli import main  # noqa: E402
from viscoforce.exceptions import SchemaError  # noqa: E402
from viscoforce.fitting.models import make_model  # noqa: E402
from viscoforce.plotting.viewer import (  # noqa: E402
    DATA_ISLAND_ID,
    best_fit_curves,
    map_view,
    report_html,
)
from viscoforce.schema import make_spectrum  # noqa: E402

#: The contact model's fixed inputs of the small synthetic map.
FIXED = {"radius": 5e-6, "indentation": 1e-6, "material": "sls"}
TRUTH = {"E0": 3e3, "E_inf": 1e3, "tau": 5e-3}


def island(html: str) -> dict:
    """The page's JSON data island, parsed."""
    match = re.search(rf'<script type="application/json" id="{DATA_ISLAND_ID}">(.*?)</script>',
                      html, re.S)
    assert match is not None, "no data island"
    return json.loads(match.group(1))


def synthetic_spectra(rng, ny=2, nx=3, n_omega=12, noise=0.02):
    """Spectra of a (y, x) map from the contact SLS model, E0 varying across the map, noisy."""
    omega = np.geomspace(2 * np.pi, 2 * np.pi * 300, n_omega)
    model = make_model("contact", **FIXED)
    k = np.empty((ny, nx, n_omega), dtype=complex)
    for j, i in np.ndindex(ny, nx):
        values = {**TRUTH, "E0": TRUTH["E0"] * (1 + 0.2 * (j * nx + i))}
        k[j, i] = model.raw(omega, values)
    stiffness = np.abs(k) * (1 + noise * rng.standard_normal(k.shape))
    phase = np.angle(k) + noise * rng.standard_normal(k.shape)
    coords = {"y": ("y", np.arange(ny) * 2e-6), "x": ("x", np.arange(nx) * 2e-6)}
    quality = np.zeros(k.shape, dtype=np.int8)
    quality[0, 1, -1] = 2  # one low-signal point: left out of the fit and of the Bode plot
    ds = make_spectrum(omega, stiffness * np.exp(1j * phase), 1e-9, 5e-8, dims=("y", "x", "omega"),
                       coords=coords, quality=quality,
                       stderr={"stiffness": noise * stiffness,
                               "phase": np.full(k.shape, np.degrees(noise))})
    return ds.assign_coords(frequency=("omega", omega / (2 * np.pi), {"units": "Hz"}))


def fit_synthetic_map():
    """A fitted 2 × 3 map (fit_map, in this process) and its spectra."""
    from viscoforce.fitting.maps import fit_map

    spectra = synthetic_spectra(np.random.default_rng(24))
    fits = fit_map(spectra, "contact", scheduler="synchronous", progress=False, **FIXED)
    return fits, spectra


@pytest.fixture(scope="module")
def fitted():
    """:func:`fit_synthetic_map`, once per module."""
    return fit_synthetic_map()


def big_map(ny=64, nx=64, n_omega=40, seed=1):
    """A fit-result-like 64 × 64 map with 40 frequencies (no fitting: the size test)."""
    rng = np.random.default_rng(seed)
    dims = ("y", "x")
    omega = np.geomspace(1.0, 1e4, n_omega)
    params = ["E0", "E_inf", "tau"]
    shape = (ny, nx)
    data = {}
    for name, scale, unit in (("E0", 3e3, "Pa"), ("E_inf", 1e3, "Pa"), ("tau", 1e-3, "s")):
        v = scale * rng.lognormal(0, 0.3, shape)
        data[name] = (dims, v, {"units": unit})
        data[f"{name}_stderr"] = (dims, 0.05 * v, {"units": unit})
    quality = rng.choice([0, 0, 0, 2, 3], size=shape).astype(np.int8)
    data.update({
        "quality": (dims, quality), "success": (dims, np.ones(shape, dtype=np.int8)),
        "redchi": (dims, rng.lognormal(0, 0.5, shape)),
        "chi2_pvalue": (dims, rng.uniform(0, 1, shape)),
        "identifiability": ((*dims, "param_i"), np.zeros((*shape, 3), dtype=np.int8)),
        "fit_stiffness": ((*dims, "omega"), rng.lognormal(0, 1, (*shape, n_omega)),
                          {"units": "N/m"}),
        "fit_phase": ((*dims, "omega"), rng.uniform(0, 60, (*shape, n_omega)),
                      {"units": "degree"})})
    coords = {"y": ("y", np.arange(ny) * 1e-6), "x": ("x", np.arange(nx) * 1e-6),
              "param_i": params, "omega": omega}
    fits = xr.Dataset(data, coords=coords, attrs={"model": "contact"})
    k = rng.lognormal(0, 1, (*shape, n_omega)) * np.exp(1j * np.radians(
        rng.uniform(0, 60, (*shape, n_omega))))
    spectra = make_spectrum(omega, k, 1e-9, 5e-8, dims=("y", "x", "omega"),
                            coords={"y": coords["y"], "x": coords["x"]},
                            stderr={"stiffness": 0.05 * np.abs(k),
                                    "phase": np.full(k.shape, 1.0)})
    return fits, spectra.assign_coords(frequency=("omega", omega / (2 * np.pi)))


def test_data_island_parses_and_matches_the_netcdf(fitted):
    fits, spectra = fitted
    html = report_html(map_view(fits, spectra, best_fit_curves(fits, spectra, **FIXED)))
    data = island(html)
    pixels = data["pixels"]
    assert len(pixels) == fits.sizes["y"] * fits.sizes["x"] == 6
    assert data["dims"] == ["y", "x"] and data["params"] == ["E_inf", "E0", "tau"]
    for p in pixels:
        j, i = divmod(p["index"], fits.sizes["x"])
        pixel = fits.isel(y=j, x=i)
        assert p["y"] == pytest.approx(float(pixel["y"]), rel=0, abs=0)
        assert p["x"] == pytest.approx(float(pixel["x"]), rel=0, abs=0)
        for name in ("E0", "E0_stderr", "E_inf", "tau", "tau_stderr", "redchi"):
            assert p[name] == float(pixel[name]), name  # exact: the JSON keeps every digit
        assert p["quality"] == int(pixel["quality"])
        assert {"chi2_pvalue", "quality_name"} <= set(p)


def test_best_fit_curves_reproduce_the_fits_chi_square(fitted):
    """Residuals of the evaluated curves against the data give back each pixel's redchi.

    Curves on 60 log-spaced points are interpolated to the 12 data frequencies (log |k|, phase),
    so redchi agrees to 1 %, not to rounding.
    """
    fits, spectra = fitted
    view = map_view(fits, spectra, best_fit_curves(fits, spectra, **FIXED))
    n = spectra.sizes["omega"]
    r_re = view.spectra["residual_re"].reshape(-1, n)
    r_im = view.spectra["residual_im"].reshape(-1, n)
    dof = 2 * np.isfinite(r_re).sum(axis=1) - len(view.params)
    redchi = np.nansum(r_re ** 2 + r_im ** 2, axis=1) / dof
    np.testing.assert_allclose(redchi, fits["redchi"].values.reshape(-1), rtol=0.01)
    np.testing.assert_allclose(fits["E0"].values.reshape(-1),
                               TRUTH["E0"] * (1 + 0.2 * np.arange(6)), rtol=0.2)


def test_the_page_is_self_contained_and_a_64x64_map_with_40_frequencies_fits_in_20_mb():
    fits, spectra = big_map()
    html = report_html(map_view(fits, spectra))
    size = len(html.encode())
    assert size <= 20 * 2 ** 20, f"{size / 2 ** 20:.1f} MiB"
    assert not re.search(r"<script[^>]+src=", html, re.I), "an external script"
    assert not re.search(r"<link[^>]+href=[\"']https?://", html, re.I), "an external stylesheet"
    assert len(island(html)["pixels"]) == 64 * 64


def test_masked_pixels_are_nan_in_the_colour_field_and_left_out_of_the_histogram():
    fits, spectra = big_map(8, 8, 6)
    ident = fits["identifiability"].values.copy()
    ident[0, 0, 2] = 1  # tau not determined at pixel 0 only
    fits["identifiability"] = (fits["identifiability"].dims, ident)
    view = map_view(fits, spectra)
    quality = fits["quality"].values.reshape(-1)
    for name in view.params:
        masked = np.isnan(view.colour[name])
        extra = np.zeros(64, dtype=bool)
        if name == "tau":
            extra[0] = True
        np.testing.assert_array_equal(masked, np.isin(quality, (1, 2)) | extra)
        assert view.histograms[name][2].sum() == (~masked).sum()


def test_a_curve_map_places_pixels_on_x_y_and_without_spectra_says_so():
    fits, _ = big_map(2, 3, 5)
    flat = fits.stack(curve=("y", "x")).reset_index("curve").drop_vars(["y", "x"])
    xs, ys = np.meshgrid(np.arange(3) * 1e-6, np.arange(2) * 1e-6)
    flat = flat.assign_coords(x=("curve", xs.reshape(-1)), y=("curve", ys.reshape(-1)))
    view = map_view(flat)
    np.testing.assert_allclose(view.x, xs.reshape(-1) * 1e6)
    np.testing.assert_allclose(view.width, 1.0)
    assert view.axis_labels == ("x [µm]", "y [µm]")
    assert any("no spectra" in note for note in view.notes)
    assert view.fits["stiffness"].size == 6 * 5  # the curves stored in the fit result


def test_not_a_map_raises_naming_what_is_missing(fitted):
    fits, spectra = fitted
    with pytest.raises(SchemaError, match=r"not a fitted map: no param_i"):
        map_view(spectra)
    with pytest.raises(SchemaError, match=r"a single fit \(no map dims\)"):
        map_view(fits.isel(y=0, x=0))
    other = spectra.isel(x=slice(0, 2))
    with pytest.raises(ValueError, match=r"spectra \(--data\) is not over this map's pixels"):
        map_view(fits, other)


# ── CLI ──────────────────────────────────────────────────────────────────────────────────────

@pytest.fixture(scope="module")
def files(fitted, tmp_path_factory):
    fits, spectra = fitted
    folder = tmp_path_factory.mktemp("view")
    fits.to_netcdf(folder / "fits.nc")
    spectra.to_netcdf(folder / "spectra.nc")
    return folder


def test_cli_writes_the_page_and_prints_json(files, capsys):
    out = files / "report.html"
    assert main(["view", str(files / "fits.nc"), "--data", str(files / "spectra.nc"),
                 "--out", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["out"] == str(out) and info["pixels"] == 6
    assert info["bytes"] == out.stat().st_size
    assert len(island(out.read_text())["pixels"]) == 6


@pytest.mark.parametrize(("argv", "message"), [
    (["{d}/missing.nc", "--out", "{d}/r.html"], r"FITS .*missing\.nc: no such file"),
    (["{d}/spectra.nc", "--out", "{d}/r.html"], r"FITS .*spectra\.nc: not a fitted map"),
    (["{d}/fits.nc", "--out", "{d}/r.html", "--serve"], r"give --out REPORT\.html or --serve, "
                                                          r"not both"),
    (["{d}/fits.nc"], r"give --out REPORT\.html .* or --serve"),
    (["{d}/fits.nc", "--out", "{d}/r.txt"], r"--out .*r\.txt: the page's file name must end "
                                            r"in \.html"),
    (["{d}/fits.nc", "--out", "{d}/no/r.html"], r"--out .*: directory .* does not exist"),
    (["{d}/fits.nc", "--out", "{d}/r.html", "--port", "8000"], r"--port applies to --serve"),
    (["{d}/fits.nc", "--data", "{d}/missing.nc", "--out", "{d}/r.html"],
     r"--data .*missing\.nc: no such file"),
])
def test_cli_errors_name_the_flag(files, capsys, argv, message):
    assert main(["view", *(a.format(d=files) for a in argv)]) == 2
    err = capsys.readouterr().err
    assert re.search(message, err), err
    assert not (files / "r.html").exists()


def test_serve_answers_on_loopback_and_stops_cleanly_on_ctrl_c(files):
    """The server in a child process: fetch the page, then SIGINT; exit status 0, no traceback."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "viscoforce", "view", str(files / "fits.nc"), "--data",
         str(files / "spectra.nc"), "--serve"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        match = re.search(r"http://127\.0\.0\.1:(\d+)/", line)
        assert match, f"no URL in {line!r}; stderr: {proc.stderr.read() if proc.poll() else ''}"
        with urllib.request.urlopen(match.group(0)) as response:  # noqa: S310 - loopback
            page = response.read().decode()
        assert len(island(page)["pixels"]) == 6
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert "Traceback" not in err and "stopped" in err
