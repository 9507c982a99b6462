#!/usr/bin/env python3
"""The loss restricted to the low-noise timesteps, from the demo's per-timestep means.

For each full run (networks trained with the v, epsilon and sample objectives, 3 seeds each) and each
space the loss is scored in, the mean over the first K of the T_d = 16 timesteps of each region's
mean loss (fig2_loss_by_timestep.csv) gives the expected loss of a score that draws t uniformly
from [0, K) instead of [0, T_d). Prints and writes low_noise_score.md and .csv: loss ood / id_mm per
K, mean +- std over seeds, and in how many seeds it is at least 3 (the paper's bar).
Usage: results/fig2/low_noise_score.py   (from the repository root; standard library only)"""
import collections
import csv
import statistics

OBJECTIVES = ["v", "epsilon", "sample"]
SPACES = ["epsilon", "v", "sample"]
KS = [16, 8, 4, 2]


def ratios(path):
    by = collections.defaultdict(dict)
    for r in csv.DictReader(open(path)):
        by[(r["space"], r["region"])][int(r["t"])] = float(r["mean_loss"])
    out = {}
    for space in SPACES:
        key = space if (space, "ood") in by else "target"
        for k in KS:
            mean = lambda region: sum(by[(key, region)][t] for t in range(k)) / k
            out[(space, k)] = mean("ood") / mean("id_mm")
    return out


def main():
    rows, lines = [], []
    lines.append("| network trained with | scored in | " + " | ".join(f"t < {k}" for k in KS) + " |")
    lines.append("|---|---|" + "---|" * len(KS))
    for obj in OBJECTIVES:
        per_seed = [ratios(f"results/fig2/full_{obj}_prediction/seed_{s}/fig2_loss_by_timestep.csv") for s in range(3)]
        for space in SPACES:
            cells = []
            for k in KS:
                vals = [r[(space, k)] for r in per_seed]
                held = sum(v >= 3 for v in vals)
                cells.append(f"{statistics.mean(vals):.2f} +- {statistics.stdev(vals):.2f} ({held}/3)")
                rows.append([obj, space, k] + [f"{v:.4f}" for v in vals])
            own = " (its target)" if space == obj else ""
            lines.append(f"| {obj} | {space}{own} | " + " | ".join(cells) + " |")
    with open("results/fig2/low_noise_score.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["objective", "space", "timesteps_below", "ood_over_id_mm_seed0", "seed1", "seed2"])
        w.writerows(rows)
    text = ("Loss ood / id_mm when the score draws t from [0, K) instead of all T_d = 16 timesteps; mean +- std over 3 seeds, "
            "(seeds where it is at least 3). t < 16 is the full score.\n\n" + "\n".join(lines) + "\n")
    open("results/fig2/low_noise_score.md", "w").write(text)
    print(text)


if __name__ == "__main__":
    main()
