#!/usr/bin/env bash
# The Slurm test on a real scheduler: starts a one-node cluster (.ci/slurm/start.sh, which
# fails saying why if the daemons cannot start), then runs the gated test of tests/slurm.rs
# (a 2-task array plus merge against a local run; a task killed with scancel, resumed alone).
set -euo pipefail
cd "$(dirname "$0")/../.."
start=$(date +%s)
.ci/slurm/start.sh
# `--workspace`: the same features, hence the same build, as the README's test command.
RUBSCAN_SLURM_TEST=1 cargo test --locked --workspace --test integration slurm::real_slurm -- --nocapture
echo "Slurm test done in $(( $(date +%s) - start )) s"
