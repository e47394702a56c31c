#!/usr/bin/env python3
"""Calibration of the reported rotation covariance on simulated sequences (issue 14 / 15).

Usage: family_calibration.py [--frames OUT.tsv] TRDIR SEQD [NAME...]
  TRDIR  holds NAME.txt and NAME.jsonl from
         `momo run SEQD/NAME -o TRDIR/NAME.txt --diagnostics TRDIR/NAME.jsonl`
  SEQD   the sequences (poses.txt, rig.json, labels.csv, bound.csv; `momo simulate`)
  NAME   default: every NAME.jsonl in TRDIR
Per frame k (the pair k-1, k) the rotation error vector in the vehicle frame,
delta = rotvec(R_vc E R_vc^T) - rotvec(R_vc G R_vc^T) (E, G the estimated and true relative
rotations of camera 0), is scored against the reported covariance of the parameters
rot_x, rot_y, rot_z (the first three of `covariance`, over the `free` parameters):
NEES = delta^T Sigma^-1 delta (chi-square(3): mean 3, 95 % below 7.81) and z_i = |delta_i| / sigma_i.
Prints the trust gap (frames above 1 deg neither flagged nor within 3 sigma on every axis; a
frame is flagged where its status is neither `estimated` nor `standstill`: a standstill is a
state of the vehicle, not a warning, and its covariance is as trusted as an estimated frame's)
and,
over all frames / frames flagged or not / by the share of object matches (labels.csv)
/ by the trust module's flags (competing motion, road alternative): frames, share inside the
95 % bound, mean and median NEES, share of unflagged frames more than 3 sigma off on some axis
(a calibrated Gaussian: 0.8 %) and per axis (x roll, y pitch, z yaw), the median sigma over
the Cramer-Rao bound (bound.csv: rotation_bound_deg, the static matches' bound) as the
sharpness. Needs numpy (e.g. /tmp/rig30/venv/bin/python). --frames writes one row per frame.
"""
import csv
import json
import math
import os
import sys

import numpy as np

CHI2_95 = 7.814727903251178
# The statuses whose covariance a user trusts (the others flag the frame).
TRUSTED = ("estimated", "standstill")


def rotvec(r):
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / 2
    s = np.linalg.norm(w)
    return w / s * math.atan2(s, (np.trace(r) - 1) / 2) if s > 1e-15 else np.zeros(3)


def poses(p):
    return np.loadtxt(p).reshape(-1, 3, 4)[:, :, :3]


def frames_of(trd, seqd, name):
    rig = json.load(open(f"{seqd}/{name}/rig.json"))
    rvc = np.array(rig["cameras"][0]["T_vehicle_camera"])[:3, :3]
    g = poses(f"{seqd}/{name}/poses.txt")
    e = poses(f"{trd}/{name}.txt")
    obj, tot = {}, {}
    lab = f"{seqd}/{name}/labels.csv"
    if os.path.exists(lab):
        for r in csv.DictReader(open(lab)):
            k = int(r["frame"])
            tot[k] = tot.get(k, 0) + 1
            obj[k] = obj.get(k, 0) + (r["label"] == "moving_object")
    bound = {}
    bp = f"{seqd}/{name}/bound.csv"
    if os.path.exists(bp):
        for r in csv.DictReader(open(bp)):
            if r["rotation_bound_deg"]:
                bound[int(r["frame"])] = math.radians(float(r["rotation_bound_deg"]))
    out = []
    for line in open(f"{trd}/{name}.jsonl"):
        d = json.loads(line)
        k = d["frame"]
        if k >= len(g) or k >= len(e):
            continue
        gr = g[k - 1].T @ g[k]
        er = e[k - 1].T @ e[k]
        gv = rotvec(rvc @ gr @ rvc.T)
        ev = rotvec(rvc @ er @ rvc.T)
        delta = ev - gv
        free = d.get("free") or []
        cov = d.get("covariance")
        row = dict(name=name, frame=k, status=d["status"], reason=d.get("reason") or "",
                   err=math.degrees(np.linalg.norm(rotvec(er.T @ gr))),
                   dx=delta[0], dy=delta[1], dz=delta[2], yaw_rate=gv[2],
                   obj=obj.get(k, 0) / max(tot.get(k, 1), 1),
                   competing=d.get("competing") is not None,
                   road_alt=d.get("road_alternative") is not None,
                   jackknife=bool(d.get("jackknife")),
                   inliers=d.get("inliers", 0), matches=d.get("matches", 0),
                   clustering=d.get("residual_clustering") or float("nan"),
                   bound=bound.get(k, float("nan")), nees=float("nan"),
                   sx=float("nan"), sy=float("nan"), sz=float("nan"))
        # A degenerate frame reports an empty covariance (no sigma, no NEES).
        if cov and len(cov) == len(free) ** 2 and all(i in free for i in range(3)):
            n = len(free)
            c = np.array(cov, dtype=float).reshape(n, n)
            idx = [free.index(i) for i in range(3)]
            c3 = c[np.ix_(idx, idx)]
            row["sx"], row["sy"], row["sz"] = np.sqrt(np.diag(c3))
            try:
                row["nees"] = float(delta @ np.linalg.solve(c3, delta))
            except np.linalg.LinAlgError:
                pass
        out.append(row)
    return out


def summary(label, rows):
    rows = [r for r in rows if np.isfinite(r["nees"])]
    if not rows:
        return
    nees = np.array([r["nees"] for r in rows])
    z = np.array([[abs(r["dx"]) / r["sx"], abs(r["dy"]) / r["sy"], abs(r["dz"]) / r["sz"]]
                  for r in rows])
    unfl = np.array([r["status"] in TRUSTED for r in rows])
    over = (z.max(1) > 3) & unfl
    axes = " ".join(f"{a}={((z[:, i] > 3) & unfl).sum()}" for i, a in enumerate("xyz"))
    sharp = [max(r["sx"], r["sy"], r["sz"]) / r["bound"] for r in rows
             if np.isfinite(r["bound"]) and r["bound"] > 0]
    print(f"{label:28s} n {len(rows):6d} inside95 {100 * (nees <= CHI2_95).mean():5.1f} % "
          f"meanNEES {nees.mean():8.2f} median {np.median(nees):6.2f} "
          f"unflagged>3sig {over.sum():5d} / {unfl.sum():5d} ({100 * over.sum() / max(unfl.sum(), 1):4.1f} %) "
          f"[{axes}] sigma/bound {np.median(sharp) if sharp else float('nan'):5.2f}")


def main():
    args = sys.argv[1:]
    fout = None
    if args[:1] == ["--frames"]:
        fout, args = args[1], args[2:]
    trd, seqd, names = args[0], args[1], args[2:]
    if not names:
        names = sorted(f[:-6] for f in os.listdir(trd) if f.endswith(".jsonl"))
    rows = [r for n in names for r in frames_of(trd, seqd, n)]
    if fout:
        with open(fout, "w") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0].keys()), delimiter="\t")
            w.writeheader()
            w.writerows(rows)
    big = [r for r in rows if r["err"] > 1]
    flagged = sum(r["status"] not in TRUSTED for r in big)
    within = sum(np.isfinite(r["sx"]) and max(abs(r["d" + a]) / r["s" + a] for a in "xyz") <= 3
                 for r in big)
    gap = sum(r["status"] in TRUSTED and not (
        np.isfinite(r["sx"]) and max(abs(r["d" + a]) / r["s" + a] for a in "xyz") <= 3)
        for r in big)
    print(f"sequences {len(names)} frames {len(rows)}; frames above 1 deg {len(big)}: flagged "
          f"{flagged}, within 3 sigma {within}, neither (the trust gap) {gap}")
    summary("all", rows)
    summary("estimated", [r for r in rows if r["status"] == "estimated"])
    summary("standstill", [r for r in rows if r["status"] == "standstill"])
    summary("flagged", [r for r in rows if r["status"] not in TRUSTED])
    for lo, hi in [(0, 0.1), (0.1, 0.3), (0.3, 0.5), (0.5, 1.01)]:
        summary(f"object share {lo}-{hi}", [r for r in rows if lo <= r["obj"] < hi])
    summary("competing", [r for r in rows if r["competing"]])
    summary("no competing", [r for r in rows if not r["competing"]])
    summary("road alternative", [r for r in rows if r["road_alt"]])
    summary("|yaw rate| > 1 deg", [r for r in rows if abs(r["yaw_rate"]) > math.radians(1)])
    summary("|yaw rate| <= 1 deg", [r for r in rows if abs(r["yaw_rate"]) <= math.radians(1)])


if __name__ == "__main__":
    main()
