"""The README's "From Python" snippet runs as written, from a folder holding the shipped
sweeps, and prints what its comments say."""

from __future__ import annotations

import contextlib
import io
import os
import re
from pathlib import Path


def test_the_readme_python_snippet_runs(repo: Path, tmp_path: Path) -> None:
    readme = (repo / "README.md").read_text()
    section = readme.split("## From Python", 1)[1]
    snippet = re.search(r"```python\n(.*?)```", section, flags=re.S)
    assert snippet, "no python block in the README's From Python section"
    (tmp_path / "sweeps").symlink_to(repo / "sweeps")
    out = io.StringIO()
    cwd = Path.cwd()
    os.chdir(tmp_path)
    try:
        with contextlib.redirect_stdout(out):
            exec(compile(snippet.group(1), "README.md", "exec"), {})
    finally:
        os.chdir(cwd)
    printed = out.getvalue()
    assert "/grid/friction/0 - -0.15 is less than the minimum of 0" in printed, printed
    assert (tmp_path / "results/quickstart/results.parquet").is_file()
