//! Studies: many runs of one question (`trn compare`, `trn sweep`, `trn lifelong`, a study
//! file), each run independent of the others.
//!
//! - A [`Study`] is a list of [`Job`]s: a run specification and the row of the table it
//!   belongs to, in a fixed order (configurations, then seeds). It comes from a study file
//!   ([`file`](mod@file): grid axes over plant keys, presets, ablations, laws, seeds, the evaluation's
//!   size) or from a command's options ([`crate::lifelong`]).
//! - [`exec::execute`] runs the jobs on a pool of worker threads (rayon), each run built and
//!   run inside its worker on its own seed, plant and controller: the results are the same
//!   whatever the number of workers. Each finished run is written at once as one JSON file
//!   ([`runfile`]) in the study's run folder; `resume` skips the runs whose file is there
//!   with the same run specification; a shard ([`Shard`]) runs a deterministic slice.
//! - [`finish`] turns the run files (of one machine, or of every shard: `trn merge`) into the
//!   study's table and JSON, always from the files as read back, so a merged, a resumed and
//!   an uninterrupted study give the same bytes.

pub mod exec;
pub mod file;
mod keys;
mod kinds;
mod lenient;
pub mod runfile;
pub mod stats;

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use trn_bench::spec::RunSpec;
use trn_bench::{LabError, Result};

pub use exec::{execute, Options, Outcome, Watch};
pub use kinds::{finish, line, run, Ran};
pub use runfile::RunFile;

/// What built the runs: the tools' version and the controller's tables (named `trn-lab`, the
/// crate the studies were part of when run files began to carry it: run files written since
/// stay comparable). Two builds of the
/// same version with other code give other results too: `--resume` and `trn merge` trust
/// that the run files come from the code that runs now.
pub const BUILD: &str = if cfg!(feature = "compact") {
    concat!(
        "trn-lab ",
        env!("CARGO_PKG_VERSION"),
        ", i16 tables (compact)"
    )
} else {
    concat!("trn-lab ", env!("CARGO_PKG_VERSION"), ", f32 tables")
};

/// The table a study's results make.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Table {
    /// Configurations over seeds, every figure of the honest protocol (`trn compare`).
    #[default]
    Compare,
    /// Plant variants over seeds: the measured errors against the noise floor (`trn sweep`).
    Sweep,
    /// Controllers' snapshot curves over a long run (`trn lifelong`).
    Lifelong,
}

/// The parameters of the life-long table (its caption and its "after the initial training").
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LifelongTable {
    /// Seed of the runs.
    pub seed: u64,
    /// The plant's name.
    pub config: String,
    /// Trials per network.
    pub trials: usize,
    /// Training trials before the frozen network stops learning.
    pub initial: usize,
    /// A snapshot every this many trials.
    pub snapshot_every: usize,
    /// Held-out targets per network in a snapshot.
    pub snapshot_targets: usize,
    /// Held-out grasps in a snapshot.
    pub snapshot_grasps: usize,
}

/// What identifies a study and makes its table: written into every run file, so the files
/// of a study's shards can be merged without the command that made them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyHeader {
    /// The study's name (`compare`, `sweep`, `lifelong` or the study file's).
    pub name: String,
    /// Its table.
    pub table: Table,
    /// Runs in the whole study (every shard).
    pub runs: usize,
    /// The build that ran it ([`BUILD`]): the i16 tables of the compact build give other
    /// results than the f32 build's, so neither resumes nor merges with the other's runs.
    pub build: String,
    /// A digest of every job (row, seed, profile, plant, plan, bus): two files belong to the
    /// same study if and only if their digests agree.
    pub digest: String,
    /// The life-long table's parameters.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lifelong: Option<LifelongTable>,
}

/// The row of the table a run belongs to.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Row {
    /// Its name in the table.
    pub name: String,
    /// Its key (`--configs`, file names).
    pub key: String,
}

/// One run of a study.
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    /// Its place in the study (0-based; the order of the table).
    pub index: usize,
    /// Its row.
    pub row: Row,
    /// What it runs.
    pub spec: RunSpec,
}

impl Job {
    /// The name of its run file: the row's key, the seed and a digest of the specification
    /// (so another specification of the same row and seed never takes its file).
    pub fn file_name(&self) -> String {
        format!(
            "{}-seed{}-{}.json",
            slug(&self.row.key),
            self.spec.seed,
            &digest(canonical(&self.spec))[..8]
        )
    }
}

/// A study: its header and its jobs.
#[derive(Debug, Clone, PartialEq)]
pub struct Study {
    /// What identifies it and makes its table.
    pub header: StudyHeader,
    /// Its runs, in the table's order.
    pub jobs: Vec<Job>,
    /// The plant files its runs name, written before the first run ([`Study::write_plants`]).
    pub plants: Vec<PlantFile>,
}

/// A plant made of keys, and the file a study writes it to so that its row can be run again
/// alone with `--config` ([`file::StudyFile::study`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PlantFile {
    /// Where it is written (the runs name this path).
    pub path: std::path::PathBuf,
    /// The plant (written as TOML).
    pub plant: trn_plant::SimConfig,
}

impl Study {
    /// A study of `runs` (row and specification), in that order.
    pub fn new(
        name: &str,
        table: Table,
        lifelong: Option<LifelongTable>,
        runs: Vec<(Row, RunSpec)>,
    ) -> Study {
        let jobs: Vec<Job> = runs
            .into_iter()
            .enumerate()
            .map(|(index, (row, spec))| Job { index, row, spec })
            .collect();
        let mut text = format!("{name}\n{table:?}\n{lifelong:?}\n{BUILD}\n");
        for j in &jobs {
            text.push_str(&format!(
                "{}\t{}\t{}\n",
                j.row.name,
                j.row.key,
                canonical(&j.spec)
            ));
        }
        Study {
            header: StudyHeader {
                name: name.to_string(),
                table,
                runs: jobs.len(),
                build: BUILD.to_string(),
                digest: digest(&text),
                lifelong,
            },
            jobs,
            plants: Vec::new(),
        }
    }

    /// Writes the plant files the runs name ([`Study::plants`]), each durably, and asks
    /// `stop` before each: `Ok(false)` when it said stop (the files written so far stay; the
    /// next call writes every one again). A study of many configurations writes as many files
    /// before its first run, so an interrupt must be heard here too.
    pub fn write_plants(&self, stop: &dyn Fn() -> bool) -> Result<bool> {
        for p in &self.plants {
            if stop() {
                return Ok(false);
            }
            if let Some(dir) = p.path.parent().filter(|d| !d.as_os_str().is_empty()) {
                trn_bench::fsio::create_folder(dir)?;
            }
            let text = toml::to_string(&p.plant).map_err(|e| LabError::Usage(e.to_string()))?;
            trn_bench::fsio::write_durably(&p.path, text.as_bytes())?;
        }
        Ok(true)
    }

    /// Refuses a study that cannot run, before anything runs: no runs, two runs of the same
    /// specification, a run's own check, a run that would write files of its own.
    pub fn check(&self) -> Result<()> {
        if self.jobs.is_empty() {
            return Err(LabError::Usage(format!(
                "study {}: no runs (no configuration or no seed selected)",
                self.header.name
            )));
        }
        let mut names = std::collections::BTreeMap::new();
        for j in &self.jobs {
            j.spec.check()?;
            if j.spec.outputs != trn_bench::spec::Outputs::default() {
                return Err(LabError::Usage(format!(
                    "study {}: run {} writes files of its own; a study writes one file per run",
                    self.header.name, j.index
                )));
            }
            if let Some(other) = names.insert(j.file_name(), j.index) {
                return Err(LabError::Usage(format!(
                    "study {}: runs {other} and {} ({}, seed {}) are the same run",
                    self.header.name, j.index, j.row.name, j.spec.seed
                )));
            }
        }
        Ok(())
    }

    /// The jobs of a shard (all of them without one).
    pub fn select(&self, shard: Option<Shard>) -> Vec<&Job> {
        self.jobs
            .iter()
            .filter(|j| shard.is_none_or(|s| s.owns(j.index)))
            .collect()
    }
}

/// A deterministic slice of a study: shard `index` of `count` runs the jobs whose index is
/// `index` modulo `count` (round robin, so each shard gets a share of every row).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This shard (0-based).
    pub index: usize,
    /// Shards in all.
    pub count: usize,
}

impl Shard {
    /// Whether job `job` is this shard's.
    pub fn owns(&self, job: usize) -> bool {
        job % self.count == self.index
    }
}

impl FromStr for Shard {
    type Err = String;

    /// `I/N` with `0 <= I < N`.
    fn from_str(s: &str) -> std::result::Result<Shard, String> {
        let bad = || format!("{s:?} is not a shard I/N with 0 <= I < N (e.g. 0/4)");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (
            i.trim().parse::<usize>().map_err(|_| bad())?,
            n.trim().parse::<usize>().map_err(|_| bad())?,
        );
        if count == 0 || index >= count {
            return Err(bad());
        }
        Ok(Shard { index, count })
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// A specification as text for digests: the JSON of what decides the run's results (the
/// plant's name and the outputs left out: the same plant from another path is the same run).
fn canonical(spec: &RunSpec) -> String {
    let mut s = spec.clone();
    s.plant_name = None;
    s.outputs = Default::default();
    serde_json::to_string(&s).unwrap_or_default()
}

/// CRC-64 (XZ) of `text` (a specification's JSON, a run file's bytes) as 16 hex digits:
/// stable across machines and builds (unlike `std`'s hasher), which a study split over a
/// cluster needs.
pub fn digest(text: impl AsRef<[u8]>) -> String {
    let crc = crc::Crc::<u64>::new(&crc::CRC_64_XZ);
    format!("{:016x}", crc.checksum(text.as_ref()))
}

/// A name as a file name: ASCII letters and digits, runs of anything else as one `-`.
pub fn slug(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect::<String>()
        .split('-')
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join("-")
}

/// The table and JSON of a whole study, from its run files.
#[derive(Debug, Clone)]
pub struct Finished {
    /// The markdown table (what the command prints).
    pub table: String,
    /// The study's JSON (what `--report` or the study's JSON file gets).
    pub json: serde_json::Value,
    /// Every run of the study, in its order.
    pub files: Vec<RunFile>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use trn_bench::spec::Command;

    fn study(seeds: u64) -> Study {
        let runs = (0..seeds)
            .flat_map(|s| {
                ["a", "b"].map(|k| {
                    let row = Row {
                        name: k.to_uppercase(),
                        key: k.into(),
                    };
                    (row, RunSpec::new(Command::Train, 100 + s))
                })
            })
            .collect();
        Study::new("t", Table::Compare, None, runs)
    }

    #[test]
    fn shards_partition_the_jobs() {
        let s = study(5);
        for n in 1..=4 {
            let mut seen = vec![0; s.jobs.len()];
            for i in 0..n {
                for j in s.select(Some(Shard { index: i, count: n })) {
                    seen[j.index] += 1;
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{n} shards: {seen:?}");
        }
        assert_eq!(s.select(None).len(), 10);
    }

    #[test]
    fn shard_syntax() {
        assert_eq!("1/4".parse(), Ok(Shard { index: 1, count: 4 }));
        for bad in ["4/4", "0/0", "1", "a/2", "-1/2", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
    }

    /// The digest changes with anything that changes a result, not with the plant's path.
    #[test]
    fn the_digest_follows_the_runs() {
        let a = study(2);
        assert_eq!(a.header.digest, study(2).header.digest);
        assert_ne!(a.header.digest, study(3).header.digest);
        let mut runs: Vec<(Row, RunSpec)> = a
            .jobs
            .iter()
            .map(|j| (j.row.clone(), j.spec.clone()))
            .collect();
        runs[0].1.plant_name = Some("elsewhere/x.toml".into());
        assert_eq!(
            Study::new("t", Table::Compare, None, runs.clone())
                .header
                .digest,
            a.header.digest
        );
        runs[0].1.plan.grasps = 7;
        assert_ne!(
            Study::new("t", Table::Compare, None, runs).header.digest,
            a.header.digest
        );
        assert!(a.check().is_ok());
    }

    #[test]
    fn the_same_run_twice_is_refused() {
        let spec = RunSpec::new(Command::Train, 1);
        let row = Row {
            name: "x".into(),
            key: "x".into(),
        };
        let s = Study::new(
            "t",
            Table::Compare,
            None,
            vec![(row.clone(), spec.clone()), (row, spec)],
        );
        assert!(s.check().unwrap_err().to_string().contains("same run"));
    }
}
