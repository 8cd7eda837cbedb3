"""The session fixture of tests/benchmarks/: each suite's smoke run, once (see _smoke.py)."""

from __future__ import annotations

import os
from collections.abc import Callable

import pytest

from tests.benchmarks._smoke import HEAVY_SMOKE, QuickRun, quick_runs, suite_of


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """The heavy suites' smoke runs and the checks on them are slow tests (``HEAVY_SMOKE``)."""
    for item in items:
        if suite_of(item) in HEAVY_SMOKE:
            item.add_marker(pytest.mark.slow)


@pytest.fixture(scope="session")
def quick_run(tmp_path_factory) -> Callable[[str], QuickRun]:
    """``quick_run(name)``: the suite's smoke run, run once per session and shared by the xdist
    workers (skipped where it cannot run here: a module it needs, such as dask.distributed, or
    its data file is absent)."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # the session's folder, shared by its workers
    return quick_runs(root / "benchmark-smoke-runs")
