//! The `controller-node` binary as a user meets it: its help says what it is.

use std::process::Command;

/// Fails if the help shows the package's description instead of the binary's own, or does
/// not run.
#[test]
fn controller_nodes_help_says_what_it_does() {
    let out = Command::new(env!("CARGO_BIN_EXE_controller-node"))
        .arg("--help")
        .output()
        .expect("the binary runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let help = String::from_utf8_lossy(&out.stdout).replace('\n', " ");
    assert!(
        help.contains("the controller as a CAN node in its own process"),
        "{help}"
    );
    assert!(!help.contains("The host side's buses"), "{help}");
}
