//! `sim-pictures`: writes `hysteresis.png` (joint 1's loop, like Fig. 8.2) and `arm.png`
//! (the arm, a cylinder and both camera images) for a person to check.

use clap::Parser;
use rand_core::SeedableRng;
use std::path::PathBuf;
use std::process::ExitCode;
use trn_plant::{Plant, SimConfig};
use trn_sim::picture;

/// `sim-pictures`: pictures of the simulated plant for a person to check: joint 1's
/// hysteresis loop (like the chapter's Fig. 8.2) and the arm with a cylinder beside both
/// camera images.
#[derive(Debug, Parser)]
#[command(name = "sim-pictures", version)]
struct Args {
    /// Output directory.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Simulator configuration: a built-in name (`ideal`, `realistic`, `aging`, `realistic-aging`) or a TOML
    /// file (default: the ideal plant).
    #[arg(long)]
    config: Option<String>,
    /// Seed of the pose drawn.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

fn run(a: &Args) -> Result<(), String> {
    let cfg = match &a.config {
        Some(p) => SimConfig::resolve(Some(std::path::Path::new(p))).map_err(|e| e.to_string())?,
        None => SimConfig::default(),
    };
    trn_bench::fsio::create_folder(&a.out).map_err(|e| e.to_string())?;
    let named =
        |file: &str, e: &dyn std::fmt::Display| format!("{}: {e}", a.out.join(file).display());
    picture::hysteresis(&cfg, 0, &a.out.join("hysteresis.png"))
        .map_err(|e| named("hysteresis.png", &e))?;
    let mut plant = Plant::new(&cfg, a.seed).map_err(|e| e.to_string())?;
    plant.move_to_random_joints(
        &mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(a.seed),
        5,
    );
    picture::arm(&mut plant, &a.out.join("arm.png")).map_err(|e| named("arm.png", &e))?;
    println!("wrote {0}/hysteresis.png and {0}/arm.png", a.out.display());
    Ok(())
}

fn main() -> ExitCode {
    match run(&Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("sim-pictures: error: {e}");
            ExitCode::FAILURE
        }
    }
}
