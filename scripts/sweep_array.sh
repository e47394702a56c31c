#!/usr/bin/env bash
# Runs a large `momo sweep` as N independent copies of one command (a batch scheduler's job
# array, or any runner of N copies), then merges their results. No cluster code of our own: each
# copy runs `momo sweep --shard I/N`, a deterministic, disjoint slice of the jobs; `momo sweep
# merge` joins the slices and fails if one is missing, duplicated or from another grid.
#
# Usage:
#   scripts/sweep_array.sh task  GRID OUT SEQ...     one copy: shard I/N with I and N from
#                                                    SLURM_ARRAY_TASK_ID / SLURM_ARRAY_TASK_COUNT
#                                                    (Slurm, --array=1-N) or TASK_ID / TASK_COUNT;
#                                                    writes OUT/shard-I-of-N/{results.csv,summary.md}
#   scripts/sweep_array.sh merge OUT                 joins OUT/shard-*/results.csv into OUT/merged/
#   scripts/sweep_array.sh local N GRID OUT SEQ...   runs the N copies here as background
#                                                    processes, then merges (what CI tests)
#   scripts/sweep_array.sh slurm N GRID OUT SEQ...   submits `sbatch --array=1-N` running `task`,
#                                                    and a merge job that starts when all succeed
#
# Environment:
#   MOMO   the momo binary (default: target/release/momo of this checkout, built if missing)
#   JOBS   worker threads per copy (default: all cores of the copy's machine; set it to the
#          cores a scheduler gives one task, e.g. JOBS=$SLURM_CPUS_PER_TASK)
#   SBATCH_ARGS  extra sbatch options for `slurm` (partition, time, cpus-per-task, ...)
#
# Sequence directories and the grid must be reachable under the same paths from every copy
# (a shared file system); results are keyed by sequence directory name.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
self="$root/scripts/sweep_array.sh"
usage() {
    sed -n '/^# Usage:/,/^# Sequence directories/p' "$self" | sed 's/^# \{0,1\}//' >&2
    exit 2
}
momo_bin() {
    if [[ -n "${MOMO:-}" ]]; then
        printf '%s\n' "$MOMO"
        return
    fi
    if [[ ! -x "$root/target/release/momo" ]]; then
        (cd "$root" && cargo build --release --quiet) >&2
    fi
    printf '%s\n' "$root/target/release/momo"
}
jobs_arg() {
    if [[ -n "${JOBS:-}" ]]; then printf -- '--jobs\n%s\n' "$JOBS"; fi
}

cmd="${1:-}"
[[ -n "$cmd" ]] || usage
shift

case "$cmd" in
task)
    [[ $# -ge 3 ]] || usage
    grid="$1" out="$2"
    shift 2
    id="${SLURM_ARRAY_TASK_ID:-${TASK_ID:-}}"
    count="${SLURM_ARRAY_TASK_COUNT:-${TASK_COUNT:-}}"
    if [[ -z "$id" || -z "$count" ]]; then
        echo "sweep_array: set SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT (or TASK_ID and TASK_COUNT), 1-based" >&2
        exit 2
    fi
    momo="$(momo_bin)"
    mapfile -t extra < <(jobs_arg)
    exec "$momo" sweep --grid "$grid" --sequences "$@" --output "$out/shard-$id-of-$count" \
        --shard "$id/$count" --quiet "${extra[@]}"
    ;;
merge)
    [[ $# -eq 1 ]] || usage
    out="$1"
    shopt -s nullglob
    files=("$out"/shard-*-of-*/results.csv)
    if [[ ${#files[@]} -eq 0 ]]; then
        echo "sweep_array: no $out/shard-*-of-*/results.csv" >&2
        exit 2
    fi
    "$(momo_bin)" sweep merge "${files[@]}" --output "$out/merged"
    ;;
local)
    [[ $# -ge 4 ]] || usage
    n="$1" grid="$2" out="$3"
    shift 3
    momo="$(momo_bin)"
    pids=()
    for ((i = 1; i <= n; i++)); do
        TASK_ID="$i" TASK_COUNT="$n" MOMO="$momo" "$self" task "$grid" "$out" "$@" &
        pids+=("$!")
    done
    failed=0
    for p in "${pids[@]}"; do
        wait "$p" || failed=1
    done
    if [[ $failed -ne 0 ]]; then
        echo "sweep_array: a task failed; not merging" >&2
        exit 1
    fi
    MOMO="$momo" "$self" merge "$out"
    ;;
slurm)
    [[ $# -ge 4 ]] || usage
    command -v sbatch >/dev/null || { echo "sweep_array: sbatch not found" >&2; exit 2; }
    n="$1" grid="$2" out="$3"
    shift 3
    momo="$(momo_bin)"
    mkdir -p "$out/logs"
    quoted="$(printf '%q ' "$@")"
    # shellcheck disable=SC2086 # SBATCH_ARGS is a list of options
    array_id="$(sbatch --parsable ${SBATCH_ARGS:-} --array="1-$n" --job-name=momo-sweep \
        --output="$out/logs/task-%a.log" \
        --wrap="MOMO=$(printf '%q' "$momo") JOBS=\${SLURM_CPUS_PER_TASK:-} $(printf '%q' "$self") task $(printf '%q' "$grid") $(printf '%q' "$out") $quoted")"
    # shellcheck disable=SC2086
    merge_id="$(sbatch --parsable ${SBATCH_ARGS:-} --dependency="afterok:$array_id" \
        --job-name=momo-sweep-merge --output="$out/logs/merge.log" \
        --wrap="MOMO=$(printf '%q' "$momo") $(printf '%q' "$self") merge $(printf '%q' "$out")")"
    echo "sweep_array: submitted array job $array_id (1-$n) and merge job $merge_id; results in $out/merged" >&2
    ;;
*)
    usage
    ;;
esac
