//! Proptest strategies shared by the integration tests.
#![allow(dead_code)]

use proptest::prelude::*;
use trn_protocol::*;

pub fn px() -> impl Strategy<Value = f32> {
    -2000.0f32..2000.0
}

pub fn point() -> impl Strategy<Value = PixelPoint> {
    (
        px(),
        px(),
        prop_oneof![
            Just(PointStatus::Valid),
            Just(PointStatus::OutOfView),
            Just(PointStatus::Occluded),
            Just(PointStatus::NotDetected),
            Just(PointStatus::Estimated)
        ],
    )
        .prop_map(|(x, y, status)| PixelPoint { x, y, status })
}

pub fn capture_kind() -> impl Strategy<Value = CaptureKind> {
    prop_oneof![
        Just(CaptureKind::GripperLights),
        Just(CaptureKind::GripperCentre)
    ]
}

pub fn servo() -> impl Strategy<Value = NodeId> {
    (0u8..5).prop_map(|j| NodeId::servo(j).unwrap())
}

pub fn any_node() -> impl Strategy<Value = NodeId> {
    prop_oneof![
        Just(NodeId::Controller),
        servo(),
        Just(NodeId::CameraProcessor),
        Just(NodeId::Gripper),
        Just(NodeId::Runner)
    ]
}

fn safe_state() -> impl Strategy<Value = SafeState> {
    prop_oneof![
        Just(SafeState::Normal),
        Just(SafeState::HoldLast),
        Just(SafeState::Vented)
    ]
}

fn node_state() -> impl Strategy<Value = NodeState> {
    prop_oneof![
        Just(NodeState::Booting),
        Just(NodeState::Operational),
        Just(NodeState::SafeState),
        Just(NodeState::Fault)
    ]
}

fn mode() -> impl Strategy<Value = Mode> {
    prop_oneof![
        Just(Mode::Idle),
        Just(Mode::Priming),
        Just(Mode::Training),
        Just(Mode::Mature)
    ]
}

fn emergency_reason() -> impl Strategy<Value = EmergencyReason> {
    prop_oneof![
        Just(EmergencyReason::Operator),
        Just(EmergencyReason::HeartbeatLost),
        Just(EmergencyReason::PressureFault),
        Just(EmergencyReason::ControllerFault),
        Just(EmergencyReason::BusFault)
    ]
}

fn safe_reason() -> impl Strategy<Value = SafeStateReason> {
    prop_oneof![
        Just(SafeStateReason::HeartbeatLost),
        Just(SafeStateReason::Emergency),
        Just(SafeStateReason::Commanded)
    ]
}

fn safe_action() -> impl Strategy<Value = SafeStateAction> {
    prop_oneof![Just(SafeStateAction::HoldLast), Just(SafeStateAction::Vent)]
}

fn observation() -> impl Strategy<Value = Observation> {
    (
        any::<u16>(),
        capture_kind(),
        [point(), point(), point(), point()],
    )
        .prop_map(|(seq, what, points)| match what {
            CaptureKind::GripperLights => Observation { seq, what, points },
            CaptureKind::GripperCentre => Observation::centre(seq, points[0], points[1]),
        })
}

/// Any valid envelope of any kind, with a node the kind allows (each kind about equally
/// often).
pub fn envelope() -> impl Strategy<Value = Envelope> {
    prop_oneof![17 => first_kinds(), 11 => table_kinds()]
}

fn session_config() -> impl Strategy<Value = SessionConfig> {
    (
        any::<u64>(),
        0..PRESET_CODES,
        0..ABLATION_CODES,
        1..=IMAGE_SIDE_MAX,
        1..=IMAGE_SIDE_MAX,
        any::<bool>(),
        (any::<bool>(), 0..LAW_CODES),
    )
        .prop_map(
            |(seed, preset, ablation, image_width, image_height, fd, (keep_tables, law))| {
                SessionConfig {
                    seed,
                    preset,
                    ablation,
                    image_width,
                    image_height,
                    fd,
                    keep_tables,
                    law,
                }
            },
        )
}

fn guard_op() -> impl Strategy<Value = GuardOp> {
    prop_oneof![
        Just(GuardOp::Reseed),
        Just(GuardOp::TableWrite),
        Just(GuardOp::StoreErase)
    ]
}

fn chunk() -> impl Strategy<Value = ChunkData> {
    proptest::collection::vec(any::<u8>(), CHUNK).prop_map(|b| ChunkData::new(&b))
}

/// The guard's and the tables' kinds.
fn table_kinds() -> impl Strategy<Value = Envelope> {
    let ctrl = |m: Message| Envelope::new(NodeId::Controller, m);
    prop_oneof![
        (session_config(), any::<u32>())
            .prop_map(move |(config, nonce)| ctrl(ConfirmedSessionConfig { config, nonce }.into())),
        guard_op().prop_map(move |op| ctrl(GuardRequest { op }.into())),
        (guard_op(), any::<u32>(), any::<u16>()).prop_map(move |(op, nonce, window_ms)| ctrl(
            GuardNonce {
                op,
                nonce,
                window_ms
            }
            .into()
        )),
        (
            prop_oneof![
                Just(StoreOp::Status),
                Just(StoreOp::Save),
                Just(StoreOp::Erase)
            ],
            any::<u32>()
        )
            .prop_map(move |(op, nonce)| ctrl(StoreCommand { op, nonce }.into())),
        (
            prop_oneof![
                Just(TablesEvent::Status),
                Just(TablesEvent::Restored),
                Just(TablesEvent::NotRestored),
                Just(TablesEvent::Saved),
                Just(TablesEvent::Applied),
                Just(TablesEvent::Erased)
            ],
            any::<[u32; 5]>()
        )
            .prop_map(move |(event, v)| ctrl(
                TablesStatus {
                    event,
                    image_len: v[0],
                    fingerprint: v[1],
                    steps1: v[2],
                    steps2: v[3],
                    stored_sequence: v[4],
                }
                .into()
            )),
        any::<[u32; 4]>().prop_map(move |v| ctrl(
            TableWriteBegin {
                nonce: v[0],
                image_len: v[1],
                image_crc: v[2],
                fingerprint: v[3]
            }
            .into()
        )),
        any::<u32>().prop_map(move |image_crc| ctrl(TableWriteEnd { image_crc }.into())),
        any::<u16>().prop_map(move |index| ctrl(TableReadRequest { index }.into())),
        (any::<u16>(), chunk())
            .prop_map(move |(index, data)| ctrl(TableReadChunk { index, data }.into())),
        (any::<u16>(), chunk())
            .prop_map(move |(index, data)| ctrl(TableWriteChunk { index, data }.into())),
        (any::<u16>(), any::<u32>())
            .prop_map(move |(next, image_crc)| ctrl(TableWriteAck { next, image_crc }.into())),
    ]
}

/// The kinds of the first protocol versions.
fn first_kinds() -> impl Strategy<Value = Envelope> {
    let raw = 0u16..=4095;
    prop_oneof![
        (servo(), any::<u16>(), raw.clone())
            .prop_map(|(n, seq, raw)| Envelope::new(n, PressureCommand { seq, raw }.into())),
        (
            servo(),
            any::<u16>(),
            raw.clone(),
            any::<bool>(),
            safe_state(),
            raw.clone()
        )
            .prop_map(
                |(n, seq, raw, saturated, safe_state, applied)| Envelope::new(
                    n,
                    ServoStatus {
                        seq,
                        raw,
                        applied,
                        saturated,
                        safe_state
                    }
                    .into()
                )
            ),
        (any::<u16>(), capture_kind()).prop_map(|(seq, what)| Envelope::new(
            NodeId::CameraProcessor,
            CaptureRequest { seq, what }.into()
        )),
        observation().prop_map(|o| Envelope::new(NodeId::CameraProcessor, o.into())),
        (
            any::<u32>(),
            any::<bool>(),
            any::<bool>(),
            proptest::array::uniform8(px())
        )
            .prop_map(|(trial, learn, grasp, v)| Envelope::new(
                NodeId::Controller,
                Stage1Target {
                    trial,
                    learn,
                    grasp,
                    fine_moves: trn_protocol::FINE_MOVES_POLICY,
                    v
                }
                .into()
            )),
        (
            any::<u32>(),
            any::<bool>(),
            any::<bool>(),
            proptest::array::uniform4(px())
        )
            .prop_map(|(trial, learn, grasp, c)| Envelope::new(
                NodeId::Controller,
                Stage2Target {
                    trial,
                    learn,
                    grasp,
                    fine_moves: trn_protocol::FINE_MOVES_POLICY,
                    c
                }
                .into()
            )),
        (any::<u32>(), proptest::array::uniform5(-1.0f32..=1.0)).prop_map(|(trial, p)| {
            Envelope::new(NodeId::Controller, SupervisedPressure { trial, p }.into())
        }),
        any::<u32>()
            .prop_map(|trial| Envelope::new(NodeId::Controller, GraspRequest { trial }.into())),
        (
            any::<u32>(),
            0u8..=2,
            0.0f32..1e4,
            0.0f32..1e4,
            any::<u8>(),
            any::<bool>()
        )
            .prop_map(
                |(trial, stage, coarse_error_px, final_error_px, fine_moves, cap_hit)| {
                    Envelope::new(
                        NodeId::Controller,
                        TrialReport {
                            trial,
                            stage,
                            coarse_error_px,
                            final_error_px,
                            fine_moves,
                            cap_hit,
                        }
                        .into(),
                    )
                }
            ),
        any::<bool>()
            .prop_map(|close| Envelope::new(NodeId::Gripper, GripperCommand { close }.into())),
        any::<bool>()
            .prop_map(|closed| Envelope::new(NodeId::Gripper, GripperStatus { closed }.into())),
        (any_node(), any::<u8>(), node_state())
            .prop_map(|(n, counter, state)| Envelope::new(n, Heartbeat { counter, state }.into())),
        (
            prop_oneof![Just(NodeId::Controller), Just(NodeId::Broadcast)],
            mode()
        )
            .prop_map(|(n, mode)| Envelope::new(n, ModeChange { mode }.into())),
        (
            prop_oneof![Just(NodeId::Controller), Just(NodeId::Broadcast)],
            session_config()
        )
            .prop_map(|(n, c)| Envelope::new(n, c.into())),
        (any_node(), any::<u16>(), any::<u32>())
            .prop_map(|(n, code, detail)| Envelope::new(n, ErrorReport { code, detail }.into())),
        (any_node(), emergency_reason())
            .prop_map(|(n, reason)| Envelope::new(n, Emergency { reason }.into())),
        (any_node(), safe_reason(), safe_action(), raw).prop_map(
            |(n, reason, action, held_raw)| {
                Envelope::new(
                    n,
                    SafeStateEntered {
                        reason,
                        action,
                        held_raw,
                    }
                    .into(),
                )
            }
        ),
    ]
}

pub fn mode_strategy() -> impl Strategy<Value = BusMode> {
    prop_oneof![Just(BusMode::Classic), Just(BusMode::Fd)]
}
