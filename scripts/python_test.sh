#!/usr/bin/env bash
# The Python bindings (crates/momo-py): builds the package with maturin (dev profile, as the
# debug `momo` binary it is compared with) into a venv under target/, then runs its pytest suite
# (python/tests: equality with `momo run`/`momo simulate`/`momo eval`, every exception path,
# Config round trips). Exits non-zero on any failure, and when no test ran (pytest's exit 5).
#
#   bash scripts/python_test.sh            # build + test
#   PYTHON=python3.12 bash scripts/python_test.sh
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
venv=$root/target/pyvenv
started=$(date +%s)

if [ ! -x "$venv/bin/python" ]; then
    "${PYTHON:-python3}" -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q --disable-pip-version-check "maturin>=1.7,<2" "numpy>=1.21" "pytest>=7"

# The CLI the tests compare with (same profile and target dir as the extension).
# The CLI the tests compare against, from the same build as `cargo test --workspace` (same
# features, so this is a no-op after it; `cargo build --bin momo` alone would resolve other
# dependency features and compile them again).
cargo test --workspace --no-run --quiet

# Build the wheel (abi3) and install it: no build products land in the source tree.
rm -rf "$root/target/wheels/python-test"
PATH="$venv/bin:$PATH" VIRTUAL_ENV="$venv" maturin build --quiet \
    --manifest-path crates/momo-py/Cargo.toml --interpreter "$venv/bin/python" \
    --out "$root/target/wheels/python-test"
"$venv/bin/python" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps \
    "$root"/target/wheels/python-test/momo-*.whl

cd "$root/target"   # import the installed package, not the source tree
MOMO_BIN="$root/target/debug/momo" "$venv/bin/python" -m pytest -q -p no:cacheprovider \
    "$root/crates/momo-py/python/tests"
echo "python_test.sh: done in $(( $(date +%s) - started )) s"
