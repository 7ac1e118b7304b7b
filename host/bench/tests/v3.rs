//! A controller of protocol version 3 (the project's node in its version-3 mode,
//! `NodeConfig::HOST_V3`: the guard's and the tables' kinds, their error codes and the point
//! status `Estimated` are unknown to it) served by this runner as version 3 (SPEC.md,
//! "Versions"): `trn train` runs its trials as against a version-4 node, with no table
//! traffic, and says the controller speaks v3; a run that needs the tables over the bus is
//! refused naming the version (the conformance suite's v3 profile: trn-conformance's
//! tests/v3.rs).

use trn_bench::schedule::Plan;
use trn_bench::{run, Command, RunSpec};

fn train(v3: bool) -> RunSpec {
    let mut spec = RunSpec::new(Command::Train, 100);
    spec.plan = Plan::new(60, 10, 4);
    spec.inline_v3 = v3;
    spec
}

#[test]
fn trn_train_completes_against_a_v3_controller_with_the_trials_of_a_v4_one() {
    let v3 = run::run_quietly(&train(true)).unwrap();
    let v4 = run::run_quietly(&train(false)).unwrap();
    assert_eq!(v3.controller_protocol, Some(3));
    assert_eq!(v4.controller_protocol, Some(4));
    assert_eq!(v3.trials, 60);
    assert_eq!(v3.stage1_error_px.len(), 60);
    // the same trials: the table traffic (status, save) of a v4 session changes no move
    assert_eq!(v3.stage1_error_px, v4.stage1_error_px);
    assert_eq!(v3.stage2_error_px, v4.stage2_error_px);
    assert_eq!(v3.deployment.targets, 10);
    assert_eq!(v3.grasp.grasps, 4);
    // no table traffic but the status request that told the version (its repeats: the
    // bus's), no save
    let repeats = trn_transport::BusSpec::InProc.profile(false).retries;
    assert_eq!(
        v3.bus_stats.runner.table_repeats, repeats,
        "{:?}",
        v3.bus_stats.runner
    );
    assert_eq!(
        v4.bus_stats.runner.table_repeats, 0,
        "{:?}",
        v4.bus_stats.runner
    );
    let line = trn_bench::summary::protocol_line(&v3).unwrap();
    assert!(
        line.contains("protocol v3") && line.contains("not read"),
        "{line}"
    );
    assert_eq!(trn_bench::summary::protocol_line(&v4), None);
}

#[test]
fn runs_that_need_the_tables_refuse_a_v3_controller_naming_the_version() {
    let dir = std::env::temp_dir().join(format!("trn-v3-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut keep = train(true);
    keep.keep_tables = true;
    let mut reset = train(true);
    reset.reset_tables = true;
    let mut file = train(true);
    file.tables = Some(dir.join("tables.bin"));
    let mut out = train(true);
    out.outputs.checkpoint = Some(dir.join("c.ckpt"));
    for (spec, option) in [
        (keep, "--keep-tables"),
        (reset, "--reset-tables"),
        (file, "--tables"),
        (out, "--checkpoint-out"),
    ] {
        let e = run::run_quietly(&spec).unwrap_err().to_string();
        assert!(
            e.contains("speaks protocol v3") && e.contains(option) && e.contains("v4"),
            "{option}: {e}"
        );
    }
    // refused before the trials: no checkpoint written
    assert!(!dir.join("c.ckpt").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The camera processor's estimated lights (a point status version 3 does not have) reach a
/// version-3 controller as hidden (`Occluded`): the grasps that a version-4 controller
/// completes on estimates abort there, and no observation is one it cannot decode (its frame
/// errors are the status requests of the probe alone).
#[test]
fn a_v3_controller_gets_estimated_lights_as_hidden_ones() {
    let mut spec = train(true);
    spec.plan = Plan::new(60, 10, 20);
    let v3 = run::run_quietly(&spec).unwrap();
    spec.inline_v3 = false;
    let v4 = run::run_quietly(&spec).unwrap();
    let counts =
        |r: &trn_bench::report::Report, what: &str| r.bus_stats.controller.as_ref().unwrap()[what];
    let probe = trn_transport::BusSpec::InProc.profile(false).retries + 1;
    assert_eq!(counts(&v3, "frame_errors"), probe);
    assert_eq!(counts(&v4, "frame_errors"), 0);
    assert!(
        !v3.failures.is_empty(),
        "this seed's grasps see estimated lights"
    );
    assert!(v4.failures.is_empty(), "{:?}", v4.failures);
    for f in &v3.failures {
        assert!(f.reason.contains("occluded"), "{f:?}");
    }
    assert!(v3.grasp.success_rate < v4.grasp.success_rate);
}

/// Under 5 % of every fault at once the version is still told right both ways (a v4 node's
/// status answer gets through one of its requests' repeats; a v3 node keeps beating), and
/// the v3 node learns what it learns on a clean bus.
#[test]
fn the_version_is_told_right_under_faults() {
    let faults: trn_protocol::bus::FaultConfig =
        "drop=0.05,dup=0.05,corrupt=0.05,truncate=0.05,reorder=0.05"
            .parse()
            .unwrap();
    for v3 in [true, false] {
        let clean = run::run_quietly(&train(v3)).unwrap();
        let mut spec = train(v3);
        spec.bus.faults = Some(faults);
        let faulty = run::run_quietly(&spec).unwrap();
        let version = if v3 { 3 } else { 4 };
        assert_eq!(faulty.controller_protocol, Some(version));
        assert_eq!(faulty.stage1_error_px, clean.stage1_error_px, "v{version}");
        assert_eq!(faulty.stage2_error_px, clean.stage2_error_px, "v{version}");
        let injected = faulty.bus_stats.injected.as_ref().unwrap();
        assert!(injected["dropped"] > 0, "{injected:?}");
    }
}
