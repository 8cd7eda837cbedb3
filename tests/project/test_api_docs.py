"""The API reference builds offline from the numpydoc docstrings (docs/build_api.py, pdoc).

Skipped when pdoc (a test extra) is not installed. Builds every page of the site into ``tmp_path``,
without the highlighted source views and the search index (``build(..., show_source=False,
search=False)``): they are about half of the build time and nothing here reads them.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    pytest.importorskip("pdoc")
    spec = importlib.util.spec_from_file_location("build_api", REPO / "docs" / "build_api.py")
    build_api = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build_api)
    out = tmp_path_factory.mktemp("api")
    index = build_api.build(out, show_source=False, search=False)
    assert index == out / "index.html"
    return out


def test_index_and_module_pages_exist(site):
    assert (site / "index.html").is_file()
    for page in ("viscoforce.html", "viscoforce/fitting/fit.html", "viscoforce/plotting/maps.html",
                 "viscoforce/io/jpk.html", "viscoforce/physics/materials.html"):
        assert (site / page).is_file(), page


def test_numpydoc_docstrings_are_rendered(site):
    html = (site / "viscoforce" / "fitting" / "fit.html").read_text(encoding="utf-8")
    assert "fit_spectrum" in html
    assert "Fit one spectrum (over" in html            # fit_spectrum's summary line
    assert "Parameters" in html and "Returns" in html  # numpydoc sections became headings


def test_private_modules_are_left_out(site):
    assert not list(site.rglob("_*.html"))


def test_build_starts_no_cluster(site):
    """Importing every public module (as pdoc does) starts no dask client or cluster."""
    distributed_client = sys.modules.get("distributed.client")
    if distributed_client is not None:
        assert distributed_client._get_global_client() is None
