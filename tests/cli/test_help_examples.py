"""Every ``--help`` example runs verbatim from an empty folder (exit 0), as a newcomer would run it.

The examples (:data:`viscoforce.cli._examples.EXAMPLES`) read the files shipped inside viscoforce
as ``example:NAME`` (:mod:`viscoforce.cli.examples`), so they need no repository around them: each
runs here in a fresh, empty ``tmp_path`` (``main()`` in-process, the current folder changed), and
one (``fit``'s first, verbatim but for ``python -m``) runs as a separate ``python -m viscoforce``
process there, and not again in-process. ``demo``'s second example is run,
from an empty folder too, by ``tests/cli/test_demo.py`` (which checks its numbers); the first,
the same run without ``--json``, is marked slow.
"""

from __future__ import annotations

import json
import shlex
import subprocess
import sys

import pytest

from viscoforce.cli import COMMANDS, main
from viscoforce.cli._examples import EXAMPLES
from viscoforce.cli.examples import PREFIX
from viscoforce.data import example_names

#: (command, index) of examples another test runs verbatim from an empty folder.
RUN_ELSEWHERE = {("demo", 1): "tests/cli/test_demo.py",
                 ("fit", 0): "test_the_example_route_works_in_a_separate_process, below"}
#: (command, index) of examples too slow for every run (another example covers the same path).
SLOW = {("demo", 0): "the demo, as demo-1 without --json (test_demo.py runs that one)"}


def _marks(name: str, i: int) -> list:
    if (name, i) in RUN_ELSEWHERE:
        return [pytest.mark.skip(reason=f"run by {RUN_ELSEWHERE[name, i]}")]
    if (name, i) in SLOW:
        return [pytest.mark.slow]
    return []


def _parts(line: str) -> list[list[str]]:
    return [shlex.split(part) for part in line.split("&&")]


@pytest.mark.parametrize(("command", "index"), [
    pytest.param(name, i, id=f"{name}-{i}", marks=_marks(name, i))
    for name in EXAMPLES for i in range(2)])
def test_help_example_runs_from_an_empty_folder(capsys, tmp_path, monkeypatch, command, index):
    monkeypatch.chdir(tmp_path)
    assert not any(tmp_path.iterdir())
    for argv in _parts(EXAMPLES[command][index]):
        assert argv[0] == "viscoforce"
        code = main(argv[1:])
        captured = capsys.readouterr()
        assert code == 0, f"{shlex.join(argv)}\n{captured.err}"


def test_every_command_has_examples_and_they_read_only_shipped_files():
    assert set(EXAMPLES) == {c.name for c in COMMANDS}
    shipped = set(example_names())
    for name, lines in EXAMPLES.items():
        for line in lines:
            assert "data_examples" not in line, line
            for argv in _parts(line):
                for token in argv:
                    value = token.split("=", 1)[-1]
                    if value.startswith(PREFIX):
                        assert value[len(PREFIX):] in shipped, (name, token)


def test_the_example_route_works_in_a_separate_process(tmp_path):
    """``python -m viscoforce`` in an empty folder, not the test's interpreter state."""
    argv = _parts(EXAMPLES["fit"][0])
    assert argv == [["viscoforce", "fit", "example:sls_spectrum.csv", "--model", "exact",
                     "--h0=-5nm", "--json"]]   # the example, run here as it is shown
    run = subprocess.run([sys.executable, "-m", *argv[0]], cwd=tmp_path, capture_output=True,
                         text=True, timeout=300, check=False)
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    assert result["model"] == "exact"
    assert result["params"]["tau"]["value"] == pytest.approx(5e-3, rel=0.05)  # the file's truth
    assert not any(tmp_path.iterdir())  # nothing written where it ran
