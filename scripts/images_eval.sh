#!/usr/bin/env bash
# Visual odometry from real KITTI images: the feature front end (`momo match`) feeding momo and
# the 5-point baseline, and `momo vo` end to end.
#
# Usage: scripts/images_eval.sh [DATA_DIR] [OUT_DIR] [SECTION.md]
#   DATA_DIR    the data folder holding kitti_stereo_snippets/; default $MOMO_DATA or
#               ../shared/data beside the repository
#   OUT_DIR     rigs, sequences, estimates, logs; default target/images_eval
#   SECTION.md  the Markdown section written; default OUT_DIR/images.md
#
# For KITTI 06 and 01 (frames 0-50) and for the left camera alone (mono) and left + right as a
# two-camera rig (stereo): the rig and odometry.csv (arc lengths from the ground truth) are made
# by the `kitti_setup` example of momo-match; `momo match` writes the sequence; `momo run` runs
# momo (default configuration) and `--estimator five-point` on the same matches; `momo vo`
# matches and estimates in one pass; `momo eval --gt poses.txt` scores every estimate
# (frame-to-frame rotation error). Matching times are those `momo match` reports (detection,
# description and matching of all cameras per frame, decoding excluded) on this machine.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
abs() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$PWD/$1" ;; esac; }
data="$(abs "${1:-${MOMO_DATA:-$root/../shared/data}}")"
out="$(abs "${2:-$root/target/images_eval}")"
section="$(abs "${3:-$out/images.md}")"
snippets="$data/kitti_stereo_snippets"
if [[ ! -d "$snippets" ]]; then
    echo "images_eval: $snippets not found (set DATA_DIR or MOMO_DATA)" >&2
    exit 2
fi

(cd "$root" && nice cargo build --release && nice cargo build --release -p momo-match --example kitti_setup)
momo="$root/target/release/momo"
setup="$root/target/release/examples/kitti_setup"
mkdir -p "$out/seq" "$out/est" "$out/log"

# "median p95 max above_one" of an estimate from `momo eval`'s table.
scores() { # GT EST
    "$momo" eval --gt "$1" --est "$2" | awk 'NR == 3 { printf "%.3f %.3f %.3f %d", $3, $4, $5, $6 }'
}

rows=()
for s in 06 01; do
    dir="$snippets/kitti${s}_frames000000-000050"
    "$setup" "$dir" "$out/kitti$s"
    gt="$dir/poses.txt"
    for rig in mono stereo; do
        if [[ $rig == mono ]]; then folders=("$dir/image_0"); else folders=("$dir/image_0" "$dir/image_1"); fi
        name="${s}_$rig"
        seq="$out/seq/$name"
        "$momo" match "${folders[@]}" --rig "$out/kitti$s/rig_$rig.json" \
            --odometry "$out/kitti$s/odometry.csv" -o "$seq" 2> "$out/log/match_$name.txt"
        ms=$(sed -n 's/.*[ (]\([0-9.]*\) ms\/frame matching.*/\1/p' "$out/log/match_$name.txt")
        "$momo" run "$seq" -o "$out/est/${name}_momo.txt" -q
        "$momo" run "$seq" -o "$out/est/${name}_five_point.txt" --estimator five-point -q
        "$momo" vo "${folders[@]}" --rig "$out/kitti$s/rig_$rig.json" \
            --odometry "$out/kitti$s/odometry.csv" -o "$out/est/${name}_vo.txt" 2> "$out/log/vo_$name.txt"
        vo_ms=$(sed -n 's/.*[ (]\([0-9.]*\) ms\/frame matching.*/\1/p' "$out/log/vo_$name.txt")
        # Without odometry.csv: the scale comes from the stereo cross-camera matches
        # (momo-match's stereo module) or from the road, read through the mount calibrated on the
        # first frame pairs (mono, `odometry.road_scale_mount`).
        "$momo" vo "${folders[@]}" --rig "$out/kitti$s/rig_$rig.json" \
            -o "$out/est/${name}_vo_noodo.txt" 2> "$out/log/vo_noodo_$name.txt"
        noodo_ms=$(sed -n 's/.*[ (]\([0-9.]*\) ms\/frame matching.*/\1/p' "$out/log/vo_noodo_$name.txt")
        scale=$(sed -n 's/.*scale: \(.*\)$/\1/p' "$out/log/vo_noodo_$name.txt")
        for est in momo five_point vo vo_noodo; do
            read -r med p95 max gross <<< "$(scores "$gt" "$out/est/${name}_$est.txt")"
            read -r terr ratio _ <<< "$(python3 "$root/scripts/snippet_terr.py" "$gt" "$out/est/${name}_$est.txt")"
            case $est in
                momo) label="momo (\`momo match\` + \`momo run\`)"; t="$ms" ;;
                five_point) label="5-point RANSAC (same matches)"; t="$ms" ;;
                vo) label="\`momo vo\` (one pass)"; t="$vo_ms" ;;
                vo_noodo) label="\`momo vo\`, no odometry.csv (scale: $scale)"; t="$noodo_ms" ;;
            esac
            rows+=("| $s | $rig | $label | $med | $p95 | $max | $gross | $terr | $ratio | $t |")
        done
    done
done

cores=$(nproc)
{
    echo "## From images: KITTI 06 and 01 (frames 0-50) through the feature front end"
    echo
    echo "Real KITTI gray images (\`kitti_stereo_snippets\`), matched by \`momo match\` (StereoScan-style"
    echo "blob and corner features, circular matching, bucketing to 200 matches per camera and frame"
    echo "pair, default options), arc lengths from the ground truth. Frame-to-frame rotation error of"
    echo "camera 0 in degrees against \`poses.txt\` (\`momo eval\`), over 50 frame pairs; \"> 1°\" counts"
    echo "gross errors. \"ms/frame\" is detection + description + matching of all cameras per frame"
    echo "(decoding excluded), as \`momo match\` / \`momo vo\` report it, on this $cores-core machine while"
    echo "other jobs may have been running. Made by \`scripts/images_eval.sh\`."
    echo
    echo "t_err is the KITTI devkit's translational error of one segment, the whole snippet (frame 0"
    echo "to 50, \`scripts/snippet_terr.py\`; the devkit's 100-800 m segments are longer than the"
    echo "snippets), in %; \"path\" the estimated over the ground-truth path length. Without"
    echo "odometry.csv a mono rig's scale is unobservable (t_err meaningless); a stereo rig's comes from"
    echo "the cross-camera matches of \`momo-match\`'s stereo module (left(k-1)-right(k), right(k-1)-left(k))."
    echo
    echo "| seq | rig | estimator | median | p95 | max | > 1° | t_err % | path | ms/frame matching |"
    echo "| --- | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    printf '%s\n' "${rows[@]}"
} > "$section.tmp"
mv "$section.tmp" "$section"
echo "images_eval: wrote $section" >&2
