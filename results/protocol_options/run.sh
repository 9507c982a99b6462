#!/usr/bin/env bash
# The protocol options of issue 11, part 3, measured on nav2d_random with Diff-DAgger: each config is
# one `eval` (RQ1 on N_D = 3 demonstrations, interactive learning to N_f = 24, RQ2; 100 rollouts per
# measurement) over the same seeds. Resumable: a config whose report.md exists is skipped.
# Usage: results/protocol_options/run.sh [SEEDS]   (from the repository root; default 2 seeds)
set -euo pipefail
cd "$(dirname "$0")/../.."
seeds=${1:-2}
bin=${DD_BIN:-build/app/diffdagger}
for name in default gate_every_step from_scratch score_raw; do
  out=results/protocol_options/$name
  [[ -f $out/report.md ]] && { echo "$name: done"; continue; }
  "$bin" --threads "${DD_THREADS:-1}" eval --task nav2d_random --config results/protocol_options/$name.yaml \
    --methods diff --seeds "$seeds" --out "$out"
  rm -rf "$out/runs"  # data sets and checkpoints stay out of the repository
done
