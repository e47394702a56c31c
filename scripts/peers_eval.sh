#!/usr/bin/env bash
# Compares momo with peer relative-pose estimators from PyPI (OpenCV, PoseLib) on the same
# sequences, and writes a Markdown section for docs/RESULTS.md.
#
# Usage: scripts/peers_eval.sh [DATA_DIR] [OUT_DIR] [SECTION.md]
#   DATA_DIR    the shared data folder holding kitti00_stereo_matches_l1avgvo/ (or that folder
#               itself); default ../shared/data (relative to the workspace root). Without it the
#               KITTI sequences are skipped with a message.
#   OUT_DIR     where the venv, sequences, estimates and rows go; default target/peers
#   SECTION.md  the Markdown section written; default OUT_DIR/peers.md
#   MOMO        environment variable: the momo binary (default target/release/momo, built with
#               `cargo build --release` only if it is missing)
#   PYTHON      environment variable: the Python used to create the venv (default python3.11,
#               else python3)
#   FRAMES      environment variable: frames per simulated sequence (default 300)
#   THRESHOLDS  environment variable: the peers' inlier thresholds in pixels, one run each
#               (default "1", both libraries' documented default; e.g. "1 2" adds rows
#               labelled @2px)
#
# Sequences: `momo simulate --scenario S --frames $FRAMES --seed 1` for every scenario that
# `momo simulate --help` lists, and `momo import-kitti` of the real KITTI 00 matches with 100,
# 200 and 300 matches per frame (mono, seed 1) and a stereo pair with 200 per camera.
# Methods: momo's default configuration, the in-tool five-point baseline
# (`momo run --estimator five-point`, and `five-point-refined` where `momo run --help` offers
# it), and the peers of scripts/peers/peers.py: opencv-ransac, opencv-magsac and poselib on
# camera 0 (on multi-camera rigs too: camera 0 only), poselib-generalized on rigs with more
# than one camera (all cameras with their extrinsics). Every estimate is scored by `momo eval`.
# The peers are installed into OUT_DIR/venv from scripts/peers/requirements.txt; if pip cannot
# install them, the peers are skipped with a message and the momo rows are still written.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
abs() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$PWD/$1" ;; esac; }
data="$(abs "${1:-$root/../shared/data}")"
out="$(abs "${2:-$root/target/peers}")"
section="$(abs "${3:-$out/peers.md}")"
frames="${FRAMES:-300}"
thresholds="${THRESHOLDS:-1}"
momo="${MOMO:-$root/target/release/momo}"
if [[ ! -x "$momo" ]]; then
    (cd "$root" && cargo build --release)
fi
mkdir -p "$out/seq" "$out/est" "$(dirname "$section")"

# --- peers: a venv with the pinned wheels ---------------------------------------------------
peers=1
py="${PYTHON:-}"
if [[ -z "$py" ]]; then
    py="$(command -v python3.11 || command -v python3 || true)"
fi
venv="$out/venv"
if [[ -z "$py" ]]; then
    echo "peers_eval: no python3 found: skipping the peers" >&2
    peers=0
elif [[ ! -x "$venv/bin/python" ]] && ! "$py" -m venv "$venv" >"$out/venv.log" 2>&1; then
    echo "peers_eval: cannot create a venv with $py (see $out/venv.log): skipping the peers" >&2
    peers=0
fi
if ((peers)); then
    if ! "$venv/bin/python" -m pip install --disable-pip-version-check -q \
        -r "$root/scripts/peers/requirements.txt" >>"$out/venv.log" 2>&1; then
        echo "peers_eval: pip could not install scripts/peers/requirements.txt" \
            "(see $out/venv.log): skipping the peers" >&2
        peers=0
    elif ! "$venv/bin/python" -c 'import cv2, poselib' >>"$out/venv.log" 2>&1; then
        echo "peers_eval: cv2 / poselib do not import (see $out/venv.log): skipping the peers" >&2
        peers=0
    fi
fi
versions="momo $("$momo" --version | awk '{print $2}')"
if ((peers)); then
    versions="$versions, $("$venv/bin/python" - <<'PY'
import sys, cv2, numpy
from importlib.metadata import version
print("Python %s, opencv-python-headless %s, poselib %s, numpy %s" % (
    sys.version.split()[0], version("opencv-python-headless"), version("poselib"),
    numpy.__version__))
PY
)"
fi

# --- sequences --------------------------------------------------------------------------------
seqs=()
scenarios="$("$momo" simulate --help | grep -o 'Scenario: .*' |
    sed -e 's/\[default.*//' -e 's/([^)]*)//g' -e 's/^Scenario: //' | tr ',' '\n' |
    awk 'NF { print $1 }')"
for s in $scenarios; do
    rm -rf "$out/seq/$s"
    "$momo" simulate --scenario "$s" --frames "$frames" --seed 1 "$out/seq/$s" >/dev/null
    seqs+=("$s")
done
kitti=""
if [[ -f "$data/kitti00_stereo_matches_l1avgvo/calib.txt" ]]; then
    kitti="$data/kitti00_stereo_matches_l1avgvo"
elif [[ -f "$data/calib.txt" ]]; then
    kitti="$data"
else
    echo "peers_eval: no kitti00_stereo_matches_l1avgvo data in $data: skipping KITTI 00" >&2
fi
if [[ -n "$kitti" ]]; then
    for n in 100 200 300; do
        rm -rf "$out/seq/kitti00_mono$n"
        "$momo" import-kitti "$kitti" "$out/seq/kitti00_mono$n" --matches "$n" --seed 1 >/dev/null
        seqs+=("kitti00_mono$n")
    done
    rm -rf "$out/seq/kitti00_stereo200"
    "$momo" import-kitti "$kitti" "$out/seq/kitti00_stereo200" --stereo --matches 200 \
        --seed 1 >/dev/null
    seqs+=("kitti00_stereo200")
fi

# --- runs ---------------------------------------------------------------------------------------
momo_methods=(default five-point)
if "$momo" run --help | grep -q 'five-point-refined'; then
    momo_methods+=(five-point-refined)
fi
rows="$out/rows.tsv"
: >"$rows"
: >"$out/magsac.tsv"
# num_cameras SEQ
num_cameras() { grep -c '"T_vehicle_camera"' "$out/seq/$1/rig.json"; }
# score SEQ METHOD EST MS DEGENERATE: appends "seq method median p95 max >1deg t_err r_err ms deg".
score() {
    local scores
    scores="$("$momo" eval --gt "$out/seq/$1/poses.txt" --est "$3" | tail -n 1)"
    awk -v seq="$1" -v m="$2" -v ms="$4" -v dg="$5" \
        '{ printf "%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n", seq, m, $3, $4, $5, $6, $1, $2, ms, dg }' \
        <<<"$scores" >>"$rows"
}
failed() { printf '%s\t%s\tfailed\n' "$1" "$2" >>"$rows"; }
# whole_process SEQ EST DIAG: the default `momo run` three more times (reading matches.csv, writing
# poses and diagnostics included), timed by Python (wall clock; CPU = the child's user + system
# time from getrusage, microsecond resolution); appends "seq pairs wall_ms cpu_ms" per frame pair,
# the median of the three, to speed.tsv.
speed="$out/speed.tsv"
: >"$speed"
whole_process() {
    python3 - "$1" "$(($(wc -l <"$2") - 1))" "$momo" run "$out/seq/$1" -o "$2" -d "$3" -q \
        >>"$speed" <<'PY'
import resource, statistics, subprocess, sys, time
seq, pairs, cmd = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
wall, cpu = [], []
for _ in range(3):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(cmd, check=True)
    wall.append(time.perf_counter() - start)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
print("%s\t%d\t%.4f\t%.4f" % (seq, pairs, 1e3 * statistics.median(wall) / pairs,
                              1e3 * statistics.median(cpu) / pairs))
PY
}
# run_momo SEQ METHOD
run_momo() {
    local seq="$1" m="$2" est="$out/est/$1__$2.txt" diag="$out/est/$1__$2.csv"
    local how=()
    if [[ "$m" != default ]]; then how=(--estimator "$m"); fi
    if ! "$momo" run "$out/seq/$seq" -o "$est" -d "$diag" "${how[@]}" -q; then
        failed "$seq" "momo $m"
        return
    fi
    if [[ "$m" == default ]]; then
        whole_process "$seq" "$est" "$diag"
    fi
    local ms dg
    ms="$(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) { if ($i == "time_us") c = i; if ($i == "status") s = i }; next }
                   { t += $c; n++ } END { if (n) printf "%.3f", t / n / 1000 }' "$diag")"
    dg="$(awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "status") s = i; next }
                   $s == "no_matches" || $s == "solver_failure" { d++ } END { print d + 0 }' "$diag")"
    local label="momo $m"
    if [[ "$m" == default ]]; then label="momo (default)"; fi
    score "$seq" "$label" "$est" "$ms" "$dg"
}
# run_peer SEQ METHOD THRESHOLD_PX
run_peer() {
    local seq="$1" m="$2" t="$3" est="$out/est/$1__$2__$3px.txt" stats="$out/est/$1__$2__$3px.json"
    if ! "$venv/bin/python" "$root/scripts/peers/peers.py" "$out/seq/$seq" --method "$m" \
        --threshold-px "$t" -o "$est" --stats "$stats"; then
        failed "$seq" "$m"
        return
    fi
    local ms dg
    ms="$("$venv/bin/python" -c 'import json, sys; print("%.3f" % json.load(open(sys.argv[1]))["ms_per_frame"])' "$stats")"
    if [[ "$m" == opencv-magsac && "$t" == "${thresholds%% *}" ]]; then
        "$venv/bin/python" -c 'import json, sys; s = json.load(open(sys.argv[1])); print("%s\t%.4f\t%.4f" % (sys.argv[2], s["ms_per_frame"], s["cpu_ms_per_frame"]))' \
            "$stats" "$seq" >>"$out/magsac.tsv"
    fi
    dg="$("$venv/bin/python" -c 'import json, sys; print(json.load(open(sys.argv[1]))["degenerate"])' "$stats")"
    local label="$m"
    if (("$(num_cameras "$seq")" > 1)) && [[ "$m" != poselib-generalized ]]; then
        label="$m (camera 0)"
    fi
    if [[ "$thresholds" != 1 ]]; then label="$label @${t}px"; fi
    score "$seq" "$label" "$est" "$ms" "$dg"
}
for seq in "${seqs[@]}"; do
    echo "peers_eval: $seq" >&2
    for m in "${momo_methods[@]}"; do
        run_momo "$seq" "$m"
    done
    if ((peers)); then
        for t in $thresholds; do
            for m in opencv-ransac opencv-magsac poselib; do
                run_peer "$seq" "$m" "$t"
            done
            if (("$(num_cameras "$seq")" > 1)); then
                run_peer "$seq" poselib-generalized "$t"
            fi
        done
    fi
done

# --- section ------------------------------------------------------------------------------------
{
    echo "## Peers: OpenCV and PoseLib on the same sequences"
    echo
    echo "Generated by \`scripts/peers_eval.sh\` on $(date -u +%Y-%m-%d) ($versions)."
    echo "Simulated sequences: \`momo simulate --scenario S --frames $frames --seed 1\`; KITTI 00:"
    echo "the real l1avgvo matches of frames 0-300 (\`momo import-kitti\`, \`--matches N --seed 1\`,"
    echo "stereo: \`--stereo --matches 200\`). Arc lengths from odometry.csv for every method."
    echo "Rotation errors are frame to frame, in degrees (median, 95th percentile, max, frames"
    echo "above 1 deg); t_err (%) and r_err (deg/100 m) are the KITTI devkit's (\`momo eval\`; \"-\":"
    echo "path shorter than 100 m); ms is the mean estimation time per frame pair (momo: the"
    echo "diagnostics' time_us; peers: measured in Python around the library call only, single"
    echo "thread); held = degenerate frames where the previous motion was held."
    echo
    echo "- \`momo (default)\`: \`momo run\` with the default configuration; \`momo five-point\`:"
    echo "  the in-tool 5-point RANSAC baseline; \`momo five-point-refined\`: the same with its"
    echo "  LO-RANSAC-style refinement (where \`momo run\` offers it)."
    echo "- Peer thresholds: $thresholds px (rows marked @T px when several were run)."
    echo "- \`opencv-ransac\`: \`cv2.findEssentialMat(RANSAC, prob 0.999, threshold)\` +"
    echo "  \`cv2.recoverPose\`; \`opencv-magsac\`: the same with \`USAC_MAGSAC\`;"
    echo "  \`poselib\`: \`poselib.estimate_relative_pose\` (LO-RANSAC 5-point + refinement,"
    echo "  library defaults but \`max_epipolar_error\`). These use camera 0 only: on the stereo"
    echo "  pair and on the fisheye surround rig they see one camera (marked \"camera 0\")."
    echo "- \`poselib-generalized\`: \`poselib.estimate_generalized_relative_pose\` with all cameras"
    echo "  and the rig extrinsics (multi-camera rigs only), translation rescaled to the odometry"
    echo "  chord."
    echo "- Every peer gets our own unprojection (pinhole and Kannala-Brandt, as momo-core) as"
    echo "  the pixels of an ideal pinhole camera with the camera's focal length; thresholds are"
    echo "  in those pixels. The libraries take 2D normalised points, so fisheye bearings more than"
    echo "  80 deg off the optical axis are dropped for them (on fisheye_surround: see the stats"
    echo "  JSON next to each estimate). Scale as momo's five-point baseline: the vehicle moves the"
    echo "  odometry arc length. Settings and their reasons: \`scripts/peers/peers.py\`."
    echo
    echo "| sequence | method | median | p95 | max | >1 deg | t_err % | r_err deg/100m | ms/frame | held |"
    echo "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
    awk -F'\t' '{ if ($3 == "failed") printf "| %s | %s | failed | | | | | | | |\n", $1, $2;
                  else printf "| %s | %s | %.4f | %.4f | %.4f | %s | %s | %s | %s | %s |\n", $1, $2, $3, $4, $5, $6, $7, $8, $9, $10 }' "$rows"
    if ((peers)) && compgen -G "$out/est/*px.json" >/dev/null; then
        echo
        echo "Bearings dropped for the peers (more than 80 deg off the optical axis), per sequence"
        echo "and method, of all the matches they were given:"
        echo
        "$venv/bin/python" - "$out"/est/*px.json <<'PY'
import json, sys
seen = set()
for path in sys.argv[1:]:
    s = json.load(open(path))
    key = (s["sequence"].rstrip("/").split("/")[-1], s["method"])
    if s["bearings_dropped_beyond_max_angle"] and key not in seen:
        seen.add(key)
        print("- %s, %s: %d of %d (%.0f %%)" % (key[0], key[1], s["bearings_dropped_beyond_max_angle"],
              s["matches"], 100.0 * s["bearings_dropped_beyond_max_angle"] / s["matches"]))
PY
    fi
    if ((peers)) && [[ -s "$out/magsac.tsv" ]]; then
        echo
        echo "### Whole process: \`momo run\` against OpenCV MAGSAC's library calls"
        echo
        echo "Per frame pair, same sequences, same run: \`momo run\` with the default configuration as"
        echo "a whole process (start-up, reading rig.json, matches.csv and odometry.csv, estimating,"
        echo "writing the poses and the diagnostics; median of three runs) against the"
        echo "time spent inside \`cv2.findEssentialMat(USAC_MAGSAC)\` + \`cv2.recoverPose\` alone (one"
        echo "thread, the input already converted). CPU = user + system time (momo) and the calling"
        echo "thread's CPU time (OpenCV, \`time.thread_time\`): less sensitive than the wall clock to the"
        echo "other processes of a shared machine. Ratio = MAGSAC / momo (issue 19's target: >= 20)."
        echo
        echo "| sequence | frame pairs | momo ms (wall) | momo ms (CPU) | MAGSAC ms (wall) | MAGSAC ms (CPU) | ratio (wall) | ratio (CPU) |"
        echo "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
        awk -F'\t' 'NR == FNR { mw[$1] = $2; mc[$1] = $3; next }
            ($1 in mw) { printf "| %s | %d | %.3f | %.3f | %.3f | %.3f | %.1f | %.1f |\n",
                         $1, $2, $3, $4, mw[$1], mc[$1], mw[$1] / $3, mc[$1] / $4 }' \
            "$out/magsac.tsv" "$speed"
    fi
    if ((!peers)); then
        echo
        echo "The peers were skipped: pip could not install scripts/peers/requirements.txt."
    fi
} >"$section"
echo "peers_eval: wrote $section" >&2
