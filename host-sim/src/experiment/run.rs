//! `trn train`, `trn eval`, `trn grasp`: a controller node and the simulator nodes on one
//! bus, a schedule of trials, and the report.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command as Proc};
use std::time::{Duration, Instant};

use trn_controller::{checkpoint, Config, Controller};
use trn_protocol::bus::{InProcBus, RecordingPort};
use trn_protocol::{BusMode, Mode};

use super::cli::{Ablation, Common, Preset};
use super::controller_loop::ControllerThread;
use super::report::{combined, mean, EvalSummary, GraspSummary, Report, TrialPoint};
use super::session::{RunError, Session, TrialKind, TrialRecord};
use crate::plant::{Plant, SimConfig};

/// Errors of a run, each with a message a user can act on.
#[derive(Debug, thiserror::Error)]
pub enum AppError {
    /// Reading or writing a file.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What happened.
        source: std::io::Error,
    },
    /// The simulator configuration.
    #[error("simulator config: {0}")]
    Sim(#[from] crate::plant::SimError),
    /// A checkpoint.
    #[error("checkpoint {path}: {source}")]
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: trn_controller::Error,
    },
    /// The session on the bus.
    #[error(transparent)]
    Run(#[from] RunError),
    /// The bus could not be opened.
    #[error("bus {bus}: {msg}")]
    Bus {
        /// The `--bus` argument.
        bus: String,
        /// What is wrong.
        msg: String,
    },
    /// Plotting.
    #[cfg(feature = "plot")]
    #[error(transparent)]
    Plot(#[from] super::plot::PlotError),
    /// `--plot` in a build without the `plot` feature.
    #[error("this build has no plotting (feature `plot`): drop --plot")]
    NoPlot,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> AppError + '_ {
    move |source| AppError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// The controller configuration for a preset and an ablation, with the initial weights
/// spread over the cameras' images.
pub fn controller_config(preset: Preset, ablation: Ablation, sim: &SimConfig) -> Config {
    let mut cfg = match preset {
        Preset::Project => Config::project_default(),
        Preset::Paper => Config::paper(),
        Preset::Lifelong => Config::lifelong(),
    };
    let (w, h) = sim.image_size();
    for s in [&mut cfg.stage1, &mut cfg.stage2] {
        s.init.x = (0.0, w as f32);
        s.init.y = (0.0, h as f32);
        s.input_min = -(w.max(h) as f32);
        s.input_max = 2.0 * w.max(h) as f32;
    }
    match ablation {
        Ablation::None => {}
        Ablation::NoNeighbourhood => {
            // only the closest neuron answers and learns: a plain VQ look-up table
            for s in [&mut cfg.stage1, &mut cfg.stage2] {
                s.alpha_range = 1e-3;
                s.sigma = 1e-3;
                s.sigma_start = 1e-3;
            }
        }
        Ablation::NoPriming => cfg.supervised_steps = 0,
        Ablation::NoFine => {
            cfg.stage1.max_fine_moves = 0;
            cfg.stage2.max_fine_moves = 0;
        }
    }
    cfg
}

/// Loads the simulator configuration (defaults when no file is given).
pub fn load_sim_config(path: Option<&Path>) -> Result<SimConfig, AppError> {
    match path {
        None => Ok(SimConfig::default()),
        Some(p) => Ok(SimConfig::load(p)?),
    }
}

/// Reads and verifies a checkpoint into `ctrl`.
pub fn load_checkpoint(ctrl: &mut Controller, path: &Path) -> Result<(), AppError> {
    let bytes = fs::read(path).map_err(io(path))?;
    checkpoint::restore(ctrl, &bytes).map_err(|source| AppError::Checkpoint {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(())
}

/// Writes a checkpoint atomically: a temporary file beside the target, then a rename, so an
/// interrupted run never leaves a torn checkpoint.
pub fn save_checkpoint(ctrl: &Controller, path: &Path) -> Result<(), AppError> {
    let mut buf = vec![0u8; checkpoint::MAX_SIZE];
    let n = checkpoint::save(ctrl, &mut buf).map_err(|source| AppError::Checkpoint {
        path: path.to_path_buf(),
        source,
    })?;
    let tmp = path.with_extension("tmp");
    fs::write(&tmp, &buf[..n]).map_err(io(&tmp))?;
    fs::rename(&tmp, path).map_err(io(path))?;
    Ok(())
}

/// The schedule of a run.
#[derive(Debug, Clone, Copy)]
pub struct Plan {
    /// Training trials per network (0: no training).
    pub trials: usize,
    /// Held-out targets per network.
    pub eval_targets: usize,
    /// Grasps.
    pub grasps: usize,
}

/// The controller on the other end of the bus.
enum Peer {
    Thread(ControllerThread),
    Process(Child),
}

/// The `controller-node` executable: `$TRN_CONTROLLER_NODE`, else beside this executable
/// (or one directory up, for test executables in `target/*/deps`).
fn controller_node_exe() -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os("TRN_CONTROLLER_NODE") {
        return Ok(PathBuf::from(p));
    }
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    let beside = me.with_file_name("controller-node");
    let up = me
        .parent()
        .and_then(|d| d.parent())
        .map(|d| d.join("controller-node"));
    match (beside.exists(), up) {
        (true, _) => Ok(beside),
        (false, Some(up)) if up.exists() => Ok(up),
        _ => Err(format!(
            "{} not found: build it with `cargo build --release -p trn-sim --bins` or set TRN_CONTROLLER_NODE",
            beside.display()
        )),
    }
}

/// Runs a plan: training (if `plan.trials > 0`), held-out evaluation, grasps.
pub fn run_plan(
    common: &Common,
    plan: Plan,
    checkpoint_in: Option<&Path>,
    checkpoint_out: Option<&Path>,
    command: &str,
) -> Result<Report, AppError> {
    let sim_cfg = load_sim_config(common.config.as_deref())?;
    let cfg = controller_config(common.preset, common.ablation, &sim_cfg);
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
) -> Result<Report, AppError> {
    let started = Instant::now();
    let sim_cfg = load_sim_config(common.config.as_deref())?;
    let plant = Plant::new(&sim_cfg, common.seed)?;
    let mode = if common.fd {
        BusMode::Fd
    } else {
        BusMode::Classic
    };
    let silence = Duration::from_secs_f64(common.bus_timeout_s);

    let mut report = Report {
        command: command.to_string(),
        preset: format!(
            "{:?}{}",
            common.preset,
            match common.ablation {
                Ablation::None => String::new(),
                a => format!("+{a:?}"),
            }
        )
        .to_lowercase(),
        trials: plan.trials,
        seed: common.seed,
        bus: common.bus.clone(),
        ..Default::default()
    };

    if common.bus == "inproc" {
        let bus = InProcBus::new(mode, common.seed);
        let mut ctrl = Box::new(Controller::new(cfg));
        ctrl.init_random(common.seed);
        if let Some(p) = checkpoint_in {
            load_checkpoint(&mut ctrl, p)?;
        }
        let peer = Peer::Thread(ControllerThread::spawn(bus.port(), ctrl, mode));
        let port = bus.port();
        drive(
            common,
            plan,
            &cfg,
            port,
            plant,
            mode,
            silence,
            peer,
            checkpoint_out,
            &mut report,
        )?;
    } else if common.bus == "slcan:qemu" {
        // processor-in-the-loop: the controller is the firmware in QEMU, seeded with 1 and
        // configured as the host's project preset (firmware/src/main.rs)
        if common.seed != 1
            || common.preset != Preset::Project
            || common.ablation != Ablation::None
            || common.fd
        {
            return Err(AppError::Bus {
                bus: common.bus.clone(),
                msg: "the firmware runs the project preset seeded with 1 on CAN 2.0: use --seed 1, no --preset/--ablation/--fd".into(),
            });
        }
        let bus_err = |msg: String| AppError::Bus {
            bus: common.bus.clone(),
            msg,
        };
        let (port, child) = super::slcan_bus::SlcanPort::spawn_qemu(
            &super::slcan_bus::qemu_arm(),
            &super::slcan_bus::firmware_elf(),
        )
        .map_err(bus_err)?;
        drive(
            common,
            plan,
            &cfg,
            port,
            plant,
            mode,
            silence,
            Peer::Process(child),
            None,
            &mut report,
        )?;
    } else if let Some(iface) = common.bus.strip_prefix("socketcan:") {
        open_socketcan(
            common,
            plan,
            &cfg,
            iface,
            plant,
            mode,
            silence,
            checkpoint_in,
            checkpoint_out,
            &mut report,
        )?;
    } else {
        return Err(AppError::Bus {
            bus: common.bus.clone(),
            msg: "expected `inproc`, `socketcan:IFACE` or `slcan:qemu`".into(),
        });
    }
    report.wall_s = started.elapsed().as_secs_f64();
    if let Some(p) = &common.report {
        let json = serde_json::to_string_pretty(&report).map_err(|e| AppError::Io {
            path: p.clone(),
            source: e.into(),
        })?;
        fs::write(p, json).map_err(io(p))?;
    }
    if let Some(p) = &common.plot {
        #[cfg(feature = "plot")]
        super::plot::learning_curves(&report, p)?;
        #[cfg(not(feature = "plot"))]
        {
            let _ = p;
            return Err(AppError::NoPlot);
        }
    }
    Ok(report)
}

#[cfg(target_os = "linux")]
#[allow(clippy::too_many_arguments)]
fn open_socketcan(
    common: &Common,
    plan: Plan,
    cfg: &Config,
    iface: &str,
    plant: Plant,
    mode: BusMode,
    silence: Duration,
    checkpoint_in: Option<&Path>,
    checkpoint_out: Option<&Path>,
    report: &mut Report,
) -> Result<(), AppError> {
    let bus_err = |msg: String| AppError::Bus {
        bus: common.bus.clone(),
        msg,
    };
    let port = trn_protocol::bus::SocketCanPort::open(iface).map_err(|e| bus_err(e.to_string()))?;
    let exe = controller_node_exe().map_err(bus_err)?;
    let mut cmd = Proc::new(exe);
    cmd.arg("--iface")
        .arg(iface)
        .arg("--seed")
        .arg(common.seed.to_string());
    cmd.arg("--preset")
        .arg(format!("{:?}", common.preset).to_lowercase());
    cmd.arg("--ablation").arg(
        clap::ValueEnum::to_possible_value(&common.ablation)
            .map(|v| v.get_name().to_string())
            .unwrap_or_default(),
    );
    if let Some(c) = &common.config {
        cmd.arg("--config").arg(c);
    }
    if common.fd {
        cmd.arg("--fd");
    }
    if let Some(p) = checkpoint_in {
        cmd.arg("--checkpoint-in").arg(p);
    }
    if let Some(p) = checkpoint_out {
        cmd.arg("--checkpoint-out").arg(p);
    }
    let child = cmd
        .spawn()
        .map_err(|e| bus_err(format!("cannot start controller-node: {e}")))?;
    // give the node time to open its socket before the first target
    std::thread::sleep(Duration::from_millis(300));
    drive(
        common,
        plan,
        cfg,
        port,
        plant,
        mode,
        silence,
        Peer::Process(child),
        None,
        report,
    )
}

#[cfg(not(target_os = "linux"))]
#[allow(clippy::too_many_arguments)]
fn open_socketcan(
    common: &Common,
    _: Plan,
    _: &Config,
    _: &str,
    _: Plant,
    _: BusMode,
    _: Duration,
    _: Option<&Path>,
    _: Option<&Path>,
    _: &mut Report,
) -> Result<(), AppError> {
    Err(AppError::Bus {
        bus: common.bus.clone(),
        msg: "SocketCAN needs Linux".into(),
    })
}

#[allow(clippy::too_many_arguments)]
fn drive<P>(
    common: &Common,
    plan: Plan,
    cfg: &Config,
    port: P,
    plant: Plant,
    mode: BusMode,
    silence: Duration,
    peer: Peer,
    checkpoint_out: Option<&Path>,
    report: &mut Report,
) -> Result<(), AppError>
where
    P: embedded_can::blocking::Can<Frame = trn_protocol::CanFrame, Error = trn_protocol::Error>
        + trn_protocol::bus::ReceiveTimeout,
{
    let outcome = match &common.candump {
        Some(path) => {
            let file = fs::File::create(path).map_err(io(path))?;
            let start = Instant::now();
            let iface = common
                .bus
                .strip_prefix("socketcan:")
                .unwrap_or("inproc0")
                .to_string();
            let clock = move || 1_700_000_000_000_000u64 + start.elapsed().as_micros() as u64;
            let rec = RecordingPort::new(port, std::io::BufWriter::new(file), &iface, clock);
            let mut s = Session::new(rec, plant, mode, common.seed, silence);
            s.set_heartbeat(heartbeat_for(&common.bus));
            schedule(&mut s, common, plan, cfg, report)
        }
        None => {
            let mut s = Session::new(port, plant, mode, common.seed, silence);
            s.set_heartbeat(heartbeat_for(&common.bus));
            schedule(&mut s, common, plan, cfg, report)
        }
    };
    // the session ended (well or not): stop the controller and collect it
    match peer {
        Peer::Thread(t) => {
            if outcome.is_ok() {
                let (ctrl, _stats) = t.join().map_err(|e| AppError::Bus {
                    bus: common.bus.clone(),
                    msg: e.to_string(),
                })?;
                if let Some(p) = checkpoint_out {
                    save_checkpoint(&ctrl, p)?;
                }
            }
        }
        Peer::Process(mut child) => {
            let deadline = Instant::now() + Duration::from_secs(10);
            loop {
                match child.try_wait() {
                    Ok(Some(status)) if status.success() || outcome.is_err() => break,
                    Ok(Some(status)) => {
                        return Err(AppError::Bus {
                            bus: common.bus.clone(),
                            msg: format!("controller-node exited with {status}"),
                        })
                    }
                    Ok(None) if Instant::now() < deadline && outcome.is_ok() => {
                        std::thread::sleep(Duration::from_millis(20))
                    }
                    _ => {
                        let _ = child.kill();
                        let _ = child.wait();
                        break;
                    }
                }
            }
        }
    }
    outcome
}

fn schedule<P>(
    s: &mut Session<P>,
    common: &Common,
    plan: Plan,
    cfg: &Config,
    report: &mut Report,
) -> Result<(), AppError>
where
    P: embedded_can::blocking::Can<Frame = trn_protocol::CanFrame, Error = trn_protocol::Error>
        + trn_protocol::bus::ReceiveTimeout,
{
    let total = (plan.trials * 2 + plan.eval_targets * 2 + plan.grasps) as u64;
    let bar = if common.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        let b = indicatif::ProgressBar::new(total);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{prefix:>9} [{bar:40}] {pos}/{len} trials {msg}",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    };
    let mut cap_hits = 0usize;
    // training: stage 1 and stage 2 alternate, one trial each per step
    if plan.trials > 0 {
        s.mode(Mode::Priming)?;
        bar.set_prefix("training");
    }
    for i in 0..plan.trials {
        let supervised = (i as u32) < cfg.supervised_steps;
        if i as u32 == cfg.supervised_steps {
            s.mode(Mode::Training)?;
        }
        let r1 = s.run_trial(TrialKind::Stage1 {
            supervised,
            learn: true,
        })?;
        let r2 = s.run_trial(TrialKind::Stage2 { learn: true })?;
        let p = point(&r1, &r2);
        cap_hits += caps(&r1) + caps(&r2);
        report.aborted_trials += aborted(&r1) + aborted(&r2);
        report.push_trial(&p);
        bar.inc(2);
        if i % 10 == 9 {
            let n = report.combined_error_px.len();
            let recent = mean(&report.combined_error_px[n.saturating_sub(20)..]);
            bar.set_message(format!("combined error (last 20) {recent:.2} px"));
        }
    }
    s.mode(Mode::Mature)?;
    bar.set_prefix("eval");
    let mut eval = EvalSummary {
        targets: plan.eval_targets,
        ..Default::default()
    };
    let (mut e1, mut e2, mut t1, mut t2, mut m1, mut m2, mut mm, mut deg) = (
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
        vec![],
    );
    let mut by_move1: Vec<Vec<f32>> = vec![];
    let mut by_move2: Vec<Vec<f32>> = vec![];
    let mut noise = vec![];
    for _ in 0..plan.eval_targets {
        let r1 = s.run_trial(TrialKind::Stage1 {
            supervised: false,
            learn: false,
        })?;
        let r2 = s.run_trial(TrialKind::Stage2 { learn: false })?;
        cap_hits += caps(&r1) + caps(&r2);
        eval.cap_hits += caps(&r1) + caps(&r2);
        report.aborted_trials += aborted(&r1) + aborted(&r2);
        if let (Some(a), Some(b)) = (r1.stage1.as_ref(), r2.stage2.as_ref()) {
            e1.push(*a.errors_px.last().unwrap_or(&f32::NAN));
            t1.push(*a.errors_true_px.last().unwrap_or(&f32::NAN));
            e2.push(*b.errors_px.last().unwrap_or(&f32::NAN));
            t2.push(*b.errors_true_px.last().unwrap_or(&f32::NAN));
            m1.push(a.errors_px.len().saturating_sub(1) as f32);
            m2.push(b.errors_px.len().saturating_sub(1) as f32);
            mm.push(a.pose_error_mm);
            deg.push(a.pose_error_deg);
            noise.push(combined(a.noise_floor_px, b.noise_floor_px));
            accumulate(&mut by_move1, &a.errors_px);
            accumulate(&mut by_move2, &b.errors_px);
        }
        bar.inc(2);
    }
    eval.stage1_final_px = mean(&e1);
    eval.stage2_final_px = mean(&e2);
    eval.stage1_final_true_px = mean(&t1);
    eval.stage2_final_true_px = mean(&t2);
    eval.stage1_fine_moves = mean(&m1);
    eval.stage2_fine_moves = mean(&m2);
    eval.stage1_error_mm = mean(&mm);
    eval.stage1_error_deg = mean(&deg);
    eval.stage1_error_by_move_px = by_move_means(&by_move1);
    eval.stage2_error_by_move_px = by_move_means(&by_move2);
    let combined_eval: Vec<f32> = e1.iter().zip(&e2).map(|(a, b)| combined(*a, *b)).collect();
    let combined_true: Vec<f32> = t1.iter().zip(&t2).map(|(a, b)| combined(*a, *b)).collect();
    report.final_error_px = mean(&combined_eval);
    report.final_error_true_px = mean(&combined_true);
    report.noise_floor_px = mean(&noise);
    report.fine_moves_mean = (mean(&m1) + mean(&m2)) / 2.0;
    report.eval = eval;

    bar.set_prefix("grasp");
    let mut g = GraspSummary {
        grasps: plan.grasps,
        ..Default::default()
    };
    let (mut ok, mut gc, mut gct, mut gmm, mut gdeg, mut gmoves) =
        (0usize, vec![], vec![], vec![], vec![], vec![]);
    for _ in 0..plan.grasps {
        let r = s.run_trial(TrialKind::Grasp { learn: false })?;
        cap_hits += caps(&r);
        report.aborted_trials += aborted(&r);
        if let (Some(a), Some(b)) = (r.stage1.as_ref(), r.stage2.as_ref()) {
            if let (Some(x), Some(y)) = (a.errors_px.last(), b.errors_px.last()) {
                gc.push(combined(*x, *y));
            }
            if let (Some(x), Some(y)) = (a.errors_true_px.last(), b.errors_true_px.last()) {
                gct.push(combined(*x, *y));
            }
            gmoves.push((a.errors_px.len() + b.errors_px.len()).saturating_sub(2) as f32);
        }
        if let Some(score) = r.grasp {
            gmm.push(score.distance_mm as f32);
            gdeg.push(score.perpendicular_error_deg as f32);
            ok += score.success as usize;
        }
        bar.inc(1);
    }
    g.success_rate = if plan.grasps > 0 {
        ok as f32 / plan.grasps as f32
    } else {
        0.0
    };
    g.combined_error_px = mean(&gc);
    g.combined_error_true_px = mean(&gct);
    g.error_mm = mean(&gmm);
    g.error_deg = mean(&gdeg);
    g.fine_moves = mean(&gmoves);
    report.grasp_success_rate = g.success_rate;
    report.error_mm = g.error_mm;
    report.error_deg = g.error_deg;
    report.grasp = g;
    report.correction_cap_hits = cap_hits;
    bar.finish_and_clear();
    s.finish()?;
    Ok(())
}

/// The servo drives' heartbeat supervision for a bus. The firmware in QEMU keeps time by
/// executed instructions (`-icount`), which runs several times slower than the wall clock the
/// simulator's drives use: its 100 ms heartbeats arrive about every second of wall time, so
/// the drives allow 30 s there instead of 500 ms.
fn heartbeat_for(bus: &str) -> trn_protocol::HeartbeatConfig {
    let mut hb = trn_protocol::HeartbeatConfig::default();
    if bus.starts_with("slcan:") {
        hb.timeout_ms = 30_000;
    }
    hb
}

fn aborted(r: &TrialRecord) -> usize {
    r.aborted as usize
}

fn caps(r: &TrialRecord) -> usize {
    [r.stage1.as_ref(), r.stage2.as_ref()]
        .iter()
        .flatten()
        .filter(|s| s.report.map(|r| r.cap_hit).unwrap_or(false))
        .count()
}

/// Collects one trial's errors by move; [`by_move_means`] pads them.
fn accumulate(by_move: &mut Vec<Vec<f32>>, errors: &[f32]) {
    by_move.push(errors.to_vec());
}

/// Mean error after the coarse move and after each fine move over all trials; a trial that
/// stopped earlier keeps its last error (the arm stays where it is).
fn by_move_means(trials: &[Vec<f32>]) -> Vec<f32> {
    let longest = trials.iter().map(Vec::len).max().unwrap_or(0);
    (0..longest)
        .map(|i| {
            let col: Vec<f32> = trials
                .iter()
                .filter_map(|t| t.get(i).or(t.last()).copied())
                .collect();
            mean(&col)
        })
        .collect()
}

fn point(r1: &TrialRecord, r2: &TrialRecord) -> TrialPoint {
    let last = |r: Option<&super::session::StageRecord>| {
        r.and_then(|s| s.errors_px.last().copied())
            .unwrap_or(f32::NAN)
    };
    let moves = |r: Option<&super::session::StageRecord>| {
        r.and_then(|s| s.report)
            .map(|rep| rep.fine_moves)
            .unwrap_or(0)
    };
    TrialPoint {
        stage1_px: last(r1.stage1.as_ref()),
        stage2_px: last(r2.stage2.as_ref()),
        stage1_coarse_px: r1
            .stage1
            .as_ref()
            .and_then(|s| s.errors_px.first().copied())
            .unwrap_or(f32::NAN),
        stage1_fine_moves: moves(r1.stage1.as_ref()),
        stage2_fine_moves: moves(r2.stage2.as_ref()),
    }
}
