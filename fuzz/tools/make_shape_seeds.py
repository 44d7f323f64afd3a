#!/usr/bin/env python3
"""Writes the seed inputs of the shape fuzz target (fuzz/shape_fuzz.cc documents the layout).

Run from the repository root: python3 fuzz/tools/make_shape_seeds.py fuzz/corpus/shape
"""
import math
import os
import struct
import sys


def box_range(angle, xmin=-3.0, xmax=4.0, ymin=-2.0, ymax=5.0):
    """Range from the origin to the walls of a box room along `angle`."""
    c, s = math.cos(angle), math.sin(angle)
    hits = []
    if c > 1e-12:
        hits.append(xmax / c)
    if c < -1e-12:
        hits.append(xmin / c)
    if s > 1e-12:
        hits.append(ymax / s)
    if s < -1e-12:
        hits.append(ymin / s)
    return min(hits)


def header(layout, threshold, lookahead, min_points, gap, max_range, model_vertices):
    """The two parameter bytes; threshold, gap and max_range are indices into the target's tables."""
    return bytes([layout | threshold << 2 | (lookahead - 1) << 4 | (min_points - 1) << 6,
                  gap | max_range << 2 | (model_vertices - 1) << 4])


def doubles(*values):
    return b''.join(struct.pack('<d', v) for v in values)


def points(vertices):
    return b''.join(doubles(x, y) for x, y in vertices)


def main(out_dir):
    os.makedirs(out_dir, exist_ok=True)
    seeds = {}
    model = points([(0, 0), (2, 0), (2, 1.5), (2.2, 3)])
    # 180 deg, 91 beams (odd, as FLASER 181), box room, an object and one "no return".
    n = 91
    ranges = [box_range(-math.pi / 2 + i * math.pi / (n - 1)) for i in range(n)]
    for i in range(40, 44):
        ranges[i] = 1.0 + 0.01 * i
    ranges[60] = 30.0
    seeds['room_180.bin'] = header(0, 2, 3, 2, 1, 2, 4) + model + doubles(*ranges)
    # 360 deg, 72 beams: the last and the first group are joined across the seam.
    n = 72
    ranges = [box_range(-math.pi + i * 2 * math.pi / n) for i in range(n)]
    seeds['room_360.bin'] = header(2, 1, 2, 3, 3, 3, 4) + model + doubles(*ranges)
    # 270 deg, 40 beams, DCE threshold 0, lookahead 1.
    n = 40
    ranges = [box_range(-0.75 * math.pi + i * 1.5 * math.pi / (n - 1)) for i in range(n)]
    seeds['room_270.bin'] = header(1, 0, 1, 1, 2, 1, 2) + doubles(0, 0, 1, 1) + doubles(*ranges)
    # (range, angle) pairs with non-finite, negative and tiny values.
    inf, nan = float('inf'), float('nan')
    pairs = [(1.0, 0.0), (1.0, 0.1), (nan, 0.2), (1.1, 0.3), (1.2, inf), (-1.0, 0.5), (1.3, 0.6),
             (1.35, 0.65), (1e-3, 0.7), (2.0, -0.4), (2.0, -0.3), (2.05, -0.2)]
    seeds['raw_pairs.bin'] = (header(3, 2, 4, 2, 1, 0, 3) + doubles(0, 0, -1, 0.5, -2, 0) +
                              b''.join(doubles(r, a) for r, a in pairs))
    # A model with repeated and collinear vertices (zero-length segments, zero turns).
    degenerate = [(0, 0), (0, 0), (1, 0), (2, 0), (2, 0), (2, 1), (2, 1), (1, 1)]
    seeds['degenerate_model.bin'] = (header(0, 2, 3, 2, 1, 2, 8) + points(degenerate) +
                                     doubles(*[1.0] * 20))
    for name, data in seeds.items():
        with open(os.path.join(out_dir, name), 'wb') as f:
            f.write(data)
        print(f'wrote {name} ({len(data)} bytes)')


if __name__ == '__main__':
    main(sys.argv[1] if len(sys.argv) > 1 else 'fuzz/corpus/shape')
