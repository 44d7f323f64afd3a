#!/usr/bin/env bash
# mrpt-map-builder (CMetricMapBuilderShape fed as icp-slam feeds CMetricMapBuilderICP) against
# `shape-slam run` on the same logs, and the stock pf-localization in the CPolylineMap created
# from `shape-slam run`'s map.polylines (creation option map_file).
#   map_builder_test.sh SHAPE_SLAM MRPT_MAP_BUILDER PLUGIN.so CONFIG_DIR TEST_DATA_DIR WORK_DIR
set -u -o pipefail
bin=$1
builder=$2
plugin=$3
config_dir=$4
data=$5
work=$6
sena="/usr/share/mrpt/datasets/2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog"
[[ -r $sena ]] || { echo "SKIP: $sena missing (package mrpt-common)"; exit 77; }
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
pass() { echo "ok: $*"; }
rm -rf "$work"
mkdir -p "$work"
cd "$work" || exit 1

# Largest position difference (m) between two TUM files, matched by timestamp; "missing" when a
# timestamp of either file is not in the other.
compare_tum() {
  awk '/^#/ { next }
       FNR == NR { x[$1] = $2; y[$1] = $3; n1++; next }
       { n2++; if (!($1 in x)) { missing = 1; next }
         d = sqrt((x[$1] - $2)^2 + (y[$1] - $3)^2); if (d > worst) worst = d }
       END { if (missing || n1 != n2) print "missing"; else printf "%.9f\n", worst }' "$1" "$2"
}

# 1. The sample log (actions + sensory frames) and the observations-only log.
for log in "$sena" "$data/logs/sena_first20_obs_only.rawlog"; do
  name=$(basename "$log" .rawlog | tr ' ' _)
  "$bin" run "$log" --out "run_$name" --quiet || { fail "shape-slam run $name"; continue; }
  "$builder" "$log" --out "mb_$name" >"mb_$name.log" 2>&1 ||
    { fail "mrpt-map-builder $name (see $work/mb_$name.log)"; continue; }
  cat "mb_$name.log"
  scans=$(grep -vc '^#' "run_$name/trajectory.tum")
  [[ $(grep -vc '^#' "mb_$name/trajectory.tum") -eq $scans ]] && pass "$name: $scans poses in both" ||
    fail "$name: $(grep -vc '^#' "mb_$name/trajectory.tum") poses, shape-slam run has $scans"
  worst=$(compare_tum "run_$name/trajectory.tum" "mb_$name/trajectory.tum")
  echo "$name: largest difference to shape-slam run: $worst m"
  [[ $worst != missing ]] && awk -v d="$worst" 'BEGIN { exit !(d < 0.03) }' &&
    pass "$name: same trajectory as shape-slam run" || fail "$name: trajectories differ ($worst)"
  steps=$(wc -l <"mb_$name/log_estimated_path.txt")
  ((steps >= scans)) && pass "$name: log_estimated_path.txt has $steps steps" ||
    fail "$name: log_estimated_path.txt has $steps lines"
  for f in map.polylines map.png map.simplemap; do
    [[ -s mb_$name/$f ]] || fail "$name: no $f"
  done
  # The same polylines, vertices and counts; CPolylineMap renumbers the ids in order.
  cmp -s <(sed -E 's/^polyline [0-9]+ /polyline /' "run_$name/map.polylines") \
    <(sed -E 's/^polyline [0-9]+ /polyline /' "mb_$name/map.polylines") &&
    pass "$name: same map as shape-slam run (ids aside)" ||
    fail "$name: map.polylines differs from shape-slam run's"
done

# 2. pf-localization in the polyline map loaded from shape-slam run's map.polylines: the ready
# ini with map_file empty (the map comes from the creation option), the sample log, a start box
# within 0.5 m and 20 deg of the origin (where the log starts and the map frame is).
if command -v pf-localization >/dev/null; then
  map="$work/run_$(basename "$sena" .rawlog | tr ' ' _)/map.polylines"
  end=$(tail -1 "${map%/map.polylines}/trajectory.tum" | awk '{ print $2, $3 }')
  sed -e "s|^map_file=.*|map_file=|" -e "s|^rawlog_file=.*|rawlog_file=$sena|" \
    -e 's|^particles_count=.*|particles_count=5000|' \
    -e 's|^init_PDF_min_x=.*|init_PDF_min_x=-0.5|' -e 's|^init_PDF_max_x=.*|init_PDF_max_x=0.5|' \
    -e 's|^init_PDF_min_y=.*|init_PDF_min_y=-0.5|' -e 's|^init_PDF_max_y=.*|init_PDF_max_y=0.5|' \
    -e 's|^init_PDF_max_y=.*|&\ninit_PDF_min_yaw_deg=-20\ninit_PDF_max_yaw_deg=20|' \
    "$config_dir/pf-localization.ini" >pf.ini
  printf '[MetricMap_polylineMap_00_creationOpts]\nmap_file=%s\n' "$map" >>pf.ini
  LD_PRELOAD=$plugin pf-localization pf.ini </dev/null >pf.log 2>&1 ||
    fail "pf-localization exited $? (see $work/pf.log)"
  steps=$(grep -c "PDF estimation" pf.log)
  last=$(grep "PDF estimation" pf.log | tail -1 |
    sed -E 's/.*PDF estimation: \(([-0-9.]+),([-0-9.]+),.*/\1 \2/')
  distance=$(awk -v a="$last" -v b="$end" 'BEGIN { split(a, p, " "); split(b, q, " ");
    print sqrt((p[1] - q[1])^2 + (p[2] - q[2])^2) }')
  echo "pf-localization in map.polylines: $steps steps, ends at ($last), shape-slam at ($end): $distance m apart"
  ((steps >= 200)) && pass "pf-localization ran $steps steps" || fail "pf-localization ran $steps steps"
  [[ -n $last ]] && awk -v d="$distance" 'BEGIN { exit !(d < 0.5) }' && pass "pf-localization ends on our trajectory" ||
    fail "pf-localization in map.polylines is lost ($distance m)"
  loaded=$(ls LOG_LOCALIZATION_SHAPE_000_*/map_shape_slam__CPolylineMap_00.polylines 2>/dev/null | head -1)
  count() { grep -c "^polyline " "$1"; }
  [[ -n $loaded ]] && [[ $(count "$loaded") -eq $(count "$map") ]] &&
    pass "the map pf-localization used has the file's $(count "$map") polylines" ||
    fail "the map pf-localization saved ($loaded) is not the loaded file's"
fi

if ((failures > 0)); then
  echo "$failures check(s) failed; outputs in $work"
  exit 1
fi
echo "all checks passed"
