"""Every command's ``--help`` ends with two examples; ``example:NAME`` and ``viscoforce examples``.

The examples live in one table, :data:`viscoforce.cli._examples.EXAMPLES`; each runs verbatim from
an empty folder in ``tests/cli/test_help_examples.py``. Their input files are ``example:NAME``,
the files shipped inside viscoforce, which any input path of any command may name
(:mod:`viscoforce.cli.examples`); ``viscoforce examples`` lists them and copies them.
"""

from __future__ import annotations

import json
import shlex

import pytest

from viscoforce.cli import COMMANDS, main
from viscoforce.cli._examples import EXAMPLES
from viscoforce.cli.examples import DESCRIPTIONS
from viscoforce.data import example_names, example_path


def test_every_command_has_two_examples():
    assert set(EXAMPLES) == {c.name for c in COMMANDS}
    for name, lines in EXAMPLES.items():
        assert len(lines) == 2, name
        for line in lines:
            assert all(shlex.split(part)[:2] == ["viscoforce", shlex.split(part)[1]]
                       for part in line.split("&&")), line
            assert name in [shlex.split(part)[1] for part in line.split("&&")], line


@pytest.mark.parametrize("command", [c.name for c in COMMANDS])
def test_help_ends_with_the_examples(capsys, command):
    assert main([command, "--help"]) == 0
    lines = capsys.readouterr().out.rstrip("\n").splitlines()
    assert [line.strip() for line in lines[-2:]] == list(EXAMPLES[command])


def test_help_epilog_says_what_example_means(capsys):
    assert main(["fit", "--help"]) == 0
    assert "example:NAME is a file shipped with viscoforce" in capsys.readouterr().out


# ── example:NAME on the command line ───────────────────────────────────────────────────────────

def test_an_example_name_is_read_from_any_folder(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["load", "example:sls_modulation.jpk-force", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["kind"] == "spectrum"
    # the file name alone names a file in a subfolder when it is unique
    assert main(["fit", "example:modulation-map.jpk-force-map", "--model", "prony", "--curve",
                 "0", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["model"] == "prony"


@pytest.mark.parametrize(("argv", "message"), [
    (["fit", "example:sls_spectrum", "--model", "exact", "--h0=-5nm"],
     "example:sls_spectrum: no example file of that name; did you mean "
     "example:sls_spectrum.csv? (the examples: approach_retract_trace.csv, "),
    (["fit", "example:nothing.csv", "--model", "exact", "--h0=-5nm"],
     "`viscoforce examples` lists them"),
    (["fit", "example:sls_spectrum.csv", "--model", "exact", "--h0=-5nm", "--out",
      "example:fits.nc"],
     "--out example:fits.nc: the example files are read, never written; give an output file "
     "name of your own"),
])
def test_a_wrong_example_is_a_usage_error(capsys, tmp_path, monkeypatch, argv, message):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not any(tmp_path.iterdir())


def test_example_inputs_are_resolved_in_lists_and_pairs():
    import argparse

    from viscoforce.cli.examples import resolve_example_args

    args = argparse.Namespace(data=["example:sls_spectrum.csv", "mine.csv"],
                              drag_heights=[(1e-6, "example:sls_modulation.jpk-force")],
                              folder="example:", format_="example:kept", typed_={},
                              outputs_=())
    resolve_example_args(args)
    assert args.data == [str(example_path("sls_spectrum.csv")), "mine.csv"]
    assert args.drag_heights == [(1e-6, str(example_path("sls_modulation.jpk-force")))]
    assert args.folder == str(example_path())
    assert args.format_ == "example:kept"  # internal values (a name ending in _) are left alone


# ── viscoforce examples ────────────────────────────────────────────────────────────────────────

def test_examples_lists_every_shipped_file_with_what_it_is_and_its_size(capsys):
    assert set(DESCRIPTIONS) == set(example_names())  # a new file needs its line
    assert main(["examples"]) == 0
    out = capsys.readouterr().out
    assert "example:NAME" in out
    assert "sls_spectrum.csv" in out and "1.59 kB" in out
    assert "real/modulation-map.jpk-force-map" in out and "3.07 MB" in out
    assert "notes beside them: README.md, make_examples.py, real/LICENSE, real/SOURCE.md" in out
    assert main(["examples", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["examples"]
    assert [r["name"] for r in rows] == list(example_names())
    assert all(r["bytes"] == example_path(r["name"]).stat().st_size and r["description"]
               for r in rows)


def test_examples_copy_brings_the_notes_and_never_overwrites(capsys, tmp_path):
    target = tmp_path / "mine"
    assert main(["examples", "--copy", str(target), "modulation-map.jpk-force-map"]) == 0
    copied = sorted(p.relative_to(target).as_posix() for p in target.rglob("*") if p.is_file())
    assert copied == ["README.md", "real/LICENSE", "real/SOURCE.md",
                      "real/modulation-map.jpk-force-map"]  # the licence travels with the file
    assert (target / "real/LICENSE").read_bytes() == example_path("real/LICENSE").read_bytes()
    capsys.readouterr()
    assert main(["examples", "--copy", str(target), "--json"]) == 0  # the rest; same bytes kept
    result = json.loads(capsys.readouterr().out)
    assert sorted(result["copied"]) == sorted(set(example_names()) - set(copied))
    (target / "sls_spectrum.csv").write_text("mine\n")
    assert main(["examples", "--copy", str(target)]) == 2
    err = capsys.readouterr().err
    assert "sls_spectrum.csv exists and differs from the shipped example" in err
    assert (target / "sls_spectrum.csv").read_text() == "mine\n"


@pytest.mark.parametrize(("argv", "message"), [
    (["examples", "sls_spectrum.csv"], "NAME: the names choose the files --copy copies"),
    (["examples", "--copy", "{tmp}/c", "nothing.csv"], "nothing.csv: no example file of that name"),
    (["examples", "--copy", "{tmp}/file"], "exists and is not a directory"),
])
def test_examples_refusals(capsys, tmp_path, argv, message):
    (tmp_path / "file").write_text("x")
    assert main([a.format(tmp=tmp_path) for a in argv]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "c").exists()
