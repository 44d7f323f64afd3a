#!/usr/bin/env python3
"""Scores the loop closures of a `shape-slam run` (its loops.csv) against reference poses.

Each closure's edge (the old keyframe's robot frame to the new one's) is compared with the
reference's relative pose of the two scans (reference poses by timestamp, as `eval` associates
them). A closure is wrong when the two differ by more than --max-m or --max-deg; a closure that
holds only the heading and the offset across a corridor (loops.csv across_only = 1) is judged on
those (its position along the corridor, along_rad, is the graph's own guess). Prints, per
decision (agreed, taken, pending, confirmed, refused), how many closures there were and how many
were wrong, then every wrong closure that went into the graph (agreed, taken, confirmed): the
ones that bent the map.

  bench/tools/loop_errors.py OUT/loops.csv datasets/radish/infinite-corridor.gt.txt
  bench/tools/loop_errors.py OUT/loops.csv GT --all     # every closure, right or wrong
  bench/tools/loop_errors.py OUT/loops.csv GT --json    # counts as one JSON object

Exit status: 0, or 2 on unreadable input. Standard library only.
"""
import argparse
import csv
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import trajectories  # noqa: E402  (bench/tools, beside this script)
import variants  # noqa: E402

ACCEPTED = ("agreed", "taken", "confirmed")
DECISIONS = ("agreed", "taken", "pending", "confirmed", "refused", "ambiguous")


def score(loops_path, reference_path, max_m, max_deg, max_dt):
    reference = trajectories.read_poses(reference_path)
    with open(loops_path, encoding="utf-8", newline="") as f:
        loops = list(csv.DictReader(f))
    # The reference pose of each closure's two keyframes, associated as `eval` does.
    queries = [(float(row[f"{side}_timestamp_s"]), k, side)
               for k, row in enumerate(loops) for side in ("old", "new")]
    found = {(q[1], q[2]): pose[1:]
             for pose, q in trajectories.associate(reference, queries, max_dt)}
    rows = []
    for k, row in enumerate(loops):
        old, new = found.get((k, "old")), found.get((k, "new"))
        error = None
        if old is not None and new is not None:
            truth = variants.between(old, new)
            edge = (float(row["edge_x_m"]), float(row["edge_y_m"]), float(row["edge_theta_rad"]))
            e = variants.between(truth, edge)
            error = (math.hypot(e[0], e[1]), abs(math.degrees(e[2])))
            if row.get("across_only") == "1":  # the offset across the corridor, in the old frame
                a = float(row["along_rad"])
                across = -math.sin(a) * (edge[0] - truth[0]) + math.cos(a) * (edge[1] - truth[1])
                error = (abs(across), error[1])
        wrong = error is not None and (error[0] > max_m or error[1] > max_deg)
        rows.append((row, error, wrong))
    return rows


def main(argv):
    parser = argparse.ArgumentParser(
        description="Scores the loop closures of a shape-slam run (loops.csv) against "
                    "reference poses.")
    parser.add_argument("loops", help="loops.csv of a shape-slam run")
    parser.add_argument("reference", help="reference poses: 't x y theta' or TUM lines")
    parser.add_argument("--max-m", type=float, default=0.5,
                        help="a closure off by more than this is wrong, metres (default 0.5)")
    parser.add_argument("--max-deg", type=float, default=5.0,
                        help="... or by more than this, degrees (default 5)")
    parser.add_argument("--max-dt", type=float, default=0.001,
                        help="largest timestamp difference to a reference pose, s (default 0.001)")
    parser.add_argument("--all", action="store_true", help="list every closure, not only wrong ones")
    parser.add_argument("--json", action="store_true", help="print the counts as one JSON object")
    args = parser.parse_args(argv)
    try:
        rows = score(args.loops, args.reference, args.max_m, args.max_deg, args.max_dt)
    except (OSError, ValueError, KeyError, trajectories.TrajectoryError) as e:
        print(f"loop_errors: {e}", file=sys.stderr)
        return 2
    counts = {d: {"closures": 0, "wrong": 0, "no_reference": 0} for d in DECISIONS}
    for row, error, wrong in rows:
        c = counts.setdefault(row["decision"], {"closures": 0, "wrong": 0, "no_reference": 0})
        c["closures"] += 1
        c["wrong"] += 1 if wrong else 0
        c["no_reference"] += 1 if error is None else 0
    wrong_accepted = sum(counts[d]["wrong"] for d in ACCEPTED)
    if args.json:
        print(json.dumps({"decisions": counts, "wrong_accepted": wrong_accepted}))
        return 0
    for d, c in counts.items():
        print(f"{d:10s} {c['closures']:5d} closures, {c['wrong']:4d} wrong"
              + (f", {c['no_reference']} without reference poses" if c["no_reference"] else ""))
    print(f"wrong closures in the graph: {wrong_accepted}")
    for row, error, wrong in rows:
        if args.all or (wrong and row["decision"] in ACCEPTED):
            err = "no reference" if error is None else f"error {error[0]:.2f} m {error[1]:.1f} deg"
            across = "  across only" if row.get("across_only") == "1" else ""
            print(f"  {row['decision']:9s} keyframe {row['new_keyframe']:>5s} -> {row['old_keyframe']:>5s}"
                  f"  correction {float(row['correction_m']):6.2f} m  fit {float(row['inlier_ratio']):.2f}"
                  f" / {float(row['reverse_inlier_ratio']):.2f}  graph {float(row['graph_distance_m']):6.1f} m"
                  f"  {err}{across}{'  WRONG' if wrong else ''}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
