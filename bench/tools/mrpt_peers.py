"""The outputs of MRPT's loop-closing SLAM apps, `rbpf-slam` and `graphslam-engine`, as one pose
per laser scan (bench/run_all methods `rbpf-slam` and `graphslam-engine`).

Both read an actions / sensory-frames rawlog (`shape-slam convert --format pairs`: per scan one
odometry increment and one sensory frame with the scan) and estimate poses only at their
keyframes: rbpf-slam at each particle-filter step (the robot moved localizeLinDistance /
localizeAngDistance since the last one), graphslam-engine at each graph node (its node
registration decider fired). Between keyframes both rely on odometry, so the pose of scan i is
the pose of the last keyframe at or before it composed with the odometry from that keyframe's
scan to scan i (the keyframe's own scan gets the keyframe's pose).

Which scan each keyframe belongs to is read from the apps' own logs and checked against the
odometry of the log (carmen.scan_odometry), never assumed:
- rbpf-slam logs one line per action-observation pair in log_times.txt (`step ms map_size
  inserted`) and in log_odometry_path.txt (the odometry it composed); the particle filter runs
  at exactly the steps that insert into the map when the two pairs of thresholds are equal (as
  in the shipped gridmapping_intel.ini), and most_likely_path.txt (the final most likely
  particle's path, `x y yaw`) has the initial pose and then one pose per filter step.
- graphslam-engine's node registration decider prints each new node with the odometry edge
  since the previous node (`Registered new node: a => b / Edge: [dx dy dphi deg]`); node b's
  scan is the first scan at which the odometry composed since node a's scan equals that edge.
  Its poses are the optimised VERTEX_SE2 lines of output_graph.graph.
"""
import math
import re

POSITION_TOLERANCE_M = 2e-3  # the apps print poses with 3 to 6 decimals
ANGLE_TOLERANCE_RAD = 2e-3
STAMP_TOLERANCE_S = 1e-3  # printed with 6 decimals (%f)


class PeerOutputError(Exception):
    pass


# --- SE(2) ------------------------------------------------------------------------------------

def wrap(angle):
    return math.atan2(math.sin(angle), math.cos(angle))


def compose(a, b):
    """a ⊕ b of (x, y, theta) poses."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap(a[2] + b[2]))


def inverse(a):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-c * a[0] - s * a[1], s * a[0] - c * a[1], wrap(-a[2]))


def close(a, b):
    return (math.hypot(a[0] - b[0], a[1] - b[1]) <= POSITION_TOLERANCE_M
            and abs(wrap(a[2] - b[2])) <= ANGLE_TOLERANCE_RAD)


def increments(odometry):
    """Per scan the odometry increment since the previous scan, the first one zero (what
    `shape-slam convert --format pairs` writes)."""
    return [(0.0, 0.0, 0.0)] + [compose(inverse(a), b) for a, b in zip(odometry, odometry[1:])]


def scan_poses(stamps, odometry, keyframes):
    """[(t, x, y, theta)] per scan from keyframes [(scan index, pose)] in scan order, the first
    at scan 0: the last keyframe's pose composed with the odometry since its scan."""
    if not keyframes or keyframes[0][0] != 0:
        raise PeerOutputError("no keyframe at the first scan")
    poses, k = [], 0
    for i, t in enumerate(stamps):
        while k + 1 < len(keyframes) and keyframes[k + 1][0] <= i:
            k += 1
        scan, pose = keyframes[k]
        x, y, theta = compose(pose, compose(inverse(odometry[scan]), odometry[i]))
        poses.append((t, x, y, theta))
    return poses


def _numbers(path, columns, what):
    rows = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            if not line.strip() or line.lstrip().startswith(("%", "#")):
                continue
            fields = line.split()
            if len(fields) < columns:
                raise PeerOutputError(f"{path}:{number}: expected {what}")
            try:
                rows.append([float(v) for v in fields[:columns]])
            except ValueError:
                raise PeerOutputError(f"{path}:{number}: expected {what}") from None
    return rows


# --- rbpf-slam ----------------------------------------------------------------------------------

def rbpf_keyframes(out_dir, stamps, odometry):
    """[(scan, pose)] of the most likely particle's path, and per-scan times (ms)."""
    times = _numbers(f"{out_dir}/log_times.txt", 4, "'step ms map_size inserted'")
    odo = _numbers(f"{out_dir}/log_odometry_path.txt", 7, "'step x y z yaw pitch roll'")
    path = _numbers(f"{out_dir}/most_likely_path.txt", 3, "'x y yaw'")
    n = len(stamps)
    if len(times) != n or len(odo) != n:
        raise PeerOutputError(f"rbpf-slam logged {len(times)} steps (times) and {len(odo)} "
                              f"(odometry) for {n} scans")
    logged = _numbers(f"{out_dir}/log_estimated_path.txt", 8, "'step x y z yaw pitch roll t'")
    if len(logged) != n or any(abs(row[7] - t) > STAMP_TOLERANCE_S
                               for row, t in zip(logged, stamps)):
        raise PeerOutputError("the timestamps of log_estimated_path.txt are not the scans'")
    origin = odometry[0]
    for i, row in enumerate(odo):
        expected = compose(inverse(origin), odometry[i])
        if int(row[0]) != i or not close((row[1], row[2], row[4]), expected):
            raise PeerOutputError(f"rbpf-slam's odometry at step {i} {row[1:3] + row[4:5]} is "
                                  f"not the log's {expected}: steps and scans do not match")
    steps = [i for i, row in enumerate(times) if row[3] != 0]
    if len(path) != len(steps) + 1:
        raise PeerOutputError(f"most_likely_path.txt has {len(path)} poses for {len(steps)} "
                              "filter steps (map insertions) and the initial pose")
    path = path[1:]  # the first is the initial pose, before the first step
    if not steps or steps[0] != 0:
        raise PeerOutputError("rbpf-slam did not insert the first scan")
    # Keyframe poses are relative to the first scan's odometry frame: rebase on the log's.
    keyframes = [(s, compose(origin, (p[0], p[1], p[2]))) for s, p in zip(steps, path)]
    return keyframes, [row[1] for row in times]


# --- graphslam-engine ---------------------------------------------------------------------------

_NODE = re.compile(r"Registered new node:\s*(\d+)\s*=>\s*(\d+)\s*Edge:\s*\[\s*(\S+)\s+(\S+)\s+"
                   r"(\S+?)deg\s*\]")
_VERTEX = re.compile(r"^VERTEX_SE2\s+(\d+)\s+(\S+)\s+(\S+)\s+(\S+)\s*$", re.M)


def graphslam_node_edges(stdout_text):
    """[(a, b, (dx, dy, dphi_rad))] of the node registration decider's messages, in order."""
    edges = []
    for m in _NODE.finditer(stdout_text):
        a, b = int(m.group(1)), int(m.group(2))
        edges.append((a, b, (float(m.group(3)), float(m.group(4)),
                             math.radians(float(m.group(5))))))
    return edges


def graphslam_vertices(graph_text):
    return {int(m.group(1)): (float(m.group(2)), float(m.group(3)), float(m.group(4)))
            for m in _VERTEX.finditer(graph_text)}


def graphslam_keyframes(stdout_path, graph_path, odometry):
    """[(scan, pose)] of graphslam-engine's optimised nodes."""
    with open(stdout_path, errors="replace") as f:
        edges = graphslam_node_edges(f.read())
    with open(graph_path) as f:
        vertices = graphslam_vertices(f.read())
    if set(vertices) != set(range(len(edges) + 1)):
        raise PeerOutputError(f"{len(vertices)} graph nodes, but {len(edges)} node "
                              "registrations printed (expected one more node: the root)")
    steps = increments(odometry)
    node_scans, scan, since = [0], 0, (0.0, 0.0, 0.0)
    origin = odometry[0]
    for a, b, edge in edges:
        if a != b - 1 or b != len(node_scans):
            raise PeerOutputError(f"node registration {a} => {b} out of order")
        while not close(since, edge):
            scan += 1
            if scan >= len(steps):
                raise PeerOutputError(f"node {b}: no scan after scan {node_scans[-1]} where the "
                                      f"odometry composed equals its edge {edge}")
            since = compose(since, steps[scan])
        node_scans.append(scan)
        since = (0.0, 0.0, 0.0)
    return [(s, compose(origin, vertices[k])) for k, s in enumerate(node_scans)]


# --- bench/graphslam_lc (graphslam's CLoopCloserERD over the library class) -------------------

def graphslam_lc_keyframes(nodes_path, stamps, odometry):
    """[(scan, pose)] of bench/graphslam_lc's nodes file (`node scan timestamp x y phi`, the
    scan at which each node was registered), checked against the scans' timestamps."""
    rows = _numbers(nodes_path, 6, "'node scan timestamp x y phi'")
    keyframes = []
    for node, scan, t, x, y, phi in rows:
        scan = int(scan)
        if not 0 <= scan < len(stamps) or abs(stamps[scan] - t) > STAMP_TOLERANCE_S:
            raise PeerOutputError(f"node {int(node)}: scan {scan} at t={t} is not a scan of "
                                  "the log")
        keyframes.append((scan, compose(odometry[0], (x, y, phi))))
    return sorted(keyframes, key=lambda k: k[0])
