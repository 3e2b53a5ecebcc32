"""Type stubs of the compiled extension ``rubscan._native`` (python/src/lib.rs)."""

import os
from collections.abc import Callable
from typing import Any, final

import pyarrow as pa

__all__ = [
    "DEFAULT_REPORT_JOBS",
    "RubscanError",
    "Spec",
    "SpecError",
    "critical_speeds",
    "plan",
    "report",
    "run",
    "simulate",
    "stability",
    "version",
]

class RubscanError(RuntimeError):
    """A rubscan command failed: a model that cannot be built or read, an I/O error, a failed
    simulation."""

class SpecError(ValueError):
    """The sweep spec is invalid."""

    issues: list[tuple[str, str]]
    """Every issue as (JSON pointer, reason); the pointer "" is the whole document."""
    pointer: str
    """The first issue's JSON pointer."""
    reason: str
    """The first issue's reason."""

@final
class Spec:
    """A sweep spec, parsed and checked against the schema and the semantic rules."""

    @staticmethod
    def from_path(path: str | os.PathLike[str]) -> Spec:
        """Reads and checks a spec file; relative model paths are read from its folder."""
    @staticmethod
    def from_json(text: str, base_dir: str | os.PathLike[str]) -> Spec:
        """Parses and checks JSON text; relative model paths are read from ``base_dir``."""
    @property
    def name(self) -> str:
        """The sweep's name (its default output folder is ``results/<name>``)."""

def plan(spec: Spec) -> pa.RecordBatch:
    """One row per job: the results table's parameter columns, job_index … refinement_round."""

def run(
    spec: Spec,
    threads: int | None = None,
    output_dir: str | os.PathLike[str] | None = None,
    retry_failed: bool = False,
    timeseries: bool = False,
    progress: Callable[[int, int, int], Any] | None = None,
) -> dict[str, Any]:
    """Runs or resumes a sweep; returns planned, ran, skipped, ok, unstable, failed,
    unfinished, cancelled, wall_time_s (s) and results_path."""

def simulate(
    spec: Spec, job: int = 0, output_dir: str | os.PathLike[str] | None = None
) -> str:
    """Runs one job, writes summary.json and timeseries.parquet; returns the folder."""

def critical_speeds(spec: Spec) -> tuple[pa.RecordBatch, tuple[float, int] | None]:
    """Critical speeds (speed_rad_s, speed_rpm, nodal_diameter, compatibility) and the
    casing's critical wave speed (rad/s, nodal diameter)."""

def stability(
    spec: Spec,
    from_rad_s: float | None = None,
    to_rad_s: float | None = None,
    count: int = 41,
) -> tuple[pa.RecordBatch, dict[str, Any]]:
    """Per (friction, speed) the most unstable wave; and onset_rad_s (per friction),
    critical_wave_speed, interaction_rad_s."""

def report(
    results: str | os.PathLike[str],
    output_dir: str | os.PathLike[str] | None = None,
    jobs: list[int] | None = None,
    max_jobs: int = ...,
) -> str:
    """Writes the report's figures and index.html; returns the path of index.html."""

DEFAULT_REPORT_JOBS: int
"""Jobs a report overlays when none is named."""

def version() -> str:
    """The rubscan library's version."""
