//! Tables over the in-process bus between a reader/writer and a node whose controller has a
//! store: written in (staged, verified, applied) then read out, bit for bit, on CAN 2.0 and
//! CAN FD, with frames dropped, duplicated, reordered, corrupted and truncated, and a writer
//! that stops half way and a new one that resumes where the node says.

mod common;

use common::*;
use trn_controller::persist::TableStore;
use trn_controller::WithStore;
use trn_node::codes;
use trn_protocol::bus::{FaultConfig, InProcBus, InProcPort};
use trn_protocol::{
    chunk_count, BusMode, ChunkData, Encoder, Envelope, GuardOp, GuardRequest, Message, NodeId,
    Reassembler, StoreCommand, StoreOp, TableReadRequest, TableWriteBegin, TableWriteChunk,
    TableWriteEnd, TablesEvent, CHUNK, DEFAULT_STALE_MS,
};

/// The node on its port and the tool (reader/writer) on another, stepped together one
/// millisecond at a time.
struct Rig {
    bus: InProcBus,
    node: trn_node::ControllerNode,
    board: Board,
    node_port: InProcPort,
    node_rx: Reassembler,
    node_enc: Encoder,
    tool_port: InProcPort,
    tool_rx: Reassembler,
    tool_enc: Encoder,
    now: u32,
    /// Requests the tool sent again after no answer.
    repeats: u32,
}

impl Rig {
    fn new(mode: BusMode, faults: FaultConfig) -> Rig {
        let bus = InProcBus::new(mode, 7);
        let node_port = bus.port();
        let tool_port = bus.port();
        bus.set_faults(faults);
        let (node, board) = booted_board(31, 3);
        Rig {
            node,
            board,
            node_port,
            node_rx: Reassembler::new(DEFAULT_STALE_MS),
            node_enc: Encoder::new(mode),
            tool_port,
            tool_rx: Reassembler::new(DEFAULT_STALE_MS),
            tool_enc: Encoder::new(mode),
            bus,
            now: 0,
            repeats: 0,
        }
    }

    fn send(&mut self, msg: Message) {
        use embedded_can::blocking::Can;
        let env = Envelope::new(NodeId::Controller, msg);
        for f in &self.tool_enc.encode(&env).unwrap() {
            self.tool_port.transmit(f).unwrap();
        }
    }

    /// Sends `msg` until `answer` picks a reply (repeating every 30 ms), stepping the node.
    fn ask<T>(&mut self, msg: Message, answer: impl Fn(&Message) -> Option<T>) -> T {
        for attempt in 0..200 {
            if attempt > 0 {
                self.repeats += 1;
            }
            self.send(msg);
            for _ in 0..30 {
                self.now += 1;
                self.node
                    .service(
                        &mut self.board,
                        &mut self.node_rx,
                        &mut self.node_enc,
                        &mut self.node_port,
                        self.now,
                    )
                    .unwrap();
                while let Some(f) = self.tool_port.try_receive() {
                    if let Ok(Some(env)) = self.tool_rx.push(&f, self.now) {
                        if let Some(t) = answer(&env.msg) {
                            return t;
                        }
                    }
                }
            }
        }
        panic!("no answer to {msg:?}");
    }

    /// Writes `image` in: a nonce, the begin, every chunk from where the node says, the end.
    /// `stop_after`: the writer gives up after that many chunks (the caller resumes).
    fn write(
        &mut self,
        image: &[u8],
        fingerprint: u32,
        stop_after: Option<u16>,
    ) -> Result<(), (u16, u32)> {
        let len = image.len() as u32;
        let crc = u32::from_le_bytes(image[image.len() - 4..].try_into().unwrap());
        let next = loop {
            let op = GuardOp::TableWrite;
            let nonce = self.ask(GuardRequest { op }.into(), |m| match m {
                Message::GuardNonce(n) if n.op == op => Some(n.nonce),
                _ => None,
            });
            let begin = TableWriteBegin {
                nonce,
                image_len: len,
                image_crc: crc,
                fingerprint,
            };
            // an ack, or the guard's refusal (a nonce replaced by a repeated request's)
            match self.ask(begin.into(), |m| match m {
                Message::TableWriteAck(a) if a.image_crc == crc => Some(Ok(a.next)),
                Message::ErrorReport(e) if e.code == codes::GUARD_REFUSED => Some(Err(())),
                _ => None,
            }) {
                Ok(next) => break next,
                Err(()) => continue,
            }
        };
        let count = chunk_count(len) as u16;
        let mut k = next;
        let mut sent = 0;
        while k < count {
            if Some(sent) == stop_after {
                return Ok(());
            }
            let at = k as usize * CHUNK;
            let chunk = TableWriteChunk {
                index: k,
                data: ChunkData::new(&image[at..image.len().min(at + CHUNK)]),
            };
            k = self.ask(chunk.into(), |m| match m {
                Message::TableWriteAck(a) if a.image_crc == crc && a.next != k => Some(a.next),
                _ => None,
            });
            sent += 1;
        }
        self.ask(TableWriteEnd { image_crc: crc }.into(), |m| match m {
            Message::TablesStatus(s) if s.event == TablesEvent::Applied => Some(Ok(())),
            Message::ErrorReport(e) if e.code == codes::TABLES_FAILED => {
                Some(Err((e.code, e.detail)))
            }
            _ => None,
        })
    }

    /// Reads the node's image out: its length from the status, then every chunk.
    fn read(&mut self) -> Vec<u8> {
        let status = self.ask(
            StoreCommand {
                op: StoreOp::Status,
                nonce: 0,
            }
            .into(),
            |m| match m {
                Message::TablesStatus(s) if s.event == TablesEvent::Status => Some(*s),
                _ => None,
            },
        );
        let len = status.image_len as usize;
        let mut image = Vec::with_capacity(len);
        for k in 0..chunk_count(status.image_len) as u16 {
            let data = self.ask(TableReadRequest { index: k }.into(), |m| match m {
                Message::TableReadChunk(c) if c.index == k => Some(c.data.bytes()),
                _ => None,
            });
            image.extend_from_slice(&data);
        }
        image.truncate(len);
        image
    }
}

fn faults() -> FaultConfig {
    FaultConfig {
        drop: 0.01,
        duplicate: 0.01,
        corrupt: 0.01,
        corrupt_scope: trn_protocol::bus::CorruptScope::LongMessages,
        truncate: 0.005,
        delay: 0.01,
        max_delay_frames: 4,
    }
}

fn round_trip(mode: BusMode) {
    let source = learned(41, 6);
    let image_in = image(&source);
    let mut rig = Rig::new(mode, faults());
    assert!(!same(&rig.board.ctrl, &source));
    // a writer that stops a third of the way, then a new one that resumes
    let fp = source.config().fingerprint();
    rig.write(&image_in, fp, Some(1500)).unwrap();
    assert!(
        !same(&rig.board.ctrl, &source),
        "nothing applied before the end"
    );
    rig.write(&image_in, fp, None).unwrap();
    assert!(
        same(&rig.board.ctrl, &source),
        "the node holds the tables written in"
    );
    assert_eq!(
        rig.board.store.stored().unwrap().steps.0,
        source.stage1().learning_step()
    );
    let image_out = rig.read();
    assert!(
        image_out == image_in,
        "the tables read out differ from those written in"
    );
    let s = rig.bus.stats();
    println!(
        "{mode:?}: {} chunks each way, {} requests repeated; bus: {} sent, {} dropped, {} duplicated, {} corrupted, {} truncated, {} delayed",
        chunk_count(image_in.len() as u32),
        rig.repeats,
        s.sent,
        s.dropped,
        s.duplicated,
        s.corrupted,
        s.truncated,
        s.delayed
    );
    assert!(rig.repeats > 0 && s.dropped > 0 && s.corrupted > 0);
}

#[test]
fn tables_round_trip_over_can_2_0_with_faults_and_a_resumed_writer() {
    round_trip(BusMode::Classic);
}

#[test]
fn tables_round_trip_over_can_fd_with_faults_and_a_resumed_writer() {
    round_trip(BusMode::Fd);
}

/// An image that is not what the begin announced is refused at the end, nothing applied;
/// a node without a store refuses a write, and serves reads.
#[test]
fn a_write_that_does_not_verify_is_not_applied() {
    let source = learned(42, 2);
    let mut image_in = image(&source);
    let mut rig = Rig::new(BusMode::Fd, FaultConfig::default());
    let before = rig.board.ctrl.clone();
    // one byte changed after the CRC was announced: the checkpoint's CRC check refuses it
    let last = image_in.len() - 4;
    image_in[last / 2] ^= 0x40;
    let refused = rig.write(&image_in, source.config().fingerprint(), None);
    assert_eq!(
        refused.map_err(|(code, detail)| (code, detail >> 8 & 0xFF, detail & 0xFF)),
        Err((
            codes::TABLES_FAILED,
            codes::table_op::APPLY,
            codes::table_reason::IMAGE
        ))
    );
    assert!(same(&rig.board.ctrl, &before));
    let mut plain = WithStore {
        ctrl: learned(3, 0),
        store: store(),
    };
    let mut n = node();
    let read = send(
        &mut n,
        &mut plain.ctrl,
        TableReadRequest { index: 0 }.into(),
        0,
    );
    assert!(matches!(read[0].msg, Message::TableReadChunk(c) if c.data.bytes()[..4] == *b"TRNC"));
    let begin = send(
        &mut n,
        &mut plain.ctrl,
        TableWriteBegin {
            nonce: 0,
            image_len: 100,
            image_crc: 0,
            fingerprint: 0,
        }
        .into(),
        1,
    );
    assert_eq!(
        errors(&begin),
        vec![(
            codes::TABLES_FAILED,
            codes::table_op::WRITE_BEGIN << 8 | codes::table_reason::NO_STORE
        )]
    );
}

/// A save due while an image is being written in waits for the write's end: it would take
/// the slot the image is staged in.
#[test]
fn a_save_waits_for_a_write_in_progress() {
    let source = learned(43, 1);
    let image_in = image(&source);
    let mut rig = Rig::new(BusMode::Fd, FaultConfig::default());
    let fp = source.config().fingerprint();
    rig.write(&image_in, fp, Some(100)).unwrap();
    // asked to save meanwhile: nothing happens until the write ends
    rig.ask(
        StoreCommand {
            op: StoreOp::Save,
            nonce: 0,
        }
        .into(),
        |_| Some(()),
    );
    for _ in 0..100 {
        rig.ask(TableReadRequest { index: 0 }.into(), |m| {
            matches!(m, Message::TableReadChunk(_)).then_some(())
        });
    }
    assert_eq!(
        rig.board.store.stored().unwrap().sequence,
        1,
        "no save over the staged image"
    );
    rig.write(&image_in, fp, None).unwrap();
    assert!(same(&rig.board.ctrl, &source));
}
