#!/usr/bin/env python3
"""The image peers' front ends: OpenCV SIFT matches or KLT tracks between consecutive frames of
one camera, written as a momo sequence (matches.csv, ../../../shared/FORMAT.md), so that
peers.py (PoseLib, OpenCV) estimates from them and `momo eval` scores the result exactly as
momo's own estimates.

Usage:
    image_matches.py IMAGE_DIR SEQ --rig RIG.json [--odometry ODOMETRY.csv]
                     --detector sift|klt [--stats STATS.json]

IMAGE_DIR holds the frames as PNG files in name order (KITTI's image_0). SEQ gets rig.json and
odometry.csv (copies) and matches.csv (camera 0). STATS (default SEQ/front_end.json) gets the
settings, the matches per pair and the front end's mean time per frame (detection, description
and matching, decoding excluded; one thread).

Settings, OpenCV's documented defaults unless said (the same for every sequence):

- ``sift``: ``cv2.SIFT_create()`` (all keypoints, 3 octave layers, contrast 0.04, edge 10,
  sigma 1.6) on both frames; brute-force L2 matching, two nearest neighbours, Lowe's ratio
  test at 0.8, kept only if mutual (the best match in both directions).
- ``klt``: ``cv2.goodFeaturesToTrack`` on frame k-1 (1000 corners, quality 0.01, minimum
  distance 10 px), tracked into frame k by ``cv2.calcOpticalFlowPyrLK`` (21x21 window, 3
  pyramid levels) and back; kept if both directions succeed and the backward track returns
  within 1 px (forward-backward check).
"""

import argparse
import json
import shutil
import sys
import time
from pathlib import Path

import cv2
import numpy as np


def sift_matches(matcher, ka, da, kb, db):
    """Matches of the keypoints and descriptors of frame k-1 (``ka``, ``da``) and k."""
    if da is None or db is None or len(ka) < 2 or len(kb) < 2:
        return np.zeros((0, 4))
    fwd = matcher.knnMatch(da, db, k=2)
    bwd = matcher.knnMatch(db, da, k=1)
    back = {m[0].queryIdx: m[0].trainIdx for m in bwd if m}
    rows = []
    for m in fwd:
        if len(m) < 2 or m[0].distance > 0.8 * m[1].distance:
            continue
        if back.get(m[0].trainIdx) != m[0].queryIdx:
            continue
        rows.append((*ka[m[0].queryIdx].pt, *kb[m[0].trainIdx].pt))
    return np.array(rows).reshape(-1, 4)


def klt_matches(a, b):
    p0 = cv2.goodFeaturesToTrack(a, maxCorners=1000, qualityLevel=0.01, minDistance=10)
    if p0 is None:
        return np.zeros((0, 4))
    lk = dict(winSize=(21, 21), maxLevel=3)
    p1, st1, _ = cv2.calcOpticalFlowPyrLK(a, b, p0, None, **lk)
    p0b, st2, _ = cv2.calcOpticalFlowPyrLK(b, a, p1, None, **lk)
    ok = (st1[:, 0] == 1) & (st2[:, 0] == 1)
    ok &= np.linalg.norm((p0 - p0b).reshape(-1, 2), axis=1) < 1.0
    return np.hstack([p0.reshape(-1, 2)[ok], p1.reshape(-1, 2)[ok]])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("images", type=Path)
    ap.add_argument("seq", type=Path)
    ap.add_argument("--rig", type=Path, required=True)
    ap.add_argument("--odometry", type=Path)
    ap.add_argument("--detector", choices=["sift", "klt"], required=True)
    ap.add_argument("--stats", type=Path)
    args = ap.parse_args()
    cv2.setNumThreads(1)
    frames = sorted(args.images.glob("*.png"))
    if len(frames) < 2:
        sys.exit(f"image_matches: fewer than 2 PNG frames in {args.images}")
    args.seq.mkdir(parents=True, exist_ok=True)
    shutil.copy(args.rig, args.seq / "rig.json")
    if args.odometry:
        shutil.copy(args.odometry, args.seq / "odometry.csv")
    sift = cv2.SIFT_create()
    matcher = cv2.BFMatcher(cv2.NORM_L2)
    counts, seconds = [], 0.0
    prev = cv2.imread(str(frames[0]), cv2.IMREAD_GRAYSCALE)
    t = time.process_time()
    # SIFT: each frame is detected and described once (frame k's features are frame k+1's
    # previous ones).
    kp, desc = sift.detectAndCompute(prev, None) if args.detector == "sift" else (None, None)
    seconds += time.process_time() - t
    with open(args.seq / "matches.csv", "w") as out:
        out.write("frame,camera,u0,v0,u1,v1\n")
        for k in range(1, len(frames)):
            cur = cv2.imread(str(frames[k]), cv2.IMREAD_GRAYSCALE)
            t = time.process_time()
            if args.detector == "sift":
                kc, dc = sift.detectAndCompute(cur, None)
                m = sift_matches(matcher, kp, desc, kc, dc)
                kp, desc = kc, dc
            else:
                m = klt_matches(prev, cur)
            seconds += time.process_time() - t
            counts.append(len(m))
            for u0, v0, u1, v1 in m:
                out.write(f"{k},0,{u0:.3f},{v0:.3f},{u1:.3f},{v1:.3f}\n")
            prev = cur
    stats = {
        "detector": args.detector,
        "opencv": cv2.__version__,
        "pairs": len(counts),
        "matches_per_pair": float(np.mean(counts)),
        "min_matches": int(min(counts)),
        "ms_per_frame": 1e3 * seconds / len(counts),
        "clock": "process CPU time (all threads of the process)",
    }
    (args.stats or args.seq / "front_end.json").write_text(json.dumps(stats, indent=2) + "\n")
    print(json.dumps(stats))


if __name__ == "__main__":
    main()
