#!/usr/bin/env bash
# install_consumer test: installs the build tree into a temporary prefix, builds the consumer
# project against it with find_package(shape_slam), runs it; the README's library example is
# part of it (shape_slam::io), run on LOG with the installed default.ini.
#   run_consumer_test.sh BUILD_DIR CONSUMER_SOURCE_DIR WORK_DIR EXPECT_MRPT(0|1) README LOG
set -eu -o pipefail
build=$1
source_dir=$2
work=$3
expect_mrpt=$4
readme=$5
log=$6
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
have_io=0
[[ -e $build/src/io/libshape_slam_io.a ]] && have_io=1
if [[ $have_io == 1 ]]; then
  test -f "$prefix/lib/libshape_slam_io.a"
  test -f "$prefix/include/shape_slam_io/log_reader.h"
fi
test -f "$prefix/share/shape_slam/default.ini"
test -f "$prefix/share/shape_slam/mrpt/icp-slam.ini"
test -f "$prefix/share/shape_slam/mrpt/observations2map.ini"
if [[ $expect_mrpt == 1 ]]; then
  test -f "$prefix/lib/libshape_slam_mrpt.so"
  test -f "$prefix/include/shape_slam_mrpt/polyline_map.h"
fi
if [[ -e $build/apps/shape-slam ]]; then
  test -x "$prefix/bin/shape-slam"
fi

# The first C++ block of the README's "Using the library" section, verbatim.
awk '/^## Using the library/ { section = 1; next }
     section && /^## / { exit }
     section && /^```cpp$/ { code = 1; next }
     code && /^```$/ { exit }
     code { print }' "$readme" >"$work/readme_main.cpp"
grep -q "int main" "$work/readme_main.cpp" || { echo "no C++ example in $readme"; exit 1; }

generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
cmake -S "$source_dir" -B "$work/build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_PREFIX_PATH="$prefix" -DREADME_EXAMPLE="$work/readme_main.cpp" >"$work/configure.log"
cmake --build "$work/build" -j2 >"$work/build.log"
"$work/build/consumer_core"
if [[ $have_io == 1 ]]; then
  # README example: one "t x y theta" line per scan on stdout, the polyline count on stderr.
  "$work/build/consumer_readme" "$log" "$prefix/share/shape_slam/default.ini" \
    >"$work/readme.out" 2>"$work/readme.err"
  scans=$(awk 'NF == 4' "$work/readme.out" | wc -l)
  grep -Eq '^[1-9][0-9]* polylines, [0-9]+ loop closures$' "$work/readme.err" ||
    { echo "README example: unexpected stderr: $(cat "$work/readme.err")"; exit 1; }
  [[ $scans -gt 0 ]] || { echo "README example printed no pose"; exit 1; }
  echo "README example: $scans poses, $(cat "$work/readme.err")"
fi
if [[ $expect_mrpt == 1 ]]; then
  "$work/build/consumer_mrpt"
fi
echo "consumer built and ran against the installed package"
