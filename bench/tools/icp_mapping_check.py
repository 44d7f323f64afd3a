#!/usr/bin/python3
"""Checks empirically which line of icp-slam's log_estimated_path.txt belongs to which scan.

icp-slam logs one pose per OBSERVATION processed, without timestamps; in an observations-only
rawlog the odometry observations count too. Candidate mappings are evaluated against the
reference: the right one has the smallest local (consecutive-scan) relation error, because the
others pair a scan with a pose that is not (yet, or any longer) its own.

  bench/tools/icp_mapping_check.py SHAPE_SLAM LOG_ESTIMATED_PATH RAWLOG SCAN_STAMPS_TUM GT RELATIONS

SCAN_STAMPS_TUM: any trajectory with one line per scan in log order (e.g. shape-slam run's
trajectory.tum); only its timestamps are used."""
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import trajectories as tj  # noqa: E402

VARIANTS = {
    "after_scan": "pose logged after the scan's own observation (used by run_all)",
    "after_odometry": "pose logged after the odometry observation just before the scan",
    "one_scan_late": "pose logged after the next scan's observation",
}


def candidate_rows(path_rows, kinds):
    """Per variant, the pose-log rows picked for each scan (None where a variant has no row)."""
    scan_idx = [i for i, k in enumerate(kinds) if k == "scan"]
    late = scan_idx[1:] + [None]
    before = [i - 1 if i > 0 and kinds[i - 1] == "odometry" else None for i in scan_idx]
    pick = lambda idx: [path_rows[i] if i is not None else None for i in idx]  # noqa: E731
    return {"after_scan": pick(scan_idx), "after_odometry": pick(before),
            "one_scan_late": pick(late)}


def evaluate(shape_slam, tum, gt, relations):
    out = subprocess.run([shape_slam, "eval", tum, gt, relations, "--json"], capture_output=True,
                         text=True, timeout=120, check=True)
    return json.loads(out.stdout)


def check(shape_slam, path_rows, kinds, stamps, gt, relations):
    """{variant: eval JSON} (variants that pick no row for some scans drop those scans)."""
    if len(path_rows) != len(kinds):
        raise tj.TrajectoryError(f"{len(path_rows)} poses for {len(kinds)} observations")
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, rows in candidate_rows(path_rows, kinds).items():
            poses = [(t, r[1], r[2], r[3]) for t, r in zip(stamps, rows) if r is not None]
            if len(poses) < 2:
                continue
            tum = os.path.join(tmp, name + ".tum")
            tj.write_tum(tum, poses)
            results[name] = evaluate(shape_slam, tum, gt, relations)
    return results


def summary(results):
    parts = []
    for name, r in results.items():
        local = r["local"]
        parts.append(f"{name}: local {local['trans_m']:.3f} m / {local['rot_deg']:.2f} deg,"
                     f" ATE {r['ate_m']:.2f} m")
    best = min(results, key=lambda n: results[n]["local"]["rot_deg"]) if results else None
    return "; ".join(parts), best


def main(argv):
    if len(argv) != 7 or argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(argv) > 1 and argv[1] in ("-h", "--help") else 2
    shape_slam, path_log, rawlog, stamps_tum, gt, relations = argv[1:]
    kinds = tj.rawlog_observation_kinds(rawlog)
    stamps = [p[0] for p in tj.read_poses(stamps_tum)]
    results = check(shape_slam, tj.read_icp_slam_path(path_log), kinds, stamps, gt, relations)
    print(f"{len(kinds)} observations ({kinds.count('scan')} scans) in the rawlog")
    for name, r in results.items():
        print(f"{name:15s} ATE {r['ate_m']:8.3f} m  local {r['local']['trans_m']:.3f} m "
              f"{r['local']['rot_deg']:6.2f} deg  revisit {r['revisit']['trans_m']:.3f} m  "
              f"({VARIANTS[name]})")
    best = summary(results)[1]
    print(f"smallest local rotation error: {best}")
    return 0 if best == "after_scan" else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
