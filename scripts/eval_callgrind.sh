#!/usr/bin/env bash
# Instruction counts (callgrind, repeatable on a loaded machine) of benches/evaluations.rs per
# call: one cost evaluation, one linearisation (fused kernel and automatic) and one timed
# `Odometry::process`, for the pinhole (se3), the default model (soft_single_track) and the
# fisheye (single_track_3d) cases, and the process in units of cost evaluations (issue 19).
# Usage: scripts/eval_callgrind.sh [EVALUATIONS_BENCH_BINARY] [SOLVER_LINES]
#   (default binary: the newest target/release/deps/evaluations-*; SOLVER_LINES as
#   MOMO_EVAL_SOLVER, e.g. 'max_step_extrapolation = 2.0').
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-$(ls -t target/release/deps/evaluations-* | grep -v '\.d$' | head -1)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for c in default_pinhole soft_single fisheye; do
  MOMO_EVAL_SOLVER="${2:-}" MOMO_EVAL_ROUNDS=2 MOMO_EVAL_CASE=$c nice valgrind --tool=callgrind \
    --callgrind-out-file="$work/$c.out" "$bin" --bench none >"$work/$c.log" 2>&1
  its=$(grep -o '([0-9]* solver iterations' "$work/$c.log" | tr -d '(' || true)
  callgrind_annotate --inclusive=yes "$work/$c.out" 2>/dev/null | python3 -c '
import re, sys
case, its = sys.argv[1:3]
v = {}
for line in sys.stdin:
    m = re.match(r"\s*([\d,]+) \(.*=> .*evaluations::(timed_\w+) \((\d+)x\)", line)
    if m:
        v[m.group(2)] = int(m.group(1).replace(",", "")) / int(m.group(3))
c = v["timed_cost"]; l = v["timed_linearize"]; p = v["timed_process"]; a = v["timed_linearize_automatic"]
print(f"{case:16s} cost {c:8.0f}  linearisation {l:8.0f} ({l / c:.2f} cost evaluations), "
      f"automatic {a:8.0f}  process {p:9.0f} = {p / c:.2f} cost "
      f"evaluations ({its})")
' "$c" "$its"
done
