"""Every command the README shows runs from an empty folder (issue 38 items 4 and 5).

What is extracted, and the skip rule:

- **Shell commands**: every line of the README's fenced ```` ```bash ````, ```` ```sh ```` and
  ```` ```console ```` blocks. Blank lines and ``#`` comments are skipped; in a ``console`` block
  only lines starting with ``$ `` are commands (the rest is shown output). A line starting with
  ``pip install`` is **skipped**: it installs the package, which the suite runs inside already,
  and the README's test command (``pip install ".[test]" && ... python -m pytest -q``) is such a
  line — CI runs it verbatim (``.ci/run``, checked below), running it here would recurse. Every
  other line is one command (no ``&&``, pipes or redirections: a README line a user copies must
  work on its own), run with the installed ``viscoforce`` entry point (``python`` is the current
  interpreter) from an empty folder of its own, and must exit 0.
- **Python blocks**: every ```` ```python ```` block runs as a file from an empty folder of its
  own; it must exit 0 and print no ``nan`` (a NaN where the README promises a value or a stderr
  is a bug, not an example).

All of them run in ONE separate interpreter (the ``readme_runs`` fixture, :data:`DRIVER`), not
the test's: the Python blocks first (the first one is the first thing that interpreter runs),
then each command as the console script runs it (``viscoforce``'s ``console_scripts`` entry
point, found through the installed package's metadata, called with ``sys.argv`` set), each in a
new empty folder. One interpreter start instead of one per command.

Also: the README starts with the two set-up commands, the second exactly what ``.ci/run`` runs;
no user-facing page points to files users do not have; every relative link resolves.
"""

from __future__ import annotations

import json
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


#: (variable, attribute) the first Python block (the quickstart) leaves, reported by the driver.
QUICKSTART_VALUES = [("fit", "tau"), ("static", "force")]

#: Run in a fresh interpreter: ``python -c DRIVER ROOT SPEC``; SPEC holds the blocks and the
#: commands (argv lists). Prints one JSON object: per block and per command, the exit status,
#: stdout, stderr and the files left in its folder (and, per block, QUICKSTART_VALUES).
DRIVER = r"""
import contextlib, io, json, os, runpy, subprocess, sys, traceback
from importlib.metadata import entry_points

root, spec = sys.argv[1], json.loads(sys.argv[2])


def in_folder(name, work):
    folder = os.path.join(root, name)
    os.mkdir(folder)
    os.chdir(folder)
    out, err = io.StringIO(), io.StringIO()
    extra = {}
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = work(extra)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        except BaseException:
            traceback.print_exc()
            code = 1
    files = {p: os.path.getsize(p) for p in sorted(os.listdir(folder))}
    return {"code": code or 0, "stdout": out.getvalue(), "stderr": err.getvalue(),
            "files": files, **extra}


def block(source):
    def work(extra):
        with open("readme_block.py", "w", encoding="utf-8") as handle:
            handle.write(source)
        namespace = runpy.run_path("readme_block.py", run_name="__main__")
        os.remove("readme_block.py")
        extra["values"] = {f"{var}.{attr}": float(getattr(namespace[var], attr))
                           for var, attr in spec["values"] if var in namespace}
        return 0
    return work


def command(argv):
    def work(extra):
        if argv[0] != "viscoforce":
            proc = subprocess.run([sys.executable if argv[0] == "python" else argv[0], *argv[1:]],
                                  capture_output=True, text=True)
            sys.stdout.write(proc.stdout)
            sys.stderr.write(proc.stderr)
            return proc.returncode
        (script,) = entry_points(group="console_scripts", name="viscoforce")
        sys.argv = list(argv)
        return script.load()()   # what the installed console script runs
    return work


result = {"blocks": [in_folder(f"block{i}", block(b)) for i, b in enumerate(spec["blocks"])],
          "commands": [in_folder(f"command{i}", command(c))
                       for i, c in enumerate(spec["commands"])]}
os.chdir(root)
sys.stdout.write("RESULT " + json.dumps(result) + "\n")
"""


@pytest.fixture(scope="module")
def readme_runs(tmp_path_factory):
    """What :data:`DRIVER` reports for the README's blocks and commands (module docstring)."""
    root = tmp_path_factory.mktemp("readme")
    spec = {"blocks": python_blocks(), "commands": [shlex.split(c) for c in shell_commands()],
            "values": QUICKSTART_VALUES}
    proc = subprocess.run([sys.executable, "-c", DRIVER, str(root), json.dumps(spec)], cwd=root,
                          env=_env(), capture_output=True, text=True, timeout=900, check=False)
    line = next((x for x in proc.stdout.splitlines() if x.startswith("RESULT ")), None)
    assert proc.returncode == 0 and line, proc.stdout[-2000:] + proc.stderr[-3000:]
    return json.loads(line.removeprefix("RESULT "))


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


@pytest.mark.parametrize("index, command", list(enumerate(shell_commands())),
                         ids=shell_commands())
def test_readme_command_runs_from_an_empty_folder(index, command, readme_runs):
    argv = shlex.split(command)
    assert not {"&&", "||", "|", ";", ">", "<"} & set(argv), f"one command per line: {command}"
    run = readme_runs["commands"][index]
    assert run["code"] == 0, f"{command}\n{run['stdout'][-2000:]}\n{run['stderr'][-2000:]}"
    assert not re.search(r"\bnan\b", run["stdout"], re.I), run["stdout"][-2000:]


@pytest.mark.parametrize("index", range(len(python_blocks())))
def test_readme_python_block_runs_from_an_empty_folder(index, readme_runs):
    run = readme_runs["blocks"][index]
    assert run["code"] == 0, run["stdout"][-2000:] + run["stderr"][-3000:]
    assert run["stdout"].strip(), "the block prints what it computes"
    assert not re.search(r"\bnan\b", run["stdout"], re.I), run["stdout"][-2000:]
    if index == 0:   # the quickstart (was also exec'd in tests/project/test_api.py)
        assert abs(run["values"]["fit.tau"] - 1e-3) < 1e-9
        assert run["values"]["static.force"] == pytest.approx(1.08e-6, abs=5e-9)
        assert run["files"].get("bode.png", 0) > 0 and run["files"].get("loop.png", 0) > 0


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
