//! An interrupt keeps what was done: SIGINT, SIGTERM or SIGHUP stops a run at the next trial
//! boundary, writes the report (marked interrupted) and a checkpoint that `--continue`
//! resumes, and exits 130, 143 or 129; a second signal ends it at once.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("trn-interrupt-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn long_training(report: &Path, ckpt: &Path) -> Child {
    Command::new(env!("CARGO_BIN_EXE_trn"))
        .args(["train", "--trials", "100000", "--quiet"])
        .args(["--eval-targets", "3", "--grasps", "1"])
        .args(["--report", s(report), "--checkpoint-out", s(ckpt)])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("trn starts")
}

fn signal(child: &Child, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(ok.success());
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
    let d = dir("int");
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
    let d = dir("term");
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
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(130));
    assert!(t.elapsed() < Duration::from_secs(2), "{:?}", t.elapsed());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("interrupted again: quitting at once"), "{err}");
}

/// A run killed outright (SIGKILL) keeps its last periodic checkpoint
/// (`--checkpoint-every`), which `--continue` resumes from that trial; a writer's stale
/// temporary file is removed by the next run that writes there.
#[test]
fn a_killed_run_keeps_its_last_periodic_checkpoint() {
    let d = dir("kill");
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
    std::thread::sleep(Duration::from_secs(3));
    signal(&child, "-KILL");
    child.wait().unwrap();
    assert!(!stale.exists(), "the stale temporary file is still there");
    assert!(ckpt.exists(), "no periodic checkpoint");
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
