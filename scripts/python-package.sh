#!/usr/bin/env bash
# The Python package as a new user installs it, for the test suite:
#   bash scripts/python-package.sh
# maturin builds the abi3 wheel (cargo's progress shown),
# which is installed in a fresh venv with no Rust toolchain on PATH (the venv's own bin/ is
# all of it), its [live] extra too (no second build); then python/tests/check_package.py:
# check_env(SoftArmEnv()) and 200 random steps, the vector environment, the TRN and Broyden
# controllers from Python, the decoder on a training's candump log (0 undecoded), and a
# rerun recording of a training (`trn train --rerun-save`) read back with rerun's own
# reader; then pytest python/tests (check_env on the registered id, the native vector env,
# a pickle round trip, termination, the options, the arm's URDF and MJCF read by MuJoCo's
# loaders against the plant's kinematics; MuJoCo is installed for it, about 90 MB with its
# OpenGL bindings; the protocol's listener on python-can's virtual bus).
# Prints each part's time; the venvs (about 0.5 GB with rerun-sdk) are removed at the end.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
venv="${TRN_PY_VENV:-$root/target/py-package-venv}"
work="$(mktemp -d)"
trap 'rm -rf "$work" "$venv"' EXIT
t0=$SECONDS
python3 -m venv "$work/build"
"$work/build/bin/pip" install --quiet --disable-pip-version-check 'maturin>=1.9.4,<2'
"$work/build/bin/maturin" build --release --manifest-path python/Cargo.toml --out "$work/dist"
wheel=$(ls "$work"/dist/trn_softarm-*-cp39-abi3-*.whl)
t_wheel=$((SECONDS - t0))
rm -rf "$venv"
python3 -m venv "$venv"
# no cargo, no rustc: only the venv's programs
bare=(env "PATH=$venv/bin")
"${bare[@]}" python -c 'import shutil, sys; sys.exit(shutil.which("cargo") or shutil.which("rustc"))'
pip=("${bare[@]}" pip install --quiet --disable-pip-version-check)
"${pip[@]}" "$wheel" gymnasium
"${pip[@]}" "$wheel[live]" pytest 'mujoco>=3.2,<5' 'python-can>=4,<5'
t_install=$((SECONDS - t0 - t_wheel))
trials=15
cargo build --quiet --release --bin trn
"$root/target/release/trn" train --quiet --trials "$trials" --eval-targets 3 --grasps 2 \
    --snapshot-every 0 --candump "$work/train.log" --report "$work/train.json"
TRN_PYTHON="$venv/bin/python" "$root/target/release/trn" train --quiet --trials "$trials" \
    --eval-targets 3 --grasps 2 --snapshot-every 0 --rerun-save "$work/train.rrd"
# the Rust decoder's count, as a user runs it
"$root/target/release/trn" decode --summary "$work/train.log" | tee "$work/decode.txt"
grep -q ', 0 undecoded$' "$work/decode.txt"
(cd "$work" && "${bare[@]}" python "$root/python/tests/check_package.py" \
    --log "$work/train.log" --recording "$work/train.rrd" --trials "$trials")
# the environment's own tests (check_env on the registered id, pickling, termination, the
# native vector env against SyncVectorEnv, the options, the URDF and MJCF against the plant's
# kinematics with MuJoCo); SB3's test is skipped without it
(cd "$work" && "${bare[@]}" python -m pytest -q -p no:cacheprovider "$root/python/tests")
disk=$(du -sm "$venv" | cut -f1)
echo "python package: the wheel ${t_wheel} s, installed with gymnasium, rerun-sdk, pytest, mujoco ${t_install} s," \
    "all $((SECONDS - t0)) s; venv ${disk} MB"
