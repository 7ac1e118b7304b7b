//! The conformance suite against a controller of protocol version 3 (the project's node in
//! its version-3 mode, `NodeConfig::HOST_V3`): the suite's v3 profile passes, the checks of
//! what version 4 added reported not applicable; on the version-4 node every check passes.

use trn_bench::{Command, Report, RunSpec};

/// The names of the checks reported not applicable.
fn skipped(r: &Report) -> Vec<&str> {
    r.conformance
        .iter()
        .filter(|c| c.skipped)
        .map(|c| c.name.as_str())
        .collect()
}

#[test]
fn the_v3_profile_of_the_conformance_suite_passes() {
    let mut spec = RunSpec::new(Command::Conformance, 104);
    spec.inline_v3 = true;
    let r = trn_conformance::run_quietly(&spec).unwrap();
    assert_eq!(r.controller_protocol, Some(3));
    let failed: Vec<_> = r.conformance.iter().filter(|c| !c.passed).collect();
    assert!(failed.is_empty(), "{failed:#?}");
    let not_applicable = skipped(&r);
    assert!(
        r.conformance
            .iter()
            .filter(|c| c.skipped)
            .all(|c| c.detail.contains("protocol v3")),
        "{not_applicable:#?}"
    );
    // the tables' status and chunk, the unsupported law, the late duplicate, the repeated
    // grasp, the save, the erase without a nonce, the guard's ten, the write's three, a
    // supervised pressure dropped by the next session
    assert_eq!(not_applicable.len(), 21, "{not_applicable:#?}");
    // pre-emption is version 3's behaviour too: it runs and passes
    assert!(r
        .conformance
        .iter()
        .any(|c| c.name.contains("pre-empts") && c.passed && !c.skipped));
    assert!(not_applicable.iter().any(|n| n.contains("StoreCommand")));
    assert!(not_applicable
        .iter()
        .any(|n| n.contains("TableReadRequest")));
    assert!(not_applicable.iter().any(|n| n.contains("GUARD_REFUSED")));
    let run = r.conformance.len() - not_applicable.len();
    assert!(run >= 17, "{run} checks run");
    // the same suite on the v4 node passes every check
    let mut spec = RunSpec::new(Command::Conformance, 104);
    spec.inline_v3 = false;
    let r4 = trn_conformance::run_quietly(&spec).unwrap();
    assert_eq!(r4.controller_protocol, Some(4));
    assert_eq!(r4.conformance.len(), r.conformance.len());
    assert!(r4.conformance.iter().all(|c| c.passed));
    // but the guard's check of tables that never learn: its tables learned
    let not_applicable = skipped(&r4);
    assert_eq!(not_applicable.len(), 1, "{not_applicable:#?}");
    assert!(not_applicable[0].starts_with("On tables that never learn"));
}
