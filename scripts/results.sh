#!/usr/bin/env bash
# Produces docs/RESULTS.md: every evaluation of momo, its baselines and its peers, with pictures.
#
# Usage: scripts/results.sh [DATA_DIR] [OUT_DIR]
#   DATA_DIR  the shared data folder (default ../shared/data beside the repository)
#   OUT_DIR   scratch space for sequences and estimates (default target/results)
#   PARTS     environment variable: which parts to (re)run, default "kitti sim peers sweep images calibrate trajectories speed";
#             a part that is not run keeps its last section file (OUT_DIR/PART.md) if there is
#             one, so that one part can be refreshed without re-running all.
#
# Parts (each a script of its own, each skipping with a message when its data or tools are
# missing):
#   kitti   scripts/kitti00_eval.sh   real KITTI 00 matches: momo configurations, 5-point baselines
#   sim     scripts/sim_eval.sh       every simulated scenario, 3 seeds, with pictures (docs/img)
#   peers   scripts/peers_eval.sh     OpenCV and PoseLib from PyPI on the same sequences
#   sweep   scripts/sweep_eval.sh     `momo sweep` over models x metrics x losses x solvers
#   images  scripts/images_eval.sh    `momo match` / `momo vo` on real KITTI images
#   calibrate scripts/calibrate_eval.sh `momo calibrate` (camera mount) on KITTI 00
#   trajectories scripts/trajectories_eval.sh simulated matches along KITTI 00-10 ground truth
#   speed   scripts/speed_eval.sh     criterion targets and floor, whole-process time per frame
set -uo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
abs() { case "$1" in /*) printf '%s\n' "$1" ;; *) printf '%s\n' "$PWD/$1" ;; esac; }
data="$(abs "${1:-$root/../shared/data}")"
out="$(abs "${2:-$root/target/results}")"
parts="${PARTS:-kitti sim peers sweep images calibrate trajectories speed}"
mkdir -p "$out" "$root/docs/img"
(cd "$root" && cargo build --release) || exit 1

want() { [[ " $parts " == *" $1 "* ]]; }
part() { # NAME SCRIPT ARGS...: runs a part unless it is not wanted; failures are reported.
    local name="$1"
    shift
    want "$name" || return 0
    if [[ ! -x "$root/scripts/$1" ]]; then
        echo "results: scripts/$1 is missing; part $name skipped" >&2
        return 0
    fi
    echo "results: running $name ($1)" >&2
    if ! "$root/scripts/$@"; then
        echo "results: part $name failed; its last section is kept" >&2
    fi
}

part kitti kitti00_eval.sh "$data" "$out/kitti" &&
    { [[ ! -f "$out/kitti/kitti00.md" ]] || cp "$out/kitti/kitti00.md" "$out/kitti.md"; }
part sim sim_eval.sh "$out/sim" "$out/sim.md" "$root/docs/img"
# The peers keep their venv in target/peers (installing the wheels again is slow).
part peers peers_eval.sh "$data" "${PEERS_DIR:-$root/target/peers}" "$out/peers.md"
part sweep sweep_eval.sh "$data" "$out/sweep.md" "$out/sweep"
part images images_eval.sh "$data" "$out/images" "$out/images.md"
part calibrate calibrate_eval.sh "$data" "$out/calibrate" "$out/calibrate.md"
part trajectories trajectories_eval.sh "$data" "$out/trajectories" "$out/trajectories.md"
part speed speed_eval.sh "$out/speed" "$out/speed.md"

section() { # FILE: prints a section, demoting its top-level heading
    if [[ -f "$1" ]]; then
        sed -e 's/^# /## /' "$1"
    else
        echo "_Not produced in this run (see scripts/results.sh)._"
    fi
    echo
}

{
    echo "# Results"
    echo
    echo "Produced by \`scripts/results.sh\` (last run $(date -u +%Y-%m-%d), $("$root/target/release/momo" --version),"
    echo "on a 2-core machine shared with other jobs: times are indicative). Every number below"
    echo "comes from \`momo eval\` on the estimates the scripts wrote; rotation errors are frame to"
    echo "frame in degrees unless stated; t_err (%) and r_err (deg/100 m) are the KITTI devkit's."
    echo
    echo "# 1. KITTI 00, real matches"
    echo
    section "$out/kitti.md"
    echo "# 2. Simulated scenarios"
    echo
    section "$out/sim.md"
    echo "# 3. Peers: OpenCV and PoseLib"
    echo
    section "$out/peers.md"
    echo "# 4. Sweep: models x metrics x losses x solvers"
    echo
    section "$out/sweep.md"
    echo "# 5. From images: momo match and momo vo"
    echo
    section "$out/images.md"
    echo "# 6. Mount self-calibration"
    echo
    section "$out/calibrate.md"
    echo "# 7. Simulated matches along the KITTI 00-10 trajectories"
    echo
    section "$out/trajectories.md"
    echo "# 8. Speed"
    echo
    section "$out/speed.md"
} >"$root/docs/RESULTS.md"
echo "results: wrote docs/RESULTS.md" >&2
