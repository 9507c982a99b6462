#!/usr/bin/env bash
# diffdagger quickstart: install what is missing, configure, build, run.
#
#   ./quickstart.sh demo [ARGS...]   the headless 2-D multimodality demo (writes out/demo2d/)
#   ./quickstart.sh test             the test suite (ctest), with the output of failures
#   ./quickstart.sh build            install, configure and build only
#   ./quickstart.sh bench [ARGS...]  the Google Benchmark programs
#   ./quickstart.sh sanitize [ARGS]  the test suite built with AddressSanitizer and UBSan (build-asan/)
#   ./quickstart.sh fuzz [SECONDS]   the libFuzzer harnesses of the file loaders (clang; build-fuzz/)
#   ./quickstart.sh tsan             the console's and the session's tests under ThreadSanitizer (build-tsan/)
#
# Debian 12 packages only; nothing is downloaded at build or run time. Needs root or sudo the
# first time (to install packages); says nothing about packages when all are present.
set -euo pipefail
cd "$(dirname "$0")"

BUILD_DIR=${BUILD_DIR:-build}
JOBS=${JOBS:-2}

PACKAGES=(
  build-essential cmake ninja-build pkg-config git
  libtorch-dev libopenblas0-openmp libblas-dev libdnnl-dev libeigen3-dev
  libmujoco-dev libqhull-dev libbox2d-dev libopencv-dev libhdf5-dev
  libegl-dev libgl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri libglfw3-dev libimgui-dev libstb-dev
  libyaml-cpp-dev libcli11-dev libspdlog-dev libfmt-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  xvfb xauth xdotool fonts-dejavu-core
  python3-h5py clang libclang-rt-14-dev
)

log() { printf '\033[1m[quickstart]\033[0m %s\n' "$*" >&2; }

install_missing() {
  local missing=()
  for p in "${PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if ((${#missing[@]})); then
    local sudo=""
    if [[ $(id -u) -ne 0 ]]; then
      command -v sudo >/dev/null || { log "need root or sudo to install: ${missing[*]}"; exit 1; }
      sudo="sudo"
    fi
    log "installing ${#missing[@]} Debian packages: ${missing[*]}"
    $sudo apt-get update -q
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -q --no-install-recommends "${missing[@]}"
  fi
  # libtorch is 3-5x slower on the reference BLAS or on OpenBLAS's pthread build (its threads fight
  # libtorch's OpenMP threads): make sure the OpenMP build of OpenBLAS provides BLAS and LAPACK.
  local omp=/usr/lib/x86_64-linux-gnu/openblas-openmp
  if [[ -d $omp ]]; then
    local sudo=""; [[ $(id -u) -ne 0 ]] && sudo="sudo"
    for alt in libblas.so.3 liblapack.so.3 libopenblas.so.0; do
      local name="$alt-x86_64-linux-gnu"
      if [[ -e $omp/$alt ]] && [[ $(readlink -f "/usr/lib/x86_64-linux-gnu/$alt") != $(readlink -f "$omp/$alt") ]]; then
        log "pointing $alt at the OpenMP build of OpenBLAS"
        $sudo update-alternatives --set "$name" "$omp/$alt" >/dev/null
      fi
    done
  fi
}

configure_and_build() {
  local gen=()
  command -v ninja >/dev/null && gen=(-G Ninja)
  if [[ ! -f $BUILD_DIR/CMakeCache.txt ]]; then
    cmake -S . -B "$BUILD_DIR" "${gen[@]}" -DCMAKE_BUILD_TYPE=Release
  fi
  cmake --build "$BUILD_DIR" -j "$JOBS"
}

cmd=${1:-}
[[ $# -gt 0 ]] && shift
case "$cmd" in
  demo)
    install_missing
    configure_and_build
    "$BUILD_DIR/app/diffdagger" demo2d --out out/demo2d "$@"
    ;;
  test)
    install_missing
    configure_and_build
    cd "$BUILD_DIR"
    ctest --output-on-failure -j "$JOBS" "$@"
    ;;
  build)
    install_missing
    configure_and_build
    ;;
  sanitize)
    install_missing
    BUILD_DIR=build-asan
    if [[ ! -f $BUILD_DIR/CMakeCache.txt ]]; then
      cmake -S . -B "$BUILD_DIR" -G Ninja -DDD_SANITIZE=ON -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDD_BUILD_BENCHMARKS=OFF
    fi
    cmake --build "$BUILD_DIR" -j "$JOBS"
    cd "$BUILD_DIR"
    # libtorch, OpenMP and Mesa keep allocations to the end of the process: leak reports would be theirs
    ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0} UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1} \
      ctest --output-on-failure -j "$JOBS" "$@"
    # a passing test may still hold a report (a child process it expected to crash): list them all
    ../tests/sanitizer_reports.sh Testing/Temporary/LastTest.log
    ;;
  fuzz)
    install_missing
    tests/fuzz/run.sh "$@"
    ;;
  tsan)
    install_missing
    tests/tsan.sh
    ;;
  bench)
    install_missing
    configure_and_build
    for b in "$BUILD_DIR"/tests/bench/bench_*; do [[ -x $b ]] && "$b" "$@"; done
    ;;
  *)
    sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
