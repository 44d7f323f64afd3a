#!/usr/bin/env bash
# The test command (README, second command; .ci/run calls it): installs what is missing, builds
# and runs the whole test suite, then again under AddressSanitizer + UndefinedBehaviorSanitizer,
# runs the benchmark harness and the speed check on a small log (bench/run_all --quick,
# bench/speed --quick), and checks that the core
# builds with the MRPT parts switched off.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)
step() { echo; echo "=== $* ($(date +%T))"; }

step "setup"
bash scripts/setup.sh

step "Release build"
bash scripts/build.sh

step "tests (Release)"
ctest --test-dir "${BUILD_DIR:-build}" --output-on-failure -j"$jobs"

step "benchmark harness, quick mode (bench/run_all --quick)"
bench/run_all --quick

step "speed check, quick mode (bench/speed --quick: 200 scans of intel, about 5 s)"
bench/speed --quick

step "sanitizer build (ASan + UBSan)"
BUILD_DIR=build-asan BUILD_TYPE=RelWithDebInfo \
  CMAKE_ARGS="-DSHAPE_SLAM_SANITIZE=ON -DSHAPE_SLAM_BUILD_BENCH=OFF" bash scripts/build.sh

step "tests (ASan + UBSan)"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  LSAN_OPTIONS=suppressions=$PWD/tests/sanitizers/lsan.supp \
  ctest --test-dir build-asan --output-on-failure -j"$jobs"

step "core alone (SHAPE_SLAM_WITH_MRPT=OFF, no apps): configure and build"
BUILD_DIR=build-core CMAKE_ARGS="-DSHAPE_SLAM_WITH_MRPT=OFF -DSHAPE_SLAM_BUILD_APPS=OFF \
  -DSHAPE_SLAM_BUILD_TESTS=OFF -DSHAPE_SLAM_BUILD_BENCH=OFF" bash scripts/build.sh

step "all tests passed"
