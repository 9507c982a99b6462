#!/bin/bash
# The real console window under Xvfb: keys sent with xdotool take over from the robot and hand back,
# and so does dragging a target in the scene with the mouse;
# the session log, the data set and an F12 screenshot show that it happened. Escape then Enter quits,
# saving the episode in progress.
#   usage: gui_xvfb.sh PATH/TO/diffdagger
set -euo pipefail
bin=$(realpath "$1")
for tool in xvfb-run xdotool; do
  command -v "$tool" >/dev/null || { echo "SKIP: $tool is not installed (./quickstart.sh installs it)"; exit 77; }
done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

cat > "$work/inner.sh" <<'INNER'
set -euo pipefail
bin=$1; work=$2
log=$work/run/session.jsonl
"$bin" gui --task nav2d --quick --on-query expert --out "$work/run" --screenshots "$work/shots" >"$work/app.log" 2>&1 &
app=$!
wait_for() {  # wait_for PATTERN SECONDS
  for _ in $(seq 1 $(( $2 * 5 ))); do
    grep -q "$1" "$log" 2>/dev/null && return 0
    kill -0 $app 2>/dev/null || { echo "the console exited early"; cat "$work/app.log"; return 1; }
    sleep 0.2
  done
  echo "timed out waiting for $1 in $log"; tail -5 "$log" || true; return 1
}
wait_for '"event":"update_finished"' 240
wid=$(xdotool search --sync --onlyvisible --name "diffdagger" | head -1)
xdotool windowfocus --sync "$wid"
# take over (retried: a key that lands while the scripted expert answers a query does nothing)
for _ in $(seq 1 20); do
  xdotool key t
  sleep 0.5
  grep -q '"control":"operator".*"event":"takeover"' "$log" && break
done
wait_for '"control":"operator"' 5
xdotool keydown Right; sleep 0.6; xdotool keyup Right
xdotool key h
wait_for '"event":"hand_back"' 10
# dragging a target in the scene (the left panel) takes over too: the view gives the command, the
# controller runs it (retried, as the key above)
takeovers() { grep -c '"control":"operator".*"event":"takeover"' "$log" || true; }
for _ in $(seq 1 20); do
  xdotool mousemove --window "$wid" 360 420 mousedown 1
  sleep 0.2; xdotool mousemove --window "$wid" 420 400; sleep 0.4
  xdotool mouseup 1
  sleep 0.3
  [ "$(takeovers)" -ge 2 ] && break
done
[ "$(takeovers)" -ge 2 ] || { echo "dragging in the scene did not take over"; exit 1; }
xdotool key h
xdotool key F12
for _ in $(seq 1 25); do [ -f "$work/shots/screenshot_1.png" ] && break; sleep 0.2; done
xdotool key Escape   # asks: the episode holds operator steps
sleep 0.5
xdotool key Return   # save it and quit
for _ in $(seq 1 150); do kill -0 $app 2>/dev/null || break; sleep 0.2; done
if kill -0 $app 2>/dev/null; then echo "the console did not quit"; kill $app; exit 1; fi
wait $app
INNER

DD_THREADS=${DD_THREADS:-1} xvfb-run -a -s "-screen 0 1280x800x24" bash "$work/inner.sh" "$bin" "$work"
log=$work/run/session.jsonl
fail() { echo "FAIL: $*"; cat "$work/app.log"; exit 1; }
grep -q '"control":"operator".*"event":"takeover"' "$log" || fail "no operator takeover in $log"
grep -q '"event":"hand_back"' "$log" || fail "no hand_back in $log"
grep -q '"event":"console_end"' "$log" || fail "the console did not shut down cleanly"
[ -s "$work/shots/screenshot_1.png" ] || fail "no F12 screenshot"
"$bin" dataset info "$work/run/dataset.hdf5" > "$work/info.txt" || fail "the data set does not read back"
grep -Eq "intervention steps [1-9]" "$work/info.txt" || { cat "$work/info.txt"; fail "no intervention episode in the data set"; }
if [ -n "${DD_GUI_TEST_KEEP:-}" ]; then mkdir -p "$DD_GUI_TEST_KEEP" && cp "$work"/shots/*.png "$work/run/session.jsonl" "$DD_GUI_TEST_KEEP"; fi
echo "PASS: takeover and hand-back through the real window"
