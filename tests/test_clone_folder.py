"""The clone-folder trap that README's Troubleshooting describes: a checkout in a folder named ``pyrt``, imported
from its parent folder, is an empty namespace package; from anywhere else ``import pyrt`` is the package."""
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}


def test_import_from_the_parent_of_a_checkout_named_pyrt_is_the_namespace_readme_describes(tmp_path):
    (tmp_path / "pyrt").symlink_to(ROOT, target_is_directory=True)
    r = subprocess.run([sys.executable, "-c", "import pyrt; print(pyrt.__file__, list(pyrt.__path__)); pyrt.Error"],
                       cwd=tmp_path, env=ENV, capture_output=True, text=True, timeout=60)
    assert r.returncode != 0
    assert r.stdout.startswith(f"None ['{tmp_path / 'pyrt'}']")
    assert "module 'pyrt' has no attribute 'Error'" in r.stderr


def test_import_from_elsewhere_finds_the_package(tmp_path):
    r = subprocess.run([sys.executable, "-c", "import pyrt; print(pyrt.Error.__name__)"], cwd=tmp_path, env=ENV,
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "Error"
