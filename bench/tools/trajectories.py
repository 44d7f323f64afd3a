"""Trajectory files (TUM, 't x y theta'), icp-slam's pose log, and the alignment eval uses."""
import bisect
import gzip
import math
import re

from atomic import write_text

MAX_DT_S = 0.001  # as `shape-slam eval --max-dt` by default


class TrajectoryError(Exception):
    pass


# --- reading and writing ---------------------------------------------------------------------

def read_poses(path):
    """[(t, x, y, theta)] from a TUM file (t x y z qx qy qz qw) or 't x y theta' lines."""
    poses = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            fields = line.split()
            if not fields or fields[0].startswith("#"):
                continue
            try:
                values = [float(v) for v in fields]
            except ValueError:
                raise TrajectoryError(f"{path}:{number}: not a number") from None
            if len(values) == 8:
                t, x, y, _, _, _, qz, qw = values
                poses.append((t, x, y, 2.0 * math.atan2(qz, qw)))
            elif len(values) == 4:
                poses.append(tuple(values))
            else:
                raise TrajectoryError(
                    f"{path}:{number}: expected 4 or 8 fields, found {len(values)}")
    return poses


def write_tum(path, poses):
    """Writes [(t, x, y, theta)] as TUM lines (micrometres), atomically."""
    lines = ["# timestamp x y z qx qy qz qw"]
    for t, x, y, theta in poses:
        qz, qw = math.sin(theta / 2), math.cos(theta / 2)
        lines.append(f"{t!r} {x:.6f} {y:.6f} 0 0 0 {qz:.9f} {qw:.9f}")
    write_text(path, "\n".join(lines) + "\n")


def read_relations_stamps(path):
    """[(t1, t2, rest-of-line)] of a relations file."""
    out = []
    with open(path) as f:
        for line in f:
            fields = line.split()
            if len(fields) >= 2 and not fields[0].startswith("#"):
                out.append((float(fields[0]), float(fields[1]), line))
    return out


# --- icp-slam --------------------------------------------------------------------------------

# Every top-level object of a rawlog starts with its class name, preceded by one byte: 0x80 |
# length of the name (MRPT's archive format). A 30-odd byte class name is never found by chance.
_CLASS_NAME = re.compile(
    rb"([\x80-\xff])(mrpt::obs::C(?:Observation\w*|SensoryFrame|ActionCollection))")


def rawlog_observation_kinds(path):
    """The classes of a rawlog's entries in order: 'odometry', 'scan' or the class name.

    Only observations-only rawlogs (what `shape-slam convert` writes) have one entry per
    observation; an actions/sensory-frames rawlog raises TrajectoryError."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:2] == b"\x1f\x8b":
        data = gzip.decompress(data)
    kinds = []
    for match in _CLASS_NAME.finditer(data):
        name = match.group(2).decode()
        if match.group(1)[0] & 0x7F != len(name):
            continue
        if name.endswith(("CSensoryFrame", "CActionCollection")):
            raise TrajectoryError(
                f"{path}: an actions/sensory-frames rawlog, not observations-only")
        kinds.append({"mrpt::obs::CObservationOdometry": "odometry",
                      "mrpt::obs::CObservation2DRangeScan": "scan"}.get(name, name))
    return kinds


def read_icp_slam_path(path):
    """[(step, x, y, phi)] of icp-slam's log_estimated_path.txt."""
    rows = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            fields = line.split()
            if not fields:
                continue
            if len(fields) != 4:
                raise TrajectoryError(f"{path}:{number}: expected 'step x y phi'")
            rows.append((int(fields[0]), float(fields[1]), float(fields[2]), float(fields[3])))
    return rows


def icp_slam_scan_poses(path_rows, kinds, scan_stamps):
    """One pose per laser scan from icp-slam's per-observation pose log.

    icp-slam processes an observations-only rawlog one observation at a time (odometry
    observations too) and logs the robot pose after each. The estimate for a scan is the pose
    logged after that scan's own observation: the pose after the odometry observation before it
    is only the odometry prediction, not yet corrected by ICP."""
    if len(path_rows) != len(kinds):
        raise TrajectoryError(f"icp-slam logged {len(path_rows)} poses for {len(kinds)} "
                              "observations in the rawlog")
    if [r[0] for r in path_rows] != list(range(len(path_rows))):
        raise TrajectoryError("icp-slam's steps are not 0, 1, 2, ...")
    scan_rows = [row for row, kind in zip(path_rows, kinds) if kind == "scan"]
    if len(scan_rows) != len(scan_stamps):
        raise TrajectoryError(f"{len(scan_rows)} scan observations but {len(scan_stamps)} "
                              "scan timestamps")
    return [(t, x, y, phi) for t, (_, x, y, phi) in zip(scan_stamps, scan_rows)]


def per_scan_times_ms(times_path, kinds):
    """icp-slam's log_times.txt (ms per observation) summed per scan: a scan's own observation
    plus the odometry observation(s) since the previous scan."""
    with open(times_path) as f:
        times = [float(line.split()[0]) for line in f if line.strip()]
    if len(times) != len(kinds):
        raise TrajectoryError(f"{len(times)} times for {len(kinds)} observations")
    per_scan, pending = [], 0.0
    for ms, kind in zip(times, kinds):
        pending += ms
        if kind == "scan":
            per_scan.append(pending)
            pending = 0.0
    return per_scan


# --- alignment (as shape-slam eval: best rigid 2D alignment on poses associated by time) ----

def associate(estimate, reference, max_dt=MAX_DT_S):
    """[(estimate pose, reference pose)] for each reference pose with an estimate within max_dt."""
    est = sorted(estimate)
    stamps = [p[0] for p in est]
    pairs = []
    for ref in reference:
        i = bisect.bisect_left(stamps, ref[0])
        candidates = [j for j in (i - 1, i) if 0 <= j < len(est)]
        best = min(candidates, key=lambda j: abs(stamps[j] - ref[0]), default=None)
        if best is not None and abs(stamps[best] - ref[0]) <= max_dt:
            pairs.append((est[best], ref))
    return pairs


def best_rigid_alignment(src, dst):
    """(tx, ty, theta) minimising sum |R src_i + t - dst_i|^2 (2D Kabsch, no scale)."""
    n = len(src)
    cx, cy = sum(p[0] for p in src) / n, sum(p[1] for p in src) / n
    dx, dy = sum(p[0] for p in dst) / n, sum(p[1] for p in dst) / n
    dot = cross = 0.0
    for (ax, ay), (bx, by) in zip(src, dst):
        ax, ay, bx, by = ax - cx, ay - cy, bx - dx, by - dy
        dot += ax * bx + ay * by
        cross += ax * by - ay * bx
    theta = math.atan2(cross, dot)
    c, s = math.cos(theta), math.sin(theta)
    return dx - (c * cx - s * cy), dy - (s * cx + c * cy), theta


def transform(poses, alignment):
    tx, ty, theta = alignment
    c, s = math.cos(theta), math.sin(theta)
    return [(t, c * x - s * y + tx, s * x + c * y + ty, th + theta) for t, x, y, th in poses]


def align_onto(estimate, reference):
    """(estimate moved onto reference, ATE RMSE in m), or (None, None) if nothing associates."""
    pairs = associate(estimate, reference)
    if not pairs:
        return None, None
    alignment = best_rigid_alignment([(e[1], e[2]) for e, _ in pairs],
                                     [(r[1], r[2]) for _, r in pairs])
    moved = transform([e for e, _ in pairs], alignment)
    sq = sum((m[1] - r[1]) ** 2 + (m[2] - r[2]) ** 2 for m, (_, r) in zip(moved, pairs))
    return transform(estimate, alignment), math.sqrt(sq / len(pairs))
