//! Checkpoint files under a kill -9 at a random moment of the write, and bad files.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use trn_bench::checkpoint_file;
use trn_controller::checkpoint::{self, Provenance};
use trn_controller::{Config, Controller};

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("trn-ckpt-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn controller(seed: u64) -> Box<Controller> {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(seed);
    c
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
    let d = dir("kill");
    let path = d.join("run.ckpt");
    let bystander = d.join("run.tmp");
    std::fs::write(&bystander, b"an unrelated file").unwrap();
    checkpoint_file::save(&controller(1), Provenance::CUSTOM, &path).unwrap();
    let me = std::env::current_exe().unwrap();
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    for round in 0..12 {
        let mut child = Command::new(&me)
            .args([
                "--exact",
                "checkpoint_writer_child",
                "--nocapture",
                "--test-threads",
                "1",
            ])
            .env("TRN_CKPT_WRITER", &path)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        std::thread::sleep(Duration::from_millis(30 + seed % 200));
        child.kill().unwrap(); // SIGKILL
        child.wait().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let h = checkpoint::verify(&bytes);
        assert!(h.is_ok(), "round {round}: {:?} ({} bytes)", h, bytes.len());
        let mut c = Box::new(Controller::new(Config::project_default()));
        checkpoint_file::load(&mut c, &path, Provenance::CUSTOM, false).unwrap();
        assert_eq!(std::fs::read(&bystander).unwrap(), b"an unrelated file");
    }
    // stray temporary files of killed writes are hidden names of the checkpoint's own
    for entry in std::fs::read_dir(&d).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        assert!(
            name == "run.ckpt" || name == "run.tmp" || name.starts_with(".run.ckpt.tmp-"),
            "{name}"
        );
    }
}

#[test]
fn a_checkpoint_of_another_configuration_is_refused_unless_allowed() {
    let d = dir("config");
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
    let d = dir("odd");
    let long = d.join("long.ckpt");
    std::fs::write(&long, vec![0u8; checkpoint::MAX_SIZE + 10]).unwrap();
    let e = checkpoint_file::load(&mut c, &long, Provenance::CUSTOM, false).unwrap_err();
    assert!(
        e.to_string().contains("more than any checkpoint")
            && e.to_string()
                .contains(&(checkpoint::MAX_SIZE + 10).to_string()),
        "the file's real size: {e}"
    );
    let e = checkpoint_file::save(&c, Provenance::CUSTOM, &d).unwrap_err();
    assert!(e.to_string().contains("directory"), "{e}");
    let check = |p: &Path| trn_bench::output::check_path(p, trn_bench::output::Kind::Json);
    assert!(check(Path::new("/nonexistent/dir/x.json")).is_err());
    assert!(check(&d.join("fine.json")).is_ok());
    assert!(
        !d.join("fine.json").exists(),
        "the check leaves nothing behind"
    );
}
