"""The mode cutoff on a coating (issue 39, item 3): case study 1's nominal job at the default
20 modes per nodal diameter, massless boundary at its default step, for each cutoff given
(the default step grows as the cutoff falls), against the same job without a cutoff and
against the converged reference of `rom_convergence.py --formulation mass --modes 80` when
its results are there. Every maximum is over every step, so the step does not change how
they are read.

    venv/bin/python python/benches/cutoff_study.py --cutoffs 50000 75000 100000 150000
    venv/bin/python python/benches/cutoff_study.py --steps 2e-6 1e-6 5e-7 2.5e-7 1.25e-7

With `--steps`, the 50 kHz cutoff at each time step given instead, against the smallest: the
coating force's convergence in the step.

Each run writes results/cutoff_study/<label>/ afresh with `rubscan run` (release binary).
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np
import pyarrow.parquet as pq

from rom_convergence import COLUMNS, ROOT, run_job, spec


def run(cutoff_hz: float | None, step_s: float | None = None) -> dict[str, Any]:
    label = "none" if cutoff_hz is None else f"{cutoff_hz:g}"
    job = spec(20, "massless", 0.07)
    if cutoff_hz is not None:
        job["numerics"]["mode_cutoff_hz"] = cutoff_hz
    if step_s is not None:
        job["numerics"]["time_step_s"] = step_s
        label += f"_h{step_s:g}"
    return run_job(job, ROOT / "results" / "cutoff_study" / label, threads=1)


def steps(values: list[float]) -> None:
    """The 50 kHz cutoff at each step of `values`, against the smallest."""
    runs = {h: run(5e4, h) for h in sorted(values, reverse=True)}
    finest = runs[min(values)]
    print("| h (s) | wall (s) | " + " | ".join([*COLUMNS, "wear L2"]) + " |")
    for h, r in runs.items():
        cells = " | ".join(f"{v:+.2%}" for v in relative(r, finest))
        print(f"| {h:g} | {r['wall (s)']:.1f} | {cells} |", flush=True)


def relative(r: dict[str, Any], ref: dict[str, Any]) -> list[float]:
    """Relative difference of every column of `r` from `ref` (the wear profile: relative L2)."""
    out = [(r[name] - ref[name]) / abs(ref[name]) for name in COLUMNS]
    wear = np.linalg.norm(r["wear"] - ref["wear"]) / np.linalg.norm(ref["wear"])
    return [*out, float(wear)]


def reference() -> dict[str, Any] | None:
    path = ROOT / "results" / "rom_convergence" / "mass_80" / "results.parquet"
    if not path.exists():
        return None
    row = pq.read_table(path).to_pylist()[0]
    values = {name: row[col] for name, col in COLUMNS.items()}
    values["wear"] = np.asarray(row["wear_profile_m"], dtype=float)
    return values


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cutoffs", type=float, nargs="+", default=[5e4, 7.5e4, 1e5, 1.5e5])
    parser.add_argument("--steps", type=float, nargs="+", help="time steps (s) at 50 kHz")
    args = parser.parse_args()
    if args.steps:
        steps(args.steps)
        return
    base = run(None)
    ref = reference()
    head = " | ".join([*COLUMNS, "wear L2"])
    print(f"| cutoff (Hz) | wall (s) | against no cutoff: {head} | against mass, 80 modes: {head} |")
    for cutoff in [None, *args.cutoffs]:
        r = base if cutoff is None else run(cutoff)
        cells = [" | ".join(f"{v:+.2%}" for v in relative(r, base))]
        if ref is not None:
            cells.append(" | ".join(f"{v:+.2%}" for v in relative(r, ref)))
        label = "none" if cutoff is None else f"{cutoff:g}"
        print(f"| {label} | {r['wall (s)']:.1f} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
