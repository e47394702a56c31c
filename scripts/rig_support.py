#!/usr/bin/env python3
"""Where a rig's efficiency goes (issue 14, analysis only): per camera, how many static, object
and mismatched matches lie within 3 sigma of the estimated motion's epipolar geometry (the
support a final stage would keep), against the labels.

Usage: scripts/rig_support.py SEQ_DIR EST_DIR [NAME...]

SEQ_DIR/NAME a `momo simulate` sequence (rig.json, matches.csv, poses.txt, bound.csv,
labels.csv); EST_DIR/NAME.txt momo's estimate (what family_eval.sh writes). Per match the
residual is `angle_plane` (f0 . E f1 of camera j's motion C_j = P_j^-1 M P_j, M from camera 0's
estimated relative pose) over its first-order standard deviation under 1 px isotropic pixel
noise (the unprojection Jacobians by central differences): pixels, as `angle_plane_ml`'s
maximum-likelihood weighting. sigma is the frame's robust scale of those residuals (median
absolute value / 0.6745 over the matches within 5 sigma of a 1 px start, twice), the support the
matches within 3 sigma. The same at the ground-truth motion gives the support an oracle motion
would have. Per sequence and camera: the static matches' share in the support, the object
matches and mismatches in it per frame, and the error / bound (exact) of the frames where the
support holds object matches against those where it holds none. numpy only; the camera models
are scripts/peers/peers.py's.
"""
import collections, csv, math, os, statistics, sys
import numpy as np
from pathlib import Path

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "peers"))
from peers import read_rig  # noqa: E402

seqroot, estdir = sys.argv[1], sys.argv[2]
names = sys.argv[3:] or sorted(f[:-4] for f in os.listdir(estdir) if f.endswith(".txt"))


def poses(p):
    a = np.loadtxt(p).reshape(-1, 3, 4)
    out = np.tile(np.eye(4), (len(a), 1, 1))
    out[:, :3, :] = a
    return out


def angle(r):
    v = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / 2
    return math.degrees(math.atan2(np.linalg.norm(v), (np.trace(r) - 1) / 2))


def skew(t):
    return np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])


def jac(model, u, v, h=1e-4):
    bu1, _ = model.unproject(u + h, v)
    bu0, _ = model.unproject(u - h, v)
    bv1, _ = model.unproject(u, v + h)
    bv0, _ = model.unproject(u, v - h)
    return np.stack([(bu1 - bu0) / (2 * h), (bv1 - bv0) / (2 * h)], 2)


def pixel_residuals(model, x, c):
    b0, ok0 = model.unproject(x[:, 0], x[:, 1])
    b1, ok1 = model.unproject(x[:, 2], x[:, 3])
    r, t = c[:3, :3], c[:3, 3]
    e = skew(t / max(np.linalg.norm(t), 1e-12)) @ r
    g0, g1 = (e @ b1.T).T, (e.T @ b0.T).T
    res = np.einsum("ij,ij->i", b0, g0)
    a0 = np.einsum("ij,ijk->ik", g0, jac(model, x[:, 0], x[:, 1]))
    a1 = np.einsum("ij,ijk->ik", g1, jac(model, x[:, 2], x[:, 3]))
    s = np.sqrt((a0 ** 2).sum(1) + (a1 ** 2).sum(1))
    z = np.abs(res) / np.where(s > 0, s, np.inf)
    return np.where(ok0 & ok1, z, np.inf)


def support(zs):
    allz = np.concatenate(zs)
    sigma = 1.0
    for _ in range(2):
        inner = allz[allz < 5 * sigma]
        if len(inner) < 8:
            break
        sigma = float(np.median(inner)) / 0.6745
    return [z < 3 * sigma for z in zs], sigma


print("name | static kept % (est / truth) per camera | object kept per frame per camera "
      "(est / truth) | mismatches kept per frame | eff frames with objects kept / without (share)")
for name in names:
    sd = Path(seqroot) / name
    models, ext = read_rig(sd / "rig.json")
    gt, est = poses(sd / "poses.txt"), poses(f"{estdir}/{name}.txt")
    bound = [float(r["rotation_bound_deg"]) for r in csv.DictReader(open(sd / "bound.csv"))]
    m = collections.defaultdict(list)
    lab = collections.defaultdict(list)
    with open(sd / "matches.csv") as fm, open(sd / "labels.csv") as fl:
        next(fm)
        next(fl)
        for a, b in zip(fm, fl):
            fa = a.split(",")
            k, j = int(fa[0]), int(fa[1])
            m[(k, j)].append([float(x) for x in fa[2:6]])
            lab[(k, j)].append(b.split(",")[2])
    n = min(len(gt), len(est))
    p0 = ext[0]
    nc = len(models)
    tot = np.zeros((2, nc, 3))  # [est/truth][camera][static kept, object kept, outlier kept]
    static_total = np.zeros(nc)
    ratios_obj, ratios_clean = [], []
    for k in range(1, n):
        err = angle((np.linalg.inv(gt[k - 1]) @ gt[k])[:3, :3].T @ (np.linalg.inv(est[k - 1]) @ est[k])[:3, :3])
        ratio = err / bound[k - 1]
        for w, pose in enumerate((est, gt)):
            mv = p0 @ (np.linalg.inv(pose[k - 1]) @ pose[k]) @ np.linalg.inv(p0)
            zs, labs = [], []
            for j in range(nc):
                x = np.array(m.get((k, j), []), dtype=float).reshape(-1, 4)
                c = np.linalg.inv(ext[j]) @ mv @ ext[j]
                zs.append(pixel_residuals(models[j], x, c) if len(x) else np.zeros(0))
                labs.append(np.array(lab.get((k, j), [])))
            sup, _ = support(zs)
            obj_kept = 0
            for j in range(nc):
                if not len(labs[j]):
                    continue
                if w == 0:
                    static_total[j] += (labs[j] == "inlier").sum()
                tot[w, j, 0] += (sup[j] & (labs[j] == "inlier")).sum()
                tot[w, j, 1] += (sup[j] & (labs[j] == "moving_object")).sum()
                tot[w, j, 2] += (sup[j] & (labs[j] == "outlier")).sum()
                obj_kept += (sup[j] & (labs[j] == "moving_object")).sum()
            if w == 0:
                (ratios_obj if obj_kept > 0 else ratios_clean).append(ratio)
    frames = n - 1
    cams = " ".join(f"c{j} {100 * tot[0, j, 0] / static_total[j]:.1f}/{100 * tot[1, j, 0] / static_total[j]:.1f}" for j in range(nc))
    objs = " ".join(f"c{j} {tot[0, j, 1] / frames:.1f}/{tot[1, j, 1] / frames:.1f}" for j in range(nc))
    outl = " ".join(f"c{j} {tot[0, j, 2] / frames:.1f}" for j in range(nc))
    mo = statistics.median(ratios_obj) if ratios_obj else float("nan")
    mc = statistics.median(ratios_clean) if ratios_clean else float("nan")
    print(f"{name} | {cams} | {objs} | {outl} | {mo:.3f} / {mc:.3f} ({len(ratios_obj) / frames:.2f})", flush=True)
