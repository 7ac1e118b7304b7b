//! An arm's next episode built ahead of its reset, on a thread of the lowest priority
//! ([`Ahead`]), for the single arm (`Arm`) and each arm of a vector environment
//! (`ArmVec`); the arm's side of it is `Sim::build_ahead` and `Sim::reset_taking`.
//!
//! An episode's reset is the costliest thing an arm does (the plant built, the target's twin
//! moved along its path, the start move: about four moves' time), and a vector step waits
//! for its slowest arm: an arm that resets holds the other arms' threads idle for most of
//! the step. When the next episode's seed is known ahead and the arm does not carry its
//! plant over (`persistent`), that episode is built at once, on a thread of its own at the
//! lowest priority, from a copy of the arm: the cores' idle time (the Python layer between
//! steps, the arms that finish early, the agent's own work) builds it, and the reset takes
//! it ready. An arm built from a copy is the arm the reset would build, bit for bit: a reset
//! that does not carry the plant over keeps nothing of the episode before.

use std::thread::JoinHandle;

/// An episode (a `T`) being built ahead: its seed and the thread building it.
pub(crate) struct Ahead<T> {
    seed: u64,
    job: JoinHandle<Result<T, String>>,
}

impl<T: Send + 'static> Ahead<T> {
    /// Starts `build`ing the episode that `seed` gives, on a thread named `name` at the
    /// lowest priority; `None` when no thread can be had (the reset then builds it).
    pub(crate) fn start(
        seed: u64,
        name: String,
        build: impl FnOnce() -> Result<T, String> + Send + 'static,
    ) -> Option<Ahead<T>> {
        let job = std::thread::Builder::new().name(name).spawn(move || {
            lowest_priority();
            build()
        });
        job.ok().map(|job| Ahead { seed, job })
    }

    /// Has `slot` hold the episode that `seed` gives: kept when it already does, else what
    /// `start` begins (see [`Ahead::start`]) replaces it, and a thread building another
    /// seed's episode ends on its own.
    pub(crate) fn prepare(
        slot: &mut Option<Ahead<T>>,
        seed: u64,
        start: impl FnOnce() -> Option<Ahead<T>>,
    ) {
        if !matches!(slot, Some(a) if a.is_for(seed)) {
            *slot = start();
        }
    }

    /// Whether this is the episode `seed` gives.
    pub(crate) fn is_for(&self, seed: u64) -> bool {
        self.seed == seed
    }

    /// Whether its thread has finished.
    pub(crate) fn is_ready(&self) -> bool {
        self.job.is_finished()
    }

    /// The episode `seed` gives, if `ahead` is it and its thread has finished with it;
    /// else `None` (none, another seed's, not ready, or its thread failed: it panicked, or
    /// the build is an error that the reset will report), and a thread still building ends
    /// on its own.
    pub(crate) fn take(ahead: Option<Ahead<T>>, seed: u64) -> Option<T> {
        let a = ahead.filter(|a| a.is_for(seed) && a.is_ready())?;
        a.job.join().ok()?.ok()
    }
}

/// Lowers the calling thread's priority to the least (nice 19; on Linux a thread's nice
/// value is its own), so that building ahead takes mostly what the arms and the Python layer
/// leave idle. (The idle scheduling class, `SCHED_IDLE`, measured no faster.)
fn lowest_priority() {
    #[cfg(target_os = "linux")]
    // SAFETY: setpriority reads no memory of ours; `who = 0` is the calling thread. A
    // failure leaves the priority as it was, which is harmless.
    unsafe {
        libc::setpriority(libc::PRIO_PROCESS, 0, 19);
    }
}
