//! The tables and the configuration's law (SPEC 3.2, 3.5, 3.6 item 3): the tables' status is
//! answered, chunk 0 of the image starts with the checkpoint's magic, a law the controller
//! does not run is refused as valid but unsupported.

use embedded_can::blocking::Can;
use trn_node::codes::{self, table_reason};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, Envelope, Message, SessionConfig, StoreCommand, StoreOp, TableReadRequest,
    TablesEvent,
};

use super::journal::{echoed, errors, missing_error};
use super::{nothing_moved, Suite};
use crate::error::Result;

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
        let mut p: Vec<String> = missing_error(
            &j,
            codes::CONFIG_REJECTED,
            codes::CONFIG_UNSUPPORTED,
            "CONFIG_REJECTED (valid but unsupported)",
        )
        .into_iter()
        .collect();
        if echoed(&j) {
            p.push("the configuration was acknowledged".into());
        }
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
}
