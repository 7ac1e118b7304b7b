//! Random valid messages in every mode, with a plant answering the node's requests: the
//! tables change only inside a trial that learns, through the confirmed (nonce) path, or
//! while they never learned (nothing to lose). Nothing panics.

mod common;

use std::collections::HashMap;

use common::*;
use proptest::prelude::*;
use trn_protocol::{
    ChunkData, ConfirmedSessionConfig, Emergency, EmergencyReason, GraspRequest, GuardOp,
    GuardRequest, Message, Mode, ModeChange, SessionConfig, Stage1Target, Stage2Target,
    StoreCommand, StoreOp, SupervisedPressure, TableReadRequest, TableWriteBegin, TableWriteChunk,
    TableWriteEnd,
};

#[derive(Debug, Clone)]
enum Action {
    /// A message to the controller.
    Send(Message),
    /// The plant answers what the node asked last.
    Answer,
    /// A nonce requested and a re-seeding configuration confirmed with it.
    ConfirmedReseed(SessionConfig),
    /// Time passes (timers, saves).
    Wait(u16),
}

fn config() -> impl Strategy<Value = SessionConfig> {
    (
        0u64..4,
        any::<bool>(),
        0u8..3,
        0u8..5,
        0u8..3,
        any::<bool>(),
    )
        .prop_map(
            |(seed, keep_tables, preset, ablation, law, default_image)| SessionConfig {
                seed,
                keep_tables,
                preset,
                ablation,
                law,
                image_width: if default_image { 1024 } else { 640 },
                image_height: if default_image { 768 } else { 480 },
                fd: false,
            },
        )
}

fn lights() -> impl Strategy<Value = [f32; 8]> {
    proptest::array::uniform8(340.0f32..460.0)
}

fn message() -> impl Strategy<Value = Message> {
    let mode = prop_oneof![
        Just(Mode::Idle),
        Just(Mode::Priming),
        Just(Mode::Training),
        Just(Mode::Mature)
    ];
    let op = prop_oneof![
        Just(GuardOp::Reseed),
        Just(GuardOp::TableWrite),
        Just(GuardOp::StoreErase)
    ];
    let store_op = prop_oneof![
        Just(StoreOp::Status),
        Just(StoreOp::Save),
        Just(StoreOp::Erase)
    ];
    let fine = prop_oneof![0u8..3, Just(trn_protocol::FINE_MOVES_POLICY)];
    prop_oneof![
        mode.prop_map(|mode| ModeChange { mode }.into()),
        config().prop_map(Message::from),
        (config(), any::<u32>()).prop_map(|(config, nonce)| ConfirmedSessionConfig {
            config,
            nonce
        }
        .into()),
        op.prop_map(|op| GuardRequest { op }.into()),
        (store_op, any::<u32>()).prop_map(|(op, nonce)| StoreCommand { op, nonce }.into()),
        (0u16..4100).prop_map(|index| TableReadRequest { index }.into()),
        (any::<u32>(), 0u32..300_000, any::<u32>(), any::<u32>()).prop_map(
            |(nonce, image_len, image_crc, fingerprint)| TableWriteBegin {
                nonce,
                image_len,
                image_crc,
                fingerprint
            }
            .into()
        ),
        (0u16..4, any::<[u8; 8]>()).prop_map(|(index, b)| TableWriteChunk {
            index,
            data: ChunkData::new(&b)
        }
        .into()),
        any::<u32>().prop_map(|image_crc| TableWriteEnd { image_crc }.into()),
        (1u32..8, proptest::array::uniform5(-0.5f32..0.5))
            .prop_map(|(trial, p)| SupervisedPressure { trial, p }.into()),
        (
            1u32..8,
            any::<bool>(),
            any::<bool>(),
            fine.clone(),
            lights()
        )
            .prop_map(|(trial, learn, grasp, fine_moves, v)| Stage1Target {
                trial,
                learn,
                grasp,
                fine_moves,
                v
            }
            .into()),
        (
            1u32..8,
            any::<bool>(),
            any::<bool>(),
            fine,
            proptest::array::uniform4(340.0f32..460.0)
        )
            .prop_map(|(trial, learn, grasp, fine_moves, c)| Stage2Target {
                trial,
                learn,
                grasp,
                fine_moves,
                c
            }
            .into()),
        (1u32..8).prop_map(|trial| GraspRequest { trial }.into()),
        Just(
            Emergency {
                reason: EmergencyReason::Operator
            }
            .into()
        ),
    ]
}

fn action() -> impl Strategy<Value = Action> {
    prop_oneof![
        6 => message().prop_map(Action::Send),
        6 => Just(Action::Answer),
        1 => config().prop_map(|c| Action::ConfirmedReseed(SessionConfig { keep_tables: false, ..c })),
        1 => (1u16..600).prop_map(Action::Wait),
    ]
}

proptest! {
    // a fixed seed: the same cases every run (the failures found so far are replayed first
    // from tables_property.proptest-regressions)
    #![proptest_config(ProptestConfig {
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x007A_B1E5),
        ..ProptestConfig::with_cases(48)
    })]

    #[test]
    fn tables_change_only_in_a_learning_trial_or_through_the_nonce(
        actions in proptest::collection::vec(action(), 1..40)
    ) {
        let (mut n, mut b) = booted_board(61, 3);
        let mut plant = Plant::new();
        let mut last_out = trn_node::Outbox::new();
        let mut now = 0u32;
        // a grasp's learn flag (its Stage1Target's), and whether each trial started may learn:
        // its target asked to and the mode was not Mature
        let mut grasp_learn: HashMap<u32, bool> = HashMap::new();
        let mut may_learn: HashMap<u32, bool> = HashMap::new();
        // the trial of the last SupervisedPressure sent: a Stage1Target of that trial is a
        // priming trial and learns whatever its learn flag says (SPEC 3.1). Forgotten only
        // when a stage-1 target starts a trial (the node takes it then), so it may
        // outlive the node's (which a new session drops): it only ever allows more.
        let mut supervised: Option<u32> = None;
        for a in actions {
            now += 1;
            let before = image(&b.ctrl);
            let trained = b.ctrl.stage1().learning_step() + b.ctrl.stage2().learning_step() > 0;
            let trial_before = n.trial();
            let mode_before = n.mode();
            let mut out = trn_node::Outbox::new();
            let mut confirmed = false;
            match &a {
                Action::Send(m) => {
                    if let Message::Stage1Target(t) = m {
                        if t.grasp {
                            grasp_learn.insert(t.trial, t.learn);
                        }
                    }
                    if let Message::SupervisedPressure(s) = m {
                        supervised = Some(s.trial);
                    }
                    n.on_message(&mut b, &to_ctrl(*m), now, &mut out);
                    if let Some(t) = n.trial().filter(|t| trial_before != Some(*t)) {
                        let asked = match m {
                            Message::Stage1Target(s) => {
                                let primed = supervised.take() == Some(t);
                                s.learn || primed
                            }
                            Message::Stage2Target(s) if s.grasp => {
                                grasp_learn.get(&t).copied().unwrap_or(true)
                            }
                            Message::Stage2Target(s) => s.learn,
                            _ => true,
                        };
                        may_learn.insert(t, asked && mode_before != Mode::Mature);
                    }
                }
                Action::Answer => {
                    for env in plant.answer(&last_out) {
                        n.on_message(&mut b, &env, now, &mut out);
                    }
                }
                Action::ConfirmedReseed(c) => {
                    let got = send(&mut n, &mut b, GuardRequest { op: GuardOp::Reseed }.into(), now);
                    let nonce = got.iter().find_map(|e| match e.msg {
                        Message::GuardNonce(g) => Some(g.nonce),
                        _ => None,
                    });
                    if let Some(nonce) = nonce {
                        let m = ConfirmedSessionConfig { config: *c, nonce };
                        n.on_message(&mut b, &to_ctrl(m.into()), now, &mut out);
                        confirmed = true;
                    }
                }
                Action::Wait(ms) => {
                    now += *ms as u32;
                    n.poll(&mut b, now, &mut out);
                }
            }
            let in_learning_trial = [trial_before, n.trial()]
                .into_iter()
                .flatten()
                .any(|t| may_learn.get(&t).copied().unwrap_or(false));
            if image(&b.ctrl) != before {
                prop_assert!(
                    in_learning_trial || confirmed || !trained,
                    "tables changed outside a learning trial and without a nonce: {:?}", a
                );
            }
            if !out.is_empty() {
                last_out = out;
            }
        }
    }
}
