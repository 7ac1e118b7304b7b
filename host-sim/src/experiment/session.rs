//! The simulator's side of the bus: servo drive units, camera processor and gripper as CAN
//! nodes around one [`Plant`], and the experiment runner that places targets and scores.
//!
//! Everything between the controller and the plant crosses the bus: the runner announces a
//! target, the controller commands pressures and requests captures, the plant answers.

use std::time::{Duration, Instant};

use embedded_can::blocking::Can;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_node::codes;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::heartbeat::{HeartbeatConfig, HeartbeatEvent, HeartbeatMonitor, VENT_RAW};
use trn_protocol::{
    BusMode, CanFrame, CaptureKind, Encoder, Envelope, GraspRequest, GripperStatus, Message, Mode,
    ModeChange, NodeId, Observation, PixelPoint, PointStatus, Reassembler, SafeState, ServoStatus,
    Stage1Target, Stage2Target, SupervisedPressure, TrialReport,
};

use crate::plant::{self, Plant};

/// Errors of a session.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The controller sent nothing for too long.
    #[error("bus silent: no frame from the controller for {0:.1} s (is the controller node running on this bus?)")]
    BusSilent(f64),
    /// The transport failed.
    #[error("bus error: {0}")]
    Bus(#[from] trn_protocol::Error),
    /// The plant rejected something.
    #[error("plant: {0}")]
    Plant(#[from] plant::SimError),
    /// No valid target could be drawn (every pose hid a light).
    #[error("no valid target after {0} draws: the cameras do not see the workspace")]
    NoTarget(usize),
}

/// What kind of trial to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrialKind {
    /// Stage 1; `supervised` sends the target pressure (priming).
    Stage1 {
        /// Priming step.
        supervised: bool,
        /// Update the tables.
        learn: bool,
    },
    /// Stage 2.
    Stage2 {
        /// Update the tables.
        learn: bool,
    },
    /// A full grasp of a random cylinder.
    Grasp {
        /// Update the tables on the way.
        learn: bool,
    },
}

/// One stage of one trial, as the runner saw it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StageRecord {
    /// The controller's report.
    pub report: Option<TrialReport>,
    /// Error after the coarse move and after each fine move: noisy target vs noisy observation.
    pub errors_px: Vec<f32>,
    /// The same from noise-free projections.
    pub errors_true_px: Vec<f32>,
    /// What the camera noise alone gives at the target: |second noisy reading - target reading|.
    pub noise_floor_px: f32,
    /// Position error of the final pose against the target pose (mm); stage 1 only.
    pub pose_error_mm: f32,
    /// Orientation error of the final pose against the target pose (degrees); stage 1 only.
    pub pose_error_deg: f32,
}

/// One trial.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TrialRecord {
    /// Trial number on the bus.
    pub trial: u32,
    /// Stage 1, if it ran.
    pub stage1: Option<StageRecord>,
    /// Stage 2, if it ran.
    pub stage2: Option<StageRecord>,
    /// The controller aborted the trial (its reason is in `errors`).
    pub aborted: bool,
    /// `ErrorReport`s received during the trial (code, detail).
    pub errors: Vec<(u16, u32)>,
    /// Grasp score: distance gripper centre to cylinder centre (mm), deviation from
    /// perpendicular (degrees), and success.
    pub grasp: Option<plant::GraspScore>,
}

/// Counters of the session.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SessionStats {
    /// Frames received.
    pub frames_in: u64,
    /// Frames sent.
    pub frames_out: u64,
    /// Frames rejected by the reassembler (typed errors).
    pub frame_errors: u64,
    /// Moves (capture requests served).
    pub moves: u64,
    /// Heartbeats heard from the controller.
    pub heartbeats: u64,
}

struct Target {
    v: [f32; 8],
    v_true: [f32; 8],
    c: [f32; 4],
    c_true: [f32; 4],
    noise_v: f32,
    noise_c: f32,
    pose: Option<plant::Pose>,
    cylinder: Option<plant::Cylinder>,
}

/// The simulator nodes and the runner on one bus port.
pub struct Session<P> {
    port: P,
    plant: Plant,
    rng: Xoshiro256PlusPlus,
    enc: Encoder,
    rx: Reassembler,
    start: Instant,
    silence: Duration,
    trial: u32,
    gripper_closed: bool,
    stats: SessionStats,
    /// Each servo drive supervises the controller's heartbeat.
    monitors: [HeartbeatMonitor; 5],
    /// Last raw command each drive applied (held in the safe state).
    last_raw: [u16; 5],
}

fn dist<const D: usize>(a: &[f32; D], b: &[f32; D]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        .sqrt()
}

fn points_of<const K: usize>(o: &plant::Observation<K>) -> [PixelPoint; 4] {
    let mut points = [PixelPoint::UNUSED; 4];
    for (p, r) in points.iter_mut().zip(o.points.iter()) {
        *p = PixelPoint {
            x: r.x as f32,
            y: r.y as f32,
            status: match r.status {
                plant::PointStatus::Valid => PointStatus::Valid,
                plant::PointStatus::OutOfView => PointStatus::OutOfView,
                plant::PointStatus::Occluded => PointStatus::Occluded,
                plant::PointStatus::NotDetected => PointStatus::NotDetected,
            },
        };
        if !(p.x.is_finite() && p.y.is_finite()) {
            *p = PixelPoint::UNUSED;
        }
    }
    points
}

impl<P> Session<P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    /// A session on `port` around `plant`; `seed` drives the targets.
    pub fn new(port: P, plant: Plant, mode: BusMode, seed: u64, silence: Duration) -> Self {
        use rand_core::SeedableRng;
        Session {
            port,
            plant,
            rng: Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x5EED_7A26_E75E_55ED),
            enc: Encoder::new(mode),
            rx: Reassembler::new(trn_protocol::DEFAULT_STALE_MS),
            start: Instant::now(),
            silence,
            trial: 0,
            gripper_closed: false,
            stats: SessionStats::default(),
            monitors: core::array::from_fn(|_| {
                HeartbeatMonitor::new(HeartbeatConfig::default(), 0)
            }),
            last_raw: [2048; 5],
        }
    }

    /// Sets the servo drives' heartbeat supervision (timeout, hold or vent).
    pub fn set_heartbeat(&mut self, cfg: HeartbeatConfig) {
        let now = self.now_ms();
        self.monitors = core::array::from_fn(|_| HeartbeatMonitor::new(cfg, now));
    }

    /// True when servo drive `joint` is in its safe state.
    pub fn servo_safe(&self, joint: usize) -> bool {
        self.monitors.get(joint).is_some_and(|m| m.is_safe())
    }

    /// The servo drives' supervision: a drive that lost the controller's heartbeat holds its
    /// last pressure or vents, as configured, and says so on the bus once.
    fn supervise(&mut self, now: u32) -> Result<(), RunError> {
        for j in 0..5 {
            if let Some(HeartbeatEvent::EnteredSafeState(action)) = self.monitors[j].poll(now) {
                if action == trn_protocol::SafeStateAction::Vent {
                    self.plant.servo_command_raw(j, VENT_RAW)?;
                }
                let msg = self.monitors[j].safe_state_message(self.last_raw[j]);
                self.last_raw[j] = self.monitors[j].held_raw(self.last_raw[j]);
                let node = NodeId::servo(j as u8)?;
                self.send(node, msg)?;
            }
        }
        Ok(())
    }

    /// Waits for the next frame, supervising heartbeats meanwhile; `BusSilent` after the
    /// configured silence.
    fn next_frame(&mut self) -> Result<CanFrame, RunError> {
        let since = Instant::now();
        loop {
            let wait = self
                .silence
                .saturating_sub(since.elapsed())
                .min(Duration::from_millis(50));
            let frame = self.port.receive_timeout(wait)?;
            self.supervise(self.now_ms())?;
            if let Some(f) = frame {
                return Ok(f);
            }
            if since.elapsed() >= self.silence {
                return Err(RunError::BusSilent(self.silence.as_secs_f64()));
            }
        }
    }

    /// Counters.
    pub fn stats(&self) -> SessionStats {
        self.stats
    }

    /// The plant.
    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    fn now_ms(&self) -> u32 {
        self.start.elapsed().as_millis() as u32
    }

    fn send(&mut self, node: NodeId, msg: Message) -> Result<(), RunError> {
        for f in &self.enc.encode(&Envelope::new(node, msg))? {
            self.port.transmit(f)?;
            self.stats.frames_out += 1;
        }
        Ok(())
    }

    /// Tells the controller the session is over (`ModeChange{Idle}`).
    pub fn finish(&mut self) -> Result<(), RunError> {
        self.send(NodeId::Controller, ModeChange { mode: Mode::Idle }.into())
    }

    /// Announces a mode (`Priming`, `Training`, `Mature`).
    pub fn mode(&mut self, mode: Mode) -> Result<(), RunError> {
        self.send(NodeId::Controller, ModeChange { mode }.into())
    }

    fn draw_target(&mut self, kind: TrialKind) -> Result<(Target, [f32; 5]), RunError> {
        const DRAWS: usize = 1000;
        for _ in 0..DRAWS {
            let p = self.plant.random_pressures(&mut self.rng);
            self.plant.command(&p);
            self.plant.settle();
            let lights = self.plant.observe_gripper_lights();
            let lights_true = self.plant.observe_gripper_lights_true();
            let centre = self.plant.observe_gripper_centre();
            let centre_true = self.plant.observe_gripper_centre_true();
            let (Some(v), Some(v_true), Some(c), Some(c_true)) = (
                lights.to_vector(),
                lights_true.to_vector(),
                centre.to_vector(),
                centre_true.to_vector(),
            ) else {
                continue;
            };
            // a second reading at the same pose: what the camera noise alone gives
            let noise_v = self
                .plant
                .observe_gripper_lights()
                .to_vector()
                .map(|w| dist(&w, &v))
                .unwrap_or(0.0);
            let noise_c = self
                .plant
                .observe_gripper_centre()
                .to_vector()
                .map(|w| dist(&w, &c))
                .unwrap_or(0.0);
            let pose = Some(self.plant.gripper_pose());
            let mut t = Target {
                v,
                v_true,
                c,
                c_true,
                noise_v,
                noise_c,
                pose,
                cylinder: None,
            };
            if let TrialKind::Grasp { .. } = kind {
                let cyl = self.plant.place_cylinder();
                let (Some(cc), Some(cc_true)) = (
                    self.plant.observe_cylinder_centre().to_vector(),
                    self.plant.observe_cylinder_centre_true().to_vector(),
                ) else {
                    continue;
                };
                t.c = cc;
                t.c_true = cc_true;
                t.noise_c = self
                    .plant
                    .observe_cylinder_centre()
                    .to_vector()
                    .map(|w| dist(&w, &cc))
                    .unwrap_or(0.0);
                t.cylinder = Some(cyl);
            }
            return Ok((t, p));
        }
        Err(RunError::NoTarget(DRAWS))
    }

    /// Runs one trial to its end over the bus.
    pub fn run_trial(&mut self, kind: TrialKind) -> Result<TrialRecord, RunError> {
        self.trial += 1;
        let trial = self.trial;
        let (target, p_target) = self.draw_target(kind)?;
        // "the robot arm went to a particular arbitrarily chosen position from where it
        // tried to reach the target" (Sec. 8.4.1); stage 2 keeps the wrist of the target.
        match kind {
            TrialKind::Stage2 { .. } => self.plant.move_to_random_joints(&mut self.rng, 3),
            _ => self.plant.move_to_random_joints(&mut self.rng, 5),
        }
        self.plant.settle();
        self.gripper_closed = false;
        let mut rec = TrialRecord {
            trial,
            ..Default::default()
        };
        let mut expect_reports = 1;
        match kind {
            TrialKind::Stage1 { supervised, learn } => {
                if supervised {
                    self.send(
                        NodeId::Controller,
                        SupervisedPressure { trial, p: p_target }.into(),
                    )?;
                }
                rec.stage1 = Some(StageRecord {
                    noise_floor_px: target.noise_v,
                    ..Default::default()
                });
                self.send(
                    NodeId::Controller,
                    Stage1Target {
                        trial,
                        learn,
                        grasp: false,
                        v: target.v,
                    }
                    .into(),
                )?;
            }
            TrialKind::Stage2 { learn } => {
                rec.stage2 = Some(StageRecord {
                    noise_floor_px: target.noise_c,
                    ..Default::default()
                });
                self.send(
                    NodeId::Controller,
                    Stage2Target {
                        trial,
                        learn,
                        grasp: false,
                        c: target.c,
                    }
                    .into(),
                )?;
            }
            TrialKind::Grasp { learn } => {
                expect_reports = 2;
                rec.stage1 = Some(StageRecord {
                    noise_floor_px: target.noise_v,
                    ..Default::default()
                });
                rec.stage2 = Some(StageRecord {
                    noise_floor_px: target.noise_c,
                    ..Default::default()
                });
                self.send(NodeId::Controller, GraspRequest { trial }.into())?;
                self.send(
                    NodeId::Controller,
                    Stage1Target {
                        trial,
                        learn,
                        grasp: true,
                        v: target.v,
                    }
                    .into(),
                )?;
                self.send(
                    NodeId::Controller,
                    Stage2Target {
                        trial,
                        learn,
                        grasp: true,
                        c: target.c,
                    }
                    .into(),
                )?;
            }
        }
        let mut reports = 0;
        let mut stage1_pose_done = false;
        loop {
            let frame = self.next_frame()?;
            self.stats.frames_in += 1;
            let now = self.now_ms();
            let env = match self.rx.push(&frame, now) {
                Ok(Some(env)) => env,
                Ok(None) => continue,
                Err(_) => {
                    self.stats.frame_errors += 1;
                    continue;
                }
            };
            for m in &mut self.monitors {
                m.observe(&env, NodeId::Controller, now);
            }
            match (env.node, env.msg) {
                (NodeId::Servo(j), Message::PressureCommand(c)) => {
                    let i = j.index() as usize;
                    let safe_state =
                        match (self.monitors[i].is_safe(), self.monitors[i].config().action) {
                            (false, _) => SafeState::Normal,
                            (true, trn_protocol::SafeStateAction::HoldLast) => SafeState::HoldLast,
                            (true, trn_protocol::SafeStateAction::Vent) => SafeState::Vented,
                        };
                    // in the safe state a drive ignores commands until heartbeats resume
                    let raw = if safe_state == SafeState::Normal {
                        c.raw
                    } else {
                        self.last_raw[i]
                    };
                    self.last_raw[i] = raw;
                    let fb = self.plant.servo_command_raw(i, raw)?;
                    let status = ServoStatus {
                        seq: c.seq,
                        raw: fb.raw_pressure,
                        saturated: fb.saturated,
                        safe_state,
                    };
                    self.send(NodeId::Servo(j), status.into())?;
                }
                (NodeId::CameraProcessor, Message::CaptureRequest(req)) => {
                    self.plant.settle();
                    self.stats.moves += 1;
                    let obs = match req.what {
                        CaptureKind::GripperLights => {
                            let o = self.plant.observe_gripper_lights();
                            let t = self.plant.observe_gripper_lights_true();
                            if let (Some(r), Some(v), Some(vt)) =
                                (rec.stage1.as_mut(), o.to_vector(), t.to_vector())
                            {
                                r.errors_px.push(dist(&v, &target.v));
                                r.errors_true_px.push(dist(&vt, &target.v_true));
                            }
                            Observation {
                                seq: req.seq,
                                what: req.what,
                                points: points_of(&o),
                            }
                        }
                        CaptureKind::GripperCentre => {
                            if !stage1_pose_done {
                                // the first centre capture of a grasp ends stage 1: score its pose
                                stage1_pose_done = true;
                                if let (Some(r), Some(pose)) =
                                    (rec.stage1.as_mut(), target.pose.as_ref())
                                {
                                    (r.pose_error_mm, r.pose_error_deg) =
                                        self.plant.pose_error(pose);
                                }
                            }
                            let o = self.plant.observe_gripper_centre();
                            let t = self.plant.observe_gripper_centre_true();
                            if let (Some(r), Some(c), Some(ct)) =
                                (rec.stage2.as_mut(), o.to_vector(), t.to_vector())
                            {
                                r.errors_px.push(dist(&c, &target.c));
                                r.errors_true_px.push(dist(&ct, &target.c_true));
                            }
                            Observation {
                                seq: req.seq,
                                what: req.what,
                                points: points_of(&o),
                            }
                        }
                    };
                    self.send(NodeId::CameraProcessor, obs.into())?;
                }
                (NodeId::Gripper, Message::GripperCommand(g)) => {
                    self.gripper_closed = g.close;
                    if g.close {
                        if let Some(cyl) = target.cylinder.as_ref() {
                            rec.grasp = Some(self.plant.grasp_score(cyl));
                        }
                    }
                    self.send(NodeId::Gripper, GripperStatus { closed: g.close }.into())?;
                }
                (NodeId::Controller, Message::TrialReport(r)) if r.trial == trial => {
                    let slot = if r.stage == 2 {
                        rec.stage2.as_mut()
                    } else {
                        rec.stage1.as_mut()
                    };
                    if let Some(s) = slot {
                        s.report = Some(r);
                    }
                    if r.stage != 2 && !stage1_pose_done {
                        stage1_pose_done = true;
                        if let (Some(s), Some(pose)) = (rec.stage1.as_mut(), target.pose.as_ref()) {
                            (s.pose_error_mm, s.pose_error_deg) = self.plant.pose_error(pose);
                        }
                    }
                    reports += 1;
                    let grasp_pending =
                        matches!(kind, TrialKind::Grasp { .. }) && !self.gripper_closed;
                    if reports >= expect_reports && !grasp_pending {
                        return Ok(rec);
                    }
                }
                (NodeId::Controller, Message::ErrorReport(e)) => {
                    rec.errors.push((e.code, e.detail));
                    if e.code == codes::TRIAL_ABORTED && e.detail == trial {
                        rec.aborted = true;
                        return Ok(rec);
                    }
                }
                (NodeId::Controller, Message::Heartbeat(_)) => self.stats.heartbeats += 1,
                _ => {}
            }
            // a grasp whose gripper command came after the last report
            if matches!(kind, TrialKind::Grasp { .. })
                && reports >= expect_reports
                && self.gripper_closed
            {
                return Ok(rec);
            }
        }
    }
}
