#!/usr/bin/env bash
# The accuracy guard of a solver option that changes numbers (issue 19): runs OLD_MOMO with
# a configuration and NEW_MOMO with the same configuration plus extra `[solver]` lines, on 7
# simulated scenarios x seeds 1-3 (150 frames) and, when $MOMO_DATA (default ../shared/data)
# has them, the real KITTI 00 matches (mono 100/200/300, stereo 200; 300 frames); reports per
# sequence whether every frame's status is the same, the largest and median per-frame
# difference of the frame-to-frame rotation (degrees), the mean solver iterations per frame
# (old -> new), and the median frame-to-frame rotation error against the ground truth
# (old -> new, `momo eval`).
# Usage: scripts/lm_options_eval.sh OLD_MOMO NEW_MOMO 'SOLVER LINES' [MODEL] [WORK_DIR]
#   e.g. scripts/lm_options_eval.sh old/momo target/release/momo 'max_step_extrapolation = 2.0'
# SOLVER LINES: `;` separates lines; empty compares the two binaries as they are (then every
# pose should be bit-identical). $OLD_SOLVER: lines for the old run's `[solver]` (replacing the
# keys they set), e.g. a tight `function_tolerance` for a reference. MODEL: a model type tag (default: the default configuration's).
set -euo pipefail
old=$(realpath "$1"); new=$(realpath "$2")
extra=${3:-}
model=${4:-}
work=${5:-$(mktemp -d)}
data=$(realpath -m "${MOMO_DATA:-$(dirname "$0")/../../shared/data}")
mkdir -p "$work"
cd "$work"
seqs=()
for s in clean_pinhole outliers moving_object fisheye_surround sparse_outliers very_sparse highway; do
  for seed in 1 2 3; do
    [ -d "sim_${s}_$seed" ] || "$new" simulate --scenario "$s" --frames 150 --seed "$seed" \
      -q "sim_${s}_$seed" >/dev/null 2>&1
    seqs+=("sim_${s}_$seed")
  done
done
k="$data/kitti00_stereo_matches_l1avgvo"
if [ -d "$k" ]; then
  for m in 100 200 300; do
    [ -d "kitti_mono$m" ] || "$new" import-kitti "$k" "kitti_mono$m" --matches "$m" >/dev/null 2>&1
    seqs+=("kitti_mono$m")
  done
  [ -d kitti_stereo200 ] || "$new" import-kitti "$k" kitti_stereo200 --stereo --matches 200 >/dev/null 2>&1
  seqs+=(kitti_stereo200)
else
  echo "no KITTI 00 matches under $data: simulated sequences only" >&2
fi
"$old" config > old.toml
python3 - old.toml new.toml "$model" "$extra" "${OLD_SOLVER:-}" <<'PY'
import sys, re
src, dst, model, extra, old_extra = sys.argv[1:6]
text = open(src).read()
if model:
    text = re.sub(r'^(\[model\]\n)(?:(?!^\[).*\n?)*', r'\1type = "%s"\n\n' % model, text, flags=re.M)
    open(src, 'w').write(text)
lines = ''.join(l.strip() + '\n' for l in extra.split(';') if l.strip())
text = re.sub(r'^(\[solver\]\n(?:(?!^\[).*\n)*?)', lambda m: m.group(1) + lines, text, count=1, flags=re.M)
open(dst, 'w').write(text)
if old_extra:
    old_lines = ''.join(l.strip() + '\n' for l in old_extra.split(';') if l.strip())
    text = open(src).read()
    for l in old_lines.splitlines():
        key = l.split('=')[0].strip()
        text = re.sub(r'^%s = .*\n' % key, '', text, flags=re.M)
    text = re.sub(r'^(\[solver\]\n(?:(?!^\[).*\n)*?)', lambda m: m.group(1) + old_lines, text, count=1, flags=re.M)
    open(src, 'w').write(text)
PY
printf '%-24s %8s %12s %12s %16s %22s\n' sequence statuses max_deg median_deg iterations median_err_deg
for s in "${seqs[@]}"; do
  for v in old new; do
    bin=$old; [ $v = new ] && bin=$new
    # Exit code 3 (an untrusted run) still writes the poses.
    "$bin" run "$s" -o "${v}_$s.txt" -c "$v.toml" -d "${v}_$s.csv" -q || [ $? -eq 3 ]
    if [ -f "$s/poses.txt" ]; then
      "$bin" eval --gt "$s/poses.txt" --est "${v}_$s.txt" --json > "${v}_$s.eval" 2>/dev/null || true
    fi
  done
  python3 - "$s" <<'PY'
import sys, csv, math, json
s = sys.argv[1]
def poses(f):
    out = []
    for line in open(f):
        a = [float(v) for v in line.split()]
        out.append(([a[0:3], a[4:7], a[8:11]], [a[3], a[7], a[11]]))
    return out
def rel_rot(p, q):  # R_p^T R_q
    return [[sum(p[k][i] * q[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
def angle(ra, rb):
    f = math.sqrt(sum((ra[i][j] - rb[i][j]) ** 2 for i in range(3) for j in range(3)))
    return math.degrees(2 * math.asin(min(1.0, f / (2 * math.sqrt(2)))))
po, pn = poses(f"old_{s}.txt"), poses(f"new_{s}.txt")
d = []
for k in range(1, min(len(po), len(pn))):
    d.append(angle(rel_rot(po[k-1][0], po[k][0]), rel_rot(pn[k-1][0], pn[k][0])))
d.sort()
def diag(f):
    rows = list(csv.DictReader(open(f)))
    return ([(r.get("status"), r.get("reason"), r.get("scale")) for r in rows],
            [float(r.get("iterations") or 0) for r in rows])
so, io = diag(f"old_{s}.csv"); sn, inn = diag(f"new_{s}.csv")
same = "same" if so == sn else "DIFF:%d" % sum(a != b for a, b in zip(so, sn))
if open(f"old_{s}.txt").read() == open(f"new_{s}.txt").read():
    same += ",bit"
def err(f):
    try:
        return "%.5f" % json.load(open(f))["estimates"][0]["rotation_deg"]["median"]
    except Exception:
        return "?"
print("%-24s %8s %12.3e %12.3e %7.2f -> %5.2f %10s -> %s" % (
    s, same, d[-1] if d else 0.0, d[len(d)//2] if d else 0.0,
    sum(io)/max(len(io),1), sum(inn)/max(len(inn),1), err(f"old_{s}.eval"), err(f"new_{s}.eval")))
PY
done
