//! `ControllerNode::service` on ports with their own frame and error types, as a HAL's CAN
//! driver has them: frames converted both ways (classical and FD), the port's error
//! returned as it is, frames the protocol does not use dropped and counted; and the
//! protocol's own frame passing unchanged, FD flag included.

use std::collections::VecDeque;

use embedded_can::{ErrorKind, ExtendedId, Frame, Id, StandardId};
use trn_controller::{Config, Controller};
use trn_node::{ControllerNode, NodeConfig};
use trn_protocol::{
    BusMode, CanFrame, Encoder, Envelope, Message, Mode, ModeChange, NodeId, Reassembler,
    SessionConfig, Stage1Target, DEFAULT_STALE_MS, FINE_MOVES_POLICY,
};

/// A HAL's frame: standard or extended id, data or remote, up to `MAX` bytes.
#[derive(Debug, Clone, PartialEq)]
struct HalFrame<const MAX: usize> {
    id: Id,
    remote: bool,
    data: Vec<u8>,
}

impl<const MAX: usize> Frame for HalFrame<MAX> {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        (data.len() <= MAX).then(|| HalFrame {
            id: id.into(),
            remote: false,
            data: data.to_vec(),
        })
    }
    fn new_remote(id: impl Into<Id>, dlc: usize) -> Option<Self> {
        (dlc <= 8).then(|| HalFrame {
            id: id.into(),
            remote: true,
            data: vec![0; dlc],
        })
    }
    fn is_extended(&self) -> bool {
        matches!(self.id, Id::Extended(_))
    }
    fn is_remote_frame(&self) -> bool {
        self.remote
    }
    fn id(&self) -> Id {
        self.id
    }
    fn dlc(&self) -> usize {
        self.data.len()
    }
    fn data(&self) -> &[u8] {
        &self.data
    }
}

/// A HAL's error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum HalError {
    BusOff,
}

impl embedded_can::Error for HalError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

/// A HAL's port: frames to receive, frames sent, an error to report once.
struct HalPort<F> {
    rx: VecDeque<F>,
    tx: Vec<F>,
    fail: Option<HalError>,
}

impl<F> HalPort<F> {
    fn new(rx: impl IntoIterator<Item = F>) -> Self {
        HalPort {
            rx: rx.into_iter().collect(),
            tx: Vec::new(),
            fail: None,
        }
    }
}

impl<F: Frame + Clone> embedded_can::nb::Can for HalPort<F> {
    type Frame = F;
    type Error = HalError;

    fn transmit(&mut self, frame: &F) -> nb::Result<Option<F>, HalError> {
        self.tx.push(frame.clone());
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<F, HalError> {
        if let Some(e) = self.fail.take() {
            return Err(nb::Error::Other(e));
        }
        self.rx.pop_front().ok_or(nb::Error::WouldBlock)
    }
}

type Classic = HalFrame<8>;
type Fd = HalFrame<64>;

fn controller() -> Box<Controller> {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(1);
    c
}

/// `env` as the frames of a port of frame type `F`.
fn frames<F: Frame>(env: &Envelope, mode: BusMode) -> Vec<F> {
    Encoder::new(mode)
        .encode(env)
        .unwrap()
        .iter()
        .map(|f| F::new(StandardId::new(f.raw_id()).unwrap(), f.payload()).unwrap())
        .collect()
}

/// The messages in frames sent by a port of frame type `F`.
fn messages<F: Frame>(sent: &[F]) -> Vec<Envelope> {
    let mut rx: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
    sent.iter()
        .filter_map(|f| {
            let Id::Standard(id) = f.id() else {
                panic!("an extended id sent")
            };
            let frame = CanFrame::new_checked(id.as_raw(), f.data(), f.data().len() > 8).unwrap();
            rx.push(&frame, 0).unwrap()
        })
        .collect()
}

fn to_ctrl(msg: Message) -> Envelope {
    Envelope::new(NodeId::Controller, msg)
}

fn stage1_target() -> Envelope {
    to_ctrl(
        Stage1Target {
            trial: 4,
            learn: false,
            grasp: false,
            fine_moves: FINE_MOVES_POLICY,
            v: [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0],
        }
        .into(),
    )
}

fn session(fd: bool) -> Envelope {
    to_ctrl(
        SessionConfig {
            seed: 9,
            preset: 0,
            ablation: 0,
            image_width: 1024,
            image_height: 768,
            fd,
            keep_tables: false,
            law: 0,
        }
        .into(),
    )
}

#[test]
fn a_classical_hal_port_carries_a_segmented_target_in_and_the_moves_out() {
    let mut ctrl = controller();
    let mut node = ControllerNode::new(NodeConfig::DEFAULT);
    let (mut rx, mut enc) = (
        Reassembler::<8>::new(DEFAULT_STALE_MS),
        Encoder::new(BusMode::Classic),
    );
    let target: Vec<Classic> = frames(&stage1_target(), BusMode::Classic);
    assert!(target.len() > 1, "a long kind is segmented on CAN 2.0");
    let mut port = HalPort::new(target);
    node.service(&mut *ctrl, &mut rx, &mut enc, &mut port, 5)
        .unwrap();
    assert_eq!(node.trial(), Some(4));
    let sent = messages(&port.tx);
    let commands = sent
        .iter()
        .filter(|e| matches!(e.msg, Message::PressureCommand(_)))
        .count();
    assert_eq!(commands, 5, "{sent:?}");
    assert!(sent.iter().any(|e| matches!(e.msg, Message::Heartbeat(_))));
    assert_eq!(node.stats().frame_errors, 0);
}

#[test]
fn an_fd_hal_port_carries_long_messages_as_single_fd_frames() {
    let mut ctrl = controller();
    let mut node = ControllerNode::new(NodeConfig::DEFAULT);
    let (mut rx, mut enc) = (
        Reassembler::<8>::new(DEFAULT_STALE_MS),
        Encoder::new(BusMode::Classic),
    );
    // the session switches the node to CAN FD; the target then comes as one FD frame
    let mut input: Vec<Fd> = frames(&session(true), BusMode::Classic);
    let target: Vec<Fd> = frames(&stage1_target(), BusMode::Fd);
    assert_eq!(target.len(), 1);
    assert!(target[0].data.len() > 8);
    input.extend(target);
    let mut port = HalPort::new(input);
    node.service(&mut *ctrl, &mut rx, &mut enc, &mut port, 5)
        .unwrap();
    assert_eq!(node.trial(), Some(4));
    assert_eq!(node.stats().frame_errors, 0);
    let sent = messages(&port.tx);
    assert!(sent
        .iter()
        .any(|e| e.node == NodeId::Broadcast && matches!(e.msg, Message::SessionConfig(_))));
    assert_eq!(
        sent.iter()
            .filter(|e| matches!(e.msg, Message::PressureCommand(_)))
            .count(),
        5
    );
}

/// On a classical-only frame type an FD session's long messages cannot be sent: each is
/// dropped and counted, never truncated; single-frame messages still go out.
#[test]
fn frames_the_port_cannot_hold_are_counted_not_sent() {
    let mut ctrl = controller();
    let mut node = ControllerNode::new(NodeConfig::DEFAULT);
    let (mut rx, mut enc) = (
        Reassembler::<8>::new(DEFAULT_STALE_MS),
        Encoder::new(BusMode::Classic),
    );
    // the session's echo is long: in FD mode it is one frame of more than 8 bytes
    let mut port = HalPort::new(frames::<Classic>(&session(true), BusMode::Classic));
    node.service(&mut *ctrl, &mut rx, &mut enc, &mut port, 5)
        .unwrap();
    assert!(node.session().is_some());
    assert_eq!(node.stats().frame_errors, 1, "the session's echo");
    let sent = messages(&port.tx);
    assert!(sent.iter().any(|e| matches!(e.msg, Message::Heartbeat(_))));
    assert!(!sent
        .iter()
        .any(|e| matches!(e.msg, Message::SessionConfig(_))));
}

#[test]
fn remote_and_extended_frames_are_dropped_and_counted() {
    let mut ctrl = controller();
    let mut node = ControllerNode::new(NodeConfig::DEFAULT);
    let (mut rx, mut enc) = (
        Reassembler::<8>::new(DEFAULT_STALE_MS),
        Encoder::new(BusMode::Classic),
    );
    let mode = to_ctrl(
        ModeChange {
            mode: Mode::Training,
        }
        .into(),
    );
    let mut input = vec![
        Classic::new(ExtendedId::new(0x100).unwrap(), &[1, 2]).unwrap(),
        Classic::new_remote(StandardId::new(0x100).unwrap(), 2).unwrap(),
    ];
    input.extend(frames::<Classic>(&mode, BusMode::Classic));
    let mut port = HalPort::new(input);
    node.service(&mut *ctrl, &mut rx, &mut enc, &mut port, 5)
        .unwrap();
    assert_eq!(node.stats().frame_errors, 2);
    assert_eq!(
        node.mode(),
        Mode::Training,
        "the frame after them was handled"
    );
}

#[test]
fn a_port_error_is_returned_as_the_ports_own_error() {
    let mut ctrl = controller();
    let mut node = ControllerNode::new(NodeConfig::DEFAULT);
    let (mut rx, mut enc) = (
        Reassembler::<8>::new(DEFAULT_STALE_MS),
        Encoder::new(BusMode::Classic),
    );
    let mut port: HalPort<Classic> = HalPort::new([]);
    port.fail = Some(HalError::BusOff);
    let result = node.service(&mut *ctrl, &mut rx, &mut enc, &mut port, 5);
    assert_eq!(result, Err(HalError::BusOff));
}

/// A port of the protocol's own frames gets them unchanged: in an FD session even a
/// single-frame message (the heartbeat) goes out as an FD frame, as SPEC.md 4.1 says.
#[test]
fn the_protocols_own_frames_pass_unchanged_with_their_fd_flag() {
    let mut ctrl = controller();
    let mut node = ControllerNode::new(NodeConfig::DEFAULT);
    let (mut rx, mut enc) = (
        Reassembler::<8>::new(DEFAULT_STALE_MS),
        Encoder::new(BusMode::Classic),
    );
    let input = Encoder::new(BusMode::Classic)
        .encode(&session(true))
        .unwrap();
    let mut port: HalPort<CanFrame> = HalPort::new(input.iter().copied());
    node.service(&mut *ctrl, &mut rx, &mut enc, &mut port, 5)
        .unwrap();
    // the first turn's heartbeat went out after the switch to FD
    assert!(!port.tx.is_empty());
    assert!(port.tx.iter().all(CanFrame::is_fd), "{:?}", port.tx);
    assert!(
        port.tx.iter().any(|f| f.len() <= 8),
        "a single-frame kind, as FD"
    );
}
