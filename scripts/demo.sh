#!/usr/bin/env bash
# The demo (README, first command): installs what is missing, builds (Release) and runs
# ShapeSLAM's main job, `shape-slam run`, on the MRPT sample log that the Debian package
# mrpt-common installs (the tool's default log). Outputs go to ./shape-slam-out (trajectory,
# map.polylines, map.svg, map.png, stats.json). Arguments replace the default `run`, e.g.
#   bash scripts/demo.sh run datasets/radish/intel.log.gz --out intel-out
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh --target shape-slam
if [ $# -eq 0 ]; then
  set -- run
fi
"${BUILD_DIR:-build}/apps/shape-slam" "$@"
