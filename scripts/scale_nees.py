#!/usr/bin/env python3
"""Per-frame arc length against the ground truth, for the frames whose scale is `estimated`:
the normalised error squared (err/sigma)^2 of the reported sigma of `arc_length`.

Usage: scale_nees.py [-v] GT_POSES DIAGNOSTICS.jsonl
  GT_POSES     KITTI poses of camera 0 (12 numbers per line), line k = frame k of the sequence
  DIAGNOSTICS  `momo run --diagnostics FILE` (JSON lines; row `frame` k is the pair k-1, k)
The ground-truth arc length of frame k is the distance between camera 0's centres at k-1 and
k (the vehicle's arc length differs by the lever arm's turn, below 0.1 % at KITTI's yaw rates).
Prints: "estimated/frames mean_(err/sigma)^2 inside_95%_bound_% median_|err|_% mean_err_%
p95_|err|_%" over the `estimated` frames; with -v also one line per frame.
"""
import json
import math
import sys


def centres(path):
    out = []
    with open(path) as f:
        for line in f:
            v = [float(x) for x in line.split()]
            if len(v) == 12:
                out.append((v[3], v[7], v[11]))
    return out


def main(argv):
    verbose = "-v" in argv
    argv = [a for a in argv if a != "-v"]
    gt = centres(argv[1])
    rows, frames = [], 0
    with open(argv[2]) as f:
        for line in f:
            if not line.strip():
                continue
            d = json.loads(line)
            frames += 1
            k = d["frame"]
            if d["scale"] != "estimated" or k >= len(gt):
                continue
            i = d["param_names"].index("arc_length")
            l, s = d["params"][i], d["param_sigmas"][i]
            g = math.dist(gt[k], gt[k - 1])
            if g < 0.05:
                continue
            err = abs(l) - g
            rows.append((k, err / g, (err / s) ** 2 if s and s > 0 else math.inf, s / g))
            if verbose:
                print(f"frame {k}: gt {g:.3f} est {l:.3f} err {100 * err / g:+.2f} % sigma {100 * s / g:.2f} % z2 {rows[-1][2]:.2f}")
    if not rows:
        print(f"0/{frames} - - - - -")
        return
    n = len(rows)
    z2 = sum(r[2] for r in rows) / n
    inside = 100.0 * sum(1 for r in rows if r[2] <= 1.96**2) / n
    a = sorted(abs(r[1]) for r in rows)
    med = 100 * a[n // 2]
    p95 = 100 * a[min(n - 1, int(math.ceil(0.95 * n)) - 1)]
    mean = 100 * sum(r[1] for r in rows) / n
    print(f"{n}/{frames} {z2:.2f} {inside:.1f} {med:.2f} {mean:+.2f} {p95:.2f}")


if __name__ == "__main__":
    main(sys.argv)
