"""Execute the notebooks in ``notebooks/`` in full mode and write their outputs in place.

Usage::

    python notebooks/execute.py                  # every notebook, outputs written into the .ipynb
    python notebooks/execute.py quickstart.ipynb # only the named ones
    python notebooks/execute.py --check          # run them, write nothing; exit 1 if any fails

The kernel is ``python3`` and runs with ``notebooks/`` as working directory (as the test suite
and nbmake do); ``VISCOFORCE_NB_QUICK`` is removed from the kernel's environment, so each notebook
uses its full settings. Volatile metadata (per-cell execution timestamps) is not recorded, so a
re-run changes only what the outputs themselves change. The test suite keeps running the
notebooks in quick mode (tests/project/test_notebooks.py); this script regenerates what readers see.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

NOTEBOOKS_DIR = Path(__file__).resolve().parent


def execute(path: Path, *, write: bool) -> None:
    """Execute the notebook at ``path``; with ``write``, save it with its outputs in place.

    Raises ``nbclient.exceptions.CellExecutionError`` (naming the cell) if a cell fails.
    """
    import nbclient
    import nbformat

    notebook = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(notebook, timeout=None, startup_timeout=600,
                                     kernel_name="python3", record_timing=False,
                                     resources={"metadata": {"path": str(NOTEBOOKS_DIR)}})
    client.execute()
    for cell in notebook.cells:
        cell.metadata.pop("execution", None)   # timestamps, should an older nbclient add them
    if write:
        nbformat.write(notebook, path)


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return 0 when every notebook ran, 1 otherwise."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("notebooks", nargs="*",
                        help="notebook file names in notebooks/ (default: all *.ipynb)")
    parser.add_argument("--check", action="store_true",
                        help="execute without writing the outputs; exit 1 if any notebook fails")
    args = parser.parse_args(argv)
    names = args.notebooks or sorted(p.name for p in NOTEBOOKS_DIR.glob("*.ipynb"))
    os.environ.pop("VISCOFORCE_NB_QUICK", None)   # full mode; the kernel inherits this environment
    failed = []
    for name in names:
        path = NOTEBOOKS_DIR / Path(name).name
        start = time.perf_counter()
        try:
            execute(path, write=not args.check)
        except Exception as error:   # a failing cell: report it, go on with the other notebooks
            failed.append(name)
            print(f"FAILED {name}: {error}", file=sys.stderr)
            continue
        size = path.stat().st_size / 1e6
        print(f"ok {name}: {time.perf_counter() - start:.0f} s, {size:.2f} MB")
    if failed:
        print(f"{len(failed)} notebook(s) failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
