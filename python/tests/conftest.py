"""Shared fixtures of the Python package's tests: the repository, the CLI binary beside the
package (both built by the README's test command, `.ci/test`), and spec helpers."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from typing import Any

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def cli() -> Path:
    """The `rubscan` binary that `cargo test` builds (RUBSCAN_BIN overrides); `.ci/test` runs
    the Rust tests first."""
    path = Path(os.environ.get("RUBSCAN_BIN", REPO / "target" / "debug" / "rubscan"))
    if not path.is_file():
        pytest.fail(f"{path}: no rubscan binary (run `cargo test --no-run` or set RUBSCAN_BIN)")
    return path


def run_cli(cli: Path, *args: str | os.PathLike[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    """Runs the CLI, failing the test with its stderr when it fails."""
    out = subprocess.run([cli, *args], cwd=cwd, capture_output=True, text=True)
    assert out.returncode == 0, f"rubscan {args} failed ({out.returncode}):\n{out.stderr}"
    return out


def spec_dict(repo: Path, name: str) -> dict[str, Any]:
    """A shipped spec as a dict (sweeps/<name>.json, else tests/data/<name>.json)."""
    for folder in ("sweeps", "tests/data"):
        path = repo / folder / f"{name}.json"
        if path.is_file():
            return json.loads(path.read_text())
    raise FileNotFoundError(name)
