//! An image of the tables written in over the bus: `TableWriteBegin` (guarded when the tables
//! learned), its chunks staged in the store in order, `TableWriteEnd` verifying the image and
//! applying it whole; each answered with the chunk expected next.

use trn_controller::checkpoint;
use trn_controller::persist::{ApplyError, Expected, StageError};
use trn_controller::Control;
use trn_protocol::{
    chunk_count, GuardOp, Mode, NodeId, TableWriteAck, TableWriteBegin, TableWriteChunk,
    TableWriteEnd, TablesEvent, CHUNK,
};

use super::{failed, flash_or, learned};
use crate::codes::{self, table_op, table_reason};
use crate::node::ControllerNode;
use crate::outbox::{push, Outbox};

/// An image written in: being staged, or applied (a repeated end is answered again).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Write {
    len: u32,
    crc: u32,
    fingerprint: u32,
    next: u16,
    state: WriteState,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum WriteState {
    None,
    Staging,
    Applied,
}

impl Write {
    pub(super) const NONE: Write = Write {
        len: 0,
        crc: 0,
        fingerprint: 0,
        next: 0,
        state: WriteState::None,
    };

    /// The transfer being staged, if any.
    pub(super) fn staging(&self) -> Option<Write> {
        (self.state == WriteState::Staging).then_some(*self)
    }
}

fn stage_reason(e: StageError) -> (u32, u32) {
    match e {
        StageError::NotStarted => (table_reason::NOT_STARTED, 0),
        StageError::TooLarge => (table_reason::OUT_OF_RANGE, 0),
        StageError::OutOfOrder => (table_reason::NOT_STARTED, 0),
        StageError::Flash(c) => flash_or(table_reason::FLASH, c),
    }
}

fn apply_reason(e: ApplyError) -> (u32, u32) {
    match e {
        ApplyError::Incomplete => (table_reason::INCOMPLETE, 0),
        ApplyError::Image(e) => {
            // the checkpoint refusal's number: the low byte of its CONTROLLER_ERROR code
            let code = codes::controller_error_code(&e);
            let which = if code >> 8 == 0xB { code & 0xFF } else { 0xFF };
            (table_reason::IMAGE, which)
        }
        ApplyError::CrcMismatch => (table_reason::CRC_MISMATCH, 0),
        ApplyError::FingerprintMismatch => (table_reason::FINGERPRINT_MISMATCH, 0),
        ApplyError::Busy => (table_reason::BUSY, 0),
        ApplyError::Flash(c) => flash_or(table_reason::FLASH, c),
    }
}

impl ControllerNode {
    fn ack(out: &mut Outbox, w: &Write) {
        let ack = TableWriteAck {
            next: w.next,
            image_crc: w.crc,
        };
        push(out, NodeId::Controller, ack.into());
    }

    /// `TableWriteBegin`: in `Idle` with no trial, on a node with a store; guarded when the
    /// tables learned. A repeat of the transfer in progress is acknowledged again.
    pub(crate) fn on_write_begin<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        b: &TableWriteBegin,
        now_ms: u32,
        out: &mut Outbox,
    ) {
        const OP: u32 = table_op::WRITE_BEGIN;
        if let Some(w) = self.tables.write.staging() {
            if (w.len, w.crc, w.fingerprint) == (b.image_len, b.image_crc, b.fingerprint) {
                return Self::ack(out, &w);
            }
        }
        let idle = self.mode == Mode::Idle && self.trial.is_none();
        let Some(t) = ctrl.tables() else {
            return failed(out, OP, table_reason::NO_TABLES, 0);
        };
        if t.store.is_none() {
            return failed(out, OP, table_reason::NO_STORE, 0);
        }
        if !idle {
            return failed(out, OP, table_reason::BUSY, 0);
        }
        let count = chunk_count(b.image_len);
        if b.image_len as usize > checkpoint::MAX_SIZE || count > u16::MAX as u32 {
            return failed(out, OP, table_reason::OUT_OF_RANGE, 0);
        }
        if learned(ctrl) && !self.guard_allows(GuardOp::TableWrite, b.nonce, now_ms, out) {
            return;
        }
        self.tables_changed(ctrl, false);
        let Some(store) = ctrl.tables().and_then(|t| t.store) else {
            return;
        };
        if let Err(e) = store.stage_begin(b.image_len) {
            let (reason, extra) = stage_reason(e);
            return failed(out, OP, reason, extra);
        }
        let w = Write {
            len: b.image_len,
            crc: b.image_crc,
            fingerprint: b.fingerprint,
            next: 0,
            state: WriteState::Staging,
        };
        self.tables.write = w;
        Self::ack(out, &w);
    }

    /// `TableWriteChunk`: the next chunk is staged; any other is answered with the chunk
    /// expected (a repeat, or after a lost one: the writer resumes there).
    pub(crate) fn on_write_chunk<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        c: &TableWriteChunk,
        out: &mut Outbox,
    ) {
        let Some(mut w) = self.tables.write.staging() else {
            self.stats.ignored += 1;
            return;
        };
        if c.index != w.next || w.next as u32 >= chunk_count(w.len) {
            return Self::ack(out, &w);
        }
        let offset = c.index as u32 * CHUNK as u32;
        let n = (w.len - offset).min(CHUNK as u32) as usize;
        let Some(store) = ctrl.tables().and_then(|t| t.store) else {
            return failed(out, table_op::WRITE_CHUNK, table_reason::NO_STORE, 0);
        };
        if let Err(e) = store.stage_write(offset, &c.data.bytes()[..n]) {
            self.tables.write = Write::NONE;
            let (reason, extra) = stage_reason(e);
            return failed(out, table_op::WRITE_CHUNK, reason, extra);
        }
        w.next += 1;
        self.tables.write = w;
        Self::ack(out, &w);
    }

    /// `TableWriteEnd`: every chunk came: the store verifies the image against what the begin
    /// announced and applies it; the tables then need a session (`keep_tables`) before
    /// trials. A repeat after it was applied is answered again.
    pub(crate) fn on_write_end<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        e: &TableWriteEnd,
        out: &mut Outbox,
    ) {
        const OP: u32 = table_op::APPLY;
        let w = self.tables.write;
        if w.crc != e.image_crc || w.state == WriteState::None {
            return failed(out, OP, table_reason::NOT_STARTED, 0);
        }
        if w.state == WriteState::Applied {
            return self.push_status(ctrl, TablesEvent::Applied, out);
        }
        if (w.next as u32) < chunk_count(w.len) {
            return Self::ack(out, &w);
        }
        self.tables.write = Write::NONE;
        let Some(t) = ctrl.tables() else {
            return failed(out, OP, table_reason::NO_TABLES, 0);
        };
        let Some(store) = t.store else {
            return failed(out, OP, table_reason::NO_STORE, 0);
        };
        let expected = Expected {
            crc: w.crc,
            fingerprint: w.fingerprint,
        };
        match store.stage_apply(t.ctrl, expected) {
            Ok(copy) => {
                let tables = &mut self.tables;
                tables.fingerprint = Some(copy.fingerprint);
                tables.provenance = copy.provenance;
                tables.steps_at_save = copy.steps.0.wrapping_add(copy.steps.1);
                tables.dirty = false;
                tables.write = Write {
                    state: WriteState::Applied,
                    ..w
                };
                // the tables are new: a session must say what they are before trials
                self.session = None;
                self.session_required = learned(ctrl);
                self.push_status(ctrl, TablesEvent::Applied, out);
            }
            Err(e) => {
                let (reason, extra) = apply_reason(e);
                failed(out, OP, reason, extra);
            }
        }
    }
}
