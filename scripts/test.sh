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

# Disk: a clean clone's suite peaks at 4.5 GB in the checkout (measured: the host's release,
# debug and compact builds, the static vcan executables, the cross-built crates, the firmware
# variants, the fuzzer's build, the VM's kernel and root file system). When less than
# TRN_TEST_MIN_FREE_GB (default 4) is left after a step, the build directories that only the
# finished steps use are removed (they are caches: the next run rebuilds them).
MIN_FREE_KB=$((${TRN_TEST_MIN_FREE_GB:-4} * 1024 * 1024))
prune_if_low() { # DIR...: build directories no later step uses
    local avail
    avail=$(df --output=avail -k "$ROOT" | tail -1)
    [ "$avail" -lt "$MIN_FREE_KB" ] || return 0
    for dir in "$@"; do
        if [ -d "$ROOT/$dir" ]; then
            echo "disk: $((avail / 1024)) MB free (< $((MIN_FREE_KB / 1024)) MB): removing the build cache $dir"
            rm -rf "${ROOT:?}/$dir"
        fi
    done
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
prune_if_low target/debug
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
