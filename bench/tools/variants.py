"""Harder copies of a CARMEN log for the benchmark, with reference poses and relations derived
consistently (bench/README.md, "Variants").

  zero-odom   every ODOM and FLASER pose (and ODOM velocity) set to 0; ranges and timestamps
              kept: how logs without odometry look
  every2      every 2nd laser scan (scans 0, 2, 4, ...); ODOM records kept
  noisy-odom  odometry increments with added random-walk noise (fixed seed)
  half-beams  every 2nd beam (FLASER n -> n/2 readings, the same 180 deg field of view)
  fov120      only the beams within the central 120 deg, written as ROBOTLASER1 records
              (FLASER cannot say a field of view other than 180 deg)
  odom-glitch one scan step, somewhere in the middle third of the log, whose odometry heading
              jumps by 60-90 deg (seeded)
  odom-bad    every scan step's odometry with 5 deg (heading) and 5 cm (along, across) of
              Gaussian noise (seeded)
  odom-bias   a wheel-base error: 1 deg of heading per metre travelled
  odom-stall  at 5 scan steps (seeded) the odometry arrives one scan late: the scan reports the
              odometry pose of the scan before, the next scan the right one

Perturbed copies (perturbed_copy): 2 mm of Gaussian noise on every valid range (not on
no-return or invalid readings), seeded by the copy index; reference files unchanged.

Reference poses: those of the scans kept. Relations: those whose two timestamps are both kept;
for every2 the consecutive-scan relations of the kept scans are the composition of the two
original consecutive relations across the dropped scan (the local block stays measured)."""
import math
import random

import carmen
import trajectories
from atomic import write_text

NAMES = ["zero-odom", "every2", "noisy-odom", "half-beams", "fov120", "odom-glitch", "odom-bad",
         "odom-bias", "odom-stall", "mirror"]
# Variants that change the odometry alone: their ranges, timestamps and laser poses relative
# to the odometry are the log's (the development logs' FLASER laser pose is their odometry pose).
ODOMETRY_ONLY = ("zero-odom", "noisy-odom", "odom-glitch", "odom-bad", "odom-bias", "odom-stall")

NOISE_SEED = 20261201
NOISE_TRANS_M_PER_SQRT_M = 0.05  # std of the translation noise (along and across) after 1 m
NOISE_ROT_DEG_PER_SQRT_M = 2.0  # std of the heading noise after 1 m of travel
NOISE_ROT_DEG_PER_SQRT_RAD = 2.0  # std of the heading noise after turning 1 rad
FOV_DEG = 120.0
GLITCH_SEED = 20261202
GLITCH_DEG = (60.0, 90.0)  # size of the heading jump (either sign)
BAD_ODOM_SEED = 20261203
BAD_ODOM_ROT_DEG = 5.0  # std of the heading noise of every scan step
BAD_ODOM_TRANS_M = 0.05  # std of the translation noise (along and across) of every scan step
BIAS_DEG_PER_M = 1.0  # heading error per metre travelled
STALL_SEED = 20261204
STALL_COUNT = 5  # scan steps whose odometry arrives one scan late
RANGE_NOISE_M = 0.002  # std of the noise on each valid range of a perturbed copy
RANGE_DECIMALS = 4  # ranges of a perturbed copy are written to 0.1 mm


class VariantError(Exception):
    pass


# --- small pose algebra ------------------------------------------------------------------------

def compose(a, b):
    """a ⊕ b for (x, y, theta)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1],
            math.atan2(math.sin(a[2] + b[2]), math.cos(a[2] + b[2])))


def between(a, b):
    """a^-1 ⊕ b: the motion from a to b in a's frame."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, math.atan2(math.sin(b[2] - a[2]),
                                                          math.cos(b[2] - a[2])))


def fmt(v):
    return f"{v:.6f}"


# --- records -----------------------------------------------------------------------------------

def _records(path):
    with carmen._open_text(path) as f:
        return [line.rstrip("\n").split() for line in f]


def _flaser_n(fields):
    return int(fields[1])


def _pose_slots(fields):
    """Indices of the pose fields of an ODOM or FLASER record: [(x, y, theta) index triples]."""
    if fields[0] == "ODOM":
        return [(1, 2, 3)]
    n = _flaser_n(fields)
    return [(2 + n, 3 + n, 4 + n), (5 + n, 6 + n, 7 + n)]


def _check_flaser_only(records, path):
    if any(f and f[0] == "ROBOTLASER1" for f in records):
        raise VariantError(f"{path}: ROBOTLASER1 logs are not supported by the variants")
    if not any(f and f[0] == "FLASER" for f in records):
        raise VariantError(f"{path}: no FLASER record")


def zero_odom(records):
    out = []
    for f in records:
        if f and f[0] in ("ODOM", "FLASER"):
            f = list(f)
            for slot in _pose_slots(f):
                for i in slot:
                    f[i] = "0.000000"
            if f[0] == "ODOM":
                f[4:7] = ["0.000000"] * 3  # tv rv accel
        out.append(f)
    return out


def every2(records):
    out, k = [], 0
    for f in records:
        if f and f[0] == "FLASER":
            k += 1
            if (k - 1) % 2:
                continue
        out.append(f)
    return out


def _noisy_increment(rng, d):
    dist = math.hypot(d[0], d[1])
    sigma_t = NOISE_TRANS_M_PER_SQRT_M * math.sqrt(dist)
    sigma_r = math.radians(math.sqrt(NOISE_ROT_DEG_PER_SQRT_M ** 2 * dist
                                     + NOISE_ROT_DEG_PER_SQRT_RAD ** 2 * abs(d[2])))
    return (d[0] + rng.gauss(0.0, sigma_t), d[1] + rng.gauss(0.0, sigma_t),
            d[2] + rng.gauss(0.0, sigma_r))


def _rewrite_odometry(records, fault):
    """Every odometry pose (ODOM x y theta, FLASER odom_x..) in file order is one step of the
    odometry; each increment d becomes fault(d, is_scan) (is_scan: the increment ends at a
    FLASER record, i.e. one per scan step) and the poses are composed again from the first. The
    FLASER laser pose keeps its offset from the odometry pose."""
    out, raw_prev, faulty_prev = [], None, None
    for f in records:
        if not f or f[0] not in ("ODOM", "FLASER"):
            out.append(f)
            continue
        f = list(f)
        odom_slot = _pose_slots(f)[-1]
        raw = tuple(float(f[i]) for i in odom_slot)
        faulty = raw if raw_prev is None else compose(
            faulty_prev, fault(between(raw_prev, raw), f[0] == "FLASER"))
        if f[0] == "FLASER":
            laser_slot = _pose_slots(f)[0]
            laser = tuple(float(f[i]) for i in laser_slot)
            for i, v in zip(laser_slot, compose(faulty, between(raw, laser))):
                f[i] = fmt(v)
        for i, v in zip(odom_slot, faulty):
            f[i] = fmt(v)
        raw_prev, faulty_prev = raw, faulty
        out.append(f)
    return out


def noisy_odom(records):
    """Each odometry increment gets Gaussian noise whose variance grows linearly with the
    distance and the turn (a random walk: the same drift whatever the record rate)."""
    rng = random.Random(NOISE_SEED)
    return _rewrite_odometry(records, lambda d, _: _noisy_increment(rng, d))


def odom_glitch(records):
    """One scan step, drawn in the middle third of the scans, whose heading jumps by
    GLITCH_DEG (either sign); the odometry after it is turned with it."""
    rng = random.Random(GLITCH_SEED)
    scans = sum(1 for f in records if f and f[0] == "FLASER")
    at = rng.randrange(scans // 3, max(2 * scans // 3, scans // 3 + 1))
    jump = math.radians(rng.uniform(*GLITCH_DEG)) * rng.choice((-1.0, 1.0))
    step = [0]

    def fault(d, is_scan):
        if not is_scan:
            return d
        step[0] += 1
        return (d[0], d[1], d[2] + jump) if step[0] == at else d
    return _rewrite_odometry(records, fault)


def odom_bad(records):
    """Every scan step's increment with BAD_ODOM_TRANS_M (along, across) and BAD_ODOM_ROT_DEG
    (heading) of Gaussian noise, whatever the distance travelled."""
    rng = random.Random(BAD_ODOM_SEED)
    sigma_r = math.radians(BAD_ODOM_ROT_DEG)

    def fault(d, is_scan):
        if not is_scan:
            return d
        return (d[0] + rng.gauss(0.0, BAD_ODOM_TRANS_M), d[1] + rng.gauss(0.0, BAD_ODOM_TRANS_M),
                d[2] + rng.gauss(0.0, sigma_r))
    return _rewrite_odometry(records, fault)


def odom_bias(records):
    """A wheel-base error: every increment turns BIAS_DEG_PER_M more per metre travelled."""
    per_m = math.radians(BIAS_DEG_PER_M)
    return _rewrite_odometry(
        records, lambda d, _: (d[0], d[1], d[2] + per_m * math.hypot(d[0], d[1])))


def odom_stall(records):
    """At STALL_COUNT scan steps drawn from the whole log, the odometry arrives one scan late:
    the step's increments are held back (the scan reports the odometry pose of the scan
    before) and arrive with the next increment, so the next scan's pose is right again."""
    rng = random.Random(STALL_SEED)
    scans = sum(1 for f in records if f and f[0] == "FLASER")
    stalls = set(rng.sample(range(1, scans - 1), min(STALL_COUNT, max(scans - 2, 0))))
    state = {"scans": 0, "held": None}

    def fault(d, is_scan):
        step = state["scans"]  # the increment belongs to the step that ends at FLASER `step`
        if is_scan:
            state["scans"] += 1
        if step in stalls:
            state["held"] = d if state["held"] is None else compose(state["held"], d)
            return (0.0, 0.0, 0.0)
        if state["held"] is not None:
            d, state["held"] = compose(state["held"], d), None
        return d
    return _rewrite_odometry(records, fault)


def mirror(records):
    """The log's mirror image (y -> -y): each scan's beams in reverse order, the y and heading of
    every pose (and ODOM's rotational velocity) negated. A mapper without a handedness scores a
    log and its mirror alike. With an even beam count the FLASER beams span -90 .. 90 - step deg
    (carmen.flaser_angles_rad), so beam i's mirror is beam n - i: the mirrored beam 0 (-90 deg)
    has no source and reads 0 (no reading), and the reading of the log's beam 0 is dropped."""
    out = []
    for f in records:
        if f and f[0] == "FLASER":
            n = _flaser_n(f)
            ranges = f[2:2 + n]
            mirrored = ranges[::-1] if n % 2 else ["0.000000", *ranges[:0:-1]]
            f = [*f[:2], *mirrored, *f[2 + n:]]
            for _, y, theta in _pose_slots(f):
                f[y], f[theta] = fmt(-float(f[y])), fmt(-float(f[theta]))
        elif f and f[0] == "ODOM":
            f = list(f)
            for i in (2, 3, 5):  # y, theta, rotational velocity
                f[i] = fmt(-float(f[i]))
        out.append(f)
    return out


def half_beams(records):
    out = []
    for f in records:
        if f and f[0] == "FLASER":
            n = _flaser_n(f)
            if n % 2:
                raise VariantError(f"half-beams needs an even beam count, got FLASER {n}")
            f = ["FLASER", str(n // 2), *f[2:2 + n:2], *f[2 + n:]]
        out.append(f)
    return out


def _frontlaser_offset_m(records):
    for f in records:
        if len(f) >= 3 and f[0] == "PARAM" and f[1] == "robot_frontlaser_offset":
            return float(f[2])
    return 0.0


def fov120(records, max_range_m):
    """FLASER -> ROBOTLASER1 with the beams within +-FOV_DEG/2 (the FLASER beam angles of
    datasets/radish/README.md); max_range is the log's no-return value (carmen.max_range_m)."""
    offset = _frontlaser_offset_m(records)
    out = []
    for f in records:
        if not f or f[0] != "FLASER":
            out.append(f)
            continue
        n = _flaser_n(f)
        angles = carmen.flaser_angles_rad(n)
        step = angles[1] - angles[0] if n > 1 else math.pi
        half = math.radians(FOV_DEG / 2) + 1e-9
        keep = [i for i, a in enumerate(angles) if abs(a) <= half]
        ranges = [f[2 + i] for i in keep]
        robot = tuple(float(v) for v in f[5 + n:8 + n])
        laser = compose(robot, (offset, 0.0, 0.0))
        stamp, host, logger = f[8 + n:11 + n]
        out.append(["ROBOTLASER1", "0", fmt(angles[keep[0]]),
                    fmt(angles[keep[-1]] - angles[keep[0]]), fmt(step), fmt(max_range_m),
                    "0.01", "0", str(len(ranges)), *ranges, "0", *map(fmt, laser),
                    *map(fmt, robot), "0", "0", "0", "0", "0", stamp, host, logger])
    return out


# --- reference files ---------------------------------------------------------------------------

def _read_relations(path):
    rows = []
    with open(path) as f:
        for line in f:
            v = line.split()
            if len(v) >= 8 and not v[0].startswith("#"):
                rows.append((float(v[0]), float(v[1]), float(v[2]), float(v[3]), float(v[7])))
    return rows


def _write_relations(path, rows):
    write_text(path, "".join(f"{t1:.6f} {t2:.6f} {x:.6f} {y:.6f} 0 0 0 {th:.6f}\n"
                             for t1, t2, x, y, th in rows))


def mirror_gt(path, out_path):
    """The reference poses (t x y theta) of the mirrored log: y and the heading negated."""
    write_text(out_path, "".join(f"{fmt(t)} {fmt(x)} {fmt(-y)} {fmt(-theta)}\n"
                                 for t, x, y, theta in trajectories.read_poses(path)))


def mirror_relations(path, out_path):
    """The relations of the mirrored log: y and the heading negated (planar: z, roll, pitch 0)."""
    _write_relations(out_path, [(t1, t2, x, -y, -th) for t1, t2, x, y, th in _read_relations(path)])


def every2_relations(relations_path, out_path, all_stamps, kept_stamps):
    """Local relations of the kept scans by composing the two original local relations across
    the dropped scan, then every original relation whose two timestamps are kept."""
    rows = _read_relations(relations_path)
    key = lambda t: round(t, 6)  # noqa: E731
    by_pair = {(key(r[0]), key(r[1])): r for r in rows}
    kept = {key(t) for t in kept_stamps}
    order = [key(t) for t in all_stamps]
    local = []
    for a, b, c in zip(order, order[1:], order[2:]):
        if a not in kept or c not in kept or (a, b) not in by_pair or (b, c) not in by_pair:
            continue
        r1, r2 = by_pair[(a, b)], by_pair[(b, c)]
        x, y, th = compose(r1[2:], r2[2:])
        local.append((r1[0], r2[1], x, y, th))
    rest = [r for r in rows if key(r[0]) in kept and key(r[1]) in kept]
    _write_relations(out_path, local + rest)
    return len(local) + len(rest)


# --- a variant on disk --------------------------------------------------------------------------

def write_variant(name, log_path, gt_path, relations_path, out_stem):
    """Writes out_stem.log (and .gt.txt / .relations when the source has them). Returns the
    path of the log."""
    if name not in NAMES:
        raise VariantError(f"unknown variant '{name}'; known: {', '.join(NAMES)}")
    records = _records(log_path)
    _check_flaser_only(records, log_path)
    if name == "zero-odom":
        out = zero_odom(records)
    elif name == "every2":
        out = every2(records)
    elif name == "noisy-odom":
        out = noisy_odom(records)
    elif name == "half-beams":
        out = half_beams(records)
    elif name == "fov120":
        out = fov120(records, carmen.max_range_m(log_path))
    elif name == "mirror":
        out = mirror(records)
    else:
        out = {"odom-glitch": odom_glitch, "odom-bad": odom_bad, "odom-bias": odom_bias,
               "odom-stall": odom_stall}[name](records)
    log_out = out_stem + ".log"
    write_text(log_out, "".join(" ".join(f) + "\n" for f in out))
    all_stamps, kept = carmen.scan_stamps(log_path), carmen.scan_stamps(log_out)
    if name == "mirror":
        if gt_path:
            mirror_gt(gt_path, out_stem + ".gt.txt")
        if relations_path:
            mirror_relations(relations_path, out_stem + ".relations")
        return log_out
    if gt_path:
        carmen.write_subset_by_stamps(gt_path, out_stem + ".gt.txt", kept, 1)
    if relations_path:
        if name == "every2":
            every2_relations(relations_path, out_stem + ".relations", all_stamps, kept)
        else:
            carmen.write_subset_by_stamps(relations_path, out_stem + ".relations", kept, 2)
    return log_out


# --- perturbed copies -------------------------------------------------------------------------

def _noisy_ranges(ranges, max_range_m, rng):
    """RANGE_NOISE_M of Gaussian noise on each valid range (finite, > 0, < max_range_m); a noisy
    range stays valid (> 0, < max_range_m), the others are written unchanged."""
    out = []
    for text in ranges:
        r = float(text)
        if not (math.isfinite(r) and 0.0 < r < max_range_m):
            out.append(text)
            continue
        noisy = r + rng.gauss(0.0, RANGE_NOISE_M)
        low, high = 10.0 ** -RANGE_DECIMALS, max_range_m - 10.0 ** -RANGE_DECIMALS
        out.append(f"{min(max(noisy, low), high):.{RANGE_DECIMALS}f}")
    return out


def perturb_ranges(records, flaser_max_range_m, seed):
    """The records with noisy valid ranges (FLASER: below the log's no-return value by
    shape-slam's reader rule; ROBOTLASER1: below its own max range field)."""
    rng = random.Random(seed)
    out = []
    for f in records:
        if f and f[0] == "FLASER":
            n = _flaser_n(f)
            f = [*f[:2], *_noisy_ranges(f[2:2 + n], flaser_max_range_m, rng), *f[2 + n:]]
        elif f and f[0] == "ROBOTLASER1":
            n = int(f[8])
            f = [*f[:9], *_noisy_ranges(f[9:9 + n], float(f[5]), rng), *f[9 + n:]]
        out.append(f)
    return out


def perturbed_copy(log_path, out_path, copy_index):
    """Writes a copy of a CARMEN log with 2 mm of noise on its valid ranges, seeded by
    copy_index (copy 0 is noisy too). Timestamps, odometry and record order are kept, so the
    source's reference poses and relations apply unchanged. Returns out_path."""
    records = _records(log_path)
    if not any(f and f[0] in ("FLASER", "ROBOTLASER1") for f in records):
        raise VariantError(f"{log_path}: no FLASER or ROBOTLASER1 record")
    out = perturb_ranges(records, carmen.max_range_m(log_path), copy_index)
    write_text(out_path, "".join(" ".join(f) + "\n" for f in out))
    return out_path
