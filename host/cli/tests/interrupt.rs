//! An interrupt keeps what was done: SIGINT, SIGTERM or SIGHUP stops a run at the next trial
//! boundary, writes the report (marked interrupted) and a checkpoint that `--continue`
//! resumes, and exits 130, 143 or 129; a second signal ends it at once.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A folder of the test's own, named after it, removed when the test ends, passed or failed.
fn dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("trn-interrupt-{name}-"))
        .tempdir()
        .expect("a temporary folder")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `trn ARGS` started, its output captured.
fn start(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_trn"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("trn starts")
}

fn long_training(report: &Path, ckpt: &Path) -> Child {
    start(&[
        "train",
        "--trials",
        "100000",
        "--quiet",
        "--eval-targets",
        "3",
        "--grasps",
        "1",
        "--report",
        s(report),
        "--checkpoint-out",
        s(ckpt),
    ])
}

fn signal(child: &Child, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
}

/// The output of `child` once it ended; killed and failed (`what`) if it has not within 20 s
/// (a test that would otherwise wait for hours).
fn ended_within_20_s(mut child: Child, what: &str) -> std::process::Output {
    let t = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t.elapsed() > Duration::from_secs(20) {
            child.kill().unwrap();
            panic!("{what} 20 s after the interrupt");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// SIGINT a few seconds into a training of 100,000 trials: exit 130, the report written and
/// marked interrupted with the trials done, a checkpoint that `trn eval` reads and that
/// `--continue` resumes from the trial reached (its report counting all of them). Fails
/// when an interrupt loses the run or its checkpoint, or the continued run restarts.
#[test]
fn sigint_keeps_what_was_done_and_continue_resumes_it() {
    let d_scratch = dir("int");
    let d = d_scratch.path();
    let (report, ckpt) = (d.join("r.json"), d.join("net.ckpt"));
    let child = long_training(&report, &ckpt);
    std::thread::sleep(Duration::from_secs(3));
    signal(&child, "-INT");
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    let r = json(&report);
    assert_eq!(r["interrupted"], true);
    let done = r["trials"].as_u64().unwrap();
    assert!(done > 0 && done < 100_000, "{done} trials");
    assert_eq!(r["stage1_error_px"].as_array().unwrap().len() as u64, done);
    assert!(ckpt.exists() && d.join("net.ckpt.sim").exists());
    let eval = Command::new(env!("CARGO_BIN_EXE_trn"))
        .args(["eval", "--checkpoint-in", s(&ckpt), "--quiet"])
        .args(["--eval-targets", "2", "--grasps", "0"])
        .output()
        .unwrap();
    assert!(
        eval.status.success(),
        "{}",
        String::from_utf8_lossy(&eval.stderr)
    );
    let more = d.join("more.json");
    let cont = Command::new(env!("CARGO_BIN_EXE_trn"))
        .args([
            "train",
            "--checkpoint-in",
            s(&ckpt),
            "--continue",
            "--trials",
            "3",
        ])
        .args(["--eval-targets", "2", "--grasps", "0", "--quiet"])
        .args(["--report", s(&more)])
        .output()
        .unwrap();
    assert!(
        cont.status.success(),
        "{}",
        String::from_utf8_lossy(&cont.stderr)
    );
    let m = json(&more);
    assert_eq!(
        m["trials"].as_u64(),
        Some(done + 3),
        "the network's trials in all"
    );
    assert_eq!(m["trials_this_run"].as_u64(), Some(3));
    assert_eq!(
        m["stage1_error_px"].as_array().unwrap().len() as u64,
        done + 3,
        "the whole curve"
    );
    assert_eq!(m["interrupted"], false);
}

/// SIGTERM ends the same way with 143, SIGHUP with 129; a second signal ends the process at
/// once without waiting for the trial boundary.
#[test]
fn sigterm_exits_143_and_a_second_signal_ends_at_once() {
    let d_scratch = dir("term");
    let d = d_scratch.path();
    let (report, ckpt) = (d.join("r.json"), d.join("net.ckpt"));
    let child = long_training(&report, &ckpt);
    std::thread::sleep(Duration::from_secs(2));
    signal(&child, "-TERM");
    let out = child.wait_with_output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(143),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(json(&report)["interrupted"], true);
    // a closed terminal (SIGHUP) too, with 129: it used to end the run with nothing written
    let (report_hup, ckpt_hup) = (d.join("hup.json"), d.join("hup.ckpt"));
    let child = long_training(&report_hup, &ckpt_hup);
    std::thread::sleep(Duration::from_secs(2));
    signal(&child, "-HUP");
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(129), "{err}");
    assert_eq!(json(&report_hup)["interrupted"], true);
    assert!(ckpt_hup.exists(), "the checkpoint of what was done");
    let (report2, ckpt2) = (d.join("r2.json"), d.join("net2.ckpt"));
    let child = long_training(&report2, &ckpt2);
    std::thread::sleep(Duration::from_secs(2));
    signal(&child, "-INT");
    signal(&child, "-INT");
    let t = Instant::now();
    let status = child.wait_with_output().unwrap().status;
    assert_eq!(status.code(), Some(130));
    assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
}

/// In a study the first interrupt lets the run in progress finish (here one of 100,000
/// trials: hours); a second one quits at once and says so, where it used to end without a
/// word.
#[test]
fn a_second_interrupt_quits_a_study_at_once_and_says_so() {
    let d_scratch = dir("study-twice");
    let d = d_scratch.path();
    let out_dir = d.join("out");
    let mut child = start(&[
        "compare",
        "--seeds",
        "1",
        "--trials",
        "100000",
        "--jobs",
        "1",
        "--eval-targets",
        "3",
        "--grasps",
        "0",
        "--quiet",
        "--out",
        s(&out_dir),
    ]);
    std::thread::sleep(Duration::from_secs(2));
    signal(&child, "-INT");
    // the first is handled (a pending signal of the same kind would absorb the second)
    std::thread::sleep(Duration::from_millis(500));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the first ended the study"
    );
    signal(&child, "-INT");
    let out = ended_within_20_s(child, "the study went on");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted again: quitting at once"), "{err}");
}

/// A run killed outright (SIGKILL) keeps its last periodic checkpoint
/// (`--checkpoint-every`), which `--continue` resumes from that trial; a writer's stale
/// temporary file is removed by the next run that writes there.
#[test]
fn a_killed_run_keeps_its_last_periodic_checkpoint() {
    let d_scratch = dir("kill");
    let d = d_scratch.path();
    let ckpt = d.join("net.ckpt");
    let stale = d.join(".net.ckpt.tmp-999999999-0");
    std::fs::write(&stale, b"left by a killed writer").unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_trn"))
        .args(["train", "--trials", "100000", "--quiet"])
        .args(["--checkpoint-out", s(&ckpt), "--checkpoint-every", "10"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // killed once its first periodic checkpoint is there (however fast this build trains:
    // a debug build needs far longer for 10 trials than a release build)
    let t = Instant::now();
    while !ckpt.exists() {
        if child.try_wait().unwrap().is_some() || t.elapsed() > Duration::from_secs(300) {
            let _ = child.kill();
            panic!("no periodic checkpoint ({:?} after the start)", t.elapsed());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    signal(&child, "-KILL");
    child.wait().unwrap();
    assert!(!stale.exists(), "the stale temporary file is still there");
    let more = d.join("more.json");
    let cont = Command::new(env!("CARGO_BIN_EXE_trn"))
        .args([
            "train",
            "--checkpoint-in",
            s(&ckpt),
            "--continue",
            "--trials",
            "1",
        ])
        .args(["--eval-targets", "1", "--grasps", "0", "--quiet"])
        .args(["--report", s(&more)])
        .output()
        .unwrap();
    assert!(
        cont.status.success(),
        "{}",
        String::from_utf8_lossy(&cont.stderr)
    );
    let trials = json(&more)["trials"].as_u64().unwrap();
    assert!(
        trials > 10 && (trials - 1).is_multiple_of(10),
        "{trials} trials"
    );
}

/// An interrupt while a large held-out set is still being drawn (each target settles a twin
/// of the arm: a million of them take hours) ends the run at once, with the report written
/// and marked interrupted, where the first signal used to wait for the whole set.
#[test]
fn an_interrupt_while_the_held_out_set_is_drawn_ends_the_run() {
    let d_scratch = dir("held-out");
    let d = d_scratch.path();
    let report = d.join("r.json");
    let child = start(&[
        "train",
        "--trials",
        "5",
        "--quiet",
        "--eval-targets",
        "1000000",
        "--grasps",
        "0",
        "--report",
        s(&report),
    ]);
    std::thread::sleep(Duration::from_secs(2));
    signal(&child, "-INT");
    let out = ended_within_20_s(child, "still drawing the held-out set");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    let r = json(&report);
    assert_eq!(r["interrupted"], true);
    assert_eq!(r["learning_curve"].as_array().map_or(0, Vec::len), 0);
}

/// An interrupt while a large study is still being built (a grid of 100,000 configurations
/// takes seconds before its first run) ends it there and says so, with nothing written.
#[test]
fn an_interrupt_while_a_study_is_built_ends_it_before_any_run() {
    let d_scratch = dir("study-build");
    let d = d_scratch.path();
    let values: Vec<String> = (0..100_000)
        .map(|i| format!("{}", 0.3 + i as f64 * 1e-6))
        .collect();
    let grid = format!(
        "name = \"grid\"\nseeds = {{ first = 100, count = 1 }}\n[base]\nplant = \"ideal\"\n\
         trials = 5\neval_targets = 2\ngrasps = 0\n[[axis]]\nkey = \"joints.*.damping_ratio\"\n\
         values = [{}]\n",
        values.join(", ")
    );
    let file = d.join("grid.toml");
    std::fs::write(&file, grid).unwrap();
    let out_dir = d.join("out");
    let child = start(&["study", s(&file), "--out", s(&out_dir), "--quiet"]);
    std::thread::sleep(Duration::from_millis(500));
    signal(&child, "-INT");
    let out = ended_within_20_s(child, "still building the study");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("while the study was being built"), "{err}");
    assert!(!out_dir.exists(), "something was written");
}
