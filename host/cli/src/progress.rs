//! What the command line shows while a run goes on, and how it is interrupted: a progress
//! bar with the time left on a terminal (nothing off one), and SIGINT/SIGTERM/SIGHUP (a
//! closed terminal). The first signal asks the run to stop at the next trial boundary (it
//! then writes what it did, marked interrupted); a second one ends the process at once (exit
//! 130, 143 or 129).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use std::io::IsTerminal;
use trn_bench::Observer;

/// The signals that ask a run to stop, as flags.
#[derive(Debug, Clone, Default)]
pub struct Interrupts {
    int: Arc<AtomicBool>,
    term: Arc<AtomicBool>,
    hup: Arc<AtomicBool>,
}

impl Interrupts {
    /// Installs the handlers: the first SIGINT/SIGTERM/SIGHUP sets its flag, a second one
    /// exits at once with 128 + the signal number.
    pub fn install() -> std::io::Result<Interrupts> {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        use signal_hook::flag;
        let i = Interrupts::default();
        let any = Arc::new(AtomicBool::new(false));
        for (sig, mine) in [(SIGINT, &i.int), (SIGTERM, &i.term), (SIGHUP, &i.hup)] {
            // registered first: they run before the flag below is set by this same signal
            say_when_second(sig, any.clone())?;
            flag::register_conditional_shutdown(sig, 128 + sig, any.clone())?;
            flag::register(sig, any.clone())?;
            flag::register(sig, mine.clone())?;
        }
        Ok(i)
    }

    /// True once a signal came.
    pub fn requested(&self) -> bool {
        [&self.int, &self.term, &self.hup]
            .iter()
            .any(|f| f.load(Ordering::Relaxed))
    }

    /// The exit code of an interrupted run: 130 after SIGINT, 143 after SIGTERM, 129 after
    /// SIGHUP.
    pub fn exit_code(&self) -> Option<u8> {
        [(&self.int, 130), (&self.term, 143), (&self.hup, 129)]
            .into_iter()
            .find(|(f, _)| f.load(Ordering::Relaxed))
            .map(|(_, code)| code)
    }
}

/// On a second signal (`any` already set), says on stderr that the process quits at once,
/// before the shutdown registered after it ends it: it used to end without a word.
#[cfg(unix)]
fn say_when_second(sig: i32, any: Arc<AtomicBool>) -> std::io::Result<()> {
    const SAID: &[u8] = b"\ntrn: interrupted again: quitting at once, nothing more is written\n";
    let action = move || {
        if any.load(Ordering::SeqCst) {
            #[allow(unsafe_code)]
            // SAFETY: write(2) is async-signal-safe; the buffer is a static byte string of
            // the length passed. Its result is ignored: nothing can be done about a failed
            // write in a signal handler, and the process exits right after.
            unsafe {
                libc::write(2, SAID.as_ptr().cast(), SAID.len());
            }
        }
    };
    #[allow(unsafe_code)]
    // SAFETY: the action only loads an atomic and calls write(2), both async-signal-safe; it
    // allocates, locks and panics nothing.
    unsafe { signal_hook::low_level::register(sig, action) }.map(drop)
}

#[cfg(not(unix))]
fn say_when_second(_: i32, _: Arc<AtomicBool>) -> std::io::Result<()> {
    Ok(())
}

/// The command line's observer of one run.
pub struct Progress {
    bar: indicatif::ProgressBar,
    interrupts: Interrupts,
}

impl Progress {
    /// A bar on stderr when it is a terminal and not `quiet`.
    pub fn new(quiet: bool, interrupts: Interrupts) -> Progress {
        let bar = if quiet || !std::io::stderr().is_terminal() {
            indicatif::ProgressBar::hidden()
        } else {
            let b = indicatif::ProgressBar::new(0);
            b.set_style(
                indicatif::ProgressStyle::with_template(
                    "{prefix:>9} [{bar:40}] {pos}/{len} trials, {eta} left {msg}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            b
        };
        Progress { bar, interrupts }
    }
}

impl Observer for Progress {
    fn start(&mut self, trials: u64) {
        self.bar.set_length(trials);
    }

    fn phase(&mut self, name: &str) {
        self.bar.set_prefix(name.to_string());
    }

    fn trial(&mut self, _record: &trn_bench::records::TrialRecord) {
        self.bar.inc(1);
    }

    fn message(&mut self, text: &str) {
        self.bar.set_message(text.to_string());
    }

    fn notice(&mut self, text: &str) {
        self.bar.suspend(|| eprintln!("trn: {text}"));
    }

    fn finish(&mut self) {
        self.bar.finish_and_clear();
    }

    fn stop_requested(&self) -> bool {
        self.interrupts.requested()
    }
}
