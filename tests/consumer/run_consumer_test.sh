#!/usr/bin/env bash
# install_consumer test: installs the build tree into a temporary prefix, builds the consumer
# project against it with find_package(shape_slam), runs it.
#   run_consumer_test.sh BUILD_DIR CONSUMER_SOURCE_DIR WORK_DIR EXPECT_MRPT(0|1)
set -eu -o pipefail
build=$1
source_dir=$2
work=$3
expect_mrpt=$4
rm -rf "$work"
mkdir -p "$work"
prefix=$work/prefix

cmake --install "$build" --prefix "$prefix" >"$work/install.log"
echo "installed into $prefix"
# The layout a user relies on.
test -f "$prefix/include/shape_slam/pipeline.h"
test ! -e "$prefix/include/shape_slam/internal" || { echo "internal headers installed"; exit 1; }
test -f "$prefix/lib/libshape_slam_core.a"
test -f "$prefix/lib/cmake/shape_slam/shape_slamConfig.cmake"
test -f "$prefix/lib/cmake/shape_slam/shape_slamConfigVersion.cmake"
if [[ $expect_mrpt == 1 ]]; then
  test -f "$prefix/lib/libshape_slam_mrpt.so"
  test -f "$prefix/include/shape_slam_mrpt/polyline_map.h"
fi
if [[ -e $build/apps/shape-slam ]]; then
  test -x "$prefix/bin/shape-slam"
fi

generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
cmake -S "$source_dir" -B "$work/build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" >"$work/configure.log"
cmake --build "$work/build" -j2 >"$work/build.log"
"$work/build/consumer_core"
if [[ $expect_mrpt == 1 ]]; then
  "$work/build/consumer_mrpt"
fi
echo "consumer built and ran against the installed package"
