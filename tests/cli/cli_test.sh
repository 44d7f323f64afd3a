#!/usr/bin/env bash
# Command-line tests of shape-slam: every command's help, the main jobs on small real logs, and
# bad input (clear message naming the problem, non-zero exit, no crash, nothing lost).
# Usage: cli_test.sh SHAPE_SLAM_BINARY TEST_DATA_DIR
set -uo pipefail
BIN=$1
DATA=$2
SENA="/usr/share/mrpt/datasets/2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog"
# WORK, fail, pass, expect CODE PATTERN -- command...
source "$(dirname "${BASH_SOURCE[0]}")/checks.sh"

# Help everywhere.
expect 0 "Commands:" -- "$BIN" --help
for cmd in run localize extract match eval convert; do
  expect 0 "Usage: shape-slam $cmd" -- "$BIN" "$cmd" --help
done
expect 2 "unknown command" -- "$BIN" frobnicate
expect 0 "--grid-resolution M" -- "$BIN" run --help
expect 0 "map.simplemap" -- "$BIN" run --help
# The version is CMake's project(VERSION).
version=$(sed -n 's/^project(shape_slam VERSION \([0-9.]*\).*/\1/p' "$DATA/../../CMakeLists.txt")
[ -n "$version" ] || fail "no project(VERSION) in CMakeLists.txt"
expect 0 "^shape-slam ${version//./\\.}\$" -- "$BIN" --version
expect 0 "^shape-slam ${version//./\\.}\$" -- "$BIN" version
expect 2 "Usage" -- "$BIN"

# extract and match on a small CARMEN log.
LOG="$DATA/logs/intel_head.log"
expect 0 '"polylines"' -- "$BIN" extract "$LOG" --scan 1 --json
expect 0 '^-?[0-9.e-]+ -?[0-9.e-]+ -?[0-9.e-]+$' -- "$BIN" match "$LOG" --scan 0 --to 1
expect 0 '"T_i_j":\[' -- "$BIN" match "$LOG" --scan 0 --to 1 --json --guess 0.1 0 0.05
expect 1 "scan 99 does not exist" -- "$BIN" match "$LOG" --scan 0 --to 99
expect 2 "required" -- "$BIN" match "$LOG" --scan 0
expect 2 "--guess" -- "$BIN" match "$LOG" --scan 0 --to 1 --guess 1 nan 0

# convert, then map the converted rawlog; evaluate the run against itself (ATE 0).
expect 0 "laser scans" -- "$BIN" convert "$LOG" "$WORK/head.rawlog"
# The action-observation layout (rbpf-slam, graphslam-engine) reads back as the same scans.
expect 0 "3 action-observation pairs, 3 scans with odometry" -- \
  "$BIN" convert "$LOG" "$WORK/pairs.rawlog" --format pairs
expect 0 "" -- "$BIN" run "$WORK/pairs.rawlog" --out "$WORK/pairs" --quiet
[ "$(grep -vc "^#" "$WORK/pairs/trajectory.tum")" = 3 ] || fail "pairs rawlog: not 3 scans mapped"
expect 2 "neither observations nor pairs" -- "$BIN" convert "$LOG" "$WORK/x.rawlog" --format xyz
expect 0 "" -- "$BIN" run "$WORK/head.rawlog" --out "$WORK/head" --quiet
for f in trajectory.tum map.polylines map.svg map.png map.pgm map.yaml map.gridmap map.simplemap \
  scan_times.csv loops.csv stats.json; do
  [ -s "$WORK/head/$f" ] || fail "run did not write $f"
done
[ "$(head -n 1 "$WORK/head/scan_times.csv")" = "scan,timestamp_s,ms,track,keyframe" ] || fail "scan_times.csv header"
[ "$(($(wc -l < "$WORK/head/scan_times.csv") - 1))" = "$(grep -vc "^#" "$WORK/head/trajectory.tum")" ] ||
  fail "scan_times.csv: not one line per scan"
head -n 1 "$WORK/head/loops.csv" | grep -q "^new_keyframe,old_keyframe,new_timestamp_s,old_timestamp_s,decision," ||
  fail "loops.csv header"
# bench/tools/loop_errors.py reads it (the run's own trajectory standing in for the reference).
TOOLS="$DATA/../../bench/tools"
expect 0 "wrong closures in the graph: " -- python3 "$TOOLS/loop_errors.py" "$WORK/head/loops.csv" \
  "$WORK/head/trajectory.tum" --max-dt 0.01
expect 2 "loop_errors: .*no-such" -- python3 "$TOOLS/loop_errors.py" "$WORK/no-such.csv" \
  "$WORK/head/trajectory.tum"
expect 0 "usage: loop_errors.py" -- python3 "$TOOLS/loop_errors.py" --help
# bench/tools/heading_drift.py: a trajectory turned 0.001 rad more at every step than its
# reference drifts +0.0573 deg a step; the log's odometry is measured beside it.
awk '!/^#/ { print $1, $2, $3, 2 * atan2($7, $8) }' "$WORK/head/trajectory.tum" > "$WORK/ref.txt"
awk '{ print $1, $2, $3, $4 + 0.001 * NR }' "$WORK/ref.txt" > "$WORK/turned.txt"
expect 0 "trajectory: heading drift .* deg over [0-9]+ steps \\(\\+0\\.0573 deg a step" -- \
  python3 "$TOOLS/heading_drift.py" "$WORK/turned.txt" "$WORK/ref.txt" --max-dt 0.01
expect 0 "odometry: heading drift" -- python3 "$TOOLS/heading_drift.py" "$WORK/ref.txt" \
  "$WORK/ref.txt" --log "$LOG" --max-dt 0.01
expect 2 "heading_drift: .*no-such" -- python3 "$TOOLS/heading_drift.py" "$WORK/no-such.tum" \
  "$WORK/ref.txt"
expect 0 "usage: heading_drift.py" -- python3 "$TOOLS/heading_drift.py" --help
head -c 2 "$WORK/head/map.pgm" | grep -q P5 || fail "map.pgm is not a binary PGM"
grep -qx "image: map.pgm" "$WORK/head/map.yaml" || fail "map.yaml does not name map.pgm"
grep -qx "resolution: 0.05" "$WORK/head/map.yaml" || fail "map.yaml: default resolution not 0.05"
grep -Eqx "origin: \[-?[0-9.e-]+, -?[0-9.e-]+, 0\.0\]" "$WORK/head/map.yaml" || fail "map.yaml origin"
# The grid options: resolution, each output switched off, bad values (usage errors, exit 2).
expect 0 "" -- "$BIN" run "$WORK/head.rawlog" --out "$WORK/coarse" --quiet --grid-resolution 0.1
grep -qx "resolution: 0.1" "$WORK/coarse/map.yaml" || fail "--grid-resolution 0.1 not in map.yaml"
[ "$(wc -c <"$WORK/coarse/map.pgm")" -lt "$(wc -c <"$WORK/head/map.pgm")" ] ||
  fail "a coarser grid is not smaller"
expect 0 "" -- "$BIN" run "$WORK/head.rawlog" --out "$WORK/nogrid" --quiet --no-grid --no-gridmap \
  --no-simplemap
for f in map.pgm map.yaml map.gridmap map.simplemap; do
  [ ! -e "$WORK/nogrid/$f" ] || fail "--no-grid/--no-gridmap/--no-simplemap still wrote $f"
done
[ -s "$WORK/nogrid/map.polylines" ] || fail "--no-grid dropped map.polylines"
expect 0 "" -- "$BIN" run "$WORK/head.rawlog" --out "$WORK/onlyros" --quiet --no-gridmap \
  --no-simplemap
[ -s "$WORK/onlyros/map.pgm" ] && [ ! -e "$WORK/onlyros/map.gridmap" ] &&
  [ ! -e "$WORK/onlyros/map.simplemap" ] || fail "--no-gridmap --no-simplemap"
for bad in -1 0 abc nan; do
  expect 2 "grid-resolution.*'$bad'" -- "$BIN" run "$WORK/head.rawlog" --out "$WORK/o" \
    --grid-resolution "$bad"
done
expect 0 "ATE \(RMSE\) +0\.0+ m" -- "$BIN" eval "$WORK/head/trajectory.tum" "$WORK/head/trajectory.tum"
# Gross local errors: a 1 m slide after the first pose is one step off by more than 0.5 m.
expect 0 "gross local err 0 of [1-9][0-9]* steps \(off by > 0\.5 m or > 10 deg\)" -- \
  "$BIN" eval "$WORK/head/trajectory.tum" "$WORK/head/trajectory.tum"
awk '!/^#/ && n++ > 0 { $2 += 1.0 } { print }' "$WORK/head/trajectory.tum" >"$WORK/slide.tum"
expect 0 '"gross_local":\{"count":1,"steps":[1-9]' -- \
  "$BIN" eval "$WORK/slide.tum" "$WORK/head/trajectory.tum" --json
expect 0 '"gross_local":\{"count":0,' -- \
  "$BIN" eval "$WORK/slide.tum" "$WORK/head/trajectory.tum" --json --gross-m 1.5
# --list-gross names the step: from the first pose (0) to the second (1), moved 1 m more.
expect 0 "pose 0 -> 1 \(t [0-9.]+ -> [0-9.]+\): moved .*, off by 1\.000 m 0\.0 deg" -- \
  "$BIN" eval "$WORK/slide.tum" "$WORK/head/trajectory.tum" --list-gross
expect 0 '"list":\[\{"index":1,"t1":[0-9.e+-]+,"t2":[0-9.e+-]+,"estimated":\[' -- \
  "$BIN" eval "$WORK/slide.tum" "$WORK/head/trajectory.tum" --json --list-gross
expect 2 "gross-deg must be >= 0" -- \
  "$BIN" eval "$WORK/slide.tum" "$WORK/head/trajectory.tum" --gross-deg -1

# The demo: the MRPT sample log, default output names, a sane map.
if [ -f "$SENA" ]; then
  expect 0 "" -- "$BIN" run "$SENA" --out "$WORK/sena" --quiet --no-odometry --max-scans 40
  python3 - "$WORK/sena/stats.json" <<'PY' || fail "stats.json of the sample log is not sane"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["scans"] == 40, d
assert d["map"]["polylines"] > 10 and d["map"]["vertices"] >= 2 * d["map"]["polylines"], d
assert 0 < d["per_scan_ms"]["median"] <= d["per_scan_ms"]["max"], d
PY
fi

# Bad input: wrong paths, directories, empty files, garbage, truncated gzip, bad ini.
expect 1 "cannot open|No such file|does not exist" -- "$BIN" run "$WORK/missing.log" --out "$WORK/o"
expect 1 "directory" -- "$BIN" run "$WORK" --out "$WORK/o"
: >"$WORK/empty.log"
expect 1 "empty" -- "$BIN" run "$WORK/empty.log" --out "$WORK/o"
head -c 3000 /dev/urandom >"$WORK/garbage.log"
expect 1 "error" -- "$BIN" run "$WORK/garbage.log" --out "$WORK/o"
gzip -c "$LOG" | head -c 600 >"$WORK/truncated.log.gz"
expect 1 "truncated|corrupt|gzip" -- "$BIN" extract "$WORK/truncated.log.gz" --scan 3
printf '[matcher]\nno_such_key = 1\n' >"$WORK/bad-key.ini"
expect 1 "no_such_key" -- "$BIN" run "$LOG" --config "$WORK/bad-key.ini" --out "$WORK/o"
printf '[matcher]\nskip_penalty_per_m = abc\n' >"$WORK/bad-value.ini"
expect 1 "skip_penalty_per_m" -- "$BIN" run "$LOG" --config "$WORK/bad-value.ini" --out "$WORK/o"
# NaN, inf and negative ranges are "no reading": the run completes and counts them.
sed -e '0,/^FLASER/s/^FLASER \([0-9]*\) [^ ]* [^ ]* [^ ]*/FLASER \1 nan inf -1/' "$LOG" >"$WORK/nan.log"
expect 0 "" -- "$BIN" run "$WORK/nan.log" --out "$WORK/nan" --quiet
grep -q '"invalid_ranges": *3' "$WORK/nan/stats.json" || fail "invalid ranges not counted: $(cat "$WORK/nan/stats.json")"
# A scan with no valid reading at all: mapped as nothing, no crash.
awk '/^FLASER/ && !done {n=$2; printf "FLASER %d", n; for (i=0;i<n;i++) printf " nan"; for (i=n+3;i<=NF;i++) printf " %s", $i; print ""; done=1; next} {print}' "$LOG" >"$WORK/noscan.log"
expect 0 "" -- "$BIN" run "$WORK/noscan.log" --out "$WORK/noscan" --quiet

# A corrupt rawlog on which MRPT 2.5.8's own decoder crashes (found by fuzzing): a clear error,
# exit 1, no core dump. (Sanitizer builds leave fatal signals to the sanitizer's report.)
SEGV_LOG="$DATA/../../fuzz/findings/rawlog_reader/mrpt_segv_action_movement.rawlog"
sanitized=$(ldd "$BIN" 2>/dev/null | grep -c libasan || true)  # not grep -q: pipefail + SIGPIPE
if [ -f "$SEGV_LOG" ] && [ "$sanitized" = "0" ]; then
  # scan 0 is the frame before the corrupt action collection; scan 1 needs that entry.
  expect 1 "fatal signal.*reading the log" -- "$BIN" extract "$SEGV_LOG" --scan 1
fi

# A log whose odometry is all zero (how real logs without odometry look): noticed, said on
# stderr and in stats.json, mapped by shape alone.
awk '$1 == "ODOM" { $2 = 0; $3 = 0; $4 = 0 }
     $1 == "FLASER" { n = $2; for (i = n + 3; i <= n + 8; ++i) $i = 0 } { print }' "$LOG" \
  >"$WORK/zero-odom.log"
expect 0 "odometry never changes" -- "$BIN" run "$WORK/zero-odom.log" --out "$WORK/zero" --quiet
grep -q '"status": *"constant"' "$WORK/zero/stats.json" || fail "stats.json: odometry not 'constant'"
expect 0 "" -- "$BIN" run "$LOG" --out "$WORK/moving" --quiet
grep -q '"status": *"used"' "$WORK/moving/stats.json" || fail "stats.json: odometry not 'used'"
# localize: in the map that run made of the same log, without and with --initial (the run's
# first pose); the map file is left unchanged; bad maps name the file and line (exit 1).
map_sum=$(cksum <"$WORK/moving/map.polylines")
expect 0 "localized [0-9]+ of 3 scans" -- "$BIN" localize "$WORK/moving/map.polylines" "$LOG" \
  --out "$WORK/loc"
[ "$(cksum <"$WORK/moving/map.polylines")" = "$map_sum" ] || fail "localize changed the map file"
for f in trajectory.tum map.svg map.png status.csv stats.json; do
  [ -s "$WORK/loc/$f" ] || fail "localize did not write $f"
done
grep -q "trajectory" "$WORK/loc/map.svg" || fail "localize: map.svg has no trajectory layer"
python3 - "$WORK/loc/stats.json" "$WORK/loc/trajectory.tum" "$WORK/loc/status.csv" <<'PY' || fail "localize outputs not sane"
import csv, json, sys
d = json.load(open(sys.argv[1]))
assert d["scans"] == 3 and d["localized_scans"] >= 1 and 0 <= d["first_localized_scan"] <= 1, d
assert d["lost_events"] == 0 and d["per_scan_ms"]["median"] > 0, d
poses = [l for l in open(sys.argv[2]) if l.strip() and not l.startswith("#")]
assert len(poses) == d["localized_scans"], (len(poses), d)
# status.csv: one row per scan, its status and localized flag as stats.json counts them, and
# the pose of each localized row the trajectory's.
rows = list(csv.DictReader(open(sys.argv[3])))
assert [int(r["scan"]) for r in rows] == [0, 1, 2], rows
for name, count in d["status_counts"].items():
    assert sum(r["status"] == name for r in rows) == count, (name, rows)
localized = [r for r in rows if r["localized"] == "1"]
assert len(localized) == d["localized_scans"] and all(r["status"] == "tracking" for r in localized), rows
for r, p in zip(localized, poses):
    assert abs(float(r["x"]) - float(p.split()[1])) < 1e-6 and abs(float(r["y"]) - float(p.split()[2])) < 1e-6, (r, p)
PY
read -r _ x y _ _ _ qz qw < <(grep -v '^#' "$WORK/moving/trajectory.tum" | head -n 1)
theta=$(python3 -c "import math; print(2 * math.atan2($qz, $qw))")
expect 0 "localized 3 of 3 scans" -- "$BIN" localize "$WORK/moving/map.polylines" "$LOG" \
  --out "$WORK/loc-init" --initial "$x" "$y" "$theta"
grep -q '"first_localized_scan": *0' "$WORK/loc-init/stats.json" || fail "--initial: not localized at scan 0"
expect 2 "--initial" -- "$BIN" localize "$WORK/moving/map.polylines" "$LOG" --initial 1 nan 0
expect 2 "missing argument LOG" -- "$BIN" localize "$WORK/moving/map.polylines"
expect 1 "garbage.log:[0-9]+:" -- "$BIN" localize "$WORK/garbage.log" "$LOG" --out "$WORK/o"
head -n 6 "$WORK/moving/map.polylines" >"$WORK/truncated.polylines"
expect 1 "truncated.polylines:[0-9]+:.*(end of file|expected)" -- \
  "$BIN" localize "$WORK/truncated.polylines" "$LOG" --out "$WORK/o"
expect 1 "missing.polylines" -- "$BIN" localize "$WORK/missing.polylines" "$LOG" --out "$WORK/o"
# Fewer than 90 % of the scans matched: a warning with the count, and the flag in stats.json.
printf '[pipeline]\nmin_inlier_ratio = 1.0\n' >"$WORK/never-trusted.ini"
expect 0 "warning: only [0-9]+ of [0-9]+ scans" -- \
  "$BIN" run "$LOG" --config "$WORK/never-trusted.ini" --out "$WORK/untrusted" --quiet
grep -q '"low_match_warning": *true' "$WORK/untrusted/stats.json" || fail "stats.json: no low_match_warning"
# eval warns when it associates fewer than 90 % of the reference poses.
head -n 2 "$WORK/moving/trajectory.tum" >"$WORK/short.tum"
expect 0 "warning: only 1 of 3 reference poses" -- "$BIN" eval "$WORK/short.tum" "$WORK/moving/trajectory.tum"

# A failed run leaves earlier results in the output directory untouched.
mkdir -p "$WORK/keep"
echo "precious" >"$WORK/keep/trajectory.tum"
expect 1 "no_such_key" -- "$BIN" run "$LOG" --config "$WORK/bad-key.ini" --out "$WORK/keep"
[ "$(cat "$WORK/keep/trajectory.tum")" = "precious" ] || fail "a failed run overwrote trajectory.tum"
[ -z "$(find "$WORK/keep" -name '*.tmp*')" ] || fail "temporary files left behind"

if [ "$failures" -ne 0 ]; then
  echo "$failures CLI check(s) failed"
  exit 1
fi
echo "all CLI checks passed"
