"""Shared fixtures of the Python package's tests: the repository, the CLI binary beside the
package (both built by the README's test command, `.ci/test`), and spec helpers."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from typing import Any

import pyarrow as pa
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


def without_wall_time(table: pa.Table) -> pa.Table:
    """The table without its wall-time columns, the only ones that differ between runs."""
    return table.drop_columns([c for c in table.column_names if c.startswith("wall_time")])


def ipc_bytes(table: pa.Table) -> bytes:
    """The table's Arrow IPC stream: equal bytes mean equal schema, metadata and bits."""
    sink = pa.BufferOutputStream()
    with pa.ipc.new_stream(sink, table.schema) as writer:
        writer.write_table(table)
    return sink.getvalue().to_pybytes()


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The notebook (90 s of the two workers' ~170) starts first and the README snippet (30 s)
    ends the list: pytest-xdist hands tests out in list order, and a worker holds the test
    after the one it runs, so the README test right after the notebook ran after it on the same
    worker while the other worker ran out of tests."""
    order = {"test_the_example_notebook_runs": -1, "test_the_readme_python_snippet_runs": 1}
    items.sort(key=lambda item: order.get(item.name, 0))
