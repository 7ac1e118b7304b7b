//! A short run's learning curve and figures against a recording: any change of behaviour
//! (learning rules, plant, targets, scoring, the bus's effect on the run) shows here bit for
//! bit. The recording `fixtures/curve-seed3.json` was made with the code before the
//! experiment layer was restructured (issue 10), and is re-recorded only when behaviour is
//! changed on purpose:
//! `TRN_BLESS=1 cargo test --release -p trn-bench --test golden_curve` (then say why in the
//! commit).

use std::path::PathBuf;
use trn_bench::schedule::Plan;
use trn_bench::{run, Command, RunSpec};

fn fixture() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/curve-seed3.json")
}

#[test]
fn a_short_run_reproduces_the_recorded_curve_bit_for_bit() {
    // the plant the recording was made on (the runs' default is the realistic one)
    let mut spec = RunSpec::new(Command::Train, 3)
        .with_plant(Some("ideal"))
        .unwrap();
    // snapshots every 10 trials: they must not change the training curve
    spec.plan = Plan {
        snapshot_every: 10,
        snapshot_targets: 5,
        ..Plan::new(40, 10, 4)
    };
    let r = run::run_quietly(&spec).unwrap();
    let now = serde_json::json!({
        "seed": r.seed,
        "trials": r.trials,
        "stage1_error_px": r.stage1_error_px,
        "stage2_error_px": r.stage2_error_px,
        "combined_error_px": r.combined_error_px,
        "fine_moves": r.fine_moves,
        "fine_moves_stage2": r.fine_moves_stage2,
        "final_error_px": r.final_error_px,
        "final_error_true_px": r.final_error_true_px,
        "noise_floor_px": r.noise_floor_px,
        "grasp_success_rate": r.grasp_success_rate,
        "error_mm": r.error_mm,
        "error_deg": r.error_deg,
        "eval_stage1_error_by_move_px": r.eval.stage1_error_by_move_px,
        "eval_stage2_error_by_move_px": r.eval.stage2_error_by_move_px,
        "deployment_combined_true_px": r.deployment.combined_true_px,
        "deployment_combined_measured_px": r.deployment.combined_measured_px,
        "snapshot_combined_true_px": r.learning_curve.iter().flat_map(|p| p.combined_true_px.clone()).collect::<Vec<_>>(),
    });
    if std::env::var_os("TRN_BLESS").is_some() {
        std::fs::write(fixture(), serde_json::to_string_pretty(&now).unwrap()).unwrap();
        return;
    }
    let recorded: serde_json::Value =
        serde_json::from_slice(&std::fs::read(fixture()).unwrap()).unwrap();
    let obj = recorded.as_object().unwrap();
    assert_eq!(obj.len(), now.as_object().unwrap().len());
    for (key, want) in obj {
        // compared as f32 bit patterns: the JSON holds each f32's shortest exact form
        let bits = |v: &serde_json::Value| -> Vec<u32> {
            match v {
                serde_json::Value::Array(a) => a
                    .iter()
                    .map(|x| (x.as_f64().unwrap() as f32).to_bits())
                    .collect(),
                x => vec![(x.as_f64().unwrap() as f32).to_bits()],
            }
        };
        assert_eq!(
            bits(&now[key]),
            bits(want),
            "{key} differs from the recording"
        );
    }
}
