//! [`Crew`]: threads that run a call's jobs with the calling thread among them, kept awake
//! between calls. Made for the native vector environment of `trn_softarm` (`ArmVec`: a
//! call is a vector step, a job an arm's move or reset); nothing in it knows an arm.
//!
//! A vector step at a coarse physics step is short (two arms' moves of 20 to 90 µs at
//! `dt_s=0.05`), and the agent's Python between two steps (an action drawn, the
//! observation made) is about as long. rayon's threads go to sleep in such a gap, and on
//! this class of machine (a virtual machine's cores) waking a sleeping thread takes tens of
//! µs: a step on rayon's pool waited for its worker to wake and then for the caller to be
//! woken, and cost more than the two moves one after the other on one thread (measured by
//! `python/examples/bench_steps.py`, docs/python/speed.md).
//!
//! A crew does not hand its work over and wait: the calling thread takes jobs itself, from a
//! shared counter, as the crew's threads do, so a call never waits for a thread to wake (a
//! sleeping thread finds the jobs taken). A crew's thread spins for [`AWAKE`] after its last
//! job before it sleeps, so that the next call finds it awake; the caller waits for the jobs
//! others took by spinning too (one job at most), yielding its core once it has spun for
//! [`SPIN_BEFORE_YIELD`] (a loaded machine).
//!
//! A job that panics is reported as its error; the crew's thread goes on.
//!
//! A process forked from one that holds a crew has none of its threads (and may have a copy
//! of a lock one of them held): in the child, the caller runs every job itself, touching
//! nothing the threads share, and dropping the crew joins nothing.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long a crew's thread stays awake after its last job: longer than the Python layer
/// between two steps of a vector environment (about 0.1 ms), shorter than a policy's
/// forward pass that would otherwise have the thread spin through it.
pub const AWAKE: Duration = Duration::from_millis(1);

/// How long the caller spins for the jobs the crew took before it yields its core.
pub const SPIN_BEFORE_YIELD: Duration = Duration::from_micros(200);

/// Job `i` of a call: `Ok` or the reason it failed.
pub type Task = dyn Fn(usize) -> Result<(), String> + Send + Sync;

/// A call's work: `n` jobs, each run once by whichever thread claims it.
struct Job {
    generation: u32,
    n: usize,
    task: Arc<Task>,
    done: AtomicUsize,
    /// Each job's error, if it had one.
    errors: Mutex<Vec<Option<String>>>,
}

struct Shared {
    /// The current call's generation (high 32 bits) and its next unclaimed job (low 32
    /// bits): one word, so that a claim of a finished call's job cannot succeed.
    claim: AtomicU64,
    job: Mutex<Option<Arc<Job>>>,
    /// Threads asleep (see [`Crew::run`] for the wake-up's order).
    sleepers: AtomicUsize,
    asleep: Mutex<()>,
    wake: Condvar,
    stop: AtomicBool,
}

/// A caller and `threads` threads that run a call's `n` jobs (see the module).
pub struct Crew {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    generation: u32,
    /// The process the threads run in (see the module on forks).
    pid: u32,
}

impl Shared {
    /// Claims the call's jobs one by one and runs each, until none is left.
    fn work_on(&self, job: &Job) {
        let generation = u64::from(job.generation) << 32;
        loop {
            let s = self.claim.load(Ordering::Acquire);
            let i = (s & 0xFFFF_FFFF) as usize;
            if s & !0xFFFF_FFFF != generation || i >= job.n {
                return;
            }
            if self
                .claim
                .compare_exchange_weak(s, s + 1, Ordering::AcqRel, Ordering::Acquire)
                .is_err()
            {
                continue;
            }
            let outcome = catch_unwind(AssertUnwindSafe(|| (job.task)(i)))
                .unwrap_or_else(|_| Err(format!("job {i} panicked")));
            if let Err(e) = outcome {
                job.errors.lock().unwrap_or_else(|p| p.into_inner())[i] = Some(e);
            }
            job.done.fetch_add(1, Ordering::AcqRel);
        }
    }

    /// A crew thread's life: work on each new job, stay awake for [`AWAKE`] after the last,
    /// then sleep until woken.
    fn serve(&self) {
        let mut seen = 0u64;
        let mut last = Instant::now();
        let mut spins = 0u32;
        while !self.stop.load(Ordering::Acquire) {
            let generation = self.claim.load(Ordering::Acquire) >> 32;
            if generation != seen {
                seen = generation;
                let job = self.job.lock().unwrap_or_else(|p| p.into_inner()).clone();
                if let Some(job) = job.filter(|j| u64::from(j.generation) == generation) {
                    self.work_on(&job);
                }
                last = Instant::now();
                continue;
            }
            spins = spins.wrapping_add(1);
            // the clock read every 64 spins: a spin is a few ns
            if !spins.is_multiple_of(64) || last.elapsed() < AWAKE {
                std::hint::spin_loop();
                continue;
            }
            let guard = self.asleep.lock().unwrap_or_else(|p| p.into_inner());
            self.sleepers.fetch_add(1, Ordering::SeqCst);
            // checked after counting itself asleep (see `Crew::run`)
            let mut guard = guard;
            while self.claim.load(Ordering::SeqCst) >> 32 == seen
                && !self.stop.load(Ordering::SeqCst)
            {
                guard = self.wake.wait(guard).unwrap_or_else(|p| p.into_inner());
            }
            self.sleepers.fetch_sub(1, Ordering::SeqCst);
            drop(guard);
            last = Instant::now();
        }
    }

    fn wake_all(&self) {
        if self.sleepers.load(Ordering::SeqCst) > 0 {
            let _guard = self.asleep.lock().unwrap_or_else(|p| p.into_inner());
            self.wake.notify_all();
        }
    }
}

impl Crew {
    /// A crew of `threads` threads beside the caller (none: the caller runs every job).
    /// A thread that cannot be had leaves the crew smaller.
    pub fn new(threads: usize) -> Crew {
        let shared = Arc::new(Shared {
            claim: AtomicU64::new(0),
            job: Mutex::new(None),
            sleepers: AtomicUsize::new(0),
            asleep: Mutex::new(()),
            wake: Condvar::new(),
            stop: AtomicBool::new(false),
        });
        let threads = (0..threads)
            .filter_map(|k| {
                let s = shared.clone();
                std::thread::Builder::new()
                    .name(format!("trn-crew-{k}"))
                    .spawn(move || s.serve())
                    .ok()
            })
            .collect();
        Crew {
            shared,
            threads,
            generation: 0,
            pid: std::process::id(),
        }
    }

    /// A crew with a thread for each core but the caller's, at most `n - 1` (calls of `n`
    /// jobs).
    pub fn for_jobs(n: usize) -> Crew {
        let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
        Crew::new(cores.min(n).saturating_sub(1))
    }

    /// Threads beside the caller.
    pub fn threads(&self) -> usize {
        if self.forked() {
            0
        } else {
            self.threads.len()
        }
    }

    /// Whether this is a copy in a forked process, which has none of the threads.
    fn forked(&self) -> bool {
        std::process::id() != self.pid
    }

    /// `run` in a forked process: every job on the caller, in order.
    fn run_alone(n: usize, task: &Task) -> Result<(), String> {
        let mut first = Ok(());
        for i in 0..n {
            let outcome = catch_unwind(AssertUnwindSafe(|| task(i)))
                .unwrap_or_else(|_| Err(format!("job {i} panicked")));
            if first.is_ok() {
                first = outcome;
            }
        }
        first
    }

    /// Runs `task(i)` for every job `i < n`, the caller and the crew taking jobs in turn;
    /// returns when all have run, with the error of the lowest job that failed.
    pub fn run(&mut self, n: usize, task: Arc<Task>) -> Result<(), String> {
        if self.forked() {
            return Crew::run_alone(n, &*task);
        }
        self.generation = self.generation.wrapping_add(1).max(1);
        let job = Arc::new(Job {
            generation: self.generation,
            n,
            task,
            done: AtomicUsize::new(0),
            errors: Mutex::new(vec![None; n]),
        });
        let sh = &self.shared;
        *sh.job.lock().unwrap_or_else(|p| p.into_inner()) = Some(job.clone());
        // published before the sleepers are counted: a thread counts itself asleep before it
        // checks the generation, so either it sees this job or this call sees it asleep
        sh.claim
            .store(u64::from(self.generation) << 32, Ordering::SeqCst);
        sh.wake_all();
        sh.work_on(&job);
        let start = Instant::now();
        while job.done.load(Ordering::Acquire) < n {
            if start.elapsed() < SPIN_BEFORE_YIELD {
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
        let errors = std::mem::take(&mut *job.errors.lock().unwrap_or_else(|p| p.into_inner()));
        errors.into_iter().flatten().next().map_or(Ok(()), Err)
    }
}

impl Drop for Crew {
    fn drop(&mut self) {
        if self.forked() {
            // the threads are the parent's: nothing to stop, join or detach
            self.threads.drain(..).for_each(std::mem::forget);
            return;
        }
        self.shared.stop.store(true, Ordering::SeqCst);
        {
            let _guard = self.shared.asleep.lock().unwrap_or_else(|p| p.into_inner());
            self.shared.wake.notify_all();
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every job runs exactly once a call, whichever thread takes it, over many calls with
    /// and without gaps long enough for the crew to sleep; fails if a claim could run a job
    /// twice or skip one, or a call returned before the crew's jobs were done.
    #[test]
    fn every_job_runs_once_a_call() {
        for threads in [0, 1, 3] {
            let mut crew = Crew::new(threads);
            let counts: Arc<Vec<AtomicUsize>> =
                Arc::new((0..7).map(|_| AtomicUsize::new(0)).collect());
            for call in 0..300 {
                let c = counts.clone();
                crew.run(
                    7,
                    Arc::new(move |i| {
                        c[i].fetch_add(1, Ordering::SeqCst);
                        Ok(())
                    }),
                )
                .unwrap();
                for (i, k) in counts.iter().enumerate() {
                    assert_eq!(
                        k.load(Ordering::SeqCst),
                        call + 1,
                        "job {i}, call {call}, {threads} threads"
                    );
                }
                if call % 50 == 0 {
                    std::thread::sleep(AWAKE * 3);
                }
            }
        }
    }

    /// The lowest failing job's error is the call's, a panic among them; the crew runs the
    /// next call as before. Fails if errors were dropped or a panic killed a thread that the
    /// next call then waited for.
    #[test]
    fn errors_and_panics_are_the_calls_error() {
        let mut crew = Crew::new(1);
        for _ in 0..20 {
            let r = crew.run(
                4,
                Arc::new(|i| match i {
                    1 => panic!("job one"),
                    3 => Err("job three".into()),
                    _ => Ok(()),
                }),
            );
            assert_eq!(r, Err("job 1 panicked".into()));
            let r = crew.run(
                4,
                Arc::new(|i| {
                    if i == 3 {
                        Err("job three".into())
                    } else {
                        Ok(())
                    }
                }),
            );
            assert_eq!(r, Err("job three".into()));
        }
        assert_eq!(crew.run(2, Arc::new(|_| Ok(()))), Ok(()));
    }
}
