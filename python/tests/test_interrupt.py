"""Ctrl-C in a notebook or a script: SIGINT to a Python process running a sweep stops it
cleanly, as the CLI's exit 130 does. Finished jobs are kept, the table and manifest are
written, and running the spec again runs only the rest."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import rubscan
from conftest import spec_dict


def test_sigint_stops_the_sweep_and_keeps_finished_jobs(repo, tmp_path):
    # The small sweep's six jobs, of about half a second each on one worker: time to interrupt
    # after the first.
    spec = spec_dict(repo, "small_sweep")
    n_jobs = len(spec["grid"]["speed"]["values"]) * len(spec["grid"]["friction"])
    spec_path = tmp_path / "scan.json"
    spec_path.write_text(json.dumps(spec))
    out = tmp_path / "out"
    script = (
        "import rubscan, sys\n"
        f"rubscan.run({str(spec_path)!r}, output_dir={str(out)!r}, threads=1, progress=False)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", script], stderr=subprocess.PIPE, text=True)
    jobs = out / "jobs"
    deadline = time.monotonic() + 600  # a fresh machine builds and caches the models first
    while not (jobs.is_dir() and any(jobs.glob("*.json"))):
        assert proc.poll() is None, f"the sweep ended before it was interrupted:\n{proc.stderr.read()}"
        assert time.monotonic() < deadline, "no job finished in 600 s"
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode != 0 and "KeyboardInterrupt" in stderr, stderr

    kept = {p.name: p.read_bytes() for p in jobs.glob("*.json")}
    assert 1 <= len(kept) < n_jobs, f"{len(kept)} records after the interrupt"
    table = rubscan.read_results(out)
    assert len(table) == len(kept) and set(table["status"]) == {"ok"}
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["summary"]["cancelled"] is True, manifest["summary"]

    calls: list[tuple[int, int, int]] = []
    resumed = rubscan.run(spec_path, output_dir=out, threads=2, progress=lambda *a: calls.append(a))
    assert calls[-1][:2] == (n_jobs - len(kept), n_jobs - len(kept)), calls[-1]
    assert len(resumed) == n_jobs and set(resumed["status"]) == {"ok"}
    for name, before in kept.items():
        assert (jobs / name).read_bytes() == before, f"{name} was run again"
