//! The node's tables over the bus and in their store (protocol/SPEC.md 3.5): the status,
//! saves (on a command, on entering `Mature`, every N learning steps; a save's steps run in
//! every turn, trials or not, and its store writes the tables only while the controller runs
//! no trial: a trial's start waits for a save in progress, up to
//! `NodeConfig::save_hold_ms`), erasing the stored copy, chunks of the checkpoint image read out from the
//! live tables, an image written in (staged in the store, verified and applied whole), the
//! announcement at boot. The node keeps a few dozen bytes of it, never the image.

use trn_controller::checkpoint::{self, ImageCursor, Provenance};
use trn_controller::persist::{SaveError, StoredCopy};
use trn_controller::Control;
use trn_protocol::{
    ChunkData, GuardOp, Mode, NodeId, StoreCommand, StoreOp, TableReadChunk, TableReadRequest,
    TablesEvent, TablesStatus, CHUNK,
};

use super::{error, ControllerNode};
use crate::codes::{self, table_op, table_reason};
use crate::guard::op_code;
use crate::outbox::{push, Outbox};

mod write;

use write::Write;

/// Where the save stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Save {
    Idle,
    /// Due: begins at the next turn.
    Wanted,
    /// Steps run from `poll`.
    Running,
}

/// The node's state of its tables.
#[derive(Debug, Clone)]
pub(crate) struct TableState {
    /// The configuration fingerprint the tables were learned (or seeded) under, when the
    /// node knows it (seeded, restored, written in); otherwise the controller's.
    pub(crate) fingerprint: Option<u32>,
    /// The preset and ablation they were learned with (the checkpoint's provenance).
    pub(crate) provenance: Provenance,
    /// True when the tables may differ from the stored copy.
    pub(crate) dirty: bool,
    /// Learning steps (both stages) at the last save or restore.
    steps_at_save: u32,
    save: Save,
    /// True when the save was asked for (a command, entering `Mature`), not by steps.
    asked: bool,
    /// True when the learning steps make a save due (not only its erases).
    due: bool,
    write: Write,
    /// A status to announce at the next poll (at boot).
    announce: Option<TablesEvent>,
}

impl TableState {
    pub(crate) const fn new() -> TableState {
        TableState {
            fingerprint: None,
            provenance: Provenance::CUSTOM,
            dirty: true,
            steps_at_save: 0,
            save: Save::Idle,
            asked: false,
            due: false,
            write: Write::NONE,
            announce: None,
        }
    }
}

/// Learning steps of both stages, `None` for a controller without TRN tables.
pub(crate) fn steps<C: Control + ?Sized>(ctrl: &mut C) -> Option<(u32, u32)> {
    let t = ctrl.tables()?;
    Some((
        t.ctrl.stage1().learning_step(),
        t.ctrl.stage2().learning_step(),
    ))
}

/// True when the controller holds TRN tables that learned: what the guard protects.
pub(crate) fn learned<C: Control + ?Sized>(ctrl: &mut C) -> bool {
    steps(ctrl).is_some_and(|(a, b)| a > 0 || b > 0)
}

fn failed(out: &mut Outbox, op: u32, reason: u32, extra: u32) {
    error(
        out,
        codes::TABLES_FAILED,
        (extra & 0xFF) << 16 | op << 8 | reason,
    );
}

fn flash_or(reason: u32, code: u8) -> (u32, u32) {
    (reason, code as u32)
}

fn save_reason(e: SaveError) -> (u32, u32) {
    match e {
        SaveError::NotStarted => (table_reason::NOT_STARTED, 0),
        SaveError::TooLarge => (table_reason::OUT_OF_RANGE, 0),
        SaveError::Changed => (table_reason::CHANGED, 0),
        SaveError::Flash(c) => flash_or(table_reason::FLASH, c),
    }
}

impl ControllerNode {
    /// Tells the node what the embedding restored at boot (`None`: nothing, the tables are
    /// the reset ones): the node announces it with `TablesStatus{Restored | NotRestored}` at
    /// its next poll, and, when the restored tables learned, refuses trials until a session
    /// is configured (`SESSION_REQUIRED`).
    pub fn tables_restored<C: Control + ?Sized>(&mut self, ctrl: &mut C, copy: Option<StoredCopy>) {
        let t = &mut self.tables;
        match copy {
            Some(copy) => {
                t.fingerprint = Some(copy.fingerprint);
                t.provenance = copy.provenance;
                t.steps_at_save = copy.steps.0.wrapping_add(copy.steps.1);
                t.dirty = false;
                t.announce = Some(TablesEvent::Restored);
            }
            None => t.announce = Some(TablesEvent::NotRestored),
        }
        if learned(ctrl) {
            self.session_required = true;
        }
    }

    /// The fingerprint of the configuration the tables were learned under.
    pub(crate) fn tables_fingerprint<C: Control + ?Sized>(&self, ctrl: &C) -> u32 {
        self.tables
            .fingerprint
            .unwrap_or_else(|| ctrl.fingerprint())
    }

    /// The status of the tables and the stored copy.
    fn status<C: Control + ?Sized>(&self, ctrl: &mut C, event: TablesEvent) -> TablesStatus {
        let fingerprint = self.tables_fingerprint(ctrl);
        let provenance = self.tables.provenance;
        let (image_len, steps, stored) = match ctrl.tables() {
            Some(t) => {
                let len = ImageCursor::new(t.ctrl, provenance).len() as u32;
                let steps = (
                    t.ctrl.stage1().learning_step(),
                    t.ctrl.stage2().learning_step(),
                );
                let stored = t.store.and_then(|s| s.stored()).map_or(0, |c| c.sequence);
                (len, steps, stored)
            }
            None => (0, (0, 0), 0),
        };
        TablesStatus {
            event,
            image_len,
            fingerprint,
            steps1: steps.0,
            steps2: steps.1,
            stored_sequence: stored,
        }
    }

    fn push_status<C: Control + ?Sized>(&self, ctrl: &mut C, event: TablesEvent, out: &mut Outbox) {
        let s = self.status(ctrl, event);
        push(out, NodeId::Controller, s.into());
    }

    /// Tables changed (re-seeded, written in, a trial that learns began): a save in progress
    /// is abandoned; `resave` asks for it again once no learning trial runs.
    pub(crate) fn tables_changed<C: Control + ?Sized>(&mut self, ctrl: &mut C, resave: bool) {
        self.tables.dirty = true;
        if self.tables.save == Save::Running {
            if let Some(store) = ctrl.tables().and_then(|t| t.store) {
                store.save_cancel();
            }
            self.tables.save = if resave { Save::Wanted } else { Save::Idle };
            self.tables.asked &= resave;
        }
    }

    /// A save is due on entering `Mature` when the tables changed since the last one.
    pub(crate) fn entering_mode(&mut self, mode: Mode) {
        if mode == Mode::Mature && self.mode != Mode::Mature && self.tables.dirty {
            self.want_save();
            self.tables.asked = true;
        }
    }

    fn want_save(&mut self) {
        if self.tables.save == Save::Idle {
            self.tables.save = Save::Wanted;
        }
    }

    /// True when the save in progress may write the tables at the next gap between trials
    /// (asked for, or due by steps), not only erase ahead of its turn.
    fn save_ready(&self) -> bool {
        self.tables.asked || self.tables.due
    }

    /// True while a save that may write the tables runs (a trial's start waits for it).
    pub(crate) fn tables_saving(&self) -> bool {
        self.tables.save == Save::Running && self.save_ready()
    }

    /// True while the tables' part of `poll` has work for the very next turn: an
    /// announcement, or a save that is due or running and not held back (a save runs one
    /// small step a turn; during a trial its erases are polled at the trial's own turns, its
    /// frames and heartbeats; a staged image holds it back until a frame changes that).
    pub(crate) fn tables_want_a_turn(&self) -> bool {
        let held =
            self.trial.is_some() || self.tables.write.staging().is_some() || !self.save_ready();
        self.tables.announce.is_some() || (self.tables.save != Save::Idle && !held)
    }

    /// The tables' part of `poll`: the boot announcement, a save due by learning steps, one
    /// step of the save in progress.
    pub(crate) fn poll_tables<C: Control + ?Sized>(&mut self, ctrl: &mut C, out: &mut Outbox) {
        if let Some(event) = self.tables.announce.take() {
            self.push_status(ctrl, event, out);
        }
        // a controller without TRN tables or without a store saves nothing: no save is due
        let Some((s1, s2)) = steps(ctrl) else {
            self.tables.save = Save::Idle;
            return;
        };
        let Some(t) = ctrl.tables() else { return };
        let Some(store) = t.store else {
            self.tables.save = Save::Idle;
            return;
        };
        let since = s1.wrapping_add(s2).wrapping_sub(self.tables.steps_at_save);
        // the erases begin `save_lead_steps` before the save is due, during the trials (the
        // tables are not read); the tables are written once it is due, between trials
        let every = self.cfg.save_every_steps;
        self.tables.due = every != u32::MAX && since >= every;
        if every != u32::MAX && since.saturating_add(self.cfg.save_lead_steps) >= every {
            self.want_save();
        }
        // never while an image is staged in the slot a save would use; between trials only
        // when the save may write the tables
        if self.tables.write.staging().is_some() || (self.trial.is_none() && !self.save_ready()) {
            return;
        }
        let provenance = self.tables.provenance;
        let step = match self.tables.save {
            Save::Idle => return,
            Save::Wanted => store.save_begin(t.ctrl, provenance).map(|_| None),
            Save::Running => store.save_step(t.ctrl),
        };
        match step {
            Ok(None) => self.tables.save = Save::Running,
            Ok(Some(copy)) => {
                self.tables.save = Save::Idle;
                self.tables.asked = false;
                self.tables.dirty = false;
                self.tables.steps_at_save = copy.steps.0.wrapping_add(copy.steps.1);
                self.push_status(ctrl, TablesEvent::Saved, out);
            }
            Err(SaveError::Changed) => self.tables.save = Save::Wanted,
            Err(e) => {
                // reported once: a save by steps is tried again only after as many more
                self.tables.save = Save::Idle;
                self.tables.asked = false;
                self.tables.steps_at_save = s1.wrapping_add(s2);
                let (reason, extra) = save_reason(e);
                failed(out, table_op::SAVE, reason, extra);
            }
        }
    }

    /// `StoreCommand`: the status, a save now, or (guarded) erasing the stored copies.
    pub(crate) fn on_store_command<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        c: &StoreCommand,
        now_ms: u32,
        out: &mut Outbox,
    ) {
        let op = match c.op {
            StoreOp::Status => return self.push_status(ctrl, TablesEvent::Status, out),
            StoreOp::Save => table_op::SAVE,
            StoreOp::Erase => table_op::ERASE,
        };
        let Some(t) = ctrl.tables() else {
            return failed(out, op, table_reason::NO_TABLES, 0);
        };
        if t.store.is_none() {
            return failed(out, op, table_reason::NO_STORE, 0);
        }
        if c.op == StoreOp::Save {
            if self.tables.dirty || self.tables.save != Save::Idle {
                self.want_save();
                self.tables.asked = true;
            } else {
                // nothing changed since the last save: that copy is the answer
                self.push_status(ctrl, TablesEvent::Saved, out);
            }
            return;
        }
        if !self.guard_allows(GuardOp::StoreErase, c.nonce, now_ms, out) {
            return;
        }
        self.tables_changed(ctrl, false);
        let Some(store) = ctrl.tables().and_then(|t| t.store) else {
            return;
        };
        match store.erase() {
            Ok(()) => self.push_status(ctrl, TablesEvent::Erased, out),
            Err(trn_controller::persist::EraseError::Flash(code)) => {
                failed(out, table_op::ERASE, table_reason::FLASH, code as u32)
            }
        }
    }

    /// `TableReadRequest`: chunk `index` of the checkpoint image, from the live tables.
    /// Served between trials (a trial that learns would change the tables under a reader).
    pub(crate) fn on_read_request<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        r: &TableReadRequest,
        out: &mut Outbox,
    ) {
        let provenance = self.tables.provenance;
        let busy = self.trial.is_some();
        let Some(t) = ctrl.tables() else {
            return failed(out, table_op::READ, table_reason::NO_TABLES, 0);
        };
        if busy {
            return failed(out, table_op::READ, table_reason::BUSY, 0);
        }
        let mut bytes = [0u8; CHUNK];
        let offset = r.index as usize * CHUNK;
        if checkpoint::read_at(t.ctrl, provenance, offset, &mut bytes) == 0 {
            return failed(out, table_op::READ, table_reason::OUT_OF_RANGE, 0);
        }
        let chunk = TableReadChunk {
            index: r.index,
            data: ChunkData::new(&bytes),
        };
        push(out, NodeId::Controller, chunk.into());
    }

    /// Checks a destructive operation's nonce; a refusal is reported (`GUARD_REFUSED`).
    pub(crate) fn guard_allows(
        &mut self,
        op: GuardOp,
        nonce: u32,
        now_ms: u32,
        out: &mut Outbox,
    ) -> bool {
        let window = self.cfg.nonce_window_ms as u32;
        match self.guard.check(op, nonce, now_ms, window) {
            Ok(()) => true,
            Err(r) => {
                error(out, codes::GUARD_REFUSED, op_code(op) << 8 | r as u32);
                false
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The firmware's compact build has almost no RAM to spare: the node's state of its
    /// tables and of its guard stays a few dozen bytes (the image is never buffered).
    #[test]
    fn the_tables_and_guard_state_is_a_few_dozen_bytes() {
        let tables = core::mem::size_of::<TableState>();
        let guard = core::mem::size_of::<crate::guard::Guard>();
        println!("TableState {tables} B, Guard {guard} B");
        assert!(tables <= 40, "{tables}");
        assert!(guard <= 32, "{guard}");
    }
}
