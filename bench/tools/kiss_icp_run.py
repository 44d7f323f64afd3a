"""KISS-ICP (PyPI kiss-icp) on a CARMEN log, without odometry: each scan as z=0 3D points in the
sensor frame (beams that are not finite, <= 0 or at the no-return value dropped), registered
with KISS-ICP's Python API and its default configuration except data.max_range and
mapping.voxel_size. Runs in the benchmark's virtual environment (tools/peers_venv.py).

Usage: kiss_icp_run.py LOG OUT_DIR [--max-range M] [--voxel-size M]
Writes OUT_DIR/trajectory.tum (scan timestamps; x, y and the heading of KISS-ICP's 3D pose) and
OUT_DIR/stats.json (scans, per-scan registration time, the settings)."""
import argparse
import json
import math
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import carmen  # noqa: E402
import trajectories as tj  # noqa: E402
from atomic import write_text  # noqa: E402

MAX_RANGE_M = 30.0
VOXEL_SIZE_M = 0.1


def scan_points(angles, ranges, max_range_m):
    """Sensor-frame z=0 points of the valid beams."""
    return [(r * math.cos(a), r * math.sin(a), 0.0) for a, r in zip(angles, ranges)
            if math.isfinite(r) and r > 0.0 and (max_range_m is None or r < max_range_m)]


def make_pipeline(max_range_m, voxel_size_m):
    from kiss_icp.config import KISSConfig
    from kiss_icp.kiss_icp import KissICP
    config = KISSConfig()
    config.data.max_range = max_range_m
    config.mapping.voxel_size = voxel_size_m
    return KissICP(config=config), config


def planar_pose(T):
    """(x, y, heading) of a 4x4 pose."""
    return float(T[0, 3]), float(T[1, 3]), math.atan2(float(T[1, 0]), float(T[0, 0]))


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("log")
    parser.add_argument("out_dir")
    parser.add_argument("--max-range", type=float, default=MAX_RANGE_M)
    parser.add_argument("--voxel-size", type=float, default=VOXEL_SIZE_M)
    args = parser.parse_args(argv)
    import numpy as np
    scans = carmen.read_scans(args.log)
    if not scans:
        print(f"kiss_icp_run: no laser scan in {args.log}", file=sys.stderr)
        return 1
    pipeline, config = make_pipeline(args.max_range, args.voxel_size)
    poses, times_ms, empty = [], [], 0
    for t, angles, ranges, max_range_m in scans:
        points = np.asarray(scan_points(angles, ranges, max_range_m), dtype=np.float64)
        start = time.perf_counter()
        if len(points):
            pipeline.register_frame(points.reshape(-1, 3), np.empty(0))
        else:
            empty += 1  # nothing to register: the pose stays where it was
        times_ms.append(1000.0 * (time.perf_counter() - start))
        poses.append((t, *planar_pose(pipeline.last_pose)))
    os.makedirs(args.out_dir, exist_ok=True)
    tj.write_tum(os.path.join(args.out_dir, "trajectory.tum"), poses)
    import kiss_icp
    stats = {"scans": len(poses), "scans_without_points": empty,
             "per_scan_ms": {"median": statistics.median(times_ms),
                             "mean": statistics.fmean(times_ms)},
             "kiss_icp_version": getattr(kiss_icp, "__version__", "unknown"),
             "config": config.model_dump()}
    write_text(os.path.join(args.out_dir, "stats.json"), json.dumps(stats, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
