"""The learning-free references from Python (``Controller("model" | "oracle", env=...)``) and
the baseline table's script (python/examples/baselines.py) on a small run.

    pytest python/tests/test_baselines.py
"""

import json
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import trn_softarm
from trn_softarm import Controller, SoftArmEnv, run_episode
from trn_softarm._native import Ctrl

SCRIPT = pathlib.Path(__file__).resolve().parents[1] / "examples" / "baselines.py"


def final_errors(env, ctrl, seeds):
    out = []
    for s in seeds:
        infos = run_episode(env, ctrl, seed=s, learn=False)
        out.append((infos[-1]["error_true_px"], len(infos)))
    return out


@pytest.mark.parametrize("stage", [1, 2])
def test_the_oracle_lands_where_the_model_needs_fine_moves(stage):
    """The oracle (an exact copy of the arm at each decision) ends its coarse move within
    the TRN's tolerance nearly always; the calibrated model (no hysteresis, no drift) needs
    fine moves. Fails if the oracle is not handed the arm's plant as it is (a stale copy
    would miss by the arm's own moves), or if the model were given the true state."""
    env = SoftArmEnv(config="realistic", stage=stage, max_moves=7, tolerance_px=0.0)
    seeds = range(500, 512)
    oracle = final_errors(env, Controller("oracle", env=env), seeds)
    model = final_errors(env, Controller("model", env=env), seeds)
    assert np.mean([m for _, m in oracle]) < 1.5, oracle
    assert np.median([e for e, _ in oracle]) < 1.2, oracle
    assert np.mean([m for _, m in model]) > 3.0, model
    coarse = Controller("model", env=env)
    run_episode(env, coarse, seed=500, learn=False, fine_moves=2)
    assert coarse.outcome[f"stage{stage}"]["coarse_error_px"] > 10.0, coarse.outcome


@pytest.mark.parametrize("stage", [1, 2])
def test_the_tolerance_is_the_one_a_trial_stops_at(stage):
    """``Controller.tolerance_px`` is the tolerance a trial that does not learn reports (the
    baseline table measures success against it): the preset's, per stage, for every law.
    Fails if it read the other stage's value or a learning schedule's."""
    env = SoftArmEnv(config="ideal", stage=stage)
    trn = Controller("trn", stage=stage, seed=1)
    run_episode(env, trn, seed=3, learn=False, fine_moves=0)
    assert trn.tolerance_px == trn.outcome[f"stage{stage}"]["tolerance_px"] == (1.5 if stage == 1 else 1.0)
    assert Controller("trn", stage=stage, preset="paper").tolerance_px == pytest.approx(0.1)
    assert Controller("model", env=env).tolerance_px == trn.tolerance_px
    with pytest.raises(ValueError, match="stage 3"):
        trn._ctrl.mature_tolerance_px(3)


def test_the_references_need_an_arm():
    env = SoftArmEnv(stage=2)
    with pytest.raises(ValueError, match="pass env="):
        Controller("oracle")
    with pytest.raises(ValueError, match="stage 1: the environment is of stage 2"):
        Controller("model", stage=1, env=env)
    with pytest.raises(ValueError, match="no single arm"):
        Controller("model", env=trn_softarm.SoftArmVectorEnv(num_envs=2))
    with pytest.raises(ValueError, match="pass the environment's arm"):
        Ctrl("oracle")
    with pytest.raises(ValueError, match="no law"):
        Ctrl("pid")
    # the oracle asked to decide without the arm it models
    ctrl = Ctrl("oracle", arm=env.unwrapped._arm)
    with pytest.raises(ValueError, match="arm="):
        ctrl.begin(2, [500.0, 400.0, 520.0, 380.0])
    assert ctrl.law == "oracle" and not ctrl.busy


def test_the_baseline_script_writes_its_table(tmp_path):
    out = tmp_path / "b.md"
    subprocess.run(
        [sys.executable, str(SCRIPT), "--test", "12", "--train", "150", "--rl-steps", "0", "--out", str(out)],
        check=True,
        capture_output=True,
    )
    table = out.read_text()
    figures = json.loads(out.with_suffix(".json").read_text())
    assert "No reinforcement-learning rows in this run: --rl-steps 0." in table
    for stage in ("1", "2"):
        rows = {r["agent"].split(" (")[0]: r for r in figures["stages"][stage]["rows"]}
        assert set(rows) == {"TRN", "Broyden servo", "calibrated model", "oracle", "random pressures"}
        assert all(r["episodes"] == 12 for r in rows.values())
        assert rows["oracle"]["median_px"] < rows["random pressures"]["median_px"] / 20
        assert rows["oracle"]["success"] >= 0.75, rows["oracle"]
        assert rows["random pressures"]["moves"] == 7.0
        assert rows["TRN"]["moves"] < 7.0
        assert f"| {rows['oracle']['agent']} | " in table


def test_the_baseline_script_refuses_meaningless_counts(tmp_path):
    r = subprocess.run(
        [sys.executable, str(SCRIPT), "--test", "0", "--out", str(tmp_path / "b.md")],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 2 and "--test 0" in r.stderr
    assert not (tmp_path / "b.md").exists()
