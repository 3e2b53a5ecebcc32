"""Convergence of the case-study quantities with the modes per nodal diameter (issue 39, item 1).

Runs case study 1's nominal job (Ω = 3000 rad/s, μ = 0.15, nominal coating, 70 ms) on the
built-in models with the same number of fixed-interface modes per nodal diameter on the
impeller and the casing, for each count given, with the massless boundary at its default step
(and optionally the paper's formulation at h = 1e-7 s), then prints every reported maximum and
the wear profile's relative L2 change against the count twice as large (the default rule:
the smallest count at which doubling it moves every column by less than 2 %).

    venv/bin/python python/benches/rom_convergence.py --modes 10 20 30 40 60 80

Each run writes results/rom_convergence/<label>/ afresh with `rubscan run` (release binary).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import time
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq

ROOT = Path(__file__).resolve().parents[2]
COLUMNS = {
    "blade LE (m)": "max_blade_le_radial_m",
    "blade TE (m)": "max_blade_te_radial_m",
    "blade LE < 15 kHz (m)": "max_blade_le_radial_lowpass_m",
    "blade TE < 15 kHz (m)": "max_blade_te_radial_lowpass_m",
    "casing (m)": "max_casing_radial_m",
    "coating force (N)": "max_coating_force_n",
}


def spec(modes: int, formulation: str, duration_s: float) -> dict[str, Any]:
    base = json.loads((ROOT / "sweeps" / "case_study_1.json").read_text())
    numerics: dict[str, Any] = {"decimation": 50}
    if formulation == "mass":
        numerics.update(time_step_s=1e-7, boundary="mass")
    else:
        numerics.update(boundary="massless")
    return {
        "name": f"rom_convergence_{formulation}_{modes}",
        "models": {
            "impeller": {"builtin": {"modes_per_diameter": modes}},
            "casing": {"builtin": {"modes_per_diameter": modes}},
        },
        "scenario": {**base["scenario"], "duration_s": duration_s},
        "numerics": numerics,
        "grid": {"speed": {"unit": "rad_s", "values": [3000]}, "friction": [0.15]},
    }


def run(modes: int, formulation: str, duration_s: float, threads: int) -> dict[str, Any]:
    out = ROOT / "results" / "rom_convergence" / f"{formulation}_{modes}"
    return run_job(spec(modes, formulation, duration_s), out, threads)


def run_job(job: dict[str, Any], out: Path, threads: int) -> dict[str, Any]:
    """Runs the one-job sweep `job` into `out` afresh; its maxima, wear profile and wall (s)."""
    shutil.rmtree(out, ignore_errors=True)  # a fresh run, never a resume of another revision
    out.mkdir(parents=True)
    path = out / "spec.json"
    path.write_text(json.dumps(job, indent=2))
    start = time.perf_counter()
    subprocess.run(
        [str(ROOT / "target/release/rubscan"), "run", str(path), "-o", str(out),
         "--threads", str(threads)],
        check=True, capture_output=True,
    )
    wall = time.perf_counter() - start
    row = pq.read_table(out / "results.parquet").to_pylist()[0]
    assert row["status"] == "ok", row["reason"]
    values = {name: row[col] for name, col in COLUMNS.items()}
    values["wear"] = np.asarray(row["wear_profile_m"], dtype=float)
    values["wall (s)"] = wall
    return values


def change(a: dict[str, Any], b: dict[str, Any]) -> dict[str, float]:
    """Relative change of every column from a to b (the wear profile: relative L2)."""
    out = {name: (b[name] - a[name]) / abs(b[name]) for name in COLUMNS}
    out["wear L2"] = float(np.linalg.norm(b["wear"] - a["wear"]) / np.linalg.norm(b["wear"]))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--modes", type=int, nargs="+", default=[10, 20, 30, 40, 60, 80])
    parser.add_argument("--formulation", choices=["massless", "mass"], default="massless")
    parser.add_argument("--duration", type=float, default=0.07, help="simulated time (s)")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    results: dict[int, dict[str, Any]] = {}
    for m in args.modes:
        results[m] = run(m, args.formulation, args.duration, args.threads)
        r = results[m]
        print(f"{m:3d} modes: " + ", ".join(
            f"{k} {r[k]:.5g}" for k in [*COLUMNS, "wall (s)"]), flush=True)
    print("\nchange when the count doubles (relative; wear: relative L2)")
    print("| modes | → | " + " | ".join([*COLUMNS, "wear L2"]) + " |")
    for m in args.modes:
        if 2 * m in results:
            c = change(results[m], results[2 * m])
            print(f"| {m} | {2 * m} | " + " | ".join(f"{v:+.2%}" for v in c.values()) + " |")
    top = max(args.modes)
    print(f"\nchange against {top} modes")
    for m in args.modes[:-1]:
        c = change(results[m], results[top])
        print(f"| {m} | " + " | ".join(f"{v:+.2%}" for v in c.values()) + " |")


if __name__ == "__main__":
    main()
