"""The package is typed: its stubs match the compiled module, and mypy --strict passes on it."""

from __future__ import annotations

import inspect
import subprocess
import sys
from pathlib import Path

import rubscan

PACKAGE = Path(rubscan.__file__).resolve().parent


def mypy(module: str, target: str) -> subprocess.CompletedProcess[str]:
    """Runs mypy's `module` (mypy or mypy.stubtest) on `target` with the package's config."""
    config = str(PACKAGE.parent / "pyproject.toml")
    flag = "--mypy-config-file" if module == "mypy.stubtest" else "--config-file"
    cmd = [sys.executable, "-m", module, flag, config, target]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=PACKAGE.parent)


def test_the_stubs_match_the_compiled_module():
    out = mypy("mypy.stubtest", "rubscan._native")
    assert out.returncode == 0, out.stdout + out.stderr


def test_the_package_passes_mypy_strict():
    out = mypy("mypy", str(PACKAGE))
    assert out.returncode == 0, out.stdout + out.stderr


def test_every_public_function_has_a_docstring_with_units_where_it_returns_quantities():
    for name in rubscan.__all__:
        obj = getattr(rubscan, name)
        assert inspect.getdoc(obj), f"rubscan.{name} has no docstring"
    for name in ("campbell", "stability", "run", "plan"):
        doc = inspect.getdoc(getattr(rubscan, name)) or ""
        assert "rad/s" in doc or "rad_s" in doc, f"rubscan.{name}'s docstring states no unit"
