#!/usr/bin/env python3
"""The frame pairs above a rotation error threshold on a multi-camera traffic set, by object and
camera (`moving_traffic_surround`, the `rigtraffic` sets of scripts/family_eval.sh).

Usage: scripts/rig_frames.py SEQ_DIR EST_DIR [--threshold DEG] [NAME...]

SEQ_DIR/NAME is a `momo simulate` sequence (rig.json, matches.csv, poses.txt, bound.csv and
labels.csv with the `object` and `object_kind` columns); EST_DIR/NAME.txt momo's estimate and
EST_DIR/NAME.jsonl its diagnostics (`momo run -o ... --diagnostics ...`, what family_eval.sh
writes). NAME: default every NAME.jsonl in EST_DIR. For every frame pair whose frame-to-frame
rotation error of camera 0 is above the threshold (default 1 deg): the error, the bound, the
diagnostics' status, reason, constraint, inliers per camera, the competing motion's share, and
the estimate's support, the matches within 0.003 rad of the epipolar plane of the estimated
vehicle motion carried into each camera (C_j = P_j^-1 M P_j, M = P_0 E P_0^-1 from camera 0's
estimated relative pose E): per camera its static / object / outlier matches, and the object
holding most of the supporting object matches (its kind and camera). A frame is `on_object`
when objects hold more of the estimate's support than static points do. Prints one line per
frame and a summary by the dominant supporting object's kind. numpy only; the camera models
are scripts/peers/peers.py's port of momo's.
"""
import argparse, collections, csv, json, math, os, sys
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "peers"))
from peers import read_rig  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("seq"); ap.add_argument("est"); ap.add_argument("names", nargs="*")
ap.add_argument("--threshold", type=float, default=1.0)
args = ap.parse_args()
names = args.names or sorted(f[:-6] for f in os.listdir(args.est) if f.endswith(".jsonl"))


def poses(p):
    a = np.loadtxt(p).reshape(-1, 3, 4)
    out = np.tile(np.eye(4), (len(a), 1, 1))
    out[:, :3, :] = a
    return out


def angle(r):
    return math.degrees(math.acos(max(-1.0, min(1.0, (np.trace(r) - 1) / 2))))


def skew(t):
    return np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])


by_kind = collections.Counter()
by_camera_kind = collections.Counter()
rows_out = []
total_frames = 0
for name in names:
    sd = os.path.join(args.seq, name)
    models, ext = read_rig(__import__("pathlib").Path(sd) / "rig.json")
    gt, est = poses(f"{sd}/poses.txt"), poses(f"{args.est}/{name}.txt")
    diag = {}
    for line in open(f"{args.est}/{name}.jsonl"):
        d = json.loads(line)
        diag[d["frame"]] = d
    bound = {int(r["frame"]): r["rotation_bound_deg"] for r in csv.DictReader(open(f"{sd}/bound.csv"))}
    n = min(len(gt), len(est))
    total_frames += n - 1
    bad = []
    for k in range(1, n):
        eg = np.linalg.inv(gt[k - 1]) @ gt[k]
        ee = np.linalg.inv(est[k - 1]) @ est[k]
        err = angle(eg[:3, :3].T @ ee[:3, :3])
        if err > args.threshold:
            bad.append((k, err, ee))
    if not bad:
        continue
    want = {k for k, _, _ in bad}
    m = collections.defaultdict(list)
    lab = collections.defaultdict(list)
    with open(f"{sd}/matches.csv") as fm, open(f"{sd}/labels.csv") as fl:
        next(fm); next(fl)
        for a, b in zip(fm, fl):
            fa = a.rstrip("\n").split(","); fb = b.rstrip("\n").split(",")
            k = int(fa[0])
            if k in want:
                j = int(fa[1])
                m[(k, j)].append([float(x) for x in fa[2:6]])
                lab[(k, j)].append((fb[2], fb[3], fb[4]))
    p0 = ext[0]
    for k, err, ee in bad:
        mv = p0 @ ee @ np.linalg.inv(p0)  # vehicle motion (vehicle k in vehicle k-1)
        d = diag.get(k, {})
        support = collections.Counter()
        per_cam = []
        objs = collections.Counter()
        for j, (model, pj) in enumerate(zip(models, ext)):
            x = np.array(m.get((k, j), []), dtype=float).reshape(-1, 4)
            labels = lab.get((k, j), [])
            if not len(x):
                per_cam.append(f"c{j}:-")
                continue
            b0, ok0 = model.unproject(x[:, 0], x[:, 1])
            b1, ok1 = model.unproject(x[:, 2], x[:, 3])
            c = np.linalg.inv(pj) @ mv @ pj
            r, t = c[:3, :3], c[:3, 3]
            tn = np.linalg.norm(t)
            e = skew(t / tn) @ r if tn > 1e-12 else None
            if e is None:
                # no translation: rotation only, the angle between b0 and R b1
                res = np.linalg.norm(np.cross(b0, (r @ b1.T).T), axis=1)
            else:
                res = np.abs(np.einsum("ij,ij->i", b0, (e @ b1.T).T))
            sup = (res < 0.003) & ok0 & ok1
            cnt = collections.Counter()
            share_obj = sum(1 for l in labels if l[0] == "moving_object") / len(labels)
            for s, l in zip(sup, labels):
                if not s:
                    continue
                if l[0] == "moving_object":
                    cnt["object"] += 1
                    objs[(l[1], l[2], j)] += 1
                else:
                    cnt[l[0]] += 1
            support.update(cnt)
            per_cam.append(f"c{j}:obj{share_obj:.0%} sup s{cnt['inlier']}/o{cnt['object']}/x{cnt['outlier']}")
        on_object = support["object"] > support["inlier"]
        top = objs.most_common(1)
        if top:
            (oi, kind, cam), cnum = top[0]
            dom = f"{kind}#{oi}@c{cam}({cnum})"
        else:
            kind, cam, dom = "none", -1, "none"
        key = kind if on_object else "static(" + ("weak" if d.get("status") != "ok" else "ok") + ")"
        by_kind[key] += 1
        if on_object:
            by_camera_kind[(kind, cam)] += 1
        comp = d.get("competing")
        rows_out.append(
            f"{name} {k} err {err:.2f} bound {float(bound.get(k) or 'nan'):.4f} status {d.get('status')} "
            f"reason {d.get('reason')} constraint {d.get('constraint')} inl {d.get('inliers_per_camera')} "
            f"competing {comp[1] if comp else None} road {'yes' if d.get('road_alternative') else 'no'} "
            f"| support static {support['inlier']} object {support['object']} outlier {support['outlier']} "
            f"top {dom} | " + " ".join(per_cam))
print(f"frames above {args.threshold} deg: {sum(by_kind.values())} of {total_frames}")
print("by what the estimate follows (on_object: the dominant supporting object's kind):")
for k, v in by_kind.most_common():
    print(f"  {k}: {v}")
print("on_object frames by (kind, camera of the dominant object):")
for k, v in by_camera_kind.most_common():
    print(f"  {k}: {v}")
for r in rows_out:
    print(r)
