//! The conformance suite (protocol/SPEC.md) against the project's controller node on the
//! in-process bus, on CAN 2.0 and CAN FD, both presets. (Over SocketCAN it runs in the
//! vcan VM, `scripts/vcan/tests.sh`; against the firmware in QEMU, `scripts/cross/pil.sh`.)

use trn_bench::spec::ControllerChoice;
use trn_bench::{Command, Profile, RunSpec};
use trn_controller::presets::{Ablation, Preset};

fn suite(seed: u64, preset: Preset, fd: bool) {
    suite_with(seed, preset, fd, ControllerChoice::Trn)
}

fn suite_with(seed: u64, preset: Preset, fd: bool, law: ControllerChoice) {
    let mut spec = RunSpec::new(Command::Conformance, seed);
    spec.profile = Profile {
        preset,
        ablation: Ablation::None,
        law,
    };
    spec.bus.fd = fd;
    let r = trn_conformance::run_quietly(&spec).unwrap();
    assert!(r.conformance.len() >= 18, "{} checks", r.conformance.len());
    let failed: Vec<_> = r.conformance.iter().filter(|c| !c.passed).collect();
    assert!(failed.is_empty(), "{failed:#?}");
    // the save, the erase without a nonce and a pre-emption are checked for every law: the
    // save or the refusal answered (or the reason there is no store or no tables), the
    // trial in progress ended without a word
    for name in [
        "StoreCommand{Save}",
        "StoreCommand{Erase}",
        "A newer trial's target mid-trial pre-empts",
    ] {
        let check = r.conformance.iter().find(|c| c.name.starts_with(name));
        assert!(
            check.is_some_and(|c| c.passed && !c.skipped),
            "{name}: {check:?}"
        );
    }
    // an end with no write and `keep_tables` under another configuration and the tables'
    // own, for every law; where the tables learned (the TRN), a begin without a nonce
    // refused and a write begun with one
    let mut names = vec![
        "TableWriteEnd with no write staged",
        "SessionConfig{keep_tables: true} of another",
        "SessionConfig{keep_tables: true} of the tables' own",
    ];
    if law == ControllerChoice::Trn {
        names.push("TableWriteBegin into learned tables without a nonce");
        names.push("A write begun with GuardNonce{TableWrite}");
        // another operation's nonce refused as wrong with the re-seed's op
        names.push("A nonce of another operation");
    } else {
        // the guard of tables that never learn: it answers, a re-seed needs no nonce
        names.push("On tables that never learn");
    }
    for name in names {
        let check = r.conformance.iter().find(|c| c.name.starts_with(name));
        assert!(
            check.is_some_and(|c| c.passed && !c.skipped),
            "{name}: {check:?}"
        );
    }
}

#[test]
fn the_project_node_conforms_on_can_2_0() {
    suite(100, Preset::Project, false);
}

#[test]
fn the_project_node_conforms_on_can_fd_with_the_paper_preset() {
    suite(101, Preset::Paper, true);
}

#[test]
fn the_broyden_baseline_conforms_too() {
    suite_with(102, Preset::Project, false, ControllerChoice::Broyden);
}

#[test]
fn the_model_based_reference_conforms_too() {
    suite_with(103, Preset::Project, false, ControllerChoice::Model);
}

// The oracle is not run through the suite: it commands from the plant's true state, so the
// same target from the same commanded start pose (a different hysteresis history after
// the first run) is rightly commanded differently, which the suite's check that mature
// operation learns nothing takes for learning.
