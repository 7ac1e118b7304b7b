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
