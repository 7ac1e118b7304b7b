//! What produced a report ([`Provenance`]): the version, the git commit of the sources and
//! whether they differed from it (both read at build time by `build.rs`, so a binary carries
//! them wherever it runs; `unknown` when built from a tree without git), and the command
//! line. The run's whole specification, plant configuration included, is the report's
//! `spec` beside it.

use serde::{Deserialize, Serialize};

/// Where a report came from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Provenance {
    /// The crate version of the tools (`trn-bench`).
    pub version: String,
    /// The git commit the build's sources came from (`unknown` without git).
    pub git_commit: String,
    /// Whether the build's sources differed from that commit (changed or new files);
    /// `None` when unknown.
    pub git_dirty: Option<bool>,
    /// The command line of the process that wrote the report (its arguments, the program
    /// first: `trn train --seed 3 ...`, or the Python interpreter's).
    pub command_line: Vec<String>,
}

impl Provenance {
    /// This build's and this process's provenance.
    pub fn current() -> Provenance {
        Provenance {
            version: env!("CARGO_PKG_VERSION").to_string(),
            git_commit: env!("TRN_GIT_COMMIT").to_string(),
            git_dirty: match env!("TRN_GIT_DIRTY") {
                "true" => Some(true),
                "false" => Some(false),
                _ => None,
            },
            command_line: std::env::args_os()
                .map(|a| a.to_string_lossy().into_owned())
                .collect(),
        }
    }
}

/// A result file's content with its provenance beside it: `{"provenance": .., "results": ..}`.
#[derive(Debug, Clone, Serialize)]
pub struct Stamped<T> {
    /// Where it came from.
    pub provenance: Provenance,
    /// What it is.
    pub results: T,
}

impl<T> Stamped<T> {
    /// `results` with this process's provenance.
    pub fn new(results: T) -> Stamped<T> {
        Stamped {
            provenance: Provenance::current(),
            results,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_build_knows_its_commit_and_the_process_its_command_line() {
        let p = Provenance::current();
        assert_eq!(p.version, env!("CARGO_PKG_VERSION"));
        // this crate is built from the project's git checkout in development and CI
        if std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../.git")).exists() {
            assert_eq!(p.git_commit.len(), 40, "{}", p.git_commit);
            assert!(p.git_commit.chars().all(|c| c.is_ascii_hexdigit()));
            assert!(p.git_dirty.is_some());
        }
        assert!(!p.command_line.is_empty());
        let json = serde_json::to_string(&Stamped::new(vec![1, 2])).unwrap();
        assert!(json.contains("\"git_commit\"") && json.contains("\"results\":[1,2]"));
    }
}
