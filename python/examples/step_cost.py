"""A fixed amount of the arm's work, for instruction counts that do not depend on the load:

    valgrind --tool=callgrind --callgrind-out-file=/dev/null \
        python python/examples/step_cost.py STEPS RESETS [DT_S]

``Arm.step`` STEPS times (random pressures, seeded) and ``Arm.reset`` RESETS times on the
realistic plant (``DT_S``: the ``dt_s`` option); the difference of two runs' "Collected"
counts over the difference of their STEPS (or RESETS) is the cost of one.
``bash scripts/step_cost.sh`` does exactly that and writes docs/python/step-cost.md.
"""

import sys

import numpy as np

from trn_softarm._native import Arm

steps, resets = int(sys.argv[1]), int(sys.argv[2])
dt = float(sys.argv[3]) if len(sys.argv) > 3 else None
rng = np.random.default_rng(0)
actions = [rng.uniform(-1, 1, 5).tolist() for _ in range(steps)]
arm = Arm("realistic", 1, dt)
arm.reset(1)
for a in actions:
    arm.step(a)
for k in range(resets):
    arm.reset(k)
