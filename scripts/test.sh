#!/usr/bin/env bash
# Every test: the Rust workspace (unit, integration, doc and example tests) and the Python
# bindings' pytest suite (scripts/python_test.sh: a venv under target/, maturin, pytest).
# This is the README's test command and what CI (.ci/run) runs after fmt and clippy.
set -euo pipefail
cd "$(dirname "$0")/.."
# Property tests draw from a fixed seed here, so a CI run is reproducible; set PROPTEST_RNG_SEED
# to draw others (plain `cargo test` draws fresh ones every run). Failing draws found that way
# go into the `*.proptest-regressions` files, which every run replays first.
export PROPTEST_RNG_SEED="${PROPTEST_RNG_SEED:-20261129}"
cargo test --workspace
bash scripts/python_test.sh
