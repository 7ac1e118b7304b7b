//! `Mature` (SPEC 3, 3.1, 3.2): a grasp and a repeat of its start, tables frozen whatever
//! a target says, configurations outside `Idle` (another refused, the one in force echoed).

use embedded_can::blocking::Can;
use trn_node::codes;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{CanFrame, CaptureKind, Envelope, GraspRequest, Message, Mode, SessionConfig};

use super::{nothing_moved, stage1, stage2, Suite, STAGE1_JOINTS, STAGE2_JOINTS};
use trn_bench::journal::{
    echoed, errors, gripper_commands, missing_error, move_problems, moves, reports, Move,
};
use trn_bench::Result;
use trn_plant::targets::Target;

const REPEATED_GRASP: &str = "A repeated start of the finished grasp is answered once: both reports and one GripperCommand{close}, no move";

impl<P> Suite<'_, P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    pub(super) fn mature(&mut self, session: SessionConfig) -> Result<()> {
        let mode = self.runner.mode(Mode::Mature);
        self.collect(|_| true, false)?;
        self.verdict(
            "ModeChange{Mature} is acknowledged",
            mode.err().map(|e| e.to_string()).into_iter().collect(),
        );

        // a grasp: stage 1, stage 2 from where it ended, both reports, then the close
        let t = self.target(true, 5)?;
        let trial = self.next_trial();
        self.runner.rig_mut().gripper_mut().open();
        self.send(GraspRequest { trial }.into())?;
        self.send(stage1(trial, &t, 1, true).into())?;
        self.send(stage2(trial, &t, 1, true).into())?;
        let closed = |j: &[Envelope]| !gripper_commands(j).is_empty();
        let j = self.collect(closed, false)?;
        let m = moves(&j);
        let (lights, centre): (Vec<_>, Vec<_>) = m
            .iter()
            .cloned()
            .partition(|m| m.what == CaptureKind::GripperLights);
        let mut p = move_problems(&lights, &STAGE1_JOINTS, CaptureKind::GripperLights);
        p.extend(move_problems(
            &centre,
            &STAGE2_JOINTS,
            CaptureKind::GripperCentre,
        ));
        if m.iter().position(|m| m.what == CaptureKind::GripperCentre)
            < m.iter().rposition(|m| m.what == CaptureKind::GripperLights)
        {
            p.push("a stage-2 move before the end of stage 1".into());
        }
        if (lights.len(), centre.len()) != (2, 2) {
            p.push(format!(
                "{} stage-1 and {} stage-2 moves, expected 2 and 2 (both stages use the Stage2Target's fine_moves: 1)",
                lights.len(),
                centre.len()
            ));
        }
        let stages: Vec<u8> = reports(&j).iter().map(|r| r.stage).collect();
        if stages != [1, 2] || reports(&j).iter().any(|r| r.trial != trial) {
            p.push(format!(
                "reports {:?}, expected stage 1 then stage 2",
                reports(&j)
            ));
        }
        let last_report = j
            .iter()
            .rposition(|e| matches!(e.msg, Message::TrialReport(_)));
        match gripper_commands(&j).first() {
            Some(&(i, true)) if last_report.is_some_and(|r| r < i) => {}
            other => p.push(format!(
                "gripper command {other:?}: GripperCommand{{close: true}} after both reports"
            )),
        }
        self.verdict(
            "Grasp: GraspRequest, Stage1Target{grasp}, Stage2Target{grasp}: stage-1 moves, then stage-2 moves, TrialReport stage 1 and 2, then GripperCommand{close}",
            p,
        );

        // the grasp's start repeated: its reports and one close again, no move
        self.repeated_grasp(trial, &t)?;

        // in Mature the tables are frozen: the same target from the same start pose gives the
        // same commands, whatever `learn` says (one move each: a fine move would depend on
        // the cameras' noise)
        let t = self.target(false, 5)?;
        let start = self.runner.rig().plant().random_pressures(&mut self.rng);
        let mut runs = Vec::new();
        for _ in 0..2 {
            {
                let mut plant = self.runner.rig_mut().plant_mut();
                plant.command(&start);
                plant.settle();
            }
            let trial = self.next_trial();
            let mut msg = stage1(trial, &t, 0, false);
            msg.learn = true;
            self.send(msg.into())?;
            let j = self.collect(Self::ended(trial, 1), false)?;
            runs.push(moves(&j).iter().map(Move::raws).collect::<Vec<_>>());
        }
        let mut p = Vec::new();
        if runs[0].is_empty() || runs[0] != runs[1] {
            p.push(format!("first run {:?}, second {:?}", runs[0], runs[1]));
        }
        self.verdict(
            "Mature: a target with learn: true learns nothing (the same target, fine_moves: 0, from the same start pose is commanded the same way twice)",
            p,
        );

        // a new configuration outside Idle is refused, nothing changes
        let other = SessionConfig {
            seed: session.seed.wrapping_add(1),
            ..session
        };
        self.send(other.into())?;
        let j = self.collect(Self::error_seen(codes::CONFIG_REJECTED), true)?;
        let mut p: Vec<String> = missing_error(
            &j,
            codes::CONFIG_REJECTED,
            codes::CONFIG_NOT_IDLE,
            "CONFIG_REJECTED (not idle)",
        )
        .into_iter()
        .collect();
        if echoed(&j) {
            p.push("the new configuration was acknowledged".into());
        }
        self.verdict(
            "A SessionConfig outside Idle is refused (CONFIG_REJECTED, detail 1) and not acknowledged",
            p,
        );

        // a repeat of the configuration in force is acknowledged in any mode (a lost echo)
        self.send(session.into())?;
        let echo = move |j: &[Envelope]| j.iter().any(|e| e.msg == Message::SessionConfig(session));
        let j = self.collect(echo, true)?;
        let mut p = Vec::new();
        if !echo(&j) {
            p.push("no echo of the configuration in force".into());
        }
        if !errors(&j).is_empty() {
            p.push(format!("errors {:?}", errors(&j)));
        }
        self.verdict(
            "A repeat of the SessionConfig in force outside Idle (Mature) is acknowledged again, not refused",
            p,
        );
        Ok(())
    }

    /// The start of the finished grasp `trial` (target `t`) repeated: its reports and one
    /// close again, no move (version 4).
    fn repeated_grasp(&mut self, trial: u32, t: &Target) -> Result<()> {
        if self.v4_only(REPEATED_GRASP) {
            return Ok(());
        }
        self.send(GraspRequest { trial }.into())?;
        self.send(stage1(trial, t, 1, true).into())?;
        self.send(stage2(trial, t, 1, true).into())?;
        let closed = |j: &[Envelope]| !gripper_commands(j).is_empty();
        let j = self.collect(closed, true)?;
        let mut p = nothing_moved(&j);
        let closes = gripper_commands(&j).iter().filter(|c| c.1).count();
        if closes != 1 {
            p.push(format!("{closes} closes, expected one"));
        }
        let stages: Vec<u8> = reports(&j).iter().map(|r| r.stage).collect();
        if stages != [1, 2] {
            p.push(format!("reports {:?}, expected both again", reports(&j)));
        }
        self.verdict(REPEATED_GRASP, p);

        Ok(())
    }
}
