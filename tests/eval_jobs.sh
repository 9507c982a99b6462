#!/usr/bin/env bash
# `eval --jobs 2` runs the cells in child processes of one thread each and gives what one process with
# one thread gives: the same RQ1 and RQ2 numbers, a log per cell, and a report. A cell that fails is
# named with its log, and the finished cells are kept for the rerun. `--report` writes a partial
# report from the finished cells without running any.
# Usage: tests/eval_jobs.sh BIN   (ctest runs it in the build's tests folder)
set -euo pipefail
bin=$1
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cat > "$dir/tiny.yaml" <<'YAML'
preset: nav2d
train: {steps: 30, batch_size: 32, warmup_steps: 10}
dagger: {initial_demos: 3, final_demos: 5, demos_per_update: 2}
method: {members: 2, critic_steps: 50, loss_samples: 64}
rq1_demos: 2
YAML
args=(eval --task nav2d --config "$dir/tiny.yaml" --episodes 4 --methods diff,thrifty,bc)
"$bin" --threads 1 "${args[@]}" --out "$dir/one" > "$dir/one.log" 2>&1 || { cat "$dir/one.log"; exit 1; }
"$bin" --threads 2 "${args[@]}" --jobs 2 --out "$dir/two" > "$dir/two.log" 2>&1 || { cat "$dir/two.log"; exit 1; }
for f in rq1 rq2; do
  # the rates and counts; RQ3's wall-clock times differ by nature
  if ! cmp -s <(cut -d, -f1-14 "$dir/one/$f.csv") <(cut -d, -f1-14 "$dir/two/$f.csv"); then
    echo "FAIL: $f.csv differs between --jobs 1 --threads 1 and --jobs 2"; diff "$dir/one/$f.csv" "$dir/two/$f.csv"; exit 1
  fi
done
for cell in diff_seed0_rq1 diff_seed0_rq2 thrifty_seed0_rq1 thrifty_seed0_rq2 bc_seed0_rq2; do
  [[ -s $dir/two/logs/$cell.log ]] || { echo "FAIL: no log for $cell"; exit 1; }
  [[ -f $dir/two/cells/$cell.json ]] || { echo "FAIL: no cell file for $cell"; exit 1; }
done
grep -q "5/5 cells" "$dir/two.log" || { echo "FAIL: no progress line for the last cell"; cat "$dir/two.log"; exit 1; }
# interactive learning says where it is: a line per update in the cell's log
grep -q "RQ2 diff     update 1: 3/5 demonstrations" "$dir/two/logs/diff_seed0_rq2.log" ||
  { echo "FAIL: no line for update 1 in the DAgger cell's log"; cat "$dir/two/logs/diff_seed0_rq2.log"; exit 1; }
grep -q "cells finished by an earlier" "$dir/two/report.md" && { echo "FAIL: cells run by --jobs counted as an earlier run's"; exit 1; }
# --only-rq1: the RQ1 cells alone, the same numbers as the full evaluation's, no DAgger run, no report
"$bin" --threads 2 "${args[@]}" --jobs 2 --only-rq1 --out "$dir/rq1" > "$dir/rq1.log" 2>&1 || { cat "$dir/rq1.log"; exit 1; }
for cell in diff_seed0_rq1 thrifty_seed0_rq1; do
  for k in tp fp tn fn; do
    [[ $(grep "\"$k\"" "$dir/rq1/cells/$cell.json") == $(grep "\"$k\"" "$dir/one/cells/$cell.json") ]] ||
      { echo "FAIL: --only-rq1 gives another $k for $cell"; exit 1; }
  done
done
ls "$dir/rq1/cells" | grep -q rq2 && { echo "FAIL: --only-rq1 ran a DAgger cell"; exit 1; }
[[ ! -e $dir/rq1/report.md ]] || { echo "FAIL: --only-rq1 wrote a report"; exit 1; }
grep -q "RQ1 diff " "$dir/rq1.log" || { echo "FAIL: --only-rq1 did not print the RQ1 numbers"; cat "$dir/rq1.log"; exit 1; }
# --report: a report from the finished cells (here RQ1 only), running none, the missing cells listed
cells_before=$(ls "$dir/rq1/cells" | wc -l)
"$bin" --threads 1 "${args[@]}" --seeds 2 --report --out "$dir/rq1" > "$dir/partial.log" 2>&1 || { cat "$dir/partial.log"; exit 1; }
[[ $(ls "$dir/rq1/cells" | wc -l) == "$cells_before" ]] || { echo "FAIL: --report ran a cell"; exit 1; }
grep -q "Partial report" "$dir/rq1/report.md" || { echo "FAIL: the report does not say it is partial"; exit 1; }
# a plot only where a cell finished: RQ1's, no empty RQ2 or RQ3 chart
[[ -s $dir/rq1/rq1_failure_prediction.png && ! -e $dir/rq1/rq2_success.png && ! -e $dir/rq1/rq3_wallclock.png ]] &&
  grep -q "Plots: \`rq1_failure_prediction.png\`\. " "$dir/rq1/report.md" || { echo "FAIL: empty plots written or listed"; ls "$dir/rq1"; exit 1; }
grep -q "diff:0:rq2, thrifty:0:rq2, bc:0:rq2, diff:1:rq1, diff:1:rq2, thrifty:1:rq1, thrifty:1:rq2, bc:1:rq2" "$dir/rq1/report.md" ||
  { echo "FAIL: the missing cells are not listed"; cat "$dir/rq1/report.md"; exit 1; }
/usr/bin/python3 - "$dir/rq1" <<'PY' || exit 1
import csv, json, sys
d = sys.argv[1]
rq1 = {r["method"]: r for r in csv.DictReader(open(d + "/rq1.csv"))}
for m in ("diff", "thrifty"):
    cell = json.load(open(f"{d}/cells/{m}_seed0_rq1.json"))
    if [int(rq1[m][k]) for k in ("tp", "fp", "tn", "fn")] != [cell[k] for k in ("tp", "fp", "tn", "fn")] or rq1[m]["seeds"] != "1":
        sys.exit(f"FAIL: --report's rq1.csv row {rq1[m]} is not the one finished cell {cell}")
rq2 = {r["method"]: r for r in csv.DictReader(open(d + "/rq2.csv"))}
if rq2["bc"]["success_rate"] != "nan" or rq2["bc"]["seeds"] != "0":
    sys.exit(f"FAIL: a method without a finished RQ2 cell has {rq2['bc']}")
PY
# on a finished evaluation it says where the report came from, not a run time of its own
"$bin" --threads 1 "${args[@]}" --report --out "$dir/one" > "$dir/full.log" 2>&1 || { cat "$dir/full.log"; exit 1; }
grep -q "Written by \`eval --report\` from the finished cells" "$dir/one/report.md" && ! grep -q "Took " "$dir/one/report.md" ||
  { echo "FAIL: --report on a finished evaluation claims a run time"; tail -3 "$dir/one/report.md"; exit 1; }
# ... and it refuses a folder of another config, or none, naming the file
if "$bin" eval --task nav2d --report --out "$dir/rq1" > "$dir/other.log" 2>&1; then echo "FAIL: --report read another config's cells"; exit 1; fi
grep -q "rq1/config.json: --report writes the report of the evaluation whose config" "$dir/other.log" || { cat "$dir/other.log"; exit 1; }
if "$bin" "${args[@]}" --report --out "$dir/none" > "$dir/none.log" 2>&1; then echo "FAIL: --report without an evaluation"; exit 1; fi
grep -q "none/config.json: missing" "$dir/none.log" && [[ ! -e $dir/none ]] || { echo "FAIL: no clear error, or a folder made"; cat "$dir/none.log"; exit 1; }
# an RQ1 cell stopped (kill -9) during its rollouts continues where it stopped: the method as saved,
# the rollouts that ended kept, and the same numbers (compared rules included) as an unstopped cell
cat > "$dir/cmp.yaml" <<'YAML'
preset: nav2d
train: {steps: 30, batch_size: 32, warmup_steps: 10}
dagger: {initial_demos: 3, final_demos: 5, demos_per_update: 2}
method: {members: 2, critic_steps: 50, loss_samples: 64, compare_scores: [epsilon, "target@2"]}
rq1_demos: 2
YAML
cmp_args=(--threads 1 eval --task nav2d --config "$dir/cmp.yaml" --episodes 16 --methods diff --only-rq1)
"$bin" "${cmp_args[@]}" --out "$dir/whole" > "$dir/whole.log" 2>&1 || { cat "$dir/whole.log"; exit 1; }
"$bin" "${cmp_args[@]}" --out "$dir/stopped" > "$dir/stopped.log" 2>&1 &
pid=$!
rollouts=$dir/stopped/partial/diff_seed0_rq1/rollouts.jsonl
for _ in $(seq 1 1200); do
  [[ -f $rollouts ]] && (( $(wc -l < "$rollouts") >= 3 )) && break
  kill -0 $pid 2>/dev/null || break
  sleep 0.05
done
kill -9 $pid 2>/dev/null || { echo "FAIL: the cell ended before it could be stopped"; cat "$dir/stopped.log"; exit 1; }
wait $pid 2>/dev/null || true
[[ ! -f $dir/stopped/cells/diff_seed0_rq1.json ]] || { echo "FAIL: a stopped cell was written"; exit 1; }
"$bin" "${cmp_args[@]}" --out "$dir/stopped" > "$dir/resumed.log" 2>&1 || { cat "$dir/resumed.log"; exit 1; }
grep -q "continues from" "$dir/resumed.log" || { echo "FAIL: the rerun did not continue the stopped cell"; cat "$dir/resumed.log"; exit 1; }
strip() { grep -v '"episodes"\|_s"' "$1"; }  # and the seconds: risk_data_s, threshold_s, thresholds_s
cmp -s <(strip "$dir/whole/cells/diff_seed0_rq1.json") <(strip "$dir/stopped/cells/diff_seed0_rq1.json") ||
  { echo "FAIL: the continued cell differs from the unstopped one"; diff "$dir/whole/cells/diff_seed0_rq1.json" "$dir/stopped/cells/diff_seed0_rq1.json"; exit 1; }
grep -q '"target@2"' "$dir/whole/cells/diff_seed0_rq1.json" || { echo "FAIL: no compared rule in the cell"; exit 1; }
[[ ! -e $dir/stopped/partial/diff_seed0_rq1 ]] || { echo "FAIL: the finished cell left its partial folder"; exit 1; }
# the report: Table I and rq1.csv carry the compared rules' rows, with the cell's counts
"$bin" --threads 1 eval --task nav2d --config "$dir/cmp.yaml" --episodes 16 --methods diff --out "$dir/whole" > "$dir/report.log" 2>&1 || { cat "$dir/report.log"; exit 1; }
/usr/bin/python3 - "$dir/whole" <<'PY' || exit 1
import csv, json, sys
d = sys.argv[1]
cell = json.load(open(d + "/cells/diff_seed0_rq1.json"))
rows = {r["method"]: r for r in csv.DictReader(open(d + "/rq1.csv"))}
for rule, p in cell["compare"].items():
    r = rows.get("diff@" + rule)
    if r is None or [int(r[k]) for k in ("tp", "fp", "tn", "fn")] != [p[k] for k in ("tp", "fp", "tn", "fn")]:
        sys.exit(f"FAIL: rq1.csv's row diff@{rule} is {r}, the cell says {p}")
if [int(rows["diff"][k]) for k in ("tp", "fp", "tn", "fn")] != [cell[k] for k in ("tp", "fp", "tn", "fn")]:
    sys.exit("FAIL: rq1.csv's diff row is not the cell's main rule")
# what the threshold pass cost and did, and the thread count, recorded with the cell
if not (cell["threads"] == 1 and 0 < cell["threshold_refined"] <= cell["threshold_pairs"] and cell["threshold_s"] <= cell["thresholds_s"]):
    sys.exit(f"FAIL: the cell does not record its threshold pass and thread count: {cell}")
report = open(d + "/report.md").read()
if "scored target@2" not in report or "scored epsilon" not in report:
    sys.exit("FAIL: Table I has no rows for the compared rules")
PY
# a cell that cannot run: the rerun names it and its log, keeps the others, and fails
rm "$dir/two/cells/bc_seed0_rq2.json" "$dir/two/cells/diff_seed0_rq2.json"
rm -rf "$dir/two/runs" && touch "$dir/two/runs"  # no folder can be made for their runs
if "$bin" "${args[@]}" --jobs 2 --out "$dir/two" > "$dir/fail.log" 2>&1; then
  echo "FAIL: a failing cell went unreported"; exit 1
fi
grep -q "cells failed" "$dir/fail.log" && grep -q "logs/bc_seed0_rq2.log" "$dir/fail.log" ||
  { echo "FAIL: the failed cells and their logs are not named"; cat "$dir/fail.log"; exit 1; }
[[ -f $dir/two/cells/thrifty_seed0_rq2.json ]] || { echo "FAIL: a finished cell was lost"; exit 1; }
# Ensemble-DAgger's rule is Thrifty-DAgger's novelty half: Thrifty's RQ1 cell writes Ensemble's too,
# and --jobs starts no process of its own for it
"$bin" --threads 2 eval --task nav2d --config "$dir/tiny.yaml" --episodes 4 --methods ensemble,thrifty --jobs 2 --only-rq1 \
  --out "$dir/ens" > "$dir/ens.log" 2>&1 || { cat "$dir/ens.log"; exit 1; }
grep -q '"from": "thrifty:0:rq1"' "$dir/ens/cells/ensemble_seed0_rq1.json" ||
  { echo "FAIL: no Ensemble-DAgger cell from Thrifty-DAgger's"; ls "$dir/ens/cells"; exit 1; }
[[ ! -e $dir/ens/logs/ensemble_seed0_rq1.log ]] || { echo "FAIL: --jobs ran Ensemble-DAgger's RQ1 cell as well"; exit 1; }
grep -q "RQ1 ensemble TP" "$dir/ens.log" || { echo "FAIL: --only-rq1 did not print Ensemble-DAgger's numbers"; cat "$dir/ens.log"; exit 1; }
echo "eval --jobs: same RQ1 and RQ2 as one process, logs per cell, failures named; a stopped RQ1 cell continues to the same numbers; compared rules reach the report; Thrifty-DAgger's RQ1 cell gives Ensemble-DAgger's"
