#!/usr/bin/env bash
# The MRPT files of `shape-slam run` used by MRPT: map.gridmap loaded as MRPT's apps load a
# .gridmap (and compared cell by cell with map.pgm/map.yaml) and used by the stock
# pf-localization to localise the same log in it, map.simplemap loaded by CSimpleMap and turned
# into a map by the stock observations2map.
#   run_outputs_test.sh SHAPE_SLAM MAP_OUTPUTS_CHECK WORK_DIR
set -u -o pipefail
bin=$1
check=$2
work=$3
sena="/usr/share/mrpt/datasets/2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog"
[[ -r $sena ]] || { echo "SKIP: $sena missing (package mrpt-common)"; exit 77; }
command -v observations2map >/dev/null ||
  { echo "SKIP: observations2map missing (mrpt-apps)"; exit 77; }
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
rm -rf "$work"
mkdir -p "$work"
cd "$work" || exit 1

"$bin" run "$sena" --out run --quiet || { echo "FAIL: shape-slam run"; exit 1; }
keyframes=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["keyframes"])' \
  run/stats.json)
echo "shape-slam run: $keyframes keyframes"
"$check" run/map.gridmap run/map.yaml run/map.simplemap "$keyframes" ||
  fail "map.gridmap / map.simplemap as loaded by MRPT"

# observations2map needs an existing output folder.
cat >o2m.ini <<'INI'
[MappingApplication]
occupancyGrid_count=1
[MappingApplication_occupancyGrid_00_creationOpts]
resolution=0.05
INI
mkdir -p o2m
observations2map o2m.ini run/map.simplemap o2m/map </dev/null >o2m.log 2>&1 ||
  fail "observations2map on map.simplemap exited $? (see $work/o2m.log)"
png=o2m/map_mrpt__maps__COccupancyGridMap2D_00.png
grep -q "done: $keyframes observations" o2m.log && echo "ok: observations2map read $keyframes scans" ||
  fail "observations2map did not read $keyframes scans (see $work/o2m.log)"
[[ -s $png ]] && echo "ok: observations2map wrote $png" || fail "observations2map wrote no $png"

# pf-localization (MRPT's shipped localization_demo.ini, headless) on the same log in
# map.gridmap, from a uniform start within 0.5 m and 20 deg of the map's origin (where the log
# starts; the app seeds its random generator from the clock, so the start box is kept narrow):
# its last estimate must lie where shape-slam's trajectory ends.
shipped=/usr/share/mrpt/config_files/pf-localization/localization_demo.ini
if [[ -r $shipped ]] && command -v pf-localization >/dev/null; then
  sed -e "s|^map_file=.*|map_file=$work/run/map.gridmap|" -e "s|^rawlog_file=.*|rawlog_file=$sena|" \
    -e 's|^3DSceneFrequency=.*|3DSceneFrequency=-1|' \
    -e 's|^SHOW_PROGRESS_3D_REAL_TIME.*|SHOW_PROGRESS_3D_REAL_TIME=false|' \
    -e 's|^particles_count=.*|particles_count=10000|' \
    -e 's|^init_PDF_min_x=.*|init_PDF_min_x=-0.5|' -e 's|^init_PDF_max_x=.*|init_PDF_max_x=0.5|' \
    -e 's|^init_PDF_min_y=.*|init_PDF_min_y=-0.5|' -e 's|^init_PDF_max_y=.*|init_PDF_max_y=0.5|' \
    -e 's|^init_PDF_max_y=.*|&\ninit_PDF_min_yaw_deg=-20\ninit_PDF_max_yaw_deg=20|' \
    "$shipped" >pf.ini
  pf-localization pf.ini </dev/null >pf.log 2>&1 ||
    fail "pf-localization on map.gridmap exited $? (see $work/pf.log)"
  last=$(grep "PDF estimation" pf.log | tail -1 |
    sed -E 's/.*PDF estimation: \(([-0-9.]+),([-0-9.]+),.*/\1 \2/')
  end=$(tail -1 run/trajectory.tum | awk '{ print $2, $3 }')
  distance=$(awk -v a="$last" -v b="$end" 'BEGIN { split(a, p, " "); split(b, q, " ");
    print sqrt((p[1] - q[1])^2 + (p[2] - q[2])^2) }')
  echo "pf-localization in map.gridmap ends at ($last), shape-slam at ($end): $distance m apart"
  awk -v d="$distance" 'BEGIN { exit !(d < 0.5) }' || fail "pf-localization in map.gridmap is lost"
fi

if ((failures > 0)); then
  echo "$failures check(s) failed; outputs in $work"
  exit 1
fi
echo "all checks passed"
