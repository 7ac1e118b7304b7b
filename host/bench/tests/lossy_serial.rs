//! `--faults` on a bus this process does not deliver: `trn train --bus slcan:PTY
//! --external-controller --faults ...` against the project's controller node on the other end
//! of a pseudo-terminal pair (its loop in a thread). The host's fault layer drops, duplicates
//! and reorders frames both ways; the repeats of both sides recover them, so the run learns
//! exactly what the clean run learns, and the report counts what was injected.

use trn_bench::schedule::Plan;
use trn_bench::{run, Command, Report, RunSpec};
use trn_transport::slcan_serial::PtyPeer;
use trn_transport::{controller_loop, BusSpec};

/// `trials` training trials of seed 7 over a fresh pair, with `faults`.
fn train(trials: usize, faults: Option<&str>) -> Report {
    let node = PtyPeer::spawn(|port, stop| controller_loop::run_fresh(port, 7, stop))
        .expect("a pseudo-terminal pair");
    let mut spec = RunSpec::new(Command::Train, 7);
    spec.plan = Plan::new(trials, 0, 0);
    spec.bus.spec = BusSpec::SlcanSerial(node.path().to_string());
    spec.bus.external_controller = true;
    spec.bus.faults = faults.map(|f| f.parse().expect("a fault list"));
    let report = run::run_quietly(&spec);
    node.finish()
        .expect("the node's thread")
        .expect("the node's loop");
    report.expect("the run")
}

/// Fails if `--faults` is refused on the serial bus, if the layer injects nothing or counts
/// wrongly, if the runner never repeats (its repeats are what recovers a lost start), or if
/// a lost, duplicated or reordered frame changes what is learned.
#[test]
fn a_lossy_serial_line_learns_what_the_clean_one_learns() {
    let clean = train(12, None);
    assert_eq!(clean.bus_stats.injected, None, "no faults, no counts");
    let lossy = train(12, Some("drop=0.05,dup=0.03,reorder=0.03"));
    let injected = lossy
        .bus_stats
        .injected
        .clone()
        .expect("the injected faults");
    let n = |k: &str| injected[k];
    assert!(
        n("dropped") > 20 && n("duplicated") > 5 && n("delayed") > 5,
        "{injected:?}"
    );
    // every copy is delivered, or still held back by a delay when the run ended
    let held = n("sent") - n("dropped") + n("duplicated") - n("delivered");
    assert!(held <= n("delayed"), "{injected:?}");
    assert!(
        lossy.bus_stats.runner.target_repeats > 0,
        "{:?}",
        lossy.bus_stats.runner
    );
    assert_eq!(lossy.failed_trials, 0, "{:?}", lossy.failures);
    for (what, a, b) in [
        ("stage 1", &clean.stage1_error_px, &lossy.stage1_error_px),
        ("stage 2", &clean.stage2_error_px, &lossy.stage2_error_px),
    ] {
        assert_eq!(a.len(), 12, "{what}");
        let bits = |v: &Vec<f32>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(a), bits(b), "{what}: the learning curve changed");
    }
    assert_eq!(clean.fine_moves, lossy.fine_moves);
}
