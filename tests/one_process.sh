#!/usr/bin/env bash
# The two-process split and its switch: at 2 threads a training step's minibatch, the threshold's
# scoring passes and the rollouts go to one-thread child processes; `--one-process` or
# $DD_ONE_PROCESS=1 keep them in this process's threads. Both ways train the same policy up to float
# rounding.
set -euo pipefail
bin=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cd "$dir"
run() {  # run NAME [ENV=VALUE...] [-- GLOBAL FLAGS...]: a tiny training run at 2 threads, logged at debug level
  local name=$1; shift
  local envs=() flags=()
  while [ $# -gt 0 ] && [ "$1" != "--" ]; do envs+=("$1"); shift; done
  [ $# -gt 0 ] && shift && flags=("$@")
  env "${envs[@]+"${envs[@]}"}" "$bin" -v --threads 2 "${flags[@]+"${flags[@]}"}" train --task nav2d --demos 4 --steps 20 \
    --batch 32 --threshold screened --eval 2 --out "$name" >"$name.log" 2>&1 || { cat "$name.log"; exit 1; }
}
split() {
  grep -q "minibatch split with child process" "$1.log" && grep -q "training pairs in two child processes" "$1.log" &&
    grep -q "rollouts 0 to 1 in two child processes" "$1.log"
}
run two DD_ONE_PROCESS=0
split two || { echo "FAIL: 2 threads did not split the work between two processes"; cat two.log; exit 1; }
run flag -- --one-process
run env DD_ONE_PROCESS=1
for name in flag env; do
  if grep -q "child process" "$name.log"; then echo "FAIL: $name: forked although asked to stay in one process"; exit 1; fi
done
# the same training either way (float rounding apart): final loss and threshold
python3 - two/summary.json flag/summary.json env/summary.json <<'PY'
import json, sys
runs = [json.load(open(p)) for p in sys.argv[1:]]
for key in ("final_loss", "threshold"):
    vals = [r[key] if key == "final_loss" else r[key]["screened"]["threshold"] for r in runs]
    if max(vals) - min(vals) > 1e-3 * max(abs(v) for v in vals):
        sys.exit(f"FAIL: {key} differs between one and two processes: {vals}")
print("one_process: final loss", [r["final_loss"] for r in runs], "threshold", [r["threshold"]["screened"]["threshold"] for r in runs])
PY
echo "one_process: the work splits in two processes by default at 2 threads, and stays in one with --one-process or DD_ONE_PROCESS=1"
