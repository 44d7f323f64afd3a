#!/usr/bin/python3
"""OpenKarto's correlative scan matcher (PyPI karto-scanmatcher, the matcher behind
slam_toolbox) on the scan pairs of bench/match_benchmark, from no guess.

Reads the pairs that match_benchmark wrote (match_pairs.csv: log, gap, scan indices, their
timestamps, the reference motion), matches scan b against scan a for every pair with each
search window (Karto's search_size, i.e. the side of the square searched, and
coarse_search_angle_offset: 2 m / +-45 deg and 4 m / +-90 deg), the search centred on the
identity (no guess), every other ScanMatcherConfig field at its default. Success: the
estimate within 10 cm and 2 deg of the reference motion, as in match_benchmark.

Writes karto.csv and karto.md (one row per log, gap and window) and karto_pairs_detail.csv
(every pair) next to the pairs file. Runs in the peers' virtual environment
(build/bench-venv, made with pip on first use): started with another Python, it re-runs
itself there.

Usage: bench/karto_pairs.py [--pairs bench/results/match_pairs.csv] [--max-pairs N]
                            [--max-pairs-wide N] [--with-ceiling]"""
import argparse
import csv
import io
import math
import os
import statistics
import sys
import time

BENCH_DIR = os.path.dirname(os.path.abspath(__file__))
REPO_DIR = os.path.dirname(BENCH_DIR)
sys.path.insert(0, os.path.join(BENCH_DIR, "tools"))

import atomic  # noqa: E402
import carmen  # noqa: E402
import peers_venv  # noqa: E402
from variants import between  # noqa: E402

DEFAULT_PAIRS = os.path.join(BENCH_DIR, "results", "match_pairs.csv")
DEFAULT_LOG_DIR = os.path.join(REPO_DIR, "datasets", "radish")
DEFAULT_VENV = os.path.join(REPO_DIR, "build", "bench-venv")
WINDOWS = [("2 m / ±45 deg", 2.0, 45.0), ("4 m / ±90 deg", 4.0, 90.0)]
SUCCESS_TRANS_M = 0.10
SUCCESS_ROT_DEG = 2.0
STAMP_TOLERANCE_S = 0.001
REEXEC_GUARD = "SHAPE_SLAM_KARTO_PAIRS_IN_VENV"


def parse_args(argv):
    parser = argparse.ArgumentParser(
        prog="bench/karto_pairs.py", description=__doc__.split("\n\n")[0],
        epilog="\n\n".join(__doc__.split("\n\n")[1:]),
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--pairs", default=DEFAULT_PAIRS, metavar="CSV",
                        help="match_pairs.csv of match_benchmark (default: bench/results/)")
    parser.add_argument("--log-dir", default=DEFAULT_LOG_DIR, metavar="DIR",
                        help="where LOG.log.gz of each pair's log is (default: datasets/radish)")
    parser.add_argument("--out", metavar="DIR", help="output folder (default: the pairs' folder)")
    parser.add_argument("--max-pairs", type=int, metavar="N",
                        help="at most N pairs per log and gap, evenly spread (default: all)")
    parser.add_argument("--max-pairs-wide", type=int, metavar="N",
                        help="at most N pairs per log and gap for the 4 m window, which is "
                             "about 10x slower (default: as --max-pairs)")
    parser.add_argument("--with-ceiling", action="store_true",
                        help="also match from the reference motion (the ceiling)")
    parser.add_argument("--venv", default=DEFAULT_VENV, metavar="DIR",
                        help="the peers' virtual environment (default: build/bench-venv)")
    return parser.parse_args(argv)


def in_venv_or_reexec(venv):
    """Imports karto_scanmatcher, re-running this script in the venv when it is missing here."""
    try:
        import karto_scanmatcher
        return karto_scanmatcher
    except ImportError:
        if os.environ.get(REEXEC_GUARD):
            raise
    python = peers_venv.ensure(venv, "karto_scanmatcher",
                               log=lambda m: print(m, file=sys.stderr, flush=True))
    os.environ[REEXEC_GUARD] = "1"
    os.execv(python, [python, os.path.abspath(__file__), *sys.argv[1:]])


def read_pairs(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    groups = {}
    for r in rows:
        pair = (int(r["scan_a"]), int(r["scan_b"]), float(r["t_a"]), float(r["t_b"]),
                (float(r["ref_x_m"]), float(r["ref_y_m"]), float(r["ref_theta_rad"])))
        groups.setdefault((r["log"], int(r["gap"])), []).append(pair)
    return groups


def spread(pairs, limit):
    if not limit or len(pairs) <= limit:
        return pairs
    return [pairs[i * len(pairs) // limit] for i in range(limit)]


def load_scans(log_dir, log, pairs):
    """The log's scans (tools/carmen.py), checked against the pairs' timestamps."""
    path = os.path.join(log_dir, log + ".log.gz")
    scans = carmen.read_scans(path)
    for a, b, t_a, t_b, _ in pairs:
        for index, stamp in ((a, t_a), (b, t_b)):
            if index >= len(scans) or abs(scans[index][0] - stamp) > STAMP_TOLERANCE_S:
                raise SystemExit(f"karto_pairs: {path}: scan {index} is not the one of the "
                                 f"pairs file (timestamp {stamp})")
    return scans


class Matcher:
    """One Karto matcher per search window; scans as Karto LocalizedRangeScans."""

    def __init__(self, karto, size_m, angle_deg):
        self.karto = karto
        config = karto.ScanMatcherConfig()
        config.search_size = size_m
        config.coarse_search_angle_offset = math.radians(angle_deg)
        self.range_threshold_m = config.range_threshold
        self.wrapper = karto.Wrapper(config)

    def scan(self, scan, pose, num):
        t, angles, ranges, max_range_m = scan
        step = angles[1] - angles[0]
        laser = self.karto.LaserScanConfig(angles[0], angles[-1], step, 0.0, max_range_m,
                                           min(self.range_threshold_m, max_range_m), "laser")
        valid = [r if math.isfinite(r) and 0.0 < r < max_range_m else max_range_m
                 for r in ranges]  # no return: at the max range, beyond the range threshold
        p = self.karto.Pose2(*pose)
        return self.karto.LocalizedRangeScan(laser, valid, p, p, num, t)

    def match(self, scan_a, scan_b, guess):
        """(estimated T_a_b, ms): scan b matched against scan a placed at the origin."""
        start = time.perf_counter()
        result = self.wrapper.match_scan(self.scan(scan_b, guess, 1),
                                         [self.scan(scan_a, (0.0, 0.0, 0.0), 0)], True, True)
        ms = 1000.0 * (time.perf_counter() - start)
        best = result.best_pose
        return (best.x, best.y, best.yaw), ms


def percentile(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(q * (len(v) - 1) + 0.5))] if v else float("nan")


def run(args, karto):
    groups = read_pairs(args.pairs)
    conditions = [("no guess", False)] + ([("at the reference", True)] if args.with_ceiling
                                          else [])
    summary, detail, scans_of = [], [], {}
    for (log, gap), all_pairs in groups.items():
        if log not in scans_of:
            scans_of[log] = load_scans(args.log_dir, log, [p for (l, _), ps in groups.items()
                                                           if l == log for p in ps])
        scans = scans_of[log]
        by_pair = {}  # (window, condition, a, b) -> outcome
        for w, (window, size_m, angle_deg) in enumerate(WINDOWS):
            limit = args.max_pairs_wide if w and args.max_pairs_wide else args.max_pairs
            pairs = spread(all_pairs, limit)
            matcher = Matcher(karto, size_m, angle_deg)
            for condition, at_reference in conditions:
                outcomes = []
                for a, b, _, _, truth in pairs:
                    guess = truth if at_reference else (0.0, 0.0, 0.0)
                    estimate, ms = matcher.match(scans[a], scans[b], guess)
                    e = between(truth, estimate)
                    outcomes.append((math.hypot(e[0], e[1]), abs(math.degrees(e[2])), ms))
                    by_pair[(window, condition, a, b)] = outcomes[-1]
                    detail.append([log, gap, window, condition, a, b, *estimate, *outcomes[-1]])
                summary.append(row_stats(log, gap, window, condition, outcomes))
                print(f"{log} gap {gap} {window} {condition}: {len(outcomes)} pairs, "
                      f"{summary[-1]['success_pct']:.1f} % within 10 cm / 2 deg",
                      file=sys.stderr, flush=True)
        summary += same_pairs_rows(log, gap, by_pair, spread(all_pairs, args.max_pairs_wide),
                                   conditions) if args.max_pairs_wide else []
    return summary, detail


def same_pairs_rows(log, gap, by_pair, wide_pairs, conditions):
    """The 2 m window's results on the (fewer) pairs of the 4 m window, for a like-for-like
    comparison when --max-pairs-wide is smaller than --max-pairs."""
    window = WINDOWS[0][0]
    rows = []
    for condition, _ in conditions:
        outcomes = [by_pair.get((window, condition, a, b)) for a, b, *_ in wide_pairs]
        if all(outcomes) and len(outcomes) < sum(1 for k in by_pair if k[:2] == (window,
                                                                                  condition)):
            rows.append(row_stats(log, gap, window + " (the 4 m pairs)", condition, outcomes))
    return rows


def row_stats(log, gap, window, condition, outcomes):
    ok = sum(1 for t, r, _ in outcomes if t < SUCCESS_TRANS_M and r < SUCCESS_ROT_DEG)
    te, re, ms = ([o[i] for o in outcomes] for i in range(3))
    return {"log": log, "gap": gap, "window": window, "condition": condition,
            "pairs": len(outcomes), "success_pct": 100.0 * ok / len(outcomes) if outcomes else 0,
            "trans_err_median_m": percentile(te, 0.5), "trans_err_p90_m": percentile(te, 0.9),
            "rot_err_median_deg": percentile(re, 0.5), "rot_err_p90_deg": percentile(re, 0.9),
            "time_median_ms": percentile(ms, 0.5),
            "time_mean_ms": statistics.fmean(ms) if ms else float("nan")}


def write_outputs(out_dir, summary, detail, karto_version):
    columns = list(summary[0]) if summary else []
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(columns)
    for s in summary:
        writer.writerow([f"{v:.4f}" if isinstance(v, float) else v for v in s.values()])
    atomic.write_text(os.path.join(out_dir, "karto.csv"), text.getvalue())
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["log", "gap", "window", "condition", "scan_a", "scan_b", "x_m", "y_m",
                     "theta_rad", "trans_err_m", "rot_err_deg", "ms"])
    for d in detail:
        writer.writerow([f"{v:.6f}" if isinstance(v, float) else v for v in d])
    atomic.write_text(os.path.join(out_dir, "karto_pairs_detail.csv"), text.getvalue())
    lines = [f"OpenKarto correlative matcher (karto-scanmatcher {karto_version}) on the pairs of "
             "match_pairs.csv; search centred on the identity (no guess) unless said; success: "
             "error < 10 cm and < 2 deg.", "",
             "| log | gap | window | guess | pairs | success | median err (m / deg) | "
             "ms (median) |", "|---|---|---|---|---|---|---|---|"]
    for s in summary:
        lines.append(f"| {s['log']} | {s['gap']} | {s['window']} | {s['condition']} | "
                     f"{s['pairs']} | {s['success_pct']:.1f} % | {s['trans_err_median_m']:.3f} / "
                     f"{s['rot_err_median_deg']:.2f} | {s['time_median_ms']:.0f} |")
    atomic.write_text(os.path.join(out_dir, "karto.md"), "\n".join(lines) + "\n")


def main(argv):
    args = parse_args(argv)
    if not os.path.isfile(args.pairs):
        print(f"karto_pairs: {args.pairs}: no such file (run build/bench/match_benchmark first)",
              file=sys.stderr)
        return 2
    try:
        karto = in_venv_or_reexec(args.venv)
    except (peers_venv.VenvError, ImportError) as e:
        print(f"karto_pairs: no karto-scanmatcher: {e}", file=sys.stderr)
        return 2
    summary, detail = run(args, karto)
    out_dir = args.out or os.path.dirname(os.path.abspath(args.pairs))
    write_outputs(out_dir, summary, detail, getattr(karto, "__version__", "?"))
    print(open(os.path.join(out_dir, "karto.md")).read(), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
