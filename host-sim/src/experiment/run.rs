//! `trn train`, `trn eval`, `trn grasp`: opens the bus, starts the controller on it, runs
//! the schedule against the rig and writes the report.

use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

use embedded_can::blocking::Can;
use trn_controller::checkpoint::Provenance;
use trn_controller::presets::{self, ImageSize};
use trn_controller::{Config, Controller, Law};
use trn_protocol::bus::{InProcBus, ReceiveTimeout, RecordingPort};
use trn_protocol::{BusMode, CanFrame, SessionConfig};

use super::checkpoint_file;
use super::cli::{self, Ablation, Common, Preset};
use super::conformance::{self, Patience};
use super::metrics;
use super::report::Report;
use super::rig::Rig;
use super::runner::{Runner, Timing};
use super::schedule;
pub use super::schedule::Plan;
use super::sim_state::{self, SimState};
use crate::error::{io, Error, Result};
use crate::plant::{Plant, SimConfig};
use crate::reference::NominalIk;
use crate::transport::controller_loop::{ControllerThread, LoopStats};
use crate::transport::peer::{self, Peer};
use crate::transport::{slcan_qemu, slcan_serial, BusSpec};

/// The controller configuration for a preset and an ablation, for the simulator's cameras.
pub fn controller_config(preset: Preset, ablation: Ablation, sim: &SimConfig) -> Config {
    let (w, h) = sim.image_size();
    let image = ImageSize {
        width: w.min(u16::MAX as u32) as u16,
        height: h.min(u16::MAX as u32) as u16,
    };
    presets::configure(preset.into(), ablation.into(), image)
}

/// The run parameters of a session for the controller (`SessionConfig`, SPEC.md 3.2).
pub fn session_config(common: &Common, sim: &SimConfig, keep_tables: bool) -> SessionConfig {
    let (w, h) = sim.image_size();
    SessionConfig {
        seed: common.seed,
        preset: trn_controller::presets::Preset::from(common.preset) as u8,
        ablation: trn_controller::presets::Ablation::from(common.ablation) as u8,
        image_width: w.min(u16::MAX as u32) as u16,
        image_height: h.min(u16::MAX as u32) as u16,
        fd: common.fd,
        keep_tables,
        law: trn_controller::Law::from(common.controller) as u8,
    }
}

/// The controller configuration of a run's options: preset, ablation, control law.
pub fn common_config(common: &Common, sim: &SimConfig) -> Config {
    Config {
        law: common.controller.into(),
        ..controller_config(common.preset, common.ablation, sim)
    }
}

/// Loads the simulator configuration: the realistic plant ([`SimConfig::realistic`]) when
/// none is given, a built-in one by name (`ideal`, `realistic`, `aging`) unless a file of
/// that name exists, else the file.
pub fn load_sim_config(path: Option<&Path>) -> Result<SimConfig> {
    match path {
        None => Ok(SimConfig::realistic()),
        Some(p) => match p.to_str().and_then(SimConfig::named) {
            Some(c) if !p.exists() => Ok(c),
            _ => SimConfig::load(p),
        },
    }
}

/// Runs a plan: training (if `plan.trials > 0`), held-out evaluation, grasps.
pub fn run_plan(
    common: &Common,
    plan: Plan,
    checkpoint_in: Option<&Path>,
    checkpoint_out: Option<&Path>,
    command: &str,
) -> Result<Report> {
    let sim_cfg = load_sim_config(common.config.as_deref())?;
    let cfg = common_config(common, &sim_cfg);
    run_plan_with(common, plan, cfg, checkpoint_in, checkpoint_out, command)
}

/// [`run_plan`] with an explicit controller configuration (tuning, tests). Over
/// SocketCAN the `controller-node` process builds its configuration from the preset.
pub fn run_plan_with(
    common: &Common,
    plan: Plan,
    cfg: Config,
    checkpoint_in: Option<&Path>,
    checkpoint_out: Option<&Path>,
    command: &str,
) -> Result<Report> {
    run_job(
        common,
        plan,
        cfg,
        (checkpoint_in, checkpoint_out),
        command,
        false,
    )
}

/// `trn conformance`: the conformance suite against the controller on the bus (the
/// project's node unless `--external-controller`); the checks are in the report.
pub fn run_conformance(common: &Common) -> Result<Report> {
    let sim_cfg = load_sim_config(common.config.as_deref())?;
    let cfg = common_config(common, &sim_cfg);
    run_job(
        common,
        Plan::new(0, 0, 0),
        cfg,
        (None, None),
        "conformance",
        true,
    )
}

fn run_job(
    common: &Common,
    mut plan: Plan,
    cfg: Config,
    (checkpoint_in, checkpoint_out): (Option<&Path>, Option<&Path>),
    command: &str,
    conformance: bool,
) -> Result<Report> {
    let started = Instant::now();
    let sim_cfg = load_sim_config(common.config.as_deref())?;
    let plant = Plant::new(&sim_cfg, common.seed)?;
    let mode = if common.fd {
        BusMode::Fd
    } else {
        BusMode::Classic
    };
    let bus = BusSpec::parse(&common.bus)?;
    if common.external_controller
        && (checkpoint_in.is_some() || checkpoint_out.is_some() || bus == BusSpec::InProc)
    {
        return Err(Error::BusOpen {
            bus: common.bus.clone(),
            msg: "an external controller (on socketcan:IFACE or slcan:/dev/DEVICE) keeps its own tables: no --checkpoint-in/--checkpoint-out".into(),
        });
    }
    if common.faults.is_some() && bus != BusSpec::InProc {
        return Err(Error::BusOpen {
            bus: common.bus.clone(),
            msg: "--faults injects faults on the in-process bus only".into(),
        });
    }
    if cfg.law == Law::Model
        && (bus != BusSpec::InProc || checkpoint_in.is_some() || checkpoint_out.is_some())
    {
        return Err(Error::BusOpen {
            bus: common.bus.clone(),
            msg: "the model-based reference (--controller model) carries the simulator's model: in process only, no checkpoints".into(),
        });
    }
    if bus == BusSpec::SlcanQemu && (checkpoint_in.is_some() || checkpoint_out.is_some()) {
        return Err(Error::BusOpen {
            bus: common.bus.clone(),
            msg: "the firmware keeps its tables in RAM: no --checkpoint-in/--checkpoint-out".into(),
        });
    }
    // a checkpoint's schedule goes on from the trials it learned; `--continue` also restores
    // the simulation of the run that wrote it
    let mut resume = None;
    if let Some(p) = checkpoint_in {
        let (bytes, header) = checkpoint_file::read(p)?;
        plan.first_trial = header.t1 as usize;
        if plan.resume {
            let path = sim_state::path_beside(p);
            let crc = checkpoint_file::crc_of(&bytes);
            resume = Some(sim_state::load(&path, common.seed, &sim_cfg, crc)?);
        }
    } else if plan.resume {
        return Err(Error::Config("--continue needs --checkpoint-in".into()));
    }
    // the run parameters go to the controller over the bus; a tuning configuration that no
    // preset describes is given to the in-process controller directly instead
    let keep_tables = checkpoint_in.is_some() || (common.external_controller && plan.trials == 0);
    let session = (common_config(common, &sim_cfg).fingerprint() == cfg.fingerprint())
        .then(|| session_config(common, &sim_cfg, keep_tables));
    let provenance = Provenance::of(common.preset.into(), common.ablation.into());
    // every output must be writable before the run starts, not fail after it
    for p in [
        common.report.as_deref(),
        common.plot.as_deref(),
        common.candump.as_deref(),
        checkpoint_out,
    ]
    .into_iter()
    .flatten()
    {
        checkpoint_file::check_writable(p)?;
    }
    let mut report = Report {
        command: command.to_string(),
        preset: match (common.controller, common.ablation) {
            (cli::Controller::Broyden, _) => "broyden".to_string(),
            (cli::Controller::Model, _) => "model".to_string(),
            (_, Ablation::None) => common.preset.name().to_string(),
            (_, a) => format!("{}+{}", common.preset.name(), a.name().replace('-', "")),
        },
        trials: plan.trials,
        seed: common.seed,
        bus: common.bus.clone(),
        ..Default::default()
    };
    let bus_err = |msg: String| Error::BusOpen {
        bus: common.bus.clone(),
        msg,
    };
    let setup = Setup {
        common,
        plan,
        session,
        conformance,
        cfg: &cfg,
        mode,
        bus: &bus,
        resume: resume.as_ref(),
        end_state: Default::default(),
    };
    let ctrl = match bus {
        BusSpec::InProc => {
            let inproc = InProcBus::new(mode, common.seed);
            if let Some(f) = common.faults {
                inproc.set_faults(f);
            }
            let peer = if cfg.law == Law::Model {
                // the model-based reference: the simulator's own model, in process only
                let reference = Box::new(NominalIk::new(&sim_cfg, cfg)?);
                Peer::Reference(ControllerThread::spawn(inproc.port(), reference, mode))
            } else {
                let mut ctrl = Box::new(Controller::new(cfg));
                ctrl.init_random(common.seed);
                if let Some(p) = checkpoint_in {
                    checkpoint_file::load(&mut ctrl, p, provenance, common.allow_config_change)?;
                }
                Peer::Thread(ControllerThread::spawn(inproc.port(), ctrl, mode))
            };
            let done = setup.drive(inproc.port(), plant, peer, &mut report)?;
            let s = inproc.stats();
            report.bus_stats.injected = Some(counts([
                ("sent", s.sent),
                ("delivered", s.delivered),
                ("dropped", s.dropped),
                ("duplicated", s.duplicated),
                ("corrupted", s.corrupted),
                ("truncated", s.truncated),
                ("delayed", s.delayed),
            ]));
            done
        }
        BusSpec::SlcanQemu => {
            // processor-in-the-loop: the controller is the firmware in QEMU, configured and
            // seeded by the session's `SessionConfig` like any other controller
            let (port, child) = slcan_qemu::SlcanPort::spawn_qemu(
                &slcan_qemu::qemu_arm(),
                &slcan_qemu::firmware_elf(),
            )
            .map_err(bus_err)?;
            setup.drive(port, plant, Peer::Process(child), &mut report)?
        }
        BusSpec::SlcanSerial(ref path) => {
            if !common.external_controller {
                return Err(bus_err(
                    "a serial adapter connects to a controller on a real bus: add --external-controller".into(),
                ));
            }
            let port = slcan_serial::SerialSlcan::open(path).map_err(bus_err)?;
            setup.drive(port, plant, Peer::External, &mut report)?
        }
        BusSpec::SocketCan(ref iface) => {
            #[cfg(target_os = "linux")]
            {
                let port = trn_protocol::bus::SocketCanPort::open(iface)
                    .map_err(|e| bus_err(e.to_string()))?;
                if common.external_controller {
                    setup.drive(port, plant, Peer::External, &mut report)?
                } else {
                    let args = peer::NodeArgs {
                        iface,
                        seed: common.seed,
                        preset: common.preset.name(),
                        ablation: common.ablation.name(),
                        controller: trn_controller::Law::from(common.controller).name(),
                        config: common.config.as_deref(),
                        fd: common.fd,
                        checkpoint_in,
                        checkpoint_out,
                    };
                    let child = peer::spawn_controller_node(&args, &common.bus)?;
                    setup.drive(port, plant, Peer::Process(child), &mut report)?
                }
            }
            #[cfg(not(target_os = "linux"))]
            {
                let _ = iface;
                return Err(bus_err("SocketCAN needs Linux".into()));
            }
        }
    };
    if let Some((_, stats)) = &ctrl {
        let n = stats.node;
        report.bus_stats.controller = Some(counts([
            ("retries", n.retries),
            ("corrected_commands", n.corrected_commands),
            ("repeated_targets", n.repeated_targets),
            ("stale_answers", n.stale_answers),
            ("frame_errors", n.frame_errors),
            ("aborted", n.aborted),
        ]));
    }
    report.bus_stats.faults = common.faults.map(|f| format!("{f:?}"));
    if let (Some((ctrl, _)), Some(p)) = (ctrl, checkpoint_out) {
        checkpoint_file::save(&ctrl, provenance, p)?;
    }
    // the simulator's half, after the controller's (over SocketCAN the node wrote it), paired
    // with it by its CRC
    if let (Some(p), Some(mut state)) = (checkpoint_out, setup.end_state.take()) {
        if p.exists() {
            let (bytes, _) = checkpoint_file::read(p)?;
            state.checkpoint_crc = checkpoint_file::crc_of(&bytes);
            sim_state::save(&state, &sim_state::path_beside(p))?;
        }
    }
    report.wall_s = started.elapsed().as_secs_f64();
    write_outputs(common, &report)?;
    Ok(report)
}

/// Named counters for the report.
fn counts<T, const N: usize>(pairs: [(&str, T); N]) -> std::collections::BTreeMap<String, T> {
    pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
}

fn write_outputs(common: &Common, report: &Report) -> Result<()> {
    if let Some(p) = &common.report {
        let json = serde_json::to_string_pretty(report).map_err(|e| Error::Io {
            path: p.clone(),
            source: e.into(),
        })?;
        fs::write(p, json).map_err(io(p))?;
    }
    if let Some(p) = &common.plot {
        #[cfg(feature = "plot")]
        super::plot::learning_curves(report, p)?;
        #[cfg(not(feature = "plot"))]
        {
            let _ = p;
            return Err(Error::NoPlot);
        }
    }
    Ok(())
}

/// What a run needs once its bus is open.
struct Setup<'a> {
    common: &'a Common,
    plan: Plan,
    /// The run parameters sent to the controller first (none for a tuning configuration).
    session: Option<SessionConfig>,
    /// Run the conformance suite instead of the plan.
    conformance: bool,
    cfg: &'a Config,
    mode: BusMode,
    bus: &'a BusSpec,
    /// The simulation to continue (`--continue`).
    resume: Option<&'a SimState>,
    /// The simulator's state at the end of training, for the checkpoint.
    end_state: std::cell::Cell<Option<Box<SimState>>>,
}

impl Setup<'_> {
    /// Runs the schedule on `port` (recorded as a candump log if asked), then ends the
    /// controller's side; returns the in-process controller with its tables.
    fn drive<P>(
        &self,
        port: P,
        plant: Plant,
        peer: Peer,
        report: &mut Report,
    ) -> Result<Option<(Box<Controller>, LoopStats)>>
    where
        P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
    {
        let outcome = match &self.common.candump {
            Some(path) => {
                let file = fs::File::create(path).map_err(io(path))?;
                let start = Instant::now();
                let clock = move || 1_700_000_000_000_000u64 + start.elapsed().as_micros() as u64;
                let rec = RecordingPort::new(
                    port,
                    std::io::BufWriter::new(file),
                    self.bus.log_name(),
                    clock,
                );
                self.session(rec, plant, report)
            }
            None => self.session(port, plant, report),
        };
        // the session ended (well or not): stop the controller and collect it
        let ctrl = peer.finish(outcome.is_ok(), &self.common.bus)?;
        outcome.map(|_| ctrl)
    }

    fn session<P>(&self, port: P, plant: Plant, report: &mut Report) -> Result<()>
    where
        P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
    {
        let hb = heartbeat_for(self.bus);
        let rig = Rig::new(port, plant, self.mode, hb);
        let silence = Duration::from_secs_f64(self.common.bus_timeout_s);
        let reply = match self.bus {
            // the firmware's clock runs about ten times slower than the wall clock under
            // QEMU's instruction counting, and its own repeats are 200 ms of it apart
            BusSpec::SlcanQemu => Duration::from_secs(20),
            BusSpec::SocketCan(_) | BusSpec::SlcanSerial(_) => Duration::from_millis(300),
            BusSpec::InProc => Duration::from_millis(60),
        };
        let timing = Timing {
            alive: Duration::from_millis(hb.timeout_ms as u64),
            ..Timing::new(reply, silence)
        };
        let mut runner = Runner::new(rig, self.common.seed, timing);
        if self.conformance {
            let session = self.session.ok_or_else(|| Error::BusOpen {
                bus: self.common.bus.clone(),
                msg: "the conformance suite needs a preset configuration".into(),
            })?;
            let patience = match self.bus {
                BusSpec::SlcanQemu => Patience {
                    answer: Duration::from_secs(120),
                    quiet: Duration::from_secs(5),
                },
                BusSpec::SocketCan(_) | BusSpec::SlcanSerial(_) => Patience {
                    answer: Duration::from_secs(20),
                    quiet: Duration::from_millis(600),
                },
                BusSpec::InProc => Patience {
                    answer: Duration::from_secs(10),
                    quiet: Duration::from_millis(150),
                },
            };
            let checks = conformance::run(&mut runner, session, patience);
            report.bus_stats.runner = runner.stats();
            report.conformance = checks?;
            return Ok(());
        }
        if let Some(s) = self.session {
            runner.configure(s)?;
        }
        let log = schedule::run(
            &mut runner,
            self.plan,
            self.cfg,
            self.common.seed,
            self.common.quiet,
            self.resume,
        );
        report.bus_stats.runner = runner.stats();
        let mut log = log?;
        self.end_state.set(log.end_of_training.take());
        metrics::fill(report, &log, self.plan.eval_targets, self.plan.grasps);
        Ok(())
    }
}

/// The servo drives' heartbeat supervision for a bus. The firmware in QEMU keeps time by
/// executed instructions (`-icount`), which runs several times slower than the wall clock the
/// simulator's drives use: its 100 ms heartbeats arrive about every second of wall time, so
/// the drives allow 30 s there instead of 500 ms.
fn heartbeat_for(bus: &BusSpec) -> trn_protocol::HeartbeatConfig {
    let mut hb = trn_protocol::HeartbeatConfig::default();
    if *bus == BusSpec::SlcanQemu {
        hb.timeout_ms = 30_000;
    }
    hb
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The firmware configures its controller with `presets::configure` for
    /// `ImageSize::DEFAULT` (firmware/src/main.rs); the host derives the image size from the
    /// simulator's cameras. If the default cameras change, the two would differ.
    #[test]
    fn host_and_firmware_build_the_same_default_controller() {
        let host = controller_config(Preset::Project, Ablation::None, &SimConfig::default());
        let firmware = presets::configure(
            presets::Preset::Project,
            presets::Ablation::None,
            ImageSize::DEFAULT,
        );
        assert_eq!(host, firmware);
    }
}
