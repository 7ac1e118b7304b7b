//! One finished run of a study as a file: the study's header, the run's place and row, and
//! its whole report (with the run's specification in it). Written whole or not at all
//! ([`trn_bench::fsio::write_durably`]) the moment the run ends; read back to resume a study
//! and to merge the shards of one.
//!
//! A run file is checksummed: its first line inside the object is `"checksum": "HEX"`, the
//! CRC-64/XZ ([`super::digest`]) of the file without that line, as 16 lowercase hex digits
//! ([`seal`]). A file whose checksum is missing or does not match (a flipped bit, an edit, a
//! file of an older `trn`) is refused as it is read: `--resume` runs it again, `trn merge`
//! stops naming it.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{Job, Row, StudyHeader};
use trn_bench::report::Report;
use trn_bench::{io, LabError, Result};

/// The format tag of a run file.
pub const FORMAT: &str = "trn-study-run/2";

/// The start of a run file: the object's opening line, then its checksum's key.
const CHECKSUM_LINE: &str = "{\n  \"checksum\": \"";

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

    /// Its JSON, sealed with its checksum ([`seal`]).
    pub fn to_json(&self) -> Result<Vec<u8>> {
        let body = serde_json::to_vec_pretty(self)
            .map_err(|e| LabError::Usage(format!("run file: {e}")))?;
        seal(&body)
    }

    /// Parses a run file; `what` names it in the error.
    pub fn parse(bytes: &[u8], what: &Path) -> Result<RunFile> {
        let bad = |m: String| {
            LabError::Usage(format!(
                "{}: not a finished run of a study: {m}",
                what.display()
            ))
        };
        let body = unseal(bytes).map_err(bad)?;
        let value: serde_json::Value =
            serde_json::from_slice(&body).map_err(|e| bad(e.to_string()))?;
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

/// A run file's bytes from the pretty-printed JSON object `body` (which opens with `{` and a
/// newline): `body` with the line `  "checksum": "HEX",` after its opening line, HEX the
/// CRC-64/XZ of `body` itself.
pub fn seal(body: &[u8]) -> Result<Vec<u8>> {
    let Some(rest) = body.strip_prefix(b"{\n") else {
        return Err(LabError::Usage(
            "run file: not a pretty-printed JSON object".into(),
        ));
    };
    let mut out = Vec::with_capacity(body.len() + 40);
    out.extend_from_slice(CHECKSUM_LINE.as_bytes());
    out.extend_from_slice(super::digest(body).as_bytes());
    out.extend_from_slice(b"\",\n");
    out.extend_from_slice(rest);
    Ok(out)
}

/// The JSON a sealed run file holds, its checksum line removed, if the checksum matches.
fn unseal(bytes: &[u8]) -> core::result::Result<Vec<u8>, String> {
    let unsealed =
        "no checksum on its first line (a file of an older trn, or edited): run it again";
    let rest = bytes
        .strip_prefix(CHECKSUM_LINE.as_bytes())
        .ok_or_else(|| unsealed.to_string())?;
    let (stated, rest) = match (rest.get(..16), rest.get(16..)) {
        (Some(hex), Some(rest)) if rest.starts_with(b"\",\n") => (hex, &rest[3..]),
        _ => return Err(unsealed.to_string()),
    };
    let mut body = Vec::with_capacity(bytes.len());
    body.extend_from_slice(b"{\n");
    body.extend_from_slice(rest);
    let computed = super::digest(&body);
    if stated != computed.as_bytes() {
        return Err(format!(
            "its checksum {} is not its contents' ({computed}): the file was changed or damaged; run it again",
            String::from_utf8_lossy(stated)
        ));
    }
    Ok(body)
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

#[cfg(test)]
mod tests {
    use super::*;

    const BODY: &[u8] = b"{\n  \"format\": \"trn-study-run/2\",\n  \"index\": 3\n}";

    #[test]
    fn a_sealed_file_opens_to_what_was_sealed() {
        let sealed = seal(BODY).unwrap();
        assert!(sealed.starts_with(b"{\n  \"checksum\": \""));
        assert_eq!(unseal(&sealed).unwrap(), BODY);
        // the checksum is the body's own, as the format says
        let hex = &sealed[CHECKSUM_LINE.len()..CHECKSUM_LINE.len() + 16];
        assert_eq!(hex, crate::study::digest(BODY).as_bytes());
    }

    #[test]
    fn any_flipped_bit_is_refused() {
        let sealed = seal(BODY).unwrap();
        for byte in 0..sealed.len() {
            for bit in 0..8 {
                let mut bad = sealed.clone();
                bad[byte] ^= 1 << bit;
                assert!(unseal(&bad).is_err(), "bit {bit} of byte {byte}");
            }
        }
    }

    #[test]
    fn files_without_their_checksum_are_refused_by_name() {
        let err = unseal(BODY).unwrap_err();
        assert!(err.contains("no checksum"), "{err}");
        let err = RunFile::parse(BODY, Path::new("r.json"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("r.json") && err.contains("no checksum"),
            "{err}"
        );
        // a truncated checksum line
        let sealed = seal(BODY).unwrap();
        assert!(unseal(&sealed[..CHECKSUM_LINE.len() + 10]).is_err());
        // compact JSON is not a run file's body
        assert!(seal(b"{\"format\":1}").is_err());
    }
}
