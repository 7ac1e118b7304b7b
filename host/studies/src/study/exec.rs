//! Running a study's jobs on a pool of worker threads ([rayon]'s work stealing), each
//! finished run written at once to the study's run folder.
//!
//! - **The same results with any number of workers.** An in-process run is single-threaded
//!   and keeps its bus and clock in `Rc`s: each run is built and run inside the worker that
//!   takes it, from its specification alone (its seed, plant and controller); workers share
//!   nothing but the run folder, where each run has a file of its own.
//! - **Nothing finished is lost.** A run's file is written whole or not at all
//!   ([`trn_bench::fsio::write_durably`]) as soon as the run ends; a run that fails is
//!   reported and the others go on; a stop request (an interrupt) lets the runs in progress
//!   finish and starts no other, and is heard between the plant files written before the
//!   first run ([`Study::write_plants`]).
//! - **Resume.** With `resume`, a job whose file is there and holds its run specification
//!   (not only its name) and a finished, uninterrupted report is not run again; a file that
//!   cannot be read, or holds another specification, is redone.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::runfile::RunFile;
use super::{Job, Shard, Study};
use trn_bench::fsio::{self, Kind};
use trn_bench::observe::{Observer, Unobserved};
use trn_bench::{LabError, Result};

/// How a study runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Options {
    /// Worker threads (runs at once); at least 1.
    pub jobs: usize,
    /// The run folder: one JSON file per finished run.
    pub runs: PathBuf,
    /// Skip the runs whose file is already there with the same specification.
    pub resume: bool,
    /// Run only this slice of the study.
    pub shard: Option<Shard>,
}

/// Stack of a worker thread: a run keeps its controller's tables on the heap, but builds
/// them on the stack first (about 230 KB in a release build, more unoptimised).
const WORKER_STACK: usize = 16 << 20;

/// Watches a study from every worker at once (hence `Sync`): progress, and whether to stop.
pub trait Watch: Sync {
    /// The study starts: `todo` will run (`workers` at once), `resumed` were found finished.
    fn begin(&self, _todo: &[&Job], _resumed: usize, _workers: usize) {}
    /// A note worth showing (a run file redone, and why).
    fn note(&self, _text: &str) {}
    /// The observer of one run, asked for by the worker that runs it.
    fn observer(&self, _job: &Job) -> Box<dyn Observer + '_> {
        Box::new(Unobserved)
    }
    /// A run finished; its file (as read back) is at `path`.
    fn finished(&self, _job: &Job, _file: &RunFile, _path: &Path) {}
    /// A run failed.
    fn failed(&self, _job: &Job, _error: &LabError) {}
    /// True when no further run should start (the runs in progress finish).
    fn stop_requested(&self) -> bool {
        false
    }
}

/// A watch that watches nothing.
impl Watch for Unobserved {}

/// What a study's execution did.
#[derive(Debug, Default)]
pub struct Outcome {
    /// The run file of each selected job, in the study's order (`None`: not run, because it
    /// failed or the study was stopped first).
    pub files: Vec<(usize, Option<RunFile>)>,
    /// Runs found finished (resume).
    pub resumed: usize,
    /// Runs run and written now.
    pub ran: usize,
    /// Runs that failed: index and error.
    pub failed: Vec<(usize, String)>,
    /// Stopped before every selected run was done.
    pub interrupted: bool,
}

impl Outcome {
    /// Every selected job has its file.
    pub fn complete(&self) -> bool {
        self.files.iter().all(|(_, f)| f.is_some())
    }

    /// The files there are, in the study's order.
    pub fn into_files(self) -> Vec<RunFile> {
        self.files.into_iter().filter_map(|(_, f)| f).collect()
    }
}

enum Step {
    Done(Box<RunFile>),
    Failed(String),
    Skipped,
}

/// Runs the jobs of `study` (of `opts.shard`), `opts.jobs` at once, each finished run
/// written to `opts.runs` at once. Fails before anything runs if the study or its folder
/// is unusable; a run that fails is reported in the outcome, not as an error.
pub fn execute(study: &Study, opts: &Options, watch: &dyn Watch) -> Result<Outcome> {
    study.check()?;
    let mut outcome = Outcome::default();
    if !study.write_plants(&|| watch.stop_requested())? {
        outcome.interrupted = true;
        return Ok(outcome);
    }
    let selected = study.select(opts.shard);
    fsio::create_folder(&opts.runs)?;
    if let Some(j) = selected.first() {
        fsio::check_path(&opts.runs.join(j.file_name()), Kind::Json)?;
    }
    let mut done: Vec<Option<RunFile>> = vec![None; selected.len()];
    let mut todo = vec![];
    for (slot, job) in selected.iter().enumerate() {
        let path = opts.runs.join(job.file_name());
        match opts
            .resume
            .then(|| resumable(study, job, &path, watch))
            .flatten()
        {
            Some(file) => {
                done[slot] = Some(file);
                outcome.resumed += 1;
            }
            None => todo.push((slot, *job)),
        }
    }
    let workers = opts.jobs.max(1);
    let jobs: Vec<&Job> = todo.iter().map(|(_, j)| *j).collect();
    watch.begin(&jobs, outcome.resumed, workers);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(workers)
        .stack_size(WORKER_STACK)
        .thread_name(|i| format!("trn-study-{i}"))
        .build()
        .map_err(|e| LabError::Usage(format!("cannot start {workers} worker threads: {e}")))?;
    // one job per task (`with_max_len(1)`): an idle worker steals the next run, never waits
    // behind a batch of another worker's
    let steps: Vec<Step> = pool.install(|| {
        todo.par_iter()
            .with_max_len(1)
            .map(|(_, job)| run_one(study, job, &opts.runs, watch))
            .collect()
    });
    for ((slot, job), step) in todo.iter().zip(steps) {
        match step {
            Step::Done(file) => {
                done[*slot] = Some(*file);
                outcome.ran += 1;
            }
            Step::Failed(e) => outcome.failed.push((job.index, e)),
            Step::Skipped => outcome.interrupted = true,
        }
    }
    outcome.files = selected.iter().map(|j| j.index).zip(done).collect();
    Ok(outcome)
}

/// The finished run of `job` in its file, if the file holds it (rewritten with this study's
/// header when it came from an earlier version of the study).
fn resumable(study: &Study, job: &Job, path: &Path, watch: &dyn Watch) -> Option<RunFile> {
    if !path.exists() {
        return None;
    }
    let name = path.display();
    let file = match RunFile::read(path) {
        Ok(f) => f,
        Err(e) => {
            watch.note(&format!("{name}: unreadable, run again ({e})"));
            return None;
        }
    };
    if !file.is_run_of(job) {
        let why = if file.report.interrupted {
            "an interrupted run"
        } else if file.study.build != super::BUILD {
            "a run of another build"
        } else {
            "another run specification"
        };
        watch.note(&format!("{name}: {why}, run again"));
        return None;
    }
    let current = RunFile::of(&study.header, job, file.report.clone());
    if current == file {
        return Some(file);
    }
    // the same run in a study that changed around it: its place and header are this study's
    let bytes = current.to_json().ok()?;
    match fsio::write_durably(path, &bytes).and_then(|_| RunFile::parse(&bytes, path)) {
        Ok(f) => Some(f),
        Err(e) => {
            watch.note(&format!("{name}: cannot rewrite ({e}), run again"));
            None
        }
    }
}

/// Runs one job in this worker and writes its file; the file comes back as read back.
fn run_one(study: &Study, job: &Job, runs: &Path, watch: &dyn Watch) -> Step {
    if watch.stop_requested() {
        return Step::Skipped;
    }
    let mut observer = watch.observer(job);
    let report = match trn_bench::run::run(&job.spec, observer.as_mut()) {
        Ok(r) if r.interrupted => return Step::Skipped,
        Ok(r) => r,
        Err(e) => {
            watch.failed(job, &e);
            return Step::Failed(e.to_string());
        }
    };
    let path = runs.join(job.file_name());
    let file = RunFile::of(&study.header, job, report);
    let written = file.to_json().and_then(|bytes| {
        fsio::write_durably(&path, &bytes)?;
        // what a resumed study or a merge will read: the table is made from this
        RunFile::parse(&bytes, &path)
    });
    match written {
        Ok(file) => {
            watch.finished(job, &file, &path);
            Step::Done(Box::new(file))
        }
        Err(e) => {
            watch.failed(job, &e);
            Step::Failed(e.to_string())
        }
    }
}
