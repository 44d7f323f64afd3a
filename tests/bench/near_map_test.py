#!/usr/bin/env python3
"""bench/localize's other-half score relative to the map nearby (near_map_score), on made-up
runs: a half map drifted as a whole still scores every scan right; a scan placed 0.3 m off,
one not localized and one far from the first half are told apart."""
import csv
import importlib.machinery
import importlib.util
import math
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
loader = importlib.machinery.SourceFileLoader("bench_localize", os.path.join(ROOT, "bench", "localize"))
spec = importlib.util.spec_from_loader("bench_localize", loader)
localize = importlib.util.module_from_spec(spec)
loader.exec_module(localize)
compose = localize.variants.compose


def write_status(folder, rows):
    with open(os.path.join(folder, "status.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["scan", "timestamp", "status", "localized", "lost_event", "x", "y", "theta", "ms"])
        for i, (t, pose, localized) in enumerate(rows):
            w.writerow([i, f"{t:.3f}", "tracking" if localized else "lost", int(localized), 0,
                        *(f"{v:.6f}" for v in pose), 1.0])


def main():
    # The whole run drives along x, 0.5 m per scan: scans 0-9 the first half, 10-13 the second.
    whole = {float(t): (0.5 * t, 0.0, 0.0) for t in range(14)}
    whole[13.0] = (20.0, 0.0, 0.0)  # far from every first-half scan
    # The half map is the first half moved and turned (its own drift, as a whole).
    drift = (1.0, -2.0, math.radians(10.0))
    half = {t: compose(drift, whole[t]) for t in range(10)}
    rows = [(10.0, compose(drift, whole[10.0]), True),                  # right
            (11.0, compose(drift, (whole[11.0][0], 0.3, 0.0)), True),   # 0.3 m to the side
            (12.0, compose(drift, whole[12.0]), False),                 # not localized
            (13.0, compose(drift, whole[13.0]), True)]                  # no first-half neighbour
    with tempfile.TemporaryDirectory() as folder:
        write_status(folder, rows)
        got = localize.near_map_score(folder, whole, half)
    expected = {"near_map": 1.0 / 3.0, "mapped": 3.0 / 4.0}
    for key, value in expected.items():
        if abs(got[key] - value) > 1e-9:
            print(f"near_map_score: {key} = {got[key]}, expected {value}")
            return 1
    print("near_map_score: ok", got)
    return 0


if __name__ == "__main__":
    sys.exit(main())
