"""The heavy parts load only when used (issue 38 item 10).

``pip install viscoforce`` stays complete for every README command (the project's rule), so
dask/distributed (maps on a cluster), bokeh (``view``), igor2 and afmformats (instrument files),
matplotlib (figures) and lmfit (fits) are installed; none of them may be imported before the
feature that needs it runs. Each case runs in a fresh interpreter and lists what it loaded.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

#: dask itself is left out: xarray imports it to recognise dask arrays whenever it is installed
#: (xarray.namedarray.pycompat), on the first DataArray; distributed is the maps' cluster.
HEAVY = ("distributed", "bokeh", "igor2", "afmformats", "matplotlib", "matplotlib.pyplot", "lmfit",
         "h5py")
EXAMPLE = Path(__file__).resolve().parents[2] / "src" / "viscoforce" / "data" / "examples"


def _loaded(code: str) -> set[str]:
    probe = (f"import sys\n{code}\n"
             f"print('LOADED:' + ','.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", probe], check=True, capture_output=True,
                         text=True).stdout
    line = next(x for x in reversed(out.splitlines()) if x.startswith("LOADED:"))
    return set(filter(None, line.removeprefix("LOADED:").split(",")))


@pytest.mark.parametrize(("what", "code", "allowed"), [
    ("import", "import viscoforce", set()),
    ("the CLI's help", "from viscoforce.cli import main\ntry:\n    main(['fit', '--help'])\n"
                       "except SystemExit:\n    pass", set()),
    ("a spectrum fit", "from viscoforce.cli import main\n"
                       f"main(['fit', {str(EXAMPLE / 'sls_spectrum.csv')!r}, '--model', 'svda', "
                       "'--h0=-5nm', '--json'])", {"lmfit", "matplotlib"}),  # lmfit's own
    # ``import matplotlib`` (the package: its figures need pyplot, which stays unloaded)
    ("a JPK curve read", "import viscoforce as vf\n"
                         f"vf.open_data({str(EXAMPLE / 'sls_modulation.jpk-force')!r}, raw=True)",
     set()),
])
def test_heavy_parts_load_only_when_used(what, code, allowed):
    loaded = _loaded(code)
    assert loaded <= allowed, f"{what} loaded {sorted(loaded - allowed)}"
