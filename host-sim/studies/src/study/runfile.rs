//! One finished run of a study as a file: the study's header, the run's place and row, and
//! its whole report (with the run's specification in it). Written whole or not at all
//! ([`trn_bench::fsio::write_durably`]) the moment the run ends; read back to resume a study
//! and to merge the shards of one.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{Job, Row, StudyHeader};
use trn_bench::report::Report;
use trn_bench::{io, LabError, Result};

/// The format tag of a run file.
pub const FORMAT: &str = "trn-study-run/1";

/// The largest run file read (a report of a 10,000-trial run is about 2 MB).
const MAX_BYTES: u64 = 256 << 20;

/// One finished run of a study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunFile {
    /// [`FORMAT`].
    pub format: String,
    /// The study it belongs to.
    pub study: StudyHeader,
    /// Its place in the study.
    pub index: usize,
    /// Its row.
    pub row: Row,
    /// The run's report; `report.spec` is the run's specification.
    pub report: Report,
}

impl RunFile {
    /// The file of `job`'s finished run.
    pub fn of(study: &StudyHeader, job: &Job, report: Report) -> RunFile {
        RunFile {
            format: FORMAT.to_string(),
            study: study.clone(),
            index: job.index,
            row: job.row.clone(),
            report,
        }
    }

    /// Whether this is `job`'s finished run: the same run specification, not interrupted,
    /// run by this build ([`super::BUILD`]).
    pub fn is_run_of(&self, job: &Job) -> bool {
        !self.report.interrupted
            && self.report.spec.as_ref() == Some(&job.spec)
            && self.study.build == super::BUILD
    }

    /// Its JSON.
    pub fn to_json(&self) -> Result<Vec<u8>> {
        serde_json::to_vec_pretty(self).map_err(|e| LabError::Usage(format!("run file: {e}")))
    }

    /// Parses a run file; `what` names it in the error.
    pub fn parse(bytes: &[u8], what: &Path) -> Result<RunFile> {
        let bad = |m: String| {
            LabError::Usage(format!(
                "{}: not a finished run of a study: {m}",
                what.display()
            ))
        };
        let value: serde_json::Value =
            serde_json::from_slice(bytes).map_err(|e| bad(e.to_string()))?;
        if value.get("format").and_then(|f| f.as_str()) != Some(FORMAT) {
            return Err(bad(format!("no \"format\": \"{FORMAT}\"")));
        }
        let file: RunFile = super::lenient::from_value(value).map_err(|e| bad(e.to_string()))?;
        if file.report.spec.is_none() {
            return Err(bad("its report has no run specification".into()));
        }
        if file.study.runs as u64 > super::file::MAX_RUNS {
            return Err(bad(format!(
                "a study of {} runs (a study runs {} at most)",
                file.study.runs,
                super::file::MAX_RUNS
            )));
        }
        if file.index >= file.study.runs {
            return Err(bad(format!(
                "run {} of a study of {}",
                file.index, file.study.runs
            )));
        }
        Ok(file)
    }

    /// Reads a run file (at most 256 MiB).
    pub fn read(path: &Path) -> Result<RunFile> {
        use std::io::Read;
        let file = trn_plant::input::open(path).map_err(io(path))?;
        let mut bytes = Vec::new();
        file.take(MAX_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(io(path))?;
        if bytes.len() as u64 > MAX_BYTES {
            return Err(LabError::Usage(format!(
                "{}: larger than any run file",
                path.display()
            )));
        }
        RunFile::parse(&bytes, path)
    }
}

/// The run files among `paths`: each file as it is, each directory's `*.json` files (not
/// its subdirectories), in name order.
pub fn expand(paths: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut out = vec![];
    for p in paths {
        if p.is_dir() {
            let mut inside: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(io(p))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| f.is_file() && f.extension().is_some_and(|e| e == "json"))
                .filter(|f| {
                    !f.file_name()
                        .is_some_and(|n| n.to_string_lossy().starts_with('.'))
                })
                .collect();
            inside.sort();
            out.extend(inside);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// Every run of one study, in its order: the files must all be of one study (one digest),
/// every run present; a run present twice (two shards, or a rerun) counts once if both
/// files hold the same specification.
pub fn complete(files: Vec<RunFile>) -> Result<Vec<RunFile>> {
    let Some(first) = files.first() else {
        return Err(LabError::Usage("no run files".into()));
    };
    let header = first.study.clone();
    let mut slots: Vec<Option<RunFile>> = vec![None; header.runs];
    for f in files {
        if f.study.digest != header.digest || f.study.name != header.name {
            return Err(LabError::Usage(format!(
                "run files of two studies: {} ({}) and {} ({}); merge the files of one study",
                header.name, header.digest, f.study.name, f.study.digest
            )));
        }
        if f.study.runs != header.runs {
            return Err(LabError::Usage(format!(
                "run files of study {} disagree on its number of runs ({} and {}): \
                 merge the files of one study",
                header.name, header.runs, f.study.runs
            )));
        }
        let Some(slot) = slots.get_mut(f.index) else {
            return Err(LabError::Usage(format!(
                "run {} of study {}, which has {} runs",
                f.index, header.name, header.runs
            )));
        };
        match slot {
            Some(had) if had.report.spec != f.report.spec => {
                return Err(LabError::Usage(format!(
                    "run {} ({}, seed {}) is in two files with different specifications",
                    f.index, f.row.name, f.report.seed
                )))
            }
            Some(_) => {}
            None => *slot = Some(f),
        }
    }
    let missing: Vec<String> = slots
        .iter()
        .enumerate()
        .filter(|(_, s)| s.is_none())
        .map(|(i, _)| i.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(LabError::Usage(format!(
            "study {}: {} of its {} runs have no file (runs {}): run the missing shards (or --resume) first",
            header.name,
            missing.len(),
            header.runs,
            clip(&missing)
        )));
    }
    Ok(slots.into_iter().flatten().collect())
}

fn clip(items: &[String]) -> String {
    if items.len() <= 12 {
        items.join(", ")
    } else {
        format!("{}, ... {}", items[..10].join(", "), items[items.len() - 1])
    }
}

/// The runs of a study grouped by row, in the study's order.
pub(crate) fn by_row(files: &[RunFile]) -> Vec<Vec<&RunFile>> {
    let mut rows: Vec<Vec<&RunFile>> = vec![];
    for f in files {
        match rows.iter_mut().find(|r| r[0].row == f.row) {
            Some(r) => r.push(f),
            None => rows.push(vec![f]),
        }
    }
    rows
}
