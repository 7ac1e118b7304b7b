//! One rule for every file the tools write (report, plot, candump log, CSV, checkpoint and
//! its `.sim`, study results):
//!
//! 1. **Checked before the run starts**: the path names a regular file or nothing yet (not a
//!    directory, a symlink, a device, a FIFO or a socket: give the real file's path), in an
//!    existing directory this process can write to, with its kind's extension; it is not an
//!    input of the run (the configuration file, the checkpoint read and its `.sim`) nor
//!    another output of it. A failing check names the user's path, and nothing runs.
//! 2. **Written whole or not at all**: into a new temporary file beside it
//!    (`.NAME.tmp-PID-N`, keeping the extension), flushed to disk, renamed over the target,
//!    the directory flushed. A full disk or any other error names the user's path and leaves
//!    the previous file (or nothing): never a truncated one. Temporary files of writers that
//!    were killed (their process is gone) are removed when a run checks the same output.
//! 3. **One writer per output**: a run holds a lock beside each of its outputs
//!    (`.NAME.lock`) from the check to the end, and a study beside its run folder, so two
//!    runs cannot leave a checkpoint and a `.sim` from different runs, or a report, CSV or
//!    study table of the one that happened to finish last; the second is refused at once.

use std::fs::File;
use std::path::{Path, PathBuf};

use crate::error::Result;
pub use crate::fsio::{check_path, write_durably, write_json, Kind, PendingFile};
use crate::fsio::{identity, lock_beside, usage};
use crate::report::Report;
use crate::sim_state;
use crate::spec::RunSpec;

/// The outputs of a run, checked, with their locks held.
#[derive(Debug)]
pub struct OutputPlan {
    report: Option<PathBuf>,
    candump: Option<PathBuf>,
    checkpoint: Option<PathBuf>,
    _locks: Vec<File>,
}

impl OutputPlan {
    /// Checks every output of `spec` (rule 1) and takes their locks (rule 3).
    pub fn check(spec: &RunSpec) -> Result<OutputPlan> {
        let o = &spec.outputs;
        let outputs: Vec<(&Path, Kind)> = [
            (o.report.as_deref(), Kind::Json),
            (o.plot.as_deref(), Kind::Plot),
            (o.candump.as_deref(), Kind::Candump),
            (o.csv.as_deref(), Kind::Csv),
            (o.checkpoint.as_deref(), Kind::Checkpoint),
        ]
        .into_iter()
        .filter_map(|(p, k)| p.map(|p| (p, k)))
        .collect();
        let mut inputs: Vec<(PathBuf, &str)> = Vec::new();
        if let Some(name) = &spec.plant_name {
            let p = Path::new(name);
            if p.exists() {
                inputs.push((p.to_path_buf(), "the simulator configuration (--config)"));
            }
        }
        if let Some(c) = &spec.checkpoint_in {
            inputs.push((c.clone(), "the checkpoint read (--checkpoint-in)"));
            inputs.push((
                sim_state::path_beside(c),
                "the simulator state read with it",
            ));
        }
        if let Some(t) = &spec.tables {
            inputs.push((t.clone(), "the controller's tables file (--tables)"));
        }
        let mut written: Vec<(PathBuf, &str)> = Vec::new();
        for &(path, kind) in &outputs {
            check_path(path, kind)?;
            let mut mine = vec![(path.to_path_buf(), kind.option())];
            if kind == Kind::Checkpoint {
                let sim = sim_state::path_beside(path);
                check_path(&sim, Kind::SimState)?;
                mine.push((sim, Kind::SimState.option()));
            }
            for (p, what) in mine {
                let id = identity(&p);
                if let Some((_, input)) = inputs.iter().find(|(i, _)| identity(i) == id) {
                    return Err(usage(
                        &p,
                        &format!("is {input}: an output never replaces an input"),
                    ));
                }
                if let Some((_, other)) = written.iter().find(|(w, _)| identity(w) == id) {
                    return Err(usage(
                        &p,
                        &format!("is also {other}: two outputs, one file"),
                    ));
                }
                written.push((p, what));
            }
        }
        let locks = outputs
            .iter()
            .map(|&(path, kind)| lock_beside(path, kind.what()))
            .collect::<Result<Vec<File>>>()?;
        Ok(OutputPlan {
            report: o.report.clone(),
            candump: o.candump.clone(),
            checkpoint: o.checkpoint.clone(),
            _locks: locks,
        })
    }

    /// Where the checkpoint goes.
    pub fn checkpoint(&self) -> Option<&Path> {
        self.checkpoint.as_deref()
    }

    /// The candump log, written through a temporary file that becomes the log when the run
    /// ends ([`PendingFile::commit`]).
    pub fn candump(&self) -> Result<Option<PendingFile>> {
        self.candump.as_deref().map(PendingFile::create).transpose()
    }

    /// Writes the report, if one was asked for.
    pub fn write_report(&self, report: &Report) -> Result<()> {
        match &self.report {
            Some(p) => write_json(p, report),
            None => Ok(()),
        }
    }
}
