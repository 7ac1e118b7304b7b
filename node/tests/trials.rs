//! The controller node at message level, a trial at a time: a supervised trial, bad
//! observations, lost frames, non-finite targets, a grasp, a move a drive did not make.

mod common;

use common::trial::*;
use trn_node::{codes, NodeConfig, Outbox};
use trn_protocol::{
    CaptureKind, Envelope, GraspRequest, Message, NodeId, Observation, PixelPoint, PointStatus,
    SafeState, Stage1Target, Stage2Target, SupervisedPressure,
};

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

/// A `SupervisedPressure` belongs to the session it came in: a new session's configuration,
/// or `Idle` (the session's end), drops one no target took, so a later session's trial of
/// the same number is not taught the old session's pressures (it reports stage 1, not the
/// supervised stage 0).
#[test]
fn a_supervised_pressure_does_not_outlive_its_session() {
    use trn_protocol::{Mode, ModeChange};
    let stage_of_trial_7 = |end_session: Message| {
        let (mut c, mut n) = setup();
        let mut out = Outbox::new();
        let supervised = SupervisedPressure {
            trial: 7,
            p: [0.1; 5],
        };
        n.on_message(&mut c, &to_ctrl(supervised.into()), 0, &mut out);
        n.on_message(&mut c, &to_ctrl(end_session), 0, &mut out);
        n.on_message(
            &mut c,
            &to_ctrl(common::session(3, false).into()),
            0,
            &mut out,
        );
        out.clear();
        let target = Stage1Target {
            trial: 7,
            learn: true,
            grasp: false,
            fine_moves: trn_protocol::FINE_MOVES_POLICY,
            v: V,
        };
        n.on_message(&mut c, &to_ctrl(target.into()), 0, &mut out);
        let mut seq = capture(&mut n, &mut c, &out, 5).0;
        for _ in 0..10 {
            out.clear();
            n.on_message(&mut c, &lights(seq, &V), 10, &mut out);
            if let Some(r) = reports(&out).first() {
                return r.stage;
            }
            seq = capture(&mut n, &mut c, &out, 5).0;
        }
        panic!("no report");
    };
    // another session's configuration; the session's end
    assert_eq!(stage_of_trial_7(common::session(2, false).into()), 1);
    assert_eq!(stage_of_trial_7(ModeChange { mode: Mode::Idle }.into()), 1);
}
