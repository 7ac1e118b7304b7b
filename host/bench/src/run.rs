//! A run from its specification ([`RunSpec`]): checks it and its outputs, opens the bus the
//! specification names with the controller on it (inline on the simulated clock, a
//! `controller-node` process, the firmware in QEMU, or a board that is already there), runs
//! the schedule or the conformance suite (`session.rs`) and writes what was asked.

use std::time::Instant;

use trn_controller::checkpoint::Provenance;
use trn_controller::Control;
use trn_node::ControllerNode;
use trn_plant::Plant;
use trn_protocol::bus::{BusStats, FaultyPort};
use trn_protocol::BusMode;
use trn_transport::inproc::SimulatedBus;
use trn_transport::{peer, slcan_qemu, slcan_serial, BusSpec, ControllerSite, TransportError};

use crate::checkpoint_file;
use crate::error::{LabError, Result};
use crate::observe::Observer;
use crate::output::OutputPlan;
use crate::report::Report;
use crate::rig::SharedPlant;
use crate::session::{Setup, Start};
use crate::sim_state;
use crate::spec::{Command, ControllerChoice, RunSpec};
use crate::suite::{no_suite, NoSuite, Suite};
use crate::tables::opening::{Opening, Want};
use trn_references::NominalIk;
use trn_references::Oracle;
use trn_transport::board;

/// Runs a specification: training (if `plan.trials > 0`), the held-out evaluation and
/// grasps; writes the report, the candump log and the checkpoint it asks for. `observer`
/// watches it and may interrupt it. The conformance command is refused: it needs a suite
/// ([`run_with`]).
pub fn run(spec: &RunSpec, observer: &mut dyn Observer) -> Result<Report> {
    if spec.command == Command::Conformance {
        return Err(no_suite());
    }
    run_with(spec, observer, &NoSuite)
}

/// [`run`], with `suite` for the conformance command.
pub fn run_with<S: Suite>(
    spec: &RunSpec,
    observer: &mut dyn Observer,
    suite: &S,
) -> Result<Report> {
    spec.check()?;
    let outputs = OutputPlan::check(spec)?;
    let started = Instant::now();
    let seeds = crate::seeds::Seeds::of(spec.seed);
    let plant = Plant::new(&spec.plant, seeds.plant)?;
    let mut plan = spec.plan;
    let provenance = Provenance::of(spec.profile.preset, spec.profile.ablation);
    // a checkpoint's schedule goes on from the trials it learned; `--continue` also restores
    // the simulation of the run that wrote it
    let mut resume = None;
    let mut image = None;
    let configs = spec.controller();
    if let Some(p) = &spec.checkpoint_in {
        let (bytes, header, file) =
            checkpoint_file::image_for(p, &configs.profile, provenance, spec.allow_config_change)?;
        plan.first_trial = header.t1 as usize;
        let beside = sim_state::path_beside(p);
        if plan.resume {
            let crc = checkpoint_file::crc_of(&file);
            let state = sim_state::load_beside(p, spec.seed, &spec.plant, crc)?;
            plan.first_trial = state.trials_done;
            if spec.trials_left {
                plan.trials = state.trials_planned.saturating_sub(state.trials_done);
                if plan.trials == 0 {
                    return Err(LabError::Usage(format!(
                        "{}: the run that wrote it finished its {} trials: give --trials to train more",
                        p.display(),
                        state.trials_planned
                    )));
                }
            }
            resume = Some(state);
        } else if !spec.allow_config_change {
            // a checkpoint trained on another plant (its `.sim` says which) is refused; one
            // whose `.sim` is missing or unreadable is used, and the user told that its plant
            // could not be checked (the checkpoint itself holds the controller, not the plant)
            match sim_state::read_plant_config(&beside) {
                Ok(other) if other != spec.plant => {
                    return Err(LabError::Usage(format!(
                        "checkpoint {} was trained on another plant than this run's (its .sim says so); pass --allow-config-change to use it on this one",
                        p.display()
                    )));
                }
                Ok(_) => {}
                Err(e) => {
                    let why = match beside.exists() {
                        true => format!("its simulator state does not read ({e})"),
                        false => format!("no simulator state beside it ({})", beside.display()),
                    };
                    observer.notice(&format!(
                        "checkpoint {}: {why}, so the plant it was trained on is not known and not checked against this run's",
                        p.display()
                    ));
                }
            }
        }
        image = Some(bytes);
    }
    let cfg = configs.run;
    let want = match (image, spec.command) {
        (Some(bytes), _) => Want::Image(bytes),
        (None, Command::Eval | Command::Grasp) => Want::Held { or_new: false },
        (None, _) if spec.keep_tables => Want::Held { or_new: true },
        (None, _) => Want::New,
    };
    // the run parameters go to the controller over the bus; a tuning configuration that no
    // profile describes is given to the in-process controller directly instead
    let opening = configs.described.then(|| Opening {
        want,
        reset: spec.reset_tables,
        session: spec.session_config(false),
        fingerprint: configs.fingerprint,
        image: spec.image(),
        needs_tables: [
            (spec.tables.is_some(), "--tables"),
            (spec.outputs.checkpoint.is_some(), "--checkpoint-out"),
        ]
        .into_iter()
        .filter_map(|(given, option)| given.then_some(option))
        .collect(),
    });
    let mut report = Report::of(spec);
    report.bus_stats.faults = spec.bus.faults.map(|f| format!("{f:?}"));
    report.trials_this_run = plan.trials;
    let start = Start {
        spec,
        plan,
        opening,
        cfg,
        resume: resume.as_ref(),
        outputs: &outputs,
    };
    let bus_name = spec.bus.spec.to_string();
    let profile = spec.bus.spec.profile(spec.bus.external_controller);
    // every trial's CSV row (`--csv`) is kept beside the caller's observer
    let mut rows = crate::trial_csv::TrialRows::new(observer, spec.outputs.csv.is_some());
    let mut setup = Setup::new(start, &mut rows, suite);
    match profile.controller {
        ControllerSite::Inline if spec.profile.law == ControllerChoice::Model => {
            // the model-based reference: the simulator's own model, in process only
            let reference = Box::new(NominalIk::new(&spec.plant, cfg)?);
            inline(&mut setup, reference, None, plant, &mut report)?;
        }
        ControllerSite::Inline if spec.profile.law == ControllerChoice::Oracle => {
            // the physical limit: it reads the plant the rig moves
            let shared: SharedPlant = std::rc::Rc::new(std::cell::RefCell::new(plant));
            let oracle = Box::new(Oracle::new(shared.clone(), cfg));
            inline_shared(&mut setup, oracle, None, shared, &mut report)?;
        }
        ControllerSite::Inline => {
            // zeroed, as a board boots, with its store (in memory, or the tables file) and
            // what that held restored: the session configuration seeds the tables, or keeps
            // them; a configuration no profile describes is seeded here
            let (mut b, restored) = board::boot(cfg, spec.tables.as_deref())?;
            if let Some(problem) = restored.as_ref().err().and_then(board::restore_problem) {
                setup.notice(&format!(
                    "the tables file: {problem}; its tables are not used"
                ));
            }
            if setup.opening().is_none() {
                b.ctrl.init_random(seeds.tables);
            }
            let node = board::node(
                &mut b,
                restored.ok(),
                board::guard_seed(seeds.guard),
                node_config(spec),
            );
            inline(&mut setup, Box::new(b), Some(node), plant, &mut report)?;
        }
        ControllerSite::Qemu => {
            // processor-in-the-loop: the controller is the firmware in QEMU, configured and
            // seeded by the session's `SessionConfig` like any other controller
            let (port, child) = slcan_qemu::SlcanPort::spawn_qemu(
                &slcan_qemu::qemu_arm(),
                &slcan_qemu::firmware_elf(),
            )
            .map_err(|m| TransportError::open(&bus_name, m))?;
            let outcome = drive_wall(&mut setup, port, plant, &mut report);
            let stopped = peer::finish_process(child, outcome.is_ok(), &bus_name);
            outcome?;
            stopped?;
        }
        ControllerSite::External => match &spec.bus.spec {
            BusSpec::SlcanSerial(path) => {
                let port = slcan_serial::SerialSlcan::open(path, spec.bus.bitrate)
                    .map_err(|m| TransportError::open(&bus_name, m))?;
                drive_wall(&mut setup, port, plant, &mut report)?;
            }
            BusSpec::SocketCan(iface) => {
                drive_wall(&mut setup, socketcan(iface, &bus_name)?, plant, &mut report)?;
            }
            _ => {
                return Err(LabError::Usage(format!(
                    "{bus_name}: no external controller there"
                )))
            }
        },
        ControllerSite::Process => {
            let BusSpec::SocketCan(iface) = &spec.bus.spec else {
                return Err(LabError::Usage(format!(
                    "{bus_name}: no controller process there"
                )));
            };
            let port = socketcan(iface, &bus_name)?;
            let args = peer::NodeArgs {
                iface,
                tables: spec.tables.as_deref(),
            };
            let child = peer::spawn_controller_node(&args, &bus_name)?;
            let outcome = drive_wall(&mut setup, port, plant, &mut report);
            let stopped = peer::finish_process(child, outcome.is_ok(), &bus_name);
            outcome?;
            stopped?;
        }
    }
    drop(setup);
    report.wall_s = started.elapsed().as_secs_f64();
    // what the observer shows of the run comes before the files that may fail to be written
    rows.ran(&report);
    outputs.write_report(&report)?;
    if let (Some(p), Some(csv)) = (&spec.outputs.csv, rows.csv()) {
        crate::fsio::write_durably(p, csv.as_bytes())?;
    }
    Ok(report)
}

/// The session with the controller `ctrl` serviced inline on the simulated clock, by
/// `node` (booted by the caller) or a fresh node.
fn inline<C: Control + ?Sized, S: Suite>(
    setup: &mut Setup<S>,
    ctrl: Box<C>,
    node: Option<ControllerNode>,
    plant: Plant,
    report: &mut Report,
) -> Result<()> {
    let shared = std::rc::Rc::new(std::cell::RefCell::new(plant));
    inline_shared(setup, ctrl, node, shared, report)
}

/// [`inline`] on a plant the controller may read too.
fn inline_shared<C: Control + ?Sized, S: Suite>(
    setup: &mut Setup<S>,
    ctrl: Box<C>,
    node: Option<ControllerNode>,
    plant: SharedPlant,
    report: &mut Report,
) -> Result<()> {
    let spec = setup.spec();
    let mode = if spec.bus.fd {
        BusMode::Fd
    } else {
        BusMode::Classic
    };
    let node = node.unwrap_or_else(|| ControllerNode::new(node_config(spec)));
    let seeds = crate::seeds::Seeds::of(spec.seed);
    let bus = SimulatedBus::with_node(mode, seeds.faults, spec.bus.faults, ctrl, node);
    let clock = bus.clock();
    let bus = setup.drive(bus, std::rc::Rc::new(clock), plant, report)?;
    report.bus_stats.injected = Some(injected(&bus.bus_stats()));
    let n = bus.node_stats();
    report.bus_stats.controller = Some(counts([
        ("retries", n.retries),
        ("corrected_commands", n.corrected_commands),
        ("repeated_targets", n.repeated_targets),
        ("stale_answers", n.stale_answers),
        ("frame_errors", n.frame_errors),
        ("aborted", n.aborted),
    ]));
    Ok(())
}

/// The session on a bus this process does not deliver (SocketCAN, SLCAN, QEMU) on the wall
/// clock, the host's port behind the fault layer: `--faults` (none: every frame passes,
/// and no decision is drawn) on what the host sends and what it receives, seeded like the
/// in-process bus's injector.
fn drive_wall<P, S: Suite>(
    setup: &mut Setup<S>,
    port: P,
    plant: Plant,
    report: &mut Report,
) -> Result<()>
where
    P: embedded_can::blocking::Can<Frame = trn_protocol::CanFrame, Error = trn_protocol::Error>
        + trn_protocol::bus::ReceiveTimeout
        + crate::ports::ControllerPort,
{
    let spec = setup.spec();
    let given = spec.bus.faults;
    let seed = crate::seeds::Seeds::of(spec.seed).faults;
    let port = FaultyPort::new(port, given.unwrap_or_default(), seed);
    let port = setup.drive_wall(port, plant, report)?;
    if given.is_some() {
        let (out, incoming) = port.stats();
        report.bus_stats.injected = Some(injected(&sum(out, incoming)));
    }
    Ok(())
}

/// Two directions' counters as one, as the in-process bus counts its copies.
fn sum(a: BusStats, b: BusStats) -> BusStats {
    BusStats {
        sent: a.sent + b.sent,
        delivered: a.delivered + b.delivered,
        dropped: a.dropped + b.dropped,
        duplicated: a.duplicated + b.duplicated,
        corrupted: a.corrupted + b.corrupted,
        truncated: a.truncated + b.truncated,
        delayed: a.delayed + b.delayed,
    }
}

/// The in-process controller node's settings: the host's, in protocol version 3 for the
/// test suite's fixture of an old controller.
fn node_config(spec: &RunSpec) -> trn_node::NodeConfig {
    if spec.inline_v3 {
        trn_node::NodeConfig::HOST_V3
    } else {
        trn_node::NodeConfig::HOST
    }
}

#[cfg(target_os = "linux")]
fn socketcan(iface: &str, bus: &str) -> Result<trn_protocol::bus::SocketCanPort> {
    trn_protocol::bus::SocketCanPort::open(iface)
        .map_err(|e| TransportError::open(bus, e.to_string()).into())
}

#[cfg(not(target_os = "linux"))]
fn socketcan(_: &str, bus: &str) -> Result<trn_protocol::bus::SocketCanPort> {
    Err(TransportError::open(bus, "SocketCAN needs Linux").into())
}

/// The fault injector's counters for the report.
fn injected(s: &BusStats) -> std::collections::BTreeMap<String, u64> {
    counts([
        ("sent", s.sent),
        ("delivered", s.delivered),
        ("dropped", s.dropped),
        ("duplicated", s.duplicated),
        ("corrupted", s.corrupted),
        ("truncated", s.truncated),
        ("delayed", s.delayed),
    ])
}

/// Named counters for the report.
fn counts<T, const N: usize>(pairs: [(&str, T); N]) -> std::collections::BTreeMap<String, T> {
    pairs.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
}

/// A run of `spec` with nothing watching it.
pub fn run_quietly(spec: &RunSpec) -> Result<Report> {
    run(spec, &mut crate::observe::Unobserved)
}
