//! `trn`: train, evaluate and grasp with the TRN controller on the simulated SoftArm.
//! `cargo run --release --bin trn -- train` is the project's main job.

use clap::Parser;
use std::process::ExitCode;
use trn_sim::experiment::cli::{Cli, Cmd};
use trn_sim::experiment::run::{run_conformance, run_plan};
use trn_sim::experiment::schedule::Plan;
use trn_sim::experiment::{compare, lifelong, summary, sweep};

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Cmd::Train(a) => {
            let plan = Plan {
                resume: a.resume,
                ..a.common.plan(a.trials as usize)
            };
            run_plan(
                &a.common,
                plan,
                a.checkpoint_in.as_deref(),
                a.checkpoint_out.as_deref(),
                "train",
            )
            .and_then(|r| summary::print(&r, true))
        }
        Cmd::Eval(a) => {
            let plan = Plan {
                grasps: 0,
                ..a.common.plan(0)
            };
            run_plan(&a.common, plan, Some(&a.checkpoint_in), None, "eval")
                .and_then(|r| summary::print(&r, false))
        }
        Cmd::Grasp(a) => {
            let plan = Plan {
                eval_targets: 0,
                ..a.common.plan(0)
            };
            run_plan(&a.common, plan, Some(&a.checkpoint_in), None, "grasp")
                .and_then(|r| summary::print(&r, false))
        }
        Cmd::Compare(a) => compare::run(a),
        Cmd::Sweep(a) => sweep::run(a),
        Cmd::Lifelong(a) => lifelong::run(a),
        Cmd::Conformance(a) => run_conformance(&a.common).and_then(|r| summary::conformance(&r)),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("trn: error: {e}");
            ExitCode::FAILURE
        }
    }
}
