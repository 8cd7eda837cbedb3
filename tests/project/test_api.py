"""Public API hygiene: names, docstrings, README snippet, import layers."""

from __future__ import annotations

import inspect
import re
import shutil
import subprocess
import sys

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


def test_import_has_no_side_effects_on_threads_or_matplotlib():
    code = ("import os, sys; import viscoforce, viscoforce.plotting; "
            "assert 'matplotlib' not in sys.modules; "
            "assert 'OPENBLAS_NUM_THREADS' not in os.environ")
    env = {k: v for k, v in __import__("os").environ.items() if not k.endswith("NUM_THREADS")}
    subprocess.run([sys.executable, "-c", code], check=True, env=env)


@pytest.mark.skipif(shutil.which("lint-imports") is None, reason="import-linter not installed")
def test_import_layers_hold():
    proc = subprocess.run(["lint-imports"], cwd=REPO, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-2000:]


def test_top_level_entry_points_are_lazy_and_complete():
    """The quickstart's names live at the top level; lmfit/matplotlib load only on use."""
    import subprocess
    import sys

    code = ("import sys, viscoforce as vf; heavy = [m for m in ('lmfit', 'matplotlib', "
            "'distributed') if m in sys.modules]; assert not heavy, heavy; "
            "missing = [n for n in vf.__all__ if getattr(vf, n, None) is None]; "
            "assert not missing, missing; assert 'fit_spectrum' in dir(vf)")
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.filterwarnings("ignore:the model does not describe these data:"
                            "viscoforce.exceptions.GoodnessOfFitWarning")
def test_readme_quickstart_runs(tmp_path, monkeypatch):
    """The README's Python block runs as written (top-level names only) and prints τ back."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    block = re.search(r"## Python\n\n```python\n(.*?)```", (root / "README.md").read_text(),
                      re.S).group(1)
    assert "from viscoforce." not in block and len(block.splitlines()) <= 30
    monkeypatch.chdir(root)
    block = block.replace('savefig("loop.png")', f'savefig(r"{tmp_path / "loop.png"}")')
    block = block.replace('savefig("bode.png")', f'savefig(r"{tmp_path / "bode.png"}")')
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)  # noqa: S102
    assert abs(float(namespace["fit"].tau) - 1e-3) < 1e-9
    assert float(namespace["static"].force) == pytest.approx(1.08e-6, abs=5e-9)
    assert (tmp_path / "bode.png").stat().st_size > 0


def test_the_particle_and_the_rigid_sphere_tip_are_named_apart():
    """Issue 36 item 5: one class per name; the earlier name ``Sphere`` still works for both."""
    import viscoforce as vf
    from viscoforce.physics import tips

    assert vf.Particle.__name__ == "Particle" and tips.RigidSphere.__name__ == "RigidSphere"
    assert vf.Sphere is vf.Particle and tips.Sphere is tips.RigidSphere
    assert tips.tip_from("sphere:5um") == tips.RigidSphere(5e-6)
