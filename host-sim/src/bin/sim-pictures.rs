//! `sim-pictures`: writes `hysteresis.png` (joint 1's loop, like Fig. 8.2) and `arm.png`
//! (the arm, a cylinder and both camera images) for a person to check.

use clap::Parser;
use rand_core::SeedableRng;
use std::path::PathBuf;
use std::process::ExitCode;
use trn_sim::plant::{picture, Plant, SimConfig};

/// Pictures of the simulated plant.
#[derive(Debug, Parser)]
struct Args {
    /// Output directory.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// Simulator configuration (TOML).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Seed of the pose drawn.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

fn run(a: &Args) -> Result<(), Box<dyn std::error::Error>> {
    let cfg = match &a.config {
        Some(p) => SimConfig::load(p)?,
        None => SimConfig::default(),
    };
    std::fs::create_dir_all(&a.out)?;
    picture::hysteresis(&cfg, 0, &a.out.join("hysteresis.png"))?;
    let mut plant = Plant::new(&cfg, a.seed)?;
    plant.move_to_random_joints(
        &mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(a.seed),
        5,
    );
    picture::arm(&mut plant, &a.out.join("arm.png"))?;
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
