#!/usr/bin/env bash
# End-to-end speed: the same small `eval` on stacking (tests/bench/eval_stack_small.yaml, 10 rollouts
# per measurement, all four methods) with each binary given, back to back on the same machine.
# Prints each run's wall-clock and its RQ3 times, and whether RQ1 and RQ2 agree between the runs.
# Usage: tests/bench/eval_end_to_end.sh BIN [BIN...]   (from the repository root); a BIN may carry
#   extra eval arguments in the same word: tests/bench/eval_end_to_end.sh build/app/diffdagger "build/app/diffdagger --jobs 2"
#   e.g. a build of the commit before the speed work beside today's:
#   git worktree add /tmp/before 621aaf4^ && (cd /tmp/before && cmake -B build -G Ninja -DCMAKE_BUILD_TYPE=Release && cmake --build build -j2 --target diffdagger)
#   tests/bench/eval_end_to_end.sh /tmp/before/build/app/diffdagger build/app/diffdagger
# Threads: $DD_THREADS (default 2). Results go to ${OUT:-/tmp/dd_eval_bench}/runN.
set -euo pipefail
cd "$(dirname "$0")/../.."
[[ $# -ge 1 ]] || { sed -n 2,10p "$0"; exit 2; }
out=${OUT:-/tmp/dd_eval_bench}
rm -rf "$out" && mkdir -p "$out"
i=0
for spec in "$@"; do
  i=$((i + 1))
  read -ra run <<< "$spec"  # BIN, then any extra eval arguments
  start=$(date +%s.%N)
  "${run[0]}" --threads "${DD_THREADS:-2}" eval --task stack --config tests/bench/eval_stack_small.yaml --episodes 10 \
    --out "$out/run$i" "${run[@]:1}" > "$out/run$i.log" 2>&1
  end=$(date +%s.%N)
  printf 'run%d  %-50s  %7.1f s\n' "$i" "$spec" "$(echo "$end - $start" | bc)"
  cut -d, -f1-5 "$out/run$i/rq3.csv" | column -t -s, | sed 's/^/    /'
done
for j in $(seq 2 "$i"); do
  for f in rq1 rq2; do
    if cmp -s <(cut -d, -f1-4 "$out/run1/$f.csv") <(cut -d, -f1-4 "$out/run$j/$f.csv"); then
      echo "run$j: $f.csv rates as run1's"
    else
      echo "run$j: $f.csv differs from run1's:"; diff <(cut -d, -f1-4 "$out/run1/$f.csv") <(cut -d, -f1-4 "$out/run$j/$f.csv") || true
    fi
  done
done
