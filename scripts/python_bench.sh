#!/usr/bin/env bash
# Measures the Python bindings on release builds (not part of CI; minutes):
# - the per-frame overhead of Odometry.process called from Python against the same calls in Rust;
# - a KITTI-length simulated sequence (KITTI 00's ground truth as the drive, 4,541 frames)
#   through a Python loop of Odometry.process against `momo run`.
# Results: printed, and target/python_bench/python_bench.json.
#
#   bash scripts/python_bench.sh             # MOMO_DATA defaults to ../shared/data
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
data=${MOMO_DATA:-$root/../shared/data}
gt=$data/kitti_odometry_gt/poses/00.txt
if [ ! -f "$gt" ]; then
    echo "python_bench.sh: $gt not found (set MOMO_DATA); skipping" >&2
    exit 0
fi
venv=$root/target/pyvenv-bench
work=$root/target/python_bench
mkdir -p "$work"
[ -x "$venv/bin/python" ] || "${PYTHON:-python3}" -m venv "$venv"
"$venv/bin/python" -m pip install -q --disable-pip-version-check "maturin>=1.7,<2" "numpy>=1.21"
cargo build --quiet --release --bin momo
rm -rf "$work/wheel"
PATH="$venv/bin:$PATH" VIRTUAL_ENV="$venv" maturin build --quiet --release \
    --manifest-path crates/momo-py/Cargo.toml --interpreter "$venv/bin/python" --out "$work/wheel"
"$venv/bin/python" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps "$work"/wheel/momo-*.whl
seq=$work/kitti00_sim
if [ ! -f "$seq/matches.csv" ]; then
    target/release/momo simulate --scenario clean_pinhole --trajectory "$gt" --frames 4541 --seed 1 "$seq"
fi
cd "$work"
"$venv/bin/python" "$root/scripts/python_bench.py" "$root/target/release/momo" "$seq" "$work"
