#!/usr/bin/env bash
# Efficiency (median error / median Cramér-Rao bound) of several configurations on simulated
# scenarios along the KITTI ground-truth trajectories (issue 14: the independent evaluation
# simulates along them; their direction of travel jitters, unlike the built-in drive's).
#
# Usage: scripts/eff_kitti_eval.sh OUT_DIR NAME=CONFIG.toml... (CONFIG "default": built-in)
#   TRAJECTORIES  environment variable: KITTI sequence numbers (default "00 01 ... 10"), read
#                 from $MOMO_DATA/kitti_odometry_gt/poses/NN.txt (default ../shared/data)
#   SCENARIOS     environment variable: default "clean_pinhole outliers"
#   SEEDS         environment variable: default "1"
#   FRAMES        environment variable: frames per sequence (default 500; 04 has 271)
#   MOMO          environment variable: the momo binary (default target/release/momo)
#
# Writes OUT_DIR/rows.tsv (scenario trajectory seed config median bound eff t_err% frames>1deg) and prints
# it. Sequences are kept in OUT_DIR/seq and reused.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out="${1:?usage: scripts/eff_kitti_eval.sh OUT_DIR NAME=CONFIG...}"
shift
data="${MOMO_DATA:-$root/../shared/data}"
trajs="${TRAJECTORIES:-00 01 02 03 04 05 06 07 08 09 10}"
scenarios="${SCENARIOS:-clean_pinhole outliers}"
seeds="${SEEDS:-1}"
frames="${FRAMES:-500}"
momo="${MOMO:-$root/target/release/momo}"
poses="$data/kitti_odometry_gt/poses"
if [[ ! -d "$poses" ]]; then
    echo "eff_kitti_eval: no KITTI ground-truth poses in $poses" >&2
    exit 2
fi
mkdir -p "$out/seq" "$out/est"
rows="$out/rows.tsv"
: >"$rows"
for sc in $scenarios; do
    for t in $trajs; do
        for seed in $seeds; do
            seq="$out/seq/${sc}_${t}_s$seed"
            if [[ ! -f "$seq/bound.csv" ]]; then
                rm -rf "$seq"
                "$momo" simulate --scenario "$sc" --trajectory "$poses/$t.txt" \
                    --frames "$frames" --seed "$seed" "$seq" >/dev/null
            fi
            for spec in "$@"; do
                name="${spec%%=*}"
                cfg="${spec#*=}"
                how=()
                if [[ "$cfg" != default ]]; then how=(--config "$cfg"); fi
                est="$out/est/${sc}_${t}_s${seed}__$name.txt"
                if ! "$momo" run "$seq" "${how[@]}" -o "$est" -q; then
                    printf '%s\t%s\t%s\t%s\tfailed\n' "$sc" "$t" "$seed" "$name" >>"$rows"
                    continue
                fi
                "$momo" eval --gt "$seq/poses.txt" --est "$est" | tail -n 2 |
                    awk -v sc="$sc" -v t="$t" -v s="$seed" -v n="$name" '
                        NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
                        { printf "%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n", sc, t, s, n,
                              $c["median"], $c["bound"], $c["eff"], $c["t_err"], $c[">1deg"] }' \
                        >>"$rows"
            done
        done
    done
done
cat "$rows"
