#!/usr/bin/env bash
# The demo (README, first command): installs what is missing, builds (Release) and runs
# ShapeSLAM's main job on the MRPT sample log that the Debian package mrpt-common installs.
# Arguments are passed on to the shape-slam tool.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh --target shape-slam
DEFAULT_LOG="/usr/share/mrpt/datasets/2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog"
if [ $# -eq 0 ]; then
  set -- extract "$DEFAULT_LOG" --scan 100 --svg shape-slam-extract.svg
fi
"${BUILD_DIR:-build}/apps/shape-slam" "$@"
