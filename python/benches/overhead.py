"""What the Python package adds over the CLI (issue 41's speed targets), measured in one run
with the two sides alternating:

1. the quickstart sweep run by `rubscan run` (a process) and by `rubscan.run` (a call in a
   warm interpreter), each into a fresh folder: the extra wall time of the call;
2. a time series of about 10⁶ rows written by `rubscan.simulate`, read back into pandas by
   `rubscan.read_series`.

Run from the repository root after `.ci/setup` and `cargo build --release`:
    venv/bin/python python/benches/overhead.py
"""

from __future__ import annotations

import json
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import rubscan

REPO = Path(__file__).resolve().parents[2]
CLI = REPO / "target" / "release" / "rubscan"
QUICKSTART = REPO / "sweeps" / "quickstart.json"


def timed(f) -> float:
    t = time.perf_counter()
    f()
    return time.perf_counter() - t


def sweep_overhead(work: Path, rounds: int = 5) -> None:
    rubscan.run(QUICKSTART, output_dir=work / "warm", threads=2, progress=False)  # model cache, imports
    cli, py = [], []
    for i in range(rounds):
        out_cli, out_py = work / f"cli{i}", work / f"py{i}"
        cli.append(timed(lambda: subprocess.run(
            [CLI, "run", QUICKSTART, "-o", out_cli, "--threads", "2"], check=True, capture_output=True)))
        py.append(timed(lambda: rubscan.run(QUICKSTART, output_dir=out_py, threads=2, progress=False)))
    m_cli, m_py = statistics.median(cli), statistics.median(py)
    print(f"quickstart, {rounds} rounds alternating: CLI median {m_cli:.3f} s, "
          f"rubscan.run median {m_py:.3f} s, difference {m_py - m_cli:+.3f} s")


def series_to_pandas(work: Path, rows: int = 1_000_000) -> None:
    spec = json.loads(QUICKSTART.read_text())
    spec["numerics"] = {"time_step_s": 2e-7, "decimation": 1}
    spec["scenario"]["duration_s"] = rows * 2e-7
    spec["grid"]["speed"]["values"] = [3000]
    sim = rubscan.simulate(spec, output_dir=work / "series", frame="arrow")
    path = sim.directory / "timeseries.parquet"
    times = []
    for _ in range(3):
        t = time.perf_counter()
        df = rubscan.read_series(path)
        times.append(time.perf_counter() - t)
    size = path.stat().st_size / 1e6
    print(f"time series {len(df)} rows x {df.shape[1]} columns ({size:.0f} MB Parquet) to pandas: "
          f"median {statistics.median(times):.3f} s of {['%.3f' % t for t in times]}")


if __name__ == "__main__":
    work = Path(tempfile.mkdtemp(prefix="rubscan-overhead-"))
    try:
        sweep_overhead(work)
        series_to_pandas(work)
    finally:
        shutil.rmtree(work)
