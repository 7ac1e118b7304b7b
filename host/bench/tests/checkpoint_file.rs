//! Checkpoint files under a kill -9 at a random moment of the write, and bad files.

use std::path::Path;
use std::process::Command;
use std::time::Duration;

use trn_bench::checkpoint_file;
use trn_controller::checkpoint::{self, Provenance};
use trn_controller::{Config, Controller};

/// A folder of the test's own, named after it, removed when the test ends, passed or failed.
fn dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("trn-ckpt-{name}-"))
        .tempdir()
        .expect("a temporary folder")
}

fn controller(seed: u64) -> Box<Controller> {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(seed);
    c
}

/// Starts the writer test `child` of this executable on `path` (through the variable `env`)
/// and kills it (SIGKILL) after `from_ms` plus a pseudo-random draw from `seed` of up to
/// 200 ms.
fn kill_a_writer(child: &str, env: &str, path: &Path, seed: &mut u64, from_ms: u64) {
    let me = std::env::current_exe().unwrap();
    let mut child = Command::new(me)
        .args(["--exact", child, "--nocapture", "--test-threads", "1"])
        .env(env, path)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    std::thread::sleep(Duration::from_millis(from_ms + *seed % 200));
    child.kill().unwrap();
    child.wait().unwrap();
}

/// Not a test of its own: the writer the kill test starts in a child process (this test
/// executable, with `TRN_CKPT_WRITER` set). It writes checkpoints of alternating tables to
/// the path until it is killed.
#[test]
fn checkpoint_writer_child() {
    let Some(path) = std::env::var_os("TRN_CKPT_WRITER") else {
        return;
    };
    let (a, b) = (controller(1), controller(2));
    for i in 0.. {
        let c = if i % 2 == 0 { &a } else { &b };
        checkpoint_file::save(c, Provenance::CUSTOM, Path::new(&path)).unwrap();
    }
}

/// A kill -9 at random moments of repeated checkpoint writes: the path always holds a whole,
/// valid checkpoint (the old or the new one), and a file beside it that the writer did not
/// create is never touched. Fails if the write ever truncates or writes the target in place,
/// or uses a fixed temporary name that can collide with another file.
#[test]
fn a_kill_during_a_write_leaves_the_old_or_the_new_checkpoint() {
    let d_scratch = dir("kill");
    let d = d_scratch.path();
    let path = d.join("run.ckpt");
    let bystander = d.join("run.tmp");
    std::fs::write(&bystander, b"an unrelated file").unwrap();
    checkpoint_file::save(&controller(1), Provenance::CUSTOM, &path).unwrap();
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    for round in 0..12 {
        kill_a_writer(
            "checkpoint_writer_child",
            "TRN_CKPT_WRITER",
            &path,
            &mut seed,
            30,
        );
        let bytes = std::fs::read(&path).unwrap();
        let h = checkpoint::verify(&bytes);
        assert!(h.is_ok(), "round {round}: {:?} ({} bytes)", h, bytes.len());
        let mut c = Box::new(Controller::new(Config::project_default()));
        checkpoint_file::load(&mut c, &path, Provenance::CUSTOM, false).unwrap();
        assert_eq!(std::fs::read(&bystander).unwrap(), b"an unrelated file");
    }
    // stray temporary files of killed writes are hidden names of the checkpoint's own
    for entry in std::fs::read_dir(d).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(
            name == "run.ckpt" || name == "run.tmp" || name.starts_with(".run.ckpt.tmp-"),
            "{name}"
        );
    }
}

fn sim_state(trials_done: usize) -> trn_bench::sim_state::SimState {
    use rand_core::SeedableRng;
    let mut plant = trn_plant::Plant::new(&trn_plant::SimConfig::aging(), 7).unwrap();
    plant.settle();
    trn_bench::sim_state::SimState {
        version: trn_bench::sim_state::VERSION,
        seed: 7,
        trials_done,
        trials_planned: 1 << 30,
        history: Default::default(),
        runner_rng: rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3),
        runner_trial: 0,
        checkpoint_crc: 0,
        plant,
    }
}

/// Not a test of its own: the writer of the pair test, in a child process (with
/// `TRN_PAIR_WRITER` set). It writes checkpoint pairs (alternating tables, the simulator's
/// state counting the saves) until it is killed.
#[test]
fn pair_writer_child() {
    let Some(path) = std::env::var_os("TRN_PAIR_WRITER") else {
        return;
    };
    let (a, b) = (controller(1), controller(2));
    for i in 1.. {
        let c = if i % 2 == 0 { &a } else { &b };
        checkpoint_file::save_with_state(c, Provenance::CUSTOM, Path::new(&path), sim_state(i))
            .unwrap();
    }
}

/// A kill -9 at random moments of repeated checkpoint pair writes (the controller's
/// checkpoint and the simulator's `.sim`): a pair that continues is always there, the
/// checkpoint on disk with the state saved with it. Fails if a kill between the pair's two
/// writes leaves a checkpoint and a `.sim` from different saves (as writing the checkpoint,
/// then the `.sim` over the old one, did).
#[test]
fn a_kill_during_a_pair_write_leaves_a_pair_that_continues() {
    let d_scratch = dir("pair");
    let d = d_scratch.path();
    let path = d.join("run.ckpt");
    checkpoint_file::save_with_state(&controller(1), Provenance::CUSTOM, &path, sim_state(0))
        .unwrap();
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    let mut kept = 0;
    for round in 0..16 {
        kill_a_writer("pair_writer_child", "TRN_PAIR_WRITER", &path, &mut seed, 60);
        let (bytes, _) = checkpoint_file::read(&path).unwrap();
        let crc = checkpoint_file::crc_of(&bytes);
        let state =
            trn_bench::sim_state::load_beside(&path, 7, &trn_plant::SimConfig::aging(), crc)
                .unwrap_or_else(|e| panic!("round {round}: {e}"));
        assert_eq!(state.checkpoint_crc, crc);
        kept += usize::from(trn_bench::sim_state::previous_beside(&path).exists());
    }
    // a finished save leaves no kept `.sim`
    checkpoint_file::save_with_state(&controller(1), Provenance::CUSTOM, &path, sim_state(0))
        .unwrap();
    assert!(!trn_bench::sim_state::previous_beside(&path).exists());
    eprintln!("{kept} of 16 kills came between a pair's two writes");
}

#[test]
fn a_checkpoint_of_another_configuration_is_refused_unless_allowed() {
    let d_scratch = dir("config");
    let d = d_scratch.path();
    let path = d.join("a.ckpt");
    let paper = Provenance::of(
        trn_controller::presets::Preset::Paper,
        trn_controller::presets::Ablation::None,
    );
    let mut c = Box::new(Controller::new(Config::paper()));
    c.init_random(3);
    checkpoint_file::save(&c, paper, &path).unwrap();
    let mut project = controller(4);
    let before = project.stage1().net().clone();
    let project_prov = Provenance::of(
        trn_controller::presets::Preset::Project,
        trn_controller::presets::Ablation::None,
    );
    let e = checkpoint_file::load(&mut project, &path, project_prov, false).unwrap_err();
    assert!(e.to_string().contains("--allow-config-change"), "{e}");
    assert!(project.stage1().net() == &before, "nothing loaded");
    // the same provenance but another configuration: the fingerprint tells
    let e = checkpoint_file::load(&mut project, &path, paper, false).unwrap_err();
    assert!(e.to_string().contains("fingerprint"), "{e}");
    let both = format!(
        "its fingerprint {:#010x}, this run's {:#010x}",
        c.config().fingerprint(),
        project.config().fingerprint()
    );
    assert!(e.to_string().contains(&both), "{e}");
    checkpoint_file::load(&mut project, &path, project_prov, true).unwrap();
    assert!(project.stage1().net() == c.stage1().net());
}

#[test]
fn endless_and_odd_files_are_refused_without_reading_them_all() {
    let mut c = controller(5);
    let e = checkpoint_file::load(&mut c, Path::new("/dev/zero"), Provenance::CUSTOM, false)
        .unwrap_err();
    assert!(e.to_string().contains("not a regular file"), "{e}");
    let d_scratch = dir("odd");
    let d = d_scratch.path();
    let long = d.join("long.ckpt");
    std::fs::write(&long, vec![0u8; checkpoint::MAX_SIZE + 10]).unwrap();
    let e = checkpoint_file::load(&mut c, &long, Provenance::CUSTOM, false).unwrap_err();
    assert!(
        e.to_string().contains("more than any checkpoint")
            && e.to_string()
                .contains(&(checkpoint::MAX_SIZE + 10).to_string()),
        "the file's real size: {e}"
    );
    let e = checkpoint_file::save(&c, Provenance::CUSTOM, d).unwrap_err();
    assert!(e.to_string().contains("directory"), "{e}");
    let check = |p: &Path| trn_bench::output::check_path(p, trn_bench::output::Kind::Json);
    assert!(check(Path::new("/nonexistent/dir/x.json")).is_err());
    assert!(check(&d.join("fine.json")).is_ok());
    assert!(
        !d.join("fine.json").exists(),
        "the check leaves nothing behind"
    );
}
