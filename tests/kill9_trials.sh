#!/usr/bin/env bash
# The kill -9 trial of data-set writing, N times: `diffdagger collect` appends expert episodes to a
# fresh file and is killed with SIGKILL at a random moment. After each kill the file must read back
# (or not exist yet, when the kill came before the first episode), hold at least the episodes that
# were complete when the kill was decided, and take one more episode appended by a new run.
#
#   tests/kill9_trials.sh DIFFDAGGER [N=100] [CSV]
#
# Prints one line per trial and a summary; with CSV, writes trial,killed_ms_after_first_episode,seen,kept,read_back,appended.
# Exits non-zero if any trial lost a complete episode or left a file that does not read back.
set -u
bin=${1:?usage: kill9_trials.sh DIFFDAGGER [N] [CSV]}
n=${2:-100}
csv=${3:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
file=$work/live.hdf5

episodes_in() {  # the episode count `dataset info` reports, or "unreadable"
  local out
  out=$("$bin" dataset info "$1" 2>&1) || { echo unreadable; return; }
  sed -n 's/^ *episodes \([0-9]*\) .*/\1/p' <<<"$out"
}

[[ -n $csv ]] && echo "trial,killed_ms_after_first_episode,seen,kept,read_back,appended" >"$csv"
failures=0 read_back=0 empty=0 kept_all=()
RANDOM=12345  # the same kill times on every run of the script
for trial in $(seq 1 "$n"); do
  rm -f "$file" "$file.partial"
  # a long collection: each episode copies the file (crash safety), so later episodes take longer
  "$bin" --threads 1 collect --task nav2d --episodes 100000 --out "$file" >/dev/null 2>&1 &
  pid=$!
  # wait for the first episode on disk (the program's start-up varies with the machine's load), then
  # kill at a random moment of the stream
  for _ in $(seq 1 200); do [[ -f $file ]] && break; sleep 0.05; done
  ms=$((RANDOM % 1500))
  sleep "$(printf '0.%03d' $((ms % 1000)))"
  (( ms >= 1000 )) && sleep 1
  seen=0
  [[ -f $file ]] && { s=$(episodes_in "$file"); [[ $s =~ ^[0-9]+$ ]] && seen=$s; }
  kill -9 "$pid" 2>/dev/null
  wait "$pid" 2>/dev/null
  if [[ ! -f $file ]]; then
    kept=0 ok=yes
    (( seen == 0 )) || ok=no
    empty=$((empty + 1))
  else
    kept=$(episodes_in "$file")
    if [[ $kept =~ ^[0-9]+$ ]] && (( kept >= seen )); then ok=yes; read_back=$((read_back + 1)); else ok=no; fi
  fi
  # a new run appends to what the killed one left
  appended=no
  if [[ $ok == yes ]] && "$bin" --threads 1 collect --task nav2d --episodes 1 --seed 999 --out "$file" >/dev/null 2>&1; then
    after=$(episodes_in "$file")
    [[ $after == $((kept + 1)) ]] && appended=yes
  fi
  [[ $ok == yes && $appended == yes ]] || failures=$((failures + 1))
  kept_all+=("$kept")
  printf 'trial %3d: killed %4d ms after the first episode, %4d episodes complete before the kill, %4d in the file, read back %s, appended %s\n' \
    "$trial" "$ms" "$seen" "$kept" "$ok" "$appended"
  [[ -n $csv ]] && echo "$trial,$ms,$seen,$kept,$ok,$appended" >>"$csv"
done
sorted=$(printf '%s\n' "${kept_all[@]}" | sort -n)
printf '%d trials: %d files read back, %d killed before the first episode (no file), %d failures; episodes kept min %s, median %s, max %s\n' \
  "$n" "$read_back" "$empty" "$failures" "$(head -1 <<<"$sorted")" "$(sed -n "$(((n + 1) / 2))p" <<<"$sorted")" "$(tail -1 <<<"$sorted")"
exit $((failures > 0))
