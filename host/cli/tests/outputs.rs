//! Every file `trn` writes follows one rule (trn_bench::output): checked before the run, never
//! an input or another output, never a device or a symlink, written whole or not at all,
//! errors naming the user's path; counts bounded; a full disk loses nothing.

use std::path::Path;
use std::process::{Command, Output};

fn trn(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trn"))
        .args(args)
        .output()
        .expect("trn runs")
}

/// `trn` with writes limited to `blocks` x 512 B per file (`ulimit -f`, SIGXFSZ ignored so
/// a write past it fails with "file too large", as on a full disk).
fn trn_on_a_full_disk(blocks: u32, args: &[&str]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg(format!(
            "trap '' XFSZ; ulimit -f {blocks}; exec \"$0\" \"$@\""
        ))
        .arg(env!("CARGO_BIN_EXE_trn"))
        .args(args)
        .output()
        .expect("sh runs")
}

/// A folder of the test's own, named after it, removed when the test ends, passed or failed.
fn dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("trn-outputs-{name}-"))
        .tempdir()
        .expect("a temporary folder")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The default plant's configuration as a file (its keys documented beside it).
const DEFAULT_TOML: &str = include_str!("../../plant/sim.toml");

const SMALL: [&str; 7] = [
    "--trials",
    "5",
    "--eval-targets",
    "2",
    "--grasps",
    "1",
    "--quiet",
];

/// Refused before anything runs: exit 2, nothing on stdout (no run), the message names
/// `needle`.
fn refused(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(out.stdout.is_empty(), "the run went ahead: {err}");
    assert!(err.contains(needle), "stderr lacks {needle:?}: {err}");
}

fn train(extra: &[&str]) -> Output {
    let mut args = vec!["train"];
    args.extend(SMALL);
    args.extend(extra);
    trn(&args)
}

/// An output on an input is refused before the run and the input is unchanged: the
/// configuration, the checkpoint read. Fails when an output replaces an input.
#[test]
fn an_output_never_replaces_an_input() {
    let d_scratch = dir("inputs");
    let d = d_scratch.path();
    let cfg = d.join("my.json"); // any name: a configuration is any TOML file
    std::fs::write(&cfg, DEFAULT_TOML).unwrap();
    let before = std::fs::read(&cfg).unwrap();
    refused(
        &train(&["--config", s(&cfg), "--report", s(&cfg)]),
        "an output never replaces an input",
    );
    assert_eq!(std::fs::read(&cfg).unwrap(), before);
    // the usual names: refused by their kind before anything runs
    let toml = d.join("my.toml");
    std::fs::write(&toml, DEFAULT_TOML).unwrap();
    refused(
        &train(&["--config", s(&toml), "--report", s(&toml)]),
        "--report writes a .json file",
    );
    refused(
        &train(&["--config", s(&toml), "--checkpoint-out", s(&toml)]),
        "a checkpoint is not a .toml file",
    );
    assert_eq!(std::fs::read(&toml).unwrap(), DEFAULT_TOML.as_bytes());
    // a trained checkpoint and its .sim
    let ck = d.join("net.ckpt");
    let out = train(&["--checkpoint-out", s(&ck)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ckpt = std::fs::read(&ck).unwrap();
    let sim = d.join("net.ckpt.sim");
    let sim_bytes = std::fs::read(&sim).unwrap();
    refused(
        &trn(&[
            "eval",
            "--checkpoint-in",
            s(&ck),
            "--report",
            s(&ck),
            "--quiet",
        ]),
        "--report writes a .json file",
    );
    refused(
        &train(&["--checkpoint-in", s(&ck), "--checkpoint-out", s(&ck)]),
        "an output never replaces an input",
    );
    refused(
        &train(&["--checkpoint-in", s(&ck), "--candump", s(&sim)]),
        "--candump writes a .log file",
    );
    assert_eq!(std::fs::read(&ck).unwrap(), ckpt);
    assert_eq!(std::fs::read(&sim).unwrap(), sim_bytes);
    // two outputs, one file (a hard link)
    let both = d.join("both.json");
    std::fs::write(&both, b"{}").unwrap();
    let log = d.join("both.log");
    std::fs::hard_link(&both, &log).unwrap();
    refused(
        &train(&["--report", s(&both), "--candump", s(&log)]),
        "two outputs, one file",
    );
    assert_eq!(std::fs::read(&both).unwrap(), b"{}");
}

/// A device, a symlink, a directory or the wrong kind of file is refused for every output
/// before the run; nothing is created.
#[test]
fn devices_symlinks_and_wrong_kinds_are_refused_for_every_output() {
    let d_scratch = dir("kinds");
    let d = d_scratch.path();
    let real = d.join("real.json");
    std::fs::write(&real, "{}").unwrap();
    let link = d.join("link.json");
    std::os::unix::fs::symlink(&real, &link).unwrap();
    let link_log = d.join("link.log");
    std::os::unix::fs::symlink(d.join("target.log"), &link_log).unwrap();
    refused(
        &train(&["--checkpoint-out", "/dev/null"]),
        "not a regular file",
    );
    refused(&train(&["--report", "/dev/full"]), "not a regular file");
    refused(&train(&["--report", s(&link)]), "symbolic link");
    refused(&train(&["--candump", s(&link_log)]), "symbolic link");
    refused(
        &train(&["--plot", s(&d.join("out.txt"))]),
        "--plot writes a .png or .svg file",
    );
    refused(&train(&["--report", s(d)]), "is a directory");
    refused(
        &train(&["--report", s(&d.join("r.txt"))]),
        "--report writes a .json file",
    );
    refused(&train(&["--checkpoint-out", s(d)]), "is a directory");
    assert_eq!(
        std::fs::read(&real).unwrap(),
        b"{}",
        "the link's target is untouched"
    );
    assert!(!d.join("target.log").exists());
}

/// A write that fails midway (a full disk) names the user's file and leaves the previous
/// file, never a truncated one: the candump log, the report, the plot.
#[test]
fn a_full_disk_names_the_file_and_leaves_the_previous_one() {
    let d_scratch = dir("full");
    let d = d_scratch.path();
    let log = d.join("bus.log");
    let out = trn_on_a_full_disk(
        64,
        &[
            "train",
            "--trials",
            "20",
            "--eval-targets",
            "3",
            "--grasps",
            "2",
            "--quiet",
            "--candump",
            s(&log),
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains(s(&log)) && err.contains("too large"), "{err}");
    assert!(!log.exists(), "a truncated log was left");
    let png = d.join("curves.png");
    std::fs::write(&png, b"the previous plot").unwrap();
    let out = trn_on_a_full_disk(
        40,
        &[
            "train",
            "--trials",
            "5",
            "--eval-targets",
            "2",
            "--grasps",
            "1",
            "--quiet",
            "--plot",
            s(&png),
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(0), "{err}");
    assert!(err.contains(s(&png)), "{err}");
    assert!(
        !err.contains("{ ") && !err.contains("Error {"),
        "a debug dump: {err}"
    );
    assert_eq!(std::fs::read(&png).unwrap(), b"the previous plot");
    let leftovers: Vec<_> = std::fs::read_dir(d)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .filter(|n| n.to_string_lossy().contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// Counts beyond what a machine can hold are usage errors naming the option, never a
/// panic or an allocation failure.
#[test]
fn huge_counts_are_usage_errors() {
    for (cmd, opt) in [
        ("train", "--eval-targets"),
        ("train", "--grasps"),
        ("train", "--snapshot-targets"),
        ("lifelong", "--snapshot-targets"),
        ("lifelong", "--snapshot-grasps"),
    ] {
        for n in ["18446744073709551615", "99999999999"] {
            let arg = format!("{opt}={n}");
            let out = trn(&[cmd, &arg, "--quiet"]);
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(2), "{cmd} {arg}: {err}");
            assert!(err.contains(opt), "{cmd} {arg}: {err}");
        }
    }
}

/// Small things that were accepted without a word: a fault given twice, a checkpoint
/// interval without a checkpoint, `--external-controller` on the in-process bus.
#[test]
fn contradictions_are_refused_with_their_options_named() {
    refused(&train(&["--faults", "drop=0.1,drop=0.2"]), "given twice");
    refused(
        &train(&["--checkpoint-every", "2"]),
        "--checkpoint-every needs --checkpoint-out",
    );
    refused(
        &train(&["--external-controller"]),
        "--external-controller needs a real bus",
    );
}
