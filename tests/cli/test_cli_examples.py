"""Every command's ``--help`` ends with two examples, and each runs verbatim (exit 0).

The examples live in one table, :data:`viscoforce.cli._examples.EXAMPLES`; they run in a fresh
folder holding ``data_examples`` (a link to the example files shipped inside viscoforce), as from
the repository's root. ``demo``'s second example is run by ``tests/cli/test_demo.py``, which checks
its numbers.
"""

from __future__ import annotations

import shlex

import pytest

from viscoforce.cli import COMMANDS, main
from viscoforce.cli._examples import EXAMPLES
from viscoforce.data import example_path

#: (command, index) of examples another test runs verbatim.
RUN_ELSEWHERE = {("demo", 1): "tests/cli/test_demo.py"}


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


@pytest.mark.parametrize(("command", "index"), [
    pytest.param(name, i, id=f"{name}-{i}",
                 marks=[pytest.mark.skip(reason=f"run by {RUN_ELSEWHERE[name, i]}")]
                 if (name, i) in RUN_ELSEWHERE else [])
    for name in EXAMPLES for i in range(2)])
def test_example_runs_verbatim(capsys, tmp_path, monkeypatch, command, index):
    (tmp_path / "data_examples").symlink_to(example_path(), target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    for part in EXAMPLES[command][index].split("&&"):
        argv = shlex.split(part)
        assert argv[0] == "viscoforce"
        code = main(argv[1:])
        captured = capsys.readouterr()
        assert code == 0, f"{part}\n{captured.err}"
