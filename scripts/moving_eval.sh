#!/usr/bin/env bash
# Scores momo (default configuration) against the Cramér-Rao bound on a simulated scenario family
# (default: moving_traffic) over seeds x trajectories, with the peers OpenCV MAGSAC and PoseLib
# (scripts/peers/peers.py, PyPI wheels in a venv) side by side, and writes a Markdown summary.
#
# Usage: scripts/moving_eval.sh [SEEDS] [TRAJECTORIES] [FRAMES] [OUT_DIR]
#   SEEDS         number of seeds (1..SEEDS); default 3
#   TRAJECTORIES  space-separated list: KITTI ground-truth sequence numbers 00..10 (read from
#                 $MOMO_DATA/kitti_odometry_gt/poses/NN.txt, default ../shared/data) and/or
#                 `drive` (the simulator's built-in generated drive); default "00 01 02 03 04 05
#                 06 07 08 09 10 drive"
#   FRAMES        frames per sequence (at most the trajectory's length); default 500
#   OUT_DIR       sequences, estimates, rows.tsv and summary.md; default target/moving_eval
#   SCENARIO      environment variable: the `momo simulate --scenario` (default moving_traffic)
#   PEERS         environment variable: 1 (default) runs opencv-magsac and poselib too, 0 not
#   MOMO          environment variable: the momo binary (default target/release/momo)
#   MOMO_CONFIG   environment variable: a `momo run --config` file (default: the built-in one)
#   REUSE         environment variable: 1 keeps existing sequences (no re-simulation)
#   PYTHON        environment variable: Python for the peers' venv (default python3.11/python3)
#
# Per sequence, `momo eval` gives the frame-to-frame rotation error median, the frames above
# 1 deg, the bound (median over frames of bound.csv, the Cramér-Rao bound of the static
# matches) and eff = error median / bound. The summary reports, per method, the frame pairs
# above 1 deg (sum over sequences), the median and the maximum of eff over sequences, and the
# number of sequences with eff above 1.5.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
abs() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$PWD/$1" ;; esac; }
seeds="${1:-3}"
trajectories="${2:-00 01 02 03 04 05 06 07 08 09 10 drive}"
frames="${3:-500}"
out="$(abs "${4:-$root/target/moving_eval}")"
scenario="${SCENARIO:-moving_traffic}"
data="$(abs "${MOMO_DATA:-$root/../shared/data}")"
momo="${MOMO:-$root/target/release/momo}"
peers="${PEERS:-1}"
if [[ ! -x "$momo" ]]; then
    (cd "$root" && cargo build --release)
fi
mkdir -p "$out/seq" "$out/est"

venv="$root/target/peers/venv"
if ((peers)); then
    py="${PYTHON:-$(command -v python3.11 || command -v python3 || true)}"
    if [[ ! -x "$venv/bin/python" ]]; then
        mkdir -p "$(dirname "$venv")"
        "$py" -m venv "$venv" || peers=0
    fi
    if ((peers)) && ! "$venv/bin/python" -c 'import cv2, poselib' 2>/dev/null; then
        "$venv/bin/python" -m pip install --disable-pip-version-check -q \
            -r "$root/scripts/peers/requirements.txt" >"$out/venv.log" 2>&1 || true
        if ! "$venv/bin/python" -c 'import cv2, poselib' 2>/dev/null; then
            echo "moving_eval: the peers do not install (see $out/venv.log): skipping them" >&2
            peers=0
        fi
    fi
fi

rows="$out/rows.tsv"
: >"$rows"
# score NAME METHOD EST: appends "name method median >1deg bound eff pairs".
score() {
    local pairs
    pairs=$(($(wc -l <"$out/seq/$1/poses.txt") - 1))
    # Columns by their header names (`momo eval` adds columns over time).
    "$momo" eval --gt "$out/seq/$1/poses.txt" --est "$3" | tail -n 2 |
        awk -v n="$1" -v m="$2" -v p="$pairs" '
            NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
            { printf "%s\t%s\t%s\t%s\t%s\t%s\t%s\n", n, m, $c["median"], $c[">1deg"],
                $c["bound"], $c["eff"], p }' >>"$rows"
}
for t in $trajectories; do
    traj=()
    if [[ "$t" != drive ]]; then
        f="$data/kitti_odometry_gt/poses/$t.txt"
        if [[ ! -f "$f" ]]; then
            echo "moving_eval: no $f: skipping trajectory $t" >&2
            continue
        fi
        traj=(--trajectory "$f")
    fi
    for seed in $(seq 1 "$seeds"); do
        name="${scenario}_${t}_s$seed"
        if [[ "${REUSE:-0}" != 1 || ! -f "$out/seq/$name/bound.csv" ]]; then
            rm -rf "$out/seq/$name"
            "$momo" simulate --scenario "$scenario" "${traj[@]}" --frames "$frames" \
                --seed "$seed" "$out/seq/$name" >/dev/null
        fi
        est="$out/est/$name.momo.txt"
        cfg=()
        if [[ -n "${MOMO_CONFIG:-}" ]]; then cfg=(--config "$MOMO_CONFIG"); fi
        if "$momo" run "$out/seq/$name" "${cfg[@]}" -o "$est" -q; then
            score "$name" momo "$est"
        else
            printf '%s\tmomo\tfailed\n' "$name" >>"$rows"
        fi
        if ((peers)); then
            for m in opencv-magsac poselib; do
                est="$out/est/$name.$m.txt"
                if "$venv/bin/python" "$root/scripts/peers/peers.py" "$out/seq/$name" \
                    --method "$m" --threshold-px 1 -o "$est" --stats "$est.json" >/dev/null; then
                    score "$name" "$m" "$est"
                else
                    printf '%s\t%s\tfailed\n' "$name" "$m" >>"$rows"
                fi
            done
        fi
        echo "moving_eval: $name: $(grep -P "^$name\t" "$rows" | awk -F'\t' '{ printf "%s %s/%s/eff %s; ", $2, $3, $4, $6 }')" >&2
    done
done

{
    echo "## $scenario: rotation error against the Cramér-Rao bound"
    echo
    echo "Generated by \`scripts/moving_eval.sh $seeds \"$trajectories\" $frames\` on $(date -u +%Y-%m-%d)."
    echo "Seeds 1..$seeds; frames per sequence at most $frames; eff = median frame-to-frame"
    echo "rotation error / median per-frame Cramér-Rao bound of the static matches (bound.csv)."
    echo
    echo "| method | sequences | frame pairs | >1 deg | median eff | max eff | eff > 1.5 | median error (deg) |"
    echo "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    python3 - "$rows" <<'PY'
import statistics, sys
from collections import defaultdict
rows = defaultdict(list)
failed = defaultdict(int)
for line in open(sys.argv[1]):
    f = line.rstrip("\n").split("\t")
    if f[2] == "failed":
        failed[f[1]] += 1
    else:
        rows[f[1]].append(f)
for method in sorted(rows):
    r = rows[method]
    eff = [float(x[5]) for x in r if x[5] != "-"]
    med = [float(x[2]) for x in r]
    print("| %s | %d%s | %d | %d | %.2f | %.2f | %d | %.4f |" % (
        method, len(r), " (+%d failed)" % failed[method] if failed[method] else "",
        sum(int(x[6]) for x in r), sum(int(x[3]) for x in r),
        statistics.median(eff) if eff else float("nan"), max(eff) if eff else float("nan"),
        sum(e > 1.5 for e in eff), statistics.median(med)))
PY
} >"$out/summary.md"
cat "$out/summary.md"
