#!/usr/bin/env bash
# The Python package as a new user installs it, for the test suite:
#   bash scripts/python-package.sh
# In a fresh venv: `pip install ./python gymnasium` (maturin builds the abi3 wheel from the
# workspace), then python/tests/check_package.py: check_env(SoftArmEnv()) and 200 random
# steps, the vector environment, the TRN and Broyden controllers from Python, the decoder on
# a training's candump log (0 undecoded), and a rerun recording of a training
# (`trn train --rerun-save`) read back with rerun's own reader (rerun-sdk installed too),
# then pytest python/tests.
# Prints each part's time; the venv (about 0.5 GB with rerun-sdk) is removed at the end.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
venv="${TRN_PY_VENV:-$root/target/py-package-venv}"
work="$(mktemp -d)"
trap 'rm -rf "$work" "$venv"' EXIT
t0=$SECONDS
rm -rf "$venv"
python3 -m venv "$venv"
pip=("$venv/bin/pip" install --quiet --disable-pip-version-check)
"${pip[@]}" ./python gymnasium
t_install=$((SECONDS - t0))
"${pip[@]}" 'rerun-sdk==0.28.2'
t_rerun=$((SECONDS - t0 - t_install))
trials=15
cargo build --quiet --release --bin trn
"$root/target/release/trn" train --quiet --trials "$trials" --eval-targets 3 --grasps 2 \
    --snapshot-every 0 --candump "$work/train.log" --report "$work/train.json"
TRN_PYTHON="$venv/bin/python" "$root/target/release/trn" train --quiet --trials "$trials" \
    --eval-targets 3 --grasps 2 --snapshot-every 0 --rerun-save "$work/train.rrd"
# the Rust decoder's count, as a user runs it
"$root/target/release/trn" decode --summary "$work/train.log" | tee "$work/decode.txt"
grep -q ', 0 undecoded$' "$work/decode.txt"
(cd "$work" && "$venv/bin/python" "$root/python/tests/check_package.py" \
    --log "$work/train.log" --recording "$work/train.rrd" --trials "$trials")
# the environment's own tests (check_env on the registered id, pickling, termination, the
# native vector env against SyncVectorEnv, the options); SB3's test is skipped without it
"${pip[@]}" pytest
(cd "$work" && "$venv/bin/python" -m pytest -q -p no:cacheprovider "$root/python/tests")
disk=$(du -sm "$venv" | cut -f1)
echo "python package: pip install ./python gymnasium ${t_install} s, rerun-sdk ${t_rerun} s," \
    "all $((SECONDS - t0)) s; venv ${disk} MB"
