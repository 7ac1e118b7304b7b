//! One session on an open bus: the rig and the runner on the port, on the run's clock, the
//! bus recorded as a candump log if asked, then the schedule (or the conformance suite)
//! against whatever controller is on the bus. The port comes back at the end (in process it
//! holds the controller and its tables).

use std::rc::Rc;

use embedded_can::blocking::Can;
use trn_controller::checkpoint::Provenance;
use trn_controller::Config;
use trn_plant::Plant;
use trn_protocol::bus::{ReceiveTimeout, RecordingPort};
use trn_protocol::{BusMode, CanFrame};
use trn_transport::{Clock, WallClock};

use crate::checkpoint_file;
use crate::error::{io, LabError, Result};
use crate::metrics;
use crate::observe::Observer;
use crate::output::OutputPlan;
use crate::ports::ControllerPort;
use crate::report::Report;
use crate::rig::{Rig, SharedPlant};
use crate::runner::{Runner, Timing};
use crate::schedule::{self, Checkpoints, Context, Plan};
use crate::sim_state::SimState;
use crate::spec::{Command, RunSpec};
use crate::suite::{Patience, Suite};
use crate::tables::{self, opening, opening::Opening};

/// What a session starts from.
pub(crate) struct Start<'a> {
    pub spec: &'a RunSpec,
    /// The trials (the checkpoint's first trial filled in).
    pub plan: Plan,
    /// How the session begins on the controller: its run parameters and what becomes of
    /// the tables it holds (none for a tuning configuration, given to the controller
    /// directly).
    pub opening: Option<Opening>,
    /// The controller's configuration (its priming length paces the schedule).
    pub cfg: Config,
    /// The simulation to continue (`--continue`).
    pub resume: Option<&'a SimState>,
    /// The checked outputs.
    pub outputs: &'a OutputPlan,
}

/// A session about to run, and what it leaves behind; `suite` runs the conformance command.
pub(crate) struct Setup<'a, S> {
    start: Start<'a>,
    observer: &'a mut dyn Observer,
    suite: &'a S,
}

/// Microseconds of the candump log's time 0 (a fixed epoch: logs of the same run are equal).
const LOG_EPOCH_US: u64 = 1_700_000_000_000_000;

impl<'a, S: Suite> Setup<'a, S> {
    pub fn new(start: Start<'a>, observer: &'a mut dyn Observer, suite: &'a S) -> Setup<'a, S> {
        Setup {
            start,
            observer,
            suite,
        }
    }

    pub fn spec(&self) -> &RunSpec {
        self.start.spec
    }

    /// How the session begins (none: a tuning configuration).
    pub fn opening(&self) -> Option<&Opening> {
        self.start.opening.as_ref()
    }

    /// Tells the user something they must see.
    pub fn notice(&mut self, text: &str) {
        self.observer.notice(text);
    }

    /// [`Setup::drive`] on the wall clock (a real bus).
    pub fn drive_wall<P>(&mut self, port: P, plant: Plant, report: &mut Report) -> Result<P>
    where
        P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout + ControllerPort,
    {
        let plant = Rc::new(std::cell::RefCell::new(plant));
        self.drive(port, Rc::new(WallClock::start()), plant, report)
    }

    /// Runs the session on `port` with `clock`, recording the bus as a candump log if asked;
    /// returns the port.
    pub fn drive<P>(
        &mut self,
        port: P,
        clock: Rc<dyn Clock>,
        plant: SharedPlant,
        report: &mut Report,
    ) -> Result<P>
    where
        P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout + ControllerPort,
    {
        let Some(mut log) = self.start.outputs.candump()? else {
            return self.session(port, clock, plant, report);
        };
        let stamp = clock.clone();
        let now_us = move || LOG_EPOCH_US + stamp.now().as_micros() as u64;
        let iface = self.start.spec.bus.spec.log_name().to_string();
        let rec = RecordingPort::new(port, &mut log, &iface, now_us);
        let outcome = self.session(rec, clock, plant, report).and_then(|rec| {
            rec.into_parts()
                .map(|(port, _)| port)
                .map_err(LabError::from)
        });
        // a write error of the log (a full disk) surfaced as a bus error: name the log
        if let Some(kind) = log.write_error() {
            return Err(io(log.target())(kind.into()));
        }
        let port = outcome?;
        log.commit()?;
        Ok(port)
    }

    fn session<P>(
        &mut self,
        port: P,
        clock: Rc<dyn Clock>,
        plant: SharedPlant,
        report: &mut Report,
    ) -> Result<P>
    where
        P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout + ControllerPort,
    {
        let spec = self.start.spec;
        let profile = spec.bus.spec.profile(spec.bus.external_controller);
        let supervision = trn_protocol::HeartbeatConfig {
            timeout_ms: profile.heartbeat_timeout.as_millis() as u32,
            ..Default::default()
        };
        let mode = if spec.bus.fd {
            BusMode::Fd
        } else {
            BusMode::Classic
        };
        let rig = Rig::on_shared(port, clock, plant, mode, supervision);
        let silence = std::time::Duration::from_secs_f64(spec.bus.timeout_s);
        let timing = Timing {
            alive: profile.heartbeat_timeout,
            retries: profile.retries,
            adaptive: profile.adaptive_reply,
            ..Timing::new(profile.reply, silence)
        };
        let mut runner = Runner::new(rig, spec.seed, timing);
        if spec.command == Command::Conformance {
            let opening = self.start.opening.as_ref().ok_or_else(|| {
                LabError::Usage("the conformance suite needs a profile's configuration".into())
            })?;
            // the suite re-seeds the tables and trains them: learned ones only if allowed
            let spoken = tables::probe(&mut runner)?;
            report.controller_protocol = Some(spoken.version().number());
            match &spoken {
                tables::Spoken::V4(before) => {
                    opening::clear(&mut runner, opening, before, &mut *self.observer)?
                }
                tables::Spoken::V3 => {
                    opening.check_v3()?;
                    self.observer.notice(opening::V3_NOTICE);
                }
            }
            let patience = Patience {
                answer: profile.answer,
                quiet: profile.quiet,
                alive: profile.heartbeat_timeout,
            };
            let checks = self
                .suite
                .run(&mut runner, opening.session, patience, spoken);
            report.bus_stats.runner = runner.stats();
            report.conformance = checks?;
            return Ok(runner.into_rig().into_port());
        }
        let mut plan = self.start.plan;
        let mut tables_over_the_bus = false;
        if let Some(o) = &self.start.opening {
            let opened = opening::open(&mut runner, o, &mut *self.observer)?;
            report.controller_protocol = Some(opened.version.number());
            tables_over_the_bus = opened.version >= trn_protocol::ProtocolVersion::V4;
            if let (Some(steps), None) = (opened.kept_steps, self.start.resume) {
                // the controller's own tables: the schedule goes on from their steps
                plan.first_trial = steps as usize;
            }
        }
        let provenance = Provenance::of(spec.profile.preset, spec.profile.ablation);
        let target = self.start.outputs.checkpoint();
        let mut save = |runner: &Runner<P>, state: SimState| -> Result<()> {
            match (runner.rig().port().controller(), target) {
                (Some(ctrl), Some(path)) => {
                    checkpoint_file::save_with_state(ctrl, provenance, path, state)
                }
                _ => Ok(()),
            }
        };
        let checkpoints = (spec.outputs.checkpoint_every > 0).then_some(Checkpoints {
            every: spec.outputs.checkpoint_every,
            save: &mut save,
        });
        let cx = Context {
            cfg: &self.start.cfg,
            seed: spec.seed,
            observer: &mut *self.observer,
            resume: self.start.resume,
            checkpoints,
        };
        let log = schedule::run(&mut runner, plan, cx);
        report.bus_stats.runner = runner.stats();
        let mut log = log?;
        report.interrupted = log.interrupted;
        metrics::fill(report, &log, plan.eval_targets, plan.grasps);
        // the networks' whole history: the trials and curve of the run continued
        report.trials = plan.first_trial + report.stage1_error_px.len();
        if let Some(earlier) = self.start.resume {
            report.continue_from(&earlier.history);
        }
        // the session's end: a controller that trained keeps its tables (its store), the
        // checkpoint asked for is read out of it (nothing learns in Mature or after an
        // interrupt), then the session ends; a version-3 controller has no tables over the
        // bus (a run that needs them was refused at the opening)
        if tables_over_the_bus {
            if plan.trials > 0 {
                if let Some(problem) = tables::save(&mut runner)? {
                    self.observer.notice(&format!(
                        "the controller did not keep its tables: {problem}"
                    ));
                }
            }
            if let Some(path) = target {
                let st = tables::status(&mut runner)?;
                let image = tables::read(&mut runner, &st)?;
                // with the simulator's state at the end of training (or where an interrupt
                // stopped it), for `--continue`
                match log.end_of_training.take() {
                    Some(state) => checkpoint_file::save_image_with_state(&image, path, *state)?,
                    None => checkpoint_file::save_image(&image, path)?,
                }
            }
        }
        report.bus_stats.runner = runner.stats();
        runner.finish()?;
        Ok(runner.into_rig().into_port())
    }
}
