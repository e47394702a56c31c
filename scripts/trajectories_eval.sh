#!/usr/bin/env bash
# Simulated matches along the real KITTI 00-10 ground-truth trajectories: every stop, slow
# turn and speed of the real drives (4,541 frames for 00, 23,201 over all eleven), with the
# simulator's matches. Checks for what short simulated drives miss (a bug after KITTI 00's
# stop at frame 545 showed only here).
#
# Usage: scripts/trajectories_eval.sh [DATA_DIR] [OUT_DIR] [SECTION.md]
#   DATA_DIR    the shared data folder holding kitti_odometry_gt/poses/; default
#               ../shared/data beside the repository. If absent, the script says so, writes a
#               section that says so, and exits 0.
#   OUT_DIR     sequences and estimates; default target/trajectories_eval
#   SECTION.md  the Markdown section written; default OUT_DIR/trajectories.md
#   SEQS        environment variable: which sequences (default "00 01 02 03 04 05 06 07 08 09 10")
#
# Per sequence: `momo simulate --scenario outliers` (300 matches, 30 % outliers, 1 px) and
# `--scenario clean_pinhole` (300 matches, 0.5 px) along the trajectory (seed 1); `momo run`
# with the default configuration on both, and the 5-point RANSAC with LO refinement
# (`--estimator five-point-refined`) on the clean one (on the outlier one it takes about
# 0.1 s per frame pair: 40 minutes for all eleven). Scored by `momo eval`.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
abs() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$PWD/$1" ;; esac; }
data="$(abs "${1:-$root/../shared/data}")"
out="$(abs "${2:-$root/target/trajectories_eval}")"
section="$(abs "${3:-$out/trajectories.md}")"
seqs="${SEQS:-00 01 02 03 04 05 06 07 08 09 10}"
gt_dir="$data/kitti_odometry_gt/poses"
mkdir -p "$out" "$(dirname "$section")"
if [[ ! -f "$gt_dir/00.txt" ]]; then
    echo "trajectories_eval: no kitti_odometry_gt/poses in $data; skipping" >&2
    {
        echo "## Simulated matches along the KITTI 00-10 trajectories"
        echo
        echo "_Not measured: \`kitti_odometry_gt/poses\` was not found in $data._"
    } >"$section"
    exit 0
fi

(cd "$root" && cargo build --release --quiet)
momo="$root/target/release/momo"
score() { # GT EST -> "t_err r_err median p95 max >1deg"
    "$momo" eval --gt "$1" --est "$2" | tail -n 1 | awk '{ print $1, $2, $3, $4, $5, $6 }'
}
rows=()
tot_frames=0
for s in $seqs; do
    for sc in outliers clean_pinhole; do
        seq="$out/seq/${sc}_$s"
        [[ -f "$seq/matches.csv" ]] ||
            "$momo" simulate --scenario "$sc" --frames 1000000 --seed 1 \
                --trajectory "$gt_dir/$s.txt" "$seq" >/dev/null
    done
    n=$(($(wc -l <"$out/seq/outliers_$s/poses.txt") - 1))
    tot_frames=$((tot_frames + n))
    cells=("$s" "$n")
    for run in "outliers momo" "clean_pinhole momo" "clean_pinhole five_point_refined"; do
        read -r sc est <<<"$run"
        how=()
        [[ "$est" == momo ]] || how=(--estimator five-point-refined)
        "$momo" run "$out/seq/${sc}_$s" -o "$out/$sc.$s.$est.txt" -q "${how[@]}"
        read -r t r med p95 max gross <<<"$(score "$out/seq/${sc}_$s/poses.txt" "$out/$sc.$s.$est.txt")"
        cells+=("$med / $p95 / $max / $gross")
        [[ "$sc.$est" == clean_pinhole.five_point_refined ]] || cells+=("$t / $r")
    done
    rows+=("| ${cells[0]} | ${cells[1]} | ${cells[2]} | ${cells[3]} | ${cells[4]} | ${cells[5]} | ${cells[6]} |")
    echo "trajectories_eval: $s done" >&2
done

{
    echo "## Simulated matches along the KITTI 00-10 trajectories"
    echo
    echo "Made by \`scripts/trajectories_eval.sh\` on $(date -u +%Y-%m-%d) with $("$momo" --version)."
    echo "The vehicle follows each real KITTI ground-truth trajectory (every stop, slow turn and"
    echo "speed of the drive; $tot_frames frame pairs in all); the matches are simulated"
    echo "(\`momo simulate --trajectory\`, seed 1): \`outliers\` has 300 per frame pair with 30 %"
    echo "outliers and 1 px noise, \`clean_pinhole\` 300 with 0.5 px. Arc lengths from the"
    echo "odometry. Cells: frame-to-frame rotation error median / p95 / max (deg) / frames above"
    echo "1 deg, and KITTI t_err (%) / r_err (deg/100 m). momo: the default configuration;"
    echo "5-point refined: \`--estimator five-point-refined\` (too slow on the outlier sequences"
    echo "to run here: about 0.1 s per frame pair)."
    echo
    echo "| seq | frame pairs | momo, outliers: rotation | momo, outliers: t_err / r_err | momo, clean: rotation | momo, clean: t_err / r_err | 5-point refined, clean: rotation |"
    echo "| --- | ---: | --- | --- | --- | --- | --- |"
    printf '%s\n' "${rows[@]}"
} >"$section.tmp"
mv "$section.tmp" "$section"
echo "trajectories_eval: wrote $section" >&2
