//! What a user gets from the tools besides the run: each binary's help says what it does,
//! a report says what produced it (provenance), `--csv` has a row per trial, `trn decode`
//! decodes every frame of a training's candump log, and the live view refuses early.

use std::process::{Command, Output};

fn run(bin: &str, args: &[&str]) -> Output {
    Command::new(bin)
        .args(args)
        .output()
        .expect("the binary runs")
}

/// A folder of the test's own, removed when the test ends, passed or failed.
fn scratch() -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix("trn-tools-")
        .tempdir()
        .expect("a temporary folder")
}

fn stdout(o: &Output) -> String {
    assert!(
        o.status.success(),
        "failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn each_binarys_help_says_what_that_binary_does() {
    for (bin, says) in [
        (env!("CARGO_BIN_EXE_trn"), "train, evaluate and compare"),
        (
            env!("CARGO_BIN_EXE_sim-pictures"),
            "pictures of the simulated plant",
        ),
    ] {
        let help = stdout(&run(bin, &["--help"])).replace('\n', " ");
        assert!(help.contains(says), "{bin} --help: {help}");
        // not the package's description, shared by all three
        assert!(
            !help.contains("The command line of the TRN soft-arm project"),
            "{help}"
        );
    }
}

#[test]
fn a_training_log_decodes_whole_and_the_report_says_what_produced_it() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let (log, csv, report) = (tmp("bus.log"), tmp("trials.csv"), tmp("run.json"));
    let trn = env!("CARGO_BIN_EXE_trn");
    let args = [
        "train",
        "--quiet",
        "--trials",
        "12",
        "--eval-targets",
        "3",
        "--grasps",
        "2",
        "--snapshot-every",
        "0",
        "--seed",
        "5",
    ];
    let mut all: Vec<&str> = args.to_vec();
    let (l, c, r) = (
        log.to_str().unwrap(),
        csv.to_str().unwrap(),
        report.to_str().unwrap(),
    );
    all.extend(["--candump", l, "--csv", c, "--report", r]);
    stdout(&run(trn, &all));

    // every frame of a CAN 2.0 log, segmented messages included
    let out = stdout(&run(trn, &["decode", l]));
    let last = out.lines().last().unwrap();
    assert!(last.ends_with(", 0 undecoded"), "{last}");
    assert!(
        out.contains("segment 1/7 of Observation"),
        "no segments decoded"
    );
    let frames: usize = last.split(' ').next().unwrap().parse().unwrap();
    let lines = std::fs::read_to_string(&log).unwrap().lines().count();
    assert_eq!(frames, lines, "{last}");
    assert!(out.contains("Stage1Target") && out.contains("TrialReport"));

    // a row per trial: 12 + 12 training trials, the evaluations', the grasps'
    let rows = std::fs::read_to_string(&csv).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let header = rows.lines().next().unwrap();
    assert!(header.starts_with("trial,phase,"), "{header}");
    let training = rows.lines().filter(|r| r.contains(",training,")).count();
    assert_eq!(training, 24, "{rows}");
    assert!(rows.lines().any(|r| r.contains(",grasp,")), "{rows}");
    for r in rows.lines() {
        assert_eq!(r.split(',').count(), header.split(',').count(), "{r}");
    }

    // provenance: the version, the commit, the command line; the spec with the plant
    let p = &json["provenance"];
    assert_eq!(p["version"], env!("CARGO_PKG_VERSION"));
    assert!(p["git_commit"].as_str().is_some_and(|c| !c.is_empty()));
    let cmd: Vec<&str> = p["command_line"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| a.as_str().unwrap())
        .collect();
    assert_eq!(&cmd[1..args.len() + 1], &args[..], "{cmd:?}");
    // the compiler, the locked dependencies, the machine and the time
    assert!(
        p["rustc"].as_str().is_some_and(|r| r.starts_with("rustc ")),
        "{p}"
    );
    assert!(
        p["dependencies"].as_array().is_some_and(|d| d
            .iter()
            .any(|v| v.as_str().is_some_and(|v| v.starts_with("nalgebra ")))),
        "{p}"
    );
    assert!(p["host"].as_str().is_some_and(|h| !h.is_empty()), "{p}");
    let when = p["created_utc"].as_str().unwrap_or_default();
    assert!(
        when.len() == 20 && when.ends_with('Z') && when.as_bytes()[10] == b'T',
        "{p}"
    );
    assert!(json["spec"]["plant"]["joints"].is_array());
    assert_eq!(json["preset"], "project");
}

#[test]
fn the_law_never_takes_the_presets_place_in_a_report() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let report = tmp("broyden.json");
    let r = report.to_str().unwrap();
    stdout(&run(
        env!("CARGO_BIN_EXE_trn"),
        &[
            "train",
            "--quiet",
            "--controller",
            "broyden",
            "--preset",
            "paper",
            "--trials",
            "2",
            "--eval-targets",
            "1",
            "--grasps",
            "0",
            "--snapshot-every",
            "0",
            "--report",
            r,
        ],
    ));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(
        (json["preset"].as_str(), json["law"].as_str()),
        (Some("paper"), Some("broyden"))
    );
}

#[test]
fn the_live_view_without_its_python_package_is_refused_before_the_run() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let save = tmp("run.rrd");
    let out = Command::new(env!("CARGO_BIN_EXE_trn"))
        .args(["train", "--quiet", "--rerun-save", save.to_str().unwrap()])
        .env("TRN_PYTHON", "false")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("pip install"), "{err}");
    assert!(!save.exists());
    // a recording is an .rrd file (the output rule)
    let out = run(
        env!("CARGO_BIN_EXE_trn"),
        &[
            "train",
            "--quiet",
            "--rerun-save",
            tmp("run.json").to_str().unwrap(),
        ],
    );
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains(".rrd"));
}

#[test]
fn study_results_carry_their_provenance() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let trn = env!("CARGO_BIN_EXE_trn");
    let cmp = tmp("compare.json");
    let c = cmp.to_str().unwrap();
    // the runs go beside the report: the default (out/compare in the working directory)
    // would write into the checkout
    let cmp_out = tmp("compare-out");
    stdout(&run(
        trn,
        &[
            "compare",
            "--seeds",
            "1",
            "--trials",
            "3",
            "--project-only",
            "--report",
            c,
            "--out",
            cmp_out.to_str().unwrap(),
        ],
    ));
    let dir = tmp("lifelong");
    let d = dir.to_str().unwrap();
    std::fs::create_dir_all(&dir).unwrap();
    stdout(&run(
        trn,
        &[
            "lifelong",
            "--trials",
            "10",
            "--initial",
            "5",
            "--snapshot-every",
            "5",
            "--snapshot-targets",
            "2",
            "--snapshot-grasps",
            "1",
            "--only",
            "frozen",
            "--out",
            d,
        ],
    ));
    for (file, cmd) in [(cmp, "compare"), (dir.join("lifelong.json"), "lifelong")] {
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
        assert_eq!(json["provenance"]["command_line"][1], cmd, "{json}");
        assert!(json["provenance"]["git_commit"].is_string());
        assert!(json["results"].as_array().is_some_and(|r| !r.is_empty()));
    }
}

#[test]
fn trn_model_writes_the_arms_description() {
    let scratch = scratch();
    let tmp = |name: &str| scratch.path().join(name);
    let trn = env!("CARGO_BIN_EXE_trn");
    let cfg = trn_plant::SimConfig::ideal();
    let urdf = stdout(&run(trn, &["model", "--config", "ideal"]));
    assert_eq!(urdf, trn_plant::model::urdf(&cfg));
    assert!(urdf.contains("<link name=\"light_p\">"));
    let mjcf = stdout(&run(trn, &["model", "--config", "ideal", "--mjcf"]));
    assert_eq!(mjcf, trn_plant::model::mjcf(&cfg));
    // a file: the lengths are its own
    let file = tmp("short-arm.toml");
    let sim_toml = concat!(env!("CARGO_MANIFEST_DIR"), "/../plant/sim.toml");
    let text = std::fs::read_to_string(sim_toml).unwrap();
    assert!(text.contains("\nupper_arm_mm = 420.0\n"));
    std::fs::write(
        &file,
        text.replace("\nupper_arm_mm = 420.0\n", "\nupper_arm_mm = 300.0\n"),
    )
    .unwrap();
    let short = trn_plant::SimConfig::load(&file).unwrap();
    assert_eq!(short.upper_arm_mm, 300.0);
    let from_file = stdout(&run(trn, &["model", "--config", file.to_str().unwrap()]));
    assert_eq!(from_file, trn_plant::model::urdf(&short));
    assert_ne!(from_file, urdf);
    let missing = run(trn, &["model", "--config", "no-such-plant.toml"]);
    assert_eq!(missing.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&missing.stderr).contains("no-such-plant.toml"));
}
