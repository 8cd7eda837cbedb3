"""Execute the notebooks in ``notebooks/`` in full mode and write their outputs in place.

Usage::

    python notebooks/execute.py                  # every notebook, outputs written into the .ipynb
    python notebooks/execute.py quickstart.ipynb # only the named ones
    python notebooks/execute.py --check          # run them, write nothing; exit 1 if any fails

The kernel is ``python3`` and runs with ``notebooks/`` as working directory (as the test suite
and nbmake do); ``VISCOFORCE_NB_QUICK`` is removed from the kernel's environment, so each notebook
uses its full settings. Volatile metadata (per-cell execution timestamps) is not recorded, so a
re-run changes only what the outputs themselves change. This script regenerates what readers see.

The test suite runs the notebooks in quick mode (``VISCOFORCE_NB_QUICK=1``,
tests/project/test_notebooks.py) and compares each code cell's text outputs, normalised by
:func:`normalised_outputs`, with a reference:

- an untagged cell must print what the committed notebook shows (its output does not depend on
  the mode);
- a cell tagged ``quick-mode-differs`` must print what ``quick_outputs.json`` holds, the
  normalised outputs of a quick run that this script writes after the full run;
- a cell tagged ``timings`` (wall-clock tables) is not compared.

So a change that moves a notebook's output fails the suite until this script is run again (and
the notebook's prose is checked against the new outputs).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from pathlib import Path

NOTEBOOKS_DIR = Path(__file__).resolve().parent
QUICK_OUTPUTS = NOTEBOOKS_DIR / "quick_outputs.json"
QUICK_TAG, TIMINGS_TAG = "quick-mode-differs", "timings"

_PATH = re.compile(r"(?<![\w.])/(?:[\w.+-]+/)+[\w.+-]*")          # an absolute path
_TIME = re.compile(r"(?<![\w.])\d+(?:\.\d+)?\s?(?:ms|s)\b")       # a wall time: 16.4 s, 3 ms
_NUMBER = re.compile(r"(?<![\w.])(\d+\.\d*(?:[eE][-+]?\d+)?|\d+[eE][-+]?\d+)")


def normalise(text: str) -> str:
    """``text`` with paths and wall times masked, floats to 3 significant digits, spaces collapsed."""
    text = _TIME.sub("<time>", _PATH.sub("<path>", text))
    text = _NUMBER.sub(lambda m: f"{float(m.group(1)):.3g}", text)
    return " ".join(text.split())


def normalised_outputs(notebook) -> list[list[str]]:
    """Per code cell, its stream and ``text/plain`` outputs, each :func:`normalise`-d.

    ``notebook`` is a parsed notebook (``nbformat`` node or the plain JSON dict).
    """
    cells = []
    for cell in notebook["cells"]:
        if cell["cell_type"] != "code":
            continue
        # A kernel splits one stream into several outputs as its flushes fall (load-dependent):
        # consecutive outputs of one stream are joined before they are compared.
        parts: list[tuple[str | None, str]] = []
        for output in cell["outputs"]:
            if output["output_type"] == "stream":
                name, text = output["name"], _text(output["text"])
                if parts and parts[-1][0] == name:
                    parts[-1] = (name, parts[-1][1] + text)
                else:
                    parts.append((name, text))
            elif "text/plain" in output.get("data", {}):
                parts.append((None, _text(output["data"]["text/plain"])))
        cells.append([normalise(text) if name is None else f"{name}: {normalise(text)}"
                      for name, text in parts])
    return cells


def cell_tags(notebook) -> list[set[str]]:
    """Per code cell, its metadata tags."""
    return [set(cell["metadata"].get("tags", [])) for cell in notebook["cells"]
            if cell["cell_type"] == "code"]


def quick_reference(notebook) -> dict[str, list[str]]:
    """The normalised outputs of the cells tagged ``quick-mode-differs``, by code-cell index."""
    outputs, tags = normalised_outputs(notebook), cell_tags(notebook)
    return {str(i): out for i, (out, tag) in enumerate(zip(outputs, tags, strict=True))
            if QUICK_TAG in tag and TIMINGS_TAG not in tag}


def _text(value) -> str:
    return "".join(value) if isinstance(value, list) else value


def execute(path: Path, *, write: bool, quick: bool = False):
    """Execute the notebook at ``path``; with ``write``, save it with its outputs in place.

    With ``quick`` the kernel runs with ``VISCOFORCE_NB_QUICK=1`` (and nothing is written).
    Returns the executed notebook. Raises ``nbclient.exceptions.CellExecutionError`` (naming
    the cell) if a cell fails.
    """
    import nbclient
    import nbformat

    if quick:
        os.environ["VISCOFORCE_NB_QUICK"] = "1"   # the kernel inherits this environment
    else:
        os.environ.pop("VISCOFORCE_NB_QUICK", None)
    notebook = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=None, startup_timeout=600,
                                     kernel_name="python3", record_timing=False,
                                     resources={"metadata": {"path": str(NOTEBOOKS_DIR)}})
    client.execute()
    for cell in notebook.cells:
        cell.metadata.pop("execution", None)   # timestamps, should an older nbclient add them
    os.environ.pop("VISCOFORCE_NB_QUICK", None)
    if write and not quick:
        nbformat.write(notebook, path)
    return notebook


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return 0 when every notebook ran, 1 otherwise."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("notebooks", nargs="*",
                        help="notebook file names in notebooks/ (default: all *.ipynb)")
    parser.add_argument("--check", action="store_true",
                        help="execute without writing the outputs; exit 1 if any notebook fails")
    args = parser.parse_args(argv)
    names = args.notebooks or sorted(p.name for p in NOTEBOOKS_DIR.glob("*.ipynb"))
    failed = []
    reference = json.loads(QUICK_OUTPUTS.read_text(encoding="utf-8")) if QUICK_OUTPUTS.exists() else {}
    for name in names:
        path = NOTEBOOKS_DIR / Path(name).name
        start = time.perf_counter()
        try:
            execute(path, write=not args.check)
            if not args.check:   # the reference of the test suite's quick run
                reference[path.name] = quick_reference(execute(path, write=False, quick=True))
        except Exception as error:   # a failing cell: report it, go on with the other notebooks
            failed.append(name)
            print(f"FAILED {name}: {error}", file=sys.stderr)
            continue
        size = path.stat().st_size / 1e6
        print(f"ok {name}: {time.perf_counter() - start:.0f} s, {size:.2f} MB")
    if not args.check:
        QUICK_OUTPUTS.write_text(json.dumps(dict(sorted(reference.items())), indent=1,
                                            ensure_ascii=False) + "\n", encoding="utf-8")
    if failed:
        print(f"{len(failed)} notebook(s) failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
