//! Build-time provenance for reports: the git commit the sources came from and whether the
//! sources built differ from it (`trn_bench::provenance`). Robust to a tree without git (a
//! tarball): then `unknown`, unless `TRN_GIT_COMMIT` / `TRN_GIT_DIRTY` say (a packager's
//! build from an export of a known commit).

use std::path::Path;
use std::process::Command;

/// The sources a build compiles, relative to the workspace root: dirtiness is theirs.
const SOURCES: [&str; 9] = [
    "controller",
    "protocol",
    "node",
    "store",
    "vision",
    "host",
    "python/src",
    "Cargo.toml",
    "Cargo.lock",
];

/// The dependencies a report names with their locked versions.
const DEPENDENCIES: [&str; 10] = [
    "nalgebra",
    "libm",
    "heapless",
    "postcard",
    "serde",
    "rand_xoshiro",
    "socketcan",
    "image",
    "rayon",
    "embedded-can",
];

/// `name version` of each of `names` in a Cargo.lock's text (every version locked, in the
/// file's order), the names it does not lock left out.
fn locked_versions(lock: &str, names: &[&str]) -> Vec<String> {
    let mut out = Vec::new();
    let mut name: Option<&str> = None;
    for line in lock.lines() {
        if line == "[[package]]" {
            name = None;
        } else if let Some(n) = line.strip_prefix("name = ") {
            name = Some(n.trim_matches('"'));
        } else if let (Some(n), Some(v)) = (name, line.strip_prefix("version = ")) {
            if names.contains(&n) {
                out.push(format!("{n} {}", v.trim_matches('"')));
            }
        }
    }
    out
}

fn git(root: &Path, args: &[&str]) -> Option<String> {
    let out = Command::new("git")
        .arg("-C")
        .arg(root)
        .args(args)
        .output()
        .ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn main() {
    let manifest = std::env::var("CARGO_MANIFEST_DIR").unwrap_or_default();
    let root = Path::new(&manifest).join("../..");
    println!("cargo:rerun-if-env-changed=TRN_GIT_COMMIT");
    println!("cargo:rerun-if-env-changed=TRN_GIT_DIRTY");
    for s in SOURCES {
        let p = root.join(s);
        if p.exists() {
            println!("cargo:rerun-if-changed={}", p.display());
        }
    }
    // a new commit, checkout or staging shows in HEAD, the index and the refs
    for (dir, files) in [
        ("--git-dir", &["HEAD", "index"][..]),
        ("--git-common-dir", &["refs", "packed-refs"][..]),
    ] {
        if let Some(d) = git(&root, &["rev-parse", dir]) {
            let d = if Path::new(&d).is_absolute() {
                Path::new(&d).to_path_buf()
            } else {
                root.join(d)
            };
            for f in files {
                if d.join(f).exists() {
                    println!("cargo:rerun-if-changed={}", d.join(f).display());
                }
            }
        }
    }
    let commit = std::env::var("TRN_GIT_COMMIT")
        .ok()
        .or_else(|| git(&root, &["rev-parse", "HEAD"]))
        .unwrap_or_else(|| "unknown".into());
    let dirty = std::env::var("TRN_GIT_DIRTY").ok().or_else(|| {
        let mut args = vec!["status", "--porcelain", "--untracked-files=normal", "--"];
        args.extend(SOURCES);
        git(&root, &args).map(|s| (!s.is_empty()).to_string())
    });
    println!("cargo:rustc-env=TRN_GIT_COMMIT={commit}");
    // the compiler that builds this crate, and the main dependencies as Cargo.lock has them
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = Command::new(rustc)
        .arg("-V")
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map_or_else(
            || "unknown".into(),
            |o| String::from_utf8_lossy(&o.stdout).trim().to_string(),
        );
    println!("cargo:rustc-env=TRN_RUSTC_VERSION={version}");
    let lock = root.join("Cargo.lock");
    println!("cargo:rerun-if-changed={}", lock.display());
    let locked = std::fs::read_to_string(&lock).unwrap_or_default();
    println!(
        "cargo:rustc-env=TRN_DEPENDENCIES={}",
        locked_versions(&locked, &DEPENDENCIES).join(", ")
    );
    println!(
        "cargo:rustc-env=TRN_GIT_DIRTY={}",
        dirty.unwrap_or_else(|| "unknown".into())
    );
}
