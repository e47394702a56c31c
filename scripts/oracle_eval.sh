#!/usr/bin/env bash
# Oracle experiments with the simulator's labels (labels.csv, FORMAT.md version 6) on a
# simulated scenario family (default: moving_traffic), issue 14: how much of momo's distance to
# the Cramér-Rao bound is the moving objects' doing?
#
# Usage: scripts/oracle_eval.sh [SEEDS] [TRAJECTORIES] [FRAMES] [OUT_DIR]
#   SEEDS, TRAJECTORIES, FRAMES as in scripts/moving_eval.sh (defaults 5, "00 02 08", 500)
#   OUT_DIR       sequences, estimates, frames.tsv and summary.md; default target/oracle_eval
#   SCENARIO      environment variable: the `momo simulate --scenario` (default moving_traffic)
#   MOMO          environment variable: the momo binary (default target/release/momo)
#   MOMO_CONFIG   environment variable: a `momo run --config` file (default: the built-in one)
#   REUSE         environment variable: 1 keeps existing sequences (no re-simulation)
#   THRESHOLD     environment variable: support threshold on the epipolar angle (radians,
#                 default 0.003, the separation's)
#
# Per sequence, two runs of the same configuration:
#   full    the simulated sequence as it is;
#   static  the same sequence with the moving-object matches removed (labels.csv), i.e. static
#           matches and outliers only: the oracle separation.
# Both are scored against the same bound.csv (the static matches' Cramér-Rao bound). Per frame
# pair (frames.tsv): the error / bound of both runs, and the composition of the full run's
# support (the matches within THRESHOLD of the estimated motion's epipolar geometry): static,
# object and outlier matches, and how many object matches of the support an "under the road"
# test would flag (below the horizon, triangulated at the odometry scale farther than the
# road plane z = 0 of the vehicle frame allows, by more than 3 sigma of the inverse range;
# the same test on the static matches of the support gives its false alarms). The summary
# gives, per seed and over all, the median eff of both runs, and the median error / bound by
# the object share of the support.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
abs() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$PWD/$1" ;; esac; }
seeds="${1:-5}"
trajectories="${2:-00 02 08}"
frames="${3:-500}"
out="$(abs "${4:-$root/target/oracle_eval}")"
scenario="${SCENARIO:-moving_traffic}"
data="$(abs "${MOMO_DATA:-$root/../shared/data}")"
momo="${MOMO:-$root/target/release/momo}"
if [[ ! -x "$momo" ]]; then
    (cd "$root" && cargo build --release)
fi
mkdir -p "$out/seq" "$out/est"
cfg=()
if [[ -n "${MOMO_CONFIG:-}" ]]; then cfg=(--config "$MOMO_CONFIG"); fi

names=()
for t in $trajectories; do
    traj=()
    if [[ "$t" != drive ]]; then
        f="$data/kitti_odometry_gt/poses/$t.txt"
        if [[ ! -f "$f" ]]; then
            echo "oracle_eval: no $f: skipping trajectory $t" >&2
            continue
        fi
        traj=(--trajectory "$f")
    fi
    for seed in $(seq 1 "$seeds"); do
        name="${scenario}_${t}_s$seed"
        full="$out/seq/$name"
        static="$out/seq/${name}_static"
        if [[ "${REUSE:-0}" != 1 || ! -f "$full/labels.csv" ]]; then
            rm -rf "$full"
            "$momo" simulate --scenario "$scenario" "${traj[@]}" --frames "$frames" \
                --seed "$seed" "$full" >/dev/null
        fi
        rm -rf "$static"
        mkdir -p "$static"
        for f in rig.json odometry.csv poses.txt bound.csv; do
            if [[ -f "$full/$f" ]]; then cp "$full/$f" "$static/"; fi
        done
        # matches.csv without the moving-object rows (labels.csv is row for row).
        paste -d '\t' "$full/matches.csv" "$full/labels.csv" |
            awk -F'\t' -v m="$static/matches.csv" -v l="$static/labels.csv" '
                { split($2, x, ","); if (x[3] != "moving_object") { print $1 > m; print $2 > l } }'
        for kind in full static; do
            seq_dir="$full"
            if [[ $kind == static ]]; then seq_dir="$static"; fi
            "$momo" run "$seq_dir" "${cfg[@]}" -o "$out/est/$name.$kind.txt" -q
        done
        names+=("$name")
        echo "oracle_eval: $name done" >&2
    done
done

if ((${#names[@]} == 0)); then
    echo "oracle_eval: no sequences" >&2
    exit 1
fi
python3 - "$out" "${THRESHOLD:-0.003}" "${names[@]}" >"$out/summary.md" <<'PY'
import json, math, statistics, sys
from collections import defaultdict

out, thr, names = sys.argv[1], float(sys.argv[2]), sys.argv[3:]

def mat(r):  # 3x4 row-major -> (R, t)
    v = [float(x) for x in r.split()]
    return [v[0:3], v[4:7], v[8:11]], [v[3], v[7], v[11]]

def mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]

def tr(a):
    return [[a[j][i] for j in range(3)] for i in range(3)]

def mv(a, v):
    return [sum(a[i][k] * v[k] for k in range(3)) for i in range(3)]

def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]

def dot(a, b):
    return sum(x * y for x, y in zip(a, b))

def norm(a):
    return math.sqrt(dot(a, a))

def poses(path):
    return [mat(l) for l in open(path) if l.strip()]

def rel(p, k):  # pose of camera 0 at k in camera 0 at k-1
    (ra, ta), (rb, tb) = p[k - 1], p[k]
    rat = tr(ra)
    return mul(rat, rb), mv(rat, [tb[i] - ta[i] for i in range(3)])

def angle_deg(r):
    # atan2 of the skew part over the trace: accurate for small angles (acos is not).
    s = math.sqrt((r[2][1] - r[1][2]) ** 2 + (r[0][2] - r[2][0]) ** 2 + (r[1][0] - r[0][1]) ** 2) / 2
    return math.degrees(math.atan2(s, (r[0][0] + r[1][1] + r[2][2] - 1) / 2))

def per_frame_err(gt, est):
    return {k: angle_deg(mul(tr(rel(est, k)[0]), rel(gt, k)[0])) for k in range(1, min(len(gt), len(est)))}

rows = []
sigma_angle = 1.0 / 718.856  # 1 px at KITTI's focal length
for name in names:
    d = f"{out}/seq/{name}"
    rig = json.load(open(f"{d}/rig.json"))
    cams = []
    for c in rig["cameras"]:
        m = c["model"]
        if m["type"] != "pinhole":
            sys.exit("oracle_eval: only pinhole rigs")
        t = c["T_vehicle_camera"]
        cams.append((m, [row[:3] for row in t[:3]], [row[3] for row in t[:3]]))
    if len(cams) != 1:
        sys.exit("oracle_eval: only single-camera rigs")
    bound = {}
    for l in list(open(f"{d}/bound.csv"))[1:]:
        f = l.strip().split(",")
        if f[1]:
            bound[int(f[0])] = float(f[1])
    gt = poses(f"{d}/poses.txt")
    est = {kind: poses(f"{out}/est/{name}.{kind}.txt") for kind in ("full", "static")}
    err = {kind: per_frame_err(gt, est[kind]) for kind in est}
    m, r_vc, t_vc = cams[0]
    h = t_vc[2]
    by_frame = defaultdict(list)
    ml = open(f"{d}/matches.csv")
    hdr = next(ml).strip().split(",")
    col = {c: i for i, c in enumerate(hdr)}
    ll = open(f"{d}/labels.csv")
    next(ll)
    for mrow, lrow in zip(ml, ll):
        f = mrow.strip().split(",")
        k = int(f[col["frame"]])
        by_frame[k].append(([float(f[col[c]]) for c in ("u0", "v0", "u1", "v1")], lrow.strip().split(",")[2]))
    for k in sorted(by_frame):
        if k not in bound or k not in err["full"] or k not in err["static"]:
            continue
        r, t = rel(est["full"], k)
        tn = norm(t)
        # e = [t]x R, so that f0 . (e f1) = 0 for a static point (f0 ~ R f1 + t / range).
        tx = [[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]]
        e = mul(tx, r)
        count = defaultdict(int)
        flagged = defaultdict(int)
        for (u0, v0, u1, v1), label in by_frame[k]:
            f0 = [(u0 - m["cx"]) / m["fx"], (v0 - m["cy"]) / m["fy"], 1.0]
            f1 = [(u1 - m["cx"]) / m["fx"], (v1 - m["cy"]) / m["fy"], 1.0]
            n0, n1 = norm(f0), norm(f1)
            f0 = [x / n0 for x in f0]
            f1 = [x / n1 for x in f1]
            ef1 = mv(e, f1)
            etf0 = mv(tr(e), f0)
            c = abs(dot(f0, ef1))
            a, b = norm(ef1), norm(etf0)
            ang = 0.0 if a < 1e-15 or b < 1e-15 else 0.5 * (math.asin(min(1, c / a)) + math.asin(min(1, c / b)))
            if ang >= thr:
                continue
            count[label] += 1
            # Under the road: the ray below the horizon, its range beyond the road's.
            d_v = mv(r_vc, f0)
            if d_v[2] >= -1e-6 or tn < 1e-6:
                continue
            road = h / -d_v[2]
            rf1 = mv(r, f1)
            th = [x / tn for x in t]
            away = cross(th, f0)
            sa = norm(away)
            if sa < 1e-9:
                continue
            p = dot(cross(f0, rf1), away) / sa
            inv = p / (tn * sa)  # 1 / range from the parallax
            sig = math.sqrt(2) * sigma_angle / (tn * sa)
            if 1.0 / road - inv > 3.0 * sig:
                flagged[label] += 1
        n_sup = sum(count.values())
        rows.append((name, k, err["full"][k] / bound[k], err["static"][k] / bound[k],
                     count["inlier"], count["moving_object"], count["outlier"],
                     flagged["moving_object"], flagged["inlier"], n_sup))

with open(f"{out}/frames.tsv", "w") as fo:
    fo.write("sequence\tframe\terr_over_bound_full\terr_over_bound_static\tsupport_static\tsupport_object\tsupport_outlier\tobject_under_road\tstatic_under_road\n")
    for r in rows:
        fo.write("\t".join(str(x) if not isinstance(x, float) else "%.4f" % x for x in r[:9]) + "\n")

print("## Oracle: the moving-object matches removed (labels.csv)\n")
print("Per sequence: eff = median error / median bound (bound.csv), full and static runs.\n")
print("| sequence | eff full | eff static | frames > 1 deg full | static |")
print("| --- | ---: | ---: | ---: | ---: |")
# Recompute eff per sequence from errors and bounds.
effs = defaultdict(list)
for name in names:
    d = f"{out}/seq/{name}"
    bound = [float(l.split(",")[1]) for l in list(open(f"{d}/bound.csv"))[1:] if l.split(",")[1]]
    gt = poses(f"{d}/poses.txt")
    line = [name]
    for kind in ("full", "static"):
        e = per_frame_err(gt, poses(f"{out}/est/{name}.{kind}.txt"))
        eff = statistics.median(e.values()) / statistics.median(bound)
        effs[kind].append(eff)
        line.append("%.2f" % eff)
    for kind in ("full", "static"):
        e = per_frame_err(gt, poses(f"{out}/est/{name}.{kind}.txt"))
        line.append(str(sum(x > 1 for x in e.values())))
    print("| " + " | ".join(line) + " |")
print("| **median** | **%.2f** | **%.2f** | | |" % (statistics.median(effs["full"]), statistics.median(effs["static"])))
print()
print("Per frame pair, by the object share of the full run's support (matches within %g rad):\n" % thr)
print("| object share | frame pairs | median err/bound full | median err/bound static | median full/static | objects flagged under the road | static flagged |")
print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
bins = [(0, 0.05), (0.05, 0.2), (0.2, 0.3), (0.3, 0.5), (0.5, 1.01)]
for lo, hi in bins:
    sel = [r for r in rows if r[9] and lo <= r[5] / r[9] < hi]
    if not sel:
        continue
    obj = sum(r[5] for r in sel)
    sta = sum(r[4] for r in sel)
    print("| %.2f-%.2f | %d | %.2f | %.2f | %.2f | %d of %d | %d of %d |" % (
        lo, min(hi, 1), len(sel), statistics.median(r[2] for r in sel),
        statistics.median(r[3] for r in sel),
        statistics.median(r[2] / r[3] for r in sel if r[3] > 0),
        sum(r[7] for r in sel), obj, sum(r[8] for r in sel), sta))
PY
cat "$out/summary.md"
