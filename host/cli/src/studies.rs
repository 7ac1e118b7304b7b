//! What the command line shows while a study runs, and how it is interrupted: on a
//! terminal one bar over every trial of the study with the time left, and a line per
//! finished run above it; off a terminal a line per finished run with the time left, and a
//! line at least every minute while long runs go on. The first SIGINT/SIGTERM/SIGHUP lets the runs
//! in progress finish (each is written) and starts no other; a second ends the process at
//! once (`progress::Interrupts`).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use trn_bench::{LabError, Observer};
use trn_studies::study::{self, Finished, Job, Options, RunFile, Study, Watch};

use crate::progress::Interrupts;
use crate::Result;

/// Off a terminal, a line at least this often while runs go on.
const HEARTBEAT: Duration = Duration::from_secs(60);

/// The command line's watch over a study.
pub struct StudyProgress {
    bar: indicatif::ProgressBar,
    terminal: bool,
    quiet: bool,
    interrupts: Interrupts,
    told_stop: AtomicBool,
    started: Instant,
    /// Trials of the runs to do (each run's planned total).
    trials: AtomicU64,
    /// Trials done so far.
    done_trials: AtomicU64,
    runs: AtomicUsize,
    done_runs: AtomicUsize,
    last_line: Mutex<Instant>,
}

impl StudyProgress {
    /// A watch on stderr: a bar on a terminal, lines off one, nothing when `quiet`.
    pub fn new(quiet: bool, interrupts: Interrupts) -> StudyProgress {
        let terminal = !quiet && std::io::stderr().is_terminal();
        let bar = if terminal {
            let b = indicatif::ProgressBar::new(0);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "[{bar:40}] {percent:>3}% of the trials, {msg}, {eta} left",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        } else {
            indicatif::ProgressBar::hidden()
        };
        StudyProgress {
            bar,
            terminal,
            quiet,
            interrupts,
            told_stop: AtomicBool::new(false),
            started: Instant::now(),
            trials: AtomicU64::new(0),
            done_trials: AtomicU64::new(0),
            runs: AtomicUsize::new(0),
            done_runs: AtomicUsize::new(0),
            last_line: Mutex::new(Instant::now()),
        }
    }

    fn say(&self, text: &str) {
        if self.quiet {
            return;
        }
        if self.terminal {
            self.bar.println(text);
        } else {
            eprintln!("{text}");
        }
        if let Ok(mut t) = self.last_line.lock() {
            *t = Instant::now();
        }
    }

    /// The share of the study's trials done and the time left at this pace.
    fn eta(&self) -> String {
        let total = self.trials.load(Ordering::Relaxed).max(1) as f64;
        let done = (self.done_trials.load(Ordering::Relaxed) as f64).min(total);
        let elapsed = self.started.elapsed().as_secs_f64();
        let left = if done > 0.0 {
            duration(elapsed * (total - done) / done)
        } else {
            "unknown".into()
        };
        format!(
            "{:.0} % of the trials in {}, {left} left",
            100.0 * done / total,
            duration(elapsed)
        )
    }

    /// The bar goes.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

/// Seconds as `1h02m`, `4m10s` or `35s`.
fn duration(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s}s"),
        60..3600 => format!("{}m{:02}s", s / 60, s % 60),
        _ => format!("{}h{:02}m", s / 3600, (s % 3600) / 60),
    }
}

impl Watch for StudyProgress {
    fn begin(&self, todo: &[&Job], resumed: usize, workers: usize) {
        let trials: u64 = todo.iter().map(|j| j.spec.plan.total() as u64).sum();
        self.trials.store(trials, Ordering::Relaxed);
        self.runs.store(todo.len(), Ordering::Relaxed);
        self.bar.set_length(trials);
        self.bar.set_message(format!("0/{} runs", todo.len()));
        let earlier = match resumed {
            0 => String::new(),
            n => format!(" ({n} found finished)"),
        };
        self.say(&format!(
            "{} runs to do{earlier}, {workers} at once",
            todo.len()
        ));
    }

    fn note(&self, text: &str) {
        self.say(text);
    }

    fn observer(&self, _job: &Job) -> Box<dyn Observer + '_> {
        Box::new(RunProgress { study: self })
    }

    fn finished(&self, _job: &Job, file: &RunFile, _path: &Path) {
        let n = self.done_runs.fetch_add(1, Ordering::Relaxed) + 1;
        let runs = self.runs.load(Ordering::Relaxed);
        self.bar.set_message(format!("{n}/{runs} runs"));
        let wall = file.report.wall_s;
        let line = study::line(file);
        if self.terminal {
            self.say(&format!("[{n}/{runs}] {line} ({wall:.1} s)"));
        } else {
            self.say(&format!(
                "[{n}/{runs}] {line} ({wall:.1} s); {}",
                self.eta()
            ));
        }
    }

    fn failed(&self, job: &Job, error: &LabError) {
        self.say(&format!(
            "run {} ({}, seed {}) failed: {error}",
            job.index, job.row.name, job.spec.seed
        ));
    }

    fn stop_requested(&self) -> bool {
        let stop = self.interrupts.requested();
        if stop && !self.told_stop.swap(true, Ordering::Relaxed) {
            self.say("interrupted: the runs in progress finish and are written, no other starts (interrupt again to quit at once)");
        }
        stop
    }
}

/// The observer of one run: its trials count towards the study's.
struct RunProgress<'a> {
    study: &'a StudyProgress,
}

impl Observer for RunProgress<'_> {
    fn trial(&mut self, _record: &trn_bench::records::TrialRecord) {
        let s = self.study;
        s.done_trials.fetch_add(1, Ordering::Relaxed);
        s.bar.inc(1);
        if s.terminal || s.quiet {
            return;
        }
        let due = s
            .last_line
            .lock()
            .map(|t| t.elapsed() >= HEARTBEAT)
            .unwrap_or(false);
        if due {
            let done = s.done_runs.load(Ordering::Relaxed);
            let runs = s.runs.load(Ordering::Relaxed);
            s.say(&format!("[{done}/{runs}] runs finished; {}", s.eta()));
        }
    }
}

/// Runs a study with the command line's progress and interrupts; prints its table when
/// every run of it is done (and writes its JSON to `json`). `None`: a shard, or stopped.
pub fn run(
    study: &Study,
    opts: &Options,
    quiet: bool,
    interrupts: &Interrupts,
    json: Option<&Path>,
) -> Result<Option<Finished>> {
    let progress = StudyProgress::new(quiet, interrupts.clone());
    let ran = study::run(study, opts, &progress, json);
    progress.finish();
    let ran = ran?;
    let folder = opts.runs.display();
    if ran.interrupted {
        eprintln!(
            "trn: stopped: {} runs finished this time are in {folder}; the same command with --resume goes on",
            ran.ran
        );
        return Ok(None);
    }
    match (&ran.finished, opts.shard) {
        (Some(f), _) => print!("{}", f.table),
        (None, Some(s)) => eprintln!(
            "shard {s}: {} runs written to {folder} ({} found finished); `trn merge` makes the table of every shard's run files",
            ran.ran, ran.resumed
        ),
        (None, None) => {}
    }
    Ok(ran.finished)
}

/// `trn merge`: the study's table and JSON from its run files.
pub fn merge(paths: &[PathBuf], json: Option<&Path>) -> Result<Finished> {
    if let Some(p) = json {
        trn_bench::output::check_path(p, trn_bench::output::Kind::Json)?;
    }
    let inputs = trn_studies::study::runfile::expand(paths)?;
    // the report must not be one of the run files it is made from (it would replace a run)
    if let Some(out) = json.and_then(|p| std::fs::canonicalize(p).ok()) {
        if let Some(same) = inputs
            .iter()
            .find(|f| std::fs::canonicalize(f).is_ok_and(|f| f == out))
        {
            return Err(LabError::Usage(format!(
                "--report {} is one of the run files merged ({}): write the report elsewhere",
                out.display(),
                same.display()
            ))
            .into());
        }
    }
    let files = inputs
        .iter()
        .map(|p| RunFile::read(p))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let finished = study::finish(files)?;
    if let Some(p) = json {
        trn_bench::output::write_json(p, &trn_bench::provenance::Stamped::new(&finished.json))?;
    }
    print!("{}", finished.table);
    Ok(finished)
}
