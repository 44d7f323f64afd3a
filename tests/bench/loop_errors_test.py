#!/usr/bin/env python3
"""bench/tools/loop_errors.py on a made-up loops.csv: a full closure is judged on its whole
relative pose; a closure kept across a corridor (across_only = 1) only on its heading and its
offset across the corridor (along_rad), its position along it being the graph's own guess."""
import csv
import math
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "bench", "tools"))
import loop_errors  # noqa: E402

HEADER = ["new_keyframe", "old_keyframe", "new_timestamp_s", "old_timestamp_s", "decision",
          "edge_x_m", "edge_y_m", "edge_theta_rad", "correction_m", "correction_rad",
          "inlier_ratio", "reverse_inlier_ratio", "graph_distance_m", "across_only", "along_rad"]


def main():
    with tempfile.TemporaryDirectory() as work:
        # Reference: the old scan at the origin, the new one 10 m ahead along x, same heading.
        reference = os.path.join(work, "gt.txt")
        with open(reference, "w") as f:
            f.write("1.000 0 0 0\n2.000 10 0 0\n")
        loops = os.path.join(work, "loops.csv")
        rows = [
            # 3 m short along the corridor (x), 5 cm across: wrong as a full closure ...
            ["5", "1", "2.0", "1.0", "confirmed", "7.0", "0.05", "0.0", "3", "0", "0.9", "0.9", "300", "0", "0"],
            # ... right as one kept across the corridor (along x: along_rad 0) ...
            ["5", "1", "2.0", "1.0", "confirmed", "7.0", "0.05", "0.0", "3", "0", "0.9", "0.9", "300", "1", "0"],
            # ... but not when it is 0.6 m off across the corridor ...
            ["5", "1", "2.0", "1.0", "confirmed", "7.0", "0.6", "0.0", "3", "0", "0.9", "0.9", "300", "1", "0"],
            # ... or 6 deg off in heading.
            ["5", "1", "2.0", "1.0", "confirmed", "10.0", "0.0", f"{math.radians(6):.6f}", "0", "0.1",
             "0.9", "0.9", "300", "1", "0"],
            # Along a corridor at 90 deg (along y): 3 m along is not an error, 0.05 m across is not.
            ["5", "1", "2.0", "1.0", "confirmed", "10.05", "3.0", "0.0", "3", "0", "0.9", "0.9", "300", "1",
             f"{math.pi / 2:.6f}"],
        ]
        with open(loops, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(HEADER)
            w.writerows(rows)
        scored = loop_errors.score(loops, reference, 0.5, 5.0, 0.001)
        wrong = [w for _, _, w in scored]
        expected = [True, False, True, True, False]
        if wrong != expected:
            print(f"loop_errors_test: wrong {wrong}, expected {expected}", file=sys.stderr)
            return 1
        # A loops.csv from before across_only (no such column) is still read.
        old = os.path.join(work, "old.csv")
        with open(old, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(HEADER[:-2])
            w.writerow(rows[0][:-2])
        if [w for _, _, w in loop_errors.score(old, reference, 0.5, 5.0, 0.001)] != [True]:
            print("loop_errors_test: an old loops.csv is misread", file=sys.stderr)
            return 1
        out = subprocess.run([sys.executable, os.path.join(ROOT, "bench", "tools", "loop_errors.py"),
                              loops, reference], capture_output=True, text=True, check=True).stdout
        if "wrong closures in the graph: 3" not in out or "across only" not in out:
            print(f"loop_errors_test: unexpected output\n{out}", file=sys.stderr)
            return 1
    print("loop_errors_test: ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
