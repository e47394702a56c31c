"""A researcher's loop: simulate a drive (or read a sequence directory), estimate it frame by
frame with momo.Odometry, and score it as `momo eval` does.

    python crates/momo-py/examples/odometry_loop.py                 # a simulated drive
    python crates/momo-py/examples/odometry_loop.py path/to/seq     # a FORMAT.md directory
"""

import sys

import numpy as np

import momo

if len(sys.argv) > 1:
    seq = momo.Sequence.read(sys.argv[1])
else:
    seq = momo.simulate("outliers", frames=200, seed=1)
print(seq)

config = momo.Config(loss={"scale": 0.001})  # the default, made explicit
vo = momo.Odometry(seq.rig, config)
arcs = seq.arc_lengths  # None without odometry.csv; NaN where a frame pair has none

poses = [vo.pose]
statuses = {}
for k in range(1, len(seq)):
    matches = seq.frame(k)  # one (N, 4) array (u0, v0, u1, v1) per camera
    arc = None if arcs is None else float(arcs[k])
    motion, diag = vo.process(matches, arc)  # the 4x4 vehicle motion T_{k-1,k}
    poses.append(vo.pose)  # camera 0's pose, as `momo run` writes it
    statuses[diag.status] = statuses.get(diag.status, 0) + 1
    if diag.status == "estimated" and diag.inliers < 0.5 * diag.matches:
        print(f"frame {k}: only {diag.inliers}/{diag.matches} inliers")
poses = np.stack(poses)
print("frame pairs by status:", statuses)

if seq.ground_truth is not None:
    scores = momo.evaluate(seq.ground_truth, poses)
    r = scores["rotation_deg"]
    print(f"frame-to-frame rotation error: median {r['median']:.4f} deg, p95 {r['p95']:.4f} deg, "
          f"{r['above_one']} above 1 deg; KITTI t_err {scores['t_err_percent']}")
