#!/usr/bin/env bash
# Every test: the Rust workspace (unit, integration, doc and example tests) and the Python
# bindings' pytest suite (scripts/python_test.sh: a venv under target/, maturin, pytest).
# This is the README's test command and what CI (.ci/run) runs after fmt and clippy.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo test --workspace
bash scripts/python_test.sh
