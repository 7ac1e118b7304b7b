//! Diagnosis of failed grasps: one controller of `trn lifelong` (its snapshots' held-out
//! grasps), each failed grasp with the move it failed at, the lights the camera processor
//! saw, why its marker fill did not fill the hidden one, and what hid it (the simulator's
//! ground truth, for the diagnosis only). Tuning seeds only (1-99):
//! `SEED=1 CONFIG=realistic-aging TRIALS=1000 ARM=lifelong cargo run --release -p trn-studies --example grasp_failures`
//! Environment: SEED, CONFIG, TRIALS, EVERY (snapshot every), GRASPS (per snapshot),
//! TARGETS (per snapshot), ARM (frozen, project, lifelong, broyden), VERBOSE (every grasp).

use std::collections::BTreeMap;

use trn_bench::metrics::failure;
use trn_bench::records::{Phase, TrialRecord};
use trn_bench::{run, Observer};
use trn_plant::kinematics;
use trn_plant::nodes::{Capture, Sight};
use trn_plant::{Plant, PointStatus, SimConfig};
use trn_studies::lifelong::{arm_run, select, LifelongSpec};

fn env<T: std::str::FromStr>(k: &str, default: T) -> T {
    std::env::var(k)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(default)
}

/// The snapshot grasps of a run.
#[derive(Default)]
struct Grasps(Vec<TrialRecord>);

impl Observer for Grasps {
    fn trial(&mut self, r: &TrialRecord) {
        if matches!(r.phase, Phase::SnapshotGrasp(_)) {
            self.0.push(r.clone());
        }
    }
}

const MARKERS: [&str; 3] = ["p", "q", "c"];

fn status(s: Option<PointStatus>) -> &'static str {
    match s {
        None => "-",
        Some(PointStatus::Valid) => "ok",
        Some(PointStatus::OutOfView) => "out",
        Some(PointStatus::Occluded) => "occ",
        Some(PointStatus::NotDetected) => "nd",
        Some(PointStatus::Estimated) => "est",
    }
}

/// What hid each marker (p, q, c) from each camera at the capture (ground truth).
fn hiders(plant: &mut Plant, cap: &Capture, r: &TrialRecord) -> String {
    let cfg = plant.config().clone();
    let q = cap.pose.joint_angles_deg.map(f64::to_radians);
    let chain = kinematics::forward(&cfg, &q);
    let [p, ql] = kinematics::lights(&cfg, &chain.pose);
    plant.set_cylinder(r.target.cylinder);
    let mut out = vec![];
    for (m, x) in [p, ql, chain.pose.centre_mm].iter().enumerate() {
        for cam in 0..2 {
            if let Some(o) = plant.hidden_by(cam, x, &chain) {
                out.push(format!("{}{cam}:{}", MARKERS[m], o.name()));
            }
        }
    }
    out.join(" ")
}

/// Which markers the cylinder hides at the target's pre-grasp pose (ground truth).
fn hidden_at_target(plant: &mut Plant, r: &TrialRecord) -> String {
    let cfg = plant.config().clone();
    let q = r.target.pose.joint_angles_deg.map(f64::to_radians);
    let chain = kinematics::forward(&cfg, &q);
    let [p, ql] = kinematics::lights(&cfg, &chain.pose);
    plant.set_cylinder(r.target.cylinder);
    let mut out = vec![];
    for (m, x) in [p, ql, chain.pose.centre_mm].iter().enumerate() {
        for cam in 0..2 {
            if let Some(o) = plant.hidden_by(cam, x, &chain) {
                out.push(format!("{}{cam}:{}", MARKERS[m], o.name()));
            }
        }
    }
    out.join(" ")
}

fn describe(plant: &mut Plant, r: &TrialRecord, tally: &mut BTreeMap<String, usize>) {
    let Some(f) = failure(r) else { return };
    let stage1 = r
        .captures
        .iter()
        .filter(|c| matches!(c.sight, Sight::Lights { .. }))
        .count();
    let Some(last) = r.captures.last() else {
        println!("  trial {}: {} (no capture)", r.trial, f.reason());
        return;
    };
    let (stage, mv) = match last.sight {
        Sight::Lights { .. } => (1, stage1 - 1),
        Sight::Centre { .. } => (2, r.captures.len() - stage1 - 1),
    };
    let seen: Vec<String> = (0..6)
        .map(|k| format!("{}{}={}", MARKERS[k / 2], k % 2, status(last.fill.seen[k])))
        .collect();
    let why = last
        .fill
        .no_fit
        .map(|n| format!("{n:?}"))
        .unwrap_or_else(|| "-".into());
    let hid = hiders(plant, last, r);
    // where the gripper centre is against the cylinder centre, along the ray of a camera
    // that sees it and across it (mm, ground truth)
    let geometry = match (
        r.target.cylinder,
        (0..2).find(|&k| last.fill.seen[4 + k] == Some(PointStatus::Valid)),
    ) {
        (Some(cyl), Some(cam)) => {
            let cams = &plant.config().cameras;
            let eye = trn_plant::Vector3::from(cams[cam].position_mm);
            let c = last.pose.centre_mm;
            let ray = trn_plant::geometry::unit(&(c - eye));
            let e = c - cyl.centre;
            let along = e.dot(&ray);
            let across = (e - ray * along).norm();
            format!(
                "c-C {:.0} mm: along ray{cam} {along:.0}, across {across:.0}",
                e.norm()
            )
        }
        _ => "-".into(),
    };
    let at_target = hidden_at_target(plant, r);
    println!(
        "  trial {}: {} | stage {stage} move {mv} | seen {} (valid {}) | no fit: {why} | hidden: {hid} | at target: [{at_target}] | {geometry}",
        r.trial,
        f.reason(),
        seen.join(" "),
        last.fill.valid(),
    );
    let key = format!(
        "stage {stage}, {}, {}, {}",
        if mv == 0 { "coarse move" } else { "fine move" },
        last.fill
            .no_fit
            .map(|n| n.name())
            .unwrap_or("no fit needed"),
        if hid.contains("cylinder") {
            "cylinder hides"
        } else if hid.is_empty() {
            "nothing hides"
        } else {
            "arm hides"
        }
    );
    *tally.entry(key).or_default() += 1;
}

fn main() {
    let seed: u64 = env("SEED", 1);
    assert!((1..100).contains(&seed), "tuning seeds are 1-99");
    let config: String = env("CONFIG", "realistic-aging".to_string());
    let a = LifelongSpec {
        seed,
        trials: env("TRIALS", 1000),
        initial: 300,
        snapshot_every: env("EVERY", 250),
        snapshot_targets: env("TARGETS", 10),
        snapshot_grasps: env("GRASPS", 40),
        config: config.clone(),
        only: vec![env("ARM", "lifelong".to_string())],
        out: "/dev/null".into(),
    };
    let arm = select(&a.only).unwrap()[0];
    let spec = arm_run(&a, &arm).unwrap();
    let mut grasps = Grasps::default();
    let report = run::run(&spec, &mut grasps).unwrap();
    let cfg = SimConfig::resolve(Some(std::path::Path::new(&config))).unwrap();
    let mut plant = Plant::new(&cfg, 0).unwrap();
    let mut tally = BTreeMap::new();
    let verbose = std::env::var("VERBOSE").is_ok();
    for p in &report.learning_curve {
        let rs: Vec<&TrialRecord> = grasps
            .0
            .iter()
            .filter(|r| r.phase == Phase::SnapshotGrasp(p.trial))
            .collect();
        println!(
            "snapshot {}: grasps {:.1} % ({} unreachable) {:?}",
            p.trial,
            100.0 * p.grasp_success,
            p.grasps_unreachable,
            p.grasp_failures
        );
        // the stage-2 coarse move of every grasp: how far the gripper centre landed from the
        // cylinder centre (mm, ground truth) and whether the centre light was hidden there
        let mut coarse: Vec<(f64, bool)> = rs
            .iter()
            .filter_map(|r| {
                let cap = r
                    .captures
                    .iter()
                    .find(|c| matches!(c.sight, Sight::Centre { .. }))?;
                let cyl = r.target.cylinder?;
                let d = (cap.pose.centre_mm - cyl.centre).norm();
                let hidden = cap.fill.seen[4..]
                    .iter()
                    .any(|s| *s != Some(PointStatus::Valid));
                Some((d, hidden))
            })
            .collect();
        coarse.sort_by(|a, b| a.0.total_cmp(&b.0));
        if !coarse.is_empty() {
            let q = |f: f64| coarse[((coarse.len() - 1) as f64 * f) as usize].0;
            println!(
                "  stage-2 coarse move lands {:.0} / {:.0} / {:.0} mm from the cylinder centre (median / 90 % / max), centre hidden in {} of {}",
                q(0.5), q(0.9), q(1.0),
                coarse.iter().filter(|c| c.1).count(),
                coarse.len()
            );
        }
        let trace: Option<u32> = std::env::var("TRACE").ok().and_then(|s| s.parse().ok());
        for r in rs.iter().filter(|r| Some(r.trial) == trace) {
            for cap in &r.captures {
                let (noisy, truth): (Vec<_>, Vec<_>) = match cap.sight {
                    Sight::Lights { noisy, truth } => {
                        (noisy.points.to_vec(), truth.points.to_vec())
                    }
                    Sight::Centre { noisy, truth } => {
                        (noisy.points.to_vec(), truth.points.to_vec())
                    }
                };
                let cells: Vec<String> = noisy
                    .iter()
                    .zip(&truth)
                    .map(|(a, t)| {
                        format!(
                            "{}({:.1},{:.1} off {:.1})",
                            status(Some(a.status)),
                            a.x,
                            a.y,
                            (a.x - t.x).hypot(a.y - t.y)
                        )
                    })
                    .collect();
                let cyl = r
                    .target
                    .cylinder
                    .map(|c| (cap.pose.centre_mm - c.centre).norm())
                    .unwrap_or(f64::NAN);
                println!(
                    "    TRACE {} | c-C {:.0} mm | seen {:?}",
                    cells.join(" "),
                    cyl,
                    cap.fill.seen.map(status)
                );
            }
            println!(
                "    TRACE target v {:?} c {:?} reports {:?}",
                r.target.v, r.target.c, r.reports
            );
        }
        for r in rs {
            if failure(r).is_some() {
                describe(&mut plant, r, &mut tally);
            } else if verbose || r.grasp.is_some_and(|g| !g.success) {
                println!(
                    "  trial {}: grasp {:?} at target: [{}]",
                    r.trial,
                    r.grasp.map(|g| (g.success, g.distance_mm)),
                    hidden_at_target(&mut plant, r)
                );
            }
        }
    }
    // every estimated reading of the grasps against where the light projects
    let mut errs: Vec<f64> = vec![];
    for r in &grasps.0 {
        for cap in &r.captures {
            let pairs: Vec<(trn_plant::PixelReading, trn_plant::PixelReading)> = match cap.sight {
                Sight::Lights { noisy, truth } => {
                    noisy.points.into_iter().zip(truth.points).collect()
                }
                Sight::Centre { noisy, truth } => {
                    noisy.points.into_iter().zip(truth.points).collect()
                }
            };
            for (a, t) in pairs {
                if a.status == PointStatus::Estimated {
                    let e = (a.x - t.x).hypot(a.y - t.y);
                    if e > 100.0 {
                        println!(
                            "  far estimate {e:.0} px: trial {} seen {:?}",
                            r.trial,
                            cap.fill.seen.map(status)
                        );
                    }
                    errs.push(e);
                }
            }
        }
    }
    errs.sort_by(f64::total_cmp);
    if !errs.is_empty() {
        let q = |f: f64| errs[((errs.len() - 1) as f64 * f) as usize];
        println!(
            "estimated readings in grasps: {}, error {:.1} / {:.1} / {:.1} px (median / 90 % / max)",
            errs.len(),
            q(0.5),
            q(0.9),
            q(1.0)
        );
    }
    println!("aborted grasps by stage, move, fill and occluder:");
    for (k, n) in tally {
        println!("  {n:4}  {k}");
    }
}
