#!/usr/bin/env bash
# Lists the sanitizer reports in a ctest log (Testing/Temporary/LastTest.log) and fails when one is not
# expected. ctest keeps a passing test's output, so a report from a child process whose crash the test
# wanted (or from a script's command that the script survived) would otherwise go unseen.
# Expected: Interop.AFileThatCrashedLibtorchIsAnError, where ASan stops the reading child at libtorch's
# zip reader overflowing on a corrupt file, and the parent is tested to report the file as corrupt.
# Usage: tests/sanitizer_reports.sh LOG
set -euo pipefail
log=${1:?usage: sanitizer_reports.sh build-asan/Testing/Temporary/LastTest.log}
[[ -f $log ]] || { echo "sanitizer_reports: $log: no such file" >&2; exit 2; }
awk '
  /^[0-9]+\/[0-9]+ Testing: / { test = $3; case_ = "" }
  /^\[ RUN      \] /          { case_ = $4 }
  /ERROR: AddressSanitizer|ERROR: LeakSanitizer|runtime error:|WARNING: ThreadSanitizer/ {
    where = test (case_ == "" ? "" : " " case_)
    expected = (where == "test_interop Interop.AFileThatCrashedLibtorchIsAnError")
    printf "%s: %s: %s\n", (expected ? "expected" : "UNEXPECTED"), where, $0
    if (!expected) bad++
  }
  END { exit bad > 0 }
' "$log"
