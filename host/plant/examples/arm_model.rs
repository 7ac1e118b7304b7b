//! Writes the arm's robot description from a plant configuration to standard output:
//!
//! ```text
//! cargo run --release -p trn-plant --example arm_model -- [--config NAME|FILE] [--mjcf]
//! ```
//!
//! URDF by default, MuJoCo's MJCF with `--mjcf`; the configuration is a built-in one
//! (`ideal`, `realistic`, `aging`, `realistic-aging`) or a TOML file (`host/plant/sim.toml`
//! documents it), the realistic plant when none is given. The chain and its frames:
//! `trn_plant::model`.
use std::path::PathBuf;
use std::process::ExitCode;

use trn_plant::{model, SimConfig};

const USAGE: &str = "usage: arm_model [--config NAME|FILE] [--mjcf]";

fn main() -> ExitCode {
    let mut config: Option<PathBuf> = None;
    let mut mjcf = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--mjcf" => mjcf = true,
            "--urdf" => mjcf = false,
            "--config" => match args.next() {
                Some(c) => config = Some(c.into()),
                None => {
                    eprintln!("arm_model: --config needs a name or a file\n{USAGE}");
                    return ExitCode::from(2);
                }
            },
            "-h" | "--help" => {
                println!("{USAGE}");
                return ExitCode::SUCCESS;
            }
            other => {
                eprintln!("arm_model: unknown argument {other:?}\n{USAGE}");
                return ExitCode::from(2);
            }
        }
    }
    match SimConfig::resolve(config.as_deref()) {
        Ok(cfg) => {
            print!(
                "{}",
                if mjcf {
                    model::mjcf(&cfg)
                } else {
                    model::urdf(&cfg)
                }
            );
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("arm_model: {e}");
            ExitCode::FAILURE
        }
    }
}
