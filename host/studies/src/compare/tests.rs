//! The comparison's unit tests: the built-in study file describes exactly the runs of the
//! table it replaced, and the table gains its ratio to the oracle when the oracle has a row.

use super::*;
use crate::study::file::Overrides;
use trn_bench::spec::ControllerChoice;
use trn_controller::presets::{Ablation, Preset};

/// The table of the comparison before it became a study file (name, preset, ablation,
/// law, training trials at 300) and the oracle's row added since: `studies/compare.toml`
/// must describe exactly these runs, so the published figures stand.
const BEFORE: [(&str, Preset, Ablation, ControllerChoice, usize); 9] = [
    (
        "project",
        Preset::Project,
        Ablation::None,
        ControllerChoice::Trn,
        300,
    ),
    (
        "paper",
        Preset::Paper,
        Ablation::None,
        ControllerChoice::Trn,
        300,
    ),
    (
        "project, no-neighbourhood (plain VQ table)",
        Preset::Project,
        Ablation::NoNeighbourhood,
        ControllerChoice::Trn,
        300,
    ),
    (
        "project, no-priming",
        Preset::Project,
        Ablation::NoPriming,
        ControllerChoice::Trn,
        300,
    ),
    (
        "project, no-fine",
        Preset::Project,
        Ablation::NoFine,
        ControllerChoice::Trn,
        300,
    ),
    (
        "project, no-trial-secant",
        Preset::Project,
        Ablation::NoTrialSecant,
        ControllerChoice::Trn,
        300,
    ),
    (
        "Broyden servo (no training)",
        Preset::Project,
        Ablation::None,
        ControllerChoice::Broyden,
        0,
    ),
    (
        "nominal inverse kinematics (calibrated model, no learning)",
        Preset::Project,
        Ablation::None,
        ControllerChoice::Model,
        0,
    ),
    (
        "oracle (exact copy of the plant: the physical limit)",
        Preset::Project,
        Ablation::None,
        ControllerChoice::Oracle,
        0,
    ),
];

#[test]
fn the_study_file_is_the_table_it_replaced() {
    let spec = CompareSpec {
        study: None,
        over: Overrides::default(),
        out: std::env::temp_dir(),
    };
    let s = spec.study().unwrap();
    assert_eq!(s.jobs.len(), BEFORE.len() * 10);
    for (i, (name, preset, ablation, law, trials)) in BEFORE.into_iter().enumerate() {
        for (k, seed) in (100..110).enumerate() {
            let j = &s.jobs[i * 10 + k];
            assert_eq!(j.row.name, name);
            let mut old = trn_bench::RunSpec::new(trn_bench::Command::Train, seed);
            old.profile = trn_bench::Profile {
                preset,
                ablation,
                law,
            };
            old.plan = trn_bench::schedule::Plan::new(trials, 100, 50);
            let mut new = j.spec.clone();
            assert_eq!(new.plant_name.take().as_deref(), Some("realistic"));
            assert_eq!(new, old, "{name} seed {seed}");
        }
    }
    // --project-only is --configs project; --eval-targets and --grasps size the base
    let over = Overrides {
        configs: vec!["project".into(), "broyden".into()],
        seeds: Some(2),
        eval_targets: Some(7),
        grasps: Some(3),
        trials: Some(40),
        ..Overrides::default()
    };
    let s = CompareSpec { over, ..spec }.study().unwrap();
    let rows: Vec<(&str, u64, usize, usize, usize)> = s
        .jobs
        .iter()
        .map(|j| {
            (
                j.row.key.as_str(),
                j.spec.seed,
                j.spec.plan.trials,
                j.spec.plan.eval_targets,
                j.spec.plan.grasps,
            )
        })
        .collect();
    assert_eq!(
        rows,
        [
            ("project", 100, 40, 7, 3),
            ("project", 101, 40, 7, 3),
            ("broyden", 100, 0, 7, 3),
            ("broyden", 101, 0, 7, 3)
        ]
    );
}

fn row(name: &str, law: &str, px_: f32, moves: f32, grasps: f32) -> Row {
    let hi = |v: f32| Spread::of(&[v], Worse::Higher);
    Row {
        name: name.into(),
        law: law.into(),
        seeds: vec![],
        summary: Summary {
            combined_true_px: vec![hi(10.0 * px_), hi(2.0 * px_), hi(px_)],
            measured_after_budget_px: hi(px_),
            noise_floor_px: hi(1.0),
            moves_to_2px: hi(moves),
            fine_moves_stop_rule: hi(moves),
            sim_s_per_target_stop_rule: hi(moves),
            final_true_px_stop_rule: hi(px_ / 2.0),
            grasp_success: Spread::of(&[grasps], Worse::Lower),
            measured_after_budget_by_target_px: Tail::of(&[px_]),
            measured_p95_over_floor: hi(px_),
            failed_trials: 0,
        },
    }
}

#[test]
fn the_table_has_a_ratio_to_the_oracle_when_it_has_its_row() {
    let rows = [
        row("net", "trn", 3.0, 4.0, 0.8),
        row("limit", "oracle", 1.5, 0.5, 1.0),
    ];
    let t = table(&rows);
    let ratios = t
        .split("As a ratio to the oracle")
        .nth(1)
        .expect("ratio table");
    let net = ratios.lines().find(|l| l.starts_with("| net |")).unwrap();
    assert_eq!(
        net,
        "| net | 2.00 | 2.00 | 2.00 | 2.00 (2.00) | 2.00 | 8.00 | 2.00 | 8.00 | 0.80 |"
    );
    assert!(ratios.contains(
        "| limit | 1.00 | 1.00 | 1.00 | 1.00 (1.00) | 1.00 | 1.00 | 1.00 | 1.00 | 1.00 |"
    ));
    assert!(!table(&rows[..1]).contains("As a ratio"));
}
