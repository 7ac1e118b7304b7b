//! The controller node at message level: a trial, bad observations, lost frames, a grasp.

use trn_controller::{Config, Controller};
use trn_node::{codes, ControllerNode, NodeConfig, Outbox};
use trn_protocol::{
    CaptureKind, Envelope, GraspRequest, Message, NodeId, Observation, PixelPoint, PointStatus,
    SafeState, ServoStatus, Stage1Target, Stage2Target, SupervisedPressure,
};

const V: [f32; 8] = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
const C: [f32; 4] = [300.0, 200.0, 310.0, 210.0];

fn setup() -> (Box<Controller>, ControllerNode) {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(1);
    (c, ControllerNode::new(NodeConfig::default()))
}

fn to_ctrl(msg: Message) -> Envelope {
    Envelope::new(NodeId::Controller, msg)
}

fn lights(seq: u16, v: &[f32; 8]) -> Envelope {
    let p = |i: usize| PixelPoint::valid(v[2 * i], v[2 * i + 1]);
    let o = Observation {
        seq,
        what: CaptureKind::GripperLights,
        points: [p(0), p(1), p(2), p(3)],
    };
    Envelope::new(NodeId::CameraProcessor, o.into())
}

fn centre(seq: u16, c: &[f32; 4]) -> Envelope {
    let o = Observation::centre(
        seq,
        PixelPoint::valid(c[0], c[1]),
        PixelPoint::valid(c[2], c[3]),
    );
    Envelope::new(NodeId::CameraProcessor, o.into())
}

/// Every drive's confirmation of the pressure commands of `out`.
fn confirmations(out: &Outbox) -> Vec<Envelope> {
    out.iter()
        .filter_map(|e| match (e.node, e.msg) {
            (NodeId::Servo(j), Message::PressureCommand(p)) => Some(Envelope::new(
                NodeId::Servo(j),
                ServoStatus {
                    seq: p.seq,
                    raw: p.raw,
                    applied: p.raw,
                    saturated: false,
                    safe_state: SafeState::Normal,
                }
                .into(),
            )),
            _ => None,
        })
        .collect()
}

/// The capture request that follows the drives' confirmations of the pressure commands of
/// `out` (there must be `joints` of them, and no capture before they are confirmed).
fn capture(
    n: &mut ControllerNode,
    c: &mut Controller,
    out: &Outbox,
    joints: usize,
) -> (u16, CaptureKind) {
    let ok = confirmations(out);
    assert_eq!(ok.len(), joints, "{out:?}");
    assert!(
        !out.iter()
            .any(|e| matches!(e.msg, Message::CaptureRequest(_))),
        "no capture before the drives confirmed: {out:?}"
    );
    let mut after = Outbox::new();
    for env in &ok {
        n.on_message(c, env, 0, &mut after);
    }
    after
        .iter()
        .find_map(|e| match e.msg {
            Message::CaptureRequest(r) => Some((r.seq, r.what)),
            _ => None,
        })
        .expect("a capture request")
}

fn reports(out: &Outbox) -> Vec<trn_protocol::TrialReport> {
    out.iter()
        .filter_map(|e| match e.msg {
            Message::TrialReport(r) => Some(r),
            _ => None,
        })
        .collect()
}

fn errors(out: &Outbox) -> Vec<(u16, u32)> {
    out.iter()
        .filter_map(|e| match e.msg {
            Message::ErrorReport(r) => Some((r.code, r.detail)),
            _ => None,
        })
        .collect()
}

#[test]
fn a_supervised_trial_runs_to_its_report() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    n.on_message(
        &mut c,
        &to_ctrl(
            SupervisedPressure {
                trial: 7,
                p: [0.1; 5],
            }
            .into(),
        ),
        0,
        &mut out,
    );
    assert!(out.is_empty());
    n.on_message(
        &mut c,
        &to_ctrl(
            Stage1Target {
                trial: 7,
                learn: true,
                grasp: false,
                fine_moves: trn_protocol::FINE_MOVES_POLICY,
                v: V,
            }
            .into(),
        ),
        0,
        &mut out,
    );
    let (mut seq, what) = capture(&mut n, &mut c, &out, 5);
    assert_eq!(what, CaptureKind::GripperLights);
    // the arm lands on target at once: one fine move (always made while learning), then done
    for _ in 0..10 {
        out.clear();
        n.on_message(&mut c, &lights(seq, &V), 10, &mut out);
        let r = reports(&out);
        if let Some(r) = r.first() {
            assert_eq!(
                (r.trial, r.stage),
                (7, 0),
                "a supervised trial reports stage 0"
            );
            assert_eq!(r.final_error_px, 0.0);
            assert_eq!(n.trial(), None);
            return;
        }
        seq = capture(&mut n, &mut c, &out, 5).0;
    }
    panic!("no report");
}

#[test]
fn invalid_points_abort_the_trial_with_reasons() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    n.on_message(
        &mut c,
        &to_ctrl(
            Stage2Target {
                trial: 3,
                learn: true,
                grasp: false,
                fine_moves: trn_protocol::FINE_MOVES_POLICY,
                c: C,
            }
            .into(),
        ),
        0,
        &mut out,
    );
    let (seq, what) = capture(&mut n, &mut c, &out, 3);
    assert_eq!(what, CaptureKind::GripperCentre);
    out.clear();
    let mut bad = Observation::centre(
        seq,
        PixelPoint::valid(1.0, 2.0),
        PixelPoint::valid(3.0, 4.0),
    );
    bad.points[1].status = PointStatus::Occluded;
    n.on_message(
        &mut c,
        &Envelope::new(NodeId::CameraProcessor, bad.into()),
        5,
        &mut out,
    );
    assert_eq!(
        errors(&out),
        vec![
            (
                codes::INVALID_OBSERVATION,
                (1 << 8) | PointStatus::Occluded as u32
            ),
            (codes::TRIAL_ABORTED, 3)
        ]
    );
    assert!(!c.busy());
    // a late observation of the aborted trial is ignored
    out.clear();
    n.on_message(&mut c, &centre(seq, &C), 6, &mut out);
    assert!(out.is_empty());
    assert_eq!(n.stats().stale_answers, 1);
}

#[test]
fn stale_and_foreign_observations_are_ignored_and_lost_ones_retried() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    n.on_message(
        &mut c,
        &to_ctrl(
            Stage1Target {
                trial: 1,
                learn: false,
                grasp: false,
                fine_moves: trn_protocol::FINE_MOVES_POLICY,
                v: V,
            }
            .into(),
        ),
        0,
        &mut out,
    );
    let (seq, _) = capture(&mut n, &mut c, &out, 5);
    out.clear();
    n.on_message(&mut c, &lights(seq.wrapping_add(9), &V), 1, &mut out);
    n.on_message(&mut c, &centre(seq, &C), 1, &mut out);
    assert!(out.is_empty());
    assert_eq!(n.stats().stale_answers, 2);
    // the observation is lost: the capture is requested again (same seq) every timeout,
    // then, after the retries, the trial is aborted
    let t = NodeConfig::default().reply_timeout_ms;
    n.poll(&mut c, t - 1, &mut out);
    assert!(!out
        .iter()
        .any(|e| matches!(e.msg, Message::CaptureRequest(_))));
    out.clear();
    n.poll(&mut c, t, &mut out);
    assert!(out
        .iter()
        .any(|e| matches!(e.msg, Message::CaptureRequest(r) if r.seq == seq)));
    let retries = NodeConfig::default().retries as u32;
    for k in 2..=retries + 1 {
        out.clear();
        n.poll(&mut c, k * t, &mut out);
    }
    assert_eq!(
        errors(&out),
        vec![
            (codes::OBSERVATION_TIMEOUT, seq as u32),
            (codes::TRIAL_ABORTED, 1)
        ]
    );
    assert_eq!(n.stats().retries, retries);
}

#[test]
fn non_finite_targets_are_rejected_with_a_report() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    let mut v = V;
    v[2] = f32::INFINITY;
    // the protocol layer validates floats too; the node must cope if one gets through
    n.on_message(
        &mut c,
        &to_ctrl(
            Stage1Target {
                trial: 4,
                learn: true,
                grasp: false,
                fine_moves: trn_protocol::FINE_MOVES_POLICY,
                v,
            }
            .into(),
        ),
        0,
        &mut out,
    );
    assert_eq!(
        errors(&out),
        vec![(codes::CONTROLLER_ERROR, 0x102), (codes::TRIAL_ABORTED, 4)]
    );
}

#[test]
fn a_grasp_moves_stage_1_then_stage_2_then_closes() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    n.on_message(
        &mut c,
        &to_ctrl(GraspRequest { trial: 9 }.into()),
        0,
        &mut out,
    );
    n.on_message(
        &mut c,
        &to_ctrl(
            Stage1Target {
                trial: 9,
                learn: false,
                grasp: true,
                fine_moves: trn_protocol::FINE_MOVES_POLICY,
                v: V,
            }
            .into(),
        ),
        0,
        &mut out,
    );
    assert!(
        out.is_empty(),
        "the grasp starts once both targets are known"
    );
    n.on_message(
        &mut c,
        &to_ctrl(
            Stage2Target {
                trial: 9,
                learn: false,
                grasp: true,
                fine_moves: trn_protocol::FINE_MOVES_POLICY,
                c: C,
            }
            .into(),
        ),
        0,
        &mut out,
    );
    let (seq, what) = capture(&mut n, &mut c, &out, 5);
    assert_eq!(what, CaptureKind::GripperLights);
    out.clear();
    n.on_message(&mut c, &lights(seq, &V), 1, &mut out);
    let (seq, what) = capture(&mut n, &mut c, &out, 3);
    assert_eq!(what, CaptureKind::GripperCentre);
    out.clear();
    n.on_message(&mut c, &centre(seq, &C), 2, &mut out);
    let r = reports(&out);
    assert_eq!(r.iter().map(|r| r.stage).collect::<Vec<_>>(), vec![1, 2]);
    assert!(out
        .iter()
        .any(|e| matches!(e.msg, Message::GripperCommand(g) if g.close)));
}

#[test]
fn heartbeats_every_period() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    let mut beats = 0;
    for t in (0..1000).step_by(10) {
        out.clear();
        n.poll(&mut c, t, &mut out);
        beats += out
            .iter()
            .filter(|e| matches!(e.msg, Message::Heartbeat(_)))
            .count();
    }
    assert_eq!(beats, 10);
}

fn stage1(trial: u32) -> Envelope {
    to_ctrl(
        Stage1Target {
            trial,
            learn: false,
            grasp: false,
            fine_moves: trn_protocol::FINE_MOVES_POLICY,
            v: V,
        }
        .into(),
    )
}

/// A lost frame anywhere is repeated, a repeated target is recognised: the target repeated
/// while its trial runs starts nothing; a lost confirmation repeats the command (same seq);
/// a drive that applied another value (a corrupted command) gets the command again; the
/// target repeated after the trial ended gets the same report again. Fails if a repeat
/// starts a second trial, moves the arm twice or is dropped.
#[test]
fn repeats_are_recognised_and_lost_answers_requested_again() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    n.on_message(&mut c, &stage1(5), 0, &mut out);
    let first = out.clone();
    out.clear();
    n.on_message(&mut c, &stage1(5), 1, &mut out);
    assert!(out.is_empty(), "a repeated target starts nothing: {out:?}");
    assert_eq!(n.stats().trials, 1);
    assert_eq!(n.stats().repeated_targets, 1);
    // confirm 4 drives; drive 2 answers with another value, then not at all
    let ok = confirmations(&first);
    for (j, env) in ok.iter().enumerate() {
        let mut env = *env;
        if j == 2 {
            let Message::ServoStatus(mut s) = env.msg else {
                panic!()
            };
            s.applied = (s.applied + 1) % 4096;
            env.msg = s.into();
        }
        n.on_message(&mut c, &env, 2, &mut out);
    }
    assert_eq!(n.stats().corrected_commands, 1);
    let again: Vec<_> = out
        .iter()
        .filter(|e| matches!(e.msg, Message::PressureCommand(_)))
        .collect();
    assert_eq!(
        again.len(),
        1,
        "the corrupted command is sent again: {out:?}"
    );
    assert!(!out
        .iter()
        .any(|e| matches!(e.msg, Message::CaptureRequest(_))));
    out.clear();
    n.poll(&mut c, NodeConfig::default().reply_timeout_ms + 2, &mut out);
    assert_eq!(
        out.iter()
            .filter(|e| matches!(e.msg, Message::PressureCommand(_)))
            .count(),
        1,
        "only the unconfirmed drive is asked again"
    );
    // now drive 2 confirms: the capture follows
    let mut after = Outbox::new();
    n.on_message(&mut c, &ok[2], 3, &mut after);
    let seq = after
        .iter()
        .find_map(|e| match e.msg {
            Message::CaptureRequest(r) => Some(r.seq),
            _ => None,
        })
        .expect("capture after the last confirmation");
    // on target at once: the report
    after.clear();
    n.on_message(&mut c, &lights(seq, &V), 4, &mut after);
    let report = reports(&after);
    assert_eq!(report.len(), 1);
    // the report was lost: the runner repeats the target, and gets it again
    out.clear();
    n.on_message(&mut c, &stage1(5), 5, &mut out);
    assert_eq!(reports(&out), report);
    assert_eq!(n.stats().trials, 1);
}

/// A drive in its safe state did not apply the command: nothing is learned from the move,
/// the trial is aborted with the reason.
#[test]
fn a_move_a_drive_did_not_make_is_not_trusted() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    n.on_message(&mut c, &stage1(6), 0, &mut out);
    let ok = confirmations(&out);
    out.clear();
    let Message::ServoStatus(mut s) = ok[1].msg else {
        panic!()
    };
    s.safe_state = SafeState::HoldLast;
    n.on_message(&mut c, &Envelope::new(ok[1].node, s.into()), 1, &mut out);
    assert_eq!(
        errors(&out),
        vec![
            (codes::SERVO_NOT_NORMAL, 1 << 8 | 1),
            (codes::TRIAL_ABORTED, 6)
        ]
    );
    assert!(!c.busy());
}

/// A mode change is acknowledged to every node with the mode now in force.
#[test]
fn mode_changes_are_echoed() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    let m = trn_protocol::ModeChange {
        mode: trn_protocol::Mode::Mature,
    };
    n.on_message(&mut c, &to_ctrl(m.into()), 0, &mut out);
    assert_eq!(
        out.as_slice(),
        &[Envelope::new(NodeId::Broadcast, m.into())]
    );
}

fn session(keep_tables: bool, law: u8, seed: u64) -> Envelope {
    to_ctrl(
        trn_protocol::SessionConfig {
            seed,
            preset: 0,
            ablation: 0,
            image_width: 1024,
            image_height: 768,
            fd: false,
            keep_tables,
            law,
        }
        .into(),
    )
}

/// A configuration the controller cannot apply is refused with its reason and changes
/// nothing: kept tables learned under another configuration (here the paper preset's), a
/// control law this controller does not run (the host's model reference).
#[test]
fn session_configs_that_cannot_apply_are_refused_and_change_nothing() {
    let (mut c, mut n) = setup();
    c.set_config(Config::paper()).unwrap();
    let tables = c.stage1().net().clone();
    let mut out = Outbox::new();
    n.on_message(&mut c, &session(true, 0, 5), 0, &mut out);
    assert_eq!(
        errors(&out),
        vec![(codes::CONFIG_REJECTED, codes::CONFIG_MISMATCH)]
    );
    // valid, but not a law this controller runs
    let mut out = Outbox::new();
    n.on_message(&mut c, &session(false, 2, 5), 0, &mut out);
    assert_eq!(
        errors(&out),
        vec![(codes::CONFIG_REJECTED, codes::CONFIG_UNSUPPORTED)]
    );
    assert_eq!(*c.config(), Config::paper());
    assert!(
        *c.stage1().net() == tables,
        "a refused configuration re-seeded the tables"
    );
    assert!(n.session().is_none());
    // a configuration it can apply is acknowledged (echo to Broadcast) and seeds new tables
    let mut out = Outbox::new();
    n.on_message(&mut c, &session(false, 0, 5), 0, &mut out);
    assert!(errors(&out).is_empty());
    assert!(out
        .iter()
        .any(|e| e.node == NodeId::Broadcast && matches!(e.msg, Message::SessionConfig(_))));
    assert!(*c.stage1().net() != tables);
}
