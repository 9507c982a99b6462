#!/bin/sh
# Diff-DAgger on nav2d_random with the paper's score (the loss in the training target's space) and
# with the loss scored in epsilon space: the same seeds, so RQ1 rolls out the same policy on the same
# episodes under both rules (RQ1 rollouts run without intervention).
# Usage: results/score_space/run.sh [SEEDS]   (from the repository root, after a build)
set -e
seeds=${1:-2}
bin=${DD_BIN:-build/app/diffdagger}
for score in target epsilon; do
  "$bin" --threads "${DD_THREADS:-1}" eval --task nav2d_random --config results/score_space/$score.yaml --methods diff \
    --seeds "$seeds" --out results/score_space/nav2d_random_$score
done
