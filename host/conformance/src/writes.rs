//! After the guard's checks, in `Idle` (SPEC 3.2, 3.4, 3.5, 3.7): an end with no write
//! staged is refused; a write's begin into learned tables without a nonce is refused; a write
//! begun with the guard's nonce is acknowledged chunk by chunk, an out-of-order chunk answered
//! with the chunk expected, an end with another CRC refused and an early end answered with
//! the chunk expected, and none of it changes the tables (the write is never completed);
//! `keep_tables = true` is refused under another configuration and accepted under the
//! tables' own (the two checks a version-3 controller gets too). Not applicable to a
//! controller that ended its loop at `Idle` (3.1).

use embedded_can::blocking::Can;
use trn_node::codes::{self, table_op, table_reason};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, ChunkData, Envelope, GuardOp, GuardRequest, Message, SessionConfig, TableWriteAck,
    TableWriteBegin, TableWriteChunk, TableWriteEnd, TablesEvent, TablesStatus,
};

use super::{nothing_moved, Suite};
use trn_bench::journal::{echoed, errors, missing_error, refused_unacknowledged};
use trn_bench::Result;

/// The checks of this part, in order.
const CHECKS: [&str; 5] = [
    "TableWriteEnd with no write staged is refused (TABLES_FAILED 0x0405)",
    "TableWriteBegin into learned tables without a nonce is refused (GUARD_REFUSED 0x201; TABLES_FAILED 0x0201 without TRN tables, 0x0202 without a store) and stages nothing",
    "A write begun with GuardNonce{TableWrite}: TableWriteAck{next: 0, image_crc}, chunk 0 acknowledged with next 1, an out-of-order chunk and an early TableWriteEnd answered with next 1, an end with another CRC refused (0x0405); the tables unchanged",
    "SessionConfig{keep_tables: true} of another configuration is refused (CONFIG_REJECTED 2) and not acknowledged",
    "SessionConfig{keep_tables: true} of the tables' own configuration is acknowledged",
];

/// The CRC the suite's staged write announces (its image is never completed).
const CRC: u32 = 0x5EED_C0DE;

fn acks(j: &[Envelope]) -> Vec<TableWriteAck> {
    j.iter()
        .filter_map(|e| match e.msg {
            Message::TableWriteAck(a) => Some(a),
            _ => None,
        })
        .collect()
}

fn applied(j: &[Envelope]) -> bool {
    j.iter()
        .any(|e| matches!(e.msg, Message::TablesStatus(s) if s.event == TablesEvent::Applied))
}

/// What must not change: the tables' steps, fingerprint, image and stored copy.
fn held(s: &TablesStatus) -> (u32, u32, u32, u32, u32) {
    (
        s.steps1,
        s.steps2,
        s.fingerprint,
        s.image_len,
        s.stored_sequence,
    )
}

impl<P> Suite<'_, P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    fn skip_writes(&mut self, first: usize, why: &str) {
        self.skip_each(&CHECKS[first..], why);
    }

    /// An answer to `msg` (an ack, an error, a status), then quiet: what came.
    fn answer(&mut self, msg: Message) -> Result<Vec<Envelope>> {
        self.send(msg)?;
        let done = |j: &[Envelope]| {
            !acks(j).is_empty()
                || !errors(j).is_empty()
                || j.iter().any(|e| matches!(e.msg, Message::TablesStatus(_)))
        };
        self.collect(done, true)
    }

    /// The checks of this part (see the module); `session` is the suite's configuration.
    pub(super) fn writes(&mut self, session: SessionConfig) -> Result<()> {
        if !self.still_running()? {
            self.skip_writes(0, "not applicable: the controller ended its loop at ModeChange{Idle} (SPEC 3.1 allows it)");
            return Ok(());
        }
        if self.v3 {
            // version 3 has `keep_tables` and detail 2, not the writes
            self.skip_each(&CHECKS[..3], super::V4_ONLY);
            return self.keep(session, None);
        }
        let Some(before) = self.status_now()? else {
            self.skip_writes(0, "not run: no answer to StoreCommand{Status}");
            return Ok(());
        };
        let no_tables = before.image_len == 0;
        let learned = before.steps1 > 0 || before.steps2 > 0;

        // 1. an end without a begin
        let j = self.answer(TableWriteEnd { image_crc: CRC }.into())?;
        let mut p = nothing_moved(&j);
        let not_started = table_op::APPLY << 8 | table_reason::NOT_STARTED;
        p.extend(missing_error(
            &j,
            codes::TABLES_FAILED,
            not_started,
            "TABLES_FAILED (no write)",
        ));
        if applied(&j) {
            p.push("an image was applied".into());
        }
        self.verdict(CHECKS[0], p);

        // 2. a begin without a nonce
        let begin = |nonce| TableWriteBegin {
            nonce,
            image_len: before.image_len,
            image_crc: CRC,
            fingerprint: before.fingerprint,
        };
        let begin_failed = |reason| (codes::TABLES_FAILED, table_op::WRITE_BEGIN << 8 | reason);
        let mut no_store = false;
        if no_tables || learned {
            let j = self.answer(begin(0).into())?;
            let mut p = nothing_moved(&j);
            let refusal = errors(&j).first().map(|e| (e.code, e.detail));
            no_store = refusal == Some(begin_failed(table_reason::NO_STORE));
            let allowed = if no_tables {
                vec![begin_failed(table_reason::NO_TABLES)]
            } else {
                vec![
                    (codes::GUARD_REFUSED, 0x201),
                    begin_failed(table_reason::NO_STORE),
                ]
            };
            if !refusal.is_some_and(|r| allowed.contains(&r)) {
                p.push(format!(
                    "errors {:?}, expected one of {allowed:#x?}",
                    errors(&j)
                ));
            }
            if !acks(&j).is_empty() {
                p.push(format!("a write was staged: {:?}", acks(&j)));
            }
            self.verdict(CHECKS[1], p);
        } else {
            self.skip(
                CHECKS[1],
                "not applicable: its tables never learned (a write needs no nonce then)",
            );
        }

        // 3. a write begun, never completed
        if no_tables || no_store {
            let why = if no_tables {
                "not applicable: it holds no TRN tables (its status gave an image of 0 bytes)"
            } else {
                "not applicable: it has no store to stage a write in"
            };
            self.skip(CHECKS[2], why);
        } else {
            let p = self.staged_write(begin, learned, &before)?;
            self.verdict(CHECKS[2], p);
        }

        self.keep(session, Some(before))
    }

    /// `keep_tables = true` under another configuration, then under the tables' own (their
    /// status `before`, when the controller gives one, unchanged): checks 4 and 5.
    fn keep(&mut self, session: SessionConfig, before: Option<TablesStatus>) -> Result<()> {
        let other = SessionConfig {
            preset: if session.preset == 0 { 1 } else { 0 },
            keep_tables: true,
            ..session
        };
        let j = self.exchange(other.into(), Self::error_seen(codes::CONFIG_REJECTED))?;
        let p = refused_unacknowledged(
            &j,
            codes::CONFIG_REJECTED,
            codes::CONFIG_MISMATCH,
            "CONFIG_REJECTED (learned under another configuration)",
        );
        self.verdict(CHECKS[3], p);
        let own = SessionConfig {
            keep_tables: true,
            ..session
        };
        let j = self.exchange(own.into(), |j| echoed(j) || !errors(j).is_empty())?;
        let mut p = Vec::new();
        if !j.iter().any(|e| e.msg == Message::SessionConfig(own)) {
            p.push(format!("errors {:?}, expected the echo", errors(&j)));
        }
        if let Some(before) = before {
            p.extend(self.tables_changed(&before)?);
        }
        self.verdict(CHECKS[4], p);
        Ok(())
    }

    /// A write begun (with the guard's nonce when the tables learned) and left staged: the
    /// problems.
    fn staged_write(
        &mut self,
        begin: impl Fn(u32) -> TableWriteBegin,
        learned: bool,
        before: &TablesStatus,
    ) -> Result<Vec<String>> {
        let mut p = Vec::new();
        let nonce = if learned {
            let op = GuardOp::TableWrite;
            let j = self.answer_nonce(op)?;
            match j {
                Some(n) => n,
                None => {
                    p.push("no GuardNonce{TableWrite} came".into());
                    return Ok(p);
                }
            }
        } else {
            0
        };
        let expect = |p: &mut Vec<String>, what: &str, j: &[Envelope], next: u16| {
            let want = TableWriteAck {
                next,
                image_crc: CRC,
            };
            if acks(j) != [want] {
                p.push(format!(
                    "{what}: acks {:?}, errors {:?}, expected {want:?}",
                    acks(j),
                    errors(j)
                ));
            }
        };
        let j = self.answer(begin(nonce).into())?;
        expect(&mut p, "the begin", &j, 0);
        let chunk = |index| TableWriteChunk {
            index,
            data: ChunkData::new(&[]),
        };
        let j = self.answer(chunk(0).into())?;
        expect(&mut p, "chunk 0", &j, 1);
        let j = self.answer(chunk(2).into())?;
        expect(&mut p, "chunk 2 out of order", &j, 1);
        let j = self.answer(TableWriteEnd { image_crc: !CRC }.into())?;
        let not_started = table_op::APPLY << 8 | table_reason::NOT_STARTED;
        p.extend(missing_error(
            &j,
            codes::TABLES_FAILED,
            not_started,
            "TABLES_FAILED 0x0405 (another CRC)",
        ));
        let j = self.answer(TableWriteEnd { image_crc: CRC }.into())?;
        expect(&mut p, "the end before every chunk came", &j, 1);
        if applied(&j) {
            p.push("an incomplete image was applied".into());
        }
        p.extend(self.tables_changed(before)?);
        Ok(p)
    }

    /// The problem when the tables the controller holds now (its status) are not those of
    /// `before`.
    fn tables_changed(&mut self, before: &TablesStatus) -> Result<Option<String>> {
        Ok(match self.status_now()? {
            Some(s) if held(&s) == held(before) => None,
            other => Some(format!(
                "status before {before:?}, after {other:?}: expected the same tables"
            )),
        })
    }

    /// A nonce for `op`, if one came.
    fn answer_nonce(&mut self, op: GuardOp) -> Result<Option<u32>> {
        self.send(GuardRequest { op }.into())?;
        let nonce = |j: &[Envelope]| {
            j.iter().find_map(|e| match e.msg {
                Message::GuardNonce(n) if n.op == op && n.nonce != 0 => Some(n.nonce),
                _ => None,
            })
        };
        let j = self.collect(|j| nonce(j).is_some() || !errors(j).is_empty(), false)?;
        Ok(nonce(&j))
    }
}
