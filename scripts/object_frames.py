#!/usr/bin/env python3
"""The frame pairs above a rotation error threshold on the moving-traffic family, by object.

Usage: scripts/object_frames.py SEQ_DIR EST_DIR [--diag DIAG_DIR] [--threshold DEG] NAME...

SEQ_DIR/NAME holds a `momo simulate` sequence whose labels.csv has the `object` and
`object_kind` columns (FORMAT.md version 7); EST_DIR/NAME.momo.txt is momo's estimate;
DIAG_DIR/NAME.csv (optional) its `momo run -d` diagnostics. For every frame pair of every NAME,
the frame-to-frame rotation error (deg), and for those above the threshold (default 1 deg) the
dominant object's kind (the traffic object with the most matches), the object share of all
matches and of the estimate's support (epipolar angle below 0.003 rad), the object share left
by the default's cell cap (16x8 cells, at most max(2, ceil(2 * median)) per cell, as weights),
the true turn (deg), the error along the true rotation axis (negative: the estimate turns less),
the odometry arc length and the diagnostics' status. Prints a summary per dominant kind (rates
over all frame pairs of the named sequences) and one line per frame pair. numpy only.
"""
import argparse, collections, csv, json, math, statistics
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("seq"); ap.add_argument("est"); ap.add_argument("names", nargs="+")
ap.add_argument("--diag"); ap.add_argument("--threshold", type=float, default=1.0)
args = ap.parse_args()

def poses(p):
    a = np.loadtxt(p).reshape(-1, 3, 4)
    return a[:, :, :3], a[:, :, 3]

def rotvec(r):
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / 2
    s = np.linalg.norm(w)
    return w / s * math.atan2(s, (np.trace(r) - 1) / 2) if s > 1e-15 else np.zeros(3)

def bearings(u, v, m):
    f = np.stack([(u - m["cx"]) / m["fx"], (v - m["cy"]) / m["fy"], np.ones(len(u))], 1)
    return f / np.linalg.norm(f, axis=1)[:, None]

def in_support(f0, f1, r, t, thr=0.003):
    e = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]]) @ r
    ef1, etf0 = f1 @ e.T, f0 @ e
    c = np.abs(np.sum(f0 * ef1, 1))
    a, b = np.linalg.norm(ef1, axis=1), np.linalg.norm(etf0, axis=1)
    return 0.5 * (np.arcsin(np.minimum(1, c / a)) + np.arcsin(np.minimum(1, c / b))) < thr

above, frames_by_kind = [], collections.Counter()
for name in args.names:
    d = f"{args.seq}/{name}"
    m = json.load(open(f"{d}/rig.json"))["cameras"][0]["model"]
    if m["type"] != "pinhole":
        raise SystemExit("object_frames: pinhole single-camera sequences only")
    gr, gt = poses(f"{d}/poses.txt")
    er, et = poses(f"{args.est}/{name}.momo.txt")
    mt = np.genfromtxt(f"{d}/matches.csv", delimiter=",", names=True)
    lab = list(csv.reader(open(f"{d}/labels.csv")))[1:]
    if lab and len(lab[0]) < 5:
        raise SystemExit(f"object_frames: {d}/labels.csv has no object columns (FORMAT.md version 7)")
    label = np.array([x[2] for x in lab])
    obj = np.array([int(x[3]) if x[3] else -1 for x in lab])
    kind = np.array([x[4] for x in lab])
    arc = {int(x[0]): float(x[1]) for x in list(csv.reader(open(f"{d}/odometry.csv")))[1:]}
    diag = {}
    if args.diag:
        diag = {int(x["frame"]): x["status"] + (":" + x["reason"] if x["reason"] else "")
                for x in csv.DictReader(open(f"{args.diag}/{name}.csv"))}
    starts = np.searchsorted(mt["frame"].astype(int), np.arange(len(gr) + 1))
    for k in range(1, min(len(gr), len(er))):
        rg, tg = gr[k - 1].T @ gr[k], gr[k - 1].T @ (gt[k] - gt[k - 1])
        re_, te = er[k - 1].T @ er[k], er[k - 1].T @ (et[k] - et[k - 1])
        sl = slice(starts[k], starts[k + 1])
        lb, ob, kd = label[sl], obj[sl], kind[sl]
        ids, cnt = np.unique(ob[ob >= 0], return_counts=True)
        dom = kd[ob == ids[np.argmax(cnt)]][0] if len(ids) else "none"
        frames_by_kind[dom] += 1
        err = math.degrees(np.linalg.norm(rotvec(re_.T @ rg)))
        if err <= args.threshold:
            continue
        w = rotvec(rg)
        along = math.degrees(rotvec(re_ @ rg.T) @ (w / np.linalg.norm(w))) if np.linalg.norm(w) > 1e-12 else 0.0
        u0, v0 = mt["u0"][sl], mt["v0"][sl]
        f0, f1 = bearings(u0, v0, m), bearings(mt["u1"][sl], mt["v1"][sl], m)
        s = in_support(f0, f1, re_, te)
        isobj = lb == "moving_object"
        cell = np.clip((u0 / m["width"] * 16).astype(int), 0, 15) + 16 * np.clip((v0 / m["height"] * 8).astype(int), 0, 7)
        cc = np.bincount(cell, minlength=128)
        occ = np.sort(cc[cc > 0])
        cap = max(2, math.ceil(2 * occ[len(occ) // 2]))
        wt = np.minimum(1, cap / cc[cell])
        above.append(dict(name=name, k=k, err=err, dom=dom, kinds="+".join(sorted(set(kd[ob >= 0]))),
                          share=isobj.mean(), support=(isobj & s).sum() / max(s.sum(), 1),
                          capped=(wt * isobj).sum() / wt.sum(), turn=math.degrees(np.linalg.norm(w)),
                          along=along, arc=arc.get(k, float("nan")), status=diag.get(k, "")))

def q(v):
    v = sorted(v)
    return "%.2f (%.2f-%.2f)" % (statistics.median(v), v[len(v) // 4], v[3 * len(v) // 4]) if v else "-"

print(f"{len(above)} frame pairs above {args.threshold} deg")
print("| dominant object | frames above | of frame pairs | object share of matches | of the estimate's support | left by the cap | turn (deg) | along < 0 | error (deg) | competing |")
print("| --- | ---: | ---: | --- | --- | --- | --- | ---: | --- | ---: |")
for kd, n in frames_by_kind.most_common():
    rs = [r for r in above if r["dom"] == kd]
    print(f"| {kd} | {len(rs)} | {n} | {q([r['share'] for r in rs])} | {q([r['support'] for r in rs])} | "
          f"{q([r['capped'] for r in rs])} | {q([r['turn'] for r in rs])} | {sum(r['along'] < 0 for r in rs)} | "
          f"{q([r['err'] for r in rs])} | {sum('competing' in r['status'] for r in rs)} |")
for r in above:
    print("%s %d err %.2f %s [%s] share %.2f support %.2f capped %.2f turn %.2f along %.2f arc %.2f %s" % (
        r["name"], r["k"], r["err"], r["dom"], r["kinds"], r["share"], r["support"], r["capped"],
        r["turn"], r["along"], r["arc"], r["status"]))
