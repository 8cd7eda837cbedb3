"""The example files shipped inside viscoforce, found with :mod:`importlib.resources`.

They travel in the wheel, so ``viscoforce demo``, the notebooks and the README's examples run
in every folder, not only in the repository. ``examples/README.md`` says how each file was
made and its true parameters; ``examples/real/`` holds a real JPK modulation map (MIT, with its
``LICENSE`` and ``SOURCE.md``). In the repository, ``data_examples/`` is a link to the same
folder. On the command line every input file may be written ``example:NAME`` (a name of
:func:`example_names`), and ``viscoforce examples`` lists or copies them
(:mod:`viscoforce.cli.examples`).

>>> import viscoforce as vf
>>> vf.load(vf.example_path("sls_spectrum.csv"))          # doctest: +SKIP
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from viscoforce.exceptions import ParameterError, ViscoforceError

__all__ = ["example_names", "example_path"]

#: The folder of the examples inside this package.
_FOLDER = "examples"
#: Files beside the data that are not examples (the generator script's byte code).
_SKIP = ("__pycache__",)


def _folder() -> Path:
    resource = resources.files(__name__) / _FOLDER
    if not isinstance(resource, Path):
        raise ViscoforceError(
            f"viscoforce's example data is not on the file system ({resource!r}: installed "
            "inside a zip?); install viscoforce from its wheel or sdist with pip")
    return resource


def example_names() -> tuple[str, ...]:
    """Names of the shipped example files, for :func:`example_path`.

    Returns
    -------
    tuple of str
        Paths relative to the examples folder with ``/`` separators, sorted: the synthetic files
        (``sls_spectrum.csv``, ``sls_modulation.jpk-force``, ...), their ``README.md`` and
        ``make_examples.py``, and ``real/modulation-map.jpk-force-map`` with its ``LICENSE`` and
        ``SOURCE.md``.
    """
    folder = _folder()
    return tuple(sorted(
        path.relative_to(folder).as_posix() for path in folder.rglob("*")
        if path.is_file() and not any(part in _SKIP for part in path.relative_to(folder).parts)))


def example_path(name: str | None = None) -> Path:
    """Path of a shipped example file, or of the examples folder.

    Parameters
    ----------
    name : str, optional
        One of :func:`example_names`, e.g. ``"sls_spectrum.csv"`` or
        ``"real/modulation-map.jpk-force-map"``. None (the default) gives the folder itself.

    Returns
    -------
    pathlib.Path
        An absolute path inside the installed package (read the files; do not write there).

    Raises
    ------
    ParameterError
        If ``name`` is not a shipped example; the message lists the names.
    ViscoforceError
        If the package is not installed on the file system (imported from a zip).

    Examples
    --------
    >>> import viscoforce as vf
    >>> spectrum = vf.load(vf.example_path("sls_spectrum.csv"))        # doctest: +SKIP
    """
    folder = _folder()
    if name is None:
        return folder
    names = example_names()
    if name not in names:
        raise ParameterError(f"no example named {name!r}; the examples are: {', '.join(names)}")
    return folder / name
