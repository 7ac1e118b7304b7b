//! The detector's centroid accuracy on rendered frames against the Cramér-Rao bound, written
//! to docs/results/vision.md (or the path given):
//! `cargo run --release -p trn-vision --example accuracy [-- OUT.md]`

use std::fmt::Write as _;

use trn_vision::accuracy::{cramer_rao_px, measure, Blob, MEASURE_FRAME_PX};
use trn_vision::{Centroid, Sensor, VisionError};

/// Frames per row of the tables.
const FRAMES: usize = 2_000;
/// The seed of every row.
const SEED: u64 = 1;

fn main() {
    let out = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "docs/results/vision.md".to_string());
    match report() {
        Ok(text) => {
            print!("{text}");
            if let Err(e) = std::fs::write(&out, &text) {
                eprintln!("cannot write {out}: {e}");
                std::process::exit(1);
            }
        }
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1);
        }
    }
}

fn report() -> Result<String, VisionError> {
    let sensor = Sensor::machine_vision(1024, 768);
    let nominal = Blob::nominal();
    let mut t = String::new();
    let w = &mut t;
    let _ = writeln!(w, "```");
    let _ = writeln!(w, "Centroid accuracy of the camera processor on rendered frames (`cargo run --release -p trn-vision --example accuracy`)");
    let _ = writeln!(w, "{}", "=".repeat(100));
    let _ = writeln!(
        w,
        "sensor: 8-bit, {} e-/DN, black level {} DN, read noise {} e-, stray light {} e-/px, full well {} e-",
        1.0 / sensor.gain_dn_per_e,
        sensor.offset_dn,
        sensor.read_noise_e,
        sensor.stray_e,
        sensor.full_well_e
    );
    let _ = writeln!(
        w,
        "{FRAMES} frames per row ({MEASURE_FRAME_PX} x {MEASURE_FRAME_PX} px around the blob), seed {SEED}, one still blob at a uniformly random sub-pixel position"
    );
    let _ = writeln!(w, "bound: Cramer-Rao, per axis, x0 y0 electrons and background unknown, averaged over the position in the pixel;");
    let _ = writeln!(
        w,
        "       an estimator at the bound has a median distance error of 1.177 x the bound"
    );
    let _ = writeln!(w, "{}", "-".repeat(100));
    let _ = writeln!(
        w,
        "nominal blob: sigma {} px, {} e- ({} px per axis bound)",
        nominal.sigma_px,
        nominal.electrons,
        fmt(cramer_rao_px(&sensor, &nominal)?)
    );
    let _ = writeln!(
        w,
        "{:<44}{:>10}{:>10}{:>10}{:>12}{:>14}",
        "centroid", "p50 px", "p95 px", "rms/axis", "missed", "p50 / bound"
    );
    for (name, c) in [
        (
            "background-subtracted, weighted (detector)",
            Centroid::Weighted,
        ),
        ("weighted, background not subtracted", Centroid::WeightedRaw),
        ("unweighted (lit pixels' mean)", Centroid::Unweighted),
    ] {
        let a = measure(&sensor, &nominal, c, FRAMES, SEED)?;
        let _ = writeln!(
            w,
            "{:<44}{:>10}{:>10}{:>10}{:>12}{:>14.2}",
            name,
            fmt(a.p50_px),
            fmt(a.p95_px),
            fmt(a.rms_axis_px),
            a.missed,
            a.p50_ratio()
        );
    }
    let _ = writeln!(w, "{}", "-".repeat(100));
    let _ = writeln!(w, "the detector over blob sizes and brightness (peak: the brightest pixel's DN when centred; 255 saturates)");
    let _ = writeln!(
        w,
        "{:>10}{:>12}{:>8}{:>10}{:>10}{:>10}{:>10}{:>12}{:>14}",
        "sigma px",
        "electrons",
        "peak",
        "bound px",
        "p50 px",
        "p95 px",
        "rms/axis",
        "missed",
        "p50 / bound"
    );
    for sigma in [0.8, 1.3, 2.0] {
        for electrons in [3_000.0, 10_000.0, 30_000.0] {
            let blob = Blob {
                sigma_px: sigma,
                electrons,
            };
            let a = measure(&sensor, &blob, Centroid::Weighted, FRAMES, SEED)?;
            let f = trn_vision::Emitter::with_peak([0.0; 2], sigma, 1.0).electrons;
            let peak = sensor.mean_dn(electrons / f);
            let _ = writeln!(
                w,
                "{:>10}{:>12}{:>8.0}{:>10}{:>10}{:>10}{:>10}{:>12}{:>14.2}",
                sigma,
                electrons,
                peak.min(255.0),
                fmt(a.bound_px),
                fmt(a.p50_px),
                fmt(a.p95_px),
                fmt(a.rms_axis_px),
                a.missed,
                a.p50_ratio()
            );
        }
    }
    let _ = writeln!(w, "```");
    Ok(t)
}

fn fmt(v: f64) -> String {
    format!("{v:.4}")
}
