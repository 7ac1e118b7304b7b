//! After the session (SPEC 3.1, 3.4): the controller's tables learned in it, and no
//! configuration is in force after `ModeChange{Idle}`, so trials are refused; a re-seed
//! without a nonce is refused, and so is a wrong, a stale and a replayed nonce; a fresh one
//! is accepted, a nonce of another operation is refused. Not applicable to a controller that
//! ended its loop at `Idle` (3.1 allows it). On tables that never learn (a law that does not
//! train, 3.6 item 13) the guard has nothing to protect: it still answers `GuardRequest`,
//! and a re-seed needs no nonce (3.4), which the last check checks instead.

use std::time::Duration;

use embedded_can::blocking::Can;
use trn_node::codes;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, ConfirmedSessionConfig, Envelope, GuardNonce, GuardOp, GuardRequest, Message, Mode,
    SessionConfig, StoreCommand, StoreOp, TablesEvent,
};

use super::{refused_start, stage1, Suite};
use trn_bench::journal::{echoed, errors, missing_error, refused_unacknowledged, reports};
use trn_bench::{LabError, Result};

/// The checks of this part, in order (reported as not applicable together).
const CHECKS: [&str; 10] = [
    "After ModeChange{Idle}, a target on tables that learned gives SESSION_REQUIRED and starts nothing",
    "A re-seed of learned tables without a nonce (SessionConfig, keep_tables: false) is refused (GUARD_REFUSED 0x101) and not acknowledged",
    "After the refused re-seed, a target gives SESSION_REQUIRED and starts nothing",
    "GuardRequest{Reseed} is answered with GuardNonce{Reseed} and a non-zero nonce",
    "A wrong nonce is refused (GUARD_REFUSED 0x104) and not acknowledged",
    "A nonce of another operation (GuardNonce{TableWrite}) presented with a re-seed is refused (GUARD_REFUSED 0x104, the re-seed's op) and not acknowledged",
    "A stale nonce (presented after its window, counted in the controller's heartbeats) is refused (GUARD_REFUSED 0x102) and not acknowledged",
    "A fresh nonce is accepted: ConfirmedSessionConfig acknowledged with its SessionConfig",
    "A replayed confirmation (its nonce used, the tables learned again) is refused (GUARD_REFUSED 0x103) and not acknowledged",
    "On tables that never learn (a law that does not train), GuardRequest{Reseed} is answered (GuardNonce{Reseed} or GUARD_REFUSED 0x105) and a re-seed without a nonce is acknowledged",
];

/// The checks of learned tables (all but the last).
const LEARNED: usize = CHECKS.len() - 1;

fn heartbeats(j: &[Envelope]) -> usize {
    j.iter()
        .filter(|e| matches!(e.msg, Message::Heartbeat(_)))
        .count()
}

fn nonce_of(j: &[Envelope]) -> Option<GuardNonce> {
    j.iter().find_map(|e| match e.msg {
        Message::GuardNonce(n) => Some(n),
        _ => None,
    })
}

impl<P> Suite<'_, P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    /// Skips the checks of learned tables from `first` on.
    fn skip_from(&mut self, first: usize, why: &str) {
        self.skip_each(&CHECKS[first..LEARNED], why);
    }

    /// True while the controller still beats after `Idle`; false when it went silent (it
    /// ended its loop).
    pub(super) fn still_running(&mut self) -> Result<bool> {
        let silence = self.runner.timing().silence;
        let until = self.runner.rig().now() + self.patience.alive.max(Duration::from_millis(300));
        let j = self.runner.rig_mut().take_journal();
        self.all.extend_from_slice(&j);
        loop {
            if heartbeats(self.runner.rig().journal()) > 0 {
                let j = self.runner.rig_mut().take_journal();
                self.all.extend_from_slice(&j);
                return Ok(true);
            }
            let left = until.saturating_sub(self.runner.rig().now());
            if left.is_zero() {
                return Ok(false);
            }
            match self.runner.rig_mut().next_event(left, silence) {
                Ok(_) => {}
                Err(LabError::BusSilent(_)) => return Ok(false),
                Err(LabError::Transport(trn_transport::TransportError::Bus(
                    trn_protocol::Error::Io(std::io::ErrorKind::UnexpectedEof),
                ))) => return Ok(false),
                Err(e) => return Err(e),
            }
        }
    }

    /// Sends `msg`; what came until `done`, then quiet.
    pub(super) fn exchange(
        &mut self,
        msg: Message,
        done: impl Fn(&[Envelope]) -> bool,
    ) -> Result<Vec<Envelope>> {
        self.send(msg)?;
        self.collect(done, true)
    }

    /// A target refused with `SESSION_REQUIRED`: the problems.
    fn refused_target(&mut self) -> Result<Vec<String>> {
        let t = self.target(false, 5)?;
        let trial = self.next_trial();
        let j = self.exchange(
            stage1(trial, &t, 0, false).into(),
            Self::error_seen(codes::SESSION_REQUIRED),
        )?;
        Ok(refused_start(
            &j,
            codes::SESSION_REQUIRED,
            trial,
            "SESSION_REQUIRED",
        ))
    }

    /// `confirmed` refused by the guard with `detail` and not acknowledged: the problems.
    fn refused_confirmation(
        &mut self,
        confirmed: ConfirmedSessionConfig,
        detail: u32,
    ) -> Result<Vec<String>> {
        let j = self.exchange(confirmed.into(), Self::error_seen(codes::GUARD_REFUSED))?;
        Ok(refused_unacknowledged(
            &j,
            codes::GUARD_REFUSED,
            detail,
            "GUARD_REFUSED",
        ))
    }

    /// A nonce for a re-seed, or `None` (the problems said).
    fn reseed_nonce(&mut self) -> Result<(Option<GuardNonce>, Vec<String>, Vec<Envelope>)> {
        self.nonce_for(GuardOp::Reseed)
    }

    /// A nonce for `op`, or `None` (the problems said).
    fn nonce_for(
        &mut self,
        op: GuardOp,
    ) -> Result<(Option<GuardNonce>, Vec<String>, Vec<Envelope>)> {
        let answered = |j: &[Envelope]| {
            nonce_of(j).is_some() || errors(j).iter().any(|e| e.code == codes::GUARD_REFUSED)
        };
        let j = self.exchange(GuardRequest { op }.into(), answered)?;
        Ok(match nonce_of(&j) {
            Some(n) if n.op == op && n.nonce != 0 => (Some(n), vec![], j),
            other => (
                None,
                vec![format!("nonce {other:?}, errors {:?}", errors(&j))],
                j,
            ),
        })
    }

    /// The checks after the session's `Idle` (see the module); `session` is the suite's
    /// configuration, of which a re-seed with another seed is asked.
    pub(super) fn after_idle(&mut self, session: SessionConfig) -> Result<()> {
        if self.v3 {
            self.skip_each(&CHECKS, super::V4_ONLY);
            return Ok(());
        }
        if !self.still_running()? {
            self.skip_each(&CHECKS, "not applicable: the controller ended its loop at ModeChange{Idle} (SPEC 3.1 allows it)");
            return Ok(());
        }
        let ask = StoreCommand {
            op: StoreOp::Status,
            nonce: 0,
        };
        let done = |j: &[Envelope]| {
            j.iter().any(
                |e| matches!(e.msg, Message::TablesStatus(s) if s.event == TablesEvent::Status),
            )
        };
        let j = self.exchange(ask.into(), done)?;
        let learned = j.iter().any(|e| matches!(e.msg, Message::TablesStatus(s) if s.event == TablesEvent::Status && (s.steps1 > 0 || s.steps2 > 0)));
        if !learned {
            self.skip_from(0, "not applicable: its tables did not learn in the session (a law that does not train, SPEC 3.6 item 13)");
            return self.never_learned(session);
        }
        self.learned(session)?;
        self.skip(
            CHECKS[LEARNED],
            "not applicable: its tables learned (the checks before apply)",
        );
        Ok(())
    }

    /// The last check, on tables that never learn: the guard answers and a re-seed needs
    /// no nonce.
    fn never_learned(&mut self, session: SessionConfig) -> Result<()> {
        let (_, mut p, j) = self.reseed_nonce()?;
        if errors(&j)
            .iter()
            .any(|e| e.code == codes::GUARD_REFUSED && e.detail == 0x105)
        {
            p.clear();
        }
        let reseed = SessionConfig {
            seed: session.seed.wrapping_add(1),
            keep_tables: false,
            ..session
        };
        let j = self.exchange(reseed.into(), |j| echoed(j) || !errors(j).is_empty())?;
        if !j.iter().any(|e| e.msg == Message::SessionConfig(reseed)) {
            p.push(format!(
                "the re-seed without a nonce was not acknowledged: errors {:?}",
                errors(&j)
            ));
        }
        self.verdict(CHECKS[LEARNED], p);
        Ok(())
    }

    /// The checks of learned tables.
    fn learned(&mut self, session: SessionConfig) -> Result<()> {
        let p = self.refused_target()?;
        self.verdict(CHECKS[0], p);
        let reseed = SessionConfig {
            seed: session.seed.wrapping_add(1),
            keep_tables: false,
            ..session
        };
        let j = self.exchange(reseed.into(), Self::error_seen(codes::GUARD_REFUSED))?;
        let mut p: Vec<String> = missing_error(
            &j,
            codes::GUARD_REFUSED,
            0x101,
            "GUARD_REFUSED (re-seed, no nonce)",
        )
        .into_iter()
        .collect();
        if echoed(&j) {
            p.push("the re-seed was acknowledged".into());
        }
        self.verdict(CHECKS[1], p);
        let p = self.refused_target()?;
        self.verdict(CHECKS[2], p);

        let (n, p, j) = self.reseed_nonce()?;
        let Some(n) = n else {
            if errors(&j)
                .iter()
                .any(|e| e.code == codes::GUARD_REFUSED && e.detail == 0x105)
            {
                self.skip_from(3, "not applicable: it issues no nonces (GUARD_REFUSED reason 5: its generator is not seeded), so it never replaces learned tables over the bus");
            } else {
                self.verdict(CHECKS[3], p);
                self.skip_from(4, "not run: no nonce");
            }
            return Ok(());
        };
        self.verdict(CHECKS[3], vec![]);
        let wrong = if n.nonce == u32::MAX { 1 } else { n.nonce + 1 };
        let confirm = |nonce| ConfirmedSessionConfig {
            config: reseed,
            nonce,
        };
        let p = self.refused_confirmation(confirm(wrong), 0x104)?;
        self.verdict(CHECKS[4], p);

        // another operation's nonce: issued for a table write, presented with a re-seed
        // (the refusal names the re-seed's op, 1; SPEC 3.4, "Two numberings")
        let (n, mut p, _) = self.nonce_for(GuardOp::TableWrite)?;
        if let Some(n) = n {
            p.extend(self.refused_confirmation(confirm(n.nonce), 0x104)?);
        }
        self.verdict(CHECKS[5], p);

        // stale: presented after its window, measured in the controller's own heartbeats
        // (every 100 ms of its clock, SPEC 5), since its clock may run slower than ours
        let (n, mut p, _) = self.reseed_nonce()?;
        if let Some(n) = n {
            let beats = n.window_ms as usize / 100 + 2;
            let j = self.collect(|j| heartbeats(j) >= beats, false)?;
            if heartbeats(&j) < beats {
                p.push(format!(
                    "{} heartbeats while waiting for {beats}",
                    heartbeats(&j)
                ));
            }
            p.extend(self.refused_confirmation(confirm(n.nonce), 0x102)?);
        }
        self.verdict(CHECKS[6], p);

        let (n, mut p, _) = self.reseed_nonce()?;
        let fresh = n.map(|n| confirm(n.nonce));
        if let Some(c) = fresh {
            let j = self.exchange(c.into(), |j| echoed(j) || !errors(j).is_empty())?;
            let ok = j.iter().any(|e| e.msg == Message::SessionConfig(reseed));
            if !ok {
                p.push(format!(
                    "errors {:?}, expected the echo of its SessionConfig",
                    errors(&j)
                ));
            }
        }
        let accepted = p.is_empty();
        self.verdict(CHECKS[7], p);

        // the replay: the tables learn again in a session, which then ends; the same
        // confirmation comes back
        let Some(c) = fresh.filter(|_| accepted) else {
            self.skip_from(8, "not run: no confirmation was accepted");
            return Ok(());
        };
        let mut p = Vec::new();
        if let Err(e) = self.runner.mode(Mode::Training) {
            p.push(e.to_string());
        }
        let t = self.target(false, 5)?;
        let trial = self.next_trial();
        self.send(stage1(trial, &t, 0, false).into())?;
        let j = self.collect(Self::ended(trial, 1), false)?;
        if reports(&j).iter().all(|r| r.trial != trial) {
            p.push(format!(
                "the learning trial did not report: errors {:?}",
                errors(&j)
            ));
        }
        if let Err(e) = self.runner.mode(Mode::Idle) {
            p.push(e.to_string());
        }
        if p.is_empty() && !self.still_running()? {
            self.skip_from(8, "not applicable: the controller ended its loop at ModeChange{Idle} (SPEC 3.1 allows it)");
            return Ok(());
        }
        p.extend(self.refused_confirmation(c, 0x103)?);
        self.verdict(CHECKS[8], p);
        Ok(())
    }
}
