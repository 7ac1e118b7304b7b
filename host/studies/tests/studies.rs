//! Studies of many runs: the same results with any number of workers and from shards
//! merged; an interrupted study resumed without redoing its finished runs (and redoing a
//! corrupt or foreign file); study files that name what is wrong in them.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use serde_json::Value;
use trn_studies::study::file::{Overrides, StudyFile};
use trn_studies::study::{self, runfile, Job, Options, RunFile, Shard, Study, Watch};

/// 2 rows x 2 hysteresis widths x 2 seeds of tiny runs (6 training trials, 3 held-out
/// targets, 2 grasps): 8 runs of a fraction of a second each.
const TINY: &str = r#"
name = "tiny"
seeds = { first = 100, count = 2 }
[base]
plant = "ideal"
trials = 6
eval_targets = 3
grasps = 2
snapshot_every = 3
snapshot_targets = 2
[[row]]
key = "project"
[[row]]
key = "broyden"
name = "Broyden"
law = "broyden"
trials = 0
[[axis]]
key = "joints.*.hysteresis_width"
name = "width"
values = [0.05, 0.2]
"#;

/// A folder of the test's own, named after it, removed when the test ends, passed or failed.
fn scratch(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("trn-studies-{name}-"))
        .tempdir()
        .expect("a temporary folder")
}

fn tiny(dir: &Path) -> Study {
    StudyFile::parse(TINY, "tiny")
        .unwrap()
        .study(
            Path::new("."),
            &Overrides::default(),
            Some(&dir.join("plants")),
        )
        .unwrap()
}

fn opts(runs: &Path, jobs: usize) -> Options {
    Options {
        jobs,
        runs: runs.to_path_buf(),
        resume: false,
        shard: None,
    }
}

/// The JSON with every wall time set to 0 (the only field that differs run to run).
fn without_wall(mut v: Value) -> Value {
    fn walk(v: &mut Value) {
        match v {
            Value::Object(m) => {
                for (k, x) in m.iter_mut() {
                    if k == "wall_s" {
                        *x = Value::from(0.0);
                    } else {
                        walk(x);
                    }
                }
            }
            Value::Array(a) => a.iter_mut().for_each(walk),
            _ => {}
        }
    }
    walk(&mut v);
    v
}

fn json_of(ran: study::Ran) -> Value {
    without_wall(ran.finished.expect("the whole study ran").json)
}

#[test]
fn the_grid_is_rows_times_axis_values_times_seeds() {
    let dir_scratch = scratch("grid");
    let s = tiny(dir_scratch.path());
    let names: Vec<(&str, u64)> = s
        .jobs
        .iter()
        .map(|j| (j.row.name.as_str(), j.spec.seed))
        .collect();
    assert_eq!(
        names,
        [
            ("project, width 0.05", 100),
            ("project, width 0.05", 101),
            ("project, width 0.2", 100),
            ("project, width 0.2", 101),
            ("Broyden, width 0.05", 100),
            ("Broyden, width 0.05", 101),
            ("Broyden, width 0.2", 100),
            ("Broyden, width 0.2", 101),
        ]
    );
    let j = &s.jobs[6];
    assert!(j
        .spec
        .plant
        .joints
        .iter()
        .all(|x| x.hysteresis_width == 0.2));
    assert_eq!(
        (j.spec.plan.trials, j.spec.profile.law.name()),
        (0, "broyden")
    );
    assert_eq!(s.jobs[0].spec.plan.trials, 6);
    // a plant made of keys is named by the runs, and written before the first run
    let file = PathBuf::from(j.spec.plant_name.clone().unwrap());
    assert!(
        !file.exists(),
        "building the study wrote {}",
        file.display()
    );
    assert!(s.write_plants(&|| false).unwrap());
    assert_eq!(trn_plant::SimConfig::load(&file).unwrap(), j.spec.plant);
}

/// A study of many configurations writes a plant file for each before its first run (up
/// to 100,000, each written durably: minutes), so an interrupt is heard between them: the
/// files written so far stay, no run starts, the study is reported interrupted.
#[test]
fn an_interrupt_while_the_plant_files_are_written_starts_no_run() {
    /// Says stop from its `at`-th question on (0-based), and from then on, as an interrupt does.
    struct StopWhenAsked {
        at: usize,
        asked: AtomicUsize,
    }
    impl Watch for StopWhenAsked {
        fn stop_requested(&self) -> bool {
            self.asked.fetch_add(1, Ordering::Relaxed) >= self.at
        }
    }
    let stop_at = |at| StopWhenAsked {
        at,
        asked: AtomicUsize::new(0),
    };
    let dir_scratch = scratch("plants-stop");
    let dir = dir_scratch.path();
    let s = tiny(dir);
    let named: Vec<PathBuf> = s.plants.iter().map(|p| p.path.clone()).collect();
    assert_eq!(named.len(), 4, "one plant per row and width");
    let written = || named.iter().filter(|p| p.exists()).count();
    // asked before each file: stopped before the third
    let stop = stop_at(2);
    assert!(!s.write_plants(&|| stop.stop_requested()).unwrap());
    assert_eq!(written(), 2);
    // a whole study: stopped before its second plant file, nothing run
    std::fs::remove_dir_all(dir.join("plants")).unwrap();
    let ran = study::run(&s, &opts(&dir.join("runs"), 1), &stop_at(1), None).unwrap();
    assert!(ran.interrupted && ran.finished.is_none());
    assert_eq!((ran.ran, ran.resumed), (0, 0));
    assert_eq!(written(), 1);
    let runs = std::fs::read_dir(dir.join("runs")).unwrap().count();
    assert_eq!(runs, 0, "a run file was written");
    // not stopped: every file, then the runs
    let ran = study::run(
        &s,
        &opts(&dir.join("runs"), 1),
        &trn_bench::Unobserved,
        None,
    )
    .unwrap();
    assert!(!ran.interrupted && ran.ran == 8);
    assert_eq!(written(), 4);
}

/// Building a study asks whether to stop before each configuration (of the grid's
/// crossing and of the runs made from them) and ends with `Interrupted` when told to. Fails
/// if the build is not asked, goes on after a stop, or a stop is taken for a study.
#[test]
fn an_interrupt_while_a_study_is_built_ends_it_before_anything_runs() {
    // 2 rows x 2 widths x 500 damping ratios: 2,000 configurations
    let ratios: Vec<String> = (0..500)
        .map(|i| format!("{}", 0.3 + i as f64 * 1e-4))
        .collect();
    let grid = format!(
        "{TINY}[[axis]]\nkey = \"joints.*.damping_ratio\"\nvalues = [{}]\n",
        ratios.join(", ")
    );
    let file = StudyFile::parse(&grid, "grid").unwrap();
    let dir_scratch = scratch("build-stop");
    let dir = dir_scratch.path();
    let plants = dir.join("plants");
    let build = |at: usize| {
        let asked = AtomicUsize::new(0);
        let made = file.study_unless(
            Path::new("."),
            &Overrides::default(),
            Some(&plants),
            &|| asked.fetch_add(1, Ordering::Relaxed) >= at,
        );
        (made, asked.load(Ordering::Relaxed))
    };
    for at in [0, 3, 1500] {
        let (made, asked) = build(at);
        match made {
            Err(trn_bench::LabError::Interrupted(what)) => assert!(what.contains("study")),
            other => panic!("stop at {at}: {:?}", other.map(|s| s.jobs.len())),
        }
        assert_eq!(asked, at + 1, "asked after the stop");
    }
    let (made, asked) = build(usize::MAX);
    assert_eq!(made.unwrap().jobs.len(), 2 * 2 * 500 * 2);
    assert!(
        asked >= 2_000,
        "asked {asked} times for 2,000 configurations"
    );
    assert!(!plants.exists(), "building a study writes no file");
}

/// `--jobs 2` gives the runs and the table of `--jobs 1`, and so do two shards merged.
#[test]
fn parallel_and_sharded_studies_give_the_results_of_one_worker() {
    let dir_scratch = scratch("parallel");
    let dir = dir_scratch.path();
    let s = tiny(dir);
    let one = study::run(&s, &opts(&dir.join("one"), 1), &trn_bench::Unobserved, None).unwrap();
    let two = study::run(&s, &opts(&dir.join("two"), 2), &trn_bench::Unobserved, None).unwrap();
    let (one, two) = (json_of(one), json_of(two));
    assert_eq!(one, two, "2 workers changed the results");
    for shard in 0..2 {
        let o = Options {
            shard: Some(Shard {
                index: shard,
                count: 2,
            }),
            ..opts(&dir.join(format!("shard{shard}")), 2)
        };
        let ran = study::run(&s, &o, &trn_bench::Unobserved, None).unwrap();
        assert!(ran.finished.is_none(), "a shard makes no table");
        assert_eq!(ran.ran, 4);
    }
    let paths = runfile::expand(&[dir.join("shard1"), dir.join("shard0")]).unwrap();
    assert_eq!(paths.len(), 8);
    let files: Vec<RunFile> = paths.iter().map(|p| RunFile::read(p).unwrap()).collect();
    let merged = study::finish(files.clone()).unwrap();
    assert_eq!(
        without_wall(merged.json),
        one,
        "the merge of the shards is not the study"
    );
    // the table names the rows and gives the worst seed beside each mean
    assert!(
        merged.table.contains("| project, width 0.2 | 6 |"),
        "{}",
        merged.table
    );
    assert!(merged.table.contains(") |"), "{}", merged.table);
    // a shard missing is named; files of another study are refused
    let err = study::finish(files[..7].to_vec()).unwrap_err().to_string();
    assert!(err.contains("1 of its 8 runs have no file"), "{err}");
    let mut foreign = files.clone();
    foreign[0].study.digest = "0".repeat(16);
    let err = study::finish(foreign).unwrap_err().to_string();
    assert!(err.contains("two studies"), "{err}");
}

/// Stops the study after `after` runs finished; counts what it saw.
struct StopAfter {
    after: usize,
    finished: AtomicUsize,
    notes: std::sync::Mutex<Vec<String>>,
}

impl StopAfter {
    fn new(after: usize) -> StopAfter {
        StopAfter {
            after,
            finished: AtomicUsize::new(0),
            notes: Default::default(),
        }
    }
}

impl Watch for StopAfter {
    fn note(&self, text: &str) {
        self.notes.lock().unwrap().push(text.to_string());
    }
    fn finished(&self, _: &Job, _: &RunFile, _: &Path) {
        self.finished.fetch_add(1, Ordering::SeqCst);
    }
    fn stop_requested(&self) -> bool {
        self.finished.load(Ordering::SeqCst) >= self.after
    }
}

/// A study interrupted after 4 of its 8 runs keeps them; resumed, it runs only what is
/// missing, redoes a file cut short, a file holding another specification and a file whose
/// checksum does not match, and makes
/// the table of a study that was never interrupted.
#[test]
fn an_interrupted_study_resumes_without_redoing_its_finished_runs() {
    let dir_scratch = scratch("resume");
    let dir = dir_scratch.path();
    let s = tiny(dir);
    let runs = dir.join("runs");
    let stop = StopAfter::new(4);
    let first = study::run(&s, &opts(&runs, 1), &stop, None).unwrap();
    assert!(first.interrupted && first.finished.is_none());
    assert_eq!(first.ran, 4);
    let path = |i: usize| runs.join(s.jobs[i].file_name());
    let written: Vec<usize> = (0..8).filter(|&i| path(i).exists()).collect();
    assert_eq!(written, [0, 1, 2, 3], "one worker runs in order");
    let kept = std::fs::read(path(1)).unwrap();
    // run 0's file cut short (a disk full before the durable writes, a copy gone wrong),
    // run 2's holding another specification under its name
    let whole = std::fs::read(path(0)).unwrap();
    std::fs::write(path(0), &whole[..whole.len() / 2]).unwrap();
    let mut other: Value = serde_json::from_slice(&std::fs::read(path(2)).unwrap()).unwrap();
    other["report"]["spec"]["plan"]["grasps"] = Value::from(9);
    let sealed = runfile::seal(&serde_json::to_vec_pretty(&other).unwrap()).unwrap();
    std::fs::write(path(2), sealed).unwrap();
    // run 3's file with one digit of its report changed and its checksum as written (one
    // flipped bit on a disk or a copy): once taken as true
    let text = std::fs::read_to_string(path(3)).unwrap();
    let at = text.find("\"seed\": ").unwrap() + "\"seed\": ".len();
    let mut bytes = text.into_bytes();
    bytes[at] = if bytes[at] == b'9' {
        b'8'
    } else {
        bytes[at] + 1
    };
    std::fs::write(path(3), bytes).unwrap();

    let watch = StopAfter::new(usize::MAX);
    let resumed = study::run(
        &s,
        &Options {
            resume: true,
            ..opts(&runs, 2)
        },
        &watch,
        None,
    )
    .unwrap();
    assert_eq!(
        (resumed.resumed, resumed.ran),
        (1, 7),
        "{:?}",
        watch.notes.lock().unwrap()
    );
    assert_eq!(
        std::fs::read(path(1)).unwrap(),
        kept,
        "a finished run was written again"
    );
    let notes = watch.notes.lock().unwrap().join("\n");
    assert!(
        notes.contains("unreadable")
            && notes.contains("another run specification")
            && notes.contains("checksum"),
        "{notes}"
    );

    let fresh = study::run(
        &s,
        &opts(&dir.join("fresh"), 2),
        &trn_bench::Unobserved,
        None,
    )
    .unwrap();
    assert_eq!(json_of(resumed), json_of(fresh));
}

/// `--first-seed` moves a study's seeds and keeps their count (`--seeds`, else the file's
/// count or its list's length): the rows tuned on some seeds, reported on others; a count
/// that would pass the largest seed is refused.
#[test]
fn the_first_seed_moves_the_seeds_and_keeps_their_count() {
    let seeds_of = |file_seeds: &str, over: Overrides| -> Vec<u64> {
        let text =
            format!("name = \"t\"\nseeds = {file_seeds}\n[base]\nplant = \"ideal\"\ntrials = 3\n");
        let s = StudyFile::parse(&text, "t.toml")
            .and_then(|f| f.study(Path::new("."), &over, None))
            .unwrap();
        s.jobs.iter().map(|j| j.spec.seed).collect()
    };
    let first = |f: u64, n: Option<u64>| Overrides {
        first_seed: Some(f),
        seeds: n,
        ..Overrides::default()
    };
    let range = "{ first = 1, count = 3 }";
    assert_eq!(seeds_of(range, Overrides::default()), [1, 2, 3]);
    assert_eq!(seeds_of(range, first(100, None)), [100, 101, 102]);
    assert_eq!(
        seeds_of(range, first(100, Some(5))),
        [100, 101, 102, 103, 104]
    );
    assert_eq!(seeds_of("[5, 9]", first(200, None)), [200, 201]);
    assert_eq!(seeds_of("[5, 9]", first(200, Some(1))), [200]);
    let e = refused(
        &format!("name = \"t\"\nseeds = {range}\n"),
        &first(u64::MAX - 1, None),
    );
    assert!(
        e.contains("3 seeds from") && e.contains("largest seed"),
        "{e}"
    );
}

fn refused(text: &str, over: &Overrides) -> String {
    let dir_scratch = scratch("refused");
    let dir = dir_scratch.path();
    match StudyFile::parse(text, "t.toml").and_then(|f| f.study(Path::new("."), over, Some(dir))) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Two rows with the same name, key or plant file name are refused naming both (they were
/// pooled into one table row, one plant file written for both); huge seed counts and grids
/// are refused before anything is allocated (`seeds.count` at i64::MAX panicked on
/// capacity, 10^8 aborted on memory); a study name without a letter is refused.
#[test]
fn duplicate_rows_and_huge_counts_are_refused_naming_them() {
    let two = |a: &str, b: &str| {
        format!(
            "name = \"t\"\nseeds = [100]\n[[row]]\n{a}\nset = {{ pixel_noise_px = 0.1 }}\n\
             [[row]]\n{b}\nset = {{ pixel_noise_px = 0.2 }}\n"
        )
    };
    let e = refused(&two("name = \"a\"", "name = \"a\""), &Overrides::default());
    assert!(
        e.contains("rows 1 (\"a\") and 2 (\"a\")") && e.contains("same name"),
        "{e}"
    );
    let e = refused(
        &two("name = \"a\"\nkey = \"k\"", "name = \"b\"\nkey = \"k\""),
        &Overrides::default(),
    );
    assert!(
        e.contains("rows 1 (\"a\") and 2 (\"b\")") && e.contains("same key \"k\""),
        "{e}"
    );
    let e = refused(
        &two("name = \"a b\"\nkey = \"x\"", "name = \"a-b\"\nkey = \"y\""),
        &Overrides::default(),
    );
    assert!(e.contains("same plant file name \"a-b.toml\""), "{e}");
    for count in [i64::MAX as u64, 100_000_000] {
        let e = refused(
            &format!("name = \"t\"\nseeds = {{ first = 0, count = {count} }}\n"),
            &Overrides::default(),
        );
        assert!(e.contains("more than a study runs"), "{e}");
    }
    let e = refused(
        "name = \"t\"\nseeds = { first = 100, count = 2 }\n",
        &Overrides {
            seeds: Some(1_000_000),
            ..Overrides::default()
        },
    );
    assert!(e.contains("more than a study runs"), "{e}");
    let axis = |n: usize| {
        format!(
            "[[axis]]\nkey = \"pixel_noise_px\"\nvalues = [{}]\n",
            vec!["0.1"; n].join(",")
        )
    };
    let e = refused(
        &format!("name = \"t\"\nseeds = [1]\n{}{}", axis(1000), axis(1000)),
        &Overrides::default(),
    );
    assert!(e.contains("makes 1000000 configurations"), "{e}");
    let e = refused("name = \"\"\nseeds = [1]\n", &Overrides::default());
    assert!(e.contains("needs a letter or digit"), "{e}");
}

/// A bad key, a value out of its range, a value of the wrong type, an unknown setting or
/// row: refused before anything runs, naming it.
#[test]
fn study_files_name_what_is_wrong_in_them() {
    let head = "name = \"t\"\nseeds = [100]\n";
    let row = |body: &str| format!("{head}[[row]]\nname = \"r\"\n{body}\n");
    let e = refused(
        &row(r#"set = { "joints.*.hysterisis_width" = 0.1 }"#),
        &Overrides::default(),
    );
    assert!(
        e.contains("`joints.*.hysterisis_width`") && e.contains("hysteresis_width"),
        "{e}"
    );
    let e = refused(
        &row(r#"set = { "realism.load_width_gain" = -1.0 }"#),
        &Overrides::default(),
    );
    assert!(
        e.contains("load_width_gain") && e.contains("study t, r"),
        "{e}"
    );
    let e = refused(
        &row(r#"set = { pixel_noise_px = "low" }"#),
        &Overrides::default(),
    );
    assert!(
        e.contains("pixel_noise_px") && e.contains("takes float"),
        "{e}"
    );
    let e = refused(
        &row(r#"set = { "joints.7.damping_ratio" = 0.2 }"#),
        &Overrides::default(),
    );
    assert!(
        e.contains("`joints.7.damping_ratio`") && e.contains("index 0..5"),
        "{e}"
    );
    let e = refused(&row(r#"set = { realism = 0.2 }"#), &Overrides::default());
    assert!(e.contains("is a table"), "{e}");
    let e = refused(
        &row(r#"copy = { from = "nowhere.toml", keys = ["dt_s"] }"#),
        &Overrides::default(),
    );
    assert!(e.contains("nowhere.toml"), "{e}");
    let e = refused(&row("presett = \"paper\""), &Overrides::default());
    assert!(e.contains("presett"), "{e}");
    let e = refused(&row("preset = \"papr\""), &Overrides::default());
    assert!(e.contains("papr"), "{e}");
    let e = refused(&row("fine_moves = 40"), &Overrides::default());
    assert!(e.contains("fine_moves 40"), "{e}");
    let e = refused(
        &format!("{head}[[axis]]\nkey = \"law\"\nvalues = [\"trn\", \"magic\"]\n"),
        &Overrides::default(),
    );
    assert!(e.contains("axis law") && e.contains("magic"), "{e}");
    let only = Overrides {
        configs: vec!["nope".into()],
        ..Overrides::default()
    };
    let e = refused(&row(""), &only);
    assert!(e.contains("\"nope\"") && e.contains("--configs"), "{e}");
}

/// Controller keys: a row's `controller` table and an axis's `controller.` keys set fields of
/// the controller's configuration (`*` both stages), on top of the profile's; a row without
/// them runs the profile's configuration through the session; two configurations that
/// differ only in them never share a run file.
#[test]
fn controller_keys_set_the_controller_configuration() {
    let text = r#"
name = "keys"
seeds = [1]
[base]
plant = "ideal"
trials = 3
[[row]]
key = "plain"
[[row]]
key = "tuned"
controller = { "*.map_step" = 0.7, "stage1.dv_noise" = 2, "stage2.max_fine_moves" = 4 }
[[axis]]
key = "controller.stage2.trial_secant"
values = [0.0, 0.5]
"#;
    let dir_scratch = scratch("controller-keys");
    let dir = dir_scratch.path();
    let study = StudyFile::parse(text, "keys.toml")
        .and_then(|f| f.study(Path::new("."), &Overrides::default(), Some(dir)))
        .unwrap();
    assert_eq!(study.jobs.len(), 4);
    let profile = study.jobs[0].spec.profile_config();
    for job in &study.jobs {
        let got = job
            .spec
            .controller_override
            .expect("every row has the axis's key");
        let mut want = profile;
        want.stage2.trial_secant = if job.row.name.contains("0.5") {
            0.5
        } else {
            0.0
        };
        if job.row.key.starts_with("tuned") {
            want.stage1.map_step = 0.7;
            want.stage2.map_step = 0.7;
            want.stage1.dv_noise = 2.0;
            want.stage2.max_fine_moves = 4;
        }
        assert_eq!(got, want, "{}", job.row.name);
    }
    let names: std::collections::HashSet<String> =
        study.jobs.iter().map(|j| j.file_name()).collect();
    assert_eq!(names.len(), 4, "{names:?}");
    // without controller keys: no override, the profile's configuration over the session
    let plain = StudyFile::parse(
        "name = \"p\"\nseeds = [1]\n[[row]]\nkey = \"plain\"\n",
        "p.toml",
    )
    .and_then(|f| f.study(Path::new("."), &Overrides::default(), Some(dir)))
    .unwrap();
    assert!(plain.jobs[0].spec.controller_override.is_none());
}

/// A controller key that is not a field, of the wrong type, or naming a whole table:
/// refused before anything runs, naming the key.
#[test]
fn controller_keys_name_what_is_wrong_in_them() {
    let row = |body: &str| format!("name = \"t\"\nseeds = [1]\n[[row]]\nname = \"r\"\n{body}\n");
    let e = refused(
        &row(r#"controller = { "*.map_stepp" = 0.7 }"#),
        &Overrides::default(),
    );
    assert!(
        e.contains("unknown controller key `*.map_stepp`") && e.contains("study t, r"),
        "{e}"
    );
    let e = refused(
        &row(r#"controller = { "stage1.max_fine_moves" = 1.5 }"#),
        &Overrides::default(),
    );
    assert!(
        e.contains("controller key `stage1.max_fine_moves` takes integer"),
        "{e}"
    );
    let e = refused(
        &row(r#"controller = { "stage1" = 1.0 }"#),
        &Overrides::default(),
    );
    assert!(e.contains("controller key `stage1` is a table"), "{e}");
    let e = refused(
        "name = \"t\"\nseeds = [1]\n[[axis]]\nkey = \"controller.stage3.sigma\"\nvalues = [1.0]\n",
        &Overrides::default(),
    );
    assert!(
        e.contains("`stage3.sigma`") && e.contains("stage1, stage2"),
        "{e}"
    );
}

/// A snapshot evaluates the first of the held-out targets: a study asking for more of them
/// than the held-out set has is refused naming both (it was cut to the set without a word).
#[test]
fn a_snapshot_beyond_the_held_out_set_is_refused() {
    let file = |snapshot: usize| {
        format!(
            "name = \"t\"\nseeds = [100]\n[base]\ntrials = 2\neval_targets = 5\n\
             snapshot_targets = {snapshot}\n[[row]]\nname = \"a\"\n"
        )
    };
    let e = refused(&file(6), &Overrides::default());
    assert!(
        e.contains("snapshot_targets 6 is more than eval_targets 5"),
        "{e}"
    );
    let dir_scratch = scratch("snapshot-5");
    let dir = dir_scratch.path();
    StudyFile::parse(&file(5), "t.toml")
        .and_then(|f| f.study(Path::new("."), &Overrides::default(), Some(dir)))
        .expect("as many as the held-out set");
}

/// A study's folder whose path runs through a file is refused naming that file, before
/// anything runs, and the file is left as it was.
#[test]
fn a_run_folder_under_a_file_is_refused_naming_the_file() {
    let dir_scratch = scratch("folder-is-a-file");
    let dir = dir_scratch.path();
    let file = dir.join("results");
    std::fs::write(&file, b"kept").unwrap();
    let s = tiny(dir);
    for runs in [file.clone(), file.join("runs")] {
        let e = match study::run(&s, &opts(&runs, 1), &trn_bench::Unobserved, None) {
            Ok(_) => panic!("a run folder under a file was accepted"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains(&format!("{}: is a file, not a folder", file.display())),
            "{e}"
        );
    }
    assert_eq!(std::fs::read(&file).unwrap(), b"kept");
}
