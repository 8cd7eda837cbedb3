"""``viscoforce.measured.open_data`` on the real files of ../shared/data/real (when present): it
gives exactly what ``viscoforce load --out`` writes, or refuses what load refuses. Split off from
test_open.py (whose helpers it uses) so that the two halves run on different xdist workers.
"""

from __future__ import annotations

import json

import pytest
import xarray as xr

from tests.conftest import REAL_DATA_DIR
from tests.measured.test_open import _as_written, _opened, open_data_and_made
from viscoforce.cli import main
from viscoforce.exceptions import ViscoforceError

# ── real files ───────────────────────────────────────────────────────────────────────────────────

def _real_files():
    if not REAL_DATA_DIR.is_dir():
        return []
    skip = {".md", ".txt"}
    return sorted(p for p in REAL_DATA_DIR.rglob("*") if p.is_file()
                  and (p.suffix not in skip or "fmt-" in p.name)
                  and p.name not in ("LICENSE",))


@pytest.mark.parametrize("path", _real_files() or [None],
                         ids=lambda p: "absent" if p is None else p.name)
def test_real_files_give_what_load_writes(tmp_path, capsys, path):
    if path is None:
        pytest.skip("real data folder absent (../shared/data/real)")
    from viscoforce.measured import open_data

    out = tmp_path / "cli.nc"
    code = main(["load", str(path), "--out", str(out), "--json"])
    captured = capsys.readouterr()
    if code != 0:  # a file load refuses: open_data refuses it too
        assert code == 2
        with pytest.raises(ViscoforceError):
            open_data(path)
        return
    ds, made = open_data_and_made(path)
    xr.testing.assert_identical(_opened(out), _as_written(ds, tmp_path))
    assert made.summary() == json.loads(captured.out)
