#!/usr/bin/env python3
"""The fault matrix's figures (docs/robustness.md): `trn train` on the in-process bus with
each fault at 1 % and 5 %, on CAN 2.0 and CAN FD, against the fault-free run of the same seed
(seed 100, 60 training trials per network, 10 held-out targets, 10 grasps), and 20 % loss
(seed 101, 10 trials, 5 targets, 2 grasps). Writes docs/results/faults.md (then fill the docs
with scripts/readme_sections.py). About 20 s.

  python3 scripts/faults_table.py [--trn PATH] [--out FILE]
"""
import argparse
import json
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent


def train(trn, seed, plan, fd, faults, tmp):
    """One run's report, or the error it ended with."""
    report = pathlib.Path(tmp) / f"r-{seed}-{fd}-{faults or 'clean'}.json"
    cmd = [trn, "train", "--quiet", "--seed", str(seed), "--snapshot-every", "0",
           "--trials", str(plan[0]), "--eval-targets", str(plan[1]), "--grasps", str(plan[2]),
           "--report", str(report)]
    if fd:
        cmd.append("--fd")
    if faults:
        cmd += ["--faults", faults]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        return None, done.stderr.strip().splitlines()[-1] if done.stderr.strip() else f"exit {done.returncode}"
    return json.loads(report.read_text()), None


def scored(r):
    """What a run scores: the training curves, the held-out evaluation, the grasps, the failures."""
    return (r["stage1_error_px"], r["stage2_error_px"], r["eval"], r["grasp"], r["failures"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trn", default=str(ROOT / "target/release/trn"))
    ap.add_argument("--out", default=str(ROOT / "docs/results/faults.md"))
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for fd in (False, True):
            plan = (60, 10, 10)
            clean, err = train(a.trn, 100, plan, fd, None, tmp)
            if err:
                sys.exit(f"faults_table: the fault-free run failed: {err}")
            for fault in ("drop", "dup", "reorder", "corrupt", "truncate"):
                for rate in (0.01, 0.05):
                    spec = f"{fault}={rate}"
                    r, err = train(a.trn, 100, plan, fd, spec, tmp)
                    rows.append((spec, fd, plan, clean, r, err))
        for fd in (False, True):
            plan = (10, 5, 2)
            clean, err = train(a.trn, 101, plan, fd, None, tmp)
            r, err = train(a.trn, 101, plan, fd, "drop=0.2", tmp)
            rows.append(("drop=0.2", fd, plan, clean, r, err))
    out = ["| faults | framing | trials / targets / grasps (seed) | outcome | scores against the fault-free run | trial starts repeated by the runner | requests repeated by the controller | failed trials | wall s |",
           "|---|---|---|---|---|---|---|---|---|"]
    for spec, fd, plan, clean, r, err in rows:
        framing = "CAN FD" if fd else "CAN 2.0"
        seed = 101 if spec == "drop=0.2" else 100
        plan_s = f"{plan[0]} / {plan[1]} / {plan[2]} ({seed})"
        if err:
            out.append(f"| {spec} | {framing} | {plan_s} | error: {err} | | | | | |")
            continue
        same = scored(r) == scored(clean)
        curve_same = r["stage1_error_px"] == clean["stage1_error_px"] and r["stage2_error_px"] == clean["stage2_error_px"]
        verdict = "identical" if same else ("learning curves identical, evaluation differs" if curve_same else "differ")
        ctrl = (r["bus_stats"].get("controller") or {}).get("retries", "")
        out.append(f"| {spec} | {framing} | {plan_s} | completes | {verdict} | {r['bus_stats']['runner']['target_repeats']} | {ctrl} | {r['failed_trials']} | {r['wall_s']:.1f} |")
    pathlib.Path(a.out).write_text("\n".join(out) + "\n")
    print(f"faults_table: {len(rows)} rows written to {a.out}")


if __name__ == "__main__":
    main()
