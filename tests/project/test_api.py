"""Public API hygiene: names, docstrings, README snippet, import layers."""

from __future__ import annotations

import inspect
import re
import shutil
import subprocess

import pytest

import viscoforce as vf
from tests.conftest import REPO


def test_public_names_have_numpydoc_docstrings():
    for name in vf.__all__:
        if name.startswith("__"):
            continue
        obj = getattr(vf, name)
        assert inspect.getdoc(obj), f"{name} has no docstring"


def test_public_function_parameters_are_documented():
    for func in (vf.static_equilibrium, vf.default_grid):
        doc = inspect.getdoc(func)
        for param in inspect.signature(func).parameters:
            assert re.search(rf"\b{param}\b", doc), f"{func.__name__}: '{param}' undocumented"


@pytest.mark.skipif(shutil.which("lint-imports") is None, reason="import-linter not installed")
def test_import_layers_hold():
    proc = subprocess.run(["lint-imports"], cwd=REPO, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-2000:]


def test_top_level_entry_points_are_complete():
    """The quickstart's names live at the top level. That lmfit/matplotlib/distributed load only
    on use is checked in a fresh interpreter by tests/project/test_install_weight.py."""
    missing = [n for n in vf.__all__ if getattr(vf, n, None) is None]
    assert not missing, missing
    assert "fit_spectrum" in dir(vf)


def test_readme_quickstart_is_top_level_and_short():
    """The README's Python block uses top-level names only and stays short; it runs, from an empty
    folder in a fresh interpreter, and prints τ back, in tests/project/test_readme_commands.py
    (which also checks its τ and static force)."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    block = re.search(r"## Python\n\n```python\n(.*?)```", (root / "README.md").read_text(),
                      re.S).group(1)
    assert "from viscoforce." not in block and len(block.splitlines()) <= 30


def test_the_particle_and_the_rigid_sphere_tip_are_named_apart():
    """Issue 36 item 5: one class per name; the earlier name ``Sphere`` still works for both."""
    import viscoforce as vf
    from viscoforce.physics import tips

    assert vf.Particle.__name__ == "Particle" and tips.RigidSphere.__name__ == "RigidSphere"
    assert vf.Sphere is vf.Particle and tips.Sphere is tips.RigidSphere
    assert tips.tip_from("sphere:5um") == tips.RigidSphere(5e-6)
