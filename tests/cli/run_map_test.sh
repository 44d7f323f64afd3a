#!/usr/bin/env bash
# shape-slam run --map: a map of scans 0-249 of a development log (intel) continued with scans
# 150-399 (a log cut from the same file: its first scan is not at the map's origin), placed by
# the global search or by --initial. Where the two overlap the continued run's poses agree with
# the first run's, its map keeps the loaded polylines and extends them, the input map is never
# overwritten, and bad maps or a map the scans do not fit are clear errors. Two sessions: the
# first half of the log mapped, the second half continued in that map; together they match the
# reference poses as one run does.
# Usage: run_map_test.sh SHAPE_SLAM_BINARY DATASETS_DIR
set -uo pipefail
BIN=$1
LOG=$2/radish/intel.log.gz
# WORK, fail, pass, expect CODE PATTERN -- command...
source "$(dirname "${BASH_SOURCE[0]}")/checks.sh"

# compare.py FIRST_RUN CONTINUED_RUN: the scans of the first run, those the continued run has too
# (same timestamp), the fraction of these within 0.1 m, the fraction of the loaded map's vertices within 0.1 m of the
# continued map's polylines, and the continued map's vertices farther than 0.5 m from the loaded
# map (what it added).
cat >"$WORK/compare.py" <<'PY'
import math, sys
from collections import defaultdict

def tum(path):
    return {round(float(f[0]), 6): (float(f[1]), float(f[2]))
            for f in (l.split() for l in open(path)) if f and not f[0].startswith("#")}

def polylines(path):
    out, current = [], None
    for line in open(path):
        f = line.split()
        if not f or f[0].startswith("#") or f[0] in ("shape-slam-polylines", "polylines"):
            continue
        if f[0] == "polyline":
            current = []
            out.append(current)
        else:
            current.append((float(f[0]), float(f[1])))
    return out

def segment_distance(p, a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    n = dx * dx + dy * dy
    t = 0.0 if n == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / n))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)

class Segments:  # a 1 m grid of the segments, for distance queries up to 1 m
    def __init__(self, lines):
        self.cells = defaultdict(list)
        for line in lines:
            pairs = list(zip(line, line[1:])) or [(line[0], line[0])]
            for a, b in pairs:
                for i in range(math.floor(min(a[0], b[0])) - 1, math.floor(max(a[0], b[0])) + 2):
                    for j in range(math.floor(min(a[1], b[1])) - 1, math.floor(max(a[1], b[1])) + 2):
                        self.cells[(i, j)].append((a, b))
    def distance(self, p):
        near = self.cells.get((math.floor(p[0]), math.floor(p[1])), [])
        return min((segment_distance(p, a, b) for a, b in near), default=math.inf)

first, continued = sys.argv[1], sys.argv[2]
a, b = tum(first + "/trajectory.tum"), tum(continued + "/trajectory.tum")
common = [t for t in a if t in b]
agree = sum(math.hypot(a[t][0] - b[t][0], a[t][1] - b[t][1]) <= 0.1 for t in common)
loaded, extended = polylines(first + "/map.polylines"), polylines(continued + "/map.polylines")
ext, old = Segments(extended), Segments(loaded)
vertices = [p for line in loaded for p in line]
kept = sum(ext.distance(p) <= 0.1 for p in vertices)
added = sum(old.distance(p) > 0.5 for line in extended for p in line)
print("%d %d %.4f %.4f %d" % (len(a), len(common), agree / max(1, len(common)),
                              kept / max(1, len(vertices)), added))
PY

[ -r "$LOG" ] || { echo "SKIP: $LOG missing"; exit 77; }
expect 0 "--map MAP" -- "$BIN" run --help
expect 0 "Continuing a map" -- "$BIN" run --help

# Scans 0-249 mapped; scans 150-399 (the log from its 151st FLASER on) continue that map, the
# first one placed by the global search.
expect 0 "" -- "$BIN" run "$LOG" --max-scans 250 --out "$WORK/first" --quiet
map_sum=$(cksum <"$WORK/first/map.polylines")
zcat "$LOG" | awk '$1 == "FLASER" { n++ } $1 == "#" || $1 == "PARAM" || n > 150' >"$WORK/later.log"
expect 0 "continued the map .* from scan [0-9]+" -- "$BIN" run "$WORK/later.log" --max-scans 250 \
  --map "$WORK/first/map.polylines" --out "$WORK/global"
[ "$(cksum <"$WORK/first/map.polylines")" = "$map_sum" ] || fail "run --map changed the input map"
read -r scans common agree kept added < <(python3 "$WORK/compare.py" "$WORK/first" "$WORK/global")
echo "global search: $common of the first run's $scans scans in the continued run, $agree of" \
  "them within 0.1 m; $kept of the loaded map's vertices kept (0.1 m); $added vertices added" \
  "(> 0.5 m from it)"
awk -v c="$common" -v f="$agree" 'BEGIN { exit !(c >= 90 && f >= 0.9) }' &&
  pass "poses agree with the first run" || fail "$common scans in common, $agree within 0.1 m"
awk -v f="$kept" 'BEGIN { exit !(f >= 0.95) }' && pass "the loaded map is kept" ||
  fail "only $kept of the loaded map's vertices are in the output map"
((added >= 50)) && pass "the map is extended ($added vertices)" || fail "only $added vertices added"
python3 - "$WORK/global/stats.json" "$WORK/first/map.polylines" <<'PY' || fail "stats.json start_map"
import json, sys
d = json.load(open(sys.argv[1]))["start_map"]
assert d["path"] == sys.argv[2] and d["polylines"] > 0 and not d["initial_pose_given"], d
assert 0 <= d["first_scan"] < 20, d
PY

# --initial: the first scan starts at the first run's pose of scan 150.
read -r _ x y _ _ _ qz qw < <(grep -v '^#' "$WORK/first/trajectory.tum" | sed -n 151p)
theta=$(python3 -c "import math; print(2 * math.atan2($qz, $qw))")
expect 0 "from scan 0 at" -- "$BIN" run "$WORK/later.log" --max-scans 150 \
  --map "$WORK/first/map.polylines" --initial "$x" "$y" "$theta" --out "$WORK/initial"
read -r scans common agree kept added < <(python3 "$WORK/compare.py" "$WORK/first" "$WORK/initial")
echo "--initial: $common scans in common, $agree of them within 0.1 m"
awk -v c="$common" -v f="$agree" 'BEGIN { exit !(c == 100 && f >= 0.9) }' &&
  pass "--initial: poses agree" || fail "--initial: $common scans in common, $agree agree"
grep -q '"first_scan": *0' "$WORK/initial/stats.json" || fail "--initial: first_scan is not 0"

# Two sessions: the first half of the log mapped, the second half (scans 455-909, which
# revisit the first half's rooms) localized in that map by the global search and continued
# with run --map. The two halves agree when their trajectories together, aligned once, match
# the reference poses as one run's would: ATE <= 0.15 m (one run of the whole log: 0.077 m),
# no gross local error at the seam, and the revisits between the halves within 0.10 m.
expect 0 "" -- "$BIN" run "$LOG" --max-scans 455 --out "$WORK/half1" --quiet
zcat "$LOG" | awk '$1 == "FLASER" { n++ } $1 == "#" || $1 == "PARAM" || n > 455' >"$WORK/half2.log"
expect 0 "continued the map" -- "$BIN" run "$WORK/half2.log" --map "$WORK/half1/map.polylines" \
  --out "$WORK/half2"
{ cat "$WORK/half1/trajectory.tum"; grep -v '^#' "$WORK/half2/trajectory.tum"; } >"$WORK/halves.tum"
"$BIN" eval "$WORK/halves.tum" "$2/radish/intel.gt.txt" "$2/radish/intel.relations" --json \
  >"$WORK/halves.json" 2>/dev/null || fail "eval of the two halves failed"
python3 - "$WORK/halves.json" <<'PY' && pass "the two sessions agree" || fail "the two sessions disagree"
import json, sys
d = json.load(open(sys.argv[1]))
print("two sessions: %d poses, ATE %.3f m, revisits %.3f m %.2f deg, gross %d" % (
    d["matched_poses"], d["ate_m"], d["revisit"]["trans_m"], d["revisit"]["rot_deg"],
    d["gross_local"]["count"]))
assert d["matched_poses"] >= 900 and d["ate_m"] <= 0.15, d
assert d["revisit"]["trans_m"] <= 0.10 and d["gross_local"]["count"] == 0, d
PY

# Never overwrite the input map; bad maps name the file and line; no fit is an error.
expect 2 "would overwrite the input map" -- \
  "$BIN" run "$LOG" --max-scans 5 --map "$WORK/first/map.polylines" --out "$WORK/first"
expect 2 "would overwrite the input map" -- \
  "$BIN" run "$LOG" --max-scans 5 --map "$WORK/first/map.polylines" --out "$WORK/first/../first/"
[ "$(cksum <"$WORK/first/map.polylines")" = "$map_sum" ] || fail "the refused run changed the map"
expect 2 "need --map" -- "$BIN" run "$LOG" --initial 0 0 0 --out "$WORK/o"
expect 2 "--initial" -- "$BIN" run "$LOG" --map "$WORK/first/map.polylines" --initial 0 x 0 --out "$WORK/o"
expect 1 "intel.log.gz:1: not a ShapeSLAM map file" -- \
  "$BIN" run "$LOG" --max-scans 5 --map "$LOG" --out "$WORK/o"
sed '0,/^shape-slam-polylines 1/s//shape-slam-polylines 7/' "$WORK/first/map.polylines" >"$WORK/v7.polylines"
expect 1 "v7.polylines:[0-9]+: unsupported map file version 7" -- \
  "$BIN" run "$LOG" --max-scans 5 --map "$WORK/v7.polylines" --out "$WORK/o"
head -n 20 "$WORK/first/map.polylines" >"$WORK/truncated.polylines"
expect 1 "truncated.polylines:[0-9]+: unexpected end of file" -- \
  "$BIN" run "$LOG" --max-scans 5 --map "$WORK/truncated.polylines" --out "$WORK/o"
printf 'shape-slam-polylines 1\npolylines 1\npolyline 0 2 1 0\n100 100 1\n100.5 100 1\n' \
  >"$WORK/elsewhere.polylines"
expect 1 "none of the first 3 scans .* could be localized in the map" -- "$BIN" run "$LOG" \
  --max-scans 50 --map "$WORK/elsewhere.polylines" --search-scans 3 --out "$WORK/o"
[ ! -e "$WORK/o/trajectory.tum" ] || fail "a failed run --map wrote outputs"

if [ "$failures" -ne 0 ]; then
  echo "$failures run --map check(s) failed"
  exit 1
fi
echo "all run --map checks passed"
