#!/usr/bin/env python3
"""The frame pairs above a rotation error threshold of a rig (or mono) set with the error's axes and
the ground truth's direction of travel (riglock40, docs/RESULTS.md §9, twenty-sixth session).

Usage: scripts/rig_climb.py SEQ_DIR EST_DIR THRESHOLD_DEG NAME...

SEQ_DIR/NAME is a `momo simulate` sequence (rig.json, poses.txt: camera 0's poses), EST_DIR/NAME.txt
momo's estimate and EST_DIR/NAME.jsonl its diagnostics. Every motion is carried into the vehicle
frame by camera 0's mount (M = T E T^-1, T = T_vehicle_camera of camera 0). Per frame whose rotation
error is above the threshold: the error's rotation vector (vehicle x forward / y left / z up:
roll, pitch, yaw; degrees), the truth's chord climb (atan2 of the vertical over the horizontal
displacement; radians) and arc length (m), the diagnostics' status and reason. numpy only.
"""
import json, math, os, pathlib, sys
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "peers"))
from peers import read_rig  # noqa: E402


def poses(p):
    a = np.loadtxt(p).reshape(-1, 3, 4)
    o = np.tile(np.eye(4), (len(a), 1, 1))
    o[:, :3, :] = a
    return o


def log(r):
    th = math.acos(max(-1.0, min(1.0, (np.trace(r) - 1) / 2)))
    if th < 1e-12:
        return np.zeros(3)
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / (2 * math.sin(th))
    return w * th


if len(sys.argv) < 5:
    sys.exit(__doc__)
seqd, estd, thr = sys.argv[1], sys.argv[2], float(sys.argv[3])
for name in sys.argv[4:]:
    _, ext = read_rig(pathlib.Path(seqd) / name / "rig.json")
    t0 = np.asarray(ext[0])
    gt, est = poses(f"{seqd}/{name}/poses.txt"), poses(f"{estd}/{name}.txt")
    diag = {}
    for line in open(f"{estd}/{name}.jsonl"):
        d = json.loads(line)
        diag[d["frame"]] = d
    ti = np.linalg.inv(t0)
    for f in range(1, min(len(gt), len(est))):
        g = t0 @ np.linalg.inv(gt[f - 1]) @ gt[f] @ ti
        e = t0 @ np.linalg.inv(est[f - 1]) @ est[f] @ ti
        err = np.degrees(log(g[:3, :3].T @ e[:3, :3]))
        if np.linalg.norm(err) > thr:
            t = g[:3, 3]
            climb = math.atan2(t[2], math.hypot(t[0], t[1]))
            d = diag.get(f, {})
            print(f"{name} {f} err roll/pitch/yaw {err[0]:.2f} {err[1]:.2f} {err[2]:.2f} deg "
                  f"truth climb {climb:.2f} rad arc {np.linalg.norm(t):.2f} m "
                  f"{d.get('status')} {d.get('reason')}")
