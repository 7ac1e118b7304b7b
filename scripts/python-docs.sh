#!/usr/bin/env bash
# Regenerates docs/python/ (the table and figures of python/examples/compare_agents.py, the
# baseline table of python/examples/baselines.py):
#   bash scripts/python-docs.sh
# In a venv ($TRN_PY_VENV, else target/py-docs-venv, created and kept) with the package,
# Gymnasium and matplotlib installed. About a minute once the wheel is built, without the
# baseline table's PPO rows; with stable-baselines3 in the venv (it pulls torch, about 3 GB)
# the PPO rows take about 20 minutes of one core.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
venv="${TRN_PY_VENV:-$root/target/py-docs-venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check ./python gymnasium matplotlib
"$venv/bin/python" python/examples/compare_agents.py --out docs/python
"$venv/bin/python" python/examples/baselines.py --out docs/python/baselines.md
echo "wrote docs/python/compare.md, learning.png, cameras.png, baselines.md, baselines.json"
