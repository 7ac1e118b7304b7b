//! What a lossy serial SLCAN bus costs a run: `trn train --bus slcan:PTY
//! --external-controller` against the project's controller node on the other end of a
//! pseudo-terminal pair (its loop in a thread here, as `controller-node --slcan DEVICE` runs
//! it), once on a clean line and once with the host's fault layer dropping a share of the
//! frames in both directions (`--faults drop=P`): both wall times, their ratio, the repeats,
//! and whether the scores are identical.
//!
//! A pseudo-terminal carries a frame in microseconds, faster than any CAN bus, so the node's
//! side of it is paced as the bus would carry it: each frame, either way, holds the line for
//! its bits at `BITRATE` (an 11-bit frame of n bytes: 47 + 8n bits, and 10 % of stuff bits),
//! one frame at a time. `BITRATE` 0 takes the pseudo-terminal as it is.
//!
//! ```sh
//! cargo run --release -p trn-bench --example lossy_slcan -- [--trials N] [--drop P] [--seeds A,B,...] [--check]
//! ```
//! (defaults 60 trials, 0.05, seeds 100, 101, 102): each seed paced at 500 kbit/s and
//! unpaced; a Markdown table on stdout. `--check` fails when a paced ratio is above 3, a
//! lossy run's scores differ from its clean run's (it says which: the failed or aborted
//! trials' counts, or the first trial where a curve differs), or nothing was dropped. A
//! benchmark, not a test: the ratio depends on the machine's load (`scripts/lossy_slcan.sh`).

use std::time::{Duration, Instant};

use embedded_can::Frame as _;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{CanFrame, Error};

use trn_bench::schedule::Plan;
use trn_bench::{run, Command, Report, RunSpec};
use trn_transport::slcan_serial::PtyPeer;
use trn_transport::{controller_loop, BusSpec};

/// A port whose frames, sent or received, take the time a CAN bus at `bitrate` needs to
/// carry them, one after another (0: no pacing).
struct Paced<P> {
    port: P,
    bitrate: u32,
    /// When the bus is free again.
    free: Instant,
}

impl<P> Paced<P> {
    /// Holds the bus for `frame`'s bits from when it is free; returns once they went by.
    fn carry(&mut self, frame: &CanFrame) {
        if self.bitrate == 0 {
            return;
        }
        let bits = (47 + 8 * frame.dlc() as u64) * 11 / 10;
        let took = Duration::from_nanos(bits * 1_000_000_000 / self.bitrate as u64);
        self.free = self.free.max(Instant::now()) + took;
        std::thread::sleep(self.free.saturating_duration_since(Instant::now()));
    }
}

impl<P> embedded_can::nb::Can for Paced<P>
where
    P: embedded_can::nb::Can<Frame = CanFrame, Error = Error>,
{
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Error> {
        self.carry(frame);
        self.port.transmit(frame)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Error> {
        let frame = self.port.receive()?;
        self.carry(&frame);
        Ok(frame)
    }
}

impl<P: ReceiveTimeout> ReceiveTimeout for Paced<P> {
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>, Error> {
        let frame = self.port.receive_timeout(timeout)?;
        if let Some(f) = &frame {
            self.carry(f);
        }
        Ok(frame)
    }
}

/// One run of `trials` training trials (no evaluation) over a fresh pseudo-terminal pair
/// with a fresh controller node; the report and the wall time in seconds.
fn one(trials: usize, faults: Option<&str>, seed: u64, bitrate: u32) -> (Report, f64) {
    let node = PtyPeer::spawn(move |port, stop| {
        let paced = Paced {
            port,
            bitrate,
            free: Instant::now(),
        };
        controller_loop::run_fresh(paced, seed, stop)
    })
    .expect("a pseudo-terminal pair");
    let mut spec = RunSpec::new(Command::Train, seed);
    spec.plan = Plan::new(trials, 0, 0);
    spec.bus.spec = BusSpec::SlcanSerial(node.path().to_string());
    spec.bus.external_controller = true;
    spec.bus.faults = faults.map(|f| f.parse().expect("a fault list"));
    let started = Instant::now();
    let report = run::run_quietly(&spec).expect("the run");
    let wall = started.elapsed().as_secs_f64();
    node.finish()
        .expect("the node's thread")
        .expect("the node's loop");
    (report, wall)
}

/// One seed's pair of runs on one line.
struct Row {
    seed: u64,
    bitrate: u32,
    clean_s: f64,
    lossy_s: f64,
    dropped: u64,
    sent: u64,
    repeats: u32,
    /// What differs between the clean and the lossy run's scores, empty when nothing does
    /// ([`what_differs`]).
    differs: String,
}

fn row(trials: usize, faults: &str, seed: u64, bitrate: u32) -> Row {
    let (clean, clean_s) = one(trials, None, seed, bitrate);
    let (lossy, lossy_s) = one(trials, Some(faults), seed, bitrate);
    let differs = what_differs(&clean, &lossy);
    let injected = lossy.bus_stats.injected.clone().unwrap_or_default();
    let runner = lossy.bus_stats.runner;
    Row {
        seed,
        bitrate,
        clean_s,
        lossy_s,
        dropped: injected.get("dropped").copied().unwrap_or(0),
        sent: injected.get("sent").copied().unwrap_or(0),
        repeats: runner.target_repeats + runner.mode_repeats + runner.table_repeats,
        differs,
    }
}

/// Which of the scores differ between the clean run `a` and the lossy run `b`, in words
/// (empty when all are identical): the failed and aborted trials' counts, and the first trial
/// whose error or fine moves differ, per curve.
fn what_differs(a: &Report, b: &Report) -> String {
    let mut out = Vec::new();
    if a.failed_trials != b.failed_trials {
        // the first failure of each run, with its reason: what to look into
        let first = |r: &Report| {
            r.failures.first().map_or("none".to_string(), |f| {
                format!("trial {} ({}): {}", f.trial, f.phase, f.reason)
            })
        };
        out.push(format!(
            "failed trials {} clean, {} lossy; the first clean {}, the first lossy {}",
            a.failed_trials,
            b.failed_trials,
            first(a),
            first(b)
        ));
    }
    if a.aborted_trials != b.aborted_trials {
        out.push(format!(
            "aborted trials {} clean, {} lossy",
            a.aborted_trials, b.aborted_trials
        ));
    }
    // the first trial whose value differs bit for bit, or where one curve ends first
    let first = |x: &[f32], y: &[f32]| {
        let same = x
            .iter()
            .zip(y)
            .take_while(|(p, q)| p.to_bits() == q.to_bits())
            .count();
        (same < x.len().max(y.len()))
            .then(|| format!("from trial {same} ({} and {} trials)", x.len(), y.len()))
    };
    let moves = |m: &[u8]| m.iter().map(|&v| f32::from(v)).collect::<Vec<f32>>();
    let curves = [
        (
            "stage 1 error",
            first(&a.stage1_error_px, &b.stage1_error_px),
        ),
        (
            "stage 2 error",
            first(&a.stage2_error_px, &b.stage2_error_px),
        ),
        (
            "stage 1 fine moves",
            first(&moves(&a.fine_moves), &moves(&b.fine_moves)),
        ),
        (
            "stage 2 fine moves",
            first(&moves(&a.fine_moves_stage2), &moves(&b.fine_moves_stage2)),
        ),
    ];
    for (name, d) in curves {
        if let Some(d) = d {
            out.push(format!("{name} {d}"));
        }
    }
    out.join(", ")
}

/// The ratio a lossy line may cost at the bus's bit rate (`--check`).
const MAX_RATIO: f64 = 3.0;

fn main() {
    let mut trials = 60;
    let mut drop = 0.05;
    let mut seeds = vec![100, 101, 102];
    let mut check = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().unwrap_or_else(|| panic!("{a} needs a value"));
        match a.as_str() {
            "--trials" => trials = value().parse().expect("--trials N"),
            "--drop" => drop = value().parse().expect("--drop P"),
            "--seeds" => {
                seeds = value()
                    .split(',')
                    .map(|x| x.parse().expect("--seeds A,B,..."))
                    .collect()
            }
            "--check" => check = true,
            other => panic!("unknown argument {other}: --trials N --drop P --seeds A,B --check"),
        }
    }
    let faults = format!("drop={drop}");
    let mut rows = Vec::new();
    for &bitrate in &[500_000, 0] {
        for &seed in &seeds {
            let r = row(trials, &faults, seed, bitrate);
            eprintln!(
                "seed {seed}, {}: clean {:.2} s, {faults} {:.2} s, ratio {:.2}",
                line(bitrate),
                r.clean_s,
                r.lossy_s,
                r.lossy_s / r.clean_s
            );
            rows.push(r);
        }
    }
    println!("| line | seed | clean s | {faults} both ways s | ratio | frames dropped / sent | requests repeated by the runner | scores identical |");
    println!("|---|---|---|---|---|---|---|---|");
    for r in &rows {
        println!(
            "| {} | {} | {:.2} | {:.2} | {:.2} | {} / {} | {} | {} |",
            line(r.bitrate),
            r.seed,
            r.clean_s,
            r.lossy_s,
            r.lossy_s / r.clean_s,
            r.dropped,
            r.sent,
            r.repeats,
            if r.differs.is_empty() { "yes" } else { "no" }
        );
    }
    if check {
        let mut bad = Vec::new();
        for r in &rows {
            let ratio = r.lossy_s / r.clean_s;
            if r.bitrate > 0 && ratio > MAX_RATIO {
                bad.push(format!("seed {}: ratio {ratio:.2} > {MAX_RATIO}", r.seed));
            }
            if !r.differs.is_empty() {
                bad.push(format!(
                    "seed {}, {}: scores differ ({})",
                    r.seed,
                    line(r.bitrate),
                    r.differs
                ));
            }
            if r.dropped == 0 {
                bad.push(format!("seed {}: no frame dropped", r.seed));
            }
        }
        if !bad.is_empty() {
            eprintln!("lossy_slcan: {}", bad.join("; "));
            std::process::exit(1);
        }
        eprintln!("lossy_slcan: ok (every ratio at the bus's bit rate within {MAX_RATIO}, scores identical)");
    }
}

fn line(bitrate: u32) -> String {
    match bitrate {
        0 => "pseudo-terminal, unpaced".to_string(),
        b => format!("paced at {} kbit/s", b / 1000),
    }
}
