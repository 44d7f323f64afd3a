#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang (ASan + UBSan) and runs each of them for
# SECONDS_PER_TARGET (default 60), one after the other, on a working copy of its seed corpus.
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]     e.g. scripts/fuzz.sh 300 map_file shape
#
# Installs nothing: needs clang with libFuzzer (Debian: clang, libclang-rt-<version>-dev).
# The committed seeds (fuzz/corpus/<target>/) are never modified: they are copied into
# fuzz/corpus-work/<target>/ (not versioned), which keeps the inputs libFuzzer finds from one
# run to the next. Crash, leak, time-out and out-of-memory inputs go to
# ${BUILD_DIR}/fuzz-artifacts/<target>/, logs to ${BUILD_DIR}/fuzz-logs/<target>.log.
# Environment: BUILD_DIR (default build-fuzz), CC/CXX (default clang/clang++, used when the
# build directory is first configured), JOBS (build jobs, default nproc), FUZZ_TIMEOUT (seconds
# one input may take, default 25), FUZZ_ARGS (more libFuzzer flags).
# Exits non-zero when a target crashed (or leaked, timed out, ran out of memory).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-60}
shift $(($# > 0 ? 1 : 0))
BUILD_DIR=${BUILD_DIR:-build-fuzz}

echo "=== build ($BUILD_DIR)"
CC=${CC:-clang} CXX=${CXX:-clang++} cmake -S . -B "$BUILD_DIR" -G Ninja \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSHAPE_SLAM_FUZZ=ON -DSHAPE_SLAM_BUILD_TESTS=OFF \
  -DSHAPE_SLAM_BUILD_BENCH=OFF -DSHAPE_SLAM_BUILD_APPS=OFF >/dev/null
cmake --build "$BUILD_DIR" --target fuzzers -j"${JOBS:-$(nproc)}"

targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for binary in "$BUILD_DIR"/fuzz/*_fuzz; do
    name=$(basename "$binary")
    targets+=("${name%_fuzz}")
  done
fi

export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
mkdir -p "$BUILD_DIR/fuzz-logs"
summary=()
failed=0
for target in "${targets[@]}"; do
  binary="$BUILD_DIR/fuzz/${target}_fuzz"
  if [ ! -x "$binary" ]; then
    echo "no fuzz target '$target' in $BUILD_DIR/fuzz" >&2
    exit 2
  fi
  work="fuzz/corpus-work/$target"
  artifacts="$BUILD_DIR/fuzz-artifacts/$target"
  log="$BUILD_DIR/fuzz-logs/$target.log"
  mkdir -p "$work" "$artifacts"
  for seed in fuzz/corpus/"$target"/*; do
    [ -e "$work/$(basename "$seed")" ] || cp "$seed" "$work/"
  done
  dict=()
  [ -f "fuzz/dict/$target.dict" ] && dict=(-dict="fuzz/dict/$target.dict")
  before=$(ls "$artifacts")
  echo "=== $target: ${seconds} s ($(date +%T)), log $log"
  status=0
  # shellcheck disable=SC2086  # FUZZ_ARGS is a list of flags
  "$binary" "$work" -max_total_time="$seconds" -timeout="${FUZZ_TIMEOUT:-25}" \
    -artifact_prefix="$artifacts/" -print_final_stats=1 "${dict[@]}" ${FUZZ_ARGS:-} \
    >"$log" 2>&1 || status=$?
  # Executions: libFuzzer's final statistics, or the last status line (fork mode).
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  [ -n "$runs" ] || runs=$(grep -oE '^#[0-9]+' "$log" | tail -1 | tr -d '#')
  found=$(comm -13 <(echo "$before") <(ls "$artifacts") |
    grep -E '^(crash|leak|timeout|oom)-' || true)
  line="$target: ${runs:-?} executions in ${seconds} s"
  if [ "$status" -ne 0 ] || [ -n "$found" ]; then
    failed=1
    line+=", FAILED (libFuzzer exit $status)"
    grep -E '^(==[0-9]+== ?ERROR|SUMMARY|FUZZ CHECK|.*runtime error)' "$log" | head -5 || true
    for file in $found; do line+=$'\n'"    $artifacts/$file"; done
  fi
  echo "$line"
  summary+=("$line")
done

echo
echo "=== summary"
printf '%s\n' "${summary[@]}"
exit "$failed"
