#!/usr/bin/env bash
# The console's and the DAgger session's tests under ThreadSanitizer (build-tsan/, -DDD_TSAN=ON):
# the worker thread that runs policy updates, the loss field and decisions beside the frame thread
# (ui/worker.h), the session's observers, and ensemble training in child processes.
# Usage: tests/tsan.sh   (from anywhere; ./quickstart.sh tsan runs it)
# Fails on any data race report in our code; tests/tsan.supp lists the uninstrumented libraries.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${TSAN_BUILD_DIR:-build-tsan}
if [[ ! -f $build/CMakeCache.txt ]]; then
  cmake -S . -B "$build" -G Ninja -DDD_TSAN=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDD_BUILD_BENCHMARKS=OFF
fi
cmake --build "$build" -j "${JOBS:-2}" --target test_session test_console
# libtorch's operators on one thread: OpenMP's pool, which TSan cannot follow (libgomp is not
# instrumented), stays unused; our own threads are what is checked
export DD_THREADS=1 OMP_NUM_THREADS=1
export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$PWD/tests/tsan.supp ${TSAN_OPTIONS:-}"
cd "$build/tests"
./test_session
# the headless console with a scripted operator: a policy update on the worker while frames draw,
# a takeover, a hand-back and a reset; and the worker's own test
./test_console --gtest_filter='ConsoleWorker.*:Console.ScriptedOperatorTakesOverDrivesAndHandsBack'
echo "tests/tsan.sh: no data races reported"
