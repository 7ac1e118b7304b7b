//! `trn`: train, evaluate and grasp with the TRN controller on the simulated SoftArm.
//! `cargo run --release --bin trn -- train` is the project's main job.

use clap::Parser;
use std::process::ExitCode;
use trn_sim::experiment::cli::{Cli, Cmd};
use trn_sim::experiment::run::run_plan;
use trn_sim::experiment::schedule::Plan;
use trn_sim::experiment::{compare, summary};

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Cmd::Train(a) => {
            let plan = Plan {
                trials: a.trials,
                eval_targets: a.common.eval_targets,
                grasps: a.common.grasps,
            };
            run_plan(
                &a.common,
                plan,
                a.checkpoint_in.as_deref(),
                a.checkpoint_out.as_deref(),
                "train",
            )
            .map(|r| summary::print(&r, true))
        }
        Cmd::Eval(a) => {
            let plan = Plan {
                trials: 0,
                eval_targets: a.common.eval_targets,
                grasps: 0,
            };
            run_plan(&a.common, plan, Some(&a.checkpoint_in), None, "eval")
                .map(|r| summary::print(&r, false))
        }
        Cmd::Grasp(a) => {
            let plan = Plan {
                trials: 0,
                eval_targets: 0,
                grasps: a.common.grasps,
            };
            run_plan(&a.common, plan, Some(&a.checkpoint_in), None, "grasp")
                .map(|r| summary::print(&r, false))
        }
        Cmd::Compare(a) => compare::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("trn: error: {e}");
            ExitCode::FAILURE
        }
    }
}
