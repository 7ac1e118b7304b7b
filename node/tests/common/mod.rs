//! A node with learned tables and a store on a simulated flash, a scripted plant that answers
//! its requests, and helpers to send it messages and read what it answers; in [`trial`], a
//! plain node (no store) and the messages of a trial.
#![allow(dead_code)]

pub mod trial;

use trn_controller::checkpoint::{self, Provenance};
use trn_controller::WithStore;
use trn_controller::{Command, Config, Controller, Observation, Task};
use trn_node::{ControllerNode, NodeConfig, Outbox};
use trn_protocol::{
    CaptureKind, Envelope, Message, NodeId, Observation as Obs, PixelPoint, SafeState, ServoStatus,
    SessionConfig,
};
use trn_store::sim::SimFlash;
use trn_store::FlashStore;

/// The simulated flash: 32-byte write units, 4 KiB pages.
pub type Flash = SimFlash<32, 4096>;
/// A controller and its store, as a board holds them.
pub type Board = WithStore<Box<Controller>, FlashStore<Flash>>;

/// A store over an erased flash.
pub fn store() -> FlashStore<Flash> {
    let slot = FlashStore::<Flash>::slot_size_needed();
    FlashStore::new(Flash::new(2 * slot as usize / 4096), 0, slot).unwrap()
}

/// The configuration of [`session`]: the project preset for 1024 x 768 images.
pub fn project() -> Config {
    use trn_controller::presets::{configure, Ablation, ImageSize, Preset};
    configure(Preset::Project, Ablation::None, ImageSize::DEFAULT)
}

/// Tables under [`project`] seeded with `seed` that learned from `trials` stage-1 trials.
pub fn learned(seed: u64, trials: u32) -> Box<Controller> {
    let mut c = Box::new(Controller::new(project()));
    c.init_random(seed);
    for t in 0..trials {
        let v = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0].map(|x| x + t as f32);
        let mut cmd = c
            .begin(Task::Stage1 {
                v,
                supervised: None,
                learn: true,
            })
            .unwrap();
        while let Command::Move { .. } = cmd {
            let mut seen = v;
            seen[0] += 3.0;
            cmd = c.observe(Observation::Lights(seen)).unwrap();
        }
    }
    c
}

/// The checkpoint image of a controller: its tables and learning steps, byte for byte.
pub fn image(c: &Controller) -> Vec<u8> {
    let mut buf = vec![0u8; checkpoint::MAX_SIZE];
    let n = checkpoint::save(c, Provenance::CUSTOM, &mut buf).unwrap();
    buf.truncate(n);
    buf
}

/// True when two controllers are alike whole: tables, learning steps, configuration.
pub fn same(a: &Controller, b: &Controller) -> bool {
    image(a) == image(b) && a.config() == b.config()
}

/// The project preset's session for the default image size (what the firmware boots with).
pub fn session(seed: u64, keep_tables: bool) -> SessionConfig {
    SessionConfig {
        seed,
        preset: 0,
        ablation: 0,
        image_width: 1024,
        image_height: 768,
        fd: false,
        keep_tables,
        law: 0,
    }
}

/// A learning stage-1 target (one fine move) of trial `trial`.
pub fn learning_target(trial: u32) -> trn_protocol::Stage1Target {
    trn_protocol::Stage1Target {
        trial,
        learn: true,
        grasp: false,
        fine_moves: 1,
        v: [410.0, 300.0, 395.0, 290.0, 405.0, 320.0, 380.0, 300.0],
    }
}

pub fn to_ctrl(msg: Message) -> Envelope {
    Envelope::new(NodeId::Controller, msg)
}

/// Sends `msg` to the node at `now`; what it answered.
pub fn send<C: trn_controller::Control + ?Sized>(
    node: &mut ControllerNode,
    ctrl: &mut C,
    msg: Message,
    now: u32,
) -> Outbox {
    let mut out = Outbox::new();
    node.on_message(ctrl, &to_ctrl(msg), now, &mut out);
    out
}

pub fn errors(out: &[Envelope]) -> Vec<(u16, u32)> {
    out.iter()
        .filter_map(|e| match e.msg {
            Message::ErrorReport(r) => Some((r.code, r.detail)),
            _ => None,
        })
        .collect()
}

/// A plant that lands where a fixed linear map of the pressures says: lights
/// `v = 400 + 60 p` (each light coordinate from a joint), the centre from the first three.
pub struct Plant {
    held: [u16; 5],
}

impl Plant {
    pub fn new() -> Plant {
        Plant { held: [2048; 5] }
    }

    fn p(&self, j: usize) -> f32 {
        trn_protocol::raw_to_pressure(self.held[j])
    }

    /// The plant's answers to the node's requests in `out` (drives' statuses, the camera's
    /// observation, the gripper's status).
    pub fn answer(&mut self, out: &[Envelope]) -> Vec<Envelope> {
        let mut answers = Vec::new();
        for e in out {
            match (e.node, e.msg) {
                (NodeId::Servo(j), Message::PressureCommand(c)) => {
                    self.held[j.index() as usize] = c.raw;
                    let s = ServoStatus {
                        seq: c.seq,
                        raw: c.raw,
                        applied: c.raw,
                        saturated: false,
                        safe_state: SafeState::Normal,
                    };
                    answers.push(Envelope::new(NodeId::Servo(j), s.into()));
                }
                (NodeId::CameraProcessor, Message::CaptureRequest(r)) => {
                    let pt = |a: usize, b: usize| {
                        PixelPoint::valid(400.0 + 60.0 * self.p(a), 300.0 + 60.0 * self.p(b))
                    };
                    let o = match r.what {
                        CaptureKind::GripperLights => {
                            Obs::lights(r.seq, [pt(0, 1), pt(2, 3), pt(4, 0), pt(1, 2)])
                        }
                        CaptureKind::GripperCentre => Obs::centre(r.seq, pt(0, 1), pt(2, 0)),
                    };
                    answers.push(Envelope::new(NodeId::CameraProcessor, o.into()));
                }
                (NodeId::Gripper, Message::GripperCommand(g)) => {
                    let s = trn_protocol::GripperStatus { closed: g.close };
                    answers.push(Envelope::new(NodeId::Gripper, s.into()));
                }
                _ => {}
            }
        }
        answers
    }
}

/// A node with the default (firmware) settings and its guard seeded.
pub fn node() -> ControllerNode {
    let mut n = ControllerNode::new(NodeConfig::DEFAULT);
    n.seed_guard([0x5A; 16]);
    n
}

/// A board that learned (`trials` trials) and a node that restored its tables at boot.
pub fn booted_board(seed: u64, trials: u32) -> (ControllerNode, Board) {
    let mut board = WithStore {
        ctrl: learned(seed, trials),
        store: store(),
    };
    let mut n = node();
    let copy = {
        use trn_controller::persist::TableStore;
        let c = &board.ctrl;
        board.store.save_begin(c, Provenance::CUSTOM).unwrap();
        loop {
            if let Some(copy) = board.store.save_step(c).unwrap() {
                break copy;
            }
        }
    };
    n.tables_restored(&mut board, Some(copy));
    (n, board)
}
