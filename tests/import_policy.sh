#!/usr/bin/env bash
# import-policy end to end: a policy trained here goes out as a diffusion_policy state_dict, comes
# back in Python torch.save's layout (tests/diffusion_policy_interop.py), is imported, rolled out by
# `train --init --steps 0`, and run by the console, whose first update adopts it instead of training.
set -euo pipefail
bin=$1
src=$(cd "$(dirname "$0")" && pwd)
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
cd "$dir"
"$bin" --threads 1 train --task nav2d --demos 5 --steps 50 --eval 0 --out trained >/dev/null
"$bin" export-policy trained/policy.pt --state-dict unet.pt --json unet.json
/usr/bin/python3 "$src/diffusion_policy_interop.py" unet.pt unet.json python_style.pt
"$bin" import-policy python_style.pt --json unet.json --task nav2d --out imported.pt | tee import.log
grep -q "imported 28[0-9]* parameters: down_dims \[16,32,64\]" import.log
# a task of other sizes is refused, naming the file
if "$bin" import-policy python_style.pt --json unet.json --task stack --out wrong.pt >err.log 2>&1; then
  echo "FAIL: imported a nav2d network for stacking"; exit 1
fi
grep -q "python_style.pt: the network takes 4 observation" err.log || { cat err.log; exit 1; }
# rolled out as train --init does
"$bin" --threads 1 train --task nav2d --init imported.pt --steps 0 --demos 1 --eval 2 --out rollout | tee rollout.log
grep -q "over 2 rollouts" rollout.log
# the console: initial demonstrations, then an update that adopts the policy (no training), then the robot
"$bin" --threads 1 gui --task nav2d --method diff --headless --quick --policy imported.pt --on-query expert --out console \
  --max-frames 400 >/dev/null 2>&1
grep -q '"event":"console_policy"' console/session.jsonl
grep '"event":"update_finished"' console/session.jsonl | head -1 | grep -q '"train_s":0.0'
grep -q '"control":"robot","episode":4,"event":"decision"' console/session.jsonl
echo "import-policy: imported, rolled out and run by the console"
