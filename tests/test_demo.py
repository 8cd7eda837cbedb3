"""``viscoforce demo`` (issue 14 item 1): runs on the bundled data, recovers the synthetic truth."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

from viscoforce.cli import main
from viscoforce.cli.demo import REAL, SYNTHETIC, SYNTHETIC_TRUTH

EXAMPLES = Path(__file__).resolve().parents[1] / "data_examples"


def test_demo_truth_is_the_one_the_example_was_made_with():
    spec = importlib.util.spec_from_file_location("make_examples",
                                                  EXAMPLES / "make_examples.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert {k: SYNTHETIC_TRUTH[k] for k in module.TRUE_SLS} == module.TRUE_SLS
    assert SYNTHETIC_TRUTH["h0"] == module.H0


@pytest.mark.skipif(not (EXAMPLES / SYNTHETIC).is_file() or not (EXAMPLES / REAL).is_file(),
                    reason="bundled example data missing")
def test_demo_writes_its_figures_and_recovers_the_truth(tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["demo", "--out", str(out), "--data", str(EXAMPLES)]) == 0
    text = capsys.readouterr().out
    assert "chose 1 mode(s)" in text and "tip radius 10 µm assumed" in text
    for name in ("bode_synthetic.png", "loop.png", "bode_real.png"):
        assert (out / name).stat().st_size > 10_000
    report = json.loads((out / "demo.json").read_text())
    for name in ("E0", "E_inf", "tau"):
        value, err = report["synthetic"][name]
        assert abs(value - SYNTHETIC_TRUTH[name]) < 4 * err, name
    real = report["real"]
    assert real["candidate"] in real["explanation"]  # the chooser kept one and said why
    assert 0.0 <= real["chi2_pvalue"] <= 1.0 and real["redchi"] > 0
    assert "chi-square p-value" in text and "candidate sls" in text
    assert real["map"]["n_fits"] == 16
    assert real["map"]["n_good"] + sum(real["map"]["left_out"].values()) == 16
