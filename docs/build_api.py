"""Build the API reference (HTML, from the numpydoc docstrings) into ``docs/api/`` with pdoc.

Usage::

    python docs/build_api.py [--out DIR]      # default docs/api/; open DIR/index.html

Needs ``pdoc`` (in the test extras) and no network. Every public module of ``viscoforce`` is
documented: pdoc follows a package's ``__all__``, which lists names rather than submodules, so
the modules are walked here and named explicitly. Private modules (``_name``) are left out.
The output is not committed (``docs/api/`` is in .gitignore).
"""

from __future__ import annotations

import argparse
import pkgutil
import sys
import warnings
from pathlib import Path

DEFAULT_OUT = Path(__file__).resolve().parent / "api"


def module_specs() -> list[str]:
    """The public modules of viscoforce, each once, and ``!private`` exclusions, as pdoc specs."""
    import pdoc.extract

    import viscoforce

    names = ["viscoforce"] + [
        info.name for info in pkgutil.walk_packages(viscoforce.__path__, "viscoforce.")]
    specs: list[str] = []
    covered: set[str] = set()
    for name in names:   # a package without __all__ already brings its submodules: name them once
        if any(part.startswith("_") for part in name.split(".")):
            specs.append(f"!{name}")   # pdoc's exclusion spec: private modules stay out
        elif name not in covered:
            specs.append(name)
            covered.update(pdoc.extract.walk_specs([name]))
    return specs


def build(out: Path, *, show_source: bool = True, search: bool = True) -> Path:
    """Write the HTML reference of viscoforce into ``out``; return the path of its index.

    Parameters
    ----------
    out : Path
        Output folder (created if missing).
    show_source : bool
        Give every function and class its highlighted source ("View Source"); about half of
        the build time.
    search : bool
        Write the search index (``search.js``).

    Returns
    -------
    Path
        ``out / "index.html"``.
    """
    import pdoc
    import pdoc.render

    pdoc.render.configure(docformat="numpy", search=search, show_source=show_source)
    with warnings.catch_warnings():
        # annotations naming TYPE_CHECKING-only aliases (FloatArray) are shown as written
        warnings.filterwarnings("ignore", message="Error parsing type annotation",
                                category=UserWarning, module="pdoc")
        pdoc.pdoc(*module_specs(), output_directory=Path(out))
    return Path(out) / "index.html"


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return 0."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT,
                        help=f"output folder (default {DEFAULT_OUT})")
    args = parser.parse_args(argv)
    print(build(args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
