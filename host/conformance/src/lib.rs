//! The conformance suite (`trn conformance`): drives whatever controller is on the bus (the
//! project's node in process, `controller-node` on SocketCAN, the firmware over SLCAN, an
//! external board) through the sequences of `protocol/SPEC.md` 3, 3.2, 3.4 and 3.5 (session
//! configuration, priming, training, evaluation, grasp, abort, repeats, refusals, the
//! tables' status and chunks, the guard of learned tables) against the simulated rig, and
//! checks from the controller's messages alone that it does what the specification says.
//! Nothing of the controller's code is used: only the bus.
//!
//! A controller that speaks protocol version 3 (it never answered the status request,
//! SPEC.md "Versions") gets the suite's v3 profile: every check of what version 3 has, and
//! the checks of what version 4 added (the tables, the guard, a law refused as unsupported,
//! a late duplicate ignored, a finished grasp's repeated start answered once) reported as not
//! applicable.
//!
//! Where the specification leaves a choice the suite takes either: a controller may end its
//! loop at `ModeChange{Idle}` (3.1), and the guard concerns tables that learned (a law that
//! does not train has none); the checks that need a running controller or learned tables
//! are then reported as not applicable ([`Check::skipped`]), not passed or failed.
//!
//! The sequences: `sequences.rs` (session, a supervised pressure the next session drops,
//! priming, training, aborts, a late duplicate),
//! `mature.rs` (grasps and their repeats, frozen tables, configurations outside `Idle`),
//! `tables.rs` (the tables' status, chunk 0, a save, an erase refused, an unsupported law), `guard.rs` (after `Idle`:
//! trials refused, the nonce's refusals and its acceptance), `writes.rs` (a table write's
//! refusals and acknowledgements, `keep_tables` under another configuration and its own).

mod guard;
mod mature;
mod sequences;
mod tables;
mod writes;

use embedded_can::blocking::Can;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_node::codes;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, Envelope, Message, Mode, NodeId, SessionConfig, Stage1Target, Stage2Target,
    TablesStatus,
};

use trn_bench::journal::{errors, has_error, heartbeat_problems, missing_error, moves, reports};
pub use trn_bench::report::Check;
use trn_bench::runner::Runner;
pub use trn_bench::suite::Patience;
use trn_bench::tables::Spoken;
use trn_bench::{LabError, Result};
use trn_plant::targets::{self, Target};

struct Suite<'a, P> {
    runner: &'a mut Runner<P>,
    rng: Xoshiro256PlusPlus,
    patience: Patience,
    checks: Vec<Check>,
    trial: u32,
    /// Everything received, for the session-wide checks (heartbeats).
    all: Vec<Envelope>,
    /// The tables' status the controller gave first.
    status: Option<TablesStatus>,
    /// The controller speaks protocol version 3: the checks of what version 4 added are
    /// not applicable (the suite's v3 profile).
    v3: bool,
}

/// Why a check is not applicable to a version-3 controller.
pub(crate) const V4_ONLY: &str =
    "not applicable: version 4 added it, and the controller speaks protocol v3 (SPEC.md, Versions)";

const STAGE1_JOINTS: [u8; 5] = [0, 1, 2, 3, 4];
const STAGE2_JOINTS: [u8; 3] = [0, 1, 2];

/// The suite as a run of `trn_bench` takes it: [`trn_bench::run::run_with`] with it runs a
/// specification of [`trn_bench::Command::Conformance`] (and every other command as
/// [`trn_bench::run::run`] does).
#[derive(Debug, Clone, Copy, Default)]
pub struct Conformance;

/// A run of `spec` (any command) with the suite at hand for [`trn_bench::Command::Conformance`].
pub fn run_spec(
    spec: &trn_bench::RunSpec,
    observer: &mut dyn trn_bench::Observer,
) -> Result<trn_bench::Report> {
    trn_bench::run::run_with(spec, observer, &Conformance)
}

/// [`run_spec`] with nothing watching it.
pub fn run_quietly(spec: &trn_bench::RunSpec) -> Result<trn_bench::Report> {
    run_spec(spec, &mut trn_bench::Unobserved)
}

impl trn_bench::suite::Suite for Conformance {
    /// Runs the suite; `session` is the configuration it sends first.
    fn run<P>(
        &self,
        runner: &mut Runner<P>,
        session: SessionConfig,
        patience: Patience,
        spoken: Spoken,
    ) -> Result<Vec<Check>>
    where
        P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
    {
        runner.rig_mut().start_journal();
        let mut s = Suite {
            runner,
            rng: Xoshiro256PlusPlus::seed_from_u64(trn_bench::Seeds::of(session.seed).suite),
            patience,
            checks: Vec::new(),
            trial: 1000,
            all: Vec::new(),
            status: None,
            v3: spoken == Spoken::V3,
        };
        s.store_status()?;
        s.unsupported_law(session)?;
        s.session(session)?;
        s.priming()?;
        s.training()?;
        s.abort()?;
        s.mature(session)?;
        s.chunk_zero()?;
        s.save()?;
        s.erase_without_nonce()?;
        let idle = s.runner.mode(Mode::Idle);
        s.verdict(
            "ModeChange{Idle} is acknowledged (echo to Broadcast)",
            idle.err().map(|e| e.to_string()).into_iter().collect(),
        );
        s.after_idle(session)?;
        s.writes(session)?;
        let problems = heartbeat_problems(&s.all);
        s.verdict("heartbeats: Operational, counter +1 each", problems);
        Ok(s.checks)
    }
}

impl<P> Suite<'_, P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    fn verdict(&mut self, name: &str, problems: Vec<String>) {
        self.checks.push(Check {
            name: name.to_string(),
            passed: problems.is_empty(),
            detail: problems.join("; "),
            skipped: false,
        });
    }

    /// True (and the check `name` reported not applicable) when the controller speaks
    /// version 3 and the check is of something version 4 added.
    fn v4_only(&mut self, name: &str) -> bool {
        if self.v3 {
            self.skip(name, V4_ONLY);
        }
        self.v3
    }

    /// The checks `names` not applicable to this controller, and why.
    fn skip_each(&mut self, names: &[&str], why: &str) {
        for name in names {
            self.skip(name, why);
        }
    }

    /// A check not applicable to this controller, and why.
    fn skip(&mut self, name: &str, why: &str) {
        self.checks.push(Check {
            name: name.to_string(),
            passed: true,
            detail: why.to_string(),
            skipped: true,
        });
    }

    /// Ends the suite when the controller has sent nothing but heartbeats for a whole
    /// sequence's patience since the suite began: a controller that answers nothing would
    /// otherwise cost every check its full patience.
    fn answered_nothing(&self) -> Result<()> {
        // the journal holds what the controller sent (the rig's own frames do not come back)
        let answers = |j: &[Envelope]| j.iter().any(|e| !matches!(e.msg, Message::Heartbeat(_)));
        if answers(&self.all) || answers(self.runner.rig().journal()) {
            return Ok(());
        }
        Err(LabError::Controller(format!(
            "sent only heartbeats for {:.1} s: it answered no request of the conformance suite",
            self.patience.answer.as_secs_f64()
        )))
    }

    fn next_trial(&mut self) -> u32 {
        self.trial += 1;
        self.trial
    }

    fn send(&mut self, msg: Message) -> Result<()> {
        self.runner.rig_mut().send(NodeId::Controller, msg)
    }

    /// Serves the bus until `done` holds for what came since the journal was last taken
    /// (or the patience ran out), then for `quiet` more; returns what came.
    fn collect(
        &mut self,
        done: impl Fn(&[Envelope]) -> bool,
        quiet: bool,
    ) -> Result<Vec<Envelope>> {
        let silence = self.runner.timing().silence;
        let deadline = self.runner.rig().now() + self.patience.answer;
        while !done(self.runner.rig().journal()) {
            let left = deadline.saturating_sub(self.runner.rig().now());
            if left.is_zero() {
                self.answered_nothing()?;
                break;
            }
            self.runner.rig_mut().next_event(left, silence)?;
        }
        if quiet {
            let until = self.runner.rig().now() + self.patience.quiet;
            loop {
                let left = until.saturating_sub(self.runner.rig().now());
                if left.is_zero() {
                    break;
                }
                self.runner.rig_mut().next_event(left, silence)?;
            }
        }
        let j = self.runner.rig_mut().take_journal();
        self.all.extend_from_slice(&j);
        Ok(j)
    }

    /// A target of the paper's kind (the arm visits random pressures), then the arm goes to
    /// a random start pose (all joints, or the first three for stage 2).
    fn target(&mut self, grasp: bool, joints: usize) -> Result<Target> {
        let mut plant = self.runner.rig_mut().plant_mut();
        let t = targets::visit_and_return(&mut plant, &mut self.rng, grasp)?;
        plant.move_to_random_joints(&mut self.rng, joints);
        plant.settle();
        Ok(t)
    }

    fn ended(trial: u32, stages: usize) -> impl Fn(&[Envelope]) -> bool {
        move |j: &[Envelope]| {
            reports(j).iter().filter(|r| r.trial == trial).count() >= stages
                || has_error(j, codes::TRIAL_ABORTED, trial)
        }
    }

    fn error_seen(code: u16) -> impl Fn(&[Envelope]) -> bool {
        move |j: &[Envelope]| errors(j).iter().any(|e| e.code == code)
    }
}

/// Problems if the controller moved or reported.
pub(crate) fn nothing_moved(j: &[Envelope]) -> Vec<String> {
    let mut p = Vec::new();
    if !moves(j).is_empty()
        || j.iter().any(|e| {
            matches!(
                e.msg,
                Message::PressureCommand(_) | Message::CaptureRequest(_)
            )
        })
    {
        p.push("the controller moved".to_string());
    }
    p
}

/// Problems if a target answered with the error `code` (its detail the trial, named
/// `name`) moved, reported, or was not answered so.
pub(crate) fn refused_start(j: &[Envelope], code: u16, trial: u32, name: &str) -> Vec<String> {
    let mut p = nothing_moved(j);
    p.extend(missing_error(j, code, trial, name));
    if !reports(j).is_empty() {
        p.push(format!("reports {:?}", reports(j)));
    }
    p
}

pub(crate) fn stage1(trial: u32, t: &Target, fine_moves: u8, grasp: bool) -> Stage1Target {
    Stage1Target {
        trial,
        learn: !grasp,
        grasp,
        fine_moves,
        v: t.v,
    }
}

pub(crate) fn stage2(trial: u32, t: &Target, fine_moves: u8, grasp: bool) -> Stage2Target {
    Stage2Target {
        trial,
        learn: !grasp,
        grasp,
        fine_moves,
        c: t.c,
    }
}
