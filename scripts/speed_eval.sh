#!/usr/bin/env bash
# Speed of docs/RESULTS.md: the criterion targets and floor of benches/matrix.rs, and the
# whole-process time per frame of `momo run` (momo and the 5-point baselines) over a long
# sequence.
#
# Usage: scripts/speed_eval.sh [OUT_DIR] [SECTION.md]
#   OUT_DIR     sequences, estimates, logs; default target/speed_eval
#   SECTION.md  the Markdown section written; default OUT_DIR/speed.md
#   FRAMES      environment variable: frames of the long sequence (default 4541, KITTI 00's length)
#   BENCH       environment variable: 0 skips criterion (then only whole-process timings)
#
# The long sequence is `momo simulate --scenario clean_pinhole` along the KITTI 00 ground-truth
# trajectory if ../shared/data is there (a generated drive otherwise), with 300 matches per
# frame pair. Whole-process times are wall clock (`/usr/bin/time`-style, from `date +%s.%N`),
# reading matches.csv and writing the poses included, divided by the number of frame pairs.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
abs() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$PWD/$1" ;; esac; }
out="$(abs "${1:-$root/target/speed_eval}")"
section="$(abs "${2:-$out/speed.md}")"
frames="${FRAMES:-4541}"
bench="${BENCH:-1}"
gt="$root/../shared/data/kitti_odometry_gt/poses/00.txt"

(cd "$root" && cargo build --release)
momo="$root/target/release/momo"
mkdir -p "$out"

# --- criterion: the issue's targets and the floor ----------------------------------------------
median_us() { # criterion directory -> median in microseconds
    python3 -c "import json,sys; print('%.1f' % (json.load(open(sys.argv[1]))['median']['point_estimate'] / 1000))" \
        "$1/new/estimates.json"
}
if [[ "$bench" != 0 ]]; then
    (cd "$root" && cargo bench --bench matrix -- 'targets|floor' >"$out/bench.log" 2>&1)
fi
crit="$root/target/criterion"
row() { # NAME DIR
    if [[ -f "$crit/$2/new/estimates.json" ]]; then
        printf '| %s | %s |\n' "$1" "$(median_us "$crit/$2")"
    else
        printf '| %s | not measured |\n' "$1"
    fi
}

# --- whole process over a long sequence --------------------------------------------------------
seq="$out/long"
if [[ ! -f "$seq/matches.csv" ]]; then
    traj=()
    if [[ -f "$gt" ]]; then traj=(--trajectory "$gt"); fi
    "$momo" simulate --scenario clean_pinhole --frames "$frames" --seed 1 --matches 300 \
        "${traj[@]}" "$seq" >/dev/null
fi
pairs=$(($(wc -l <"$seq/poses.txt") - 1))
timed() { # NAME ARGS...: wall seconds of `momo run` with ARGS
    local name="$1"
    shift
    local t0 t1
    t0=$(date +%s.%N)
    "$momo" run "$seq" -o "$out/$name.txt" -q "$@"
    t1=$(date +%s.%N)
    python3 -c "print('%.3f' % ($t1 - $t0))"
}
t_momo=$(timed momo)
t_five=$(timed five_point --estimator five-point)
t_refined=$(timed five_point_refined --estimator five-point-refined)
per() { python3 -c "print('%.1f' % (1e6 * $1 / $pairs))"; }
score() { "$momo" eval --gt "$seq/poses.txt" --est "$out/$1.txt" | tail -n 1 | awk '{ print $3, $4 }'; }
read -r m_med m_p95 <<<"$(score momo)"
read -r f_med f_p95 <<<"$(score five_point)"
read -r r_med r_p95 <<<"$(score five_point_refined)"
ratio() { python3 -c "print('%.1f' % ($1 / $t_momo))"; }

# --- the solver's function tolerance: iterations and accuracy ----------------------------------
kitti="$root/../shared/data/kitti00_stereo_matches_l1avgvo"
tol_seqs=()
if [[ -f "$kitti/calib.txt" ]]; then
    [[ -f "$out/tol/kitti00_200/matches.csv" ]] ||
        "$momo" import-kitti "$kitti" "$out/tol/kitti00_200" --matches 200 --seed 1 2>/dev/null
    tol_seqs+=(kitti00_200)
fi
for sc in clean_pinhole outliers sparse_outliers very_sparse moving_object fisheye_surround highway; do
    [[ -f "$out/tol/$sc/matches.csv" ]] ||
        "$momo" simulate --scenario "$sc" --frames 300 --seed 1 "$out/tol/$sc" >/dev/null
    tol_seqs+=("$sc")
done
tol_rows=()
for t in 0.000001 0.00001 0.0001; do
    "$momo" config | sed "s/^function_tolerance = .*/function_tolerance = $t/" >"$out/tol/c$t.toml"
done
for sq in "${tol_seqs[@]}"; do
    cells=()
    for t in 0.000001 0.00001 0.0001; do
        "$momo" run "$out/tol/$sq" -c "$out/tol/c$t.toml" -o "$out/tol/$sq.$t.txt" -d "$out/tol/$sq.$t.csv" -q
        it=$(python3 -c "
import csv, sys
v = [float(r['iterations']) for r in csv.DictReader(open(sys.argv[1])) if r['iterations'] not in ('', 'nan')]
print('%.2f' % (sum(v) / max(len(v), 1)))" "$out/tol/$sq.$t.csv")
        read -r med p95 <<<"$("$momo" eval --gt "$out/tol/$sq/poses.txt" --est "$out/tol/$sq.$t.txt" | tail -n 1 | awk '{ print $3, $4 }')"
        cells+=("$it | $med / $p95")
    done
    tol_rows+=("| $sq | ${cells[0]} | ${cells[1]} | ${cells[2]} |")
done

cpu="$(awk -F': ' '/^model name/ { print $2; exit }' /proc/cpuinfo 2>/dev/null || true)"
{
    echo "## Speed"
    echo
    echo "Made by \`scripts/speed_eval.sh\` on $(date -u +%Y-%m-%d), $(nproc) cores${cpu:+ ($cpu)},"
    echo "shared with other jobs while it ran: read the figures as upper bounds."
    echo
    echo "### One frame pair (criterion, \`benches/matrix.rs\`, median)"
    echo
    echo "\`targets/*/solve\` is the estimator alone (warm start from a previous motion 0.4° off),"
    echo "\`targets/*/odometry\` the whole driver for one frame (\`Odometry::process\`: solve, inlier"
    echo "count, covariance, diagnostics; warm-started by a previous frame). \`floor/*/cost\` is one"
    echo "evaluation of every residual and the loss, \`floor/*/linearize\` one robustified"
    echo "linearisation (residuals, Jacobians by num-dual, normal equations): a solve costs one"
    echo "linearisation per iteration plus one at the start, so the floor of a solve is about one"
    echo "linearisation."
    echo
    echo "| benchmark | µs |"
    echo "| --- | ---: |"
    row "default, 1 pinhole camera x 300 matches: odometry (target < 100)" targets/default_pinhole_300_odometry
    row "default, 1 pinhole camera x 300 matches: solve" targets/default_pinhole_300_solve
    row "default, 1 pinhole camera x 300 matches: one cost evaluation" floor/default_pinhole_300_cost
    row "default, 1 pinhole camera x 300 matches: one linearisation" floor/default_pinhole_300_linearize
    row "single_track_3d, 4 fisheye cameras x 100 matches: odometry (target < 300)" targets/single_track_3d_fisheye4x100_odometry
    row "single_track_3d, 4 fisheye cameras x 100 matches: solve" targets/single_track_3d_fisheye4x100_solve
    row "single_track_3d, 4 fisheye cameras x 100 matches: one cost evaluation" floor/single_track_3d_fisheye4x100_cost
    row "single_track_3d, 4 fisheye cameras x 100 matches: one linearisation" floor/single_track_3d_fisheye4x100_linearize
    echo
    echo "### Whole process, $pairs frame pairs"
    echo
    echo "\`momo run\` on a simulated clean pinhole sequence of $pairs frame pairs (300 matches per"
    echo "pair$([[ -f "$gt" ]] && echo ", along the KITTI 00 ground-truth trajectory")), wall clock including reading"
    echo "matches.csv ($(du -h "$seq/matches.csv" | cut -f1)) and writing the poses."
    echo
    echo "| estimator | total s | µs per frame pair | x momo | rotation error median / p95 (°) |"
    echo "| --- | ---: | ---: | ---: | --- |"
    echo "| momo (default) | $t_momo | $(per "$t_momo") | 1.0 | $m_med / $m_p95 |"
    echo "| 5-point RANSAC | $t_five | $(per "$t_five") | $(ratio "$t_five") | $f_med / $f_p95 |"
    echo "| 5-point RANSAC, refined | $t_refined | $(per "$t_refined") | $(ratio "$t_refined") | $r_med / $r_p95 |"
    echo
    echo "### The solvers' function tolerance"
    echo
    echo "Levenberg-Marquardt's default \`function_tolerance\` went from 1e-6 to 1e-5 (stop when the Gauss-Newton model"
    echo "predicts at most that fraction of the cost can still be gained). Mean iterations per frame"
    echo "pair and frame-to-frame rotation error (median / p95, °) of the default configuration with"
    echo "each; KITTI 00 real matches (200 per frame pair, frames 0-300) and every simulated scenario"
    echo "(300 frames, seed 1)."
    echo
    echo "| sequence | iterations, 1e-6 | rotation error, 1e-6 | iterations, 1e-5 | rotation error, 1e-5 | iterations, 1e-4 | rotation error, 1e-4 |"
    echo "| --- | ---: | --- | ---: | --- | ---: | --- |"
    printf '%s\n' "${tol_rows[@]}"
} >"$section.tmp"
mv "$section.tmp" "$section"
echo "speed_eval: wrote $section" >&2
