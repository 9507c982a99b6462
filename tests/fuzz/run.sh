#!/usr/bin/env bash
# Builds the libFuzzer harnesses (clang; ASan + UBSan) in build-fuzz/ and runs each for SECONDS on
# its committed corpus, tests/fuzz/corpora/NAME, printing executions and coverage per harness.
#
#   tests/fuzz/run.sh [SECONDS] [NAME...]   run (default 60 s each, every harness); new inputs go to
#                                           build-fuzz/corpus/NAME, the committed corpus is only read
#   MERGE=1 tests/fuzz/run.sh ...           then fold the new inputs that add coverage into the
#                                           committed corpus (libFuzzer -merge=1)
#   tests/fuzz/run.sh --seeds               regenerate the seed inputs the harnesses write themselves
#   tests/fuzz/run.sh --deep SECONDS NAME   the library readers in process (DD_READ_IN_PROCESS), so that
#                                           the fuzzer sees their coverage, in libFuzzer's fork mode, which
#                                           goes on past crashes; each crash's innermost frames are listed
#                                           as ours or a library's (build-fuzz/deep/NAME/)
#
# A crash, a sanitizer report, an exception other than dd::Error, a hang (10 s) or more than 2 GB of
# memory stops the harness, leaves the input in build-fuzz/artifacts/ and fails the script.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"
build=${FUZZ_BUILD_DIR:-build-fuzz}
all=(fuzz_config fuzz_script fuzz_dataset fuzz_checkpoint fuzz_state_dict)

if [[ ! -f $build/CMakeCache.txt ]]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DDD_FUZZ=ON \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
fi
cmake --build "$build" -j "${JOBS:-2}" >/dev/null

# libtorch and OpenMP keep their own allocations to the end of the process: leak checks would only
# report those. One thread: no OpenMP pool per input.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:allocator_may_return_null=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export OMP_NUM_THREADS=1 DD_THREADS=1

if [[ ${1:-} == --seeds ]]; then
  for h in fuzz_dataset fuzz_checkpoint fuzz_state_dict; do DD_FUZZ_SEEDS=tests/fuzz/corpora/$h "$build/tests/fuzz/$h"; done
  ls -l tests/fuzz/corpora/*/
  exit 0
fi

if [[ ${1:-} == --deep ]]; then
  secs=$2 h=$3 out=$build/deep/$3
  rm -rf "$out" && mkdir -p "$out/corpus" "$out/crashes"
  cp tests/fuzz/corpora/$h/* "$out/corpus/"
  DD_READ_IN_PROCESS=1 "$build/tests/fuzz/$h" -fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1 -max_total_time="$secs" \
    -timeout=10 -rss_limit_mb=2048 -max_len=262144 -artifact_prefix="$out/crashes/" "$out/corpus" >"$out/log" 2>&1 || true
  grep -E '^#[0-9]+' "$out/log" | tail -1
  # where each crash happened: the first stack frame outside the sanitizers and libFuzzer
  for f in "$out"/crashes/*; do
    [[ -f $f ]] || continue
    frame=$(DD_READ_IN_PROCESS=1 "$build/tests/fuzz/$h" "$f" 2>&1 | grep -E '^ +#[0-9]+ ' | grep -v -E 'sanitizer|interceptor|__asan|fuzzer::|libc.so|memcpy|memmove|strlen' | head -1 |
            sed -E 's/^ +#[0-9]+ 0x[0-9a-f]+ in //' | cut -c1-120 || true)
    echo "$(basename "$f"): ${frame:-no crash on rerun}"
  done | sort -t: -k2 | tee "$out/crashes.txt"
  exit 0
fi

secs=${1:-60}
shift || true
names=("$@")
((${#names[@]})) || names=("${all[@]}")
mkdir -p "$build/artifacts"
status=0
printf '%-16s %10s %8s %8s %8s %s\n' harness executions exec/s cov ft result
for h in "${names[@]}"; do
  mkdir -p "$build/corpus/$h" tests/fuzz/corpora/$h
  log=$build/$h.log
  max_len=65536
  [[ $h == fuzz_checkpoint ]] && max_len=262144  # a checkpoint of the micro network is 207 kB
  if "$build/tests/fuzz/$h" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -max_len=$max_len -print_final_stats=1 \
       -artifact_prefix="$build/artifacts/$h-" "$build/corpus/$h" tests/fuzz/corpora/$h >"$log" 2>&1; then
    result=ok
  else
    result="FAILED (see $log and $build/artifacts/)"
    status=1
  fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | tail -1 | grep -o '[0-9]*$' || echo "?")
  speed=$(grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | tail -1 | grep -o '[0-9]*$' || echo "?")
  last=$(grep -E '^#[0-9]+' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' <<<"$last" | grep -o '[0-9]*' || echo "?")
  ft=$(grep -o 'ft: [0-9]*' <<<"$last" | grep -o '[0-9]*' || echo "?")
  printf '%-16s %10s %8s %8s %8s %s\n' "$h" "$runs" "$speed" "$cov" "$ft" "$result"
  if [[ ${MERGE:-0} == 1 && $result == ok ]]; then
    "$build/tests/fuzz/$h" -merge=1 -max_len=$max_len -timeout=10 -rss_limit_mb=2048 -artifact_prefix="$build/artifacts/$h-merge-" \
      tests/fuzz/corpora/$h "$build/corpus/$h" >>"$log" 2>&1
  fi
done
exit $status
