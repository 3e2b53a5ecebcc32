"""The headline scan's accuracy on three of its speeds (issue 39, item 5): one-speed copies of
`sweeps/headline_scan.json` at 1000, 2507.5 and 4000 rad/s, at the defaults and with each mode
cutoff given, against the paper's formulation at h = 1e-7 s on the converged 80-mode ROM (run
once with `--reference`: three jobs of about ten minutes each on one thread).

    venv/bin/python python/benches/headline_accuracy.py --reference   # once
    venv/bin/python python/benches/headline_accuracy.py --cutoffs 50000 75000

Writes results/headline_accuracy/<label>/ afresh with `rubscan run` (release binary).
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np
import pyarrow.parquet as pq

from rom_convergence import COLUMNS, ROOT, run_job

SPEEDS = [1000.0, 2507.537688442211, 4000.0]
OUT = ROOT / "results" / "headline_accuracy"


def spec(speed: float, numerics: dict[str, Any], modes: int | None = None) -> dict[str, Any]:
    job = json.loads((ROOT / "sweeps" / "headline_scan.json").read_text())
    job["grid"]["speed"] = {"unit": "rad_s", "values": [speed]}
    job["numerics"].update(numerics)
    if modes is not None:
        for part in ("impeller", "casing"):
            job["models"][part]["builtin"]["modes_per_diameter"] = modes
    return job


def rows(label: str) -> list[dict[str, Any]]:
    out = []
    for speed in SPEEDS:
        row = pq.read_table(OUT / label / f"{speed:.1f}" / "results.parquet").to_pylist()[0]
        values = {name: row[col] for name, col in COLUMNS.items()}
        values["wear"] = np.asarray(row["wear_profile_m"], dtype=float)
        out.append(values)
    return out


def run(label: str, numerics: dict[str, Any], modes: int | None = None) -> float:
    """Runs the three speeds; their total wall time (s)."""
    wall = 0.0
    for speed in SPEEDS:
        r = run_job(spec(speed, numerics, modes), OUT / label / f"{speed:.1f}", threads=1)
        wall += r["wall (s)"]
    return wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cutoffs", type=float, nargs="*", default=[5e4, 7.5e4])
    parser.add_argument("--reference", action="store_true", help="run the reference first")
    args = parser.parse_args()
    if args.reference:
        run("reference", {"boundary": "mass", "time_step_s": 1e-7, "decimation": 40}, 80)
    ref = rows("reference")
    configs = [("default", {})] + [
        (f"cutoff {c:g} Hz", {"mode_cutoff_hz": c}) for c in args.cutoffs
    ]
    names = [*COLUMNS, "wear L2"]
    print("| configuration | wall, 3 jobs (s) | Ω (rad/s) | " + " | ".join(names) + " |")
    print("| --- " * (3 + len(names)) + "|")
    for label, numerics in configs:
        wall = run(label, numerics)
        for speed, r, f in zip(SPEEDS, rows(label), ref):
            cells = [f"{(r[n] - f[n]) / abs(f[n]):+.2%}" for n in COLUMNS]
            wear = np.linalg.norm(r["wear"] - f["wear"]) / np.linalg.norm(f["wear"])
            cells.append(f"{wear:.2%}")
            print(f"| {label} | {wall:.1f} | {speed:.1f} | " + " | ".join(cells) + " |",
                  flush=True)


if __name__ == "__main__":
    main()
