#!/usr/bin/env python3
"""The signed heading error of each step of a trajectory against reference poses: its drift.

`eval` reports the mean absolute error of consecutive relations; a small bias of the same sign at
every step hides in it, yet it bends a long corridor (infinite-corridor: -0.024 deg a step of
the tracking with loop closure off, -47 deg over the log, while its odometry drifts -3.4 deg).
For each two successive reference poses that both have a trajectory pose (associated by
timestamp, as `eval` does), the trajectory's heading change between them less the reference's,
in degrees; then their sum, mean and median absolute value, in all and split by the
reference's turn in that step (right turns, straight within --straight-deg, left turns). With
--log, the same figures for the log's own odometry (CARMEN FLASER / ROBOTLASER1 poses), the
baseline the scans should beat.

  bench/tools/heading_drift.py OUT/trajectory.tum datasets/radish/intel.gt.txt
  bench/tools/heading_drift.py OUT/trajectory.tum GT --log LOG.log.gz   # and the odometry
  bench/tools/heading_drift.py OUT/trajectory.tum GT --json

A run with loop closure on ends near the reference's heading whatever its tracking did (the
sum telescopes to the last pose's heading error less the first's): measure the tracking with
`[loop_closure] enabled = false`.

Exit status: 0, or 2 on unreadable input or no step with reference poses. Standard library only.
"""
import argparse
import json
import math
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import carmen  # noqa: E402  (bench/tools, beside this script)
import trajectories  # noqa: E402
import variants  # noqa: E402


def step_errors(poses, reference, max_dt):
    """[(error_deg, reference_turn_deg)] between successive reference poses with a pose each."""
    pairs = trajectories.associate(poses, reference, max_dt)  # in reference (time) order
    out = []
    for (e0, r0), (e1, r1) in zip(pairs, pairs[1:]):
        est = variants.between(e0[1:], e1[1:])
        ref = variants.between(r0[1:], r1[1:])
        error = math.atan2(math.sin(est[2] - ref[2]), math.cos(est[2] - ref[2]))
        out.append((math.degrees(error), math.degrees(ref[2])))
    return out


def summary(errors, straight_deg):
    def part(rows):
        e = [r[0] for r in rows]
        return {"steps": len(e), "sum_deg": sum(e),
                "mean_deg": statistics.mean(e) if e else 0.0,
                "median_abs_deg": statistics.median(abs(x) for x in e) if e else 0.0}
    return {"all": part(errors),
            "right_turns": part([r for r in errors if r[1] < -straight_deg]),
            "straight": part([r for r in errors if abs(r[1]) <= straight_deg]),
            "left_turns": part([r for r in errors if r[1] > straight_deg])}


def odometry_poses(log):
    stamps, odometry = carmen.scan_stamps(log), carmen.scan_odometry(log)
    if len(stamps) != len(odometry):
        raise ValueError(f"{log}: {len(stamps)} scan timestamps but {len(odometry)} odometry poses")
    return [(t, *pose) for t, pose in zip(stamps, odometry)]


def main(argv):
    parser = argparse.ArgumentParser(
        description="Signed heading error of each step of a trajectory against reference poses "
                    "(its drift), optionally beside the log's odometry.")
    parser.add_argument("trajectory", help="trajectory: TUM or 't x y theta' lines")
    parser.add_argument("reference", help="reference poses: 't x y theta' or TUM lines")
    parser.add_argument("--log", help="CARMEN log whose odometry is measured the same way")
    parser.add_argument("--straight-deg", type=float, default=1.0,
                        help="a step turning less than this (reference) is straight, deg "
                             "(default 1)")
    parser.add_argument("--max-dt", type=float, default=0.001,
                        help="largest timestamp difference to a reference pose, s (default 0.001)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    try:
        reference = trajectories.read_poses(args.reference)
        sources = {"trajectory": trajectories.read_poses(args.trajectory)}
        if args.log:
            sources["odometry"] = odometry_poses(args.log)
        results = {}
        for name, poses in sources.items():
            errors = step_errors(poses, reference, args.max_dt)
            if not errors:
                raise ValueError(f"{name}: no two consecutive poses with reference poses")
            results[name] = summary(errors, args.straight_deg)
    except (OSError, ValueError, trajectories.TrajectoryError) as e:
        print(f"heading_drift: {e}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(results))
        return 0
    for name, parts in results.items():
        a = parts["all"]
        print(f"{name}: heading drift {a['sum_deg']:+.1f} deg over {a['steps']} steps "
              f"({a['mean_deg']:+.4f} deg a step; median |error| {a['median_abs_deg']:.3f} deg)")
        for key in ("right_turns", "straight", "left_turns"):
            p = parts[key]
            print(f"  {key.replace('_', ' '):11s} {p['steps']:6d} steps  sum {p['sum_deg']:+8.1f} deg"
                  f"  mean {p['mean_deg']:+.4f} deg")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
