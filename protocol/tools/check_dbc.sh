#!/usr/bin/env bash
# Interop check: encode real traffic, write a candump log, decode it with cantools and
# protocol/trn.dbc, compare every signal. Exits non-zero on any mismatch.
#   protocol/tools/check_dbc.sh
# Installs cantools from PyPI into a venv (idempotent; TRN_VENV overrides the location).
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
proto="$(dirname "$here")"
root="$(dirname "$proto")"
venv="${TRN_VENV:-$root/target/trn-venv}"
if ! "$venv/bin/python" -c 'import cantools' 2>/dev/null; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet --disable-pip-version-check 'cantools>=39,<46'
fi
# The DBC is generated; fail if someone edited one without the other.
if ! diff -q <(python3 "$here/gen_dbc.py") "$proto/trn.dbc" >/dev/null; then
    echo "protocol/trn.dbc is out of date: python3 protocol/tools/gen_dbc.py > protocol/trn.dbc" >&2
    exit 1
fi
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
cargo run --quiet --manifest-path "$root/Cargo.toml" -p trn-protocol --features std \
    --example gen_candump -- "$out/traffic.log" "$out/traffic.expected.jsonl"
"$venv/bin/python" "$here/decode_candump.py" "$proto/trn.dbc" "$out/traffic.log" "$out/traffic.expected.jsonl"
