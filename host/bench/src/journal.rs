//! Reading a controller's messages back: the moves it made (commands and the capture that
//! closes each), its reports, errors and gripper commands, and its heartbeats. Pure
//! functions over a journal of received messages, so every rule the conformance suite
//! checks is unit-tested on hand-made journals here.

use trn_protocol::{CaptureKind, Envelope, ErrorReport, Message, NodeId, NodeState, TrialReport};

/// One move: the pressure commands of one sequence number and the capture that closes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Move {
    /// The capture request's `seq`.
    pub seq: u16,
    /// What was captured.
    pub what: CaptureKind,
    /// `(joint, seq, raw)` of each command before the capture (repeats counted once).
    pub commands: Vec<(u8, u16, u16)>,
}

impl Move {
    /// The joints commanded, ascending.
    pub fn joints(&self) -> Vec<u8> {
        let mut j: Vec<u8> = self.commands.iter().map(|c| c.0).collect();
        j.sort_unstable();
        j.dedup();
        j
    }

    /// The raw command of each joint commanded, by joint.
    pub fn raws(&self) -> Vec<(u8, u16)> {
        let mut r: Vec<(u8, u16)> = self.commands.iter().map(|c| (c.0, c.2)).collect();
        r.sort_unstable();
        r
    }
}

/// The moves in a journal, in order. A repeated command (same joint and `seq`) or capture
/// (same `seq`) is counted once.
pub fn moves(journal: &[Envelope]) -> Vec<Move> {
    let mut done: Vec<Move> = Vec::new();
    let mut pending: Vec<(u8, u16, u16)> = Vec::new();
    for env in journal {
        match (env.node, env.msg) {
            (NodeId::Servo(j), Message::PressureCommand(c)) => {
                let key = (j.index(), c.seq);
                if !pending.iter().any(|p| (p.0, p.1) == key)
                    && done.last().is_none_or(|m| m.seq != c.seq)
                {
                    pending.push((j.index(), c.seq, c.raw));
                }
            }
            (NodeId::CameraProcessor, Message::CaptureRequest(r)) => {
                if done.last().is_some_and(|m| m.seq == r.seq) {
                    continue;
                }
                done.push(Move {
                    seq: r.seq,
                    what: r.what,
                    commands: std::mem::take(&mut pending),
                });
            }
            _ => {}
        }
    }
    done
}

/// The controller's trial reports, in order.
pub fn reports(journal: &[Envelope]) -> Vec<TrialReport> {
    journal
        .iter()
        .filter_map(|e| match (e.node, e.msg) {
            (NodeId::Controller, Message::TrialReport(r)) => Some(r),
            _ => None,
        })
        .collect()
}

/// The controller's error reports, in order.
pub fn errors(journal: &[Envelope]) -> Vec<ErrorReport> {
    journal
        .iter()
        .filter_map(|e| match (e.node, e.msg) {
            (NodeId::Controller, Message::ErrorReport(r)) => Some(r),
            _ => None,
        })
        .collect()
}

/// Whether the controller reported the error `code` with `detail`.
pub fn has_error(journal: &[Envelope], code: u16, detail: u32) -> bool {
    errors(journal)
        .iter()
        .any(|e| e.code == code && e.detail == detail)
}

/// Whether a `SessionConfig` was sent in the journal (a configuration acknowledged).
pub fn echoed(journal: &[Envelope]) -> bool {
    journal
        .iter()
        .any(|e| matches!(e.msg, Message::SessionConfig(_)))
}

/// A problem when the error `code` (named `name`) with `detail` was not reported.
pub fn missing_error(journal: &[Envelope], code: u16, detail: u32, name: &str) -> Option<String> {
    (!has_error(journal, code, detail)).then(|| {
        format!(
            "errors {:?}, expected {name} (detail {detail:#x})",
            errors(journal)
        )
    })
}

/// The problems of a configuration that must be refused with `code` and `detail` (named
/// `name`) and not acknowledged.
pub fn refused_unacknowledged(
    journal: &[Envelope],
    code: u16,
    detail: u32,
    name: &str,
) -> Vec<String> {
    let mut p: Vec<String> = missing_error(journal, code, detail, name)
        .into_iter()
        .collect();
    if echoed(journal) {
        p.push("the configuration was acknowledged".into());
    }
    p
}

/// Positions in the journal of the gripper commands, with `close`.
pub fn gripper_commands(journal: &[Envelope]) -> Vec<(usize, bool)> {
    journal
        .iter()
        .enumerate()
        .filter_map(|(i, e)| match e.msg {
            Message::GripperCommand(g) => Some((i, g.close)),
            _ => None,
        })
        .collect()
}

/// The problems of a move sequence: a move whose commands carry another `seq` than its
/// capture, a `seq` that does not advance by one per move, joints other than `joints`, or a
/// capture of another kind than `what`.
pub fn move_problems(moves: &[Move], joints: &[u8], what: CaptureKind) -> Vec<String> {
    let mut out = Vec::new();
    for (i, m) in moves.iter().enumerate() {
        if m.commands.iter().any(|c| c.1 != m.seq) {
            out.push(format!(
                "move {i}: commands with another seq than its capture {}",
                m.seq
            ));
        }
        if m.joints() != joints {
            out.push(format!(
                "move {i}: joints {:?}, expected {joints:?}",
                m.joints()
            ));
        }
        if m.what != what {
            out.push(format!(
                "move {i}: captured {:?}, expected {what:?}",
                m.what
            ));
        }
        if i > 0 && m.seq != moves[i - 1].seq.wrapping_add(1) {
            out.push(format!(
                "move {i}: seq {} after {}: one counter, +1 per move",
                m.seq,
                moves[i - 1].seq
            ));
        }
    }
    out
}

/// The problems of the controller's heartbeats: none at all, a state other than
/// `Operational`, or a counter that does not advance by one (on a fault-free bus).
pub fn heartbeat_problems(journal: &[Envelope]) -> Vec<String> {
    let beats: Vec<_> = journal
        .iter()
        .filter_map(|e| match (e.node, e.msg) {
            (NodeId::Controller, Message::Heartbeat(h)) => Some(h),
            _ => None,
        })
        .collect();
    let mut out = Vec::new();
    if beats.is_empty() {
        out.push("no heartbeat".to_string());
    }
    if let Some(h) = beats.iter().find(|h| h.state != NodeState::Operational) {
        out.push(format!("state {:?}, expected Operational", h.state));
    }
    if let Some(w) = beats
        .windows(2)
        .find(|w| w[1].counter != w[0].counter.wrapping_add(1))
    {
        out.push(format!("counter {} after {}", w[1].counter, w[0].counter));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use trn_protocol::{CaptureRequest, Heartbeat, Joint, PressureCommand};

    fn cmd(joint: u8, seq: u16, raw: u16) -> Envelope {
        Envelope::new(
            NodeId::Servo(Joint::new(joint).unwrap()),
            PressureCommand { seq, raw }.into(),
        )
    }

    fn cap(seq: u16) -> Envelope {
        Envelope::new(
            NodeId::CameraProcessor,
            CaptureRequest {
                seq,
                what: CaptureKind::GripperCentre,
            }
            .into(),
        )
    }

    fn beat(counter: u8) -> Envelope {
        Envelope::new(
            NodeId::Controller,
            Heartbeat {
                counter,
                state: NodeState::Operational,
            }
            .into(),
        )
    }

    #[test]
    fn moves_count_repeats_once_and_keep_order() {
        let j = [
            cmd(0, 7, 100),
            cmd(1, 7, 200),
            cmd(0, 7, 100), // a repeat
            cap(7),
            cap(7), // a repeated capture
            cmd(2, 8, 300),
            cap(8),
        ];
        let m = moves(&j);
        assert_eq!(m.len(), 2);
        assert_eq!(m[0].raws(), vec![(0, 100), (1, 200)]);
        assert_eq!(m[1].joints(), vec![2]);
    }

    #[test]
    fn move_rules_catch_wrong_joints_seq_and_kind() {
        let good = moves(&[cmd(0, 1, 5), cmd(1, 1, 5), cmd(2, 1, 5), cap(1)]);
        assert!(move_problems(&good, &[0, 1, 2], CaptureKind::GripperCentre).is_empty());
        // a stage-2 move that also commands the wrist
        let wrist = moves(&[cmd(0, 1, 5), cmd(3, 1, 5), cap(1)]);
        assert_eq!(
            move_problems(&wrist, &[0, 1, 2], CaptureKind::GripperCentre).len(),
            1
        );
        // commands of another seq than the capture, and a seq that jumps
        let seqs = moves(&[cmd(0, 1, 5), cap(2), cmd(0, 4, 5), cap(4)]);
        assert_eq!(
            move_problems(&seqs, &[0], CaptureKind::GripperCentre).len(),
            2
        );
        assert_eq!(
            move_problems(&good, &[0, 1, 2], CaptureKind::GripperLights).len(),
            1
        );
    }

    #[test]
    fn a_missing_error_is_a_problem_and_a_present_one_is_not() {
        let err = |code, detail| {
            Envelope::new(
                NodeId::Controller,
                trn_protocol::ErrorReport { code, detail }.into(),
            )
        };
        let j = [cap(1), err(0x0100, 7)];
        assert!(has_error(&j, 0x0100, 7));
        assert!(missing_error(&j, 0x0100, 7, "TRIAL_ABORTED").is_none());
        // another detail or another code is not it
        assert!(missing_error(&j, 0x0100, 8, "TRIAL_ABORTED").is_some());
        assert!(missing_error(&j, 0x0104, 7, "OUT_OF_ORDER").is_some());
    }

    #[test]
    fn heartbeat_rules_catch_gaps_and_absence() {
        assert!(heartbeat_problems(&[beat(254), beat(255), beat(0)]).is_empty());
        assert_eq!(heartbeat_problems(&[beat(1), beat(3)]).len(), 1);
        assert_eq!(heartbeat_problems(&[cap(1)]), vec!["no heartbeat"]);
    }
}
