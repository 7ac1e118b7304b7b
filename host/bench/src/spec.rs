//! One run's specification ([`RunSpec`]): everything that decides what a run does, with the
//! project's defaults in one place, built once (from the command line, a study, a test or a
//! Python call), checked once ([`RunSpec::check`]) and written into the run's report.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};
use trn_controller::presets::{Ablation, ImageSize, Preset};
use trn_controller::{Config, Law};
use trn_plant::SimConfig;
use trn_protocol::bus::FaultConfig;
use trn_protocol::SessionConfig;
use trn_transport::BusSpec;

use crate::error::{LabError, Result};

/// How many trials of each kind a run has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Plan {
    /// Training trials per network (0: no training).
    pub trials: usize,
    /// Held-out targets per network.
    pub eval_targets: usize,
    /// Grasps.
    pub grasps: usize,
    /// The fixed budget of fine moves of the held-out evaluation (after the coarse move).
    pub fine_moves: u8,
    /// A frozen snapshot evaluation every this many training trials (0: none).
    pub snapshot_every: usize,
    /// Held-out targets per network in a snapshot (the first of the held-out set).
    pub snapshot_targets: usize,
    /// Grasps in a snapshot (the first of the held-out grasps; 0: none).
    pub snapshot_grasps: usize,
    /// Learning stops after this many training trials per network (the tables frozen, mode
    /// `Mature`); the remaining training trials still move the arm, so drift and wear go on
    /// as in a run that keeps learning. `None`: learning throughout.
    pub learn_trials: Option<usize>,
    /// Training trials per network learned before this run (a checkpoint's): the schedule
    /// (priming, snapshots, `learn_trials`) continues from there.
    pub first_trial: usize,
    /// Continue the simulation of the run that wrote the checkpoint (its `.sim` file,
    /// [`crate::sim_state::SimState`]): the same plant, training targets and held-out sets.
    pub resume: bool,
}

impl Plan {
    /// A plan with the default evaluation: 6 fine moves, a snapshot of 50 targets every 25
    /// training trials.
    pub const fn new(trials: usize, eval_targets: usize, grasps: usize) -> Plan {
        Plan {
            trials,
            eval_targets,
            grasps,
            fine_moves: 6,
            snapshot_every: 25,
            snapshot_targets: 50,
            snapshot_grasps: 0,
            learn_trials: None,
            first_trial: 0,
            resume: false,
        }
    }

    /// Trials on the bus in all (for the progress bar).
    pub fn total(&self) -> usize {
        let snapshots = self.trials.checked_div(self.snapshot_every).unwrap_or(0);
        let per_snapshot = 2 * self.snapshot_targets.min(self.eval_targets)
            + self.snapshot_grasps.min(self.grasps);
        self.trials * 2 + snapshots * per_snapshot + self.eval_targets * 6 + self.grasps
    }
}

trn_controller::wire_enum! {
    /// The controller a run drives: one of the core's laws ([`Law`]), or a host-side one that
    /// carries the simulator and runs in process only. Its code is the session's law byte
    /// (SPEC.md 3.2; the host-side codes are [`Law::HOST_CODES`]).
    #[derive(Default)]
    pub enum ControllerChoice {
        /// The topology representing network ([`Law::Trn`]).
        #[default]
        Trn = 0 => "trn",
        /// The Broyden servo baseline ([`Law::Broyden`]).
        Broyden = 1 => "broyden",
        /// The model-based reference: the simulator's nominal inverse kinematics
        /// ([`trn_references::NominalIk`]).
        Model = 2 => "model",
        /// The physical limit: it solves on an exact copy of the simulated plant
        /// ([`trn_references::Oracle`]).
        Oracle = 3 => "oracle",
    }
}

impl ControllerChoice {
    /// The core's law this is, if it is one.
    pub const fn core(self) -> Option<Law> {
        match self {
            ControllerChoice::Trn => Some(Law::Trn),
            ControllerChoice::Broyden => Some(Law::Broyden),
            ControllerChoice::Model | ControllerChoice::Oracle => None,
        }
    }

    /// True for a host-side controller (the model-based reference, the oracle): in process
    /// only.
    pub const fn host_only(self) -> bool {
        self.core().is_none()
    }
}

impl From<Law> for ControllerChoice {
    fn from(law: Law) -> ControllerChoice {
        match law {
            Law::Trn => ControllerChoice::Trn,
            Law::Broyden => ControllerChoice::Broyden,
        }
    }
}

/// What the controller is told to be: the fields of the session's `SessionConfig` besides
/// the seed and the bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Profile {
    /// The named configuration.
    pub preset: Preset,
    /// What is left out of the method.
    pub ablation: Ablation,
    /// The control law: the core's, or a host-side controller.
    pub law: ControllerChoice,
}

impl Profile {
    /// The project's defaults: the project preset, the full method, the TRN.
    pub const DEFAULT: Profile = Profile {
        preset: Preset::Project,
        ablation: Ablation::None,
        law: ControllerChoice::Trn,
    };

    /// The controller configuration of this profile for cameras of `image` size (the one
    /// place the host builds it): the core's [`trn_controller::presets::Profile::config`];
    /// a host-side controller's is the TRN's (it uses the stop rule).
    pub fn config(&self, image: ImageSize) -> Config {
        trn_controller::presets::Profile {
            preset: self.preset,
            ablation: self.ablation,
            law: self.law.core().unwrap_or(Law::Trn),
        }
        .config(image)
    }

    /// The fingerprint a controller of this profile announces for `cfg` (SPEC.md 3.2.1):
    /// a host-side controller's is taken with its law code.
    pub fn fingerprint_of(&self, cfg: &Config) -> u32 {
        match self.law.core() {
            Some(_) => cfg.fingerprint(),
            None => cfg.fingerprint_as(self.law.code()),
        }
    }

    /// A label for tables and reports: the law when it is not the TRN, else the preset and
    /// the ablation.
    pub fn label(&self) -> String {
        match (self.law, self.ablation) {
            (ControllerChoice::Trn, Ablation::None) => self.preset.name().to_string(),
            (ControllerChoice::Trn, a) => format!("{}+{}", self.preset.name(), a.name()),
            (law, _) => law.name().to_string(),
        }
    }
}

/// A run's controller configuration ([`RunSpec::controller`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunConfig {
    /// The profile's configuration (a checkpoint's header is checked against it).
    pub profile: Config,
    /// The run's: the override, else the profile's.
    pub run: Config,
    /// The fingerprint the run's controller announces for it (SPEC.md 3.2.1).
    pub fingerprint: u32,
    /// The profile describes the run's configuration (no override, or one that is the
    /// profile's): the run parameters then go to the controller over the bus; a tuning
    /// configuration is given to the in-process controller directly.
    pub described: bool,
}

/// The bus of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BusChoice {
    /// The transport.
    pub spec: BusSpec,
    /// The controller runs elsewhere on the bus (a board): none is started.
    pub external_controller: bool,
    /// Long messages as CAN FD frames instead of CAN 2.0 segments.
    pub fd: bool,
    /// Faults injected on the in-process bus, seeded by the run's seed.
    pub faults: Option<FaultConfig>,
    /// Seconds without a frame from the controller before the run fails.
    pub timeout_s: f64,
    /// The CAN bit rate a serial adapter is started with (bit/s).
    pub bitrate: u32,
}

/// The seconds of silence a run may be given before it fails "bus silent": from five of the
/// controller's heartbeats (one every 0.1 s, SPEC.md 3) to an hour. Shorter would fail a
/// healthy controller between two heartbeats; `1e-300` once passed and failed at once.
pub const BUS_TIMEOUT_S: core::ops::RangeInclusive<f64> = 0.5..=3600.0;

/// `seconds` as the bus's silence timeout: within [`BUS_TIMEOUT_S`], or what it must be
/// (the option's name is the caller's to add).
pub fn check_bus_timeout(seconds: f64) -> core::result::Result<(), String> {
    if BUS_TIMEOUT_S.contains(&seconds) {
        Ok(())
    } else {
        Err(format!(
            "a duration in [{}, {}] seconds (the controller's heartbeat comes every 0.1 s)",
            BUS_TIMEOUT_S.start(),
            BUS_TIMEOUT_S.end()
        ))
    }
}

impl Default for BusChoice {
    fn default() -> Self {
        BusChoice {
            spec: BusSpec::InProc,
            external_controller: false,
            fd: false,
            faults: None,
            timeout_s: 10.0,
            bitrate: 500_000,
        }
    }
}

/// Where a run writes (each checked before the run starts: see `crate::output`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Outputs {
    /// The JSON report.
    pub report: Option<PathBuf>,
    /// The learning curves (PNG or SVG; drawn by the command line).
    pub plot: Option<PathBuf>,
    /// A candump log of the bus.
    pub candump: Option<PathBuf>,
    /// One CSV row per trial.
    pub csv: Option<PathBuf>,
    /// The trained networks (and the simulator's state beside them, `NAME.sim`).
    pub checkpoint: Option<PathBuf>,
    /// A checkpoint every this many training trials per network as well (0: at the end).
    pub checkpoint_every: usize,
}

/// What a run does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Command {
    /// Train, then evaluate.
    Train,
    /// Evaluate a checkpoint (no learning).
    Eval,
    /// Grasps with a checkpoint.
    Grasp,
    /// The conformance suite against the controller on the bus.
    Conformance,
}

impl Command {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Command::Train => "train",
            Command::Eval => "eval",
            Command::Grasp => "grasp",
            Command::Conformance => "conformance",
        }
    }
}

/// Everything that decides a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSpec {
    /// What the run does.
    pub command: Command,
    /// Seed of the run: the plant, the targets, the initial tables, the faults.
    pub seed: u64,
    /// The controller's profile.
    pub profile: Profile,
    /// How the plant was named (`--config`: a built-in name or a file); `None`: the default
    /// realistic plant.
    pub plant_name: Option<String>,
    /// The plant's full configuration.
    pub plant: SimConfig,
    /// The bus.
    pub bus: BusChoice,
    /// The trials.
    pub plan: Plan,
    /// Start from this checkpoint.
    pub checkpoint_in: Option<PathBuf>,
    /// Use a checkpoint learned under another configuration (it is relabelled as learned
    /// under the run's before it is written in).
    pub allow_config_change: bool,
    /// The controller's learned tables may be erased or replaced (`--reset-tables`): a
    /// training run seeds new tables, or a checkpoint is written in, even over tables that
    /// learned.
    #[serde(default)]
    pub reset_tables: bool,
    /// Train the tables the controller holds instead of new ones (`--keep-tables`).
    #[serde(default)]
    pub keep_tables: bool,
    /// The controller's store as a file (`--tables`): in process, or for the
    /// `controller-node` the run starts; the tables it holds survive the run there.
    #[serde(default)]
    pub tables: Option<PathBuf>,
    /// Continuing a run (`plan.resume`): train for the trials the continued run had left
    /// (its `.sim` says how many it was planned for) instead of `plan.trials`.
    #[serde(default)]
    pub trials_left: bool,
    /// The files the run writes.
    pub outputs: Outputs,
    /// A controller configuration no profile describes (tuning, tests, a study's controller
    /// keys): given to the in-process controller directly instead of through the session
    /// configuration.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub controller_override: Option<Config>,
    /// The in-process controller node speaks protocol version 3 (`NodeConfig::HOST_V3`):
    /// the test suite's fixture of an old controller (no option of `trn`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub inline_v3: bool,
}

/// Counts above this are refused (a usage error): a run of that many trials would not fit
/// in memory (each trial's record is about a kilobyte) nor end in a lifetime.
pub const MAX_COUNT: usize = 10_000_000;

impl RunSpec {
    /// A run with the project's defaults: the realistic plant, the project preset on the
    /// in-process bus, 300 training trials, 100 held-out targets per network, 50 grasps.
    pub fn new(command: Command, seed: u64) -> RunSpec {
        RunSpec {
            command,
            seed,
            profile: Profile::DEFAULT,
            plant_name: None,
            plant: SimConfig::realistic(),
            bus: BusChoice::default(),
            plan: Plan::new(300, 100, 50),
            checkpoint_in: None,
            allow_config_change: false,
            reset_tables: false,
            keep_tables: false,
            tables: None,
            trials_left: false,
            outputs: Outputs::default(),
            controller_override: None,
            inline_v3: false,
        }
    }

    /// The plant named as `--config` names it (a built-in name or a TOML file).
    pub fn with_plant(mut self, name: Option<&str>) -> Result<RunSpec> {
        self.plant = SimConfig::resolve(name.map(std::path::Path::new))?;
        self.plant_name = name.map(str::to_string);
        Ok(self)
    }

    /// The cameras' image size, as the controller's initial weights span it.
    pub fn image(&self) -> ImageSize {
        let (w, h) = self.plant.image_size();
        ImageSize {
            width: w.min(u16::MAX as u32) as u16,
            height: h.min(u16::MAX as u32) as u16,
        }
    }

    /// The controller configuration the profile describes for this plant.
    pub fn profile_config(&self) -> Config {
        self.profile.config(self.image())
    }

    /// The controller configuration of the run: the override, else the profile's.
    pub fn controller_config(&self) -> Config {
        self.controller_override
            .unwrap_or_else(|| self.profile_config())
    }

    /// The run's controller configuration, built once: the profile's, the run's (the
    /// override, else the profile's), the fingerprint it is announced under, and whether the
    /// profile describes it.
    pub fn controller(&self) -> RunConfig {
        let profile = self.profile_config();
        let run = self.controller_override.unwrap_or(profile);
        let fingerprint = self.profile.fingerprint_of(&run);
        RunConfig {
            profile,
            run,
            fingerprint,
            described: fingerprint == self.profile.fingerprint_of(&profile),
        }
    }

    /// The session's run parameters for the controller (SPEC.md 3.2).
    pub fn session_config(&self, keep_tables: bool) -> SessionConfig {
        let image = self.image();
        SessionConfig {
            seed: crate::seeds::Seeds::of(self.seed).tables,
            preset: self.profile.preset as u8,
            ablation: self.profile.ablation as u8,
            image_width: image.width,
            image_height: image.height,
            fd: self.bus.fd,
            keep_tables,
            law: self.profile.law.code(),
        }
    }

    /// Refuses a specification that cannot run, before anything runs: options that
    /// contradict each other or the bus, counts beyond what a machine can hold.
    pub fn check(&self) -> Result<()> {
        let usage = |m: &str| Err(LabError::Usage(m.to_string()));
        let profile = self.bus.spec.profile(self.bus.external_controller);
        let checkpoints = self.checkpoint_in.is_some() || self.outputs.checkpoint.is_some();
        let plan = &self.plan;
        for (name, n) in [
            ("--trials", plan.trials),
            ("--eval-targets", plan.eval_targets),
            ("--grasps", plan.grasps),
            ("--snapshot-targets", plan.snapshot_targets),
            ("--snapshot-grasps", plan.snapshot_grasps),
        ] {
            if n > MAX_COUNT {
                return Err(LabError::Usage(format!(
                    "{name} {n} is more than this machine can hold (at most {MAX_COUNT})"
                )));
            }
        }
        if self.bus.external_controller && self.bus.spec == BusSpec::InProc {
            return usage("--external-controller needs a real bus (socketcan:IFACE or slcan:/dev/DEVICE): the in-process bus has no controller but its own");
        }
        if self.tables.is_some() && !profile.tables_file {
            return usage(match self.bus.spec {
                BusSpec::SlcanQemu => "the firmware keeps its tables in its own store: no --tables",
                _ => "an external controller keeps its tables in its own store: no --tables",
            });
        }
        if self.keep_tables && (self.reset_tables || self.checkpoint_in.is_some()) {
            return usage("--keep-tables trains the tables the controller holds: not with --reset-tables or --checkpoint-in");
        }
        if matches!(self.command, Command::Eval | Command::Grasp)
            && self.checkpoint_in.is_none()
            && !self.bus.external_controller
            && self.tables.is_none()
        {
            return usage("this needs the tables to run: --checkpoint-in CHECKPOINT, or a controller that holds them (--external-controller, --tables FILE)");
        }
        if self.profile.law.host_only()
            && (!profile.host_laws || checkpoints || self.tables.is_some())
        {
            return usage("the model-based reference and the oracle (--controller model, oracle) carry the simulator: in process only, no checkpoints or tables");
        }
        if self.controller_override.is_some()
            && (checkpoints || self.tables.is_some() || self.keep_tables)
        {
            return usage("a controller configuration no profile describes (tuning) takes no checkpoints or tables");
        }
        if self.inline_v3
            && (profile.controller != trn_transport::ControllerSite::Inline
                || self.controller_override.is_some())
        {
            return usage("a version-3 controller node runs in process only, configured over the bus (no tuning configuration)");
        }
        if plan.resume && self.checkpoint_in.is_none() {
            return usage("--continue needs --checkpoint-in");
        }
        if self.outputs.checkpoint_every > 0
            && (self.outputs.checkpoint.is_none()
                || profile.controller != trn_transport::ControllerSite::Inline)
        {
            return usage("--checkpoint-every needs --checkpoint-out and the in-process controller (a controller on a bus gives its tables at the end)");
        }
        if let Err(e) = check_bus_timeout(self.bus.timeout_s) {
            return usage(&format!("--bus-timeout-s is {e}"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The firmware configures its controller with `presets::configure` for
    /// `ImageSize::DEFAULT`; the host derives the image size from the simulator's cameras.
    /// If the default cameras change, the two would differ.
    #[test]
    fn host_and_firmware_build_the_same_default_controller() {
        let spec = RunSpec::new(Command::Train, 1);
        let firmware =
            trn_controller::presets::configure(Preset::Project, Ablation::None, ImageSize::DEFAULT);
        assert_eq!(spec.controller_config(), firmware);
    }

    /// The host's controller choice extends the core's laws with the host-side codes of
    /// the wire, under the same names; the host-side controllers' configuration is the
    /// TRN's, fingerprinted with their code.
    #[test]
    fn the_controller_choice_is_the_cores_laws_then_the_host_codes() {
        for &law in Law::ALL {
            let c = ControllerChoice::from(law);
            assert_eq!(
                (c.code(), c.name(), c.core()),
                (law.code(), law.name(), Some(law))
            );
        }
        let host: Vec<_> = ControllerChoice::ALL
            .iter()
            .filter(|c| c.host_only())
            .map(|c| (c.code(), c.name()))
            .collect();
        assert_eq!(host, Law::HOST_CODES);
        let image = ImageSize::DEFAULT;
        for (law, code) in [(ControllerChoice::Model, 2), (ControllerChoice::Oracle, 3)] {
            let p = Profile {
                law,
                ..Profile::DEFAULT
            };
            assert_eq!(p.config(image), Profile::DEFAULT.config(image));
            assert_eq!(
                p.fingerprint_of(&p.config(image)),
                p.config(image).fingerprint_as(code)
            );
            let mut s = RunSpec::new(Command::Train, 1);
            s.profile = p;
            assert!(s.controller().described);
            assert_eq!(
                s.controller().fingerprint,
                p.config(image).fingerprint_as(code)
            );
            assert_eq!(s.session_config(false).law, code);
        }
    }

    #[test]
    fn a_spec_survives_json_whole() {
        let mut spec = RunSpec::new(Command::Train, 7)
            .with_plant(Some("ideal"))
            .unwrap();
        spec.bus.faults = Some("drop=0.1".parse().unwrap());
        spec.profile.ablation = Ablation::NoFine;
        let json = serde_json::to_string(&spec).unwrap();
        let back: RunSpec = serde_json::from_str(&json).unwrap();
        assert_eq!(back, spec);
        assert!(json.contains("\"no-fine\""), "{json}");
    }

    #[test]
    fn contradictions_and_huge_counts_are_refused_before_anything_runs() {
        let ok = RunSpec::new(Command::Train, 1);
        assert!(ok.check().is_ok());
        let mut s = ok.clone();
        s.plan.eval_targets = usize::MAX;
        let e = s.check().unwrap_err().to_string();
        assert!(e.contains("--eval-targets") && e.contains("at most"), "{e}");
        // checkpoints travel over every bus now; a tables file only where this run starts
        // the controller
        let mut s = ok.clone();
        s.bus.spec = BusSpec::SlcanQemu;
        s.outputs.checkpoint = Some("x.ckpt".into());
        assert!(s.check().is_ok());
        s.tables = Some("t.bin".into());
        assert!(s.check().unwrap_err().to_string().contains("--tables"));
        let mut s = ok.clone();
        s.bus.spec = BusSpec::SocketCan("can0".into());
        s.bus.external_controller = true;
        s.command = Command::Eval;
        s.outputs.checkpoint = Some("x.ckpt".into());
        assert!(
            s.check().is_ok(),
            "an external controller's tables read out"
        );
        s.tables = Some("t.bin".into());
        assert!(s.check().unwrap_err().to_string().contains("--tables"));
        let mut s = ok.clone();
        s.command = Command::Eval;
        assert!(s
            .check()
            .unwrap_err()
            .to_string()
            .contains("--checkpoint-in"));
        s.tables = Some("t.bin".into());
        assert!(s.check().is_ok(), "the in-process controller's tables file");
        let mut s = ok.clone();
        s.keep_tables = true;
        s.reset_tables = true;
        assert!(s.check().unwrap_err().to_string().contains("--keep-tables"));
        // faults on a bus this process does not deliver: the host's port injects them
        let mut s = ok.clone();
        s.bus.spec = BusSpec::SocketCan("vcan0".into());
        s.bus.faults = Some(FaultConfig::default());
        assert!(s.check().is_ok(), "--faults on SocketCAN");
        let mut s = ok.clone();
        s.profile.law = ControllerChoice::Model;
        s.checkpoint_in = Some("x".into());
        assert!(s.check().unwrap_err().to_string().contains("model"));
        let mut s = ok.clone();
        s.bus.external_controller = true;
        assert!(s.check().unwrap_err().to_string().contains("external"));
        let mut s = ok;
        s.plan.resume = true;
        assert!(s.check().unwrap_err().to_string().contains("--continue"));
    }
}
