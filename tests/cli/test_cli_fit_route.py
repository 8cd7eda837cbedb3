"""``fit MAP --model hertz`` on a file with modulation segments fits its force curves (issue 38
item 4: it used to refuse the spectrum without naming ``load --raw``): the same numbers as the
two-step route ``load --raw --out curves.nc`` then ``fit curves.nc``."""

from __future__ import annotations

import json

import pytest

from viscoforce.cli import main

MAP = "example:real/modulation-map.jpk-force-map"


def test_a_curve_model_on_a_modulation_map_fits_its_curves_as_load_raw_would(tmp_path, capsys):
    flags = ["--model", "hertz", "--tip", "sphere:5um", "--curve", "2", "--budget",
             "calibration", "--json"]
    assert main(["fit", MAP, *flags]) == 0
    direct = json.loads(capsys.readouterr().out)
    curves = tmp_path / "curves.nc"
    assert main(["load", MAP, "--raw", "--out", str(curves)]) == 0
    capsys.readouterr()
    assert main(["fit", str(curves), *flags]) == 0
    two_step = json.loads(capsys.readouterr().out)
    assert direct["model"] == "hertz"
    assert direct["params"]["E"]["value"] == pytest.approx(two_step["params"]["E"]["value"],
                                                           rel=1e-9)
