//! Why a trial failed: the failure of a trial record (the target out of sight, no answer,
//! an abort and the error that caused it, fewer moves than the budget), as a cause that
//! counts together in tables and the detail particular to the trial.

use trn_node::codes;

use crate::records::TrialRecord;
use crate::scoring;

/// Why a trial failed: its cause (what counts together in tables) and what is particular
/// to this trial (a sequence number, an error's detail).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Failure {
    /// The kind of failure, without numbers particular to the trial.
    pub cause: String,
    /// What is particular to it.
    pub detail: Option<String>,
}

impl Failure {
    fn of(cause: impl Into<String>) -> Failure {
        Failure {
            cause: cause.into(),
            detail: None,
        }
    }

    fn with(cause: impl Into<String>, detail: String) -> Failure {
        Failure {
            cause: cause.into(),
            detail: Some(detail),
        }
    }

    /// The cause with its detail.
    pub fn reason(&self) -> String {
        match &self.detail {
            Some(d) => format!("{} ({d})", self.cause),
            None => self.cause.clone(),
        }
    }
}

/// Why a trial failed, or `None`. With a fixed budget, a trial that made fewer moves than
/// asked (its readings invalid) failed too.
pub fn failure(r: &TrialRecord) -> Option<Failure> {
    if !r.target_seen {
        return Some(Failure::of("target not visible from the twin arm"));
    }
    if r.gave_up {
        return Some(Failure::of(
            "no answer from the controller to the target and its repeats",
        ));
    }
    if r.aborted {
        // the reason is the error the controller sent right before the abort; refusals of
        // a lost half of the trial's start (`OUT_OF_ORDER`, `MISSING_SUPERVISION`) and a
        // gripper's time-out of an earlier grasp abort nothing, and a reason lost on the
        // bus leaves only the abort
        let reason = r.errors.iter().rev().find(|(c, _)| codes::aborts_trial(*c));
        return Some(match reason {
            Some((codes::INVALID_OBSERVATION, d)) => {
                let status = ["valid", "out of view", "occluded", "not detected"];
                let s = status.get((d & 0xFF) as usize).unwrap_or(&"invalid");
                Failure::of(format!("lost light: point {} {s}", d >> 8))
            }
            Some((codes::OBSERVATION_TIMEOUT, d)) => {
                Failure::with("no observation for a capture", format!("capture {d}"))
            }
            Some((codes::CONTROLLER_ERROR, d)) => {
                Failure::of(format!("controller rejected an input ({d:#x})"))
            }
            Some((c, d)) => {
                Failure::with(format!("aborted, error {c:#06x}"), format!("detail {d}"))
            }
            None => Failure::of("aborted (its reason was lost on the bus)"),
        });
    }
    if r.fine_moves != trn_protocol::FINE_MOVES_POLICY {
        let want = r.fine_moves as usize + 1;
        let stages = [scoring::stage1(r), scoring::stage2(r)];
        for s in stages.iter().flatten() {
            if s.errors_px.len() < want {
                return Some(Failure::with(
                    "fewer moves than the budget",
                    format!("{} of {want} moves scored", s.errors_px.len()),
                ));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::records::{Phase, TrialKind};
    use trn_plant::targets::Target;

    fn aborted(errors: &[(u16, u32)]) -> TrialRecord {
        TrialRecord {
            trial: 7,
            kind: TrialKind::Grasp { learn: false },
            phase: Phase::Grasping,
            fine_moves: trn_protocol::FINE_MOVES_POLICY,
            target: Target::NONE,
            target_seen: true,
            captures: vec![],
            reports: vec![],
            errors: errors.to_vec(),
            aborted: true,
            gave_up: false,
            grasp: None,
            started_s: 0.0,
        }
    }

    /// The reason of an abort is the error sent right before it, not a refusal of a lost
    /// half of the start that came earlier in the same trial.
    #[test]
    fn an_abort_is_attributed_to_its_reason_not_to_an_earlier_refusal() {
        let occluded = (1 << 8) | 2; // point 1, `PointStatus::Occluded`
        let r = aborted(&[
            (codes::OUT_OF_ORDER, 7),
            (codes::INVALID_OBSERVATION, occluded),
            (codes::TRIAL_ABORTED, 7),
        ]);
        assert_eq!(
            failure(&r).unwrap().reason(),
            "lost light: point 1 occluded"
        );
        let r = aborted(&[(codes::OUT_OF_ORDER, 7), (codes::TRIAL_ABORTED, 7)]);
        assert_eq!(
            failure(&r).unwrap().reason(),
            "aborted (its reason was lost on the bus)"
        );
        let r = aborted(&[
            (codes::SERVO_TIMEOUT, (3 << 16) | 12),
            (codes::TRIAL_ABORTED, 7),
        ]);
        let f = failure(&r).unwrap();
        assert_eq!(
            f.cause,
            format!("aborted, error {:#06x}", codes::SERVO_TIMEOUT)
        );
        assert_eq!(f.detail, Some(format!("detail {}", (3 << 16) | 12)));
    }
}
