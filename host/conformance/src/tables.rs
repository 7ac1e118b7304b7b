//! The tables and the configuration's law (SPEC 3.2, 3.5, 3.6 item 3, 3.7): the tables' status
//! is answered, chunk 0 of the image starts with the checkpoint's magic, a save is answered,
//! an erase without a nonce is refused, a law the controller does not run is refused as valid
//! but unsupported.

use embedded_can::blocking::Can;
use trn_node::codes::{self, table_op, table_reason};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, Envelope, ErrorReport, Message, SessionConfig, StoreCommand, StoreOp,
    TableReadRequest, TablesEvent,
};

use super::{nothing_moved, Suite};
use trn_bench::journal::{errors, missing_error, refused_unacknowledged};
use trn_bench::Result;

const SAVE_CHECK: &str = "StoreCommand{Save} is answered: TablesStatus{Saved}, or TABLES_FAILED 0x0501 without TRN tables, 0x0502 without a store; no move";
const ERASE_CHECK: &str = "StoreCommand{Erase} without a nonce is refused (GUARD_REFUSED 0x301, or TABLES_FAILED 0x0601 without TRN tables, 0x0602 without a store) and erases nothing";
const STATUS_CHECK: &str = "StoreCommand{Status} is answered with TablesStatus{Status} (image length, learning steps, fingerprint)";
const CHUNK_CHECK: &str =
    "TableReadRequest{0} is answered with chunk 0 of the checkpoint image, starting with TRNC";
const LAW_CHECK: &str = "A SessionConfig of a law it does not run is refused (CONFIG_REJECTED, detail 4) and not acknowledged";

/// The `TablesStatus` messages in a journal.
fn statuses(j: &[Envelope]) -> Vec<trn_protocol::TablesStatus> {
    j.iter()
        .filter_map(|e| match e.msg {
            Message::TablesStatus(s) => Some(s),
            _ => None,
        })
        .collect()
}

impl<P> Suite<'_, P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    /// `StoreCommand{Status}` is answered with `TablesStatus{Status}`.
    pub(super) fn store_status(&mut self) -> Result<()> {
        if self.v4_only(STATUS_CHECK) {
            return Ok(());
        }
        let ask = StoreCommand {
            op: StoreOp::Status,
            nonce: 0,
        };
        self.send(ask.into())?;
        let answered = |j: &[Envelope]| statuses(j).iter().any(|s| s.event == TablesEvent::Status);
        let j = self.collect(answered, false)?;
        let status = statuses(&j)
            .into_iter()
            .find(|s| s.event == TablesEvent::Status);
        self.status = status;
        let p = match status {
            Some(_) => vec![],
            None => vec![format!(
                "statuses {:?}, expected TablesStatus{{event: Status}}",
                statuses(&j)
            )],
        };
        self.verdict(STATUS_CHECK, p);
        Ok(())
    }

    /// A configuration of a law the controller does not run (the oracle on a copy of the
    /// simulated plant: no controller on a bus has that plant) is refused with
    /// `CONFIG_REJECTED` detail 4 and not acknowledged. Sent first, in `Idle`, on tables that
    /// never learned (so that no other refusal comes first).
    pub(super) fn unsupported_law(&mut self, session: SessionConfig) -> Result<()> {
        if self.v4_only(LAW_CHECK) {
            return Ok(());
        }
        let law = if session.law == 3 { 2 } else { 3 };
        let other = SessionConfig {
            law,
            keep_tables: false,
            ..session
        };
        self.send(other.into())?;
        let j = self.collect(Self::error_seen(codes::CONFIG_REJECTED), true)?;
        let p = refused_unacknowledged(
            &j,
            codes::CONFIG_REJECTED,
            codes::CONFIG_UNSUPPORTED,
            "CONFIG_REJECTED (valid but unsupported)",
        );
        self.verdict(
            &format!("A SessionConfig of a law it does not run (law {law}) is refused (CONFIG_REJECTED, detail 4) and not acknowledged"),
            p,
        );
        Ok(())
    }

    /// Chunk 0 of the image read out starts with the magic `TRNC` (a controller without
    /// TRN tables, whose status gives an image of 0 bytes, answers `TABLES_FAILED`, no
    /// tables). Asked between trials, in `Mature`.
    pub(super) fn chunk_zero(&mut self) -> Result<()> {
        if self.v4_only(CHUNK_CHECK) {
            return Ok(());
        }
        self.send(TableReadRequest { index: 0 }.into())?;
        let done = |j: &[Envelope]| {
            j.iter()
                .any(|e| matches!(e.msg, Message::TableReadChunk(_)))
                || errors(j).iter().any(|e| e.code == codes::TABLES_FAILED)
        };
        let j = self.collect(done, false)?;
        let chunk = j.iter().find_map(|e| match e.msg {
            Message::TableReadChunk(c) => Some(c),
            _ => None,
        });
        let no_tables = self.status.is_some_and(|s| s.image_len == 0);
        let mut p = nothing_moved(&j);
        match (no_tables, chunk) {
            (false, Some(c)) if c.index == 0 && c.data.bytes()[..4] == *b"TRNC" => {}
            (false, other) => p.push(format!(
                "chunk {other:?}, errors {:?}: expected TableReadChunk{{index: 0}} starting with TRNC",
                errors(&j)
            )),
            (true, _) => {
                let reason = trn_node::codes::table_op::READ << 8 | table_reason::NO_TABLES;
                p.extend(missing_error(
                    &j,
                    codes::TABLES_FAILED,
                    reason,
                    "TABLES_FAILED (no TRN tables)",
                ));
            }
        }
        self.verdict(CHUNK_CHECK, p);
        Ok(())
    }

    /// `StoreCommand{Save}` is answered (SPEC 3.7): `TablesStatus{Saved}` by a controller that
    /// keeps its TRN tables in a store, `TABLES_FAILED` 0x0501 by one without TRN tables (its
    /// status gave an image of 0 bytes), 0x0502 by one with tables but no store; nothing
    /// moves. Asked between trials, in `Mature`.
    pub(super) fn save(&mut self) -> Result<()> {
        if self.v4_only(SAVE_CHECK) {
            return Ok(());
        }
        let ask = StoreCommand {
            op: StoreOp::Save,
            nonce: 0,
        };
        self.send(ask.into())?;
        let save_failed = |e: &ErrorReport| {
            e.code == codes::TABLES_FAILED && (e.detail >> 8) & 0xFF == table_op::SAVE
        };
        let saved = |j: &[Envelope]| statuses(j).iter().any(|s| s.event == TablesEvent::Saved);
        let done = |j: &[Envelope]| saved(j) || errors(j).iter().any(save_failed);
        let j = self.collect(done, false)?;
        let mut p = nothing_moved(&j);
        let failure = errors(&j).into_iter().find(save_failed).map(|e| e.detail);
        let no_tables = self.status.is_some_and(|s| s.image_len == 0);
        let (no_tables_detail, no_store_detail) = (
            table_op::SAVE << 8 | table_reason::NO_TABLES,
            table_op::SAVE << 8 | table_reason::NO_STORE,
        );
        match (saved(&j), failure) {
            (true, None) if !no_tables => {}
            (false, Some(d)) if no_tables && d == no_tables_detail => {}
            (false, Some(d)) if !no_tables && d == no_store_detail => {}
            (got, detail) => p.push(format!(
                "saved {got}, TABLES_FAILED {detail:#06x?}: expected {}",
                if no_tables {
                    "TABLES_FAILED 0x0501 (no TRN tables: its status gave an image of 0 bytes)"
                } else {
                    "TablesStatus{Saved}, or TABLES_FAILED 0x0502 without a store"
                }
            )),
        }
        self.verdict(SAVE_CHECK, p);
        Ok(())
    }

    /// The tables' status now (`StoreCommand{Status}` answered), if it came.
    pub(super) fn status_now(&mut self) -> Result<Option<trn_protocol::TablesStatus>> {
        let ask = StoreCommand {
            op: StoreOp::Status,
            nonce: 0,
        };
        self.send(ask.into())?;
        let status = |j: &[Envelope]| {
            statuses(j)
                .into_iter()
                .find(|s| s.event == TablesEvent::Status)
        };
        let j = self.collect(|j| status(j).is_some(), false)?;
        Ok(status(&j))
    }

    /// `StoreCommand{Erase}` without a nonce is refused and erases nothing (SPEC 3.4, 3.7):
    /// `GUARD_REFUSED` 0x301 (the erase is guarded always, and its op in the detail is 3), or
    /// first `TABLES_FAILED` 0x0601 without TRN tables, 0x0602 without a store; the stored
    /// copy's sequence is the same before and after, no `TablesStatus{Erased}`, no move.
    pub(super) fn erase_without_nonce(&mut self) -> Result<()> {
        if self.v4_only(ERASE_CHECK) {
            return Ok(());
        }
        let before = self.status_now()?;
        let ask = StoreCommand {
            op: StoreOp::Erase,
            nonce: 0,
        };
        self.send(ask.into())?;
        let refused = |e: &ErrorReport| {
            e.code == codes::GUARD_REFUSED
                || (e.code == codes::TABLES_FAILED && (e.detail >> 8) & 0xFF == table_op::ERASE)
        };
        let j = self.collect(|j| errors(j).iter().any(refused), true)?;
        let mut p = nothing_moved(&j);
        let refusal = errors(&j).into_iter().find(refused);
        let no_tables = self.status.is_some_and(|s| s.image_len == 0);
        let erase = |reason| (codes::TABLES_FAILED, table_op::ERASE << 8 | reason);
        let allowed = if no_tables {
            vec![erase(table_reason::NO_TABLES)]
        } else {
            vec![(codes::GUARD_REFUSED, 0x301), erase(table_reason::NO_STORE)]
        };
        match refusal {
            Some(e) if allowed.contains(&(e.code, e.detail)) => {}
            other => p.push(format!(
                "refusal {other:?}: expected {}",
                if no_tables {
                    "TABLES_FAILED 0x0601 (no TRN tables: its status gave an image of 0 bytes)"
                } else {
                    "GUARD_REFUSED 0x301 (erase, no nonce), or TABLES_FAILED 0x0602 without a store"
                }
            )),
        }
        if statuses(&j).iter().any(|s| s.event == TablesEvent::Erased) {
            p.push("the stored copy was erased".into());
        }
        let after = self.status_now()?;
        match (before, after) {
            (Some(b), Some(a)) if a.stored_sequence == b.stored_sequence => {}
            (b, a) => p.push(format!(
                "stored copy before {:?}, after {:?}: expected the same",
                b.map(|s| s.stored_sequence),
                a.map(|s| s.stored_sequence)
            )),
        }
        self.verdict(ERASE_CHECK, p);
        Ok(())
    }
}
