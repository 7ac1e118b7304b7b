#!/usr/bin/env bash
# The whole test suite: the README's test command, and what .ci/run calls.
# Installs what it needs (apt packages, cargo tools, PyPI packages) on a fresh machine.
# Every step runs; the script fails if any step failed. Nothing is skipped silently.
set -uo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
export CARGO_TERM_COLOR=never
LOG_DIR=${TRN_TEST_LOG_DIR:-$ROOT/out/test-logs}
mkdir -p "$LOG_DIR"

passed=0
failed=0
failed_steps=()

step() {
    local name=$1
    shift
    echo
    echo "==> [$name] $*"
    local start=$SECONDS
    if "$@"; then
        passed=$((passed + 1))
        echo "<== [$name] ok ($((SECONDS - start)) s)"
    else
        failed=$((failed + 1))
        failed_steps+=("$name")
        echo "<== [$name] FAILED ($((SECONDS - start)) s)"
    fi
}

fmt() { cargo fmt --all -- --check && rustfmt --check --edition 2021 firmware/src/*.rs; }
# every feature but the compact build's (`compact` switches the controller's tables to i16
# for the whole build: linted here with all features, tested in its own steps)
FEATURES="trn-protocol/socketcan"
clippy() {
    cargo clippy --workspace --all-targets --features "$FEATURES" -- -D warnings &&
        cargo clippy --workspace --all-targets --all-features -- -D warnings
}
unit() { cargo test --workspace --features "$FEATURES" --release; }

step fmt fmt
step clippy clippy
step unit-and-integration unit

# shellcheck source=scripts/test-steps.sh
source "$ROOT/scripts/test-steps.sh"

echo
echo "==> test suite summary"
if [ "$failed" -gt 0 ]; then
    echo "failed steps: ${failed_steps[*]}"
fi
echo "steps: $passed passed, $failed failed"
[ "$failed" -eq 0 ]
