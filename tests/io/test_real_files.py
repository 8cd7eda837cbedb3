"""Every real file in ../shared/data/real is analysed by at least one model, or refused with a reason.

One CLI run per file (the route a user takes), with the model that file's segments call for; the
files do not record tips (except the .uff, a 20° pyramid, and the Chiaro header, a 27.5 µm
sphere), so the other Hertz runs assume a 5 µm sphere. Skips cleanly when the shared data are absent.
"""

from __future__ import annotations

import hashlib
import json

import pytest

from tests.conftest import REAL_DATA_DIR
from viscoforce.cli import main

#: file → (fit arguments, what the JSON must show) or (None, the refusal's words).
CASES = {
    "PyFMReader/map-data-2021.11.05-17.37.44.432.jpk-force-map": (
        ["--model", "contact", "--material", "structural", "--tip", "sphere:5um", "--curve",
         "0"], "E_ref"),
    "PyFMReader/20200904_Egel4-Z1.0_00025.uff": (["--model", "hertz"], "E"),
    "PyFMReader/20200904_Egel4-Z1.0_00025.spm": (["--model", "hertz", "--tip", "pyramid:20"], "E"),
    "PyFMRheo/map-data-2022.10.29-12.27.34.564.jpk-force-map": (
        ["--model", "hertz", "--tip", "sphere:5um"], "E"),
    "afmformats/10.1002_btm2.10294_fig5d-cell1.zip": (
        ["--model", "relaxation", "--curve", "0"], "tau_1"),
    "afmformats/fmt-jpk-sr_cell1-0008.jpk-force": (["--model", "relaxation"], "tau_1"),
    "afmformats/fmt-jpk-cc_pr14-brain-2021.06.30.jpk-force": (["--model", "creep"], "tau_1"),
    "afmformats/fmt-jpk-cc_pr14-polymergel-2021.06.30.jpk-force": (
        ["--model", "hertz", "--tip", "sphere:5um"], "E"),
    "afmformats/fmt-igor-fd_SiN_FD_plot.ibw": (["--model", "hertz", "--tip", "cone:20"], "E"),
    "afmformats/fmt-igor-fd_U3_3_p10004.ibw": (["--model", "hertz", "--tip", "sphere:5um"], "E"),
    "afmformats/fmt-chiaro-txt_AEBP1_Indentation_002.zip": (["--model", "hertz"], "E"),
    "afmformats/fmt-afm-workshop-fd_single_2021-10-22_14.16.csv": (
        None, "no spring constant"),
    "afmformats/fmt-ntmdt-txt-fd_2015_01_17_gel4-0_1_mQ_adh_6B_Curve_DFL_Height_51.txt": (
        None, "spring_constant and sensitivity missing"),
}

pytestmark = pytest.mark.skipif(not (REAL_DATA_DIR / "afmformats").is_dir(),
                                reason="shared real data absent")


def test_the_cases_are_every_real_file():
    found = {str(p.relative_to(REAL_DATA_DIR)) for p in REAL_DATA_DIR.rglob("*")
             if p.is_file() and p.name not in ("LICENSE", "SOURCE.txt")
             and p.suffix != ".md"}
    assert found == set(CASES)
    assert len(CASES) == 13


@pytest.mark.parametrize("name", sorted(CASES))
def test_real_file_is_analysed_or_refused_with_a_reason(name, capsys):
    path = REAL_DATA_DIR / name
    before = hashlib.sha256(path.read_bytes()).hexdigest()
    flags, expected = CASES[name]
    model = flags[flags.index("--model") + 1] if flags else "hertz"
    extra = flags or ["--model", model, "--tip", "sphere:5um"]
    code = main(["fit", str(path), *extra, "--json"])
    out, err = capsys.readouterr()
    if flags is None:  # refused: exit 2, one message naming what is missing
        assert code == 2, out
        assert expected in err and "Traceback" not in err
    else:
        assert code == 0, err
        info = json.loads(out)
        params = info["params"]
        value = params[expected]
        number = value["value"] if "value" in value else value["median"]
        assert number == number and number != 0  # a finite fitted value
        if model == "hertz":
            assert "E_young" in info.get("derived", info["params"])
    assert hashlib.sha256(path.read_bytes()).hexdigest() == before  # never modified
