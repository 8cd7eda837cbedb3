"""The heavy parts load only when used (issue 38 item 10).

``pip install viscoforce`` stays complete for every README command (the project's rule), so
dask/distributed (maps on a cluster), bokeh (``view``), igor2 and afmformats (instrument files),
matplotlib (figures) and lmfit (fits) are installed; none of them may be imported before the
feature that needs it runs.

One fresh interpreter (the ``probe`` fixture) runs the cases of :data:`STEPS` one after the
other and lists, after each, what is loaded. The list is cumulative, so the steps go from the
strictest to the most permissive: a step may load only what every later step allows, and a
module a step loads but must not is reported at that step (had an earlier step loaded it, that
step would have failed). The interpreter runs without the ``*_NUM_THREADS`` variables, so that
importing viscoforce is seen not to set them. The checks on a fresh interpreter's imports from
tests/project/test_api.py, tests/cli/test_cli.py and tests/cli/test_cli_args.py are here too
(one interpreter start instead of five).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

#: dask itself is left out: xarray imports it to recognise dask arrays whenever it is installed
#: (xarray.namedarray.pycompat), on the first DataArray; distributed is the maps' cluster.
HEAVY = ("distributed", "bokeh", "igor2", "afmformats", "matplotlib", "matplotlib.pyplot", "lmfit",
         "h5py")
#: What the command line's own modules must not import (their parser and help need none of it).
CLI_HEAVY = ("matplotlib", "lmfit", "scipy.interpolate", "scipy.signal", "scipy.integrate",
             "scipy.optimize", "tqdm", "viscoforce.plotting", "viscoforce.lockin",
             "viscoforce.experiments.spectroscopy")
EXAMPLE = Path(__file__).resolve().parents[2] / "src" / "viscoforce" / "data" / "examples"

#: (id, code), strictest first (module docstring).
STEPS = [
    ("import", "import viscoforce"),
    ("the CLI's modules", "import viscoforce.cli, viscoforce.cli.model"),
    ("the CLI's help", "from viscoforce.cli import main\ntry:\n    main(['fit', '--help'])\n"
                       "except SystemExit:\n    pass"),
    ("the plotting module", "import viscoforce.plotting"),
    ("a JPK curve read", "import viscoforce as vf\n"
                         f"vf.open_data({str(EXAMPLE / 'sls_modulation.jpk-force')!r}, raw=True)"),
    # the figure formats come from matplotlib (the package), not from pyplot
    ("the figure formats", "from viscoforce.cli._args import figure_formats\nfigure_formats()"),
    ("a spectrum fit", "from viscoforce.cli import main\n"
                       f"main(['fit', {str(EXAMPLE / 'sls_spectrum.csv')!r}, '--model', 'svda', "
                       "'--h0=-5nm', '--json'])"),
]
#: The modules of HEAVY each step may have loaded (CLI_HEAVY is checked after the CLI's modules,
#: as its test did; the plotting module and what follows load some of it by design).
ALLOWED = {
    "import": set(),
    "the CLI's modules": set(),
    "the CLI's help": set(),
    "the plotting module": set(),
    "a JPK curve read": set(),
    "the figure formats": {"matplotlib"},
    # lmfit's own ``import matplotlib`` (the package: its figures need pyplot, which stays
    # unloaded)
    "a spectrum fit": {"lmfit", "matplotlib"},
}


def _probe_code() -> str:
    watched = sorted(set(HEAVY) | set(CLI_HEAVY))
    lines = ["import contextlib, io, json, os, sys"]
    for what, code in STEPS:
        lines += ["with contextlib.redirect_stdout(io.StringIO()):",
                  *(f"    {line}" for line in code.splitlines()),
                  f"print('STEP ' + json.dumps([{what!r}, "
                  f"[m for m in {watched!r} if m in sys.modules], "
                  "sorted(k for k in os.environ if k.endswith('_NUM_THREADS'))]))"]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def probe() -> dict[str, tuple[set[str], list[str]]]:
    """Per step, the watched modules loaded after it and the ``*_NUM_THREADS`` variables set."""
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", _probe_code()], check=True, capture_output=True,
                         text=True, env=env).stdout
    steps = [json.loads(line[5:]) for line in out.splitlines() if line.startswith("STEP ")]
    assert [s[0] for s in steps] == [s[0] for s in STEPS], out[-2000:]
    return {what: (set(loaded), threads) for what, loaded, threads in steps}


@pytest.mark.parametrize("what", [s[0] for s in STEPS])
def test_heavy_parts_load_only_when_used(probe, what):
    loaded = probe[what][0] & set(HEAVY)
    assert loaded <= ALLOWED[what], f"{what} loaded {sorted(loaded - ALLOWED[what])}"


def test_cli_modules_import_no_heavy_optional_libraries(probe):
    """(Was tests/cli/test_cli.py's.) The parser's modules leave plotting, fitting, SciPy's
    solvers and the lock-in unloaded."""
    assert not probe["the CLI's modules"][0] & set(CLI_HEAVY)


def test_import_has_no_side_effects_on_threads_or_matplotlib(probe):
    """(Was tests/project/test_api.py's.) Importing viscoforce and its plotting module loads no
    matplotlib and sets no BLAS thread variable."""
    loaded, threads = probe["the plotting module"]
    assert "matplotlib" not in loaded
    assert not threads


def test_figure_formats_come_from_matplotlib_without_pyplot(probe):
    """(Was tests/cli/test_cli_args.py's subprocess half.)"""
    assert "matplotlib.pyplot" not in probe["the figure formats"][0]
