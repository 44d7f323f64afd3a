#!/usr/bin/env python3
"""bench/tools/variants.py's mirror variant on a made-up log: the beams reversed (with an even
count shifted so that each beam meets its mirror direction), y, heading and the rotational
velocity negated; mirroring an odd-count log twice gives it back; the reference poses and
relations mirrored with it."""
import math
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "bench", "tools"))
import carmen  # noqa: E402
import variants  # noqa: E402


def check(condition, message):
    if not condition:
        print("FAIL: " + message)
        sys.exit(1)


def flaser(ranges, pose, stamp):
    p = [f"{v:.6f}" for v in pose]
    return ["FLASER", str(len(ranges)), *[f"{r:.6f}" for r in ranges], *p, *p, f"{stamp:.3f}",
            "host", f"{stamp:.3f}"]


def main():
    odom = ["ODOM", "1.000000", "2.000000", "0.300000", "0.5", "0.100000", "0", "1.000", "h", "1.000"]
    even = flaser([1.0, 2.0, 3.0, 4.0], (1.0, 2.0, 0.3), 1.0)
    odd = flaser([1.0, 2.0, 3.0, 4.0, 5.0], (1.0, -2.0, -0.3), 2.0)
    out = variants.mirror([odom, even, odd])
    check(out[0][2:4] == ["-2.000000", "-0.300000"] and out[0][5] == "-0.100000",
          f"ODOM y, theta, rv negated: {out[0]}")
    check(out[1][2:6] == ["0.000000", "4.000000", "3.000000", "2.000000"],
          f"even count: beam 0 has no mirror, then beams 3, 2, 1: {out[1][2:6]}")
    angles = carmen.flaser_angles_rad(4)
    for j in range(1, 4):  # mirrored beam j reads the log's beam 4 - j, at the mirrored angle
        check(math.isclose(angles[j], -angles[4 - j]), f"beam {j}'s mirror is beam {4 - j}")
    check(out[1][6:12] == ["1.000000", "-2.000000", "-0.300000"] * 2, f"poses: {out[1][6:12]}")
    check(out[2][2:7] == ["5.000000", "4.000000", "3.000000", "2.000000", "1.000000"],
          f"odd count: reversed: {out[2][2:7]}")
    check(variants.mirror(variants.mirror([odd]))[0] == odd, "odd count: twice is the log")
    with tempfile.TemporaryDirectory() as d:
        log, gt, rel = (os.path.join(d, n) for n in ("a.log", "a.gt.txt", "a.relations"))
        with open(log, "w") as f:
            f.write(" ".join(odom) + "\n" + " ".join(even) + "\n" + " ".join(odd) + "\n")
        with open(gt, "w") as f:
            f.write("# timestamp x y theta\n1.000000 1.0 2.0 0.3\n2.000000 1.0 -2.0 -0.3\n")
        with open(rel, "w") as f:
            f.write("1.000000 2.000000 0.5 0.25 0 0 0 -0.6\n")
        variants.write_variant("mirror", log, gt, rel, os.path.join(d, "m"))
        with open(os.path.join(d, "m.gt.txt")) as f:
            rows = [line.split() for line in f]
        check(rows == [["1.000000", "1.000000", "-2.000000", "-0.300000"],
                       ["2.000000", "1.000000", "2.000000", "0.300000"]], f"gt mirrored: {rows}")
        with open(os.path.join(d, "m.relations")) as f:
            rows = [line.split() for line in f]
        check(rows == [["1.000000", "2.000000", "0.500000", "-0.250000", "0", "0", "0", "0.600000"]],
              f"relations mirrored: {rows}")
    print("mirror variant: ok")


if __name__ == "__main__":
    main()
