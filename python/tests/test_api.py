"""The package's functions against the CLI: the same tables and files, bad specs raised with
their JSON pointers, frames of every kind."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pandas as pd
import polars as pl
import pyarrow.parquet as pq
import pytest

import rubscan
from conftest import ipc_bytes, run_cli, spec_dict, without_wall_time


@pytest.mark.parametrize(
    ("edit", "pointer", "reason"),
    [
        (lambda s: s["grid"].update(friction=[-0.1]), "/grid/friction/0", "minimum"),
        (lambda s: s["scenario"].update(frobnicate=1), "/scenario", "frobnicate"),
        (lambda s: s["numerics"].update(time_step_s=1e-3), "/numerics/time_step_s", "stability"),
    ],
)
def test_a_bad_spec_raises_naming_the_json_pointer(repo, tmp_path, edit, pointer, reason):
    spec = spec_dict(repo, "small_sweep")
    edit(spec)
    out = tmp_path / "out"
    with pytest.raises(rubscan.SpecError) as info:
        rubscan.run(spec, output_dir=out, progress=False)
    err = info.value
    assert any(p == pointer and reason in r for p, r in err.issues), err.issues
    assert isinstance(err, ValueError)
    assert not out.exists(), "a refused spec wrote output"


def test_a_malformed_or_missing_spec_file_raises(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"name": "x",\n  "grid": ')
    with pytest.raises(rubscan.SpecError) as info:
        rubscan.plan(bad)
    assert info.value.pointer == ""
    assert "line 2" in info.value.reason and str(bad) in info.value.reason
    with pytest.raises(rubscan.SpecError, match="cannot read"):
        rubscan.load_spec(tmp_path / "absent.json")
    with pytest.raises(TypeError, match="spec"):
        rubscan.load_spec(42)  # type: ignore[arg-type]


def test_a_dict_spec_reads_relative_paths_from_base_dir(repo, tmp_path):
    spec = spec_dict(repo, "rotor37_benchmark")
    with pytest.raises(rubscan.SpecError) as info:
        rubscan.plan(rubscan.load_spec(spec, base_dir=tmp_path))
    assert str(tmp_path) in " ".join(r for _, r in info.value.issues), info.value.issues


def test_run_then_resume_returns_the_same_table(repo, tmp_path):
    spec = repo / "tests/data/small_sweep.json"
    calls: list[tuple[int, int, int]] = []
    first = rubscan.run(spec, output_dir=tmp_path / "out", threads=2, progress=lambda *a: calls.append(a), frame="arrow")
    assert first.num_rows == 6 and set(first["status"].to_pylist()) == {"ok"}
    assert calls[-1][:2] == (6, 6), calls[-1]
    calls.clear()
    again = rubscan.run(spec, output_dir=tmp_path / "out", threads=1, progress=lambda *a: calls.append(a), frame="arrow")
    assert calls[-1][:2] == (0, 0), "the resumed run ran jobs again"
    assert ipc_bytes(without_wall_time(first)) == ipc_bytes(without_wall_time(again))
    read = rubscan.read_results(tmp_path / "out", frame="arrow")
    assert ipc_bytes(read) == ipc_bytes(again)


def test_simulate_writes_the_cli_files_bit_for_bit(repo, cli, tmp_path):
    spec = repo / "tests/data/small_sweep.json"
    run_cli(cli, "simulate", spec, "--job", "4", "-o", tmp_path / "cli", cwd=tmp_path)
    sim = rubscan.simulate(spec, 4, output_dir=tmp_path / "py")
    cli_series = (tmp_path / "cli/timeseries.parquet").read_bytes()
    assert (sim.directory / "timeseries.parquet").read_bytes() == cli_series
    assert isinstance(sim.series, pd.DataFrame) and len(sim.series) > 100
    assert sim.series.equals(pq.read_table(tmp_path / "cli/timeseries.parquet").to_pandas())
    cli_summary = json.loads((tmp_path / "cli/summary.json").read_text())
    for d in (cli_summary, sim.summary):
        d.pop("loop_seconds")
    assert sim.summary == cli_summary
    assert sim.summary["job_id"] == rubscan.plan(spec)["job_id"][4]


def test_plan_matches_the_cli_plan_in_every_frame(repo, cli, tmp_path):
    spec = repo / "tests/data/small_sweep.json"
    text = run_cli(cli, "plan", spec, cwd=tmp_path).stdout
    ids = re.findall(r"^\s*\d+\s+([0-9a-f]{16})\s", text, flags=re.M)
    jobs = rubscan.plan(spec)
    assert list(jobs["job_id"]) == ids and len(ids) == 6
    assert list(jobs.columns[:5]) == ["job_index", "job_id", "speed_rad_s", "friction", "clearance_m"]
    assert isinstance(rubscan.plan(spec, frame="polars"), pl.DataFrame)
    arrow = rubscan.plan(spec, frame="arrow")
    assert arrow.schema.field("speed_rad_s").metadata[b"unit"] == b"rad/s"
    with pytest.raises(ValueError, match="frame"):
        rubscan.plan(spec, frame="excel")  # type: ignore[arg-type]


def test_campbell_and_stability_match_the_cli(repo, cli, tmp_path):
    spec = repo / "sweeps/quickstart.json"
    text = run_cli(cli, "campbell", spec, "-o", tmp_path / "c.png", cwd=tmp_path).stdout
    rows = [tuple(float(x) for x in l.split()) for l in text.splitlines() if re.match(r"^\s+\d+\.\d\s", l)]
    crit = rubscan.campbell(spec)
    assert len(crit) == len(rows) > 0
    for (w, _, n, c), got in zip(rows, crit.itertuples()):
        assert (round(got.speed_rad_s, 1), got.nodal_diameter, round(got.compatibility, 3)) == (w, n, c)
    wave, nd = crit.attrs["critical_wave_speed"]
    assert f"{wave:.1f} rad/s" in text and f"nodal diameter {nd}" in text

    args = ["--from", "3000", "--to", "6000", "--count", "7"]
    text = run_cli(cli, "stability", spec, "-o", tmp_path / "s.png", *args, cwd=tmp_path).stdout
    st = rubscan.stability(spec, from_rad_s=3000, to_rad_s=6000, count=7)
    assert list(st.table["speed_rad_s"]) == [3000 + 500 * i for i in range(7)]
    onset = st.onset_rad_s[0.15]
    assert onset is not None and f"predicted onset {onset:.1f} rad/s" in text
    # The scan reaches past the onset: some speeds grow (an empty selection would pass `.all()`),
    # each above the onset and with a positive growth rate.
    grows = st.table[~st.table["stable"]]
    assert len(grows) > 0, f"no unstable speed in the scan:\n{st.table}"
    assert (grows["speed_rad_s"] > onset).all() and (grows["growth_rate_per_s"] > 0).all()
    assert st.critical_wave_speed == (wave, nd)


def test_report_writes_a_page(repo, tmp_path):
    rubscan.run(repo / "tests/data/small_sweep.json", output_dir=tmp_path / "out", progress=False)
    index = rubscan.report(tmp_path / "out")
    assert index == tmp_path / "out/report/index.html" and "<img" in index.read_text()
    with pytest.raises(rubscan.RubscanError, match="not a results directory"):
        rubscan.report(tmp_path / "nothing-here")


def test_the_gil_is_released_while_jobs_run(repo, tmp_path):
    """Another Python thread keeps running while a sweep runs."""
    import threading
    import time

    ticks = 0
    stop = threading.Event()

    def count() -> None:
        nonlocal ticks
        while not stop.is_set():
            ticks += 1
            time.sleep(0.001)

    spec = spec_dict(repo, "quickstart")
    spec["scenario"]["duration_s"] = 0.005
    spec["grid"]["speed"]["values"] = [2000, 3000]
    counter = threading.Thread(target=count)
    counter.start()
    t0 = time.perf_counter()
    rubscan.run(spec, output_dir=tmp_path / "out", threads=1, progress=False)
    elapsed = time.perf_counter() - t0
    stop.set()
    counter.join()
    # A held GIL would leave the counter at the few ticks of the 100 ms polls.
    assert ticks > 100 * elapsed, (ticks, elapsed)
