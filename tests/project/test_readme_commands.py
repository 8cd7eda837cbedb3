"""Every command the README shows runs from an empty folder (issue 38 items 4 and 5).

What is extracted, and the skip rule:

- **Shell commands**: every line of the README's fenced ```` ```bash ````, ```` ```sh ```` and
  ```` ```console ```` blocks. Blank lines and ``#`` comments are skipped; in a ``console`` block
  only lines starting with ``$ `` are commands (the rest is shown output). A line starting with
  ``pip install`` is **skipped**: it installs the package, which the suite runs inside already,
  and the README's test command (``pip install ".[test]" && ... python -m pytest -q``) is such a
  line — CI runs it verbatim (``.ci/run``, checked below), running it here would recurse. Every
  other line is one command (no ``&&``, pipes or redirections: a README line a user copies must
  work on its own), run with the current venv's ``viscoforce`` entry point (``python`` is the
  current interpreter) from an empty ``tmp_path``, and must exit 0.
- **Python blocks**: every ```` ```python ```` block runs as a file in a fresh interpreter from an
  empty ``tmp_path``; it must exit 0 and print no ``nan`` (a NaN where the README promises a value
  or a stderr is a bug, not an example).

Also: the README starts with the two set-up commands, the second exactly what ``.ci/run`` runs;
no user-facing page points to files users do not have; every relative link resolves.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
README = (REPO / "README.md").read_text(encoding="utf-8")
SHELL_LANGUAGES = {"bash", "sh", "console"}
FENCE = re.compile(r"^```([\w-]*)\n(.*?)^```", re.M | re.S)
TEST_COMMAND = 'pip install ".[test]" && OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 python -m pytest -q'
#: the user-facing pages (docs/architecture.md is for contributors)
PAGES = [REPO / "README.md", *sorted(p for p in (REPO / "docs").glob("*.md")
                                      if p.name != "architecture.md")]


def _blocks(languages: set[str]) -> list[tuple[str, str]]:
    return [(m.group(1), m.group(2)) for m in FENCE.finditer(README) if m.group(1) in languages]


def shell_commands() -> list[str]:
    """The README's shell command lines, minus the skipped ones (module docstring)."""
    commands = []
    for language, body in _blocks(SHELL_LANGUAGES):
        for line in body.splitlines():
            line = line.strip()
            if language == "console":
                if not line.startswith("$ "):
                    continue
                line = line[2:].strip()
            if not line or line.startswith("#") or line.startswith("pip install"):
                continue
            commands.append(line)
    return commands


def python_blocks() -> list[str]:
    return [body for _, body in _blocks({"python"})]


def _env() -> dict[str, str]:
    return {**os.environ, "MPLBACKEND": "Agg", "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}


def _entry_point(name: str) -> str:
    """The current venv's console script ``name`` (the one ``pip install .`` made)."""
    path = Path(sys.executable).parent / name
    return str(path) if path.exists() else name


def test_the_readme_starts_with_the_two_set_up_commands():
    first = FENCE.search(README)
    assert README.startswith("# viscoforce\n\n```bash\n") and first.group(1) == "bash"
    lines = first.group(2).strip().splitlines()
    assert len(lines) == 2 and lines[0].startswith("pip install . && viscoforce demo"), lines
    assert lines[1] == TEST_COMMAND
    assert TEST_COMMAND in (REPO / ".ci" / "run").read_text(encoding="utf-8")


def test_the_extraction_finds_the_tour():
    """Guards the extraction itself: a changed fence style must not make the tests below vacuous."""
    commands = shell_commands()
    assert len(commands) >= 3 and all(c.startswith("viscoforce ") for c in commands), commands
    assert not any(c.startswith("pip install") for c in commands)
    assert python_blocks() and "import viscoforce" in python_blocks()[0]


@pytest.mark.parametrize("command", shell_commands())
def test_readme_command_runs_from_an_empty_folder(command, tmp_path):
    argv = shlex.split(command)
    assert not {"&&", "||", "|", ";", ">", "<"} & set(argv), f"one command per line: {command}"
    if argv[0] == "viscoforce":
        argv[0] = _entry_point("viscoforce")
    elif argv[0] == "python":
        argv[0] = sys.executable
    proc = subprocess.run(argv, cwd=tmp_path, env=_env(), capture_output=True, text=True,
                          timeout=300, check=False)
    assert proc.returncode == 0, f"{command}\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    assert not re.search(r"\bnan\b", proc.stdout, re.I), proc.stdout[-2000:]


@pytest.mark.parametrize("index", range(len(python_blocks())))
def test_readme_python_block_runs_from_an_empty_folder(index, tmp_path):
    script = tmp_path / "readme_block.py"
    script.write_text(python_blocks()[index], encoding="utf-8")
    proc = subprocess.run([sys.executable, script.name], cwd=tmp_path, env=_env(),
                          capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    assert proc.stdout.strip(), "the block prints what it computes"
    assert not re.search(r"\bnan\b", proc.stdout, re.I), proc.stdout[-2000:]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_user_pages_point_only_to_what_users_have(page):
    text = page.read_text(encoding="utf-8")
    assert "../shared" not in text and not re.search(r"\bSPEC\b|SPEC\.md", text), page.name
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", target):   # http(s), mailto
            continue
        path, _, anchor = target.partition("#")
        resolved = (page.parent / path) if path else page
        assert resolved.exists(), f"{page.name}: link to {target} does not resolve"
        if anchor and resolved.suffix == ".md":
            slugs = {re.sub(r"[^\w\- ]", "", h.strip().lower()).replace(" ", "-")
                     for h in re.findall(r"^#+ (.*)$", resolved.read_text(encoding="utf-8"), re.M)}
            assert anchor in slugs, f"{page.name}: no heading #{anchor} in {resolved.name}"
