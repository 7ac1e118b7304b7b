//! Studies from the command line: `--jobs` and `--shard` + `trn merge` give the table and
//! JSON of one worker; a study stopped by a real SIGINT keeps its finished runs and
//! `--resume` does only the rest; bad study input is a usage error naming it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;
use trn_studies::study::runfile;

fn trn(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trn"))
        .args(args)
        .output()
        .expect("trn runs")
}

/// A folder of the test's own, named after it, removed when the test ends, passed or failed.
fn scratch(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("trn-cli-studies-{name}-"))
        .tempdir()
        .expect("a temporary folder")
}

fn ok(out: &Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{err}");
    err
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The JSON of a file with every wall time set to 0 and without its provenance (the command
/// lines differ), after checking it has one.
fn json(path: &Path) -> Value {
    fn walk(v: &mut Value) {
        match v {
            Value::Object(m) => m.iter_mut().for_each(|(k, x)| match k.as_str() {
                "wall_s" => *x = Value::from(0.0),
                _ => walk(x),
            }),
            Value::Array(a) => a.iter_mut().for_each(walk),
            _ => {}
        }
    }
    let mut v: Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    if let Some(m) = v.as_object_mut() {
        if m.contains_key("results") {
            let p = m
                .remove("provenance")
                .expect("a study's JSON says what made it");
            assert!(p["command_line"].is_array(), "{p}");
        }
    }
    walk(&mut v);
    v
}

const SMALL: [&str; 10] = [
    "compare",
    "--configs",
    "project,broyden",
    "--seeds",
    "2",
    "--trials",
    "8",
    "--eval-targets",
    "3",
    "--grasps",
];

fn compare(dir: &Path, name: &str, extra: &[&str]) -> Output {
    let (runs, report) = (dir.join(name), dir.join(format!("{name}.json")));
    let mut args = SMALL.to_vec();
    args.extend(["2", "--runs", s(&runs), "--out", s(dir)]);
    // a shard writes no report (`--report` with `--shard` is refused)
    if !extra.contains(&"--shard") {
        args.extend(["--report", s(&report)]);
    }
    args.extend(extra);
    trn(&args)
}

#[test]
fn jobs_and_merged_shards_give_the_json_of_one_worker() {
    let dir_scratch = scratch("jobs");
    let dir = dir_scratch.path();
    let one = compare(dir, "one", &["--jobs", "1"]);
    ok(&one);
    ok(&compare(dir, "two", &["--jobs", "2"]));
    assert_eq!(json(&dir.join("one.json")), json(&dir.join("two.json")));
    for shard in ["0/2", "1/2"] {
        let out = compare(dir, "shards", &["--shard", shard]);
        let err = ok(&out);
        assert!(
            err.contains(&format!("shard {shard}: 2 runs written")),
            "{err}"
        );
        assert!(out.stdout.is_empty(), "a shard prints no table");
    }
    // a shard's report is refused before anything runs, naming both options
    let report = dir.join("shard.json");
    let mut args = SMALL.to_vec();
    args.extend([
        "2",
        "--out",
        s(dir),
        "--shard",
        "0/2",
        "--report",
        s(&report),
    ]);
    let out = trn(&args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--report") && err.contains("--shard"),
        "{err}"
    );
    assert!(!report.exists());
    let merged = dir.join("merged.json");
    let out = trn(&["merge", s(&dir.join("shards")), "--report", s(&merged)]);
    ok(&out);
    assert_eq!(json(&merged), json(&dir.join("one.json")));
    assert_eq!(out.stdout, one.stdout, "the merge prints the study's table");
    // a missing shard is named
    let lone = dir.join("lone");
    ok(&compare(dir, "lone", &["--shard", "1/2"]));
    let out = trn(&["merge", s(&lone)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("have no file (runs 0, 2)"),
        "{err}"
    );
    // a run file whose header claims another number of runs (the study's digest kept) is
    // refused, naming both counts, never an index out of bounds
    let forged = dir.join("forged");
    std::fs::create_dir_all(&forged).unwrap();
    let mut runs: Vec<PathBuf> = std::fs::read_dir(dir.join("shards"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|f| f.extension().is_some_and(|e| e == "json"))
        .collect();
    runs.sort();
    for (i, f) in runs.iter().enumerate() {
        let mut v = json(f);
        if i == runs.len() - 1 {
            v["study"]["runs"] = 100.into();
            v["index"] = 50.into();
        }
        // sealed as trn seals a run file: a forgery with a valid checksum
        let sealed = runfile::seal(&serde_json::to_vec_pretty(&v).unwrap()).unwrap();
        std::fs::write(forged.join(f.file_name().unwrap()), sealed).unwrap();
    }
    let out = trn(&["merge", s(&forged)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("disagree on its number of runs (4 and 100)"),
        "{err}"
    );
    // one digit of a result changed (the checksum left as written) is refused, naming the
    // file, where it was once merged as true
    let damaged = dir.join("damaged");
    std::fs::create_dir_all(&damaged).unwrap();
    for f in &runs {
        std::fs::copy(f, damaged.join(f.file_name().unwrap())).unwrap();
    }
    let victim = damaged.join(runs[1].file_name().unwrap());
    let text = std::fs::read_to_string(&victim).unwrap();
    let at = text.find("\"seed\": ").unwrap() + "\"seed\": ".len();
    let digit = text.as_bytes()[at];
    let mut bytes = text.into_bytes();
    bytes[at] = if digit == b'9' { b'8' } else { digit + 1 };
    std::fs::write(&victim, bytes).unwrap();
    let out = trn(&["merge", s(&damaged)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success()
            && err.contains(&*victim.file_name().unwrap().to_string_lossy())
            && err.contains("checksum"),
        "{err}"
    );
    // the report may not be one of the run files merged: refused, the run file untouched
    let before = std::fs::read(&runs[0]).unwrap();
    let out = trn(&["merge", s(&dir.join("shards")), "--report", s(&runs[0])]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("is one of the run files merged"),
        "{err}"
    );
    assert_eq!(std::fs::read(&runs[0]).unwrap(), before);
}

/// 6 runs of about a second, one worker: SIGINT after the second run's file appears.
#[test]
fn a_study_stopped_by_sigint_resumes_without_redoing_finished_runs() {
    let dir_scratch = scratch("sigint");
    let dir = dir_scratch.path();
    let study = dir.join("six.toml");
    std::fs::write(
        &study,
        "name = \"six\"\nseeds = { first = 100, count = 6 }\n[base]\nplant = \"ideal\"\ntrials = 60\neval_targets = 20\ngrasps = 4\nsnapshot_every = 0\n",
    )
    .unwrap();
    let runs = dir.join("runs");
    let args = [
        "study",
        s(&study),
        "--out",
        s(dir),
        "--runs",
        s(&runs),
        "--jobs",
        "1",
    ];
    let child = Command::new(env!("CARGO_BIN_EXE_trn"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let files = || -> Vec<PathBuf> {
        let mut f: Vec<PathBuf> = std::fs::read_dir(&runs)
            .map(|d| {
                d.flatten()
                    .map(|e| e.path())
                    .filter(|p| p.extension().is_some_and(|e| e == "json"))
                    .collect()
            })
            .unwrap_or_default();
        f.sort();
        f
    };
    let t0 = Instant::now();
    while files().len() < 2 {
        assert!(t0.elapsed() < Duration::from_secs(300), "no run finished");
        std::thread::sleep(Duration::from_millis(20));
    }
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("--resume"), "{err}");
    let done = files();
    assert!(
        (2..6).contains(&done.len()),
        "{} runs finished: {err}",
        done.len()
    );
    let before: Vec<Vec<u8>> = done.iter().map(|p| std::fs::read(p).unwrap()).collect();

    let out = trn(&[&args[..], &["--resume"]].concat());
    let err = ok(&out);
    let k = done.len();
    assert!(
        err.contains(&format!("{} runs to do ({k} found finished)", 6 - k)),
        "{err}"
    );
    for (p, b) in done.iter().zip(&before) {
        assert_eq!(
            &std::fs::read(p).unwrap(),
            b,
            "{} was written again",
            p.display()
        );
    }
    assert_eq!(files().len(), 6);
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("| six | 60 |"), "{table}");
    assert!(dir.join("six.json").exists());
}

#[test]
fn bad_study_input_is_a_usage_error_naming_it() {
    let dir_scratch = scratch("bad");
    let dir = dir_scratch.path();
    let study = dir.join("bad.toml");
    std::fs::write(&study, "name = \"bad\"\nseeds = [100]\n[[axis]]\nkey = \"realism.load_widht_gain\"\nvalues = [0.1]\n").unwrap();
    let out = trn(&["study", s(&study), "--out", s(dir)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("`realism.load_widht_gain`") && err.contains("load_width_gain"),
        "{err}"
    );
    for bad in ["2/2", "1", "x/3"] {
        let out = trn(&["compare", "--shard", bad]);
        assert_eq!(out.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&out.stderr).contains("--shard"));
    }
    let out = trn(&["compare", "--configs", "projekt", "--out", s(dir)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("\"projekt\"") && err.contains("no-trial-secant"),
        "{err}"
    );
}
