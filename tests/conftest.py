from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
REFERENCE_DIR = SHARED / "data" / "reference"
REAL_DATA_DIR = SHARED / "data" / "real"


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)


@pytest.fixture
def paper_law():
    import viscoforce as vf

    return vf.paper_pressure_law()


@pytest.fixture
def make_problem(paper_law):
    """Problem factory with the paper's geometry and pressure law."""
    import viscoforce as vf

    def factory(material, deepest_position, **kw):
        return vf.ContactProblem.create(sphere=vf.PAPER.sphere(), surface_force=paper_law,
                                        material=material, deepest_position=deepest_position, **kw)

    return factory


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    import sys

    if "matplotlib.pyplot" in sys.modules:
        sys.modules["matplotlib.pyplot"].close("all")
