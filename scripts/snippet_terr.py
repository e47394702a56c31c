#!/usr/bin/env python3
"""t_err over a whole snippet: the KITTI devkit's translational error of ONE segment, from the
first to the last frame: ||t(inv(G0^-1 G1) (E0^-1 E1))|| / (GT path length), in %; also the ratio
of the estimated to the ground-truth path length. For snippets shorter than the devkit's 100 m
segments (`momo eval` prints "-" there).

Usage: snippet_terr.py GT_POSES EST_POSES   (KITTI format, 12 numbers per line)
Prints: "t_err_percent path_ratio gt_path_m"
"""
import math
import sys


def read(path):
    """(R, t) per line: R as 3 rows, t as a 3-list."""
    poses = []
    with open(path) as f:
        for line in f:
            v = [float(x) for x in line.split()]
            if len(v) == 12:
                poses.append(([v[0:3], v[4:7], v[8:11]], [v[3], v[7], v[11]]))
    return poses


def inv(p):
    r, t = p
    rt = [[r[j][i] for j in range(3)] for i in range(3)]
    return rt, [-sum(rt[i][j] * t[j] for j in range(3)) for i in range(3)]


def mul(a, b):
    (ra, ta), (rb, tb) = a, b
    r = [[sum(ra[i][k] * rb[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
    return r, [sum(ra[i][k] * tb[k] for k in range(3)) + ta[i] for i in range(3)]


def path(ps):
    return sum(math.dist(ps[i + 1][1], ps[i][1]) for i in range(len(ps) - 1))


def main():
    gt, est = read(sys.argv[1]), read(sys.argv[2])
    if len(gt) != len(est) or len(gt) < 2:
        sys.exit(f"snippet_terr: {len(gt)} ground-truth and {len(est)} estimated poses")
    g = mul(inv(gt[0]), gt[-1])
    e = mul(inv(est[0]), est[-1])
    err = mul(inv(g), e)
    length = path(gt)
    print(f"{100 * math.hypot(*err[1]) / length:.3f} {path(est) / length:.4f} {length:.1f}")


main()
