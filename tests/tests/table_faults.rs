//! The tables over a faulty bus, end to end: a checkpoint written into the in-process
//! controller and read back out of it (`trn eval --checkpoint-in C --checkpoint-out D`),
//! with each fault at 1 % and 5 % on CAN 2.0 and CAN FD. Every run completes and D is C byte
//! for byte: a lost, duplicated, reordered, corrupted or truncated frame costs a repeat,
//! never a wrong table.

use std::path::Path;

use trn_bench::schedule::Plan;
use trn_bench::{run, Command, RunSpec};
use trn_protocol::bus::FaultConfig;

/// A folder of the test's own, removed when the test ends, passed or failed.
fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix("trn-table-faults-")
        .tempdir()
        .expect("a temporary folder")
}

/// The bytes of a checkpoint of tables that learned (a short training run, no faults), made
/// once for all the tests.
fn trained() -> Vec<u8> {
    static MADE: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    MADE.get_or_init(|| {
        let scratch = scratch();
        let path = scratch.path().join("trained.ckpt");
        let mut spec = RunSpec::new(Command::Train, 100);
        spec.plan = Plan {
            snapshot_every: 0,
            ..Plan::new(12, 2, 0)
        };
        spec.outputs.checkpoint = Some(path.clone());
        run::run_quietly(&spec).unwrap();
        std::fs::read(&path).unwrap()
    })
    .clone()
}

/// Writes `ckpt` in and reads it out with `faults` on the bus; what came out.
fn round_trip(ckpt: &Path, out: &Path, fd: bool, faults: &str) -> (Vec<u8>, u32) {
    let mut spec = RunSpec::new(Command::Eval, 100);
    spec.plan = Plan {
        snapshot_every: 0,
        ..Plan::new(0, 0, 0)
    };
    spec.bus.fd = fd;
    spec.bus.faults = Some(faults.parse::<FaultConfig>().unwrap());
    spec.checkpoint_in = Some(ckpt.to_path_buf());
    spec.outputs.checkpoint = Some(out.to_path_buf());
    let r = run::run_quietly(&spec).unwrap_or_else(|e| panic!("{faults} fd {fd}: {e}"));
    let injected: u64 = r
        .bus_stats
        .injected
        .as_ref()
        .unwrap()
        .iter()
        .filter(|(k, _)| !matches!(k.as_str(), "sent" | "delivered"))
        .map(|(_, v)| v)
        .sum();
    assert!(injected > 0, "{faults} fd {fd}: no fault was injected");
    (
        std::fs::read(out).unwrap(),
        r.bus_stats.runner.table_repeats,
    )
}

fn matrix(fault: &str) {
    let scratch = scratch();
    let d = scratch.path();
    let want = trained();
    let ckpt = d.join("trained.ckpt");
    std::fs::write(&ckpt, &want).unwrap();
    for fd in [false, true] {
        for rate in [0.01, 0.05] {
            let faults = format!("{fault}={rate}");
            let out = d.join(format!("{fault}-{rate}-{fd}.ckpt"));
            let (got, repeats) = round_trip(&ckpt, &out, fd, &faults);
            assert!(got == want, "{faults} fd {fd}: the tables read out differ");
            eprintln!(
                "{faults} fd {fd}: {} bytes back bit for bit, {repeats} requests repeated",
                got.len()
            );
        }
    }
}

#[test]
fn dropped_frames() {
    matrix("drop");
}

#[test]
fn duplicated_frames() {
    matrix("dup");
}

#[test]
fn reordered_frames() {
    matrix("reorder");
}

#[test]
fn corrupted_frames() {
    matrix("corrupt");
}

#[test]
fn truncated_frames() {
    matrix("truncate");
}
