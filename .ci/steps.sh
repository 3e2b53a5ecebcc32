# Sourced by .ci/run and .ci/test (after `set -euo pipefail`): `step <name> <command…>` runs a
# command, echoes its name and appends its wall time to a table that the outermost script
# prints when it exits, also on failure (the failing step marked). Nested scripts add their
# steps to their caller's table. `step_in_background <name> <command…>` starts a step beside
# the ones that follow (its output kept in target/, printed when it ends) and
# `wait_for_background_step` waits for it, recording its own wall time and failing if it failed.
ci_step_name=""
if [ -z "${RUBSCAN_CI_STEPS:-}" ]; then
  export RUBSCAN_CI_STEPS="$PWD/target/ci-steps.tsv"
  mkdir -p "$(dirname "$RUBSCAN_CI_STEPS")"
  : > "$RUBSCAN_CI_STEPS"
  ci_outermost=1
fi
ci_started=$(date +%s)

ci_on_exit() {
  local rc=$?
  if [ -n "${ci_background_pid:-}" ]; then
    kill "$ci_background_pid" 2>/dev/null || true
  fi
  if [ -n "$ci_step_name" ]; then
    printf '%s\t%d\tFAILED\n' "$ci_step_name" "$(( $(date +%s) - ci_step_t0 ))" >> "$RUBSCAN_CI_STEPS"
  fi
  if [ -n "${ci_outermost:-}" ]; then
    echo
    echo "== wall time per step (s)"
    awk -F'\t' '{ printf "%6d  %s%s\n", $2, $1, ($3 == "" ? "" : "  <- " $3) }' "$RUBSCAN_CI_STEPS"
    printf "%6d  total, %s\n" "$(( $(date +%s) - ci_started ))" \
      "$([ "$rc" -eq 0 ] && echo passed || echo "FAILED (exit status $rc)")"
  fi
}
trap ci_on_exit EXIT

step() {
  ci_step_name=$1
  shift
  echo "== $ci_step_name"
  ci_step_t0=$(date +%s)
  "$@"
  printf '%s\t%d\n' "$ci_step_name" "$(( $(date +%s) - ci_step_t0 ))" >> "$RUBSCAN_CI_STEPS"
  ci_step_name=""
}

ci_background_pid=""
step_in_background() {
  ci_background_name=$1
  shift
  ci_background_log="$PWD/target/ci-background-step.log"
  echo "== $ci_background_name (in the background, output in $ci_background_log)"
  rm -f "$ci_background_log.end"
  ci_background_t0=$(date +%s)
  ( rc=0; "$@" || rc=$?; date +%s > "$ci_background_log.end"; exit "$rc" ) \
    > "$ci_background_log" 2>&1 &
  ci_background_pid=$!
}

wait_for_background_step() {
  local rc=0
  wait "$ci_background_pid" || rc=$?
  ci_background_pid=""
  echo "== $ci_background_name: its output"
  cat "$ci_background_log"
  local status=""
  [ "$rc" -eq 0 ] || status="FAILED"
  local end
  end=$(cat "$ci_background_log.end" 2>/dev/null || date +%s)
  printf '%s\t%d\t%s\n' "$ci_background_name (beside the next steps)" \
    "$(( end - ci_background_t0 ))" "$status" >> "$RUBSCAN_CI_STEPS"
  return "$rc"
}
