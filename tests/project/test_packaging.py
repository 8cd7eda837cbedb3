"""Issue 23 items 1-2: the wheel carries the data, the licences and py.typed; the metadata lasts.

No network: the wheel is built from a copy of the sources by the build backend's PEP 517 hook in
this environment (no build isolation), so it needs the backend of ``[build-system]`` here (the test
extra installs it).
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from importlib import resources
from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as installed_version

import pytest

import viscoforce
from tests.conftest import REPO
from viscoforce.data import example_names

PYPROJECT = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
PROJECT = PYPROJECT["project"]
#: The backend floor: PEP 639 (license expression, license-files) without deprecation warnings.
SETUPTOOLS_FLOOR = (77, 0, 3)


def _release(text: str) -> tuple[int, ...]:
    return tuple(int(part) for part in re.findall(r"\d+", text)[:3])


def test_license_is_an_spdx_expression_and_its_files_exist():
    assert PROJECT["license"] == "MIT"
    assert "License ::" not in " ".join(PROJECT["classifiers"])  # the SPDX expression says it
    for name in PROJECT["license-files"]:
        assert (REPO / name).is_file(), name
    text = (REPO / "LICENSE").read_text(encoding="utf-8")
    assert text.startswith("MIT License\n\nCopyright (c) 2026 viscoforce developers\n")
    assert "src/viscoforce/data/examples/real/LICENSE" in PROJECT["license-files"]
    requires = " ".join(PYPROJECT["build-system"]["requires"])
    assert _release(re.search(r"setuptools>=([\d.]+)", requires).group(1)) >= SETUPTOOLS_FLOOR


def test_one_version_source():
    assert "version" in PROJECT["dynamic"] and "version" not in PROJECT
    assert PYPROJECT["tool"]["setuptools"]["dynamic"]["version"] == {
        "attr": "viscoforce.__version__"}
    cff = (REPO / "CITATION.cff").read_text(encoding="utf-8")
    assert re.search(r'^version: "([^"]+)"$', cff, re.M).group(1) == viscoforce.__version__
    changelog = (REPO / "CHANGELOG.md").read_text(encoding="utf-8")
    assert "## [Unreleased]" in changelog
    assert re.search(rf"^## \[{re.escape(viscoforce.__version__)}\] - \d{{4}}-\d{{2}}-\d{{2}}$",
                     changelog, re.M)


def test_citation_names_the_software_and_the_paper():
    cff = (REPO / "CITATION.cff").read_text(encoding="utf-8")
    for key in ("cff-version: 1.2.0", "message:", "title:", "authors:", "license: MIT",
                'date-released: "2026-12-03"', "references:",
                "Interaction and deformation of viscoelastic particles: Nonadhesive particles"):
        assert key in cff, key


def test_classifiers_match_requires_python():
    floor = _release(PROJECT["requires-python"].removeprefix(">="))
    versions = [tuple(int(p) for p in c.rsplit(":: ", 1)[1].split("."))
                for c in PROJECT["classifiers"] if re.fullmatch(r"Programming Language :: "
                                                                r"Python :: 3\.\d+", c)]
    assert versions and min(versions) == floor[:2], versions
    assert {"Intended Audience :: Science/Research", "Operating System :: OS Independent",
            "Topic :: Scientific/Engineering :: Physics"} <= set(PROJECT["classifiers"])
    assert {"Homepage", "Documentation", "Issues"} <= set(PROJECT["urls"])
    assert PROJECT["authors"] == [{"name": "viscoforce developers"}]


def test_the_package_is_typed():
    assert resources.files("viscoforce").joinpath("py.typed").is_file()


def _backend_ready() -> bool:
    try:
        return _release(installed_version("setuptools")) >= SETUPTOOLS_FLOOR
    except PackageNotFoundError:
        return False


@pytest.mark.skipif(not _backend_ready(), reason="the build backend (setuptools>=77.0.3) is not "
                    "installed here: pip install 'setuptools>=77.0.3' (the test extra has it)")
def test_the_wheel_carries_the_data_the_licences_and_py_typed(tmp_path):
    source = tmp_path / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / name, source / name)
    shutil.copytree(REPO / "src", source / "src",
                    ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    # the PEP 517 hook itself (what pip or build call, without pip: uv's venvs have none)
    build = ("import sys; from setuptools import build_meta; "
             "print(build_meta.build_wheel(sys.argv[1]))")
    proc = subprocess.run([sys.executable, "-W", "always", "-c", build, str(tmp_path / "dist")],
                          cwd=source, capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    log = proc.stdout + proc.stderr
    assert "SetuptoolsDeprecationWarning" not in log and "is absent from the" not in log
    (wheel,) = (tmp_path / "dist").glob("viscoforce-*.whl")
    assert wheel.name == f"viscoforce-{viscoforce.__version__}-py3-none-any.whl"
    assert wheel.stat().st_size < 5_000_000  # the 3 MB real map is the bulk
    with zipfile.ZipFile(wheel) as archive:
        names = set(archive.namelist())
        dist_info = f"viscoforce-{viscoforce.__version__}.dist-info"
        metadata = archive.read(f"{dist_info}/METADATA").decode()
    for name in example_names():
        assert f"viscoforce/data/examples/{name}" in names, name
    assert "viscoforce/py.typed" in names
    assert f"{dist_info}/licenses/LICENSE" in names
    assert f"{dist_info}/licenses/src/viscoforce/data/examples/real/LICENSE" in names
    assert not [n for n in names if "__pycache__" in n or n.endswith(".pyc")]
    assert "License-Expression: MIT" in metadata
    assert f"Version: {viscoforce.__version__}" in metadata
    assert "Project-URL: Issues, " in metadata
