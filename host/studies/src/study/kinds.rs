//! The dispatch on a study's kind (its [`Table`]): a study's table and JSON and one line
//! per finished run, made by the kind's own module ([`crate::compare`], [`crate::sweep`],
//! [`crate::lifelong`]), and a whole study run and finished. It sits above the three kinds,
//! which take the generic machinery from the modules beside it, so no kind imports what
//! imports it.

use super::runfile::{self, RunFile};
use super::{execute, Finished, Options, Study, Table, Watch};
use trn_bench::{fsio, LabError, Result};

/// The table and JSON of a study from the run files of every one of its jobs (any order;
/// a run present twice, from two shards, counts once). Fails naming what is missing or
/// what does not belong.
pub fn finish(files: Vec<RunFile>) -> Result<Finished> {
    let files = runfile::complete(files)?;
    let header = files[0].study.clone();
    match header.table {
        Table::Compare => crate::compare::finish(&files),
        Table::Sweep => crate::sweep::finish(&files),
        Table::Lifelong => crate::lifelong::finish(&header, &files),
    }
}

/// One line about a finished run: its row, seed and headline figures.
pub fn line(file: &RunFile) -> String {
    match file.study.table {
        Table::Compare => crate::compare::line(file),
        Table::Sweep => crate::sweep::line(file),
        Table::Lifelong => crate::lifelong::line(file),
    }
}

/// What [`run`] did.
#[derive(Debug)]
pub struct Ran {
    /// Runs found finished (resume).
    pub resumed: usize,
    /// Runs run now.
    pub ran: usize,
    /// Stopped before every run was done (an interrupt): nothing was made of the runs.
    pub interrupted: bool,
    /// The table and JSON, when every run of the study is done (not for a shard).
    pub finished: Option<Finished>,
}

/// Runs a study (or a shard of it) and, when every run of the whole study has its file,
/// makes its table and writes its JSON to `json` (checked before anything runs). Fails when
/// a run failed, naming each (after the others finished and were written).
pub fn run(
    study: &Study,
    opts: &Options,
    watch: &dyn Watch,
    json: Option<&std::path::Path>,
) -> Result<Ran> {
    // one writer per run folder (per shard of it: a job array's shards share one) and per
    // JSON, from here to the end (output.rs, rule 3)
    let mut locks = Vec::new();
    if let Some(p) = json {
        fsio::check_path(p, fsio::Kind::Json)?;
        locks.push(fsio::lock_beside(p, "this study's JSON")?);
    }
    fsio::create_folder(&opts.runs)?;
    let name = opts.runs.file_name().unwrap_or_default().to_string_lossy();
    let folder = match opts.shard {
        Some(s) if s.count > 1 => opts
            .runs
            .with_file_name(format!("{name}.shard-{}-of-{}", s.index, s.count)),
        _ => opts.runs.clone(),
    };
    locks.push(fsio::lock_beside(&folder, "this study's run folder")?);
    let outcome = execute(study, opts, watch)?;
    if !outcome.failed.is_empty() {
        let errors: Vec<String> = outcome
            .failed
            .iter()
            .map(|(i, e)| {
                let j = &study.jobs[*i];
                format!("{} seed {}: {e}", j.row.name, j.spec.seed)
            })
            .collect();
        return Err(LabError::RunsFailed {
            failed: errors.len(),
            runs: outcome.files.len(),
            errors: errors.join("; "),
        });
    }
    let mut ran = Ran {
        resumed: outcome.resumed,
        ran: outcome.ran,
        interrupted: outcome.interrupted,
        finished: None,
    };
    if outcome.interrupted || opts.shard.is_some_and(|s| s.count > 1) {
        return Ok(ran);
    }
    let finished = finish(outcome.into_files())?;
    if let Some(p) = json {
        fsio::write_json(p, &trn_bench::provenance::Stamped::new(&finished.json))?;
    }
    ran.finished = Some(finished);
    Ok(ran)
}
