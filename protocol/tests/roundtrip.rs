//! Round-trip properties: every message, both bus modes, segmentation with random data.

mod common;

use std::collections::HashSet;

use common::{envelope, mode_strategy};
use proptest::prelude::*;
use trn_protocol::*;

fn decode_all(frames: &[CanFrame]) -> Vec<Result<Option<Envelope>>> {
    let mut rx: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
    frames.iter().map(|f| rx.push(f, 0)).collect()
}

proptest! {
    // a fixed seed: the same cases every run
    #![proptest_config(ProptestConfig {
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x2071),
        ..ProptestConfig::with_cases(2000)
    })]

    #[test]
    fn every_message_round_trips(env in envelope(), mode in mode_strategy(), tid in 0u8..16) {
        let mut frames = Frames::new();
        encode(&env, mode, tid, &mut frames).unwrap();
        let kind = env.msg.kind();
        if kind.is_single_frame() || mode == BusMode::Fd {
            prop_assert_eq!(frames.len(), 1);
        } else {
            prop_assert_eq!(frames.len(), segment_count(kind));
        }
        for f in &frames {
            prop_assert_eq!(f.is_fd(), mode == BusMode::Fd);
            prop_assert_eq!(f.raw_id(), env.can_id().unwrap().raw());
        }
        if kind.is_single_frame() {
            prop_assert_eq!(frames[0].len(), kind.wire_len());
        }
        let results = decode_all(&frames);
        let (last, init) = results.split_last().unwrap();
        for r in init {
            prop_assert_eq!(r, &Ok(None));
        }
        prop_assert_eq!(last, &Ok(Some(env)));
    }

    #[test]
    fn tagged_postcard_encoding_round_trips(env in envelope()) {
        let mut buf = [0u8; MESSAGE_BUDGET];
        let used = postcard::to_slice(&env.msg, &mut buf).unwrap();
        let back: Message = postcard::from_bytes(used).unwrap();
        prop_assert_eq!(back, env.msg);
    }

    /// Segments of several long messages on distinct ids, interleaved in a random order
    /// that keeps each message's own order, all reassemble: as many messages at once as the
    /// reassembler has slots (8), never more (a ninth would find no free slot, as it should).
    #[test]
    fn interleaved_segmentation(envs in proptest::collection::vec(envelope(), 1..12), seed in any::<u64>()) {
        let mut seen = HashSet::new();
        let envs: Vec<Envelope> = envs
            .into_iter()
            .filter(|e| !e.msg.kind().is_single_frame() && seen.insert(e.can_id().unwrap()))
            .take(8)
            .collect();
        let mut enc = Encoder::new(BusMode::Classic);
        let mut queues: Vec<Vec<CanFrame>> =
            envs.iter().map(|e| enc.encode(e).unwrap().to_vec()).collect();
        let mut rng = seed;
        let mut rx: Reassembler<8> = Reassembler::new(DEFAULT_STALE_MS);
        let mut got = Vec::new();
        while queues.iter().any(|q| !q.is_empty()) {
            rng ^= rng << 13; rng ^= rng >> 7; rng ^= rng << 17;
            let live: Vec<usize> = (0..queues.len()).filter(|&i| !queues[i].is_empty()).collect();
            let i = live[(rng % live.len() as u64) as usize];
            let f = queues[i].remove(0);
            if let Some(e) = rx.push(&f, 0).unwrap() {
                got.push(e);
            }
        }
        prop_assert_eq!(got.len(), envs.len());
        for e in &envs {
            prop_assert!(got.contains(e));
        }
    }

    /// Any single bit flip in a single frame yields an error or a message that passes
    /// validation (the residual risk documented in SPEC.md); in a long message it is
    /// always an error.
    #[test]
    fn bit_flips(env in envelope(), mode in mode_strategy(), which in any::<usize>(), bit in 0u8..8) {
        let frames = Encoder::new(mode).encode(&env).unwrap();
        let fi = which % frames.len();
        let f = frames[fi];
        prop_assume!(!f.is_empty());
        let mut data = f.payload().to_vec();
        let bi = (which / frames.len()) % data.len();
        data[bi] ^= 1 << bit;
        let mut frames = frames.to_vec();
        frames[fi] = CanFrame::new_checked(f.raw_id(), &data, f.is_fd()).unwrap();
        let results = decode_all(&frames);
        let kind = env.msg.kind();
        for r in &results {
            if let Ok(Some(e)) = r {
                prop_assert!(kind.is_single_frame(), "long message accepted after a bit flip");
                prop_assert!(e.msg.validate().is_ok());
            }
        }
        if !kind.is_single_frame() {
            prop_assert!(results.iter().all(|r| !matches!(r, Ok(Some(_)))));
        }
    }

    /// Random bytes on random ids never panic and never yield an invalid message.
    #[test]
    fn random_frames_never_panic(id in 0u16..0x800, data in proptest::collection::vec(any::<u8>(), 0..=8)) {
        let f = CanFrame::classic(id, &data).unwrap();
        let mut rx: Reassembler = Reassembler::new(100);
        if let Ok(Some(e)) = rx.push(&f, 0) {
            prop_assert!(e.msg.validate().is_ok());
            prop_assert_eq!(e.can_id().unwrap().raw(), id);
        }
    }
}

#[test]
fn out_of_range_values_are_rejected_on_encode_and_decode() {
    let servo = NodeId::servo(0).unwrap();
    let bad = Envelope::new(servo, PressureCommand { seq: 0, raw: 4096 }.into());
    let mut frames = Frames::new();
    assert_eq!(
        encode(&bad, BusMode::Classic, 0, &mut frames),
        Err(Error::OutOfRange("raw"))
    );
    // Hand-made frame with raw = 4096.
    let f = CanFrame::classic(0x082, &[0, 0, 0x00, 0x10]).unwrap();
    let mut rx: Reassembler = Reassembler::new(100);
    assert_eq!(rx.push(&f, 0), Err(Error::OutOfRange("raw")));
    // NaN target.
    let nan = Envelope::new(
        NodeId::Controller,
        Stage2Target {
            trial: 1,
            learn: true,
            grasp: false,
            fine_moves: trn_protocol::FINE_MOVES_POLICY,
            c: [f32::NAN, 0.0, 0.0, 0.0],
        }
        .into(),
    );
    assert_eq!(
        encode(&nan, BusMode::Fd, 0, &mut frames),
        Err(Error::OutOfRange("c"))
    );
    // A fine-move budget beyond the limit.
    let budget = Envelope::new(
        NodeId::Controller,
        Stage2Target {
            trial: 1,
            learn: false,
            grasp: false,
            fine_moves: trn_protocol::FINE_MOVES_MAX + 1,
            c: [0.0; 4],
        }
        .into(),
    );
    assert_eq!(
        encode(&budget, BusMode::Fd, 0, &mut frames),
        Err(Error::OutOfRange("fine_moves"))
    );
    // Wrong node for the kind.
    let wrong = Envelope::new(NodeId::Gripper, PressureCommand { seq: 0, raw: 1 }.into());
    assert!(matches!(
        encode(&wrong, BusMode::Classic, 0, &mut frames),
        Err(Error::NodeNotAllowed { .. })
    ));
    // Invalid bool byte.
    let f = CanFrame::classic(0x0AA, &[2]).unwrap();
    assert_eq!(rx.push(&f, 0), Err(Error::Decode));
    // Unknown kind, reserved node.
    assert_eq!(
        rx.push(&CanFrame::classic(0x7F1, &[]).unwrap(), 0),
        Err(Error::UnknownKind(0x7F))
    );
    assert_eq!(
        rx.push(&CanFrame::classic(0x700, &[0, 0]).unwrap(), 0),
        Err(Error::InvalidNode(0))
    );
}

#[test]
fn wire_lengths_are_exact_and_documented() {
    // The table in SPEC.md.
    let expected: &[(MessageKind, usize)] = &[
        (MessageKind::Emergency, 1),
        (MessageKind::SafeStateEntered, 4),
        (MessageKind::PressureCommand, 4),
        (MessageKind::ServoStatus, 8),
        (MessageKind::GripperCommand, 1),
        (MessageKind::GripperStatus, 1),
        (MessageKind::CaptureRequest, 3),
        (MessageKind::Observation, 39),
        (MessageKind::ModeChange, 1),
        (MessageKind::SessionConfig, 17),
        (MessageKind::SupervisedPressure, 24),
        (MessageKind::Stage1Target, 39),
        (MessageKind::Stage2Target, 23),
        (MessageKind::GraspRequest, 4),
        (MessageKind::TrialReport, 15),
        (MessageKind::ErrorReport, 6),
        (MessageKind::Heartbeat, 2),
        (MessageKind::ConfirmedSessionConfig, 21),
        (MessageKind::GuardRequest, 1),
        (MessageKind::GuardNonce, 7),
        (MessageKind::StoreCommand, 5),
        (MessageKind::TablesStatus, 21),
        (MessageKind::TableWriteBegin, 16),
        (MessageKind::TableWriteEnd, 4),
        (MessageKind::TableReadRequest, 2),
        (MessageKind::TableReadChunk, 50),
        (MessageKind::TableWriteChunk, 50),
        (MessageKind::TableWriteAck, 6),
    ];
    assert_eq!(expected.len(), MessageKind::ALL.len());
    for &(k, n) in expected {
        assert_eq!(k.wire_len(), n, "{k:?}");
    }
}

/// A `SessionConfig` with a meaningless code or image size never reaches a node.
#[test]
fn session_config_values_are_range_checked() {
    let ok = SessionConfig {
        seed: 1,
        preset: 0,
        ablation: 0,
        image_width: 1024,
        image_height: 768,
        fd: false,
        keep_tables: false,
        law: 0,
    };
    let mut frames = Frames::new();
    for (bad, field) in [
        (
            SessionConfig {
                preset: PRESET_CODES,
                ..ok
            },
            "preset",
        ),
        (
            SessionConfig {
                ablation: ABLATION_CODES,
                ..ok
            },
            "ablation",
        ),
        (
            SessionConfig {
                law: LAW_CODES,
                ..ok
            },
            "law",
        ),
        (
            SessionConfig {
                image_width: 0,
                ..ok
            },
            "image_width",
        ),
        (
            SessionConfig {
                image_height: IMAGE_SIDE_MAX + 1,
                ..ok
            },
            "image_height",
        ),
    ] {
        let env = Envelope::new(NodeId::Controller, bad.into());
        assert_eq!(
            encode(&env, BusMode::Fd, 0, &mut frames),
            Err(Error::OutOfRange(field))
        );
    }
    let env = Envelope::new(NodeId::Controller, ok.into());
    assert!(encode(&env, BusMode::Fd, 0, &mut frames).is_ok());
    // the confirmed form checks the same ranges
    let bad = ConfirmedSessionConfig {
        config: SessionConfig {
            law: LAW_CODES,
            ..ok
        },
        nonce: 7,
    };
    let env = Envelope::new(NodeId::Controller, bad.into());
    assert_eq!(
        encode(&env, BusMode::Classic, 0, &mut frames),
        Err(Error::OutOfRange("law"))
    );
}

/// A chunk's bytes cross the wire in order: the layout SPEC.md gives (index LE, then the
/// 56 bytes), and a short slice is zero-padded.
#[test]
fn a_table_chunk_is_its_index_then_its_bytes() {
    let bytes: Vec<u8> = (0..CHUNK as u8).collect();
    let m = TableReadChunk {
        index: 0x0102,
        data: ChunkData::new(&bytes),
    };
    let env = Envelope::new(NodeId::Controller, m.into());
    let mut frames = Frames::new();
    encode(&env, BusMode::Fd, 0, &mut frames).unwrap();
    let p = frames[0].payload();
    assert_eq!(frames[0].raw_id(), 0x791);
    assert_eq!(&p[..2], &[0x02, 0x01]);
    assert_eq!(&p[2..50], &bytes[..]);
    assert_eq!(m.data.bytes().to_vec(), bytes);
    let short = ChunkData::new(&[7, 8, 9]).bytes();
    assert_eq!(short[..3], [7, 8, 9]);
    assert!(short[3..].iter().all(|&b| b == 0));
    assert_eq!(chunk_count(48), 1);
    assert_eq!(chunk_count(49), 2);
}
