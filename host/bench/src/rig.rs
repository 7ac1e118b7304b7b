//! The simulated rig on one bus port: the plant with its five servo drives, camera processor
//! and gripper (the sans-IO nodes of [`trn_plant::nodes`]). It receives frames, reassembles
//! messages, hands each to the nodes, frames and sends their answers, and reports to the
//! runner what matters for scoring ([`Event`]).

use std::time::Duration;

use embedded_can::blocking::Can;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::heartbeat::HeartbeatConfig;
use trn_protocol::{
    BusMode, CanFrame, Encoder, Envelope, Joint, Message, NodeId, PixelPoint, PointStatus,
    ProtocolVersion, Reassembler,
};

use std::cell::{Ref, RefCell, RefMut};
use std::rc::Rc;
use trn_plant::nodes::{CameraProcessor, Capture, Gripper, Outbox, Served, ServoDrive};
use trn_plant::Plant;
use trn_transport::clock::{millis, Clock};

use crate::error::{LabError as Error, Result};

/// What the runner is told.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// The camera processor served a capture request (one move of the controller).
    Captured(Box<Capture>),
    /// The gripper was commanded (`true`: closed).
    Gripper(bool),
    /// A message from the controller that is not for a plant node (reports, errors,
    /// heartbeats, mode acknowledgements).
    Controller(Message),
    /// The controller asked a plant node again (a repeated command or capture): the trial
    /// is alive.
    Progress,
}

/// Counters of the rig.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RigStats {
    /// Frames received.
    pub frames_in: u64,
    /// Frames sent.
    pub frames_out: u64,
    /// Frames rejected by the reassembler (typed errors).
    pub frame_errors: u64,
    /// Heartbeats heard from the controller.
    pub heartbeats: u64,
}

pub use trn_references::SharedPlant;

/// The plant and its nodes on one port.
pub struct Rig<P> {
    port: P,
    plant: SharedPlant,
    drives: [ServoDrive; 5],
    camera: CameraProcessor,
    gripper: Gripper,
    enc: Encoder,
    rx: Reassembler,
    /// The run's clock (simulated in process, the wall clock on a real bus).
    clock: Rc<dyn Clock>,
    /// When the controller was last heard (any frame).
    heard: Duration,
    stats: RigStats,
    /// Every message received, in order, while journaling (the conformance suite).
    journal: Option<Vec<Envelope>>,
    /// The protocol version the controller speaks: the plant's nodes send it nothing it
    /// does not have (an `Estimated` point goes to a version-3 controller as `Occluded`).
    peer: ProtocolVersion,
}

impl<P> Rig<P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    /// The rig around `plant` on `port`, on `clock`, framing in `mode`; the drives
    /// supervise the controller's heartbeat with `supervision`.
    pub fn new(
        port: P,
        clock: Rc<dyn Clock>,
        plant: Plant,
        mode: BusMode,
        supervision: HeartbeatConfig,
    ) -> Self {
        Self::on_shared(port, clock, Rc::new(RefCell::new(plant)), mode, supervision)
    }

    /// [`Rig::new`] around a plant shared with a controller that reads its true state.
    pub fn on_shared(
        port: P,
        clock: Rc<dyn Clock>,
        plant: SharedPlant,
        mode: BusMode,
        supervision: HeartbeatConfig,
    ) -> Self {
        let start = clock.now();
        Rig {
            port,
            plant,
            drives: Joint::ALL.map(|j| ServoDrive::new(j, supervision, 0)),
            camera: CameraProcessor::new(),
            gripper: Gripper::new(),
            enc: Encoder::new(mode),
            rx: Reassembler::new(trn_protocol::DEFAULT_STALE_MS),
            clock,
            heard: start,
            stats: RigStats::default(),
            journal: None,
            peer: ProtocolVersion::CURRENT,
        }
    }

    /// Serves a controller of protocol version `v` from now on.
    pub fn serve_version(&mut self, v: ProtocolVersion) {
        self.peer = v;
    }

    /// The plant.
    pub fn plant(&self) -> Ref<'_, Plant> {
        self.plant.borrow()
    }

    /// The plant, to set up a trial (targets, start poses) outside the bus.
    pub fn plant_mut(&mut self) -> RefMut<'_, Plant> {
        self.plant.borrow_mut()
    }

    /// The gripper node.
    pub fn gripper_mut(&mut self) -> &mut Gripper {
        &mut self.gripper
    }

    /// The camera processor node.
    pub fn camera_mut(&mut self) -> &mut CameraProcessor {
        &mut self.camera
    }

    /// Starts keeping every received message (the controller's commands to the plant nodes,
    /// its reports, errors, echoes and heartbeats) in a journal.
    pub fn start_journal(&mut self) {
        self.journal = Some(Vec::new());
    }

    /// The journal so far.
    pub fn journal(&self) -> &[Envelope] {
        self.journal.as_deref().unwrap_or(&[])
    }

    /// Takes the journal, starting a new one.
    pub fn take_journal(&mut self) -> Vec<Envelope> {
        self.journal.replace(Vec::new()).unwrap_or_default()
    }

    /// True when servo drive `joint` is in its safe state.
    pub fn servo_safe(&self, joint: usize) -> bool {
        self.drives.get(joint).is_some_and(|d| d.is_safe())
    }

    /// Counters.
    pub fn stats(&self) -> RigStats {
        self.stats
    }

    /// Moves (captures) served.
    pub fn moves(&self) -> u64 {
        self.camera.captures()
    }

    /// The run's time.
    pub fn now(&self) -> Duration {
        self.clock.now()
    }

    fn now_ms(&self) -> u32 {
        millis(self.clock.now())
    }

    /// The port (to take the bus's counters, or the controller, at the end).
    pub fn port(&self) -> &P {
        &self.port
    }

    /// Ends the rig: its port.
    pub fn into_port(self) -> P {
        self.port
    }

    /// Frames and sends a message of the runner's. The plant's nodes hear it as nodes on a
    /// bus hear every frame (the camera processor starts a trial's track at its target); a
    /// port does not give a sender its own frames back, so they are handed it here.
    pub fn send(&mut self, node: NodeId, msg: Message) -> Result<()> {
        let env = Envelope::new(node, msg);
        let mut out = Outbox::new();
        self.camera
            .on_message(&mut self.plant.borrow_mut(), &env, &mut out);
        self.send_all(&out)?;
        self.send_env(&env)
    }

    fn send_env(&mut self, env: &Envelope) -> Result<()> {
        let env = &self.for_peer(*env);
        for f in &self.enc.encode(env)? {
            self.port.transmit(f)?;
            self.stats.frames_out += 1;
        }
        Ok(())
    }

    /// `env` as the controller's protocol version has it: for version 3 (which has no
    /// `Estimated` status) a light estimated by the camera processor is a hidden one,
    /// `Occluded` at (0, 0), as a version-3 camera processor reported it.
    fn for_peer(&self, mut env: Envelope) -> Envelope {
        if let Message::Observation(o) = &mut env.msg {
            if !self.peer.understands(&Message::Observation(*o)) {
                for p in &mut o.points {
                    if p.status == PointStatus::Estimated {
                        *p = PixelPoint {
                            x: 0.0,
                            y: 0.0,
                            status: PointStatus::Occluded,
                        };
                    }
                }
            }
        }
        env
    }

    fn send_all(&mut self, out: &Outbox) -> Result<()> {
        out.iter().try_for_each(|env| self.send_env(env))
    }

    /// The drives' timers (heartbeat supervision).
    fn poll(&mut self) -> Result<()> {
        let now = self.now_ms();
        let mut out = Outbox::new();
        for d in &mut self.drives {
            d.poll(&mut self.plant.borrow_mut(), now, &mut out)?;
        }
        self.send_all(&out)
    }

    /// Serves the bus until something happens that the runner must know about, or until
    /// `wait` passed without (`Ok(None)`). Fails with `BusSilent` when the controller sent no
    /// frame at all (heartbeats included) for `silence`: the other side is gone.
    pub fn next_event(&mut self, wait: Duration, silence: Duration) -> Result<Option<Event>> {
        let deadline = self.now() + wait;
        loop {
            let now = self.now();
            if now.saturating_sub(self.heard) >= silence {
                return Err(Error::BusSilent(silence.as_secs_f64()));
            }
            let left = deadline.saturating_sub(now);
            if left.is_zero() {
                return Ok(None);
            }
            let frame = self
                .port
                .receive_timeout(left.min(Duration::from_millis(50)))?;
            self.poll()?;
            let Some(frame) = frame else { continue };
            self.stats.frames_in += 1;
            let now_ms = self.now_ms();
            let env = match self.rx.push(&frame, now_ms) {
                Ok(Some(env)) => env,
                Ok(None) => continue,
                Err(_) => {
                    self.stats.frame_errors += 1;
                    continue;
                }
            };
            if let Some(j) = &mut self.journal {
                j.push(env);
            }
            if env.msg.kind().is_command() || env.node == NodeId::Controller {
                // commands come from the controller (the runner's own do not come back)
                self.heard = self.now();
            }
            if let Some(event) = self.dispatch(&env, now_ms)? {
                return Ok(Some(event));
            }
        }
    }

    /// How long ago a frame of the controller last arrived.
    pub fn since_heard(&self) -> Duration {
        self.now().saturating_sub(self.heard)
    }

    /// Restarts the controller's silence clock (at the start of a session).
    pub fn heard_now(&mut self) {
        self.heard = self.now();
    }

    /// Hands one message to every node and sends their answers.
    fn dispatch(&mut self, env: &Envelope, now: u32) -> Result<Option<Event>> {
        let mut out = Outbox::new();
        let mut answered = false;
        for d in &mut self.drives {
            answered |= d.on_message(&mut self.plant.borrow_mut(), env, now, &mut out)?;
        }
        let served = self
            .camera
            .on_message(&mut self.plant.borrow_mut(), env, &mut out);
        let gripper = self.gripper.on_message(env, &mut out);
        self.send_all(&out)?;
        Ok(match (served, gripper, env.node) {
            (Served::Capture(c), _, _) => Some(Event::Captured(c)),
            (Served::Repeat, _, _) => Some(Event::Progress),
            (_, Some(closed), _) => Some(Event::Gripper(closed)),
            _ if answered => Some(Event::Progress),
            (_, _, NodeId::Controller | NodeId::Broadcast)
                if !env.msg.kind().is_command() || env.node == NodeId::Broadcast =>
            {
                if matches!(env.msg, Message::Heartbeat(_)) {
                    self.stats.heartbeats += 1;
                }
                Some(Event::Controller(env.msg))
            }
            _ => None,
        })
    }
}
