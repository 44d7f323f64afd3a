"""Just enough of the CARMEN text format for the benchmark: laser scan timestamps, and the first
N scans of a log (with its reference poses and relations) for the --quick run.

The reader that matters is shape-slam's own (src/io/carmen_reader.cpp); this one is a fallback
and its results are checked against the scan count `shape-slam convert` reports."""
import gzip
import math

from atomic import write_text


def _open_text(path):
    with open(path, "rb") as f:
        gz = f.read(2) == b"\x1f\x8b"
    return gzip.open(path, "rt", errors="replace") if gz else open(path, errors="replace")


def _scan_stamp(fields):
    """The `timestamp` field of a FLASER or ROBOTLASER1 record, or None if malformed."""
    try:
        if fields[0] == "FLASER":
            n = int(fields[1])
            return float(fields[2 + n + 6])
        n = int(fields[8])
        n_rem = int(fields[9 + n])
        return float(fields[9 + n + 1 + n_rem + 11])
    except (ValueError, IndexError):
        return None


def scan_stamps(path):
    """Timestamps of the laser scans in log order (ROBOTLASER1 if the log has any, else FLASER),
    as shape-slam reads them; malformed records are skipped."""
    stamps = {"FLASER": [], "ROBOTLASER1": []}
    with _open_text(path) as f:
        for line in f:
            fields = line.split()
            if fields and fields[0] in stamps:
                t = _scan_stamp(fields)
                if t is not None:
                    stamps[fields[0]].append(t)
    return stamps["ROBOTLASER1"] or stamps["FLASER"]


def write_head(path, out_log, max_scans):
    """Writes the records of path up to its max_scans-th FLASER record (and every PARAM record)
    to out_log. Returns the timestamps of the scans kept."""
    kept, stamps = [], []
    with _open_text(path) as f:
        for line in f:
            fields = line.split()
            if not fields:
                continue
            if fields[0] == "FLASER":
                if len(stamps) >= max_scans:
                    continue
                t = _scan_stamp(fields)
                if t is None:
                    continue
                stamps.append(t)
            elif fields[0] != "PARAM" and len(stamps) >= max_scans:
                continue
            kept.append(line if line.endswith("\n") else line + "\n")
    write_text(out_log, "".join(kept))
    return stamps


def write_subset_by_stamps(path, out_path, stamps, columns):
    """Copies the lines of a reference file (gt: columns=1, relations: columns=2) whose first
    `columns` timestamps are all among stamps."""
    keep = {round(t, 6) for t in stamps}
    lines = []
    with open(path) as f:
        for line in f:
            fields = line.split()
            if len(fields) < columns or fields[0].startswith("#"):
                continue
            if all(round(float(v), 6) in keep for v in fields[:columns]):
                lines.append(line if line.endswith("\n") else line + "\n")
    write_text(out_path, "".join(lines))
    return len(lines)


# --- scans, for the peers that read the log themselves (KISS-ICP) -----------------------------

# The no-return rule of shape-slam's reader (src/io/carmen_reader.cpp, LargestReadings).
NO_RETURN_BAND_M = 0.005
MIN_NO_RETURN_VALUE_M = 20.0
MIN_NO_RETURN_FRACTION = 0.001


def flaser_angles_rad(n):
    """FLASER beam directions (datasets/radish/README.md): beam 0 at -90 deg, step 180 deg / n
    for even n, 180 deg / (n - 1) for odd n."""
    intervals = n if n % 2 == 0 else max(n - 1, 1)
    return [-math.pi / 2 + i * math.pi / intervals for i in range(n)]


def _params(fields, params):
    if len(fields) >= 3 and fields[1] not in params:  # the first value wins
        try:
            params[fields[1]] = float(fields[2])
        except ValueError:
            pass


def max_range_m(path):
    """The FLASER maximum range as shape-slam's reader derives it: PARAM
    laser_front_laser_max_range, else robot_front_laser_max, else the largest reading minus
    0.005 m when at least 0.1 % of the readings are within 0.005 m of it and it is >= 20 m (a
    no-return value), else the largest reading + 1 m."""
    params, readings = {}, []
    with _open_text(path) as f:
        for line in f:
            fields = line.split()
            if not fields:
                continue
            if fields[0] == "PARAM":
                _params(fields, params)
            elif fields[0] == "FLASER":
                try:
                    values = [float(v) for v in fields[2:2 + int(fields[1])]]
                except ValueError:
                    continue
                readings += [r for r in values if r >= 0.0]
    for name in ("laser_front_laser_max_range", "robot_front_laser_max"):
        if params.get(name, 0.0) > 0.0:
            return params[name]
    if not readings:
        return 1.0
    largest = max(readings)
    near = sum(1 for r in readings if r >= largest - NO_RETURN_BAND_M)
    no_return = (largest >= MIN_NO_RETURN_VALUE_M
                 and near >= MIN_NO_RETURN_FRACTION * len(readings))
    return largest - NO_RETURN_BAND_M if no_return else largest + 1.0


def read_scans(path):
    """[(timestamp, angles_rad, ranges_m, max_range_m)] of the log's laser scans in order
    (ROBOTLASER1 if the log has any, else FLASER), like scan_stamps; malformed records are
    skipped. A range is valid when finite, > 0 and < max_range_m."""
    scans = {"FLASER": [], "ROBOTLASER1": []}
    flaser_max = None
    with _open_text(path) as f:
        for line in f:
            fields = line.split()
            if not fields or fields[0] not in scans:
                continue
            t = _scan_stamp(fields)
            if t is None:
                continue
            try:
                if fields[0] == "FLASER":
                    n = int(fields[1])
                    ranges = [float(v) for v in fields[2:2 + n]]
                    angles, max_r = flaser_angles_rad(n), None
                else:
                    start, res, max_r = float(fields[2]), float(fields[4]), float(fields[5])
                    n = int(fields[8])
                    ranges = [float(v) for v in fields[9:9 + n]]
                    angles = [start + i * res for i in range(n)]
            except (ValueError, IndexError):
                continue
            scans[fields[0]].append((t, angles, ranges, max_r))
    if scans["ROBOTLASER1"]:
        return scans["ROBOTLASER1"]
    if scans["FLASER"]:
        flaser_max = max_range_m(path)
    return [(t, a, r, flaser_max) for t, a, r, _ in scans["FLASER"]]


def scan_odometry(path):
    """[(x, y, theta)] odometry pose of each laser scan, in the order and with the skipping rule
    of read_scans: FLASER's odom_x odom_y odom_theta, ROBOTLASER1's robot pose (as shape-slam's
    reader takes T_odom_robot)."""
    poses = {"FLASER": [], "ROBOTLASER1": []}
    with _open_text(path) as f:
        for line in f:
            fields = line.split()
            if not fields or fields[0] not in poses or _scan_stamp(fields) is None:
                continue
            try:
                if fields[0] == "FLASER":
                    at = 2 + int(fields[1]) + 3
                else:
                    n = int(fields[8])
                    at = 9 + n + 1 + int(fields[9 + n]) + 3
                pose = tuple(float(v) for v in fields[at:at + 3])
            except (ValueError, IndexError):
                continue
            if len(pose) == 3:
                poses[fields[0]].append(pose)
    return poses["ROBOTLASER1"] or poses["FLASER"]
