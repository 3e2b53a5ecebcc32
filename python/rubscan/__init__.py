"""rubscan from Python: plan, run and read critical-speed scans of a bladed impeller rubbing
inside a flexible casing (Batailly & Legrand 2015).

Every function takes a sweep spec as a path to its JSON file, as a dict (relative model paths
in it are read from ``base_dir``, default the current folder), or as a :class:`Spec` already
loaded. A bad spec raises :class:`SpecError` naming the JSON pointer and the reason, before
anything runs or is written. Units are SI (m, kg, s, N, Pa, rad/s) unless a column name says
otherwise. Tables come from the Rust library as Arrow and are returned as pandas (default),
polars (``frame="polars"``) or pyarrow (``frame="arrow"``).

Long calls release the GIL. Ctrl-C (``KeyboardInterrupt``) stops a sweep cleanly: no new job
starts, finished jobs are kept, and running the same spec again resumes.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Union

import pyarrow as pa
import pyarrow.parquet as pq

from . import _native
from ._native import RubscanError, Spec, SpecError

__all__ = [
    "RubscanError",
    "Simulation",
    "Spec",
    "SpecError",
    "Stability",
    "campbell",
    "load_spec",
    "plan",
    "read_results",
    "read_series",
    "report",
    "run",
    "simulate",
    "stability",
]

__version__: str = _native.version()

SpecLike = Union[str, "os.PathLike[str]", Mapping[str, Any], Spec]
"""A sweep spec: a JSON file's path, a dict, or a loaded :class:`Spec`."""

Frame = Literal["pandas", "polars", "arrow"]
"""Which kind of table a function returns."""


def load_spec(spec: SpecLike, base_dir: str | os.PathLike[str] | None = None) -> Spec:
    """Loads and checks a sweep spec (schema and semantic rules, not yet its models).

    ``spec`` is a path, a dict or a :class:`Spec` (returned as is). Relative paths inside a
    file are read from the file's folder; inside a dict, from ``base_dir`` (default: the
    current folder). Raises :class:`SpecError` with ``pointer`` and ``reason``.
    """
    if isinstance(spec, Spec):
        return spec
    if isinstance(spec, Mapping):
        base = Path.cwd() if base_dir is None else Path(base_dir)
        return Spec.from_json(json.dumps(spec), str(base))
    if isinstance(spec, (str, os.PathLike)):
        return Spec.from_path(os.fspath(spec))
    raise TypeError(f"spec: expected a path, a dict or a rubscan.Spec, got {type(spec).__name__}")


def _frame(table: pa.Table | pa.RecordBatch, frame: Frame) -> Any:
    if frame == "arrow":
        return table if isinstance(table, pa.Table) else pa.Table.from_batches([table])
    if frame == "pandas":
        # One block per column: no consolidation copy (a 10⁶-row series converts in about
        # a third of the time).
        return table.to_pandas(split_blocks=True)
    if frame == "polars":
        import polars

        return polars.from_arrow(table)
    raise ValueError(f"frame: expected 'pandas', 'polars' or 'arrow', got {frame!r}")


def plan(spec: SpecLike, *, frame: Frame = "pandas") -> Any:
    """The jobs of a sweep, after checking the whole spec with its models as :func:`run` does.

    One row per job, with the results table's parameter columns: ``job_index``, ``job_id``,
    ``speed_rad_s``, ``friction``, ``clearance_m`` (null: the model's own), the coating's
    ``coating_*`` (absolute value or scale on the nominal one) and ``refinement_round``.
    """
    return _frame(_native.plan(load_spec(spec)), frame)


def _tqdm_progress() -> Callable[[int, int, int], None] | None:
    """A tqdm bar over the sweep's jobs (a widget in a notebook), or None without tqdm."""
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    bar: Any = None

    def update(finished: int, queued: int, _steps: int) -> None:
        nonlocal bar
        if queued == 0:
            return
        if bar is None:
            bar = tqdm(total=queued, unit="job", desc="rubscan")
        if bar.total != queued:
            bar.total = queued
            bar.refresh()
        if finished > bar.n:
            bar.update(finished - bar.n)
        if finished >= queued:
            bar.close()

    return update


def run(
    spec: SpecLike,
    *,
    threads: int | None = None,
    output_dir: str | os.PathLike[str] | None = None,
    retry_failed: bool = False,
    timeseries: bool = False,
    progress: bool | Callable[[int, int, int], None] | None = None,
    frame: Frame = "pandas",
) -> Any:
    """Runs (or resumes) a sweep and returns its results table (``results.parquet``: one row
    per job, SI units in the column names, e.g. ``speed_rad_s``, ``max_blade_le_radial_m``,
    ``max_contact_normal_force_n``, and in each column's metadata).

    ``threads``: workers, None or 0 for every core. ``output_dir``: default
    ``results/<name>`` under the current folder. ``retry_failed`` re-runs failed jobs;
    ``timeseries`` also stores each job's series. ``progress``: True for a tqdm bar (the
    default when tqdm is installed), False for none, or a callable
    ``progress(jobs_finished, jobs_queued, steps_done)`` called about ten times a second.

    Jobs that fail do not raise: the table says which (``status``, ``error``) and a
    ``RuntimeWarning`` counts them. Ctrl-C raises ``KeyboardInterrupt`` once the finished
    jobs are written.
    """
    loaded = load_spec(spec)
    if progress is None or progress is True:
        callback = _tqdm_progress()
    elif progress is False:
        callback = None
    else:
        callback = progress
    summary = _native.run(
        loaded,
        threads=threads,
        output_dir=None if output_dir is None else os.fspath(output_dir),
        retry_failed=retry_failed,
        timeseries=timeseries,
        progress=callback,
    )
    if summary["failed"]:
        warnings.warn(
            f"{summary['failed']} of {summary['planned']} jobs failed; see the table's "
            f"status and error columns",
            RuntimeWarning,
            stacklevel=2,
        )
    return _frame(pq.read_table(summary["results_path"]), frame)


def read_results(results_dir: str | os.PathLike[str], *, frame: Frame = "pandas") -> Any:
    """The results table of a sweep's output folder (``results.parquet``; units in the
    column names and in the file's metadata)."""
    path = Path(results_dir) / "results.parquet"
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no results table (run the sweep first)")
    return _frame(pq.read_table(path), frame)


def read_series(path: str | os.PathLike[str], *, frame: Frame = "pandas") -> Any:
    """A time series written by :func:`simulate` or by a run with ``timeseries=True``
    (``time_s`` and one column per quantity, its unit in its name)."""
    return _frame(pq.read_table(path), frame)


@dataclass(frozen=True)
class Simulation:
    """One job's result: what ``rubscan simulate`` writes."""

    directory: Path
    """The folder holding ``summary.json`` and ``timeseries.parquet``."""
    summary: dict[str, Any]
    """``summary.json``: the job's case, step, outcome, maxima (SI units) and probe figures."""
    series: Any
    """``timeseries.parquet`` as the requested frame (``time_s`` and one column per quantity)."""


def simulate(
    spec: SpecLike,
    job: int = 0,
    *,
    output_dir: str | os.PathLike[str] | None = None,
    frame: Frame = "pandas",
) -> Simulation:
    """Runs job ``job`` of a sweep's plan, as ``rubscan simulate`` does, writing
    ``summary.json`` and ``timeseries.parquet`` to ``output_dir`` (default
    ``results/<name>/simulate-<job>``), and returns both."""
    directory = Path(
        _native.simulate(
            load_spec(spec), job, None if output_dir is None else os.fspath(output_dir)
        )
    )
    summary = json.loads((directory / "summary.json").read_text())
    return Simulation(directory, summary, read_series(directory / "timeseries.parquet", frame=frame))


def campbell(spec: SpecLike, *, frame: Frame = "pandas") -> Any:
    """The linear interaction criterion's critical speeds of a sweep's models: one row per
    coincidence with ``speed_rad_s``, ``speed_rpm``, ``nodal_diameter`` and the mode shapes'
    ``compatibility`` in [0, 1]. The flexible casing's critical wave speed (rad/s, nodal
    diameter), or None, is in the table's ``attrs["critical_wave_speed"]`` (pandas) or
    schema metadata (arrow)."""
    batch, wave = _native.critical_speeds(load_spec(spec))
    table = pa.Table.from_batches([batch]).replace_schema_metadata(
        {"critical_wave_speed": json.dumps(wave)}
    )
    out = _frame(table, frame)
    if frame == "pandas":
        out.attrs["critical_wave_speed"] = wave
    return out


@dataclass(frozen=True)
class Stability:
    """The linear stability prediction of a persistent rub over a speed range."""

    table: Any
    """One row per (friction, speed): ``stable``, and the most unstable wave's
    ``growth_rate_per_s``, ``frequency_hz``, ``nodal_diameter``, ``impeller_nodal_diameter``
    and ``wave`` (forward or backward)."""
    onset_rad_s: dict[float, float | None]
    """Per friction coefficient, the lowest speed at which a wave grows (None: none in range)."""
    critical_wave_speed: tuple[float, int] | None
    """The flexible casing's critical wave speed min_k ω_k/k (rad/s) and its nodal diameter."""
    interaction_rad_s: list[tuple[float, int]]
    """The interaction criterion's Ω*_n (rad/s) in the range, with n."""


def stability(
    spec: SpecLike,
    *,
    from_rad_s: float | None = None,
    to_rad_s: float | None = None,
    count: int = 41,
    frame: Frame = "pandas",
) -> Stability:
    """The linear stability of a persistent rub (``rubscan stability``) over ``count`` speeds
    from ``from_rad_s`` (default 0.8 × the grid's lowest) to ``to_rad_s`` (default 1.2 × its
    highest), for each friction coefficient of the grid."""
    batch, info = _native.stability(
        load_spec(spec), from_rad_s=from_rad_s, to_rad_s=to_rad_s, count=count
    )
    return Stability(
        table=_frame(batch, frame),
        onset_rad_s=info["onset_rad_s"],
        critical_wave_speed=info["critical_wave_speed"],
        interaction_rad_s=info["interaction_rad_s"],
    )


def report(
    results_dir: str | os.PathLike[str],
    *,
    output_dir: str | os.PathLike[str] | None = None,
    jobs: list[int] | None = None,
    max_jobs: int = _native.DEFAULT_REPORT_JOBS,
) -> Path:
    """Writes the report of a sweep's output folder (figures and ``index.html``, in
    ``output_dir``, default ``<results_dir>/report``) and returns the path of ``index.html``.
    ``jobs``: job indices to overlay; default: up to ``max_jobs`` chosen as the CLI does."""
    return Path(
        _native.report(
            os.fspath(results_dir),
            output_dir=None if output_dir is None else os.fspath(output_dir),
            jobs=jobs,
            max_jobs=max_jobs,
        )
    )
