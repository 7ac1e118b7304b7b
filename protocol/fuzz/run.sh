#!/usr/bin/env bash
# Run the fuzz target for SECONDS (default 60) and print the exec count.
#   protocol/fuzz/run.sh 60
# Installs cargo-fuzz if missing. Uses the nightly toolchain if rustup has one, else
# stable with RUSTC_BOOTSTRAP=1 (cargo-fuzz passes -Z flags).
set -euo pipefail
secs="${1:-60}"
here="$(cd "$(dirname "$0")" && pwd)"
cd "$here"
if ! cargo fuzz --version >/dev/null 2>&1; then
    cargo install cargo-fuzz --locked
fi
toolchain=()
if rustup toolchain list 2>/dev/null | grep -q '^nightly'; then
    toolchain=(+nightly)
else
    export RUSTC_BOOTSTRAP=1
fi
mkdir -p corpus/decode_reassemble artifacts/decode_reassemble
if [ -z "$(ls -A corpus/decode_reassemble)" ]; then
    # Seed with real encoded traffic so the fuzzer starts from valid transfers.
    cargo run --quiet --manifest-path ../../Cargo.toml -p trn-protocol --features std \
        --example fuzz_seeds -- "$here/corpus/decode_reassemble"
fi
log="$(mktemp)"
trap 'rm -f "$log"' EXIT
set +e
cargo "${toolchain[@]}" fuzz run decode_reassemble corpus/decode_reassemble -- \
    -max_total_time="$secs" -max_len=512 -print_final_stats=1 2>&1 | tee "$log" | grep -E '^(#[0-9]+\s+(INITED|DONE)|==|SUMMARY|thread|stat::)' 
status="${PIPESTATUS[0]}"
set -e
execs="$(grep -E '^stat::number_of_executed_units' "$log" | awk '{print $2}' | tail -1)"
echo "fuzz: decode_reassemble ran ${secs}s, exec count ${execs:-unknown}, exit ${status}"
exit "$status"
