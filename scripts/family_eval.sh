#!/usr/bin/env bash
# Issue 14's yardsticks in one run: the moving-traffic family (frames above 1 deg, efficiency
# against the Cramér-Rao bound, the trust gap), the static scenarios along the KITTI
# trajectories and along the built-in drive (efficiency), and real KITTI 00 (median
# frame-to-frame rotation error, t_err) for one momo binary and configuration.
#
# Usage: scripts/family_eval.sh OUT_DIR [SET...]
#   SET  one of (default: grid holdout static builtin k00)
#        grid      moving_traffic, KITTI trajectories 00-10 and the built-in drive, seeds 1-10
#        holdout   the same, seeds 11-15
#        fresh     the same, seeds 16-20 (keep for confirmation: choose nothing on it)
#        dev       the same, seeds 21-30
#        dev2      the same, seeds 31-40 (a second development set, added in the 31st session)
#        dev3      the same, seeds 41-50 (a third development set, added in the 31st session)
#        conf      the same, seeds 51-60 (a confirmation set, run since the 51st session)
#        conf2     the same, seeds 61-70 (a second confirmation set, added in the 53rd session;
#                  keep for confirmation: choose nothing on it)
#        conf3     the same, seeds 81-90 (a third confirmation set, added in the 64th session;
#                  keep for confirmation: choose nothing on it)
#        conf4     the same, seeds 91-100 (a fourth confirmation set, added in the 79th session
#                  and first run on the 78th session's defaults; keep for confirmation: choose
#                  nothing on it)
#        conf5     the same, seeds 101-110 (a fifth confirmation set, added in the 82nd session
#                  and first run on the 81st session's defaults; keep for confirmation: choose
#                  nothing on it)
#        few200    moving_traffic with 200 matches per frame pair instead of the scenario's 300
#                  (`momo simulate --matches 200`: the same traffic as grid's seeds 1-5, the
#                  objects keep their 30-70 % share and the outliers their 5 %: static matches
#                  median 66 where objects are visible, 10th percentile 56, against grid's 100 /
#                  84), KITTI trajectories 00-10 and the built-in drive, seeds 1-5 (31st session)
#        few150    the same with 150 matches (static matches: median 49 where objects are
#                  visible, 10th percentile 42; 142 where none are)
#        few100    the same with 100 matches (static: median 33 where objects are visible, 95
#                  where none are)
#        few250    the same with 250 matches (added in the 41st session)
#        many400   the same with 400 matches: denser matching than the scenario's 300 (added in
#                  the 41st session)
#        few150h, few100h  few150 / few100 on seeds 6-10 (added in the 35th session; keep for
#                  confirmation: choose nothing on them)
#        slow      moving_traffic along 28 segments of KITTI 00-10 that hold a stop or a slow
#                  start (a run of 5+ frames below 0.3 m per frame; each segment from 15 frames
#                  before it, 100 frames; `momo simulate --trajectory-start`), seeds 71-76
#                  (added in the 44th session)
#        slow200   the same with 200 matches, seeds 71-73
#        static    clean_pinhole and outliers along KITTI 00-10, seeds 1-3
#        static2   the same, seeds 4-6
#        static3   the other scenarios without moving objects along KITTI 00-10, seeds 1-2
#        static4   the same, seeds 3-5 (with static3 five seeds per scenario, as issue 14
#                  asks; added in the fifty-seventh session)
#                  (highway very_sparse fisheye_surround sparse_outliers radtan_mono
#                  wide_angle_surround; FRAMES each, the four-camera ones too: a run takes a
#                  few seconds). Along a KITTI trajectory the vehicle follows the trajectory's
#                  speed, so `highway` there is its open scene (facades 10-80 m, 30 % far
#                  points, 10 % outliers) at KITTI's speeds (median 2.65 m per frame at 10 Hz on
#                  01, the motorway: the scenario's own 25-30 m/s; 0.7-1.4 m on the others),
#                  not its own generated drive
#        builtin   six scenarios without moving objects along the built-in drive, seeds 1-5,
#                  300 frames (clean_pinhole highway very_sparse fisheye_surround outliers
#                  sparse_outliers)
#        k00       real KITTI 00 (frames 0-300): mono 100 / 200 / 300 matches, stereo 200,
#                  ground-truth arc lengths as odometry
#        rigtraffic   moving_traffic_surround (the four-camera fisheye rig with traffic all
#                  around), KITTI trajectories 00-10 and the built-in drive, seeds 1-3
#        rigtraffic2  the same, seeds 4-6 (keep for confirmation: choose nothing on it)
#        rigdev    the same, seeds 7-12 (a second development set for the rig)
#        rigconf   the same, seeds 13-18 (a confirmation set for the rig, added in the 64th
#                  session: choose nothing on it)
#        rigblind  moving_traffic_surround_blind (the same with the front camera covered in frame
#                  pairs 150-249, glare on the right camera in 300-349), seeds 1-3
#   NO_ODOMETRY environment variable: 1 runs every simulated sequence without its odometry.csv
#               (unknown scale; the sequences are read through links in OUT_DIR/SET/seqs, all
#               files but odometry.csv). bound.csv is the bound with the arc length known, so
#               efficiencies are against a bound that such a run cannot reach (added in the 45th
#               session)
#   ALONG_TRAVEL environment variable: 1 simulates every sequence along a KITTI trajectory
#               with `momo simulate --trajectory-along-travel` (the vehicle travels along its
#               road, as a real one does; as they are, the KITTI camera's poses make the
#               simulated vehicle travel about 1 deg above its own road plane) and keeps them
#               under SETS_DIR/along_travel (added in the 54th session)
#   NOISE       environment variable: the pixel noise of every simulated sequence in pixels
#               (`momo simulate --pixel-noise`; default: each scenario's own, 1 px for the traffic
#               sets) kept under SETS_DIR/noiseNOISE; bound.csv is the bound at that noise (added
#               in the fifty-ninth session)
#   STATIC_TRACKS  environment variable: the share of each frame pair's static matches that
#               continue a static match of the previous pair, as a tracker gives them (`momo
#               simulate --static-tracks`; default 0: every static match a new point), kept
#               under SETS_DIR/tracksSTATIC_TRACKS (added in the eighty-third session)
#   MOMO        environment variable: the momo binary (default target/release/momo)
#   MOMO_CONFIG environment variable: a `momo run --config` file (default: the built-in one)
#   SIM_MOMO    environment variable: the momo binary that simulates missing sequences (default
#               MOMO; e.g. a newer binary that knows a scenario MOMO does not)
#   SETS_DIR    environment variable: where the simulated / imported sequences are kept and
#               reused (default target/family_sets); they are made by the same binary's
#               `momo simulate` / `momo import-kitti` the first time
#   FRAMES      environment variable: frames per family / static sequence (default 500)
#   JOBS        environment variable: parallel runs (default 2)
#   PYTHON      environment variable: a Python with numpy for the trust gap
#               (scripts/family_calibration.py); without numpy the gap column is "-"
#   MOMO_DATA   environment variable: the shared data folder (default ../shared/data)
#
# Writes OUT_DIR/SET/rows.tsv (name, median deg, frames above 1 deg, bound deg, eff, t_err %),
# the estimates and diagnostics (OUT_DIR/SET/est), OUT_DIR/SET/summary.txt, and prints one
# summary line per set. Exits 1 where a `momo run` failed (the summary names the sequences).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
abs() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$PWD/$1" ;; esac; }
out="$(abs "${1:?usage: scripts/family_eval.sh OUT_DIR [SET...]}")"
shift
sets=("$@")
((${#sets[@]})) || sets=(grid holdout static builtin k00)
momo="$(abs "${MOMO:-$root/target/release/momo}")"
sets_dir="$(abs "${SETS_DIR:-$root/target/family_sets}")"
along_travel="${ALONG_TRAVEL:-0}"
[[ "$along_travel" == 1 ]] && sets_dir="$sets_dir/along_travel"
noise="${NOISE:-}"
[[ -n "$noise" ]] && sets_dir="$sets_dir/noise$noise"
static_tracks="${STATIC_TRACKS:-}"
[[ -n "$static_tracks" ]] && sets_dir="$sets_dir/tracks$static_tracks"
data="$(abs "${MOMO_DATA:-$root/../shared/data}")"
frames="${FRAMES:-500}"
jobs="${JOBS:-2}"
py="${PYTHON:-python3}"
cfg=""
[[ -n "${MOMO_CONFIG:-}" ]] && cfg="$(abs "$MOMO_CONFIG")"
sim_momo="$(abs "${SIM_MOMO:-$momo}")"
for b in "$momo" "$sim_momo"; do
    if [[ ! -x "$b" ]]; then
        echo "family_eval: no momo binary at $b (cargo build --release)" >&2
        exit 2
    fi
done
export momo sim_momo cfg data frames along_travel noise static_tracks

# make_seq DIR SCENARIO TRAJECTORY SEED [FRAMES [MATCHES [START]]]: simulates one sequence unless
# it is there (MATCHES: `momo simulate --matches`, default the scenario's, `-` for it; START:
# `--trajectory-start`).
make_seq() {
    local dir="$1" sc="$2" t="$3" seed="$4" n="${5:-$frames}" traj=() m=()
    [[ -f "$dir/bound.csv" ]] && return 0
    [[ "$t" != drive ]] && traj=(--trajectory "$data/kitti_odometry_gt/poses/$t.txt")
    [[ "$t" != drive && "$along_travel" == 1 ]] && traj+=(--trajectory-along-travel)
    [[ -n "${6:-}" && "${6:-}" != - ]] && m=(--matches "$6")
    [[ -n "${7:-}" ]] && traj+=(--trajectory-start "$7")
    [[ -n "$noise" ]] && m+=(--pixel-noise "$noise")
    [[ -n "$static_tracks" ]] && m+=(--static-tracks "$static_tracks")
    rm -rf "$dir"
    mkdir -p "$(dirname "$dir")"
    if ! "$sim_momo" simulate --scenario "$sc" "${traj[@]}" --frames "$n" --seed "$seed" "${m[@]}" "$dir" \
        >/dev/null 2>"$dir.err"; then
        echo "family_eval: momo simulate failed for $dir: $(cat "$dir.err")" >&2
        return 1
    fi
    rm -f "$dir.err"
}
export -f make_seq

# run_one SEQDIR ESTDIR: runs momo with diagnostics and prints the row.
run_one() {
    local seq="$1" est="$2" name c=()
    name="$(basename "$seq")"
    [[ -n "$cfg" ]] && c=(--config "$cfg")
    if ! "$momo" run "$seq" "${c[@]}" -o "$est/$name.txt" --diagnostics "$est/$name.jsonl" -q \
        2>"$est/$name.err"; then
        printf '%s\tfailed\n' "$name"
        return 0
    fi
    "$momo" eval --gt "$seq/poses.txt" --est "$est/$name.txt" | tail -n 2 |
        awk -v n="$name" '
            NR == 1 { for (i = 1; i <= NF; i++) c[$i] = i; next }
            { t = ("t_err" in c) ? $c["t_err"] : "-"
              printf "%s\t%s\t%s\t%s\t%s\t%s\n", n, $c["median"], $c[">1deg"],
                  ("bound" in c) ? $c["bound"] : "-", ("eff" in c) ? $c["eff"] : "-", t }'
}
export -f run_one

# The sequences of a set, one "DIR SCENARIO TRAJECTORY SEED FRAMES [MATCHES]" per line.
list_set() {
    local s="$1" seeds trajs="00 01 02 03 04 05 06 07 08 09 10" sc t seed n
    case "$s" in
    grid | holdout | fresh | dev | dev2 | dev3 | conf | conf2 | conf3 | conf4 | conf5)
        case "$s" in
        grid) seeds="$(seq 1 10)" ;; holdout) seeds="$(seq 11 15)" ;;
        fresh) seeds="$(seq 16 20)" ;; dev) seeds="$(seq 21 30)" ;; dev2) seeds="$(seq 31 40)" ;;
        dev3) seeds="$(seq 41 50)" ;; conf) seeds="$(seq 51 60)" ;;
        conf2) seeds="$(seq 61 70)" ;; conf3) seeds="$(seq 81 90)" ;;
        conf4) seeds="$(seq 91 100)" ;; conf5) seeds="$(seq 101 110)" ;;
        esac
        for t in $trajs drive; do for seed in $seeds; do
            echo "$sets_dir/family/moving_traffic_${t}_s$seed moving_traffic $t $seed $frames"
        done; done ;;
    few250 | few200 | few150 | few100 | few150h | few100h | many400)
        n="${s#few}"
        n="${n#many}"
        seeds="1 2 3 4 5"
        [[ "$n" == *h ]] && n="${n%h}" && seeds="6 7 8 9 10"
        for t in $trajs drive; do for seed in $seeds; do
            echo "$sets_dir/fewtraffic/moving_traffic_m${n}_${t}_s$seed moving_traffic $t $seed $frames $n"
        done; done ;;
    slow | slow200)
        # The segments: trajectory:first pose (see the set's description above).
        local segs="00:514 00:1366 00:1919 00:2225 00:3505 00:4399 02:1755 03:49 03:712
            05:1513 05:1804 05:2068 05:2295 07:0 07:288 07:625 07:993 08:6 08:1580 08:1812
            08:2120 08:2241 08:2460 08:3982 10:0 10:606 10:948 10:1108" seg m=300
        seeds="$(seq 71 76)"
        [[ "$s" == slow200 ]] && m=200 && seeds="71 72 73"
        for seg in $segs; do for seed in $seeds; do
            t="${seg%%:*}"
            n="${seg#*:}"
            echo "$sets_dir/slow/moving_traffic_m${m}_${t}_${n}_s$seed moving_traffic $t $seed 100 $m $n"
        done; done ;;
    static | static2)
        [[ "$s" == static ]] && seeds="1 2 3" || seeds="4 5 6"
        for sc in clean_pinhole outliers; do for t in $trajs; do for seed in $seeds; do
            echo "$sets_dir/static/${sc}_${t}_s$seed $sc $t $seed $frames"
        done; done; done ;;
    static3 | static4)
        [[ "$s" == static3 ]] && seeds="1 2" || seeds="3 4 5"
        for sc in highway very_sparse fisheye_surround sparse_outliers radtan_mono \
            wide_angle_surround; do for t in $trajs; do for seed in $seeds; do
            echo "$sets_dir/static3/${sc}_${t}_s$seed $sc $t $seed $frames"
        done; done; done ;;
    rigtraffic | rigtraffic2 | rigdev | rigconf)
        case "$s" in
        rigtraffic) seeds="1 2 3" ;; rigtraffic2) seeds="4 5 6" ;; rigdev) seeds="$(seq 7 12)" ;;
        rigconf) seeds="$(seq 13 18)" ;;
        esac
        for t in $trajs drive; do for seed in $seeds; do
            echo "$sets_dir/rigtraffic/moving_traffic_surround_${t}_s$seed moving_traffic_surround $t $seed $frames"
        done; done ;;
    rigblind)
        for t in $trajs drive; do for seed in 1 2 3; do
            echo "$sets_dir/rigblind/moving_traffic_surround_blind_${t}_s$seed moving_traffic_surround_blind $t $seed $frames"
        done; done ;;
    builtin)
        for sc in clean_pinhole highway very_sparse fisheye_surround outliers sparse_outliers; do
            for seed in 1 2 3 4 5; do
                echo "$sets_dir/builtin/${sc}_s$seed $sc drive $seed 300"
            done
        done ;;
    *) echo "family_eval: unknown set $s" >&2; exit 2 ;;
    esac
}

make_k00() {
    local d="$sets_dir/k00" src="$data/kitti00_stereo_matches_l1avgvo"
    [[ -f "$src/calib.txt" ]] || { echo "family_eval: no $src: skipping k00" >&2; return 1; }
    mkdir -p "$d"
    [[ -d "$d/mono100" ]] || "$momo" import-kitti "$src" "$d/mono100" --matches 100 --seed 1 >/dev/null 2>&1
    [[ -d "$d/mono200" ]] || "$momo" import-kitti "$src" "$d/mono200" --matches 200 --seed 1 >/dev/null 2>&1
    [[ -d "$d/mono300" ]] || "$momo" import-kitti "$src" "$d/mono300" --matches 300 --seed 1 >/dev/null 2>&1
    [[ -d "$d/stereo200" ]] || "$momo" import-kitti "$src" "$d/stereo200" --stereo --matches 200 --seed 1 >/dev/null 2>&1
}

failed_any=0
for s in "${sets[@]}"; do
    start=$(date +%s)
    mkdir -p "$out/$s/est"
    if [[ "$s" == k00 ]]; then
        make_k00 || continue
        ls -d "$sets_dir/k00"/* >"$out/$s/list"
    else
        list_set "$s" >"$out/$s/list.spec"
        awk '{ print $1 }' "$out/$s/list.spec" >"$out/$s/list"
        # shellcheck disable=SC2016
        xargs -P "$jobs" -L 1 bash -c 'make_seq "$@"' _ <"$out/$s/list.spec"
        if [[ "${NO_ODOMETRY:-0}" == 1 ]]; then
            # The same sequences without odometry.csv, through links.
            rm -rf "$out/$s/seqs"
            while read -r seq; do
                d="$out/$s/seqs/$(basename "$seq")"
                mkdir -p "$d"
                for f in "$seq"/*; do
                    [[ "$(basename "$f")" == odometry.csv ]] || ln -s "$(cd "$(dirname "$f")" && pwd)/$(basename "$f")" "$d/"
                done
                echo "$d"
            done <"$out/$s/list" >"$out/$s/list.noodo"
            mv "$out/$s/list.noodo" "$out/$s/list"
        fi
    fi
    xargs -P "$jobs" -I{} bash -c 'run_one "$1" "$2"' _ {} "$out/$s/est" <"$out/$s/list" |
        sort >"$out/$s/rows.tsv"
    if grep -q $'\tfailed' "$out/$s/rows.tsv"; then failed_any=1; fi
    gap="-"
    if [[ "$s" != k00 && "$s" != static* && "$s" != builtin ]] &&
        "$py" -c 'import numpy' 2>/dev/null; then
        seqd="$(dirname "$(head -n 1 "$out/$s/list")")"
        gap="$("$py" "$root/scripts/family_calibration.py" "$out/$s/est" "$seqd" \
            $(xargs -n 1 basename <"$out/$s/list") 2>/dev/null |
            sed -n 's/.*neither (the trust gap) \([0-9]*\).*/\1/p' | head -n 1)"
        gap="${gap:--}"
    fi
    python3 - "$out/$s/rows.tsv" "$s" "$gap" "$(($(date +%s) - start))" <<'PY' | tee "$out/$s/summary.txt"
import statistics, sys
rows = [l.rstrip("\n").split("\t") for l in open(sys.argv[1]) if l.strip()]
failed = [r[0] for r in rows if r[1] == "failed"]
ok = [r for r in rows if r[1] != "failed"]
name, gap, secs = sys.argv[2], sys.argv[3], sys.argv[4]
big = sum(int(r[2]) for r in ok)
eff = [float(r[4]) for r in ok if r[4] not in ("-", "")]
line = f"{name}: {len(ok)} sequences"
if failed:
    line += f" ({len(failed)} FAILED: {' '.join(failed[:5])})"
line += f"; frames > 1 deg {big}"
if eff:
    line += (f"; eff median {statistics.median(eff):.4f} mean {statistics.mean(eff):.4f} "
             f"max {max(eff):.3f}; above 1.15: {sum(e > 1.15 for e in eff)}; above 1.5: "
             f"{sum(e > 1.5 for e in eff)}")
if name == "k00":
    line += "; " + " ".join(f"{r[0]} {float(r[1]):.4f} deg t_err {r[5]}" for r in ok)
line += f"; trust gap {gap}; {secs} s"
print(line)
PY
done
if ((failed_any)); then
    echo "family_eval: some runs failed (their rows say failed; errors in OUT_DIR/SET/est/NAME.err)" >&2
    exit 1
fi
