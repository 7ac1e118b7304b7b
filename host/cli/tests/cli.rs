//! The `trn` command line: the main job end to end, checkpoints, and bad input (a clear
//! message and a non-zero exit, never a panic).

use std::process::{Command, Output};

fn trn(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_trn"))
        .args(args)
        .output()
        .expect("trn runs")
}

/// A folder of the test's own, removed when the test ends, passed or failed.
fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix("trn-cli-")
        .tempdir()
        .expect("a temporary folder")
}

fn fails_with(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "expected failure, got success; stderr: {err}"
    );
    assert_eq!(
        out.status.code(),
        Some(1),
        "a clean error exit, not a panic (101): {err}"
    );
    assert!(err.contains(needle), "stderr lacks {needle:?}: {err}");
}

const SMALL: [&str; 7] = [
    "--trials",
    "20",
    "--eval-targets",
    "3",
    "--grasps",
    "2",
    "--quiet",
];

#[test]
fn train_writes_report_plot_and_checkpoint_and_eval_reads_it() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let (ckpt, report, plot) = (tmp("a.ckpt"), tmp("a.json"), tmp("a.png"));
    let mut args = vec!["train"];
    args.extend(SMALL);
    let (c, r, p) = (
        ckpt.to_str().unwrap(),
        report.to_str().unwrap(),
        plot.to_str().unwrap(),
    );
    args.extend(["--checkpoint-out", c, "--report", r, "--plot", p]);
    args.extend(["--snapshot-every", "10", "--snapshot-targets", "2"]);
    let out = trn(&args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("paper (Sec. 8.4)") && stdout.contains("combined final error"),
        "{stdout}"
    );
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    for key in [
        "trials",
        "seed",
        "stage1_error_px",
        "stage2_error_px",
        "combined_error_px",
        "fine_moves",
        "final_error_px",
        "final_error_true_px",
        "noise_floor_px",
        "fine_moves_mean",
        "correction_cap_hits",
        "grasp_success_rate",
        "error_mm",
        "error_deg",
        "preset",
        "wall_s",
        "learning_curve",
        "failed_trials",
        "failures",
    ] {
        assert!(json.get(key).is_some(), "report lacks {key}");
    }
    // the names outside checks read (issue 11), with one entry per move of the budget
    let d = &json["deployment"];
    for key in [
        "stage1_true_px",
        "stage2_true_px",
        "combined_true_px",
        "stage1_measured_px",
        "stage2_measured_px",
        "combined_measured_px",
    ] {
        assert_eq!(d[key].as_array().map(Vec::len), Some(7), "deployment.{key}");
    }
    for key in [
        "targets",
        "fine_moves",
        "noise_floor_px",
        "moves_to_2px_mean",
        "failed_trials",
    ] {
        assert!(d.get(key).is_some(), "deployment lacks {key}");
    }
    // simulated time per target (issue 16): every move of both networks' trials is one
    // settle of 1.2 s before its capture (sim.toml's settle_s), nothing else advances the
    // plant's clock within a trial: (2 + fine moves of both) x 1.2 s
    let moves = json["fine_moves_mean"].as_f64().unwrap();
    let time = json["sim_time_per_target_s"].as_f64().unwrap();
    assert!(
        (time - 1.2 * (2.0 + 2.0 * moves)).abs() < 1e-3 * time,
        "{time} s for {moves} fine moves per network"
    );
    let curve = json["learning_curve"].as_array().unwrap();
    assert!(!curve.is_empty() && curve[0].get("stage1_true_px").is_some());
    assert_eq!(json["stage1_error_px"].as_array().unwrap().len(), 20);
    assert!(
        std::fs::metadata(&plot).unwrap().len() > 10_000,
        "a real PNG"
    );
    let out = trn(&[
        "eval",
        "--checkpoint-in",
        c,
        "--eval-targets",
        "3",
        "--fine-moves",
        "4",
        "--quiet",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("coarse move + 4 fine moves") && stdout.contains("combined, noise-free"),
        "the by-move table: {stdout}"
    );
    let out = trn(&["grasp", "--checkpoint-in", c, "--grasps", "2", "--quiet"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(!err.contains("not known"), "its .sim is beside it: {err}");
    // without its .sim, the plant the checkpoint was trained on cannot be checked: the run
    // goes on and says so
    std::fs::remove_file(format!("{c}.sim")).unwrap();
    let eval = [
        "eval",
        "--checkpoint-in",
        c,
        "--eval-targets",
        "1",
        "--quiet",
    ];
    let out = trn(&[&eval[..], &["--config", "ideal"]].concat());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("no simulator state beside it")
            && err.contains("the plant it was trained on is not known"),
        "{err}"
    );
}

#[test]
fn missing_and_malformed_configs_are_clear_errors() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let out = trn(&["train", "--config", "/nonexistent/sim.toml", "--quiet"]);
    fails_with(&out, "/nonexistent/sim.toml");
    let bad = tmp("bad.toml");
    std::fs::write(&bad, "dt_s = \"fast\"\n").unwrap();
    fails_with(
        &trn(&["train", "--config", bad.to_str().unwrap(), "--quiet"]),
        "dt_s",
    );
    std::fs::write(&bad, "pixel_noise_px = -1.0\n").unwrap();
    fails_with(
        &trn(&["train", "--config", bad.to_str().unwrap(), "--quiet"]),
        "pixel_noise_px",
    );
}

#[test]
fn corrupt_and_foreign_checkpoints_are_rejected() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let f = tmp("garbage.ckpt");
    std::fs::write(&f, b"TRNC not really a checkpoint").unwrap();
    fails_with(
        &trn(&["eval", "--checkpoint-in", f.to_str().unwrap(), "--quiet"]),
        "checkpoint",
    );
    std::fs::write(&f, vec![0u8; 1000]).unwrap();
    fails_with(
        &trn(&["eval", "--checkpoint-in", f.to_str().unwrap(), "--quiet"]),
        "magic",
    );
    fails_with(
        &trn(&["eval", "--checkpoint-in", "/nonexistent.ckpt", "--quiet"]),
        "/nonexistent.ckpt",
    );
}

#[test]
fn a_bus_that_does_not_exist_fails_and_keeps_the_last_checkpoint() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let ckpt = tmp("keep.ckpt");
    std::fs::write(&ckpt, b"previous checkpoint").unwrap();
    let c = ckpt.to_str().unwrap();
    fails_with(
        &trn(&[
            "train",
            "--bus",
            "socketcan:nosuch0",
            "--checkpoint-out",
            c,
            "--quiet",
        ]),
        "nosuch0",
    );
    fails_with(
        &trn(&["train", "--bus", "carrier-pigeon", "--quiet"]),
        "carrier-pigeon",
    );
    assert_eq!(std::fs::read(&ckpt).unwrap(), b"previous checkpoint");
}

/// A usage error: clap's clear message naming the argument, exit code 2, never a panic.
fn usage_error(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains(needle), "stderr lacks {needle:?}: {err}");
}

#[test]
fn meaningless_numbers_are_usage_errors() {
    for t in ["-1", "nan", "inf", "1e300", "0", "1e-300", "0.49"] {
        let arg = format!("--bus-timeout-s={t}");
        usage_error(&trn(&["train", &arg, "--quiet"]), "--bus-timeout-s");
    }
    usage_error(&trn(&["train", "--trials", "0", "--quiet"]), "--trials");
    usage_error(&trn(&["compare", "--seeds", "0"]), "--seeds");
    usage_error(
        &trn(&["train", "--fine-moves", "32", "--quiet"]),
        "--fine-moves",
    );
}

#[test]
fn outputs_that_cannot_be_written_fail_before_the_run() {
    // before the run: nothing was trained, so no summary was printed
    let out = trn(&["train", "--checkpoint-out", "/tmp", "--quiet"]);
    usage_error(&out, "is a directory");
    assert!(out.stdout.is_empty(), "the run went ahead");
    assert!(!std::path::Path::new("/tmp.tmp").exists());
    let out = trn(&["train", "--report", "/nonexistent/dir/r.json", "--quiet"]);
    fails_with(&out, "/nonexistent/dir");
    assert!(out.stdout.is_empty(), "the run went ahead");
}

#[test]
fn a_snapshot_beyond_the_held_out_set_is_refused() {
    let out = trn(&[
        "train",
        "--eval-targets",
        "5",
        "--snapshot-targets",
        "6",
        "--quiet",
    ]);
    usage_error(&out, "--snapshot-targets 6 is more than --eval-targets 5");
    assert!(out.stdout.is_empty(), "the run went ahead");
}

/// `--out` of the commands that write a folder: a file in its path is named, nothing ran,
/// and the file keeps its contents.
#[test]
fn an_output_folder_that_is_a_file_is_named() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let file = tmp("out-is-a-file");
    std::fs::write(&file, b"kept").unwrap();
    let f = file.to_str().unwrap();
    let under = file.join("sub");
    let commands: [&[&str]; 4] = [
        &[
            "compare",
            "--seeds",
            "1",
            "--trials",
            "2",
            "--eval-targets",
            "1",
        ],
        &["sweep", "--trials", "2", "--eval-targets", "1"],
        &[
            "lifelong",
            "--trials",
            "2",
            "--initial",
            "1",
            "--snapshot-every",
            "1",
        ],
        &["study", "../../studies/precision.toml", "--trials", "2"],
    ];
    for args in commands {
        for out_dir in [f, under.to_str().unwrap()] {
            let mut a = args.to_vec();
            a.extend(["--out", out_dir, "--quiet"]);
            let out = trn(&a);
            usage_error(&out, &format!("{f}: is a file, not a folder"));
            assert!(out.stdout.is_empty(), "{args:?} went ahead");
        }
    }
    assert_eq!(std::fs::read(&file).unwrap(), b"kept");
}

/// Two runs writing the same report, or two studies the same run folder, are refused while
/// the first holds the output's lock (the test holds it here), where the last writer's file
/// used to win with both runs exiting 0; nothing runs and the first's file is untouched.
#[test]
fn a_second_writer_of_the_same_output_is_refused() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let report = tmp("locked-report.json");
    std::fs::write(&report, b"the first run's").unwrap();
    let lock = |path: &std::path::Path| {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let file = std::fs::File::create(path.with_file_name(format!(".{name}.lock"))).unwrap();
        file.try_lock().unwrap();
        file
    };
    let held = lock(&report);
    let mut args = vec!["train", "--report", report.to_str().unwrap()];
    args.extend(SMALL);
    let out = trn(&args);
    usage_error(&out, "another run is writing this report");
    assert!(out.stdout.is_empty(), "the run went ahead");
    assert_eq!(std::fs::read(&report).unwrap(), b"the first run's");
    drop(held);

    let study = tmp("locked-study");
    std::fs::create_dir_all(study.join("runs")).unwrap();
    let held = lock(&study.join("runs"));
    let out = trn(&[
        "study",
        "../../studies/precision.toml",
        "--trials",
        "2",
        "--out",
        study.to_str().unwrap(),
        "--quiet",
    ]);
    usage_error(&out, "another run is writing this study's run folder");
    drop(held);
    let runs = std::fs::read_dir(study.join("runs")).unwrap().count();
    assert_eq!(runs, 0, "a run file was written");
}

/// Fails if a run without snapshots draws empty snapshot axes (ticks "0 0 0 ... 1 1")
/// instead of saying it took none, if a training panel's tick labels repeat a number, or if
/// the mean's legend names more trials than the run has.
#[test]
fn a_plot_without_snapshots_says_so() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let svg = tmp("no-snapshots.svg");
    let out = trn(&[
        "train",
        "--trials",
        "5",
        "--eval-targets",
        "2",
        "--grasps",
        "1",
        "--quiet",
        "--snapshot-every",
        "0",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&svg).unwrap();
    assert_eq!(
        text.matches("no snapshots: the run took none").count(),
        2,
        "both stages"
    );
    assert!(text.contains("mean over 5 trials") && !text.contains("mean over 21"));
    // the labels of the drawing, in order: each training panel's x axis reads 0 1 2 3 4 5
    let labels: Vec<&str> = text
        .split("</text>")
        .filter_map(|t| t.rsplit('>').next())
        .map(str::trim)
        .collect();
    let axis = ["0", "1", "2", "3", "4", "5"];
    let runs = labels.windows(axis.len()).filter(|w| *w == axis).count();
    assert_eq!(runs, 2, "{labels:?}");
    assert!(
        !labels.windows(2).any(|w| w == ["0", "0"]),
        "a repeated tick: {labels:?}"
    );
    let _ = std::fs::remove_file(&svg);
}
