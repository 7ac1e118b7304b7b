//! Replays a recording through the camera processor (the one `camera-node` runs, without the
//! bus) and sets what it reports beside where the lights truly are (the manifest's `truth`).
//!
//! `cargo run --release -p trn-camera --example replay -- [DIR] [--out FILE]`: DIR defaults
//! to the test suite's recording (host/camera/tests/recording); the table goes to FILE
//! (docs/results/camera-node.md for the suite's recording) or to stdout.

use std::path::{Path, PathBuf};
use std::time::Instant;

use trn_camera::{Calibration, Processor, Recording};
use trn_protocol::PointStatus;

fn main() -> Result<(), String> {
    let mut args = std::env::args().skip(1);
    let mut dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/recording");
    let mut out: Option<PathBuf> = None;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--out" => out = Some(args.next().ok_or("--out needs a file")?.into()),
            _ if !a.starts_with("--") => dir = a.into(),
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    let recording = Recording::open(&dir).map_err(|e| e.to_string())?;
    let m = recording.manifest().clone();
    let processor = Processor::for_recording(&m).map_err(|e| e.to_string())?;
    let tolerance = processor.calibration().map(Calibration::tolerance_px);
    let (mut clear, mut partial) = (Vec::new(), Vec::new());
    let (mut hidden_refused, mut hidden_valid, mut clear_refused) = (0, 0, 0);
    let (mut inconsistent, mut frames, mut seconds) = (0, 0, Vec::new());
    let mut size = (0, 0);
    for (i, c) in m.captures.iter().enumerate() {
        if c.truth.is_empty() {
            return Err(format!(
                "capture {i} has no truth to hold the readings against"
            ));
        }
        let f = recording.frames(i).map_err(|e| e.to_string())?;
        size = f.cameras[0][0].dimensions();
        frames += f.cameras[0].len() + f.cameras[1].len();
        let t = Instant::now();
        let o = processor.observe(&f).map_err(|e| e.to_string())?;
        seconds.push(t.elapsed().as_secs_f64());
        inconsistent += o.inconsistent;
        for (p, t) in o.points.iter().zip(&c.truth) {
            let e = (p.x as f64 - t.x).hypot(p.y as f64 - t.y);
            match (t.status, p.status) {
                (PointStatus::Valid, PointStatus::Valid) => clear.push(e),
                (PointStatus::Valid, _) => clear_refused += 1,
                (PointStatus::Occluded, PointStatus::Valid) => partial.push(e),
                (_, PointStatus::Valid) => hidden_valid += 1,
                _ => hidden_refused += 1,
            }
        }
    }
    clear.sort_by(f64::total_cmp);
    partial.sort_by(f64::total_cmp);
    seconds.sort_by(f64::total_cmp);
    let q = |v: &[f64], f: f64| {
        v.get(((v.len().max(1) - 1) as f64 * f).round() as usize)
            .map_or("-".to_string(), |x| format!("{x:.4}"))
    };
    // the folder as named from the repository's root, when it lies in it
    let root = std::fs::canonicalize(Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."));
    let full = std::fs::canonicalize(&dir).unwrap_or(dir.clone());
    let name = root
        .ok()
        .and_then(|r| full.strip_prefix(r).ok().map(Path::to_path_buf))
        .unwrap_or(full)
        .display()
        .to_string();
    let mut s = String::from("```\n");
    s += "A recording replayed through the camera node's processor (`cargo run --release -p trn-camera --example replay -- --out docs/results/camera-node.md`)\n";
    s += &"=".repeat(100);
    s += "\n";
    s += &format!(
        "recording: {name}, {} captures, {frames} frames of {} x {} px, gate {} px, stereo check {}\n",
        m.captures.len(),
        size.0,
        size.1,
        m.gate_px,
        tolerance.map_or("off".into(), |t| format!("within {t:.2} px"))
    );
    s += "truth: where each light projects; in clear view, or hidden in part or whole by a link (something nearer covers its centre or a point 2 deviations of its spot away), or outside the frame\n";
    s += &"-".repeat(100);
    s += "\n";
    s += &format!(
        "{:<44}{:>8}{:>10}{:>10}{:>10}\n",
        "lights (one per camera)", "count", "p50 px", "p95 px", "max px"
    );
    s += &format!(
        "{:<44}{:>8}{:>10}{:>10}{:>10}\n",
        "in clear view, reported valid",
        clear.len(),
        q(&clear, 0.5),
        q(&clear, 0.95),
        q(&clear, 1.0)
    );
    s += &format!(
        "{:<44}{:>8}\n",
        "in clear view, reported not detected", clear_refused
    );
    s += &format!(
        "{:<44}{:>8}{:>10}{:>10}{:>10}\n",
        "hidden in part, reported valid",
        partial.len(),
        q(&partial, 0.5),
        q(&partial, 0.95),
        q(&partial, 1.0)
    );
    s += &format!(
        "{:<44}{:>8}\n",
        "hidden or outside, reported not detected", hidden_refused
    );
    s += &format!(
        "{:<44}{:>8}\n",
        "hidden or outside, reported valid", hidden_valid
    );
    s += &format!(
        "{:<44}{:>8}\n",
        "lights refused by the stereo check", inconsistent
    );
    s += &"-".repeat(100);
    s += "\n";
    s += &format!(
        "processing per capture (both cameras, one core, whole frames): median {:.1} ms, max {:.1} ms\n",
        1e3 * seconds[seconds.len() / 2],
        1e3 * seconds[seconds.len() - 1]
    );
    s += "```\n";
    match out {
        Some(path) => std::fs::write(&path, s).map_err(|e| format!("{}: {e}", path.display()))?,
        None => print!("{s}"),
    }
    Ok(())
}
