//! The engine alone and the conformance command: it needs a suite (`trn-conformance`).

use trn_bench::{run, Command, LabError, RunSpec, Unobserved};

/// The engine alone refuses the conformance command before it opens a bus, naming the
/// crate that runs it; fails if it tried the bus first (a SocketCAN interface that does
/// not exist: another error) or ran a session without a suite.
#[test]
fn the_engine_alone_refuses_the_conformance_command() {
    let mut spec = RunSpec::new(Command::Conformance, 1);
    spec.bus.spec = trn_transport::BusSpec::SocketCan("trn-none0".into());
    let e = run::run(&spec, &mut Unobserved).unwrap_err();
    assert!(
        matches!(&e, LabError::Usage(m) if m.contains("trn_conformance")),
        "{e}"
    );
}

/// What watches the run learns that it is over, with the whole report, before the run's
/// files are written: the command line prints its summary there, so a write that then
/// fails (a full disk) loses no figure. Fails if `ran` comes after the writes, twice, or
/// not at all.
#[test]
fn the_observer_has_the_report_before_its_files_are_written() {
    struct Watch {
        files: Vec<std::path::PathBuf>,
        seen: Vec<(u32, bool)>,
    }
    impl trn_bench::Observer for Watch {
        fn ran(&mut self, report: &trn_bench::Report) {
            let written = self.files.iter().any(|f| f.exists());
            self.seen.push((report.seed as u32, written));
        }
    }
    let dir = std::env::temp_dir().join(format!("trn-ran-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut spec = RunSpec::new(Command::Train, 5);
    spec.plan = trn_bench::schedule::Plan {
        snapshot_every: 0,
        ..trn_bench::schedule::Plan::new(4, 2, 0)
    };
    spec.outputs.report = Some(dir.join("r.json"));
    spec.outputs.csv = Some(dir.join("r.csv"));
    let mut watch = Watch {
        files: vec![dir.join("r.json"), dir.join("r.csv")],
        seen: vec![],
    };
    let report = run::run(&spec, &mut watch).unwrap();
    assert_eq!(watch.seen, [(5, false)], "once, before any file");
    assert!(watch.files.iter().all(|f| f.exists()), "the files after it");
    assert_eq!(report.seed, 5);
    let _ = std::fs::remove_dir_all(&dir);
}
