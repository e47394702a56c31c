#!/usr/bin/env bash
# Peak memory and time of `momo` on huge and sparse inputs (issue 16, docs/GUARANTEES.md
# sections 4b and 5): a 50,000-camera rig.json, a matches.csv whose frame numbers jump to
# 1,000,000 (`momo calibrate`, `momo plot landscape`, `momo run --calibrate-mount`) and
# matches.csv files of ROWS rows streamed by `momo run`. Inputs are generated into WORK and
# removed at the end. Peak RSS from GNU time (`/usr/bin/time -f %M`).
#
#   cargo build --release --bin momo
#   bash scripts/reliability_eval.sh [WORK=/tmp/momo-reliability]
#   ROWS="10000000 30000000" bash scripts/reliability_eval.sh      # streamed sizes (rows)
#   ROWS= FIFO_ROWS=100000000 bash scripts/reliability_eval.sh     # through a FIFO, no disk
#   MOMO=/path/to/other/momo bash scripts/reliability_eval.sh      # another build (before/after)
#
# Disk: ~81 bytes per row (10 million rows: 0.8 GB), checked against the free space first.
# FIFO_ROWS: the rows are generated into a FIFO named matches.csv in the sequence directory
# (momo reads it as it is written), so any size runs without disk; the generator (awk) runs
# at the same time on the other core.
set -euo pipefail
cd "$(dirname "$0")/.."
momo=$(realpath "${MOMO:-target/release/momo}")
work=${1:-/tmp/momo-reliability}
rows_list=${ROWS-"1000000 10000000"}
fifo_rows_list=${FIFO_ROWS-}
[ -x "$momo" ] || { echo "no $momo: cargo build --release --bin momo" >&2; exit 1; }
mkdir -p "$work"
trap 'rm -rf "$work"' EXIT

measure() { # LABEL CMD...: one line: label, peak RSS, wall clock, exit code
    local label=$1
    shift
    /usr/bin/time -f "%M %e %x" -o "$work/time" "$@" >/dev/null 2>"$work/err" || true
    local kb s code
    read -r kb s code < <(tail -n 1 "$work/time")
    printf '%-58s peak %8.1f MB %9.2f s  exit %s\n' "$label" "$(echo "$kb / 1024" | bc -l)" "$s" "$code"
}

# A simulated drive: 51 frames, 360 matches per frame pair (18,000 rows, 1.4 MB).
"$momo" simulate --frames 51 --matches 360 --seed 1 "$work/base" >/dev/null 2>&1

# 1. Sparse frame numbers: frame k -> 20000 k (last frame 1,000,000), odometry alike.
mkdir -p "$work/sparse"
cp "$work/base/rig.json" "$work/sparse/"
for f in matches odometry; do
    awk -F, 'BEGIN { OFS = "," } NR == 1 { print; next } { $1 = $1 * 20000; print }' \
        "$work/base/$f.csv" > "$work/sparse/$f.csv"
done
echo "sparse matches.csv: $(stat -c %s "$work/sparse/matches.csv") bytes, last frame $(tail -n 1 "$work/sparse/matches.csv" | cut -d, -f1)"
measure "calibrate (sparse, last frame 1,000,000)" "$momo" calibrate "$work/sparse" -o "$work/r.json" -q
measure "plot landscape --frame 1000000 (sparse)" "$momo" plot landscape "$work/sparse" --frame 1000000 -o "$work/l.png"
measure "run --calibrate-mount (sparse)" "$momo" run "$work/sparse" -o "$work/p.txt" -d "$work/d.jsonl" -q --calibrate-mount
measure "run (streamed, sparse)" "$momo" run "$work/sparse" -o "$work/p.txt" -q
rm -rf "$work/sparse"

# 2. A 50,000-camera rig.json (camera 0 the simulated one, then copies) and 20 frames.
mkdir -p "$work/rig50k"
awk -v n=50000 'BEGIN {
    print "{\"cameras\": ["
    for (i = 0; i < n; i++)
        printf "%s{\"name\": \"cam%d\", \"model\": {\"type\": \"pinhole\", \"fx\": 718.856, \"fy\": 718.856, \"cx\": 607.1928, \"cy\": 185.2157, \"width\": 1241, \"height\": 376}, \"T_vehicle_camera\": [[0, 0, 1, 1], [-1, 0, 0, 0], [0, -1, 0, 1.65], [0, 0, 0, 1]]}\n", (i ? "," : ""), i
    print "]}"
}' > "$work/rig50k/rig.json"
awk -F, 'NR == 1 || $1 <= 20' "$work/base/matches.csv" > "$work/rig50k/matches.csv"
echo "rig.json: $(stat -c %s "$work/rig50k/rig.json") bytes, $(grep -c '"model"' "$work/rig50k/rig.json") cameras"
measure "run (50,000-camera rig.json, 20 frames)" "$momo" run "$work/rig50k" -o "$work/p.txt" -q
rm -rf "$work/rig50k"

# ROWS rows of the base sequence's matches: its 50 frame pairs repeated (frame k of copy r
# is 50 r + k), to standard output.
generate() {
    awk -F, -v rows="$1" 'BEGIN { OFS = "," }
        NR == 1 { print; next }
        { line[++n] = $0; frame[n] = $1; sub(/^[^,]*,/, "", line[n]) }
        END { for (i = 0; i < rows; i++) { j = i % n + 1; r = int(i / n);
              print 50 * r + frame[j], line[j] } }' "$work/base/matches.csv"
}

# 3. ROWS rows streamed: the 50 frame pairs repeated (frame k of copy r is 50 r + k).
for rows in $rows_list; do
    need=$((rows * 90))
    free=$(($(df --output=avail -B1 "$work" | tail -n 1)))
    if [ "$need" -gt $((free - 4000000000)) ]; then
        echo "$rows rows: ~$need bytes needed, $free free: skipped"
        continue
    fi
    mkdir -p "$work/huge"
    cp "$work/base/rig.json" "$work/huge/"
    generate "$rows" > "$work/huge/matches.csv"
    echo "$rows rows: $(stat -c %s "$work/huge/matches.csv") bytes, last frame $(tail -n 1 "$work/huge/matches.csv" | cut -d, -f1)"
    measure "run (streamed, $rows rows)" "$momo" run "$work/huge" -o "$work/p.txt" -q
    echo "  poses written: $(wc -l < "$work/p.txt")"
    rm -rf "$work/huge" "$work/p.txt"
done

# 4. FIFO_ROWS rows streamed through a FIFO: nothing is written to disk but the poses.
for rows in $fifo_rows_list; do
    mkdir -p "$work/fifo"
    cp "$work/base/rig.json" "$work/fifo/"
    mkfifo "$work/fifo/matches.csv"
    generate "$rows" > "$work/fifo/matches.csv" &
    gen=$!
    measure "run (streamed through a FIFO, $rows rows)" "$momo" run "$work/fifo" -o "$work/p.txt" -q
    wait "$gen" || true
    echo "  poses written: $(wc -l < "$work/p.txt")"
    rm -rf "$work/fifo" "$work/p.txt"
done
