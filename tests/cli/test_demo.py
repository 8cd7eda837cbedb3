"""``viscoforce demo`` (issue 14 item 1): runs on the bundled data, recovers the synthetic truth."""

from __future__ import annotations

import importlib.util
import json
import shlex

import pytest

from viscoforce.cli import main
from viscoforce.cli._args import UsageError
from viscoforce.cli._examples import EXAMPLES as HELP_EXAMPLES
from viscoforce.cli.demo import REAL, SYNTHETIC, SYNTHETIC_TRUTH, find_examples
from viscoforce.data import example_path

EXAMPLES = example_path()


def test_demo_truth_is_the_one_the_example_was_made_with():
    spec = importlib.util.spec_from_file_location("make_examples",
                                                  EXAMPLES / "make_examples.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert {k: SYNTHETIC_TRUTH[k] for k in module.TRUE_SLS} == module.TRUE_SLS
    assert SYNTHETIC_TRUTH["h0"] == module.H0


def test_the_demo_finds_the_shipped_data_or_says_what_is_missing(tmp_path, capsys):
    assert find_examples() == EXAMPLES
    assert (EXAMPLES / SYNTHETIC).is_file() and (EXAMPLES / REAL).is_file()
    assert find_examples(str(EXAMPLES)) == EXAMPLES
    with pytest.raises(UsageError, match=rf"cannot find the example data in --data {tmp_path}: "
                                         rf"{SYNTHETIC}, {REAL} missing; give the folder"):
        find_examples(str(tmp_path))
    assert main(["demo", "--out", str(tmp_path / "out"), "--data", str(tmp_path)]) == 2
    assert "cannot find the example data" in capsys.readouterr().err


def test_demo_writes_its_figures_and_recovers_the_truth(tmp_path, capsys, monkeypatch):
    """From an empty folder, without --data: the copy inside the package is found."""
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "demo"
    example = HELP_EXAMPLES["demo"][1]  # the --help example, verbatim
    assert example == "viscoforce demo --out-dir demo --json"
    assert main(shlex.split(example)[1:]) == 0
    captured = capsys.readouterr()
    text = captured.err  # with --json the narrative goes to stderr, stdout is the JSON object
    assert "chose 1 mode(s)" in text and "tip radius 10 µm assumed" in text
    for name in ("bode_synthetic.png", "loop.png", "bode_real.png"):
        assert (out / name).stat().st_size > 10_000
    report = json.loads((out / "demo.json").read_text())
    printed = json.loads(captured.out)
    assert printed["out_dir"] == "demo" and "demo/demo.json" in printed["written"]
    assert printed["synthetic"]["E0"] == pytest.approx(report["synthetic"]["E0"])
    for name in ("E0", "E_inf", "tau"):
        value, err = report["synthetic"][name]
        assert abs(value - SYNTHETIC_TRUTH[name]) < 4 * err, name
    real = report["real"]
    assert real["candidate"] in real["explanation"]  # the chooser kept one and said why
    assert 0.0 <= real["chi2_pvalue"] <= 1.0 and real["redchi"] > 0
    assert "chi-square p-value" in text and "candidate sls" in text
    assert real["map"]["n_fits"] == 16
    assert real["map"]["n_good"] + sum(real["map"]["left_out"].values()) == 16
